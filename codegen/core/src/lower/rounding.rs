//! Moving a value's binary point: exact left shifts, rounding right shifts (floor, or nearest
//! without an overflowing `x + 2^(n−1)`), rescaling to a format, and clamps (saturation).
//! Rounding happens only here, and each rounding adds its error to the value's bound.

use super::lir::{LStmt, Op, ValId};
use super::{err_bound, shl_exact, Lowerer, NewVal};
use crate::diag::{Diag, Result};
use crate::qformat::{pow2, IntTy, Rounding};
use proc_macro2::Span;

impl Lowerer<'_> {
    /// `v · 2^k` exactly, by a left shift. A constant is shifted at compile time, so no shift
    /// ever reaches its operand's width (a zero can take any binary point).
    pub(super) fn shl(
        &mut self,
        v: ValId,
        k: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        if k == 0 {
            return Ok(v);
        }
        let x = self.v(v).clone();
        let too_wide = || {
            Diag::new(span, "an intermediate needs more than 64 bits").help(
                "narrow the declared ranges, or pin coarser formats with `#[q(..)]` / `#[lsb(..)]`",
            )
        };
        let lo = shl_exact(x.lo, k as i32).ok_or_else(too_wide)?;
        let hi = shl_exact(x.hi, k as i32).ok_or_else(too_wide)?;
        let frac = x.frac + k as i32;
        if lo == hi {
            let ty = self.working(lo, lo, span)?;
            return Ok(self.push(NewVal::constant(lo, ty, frac, x.err), out));
        }
        let ty = self.working(lo.min(x.lo), hi.max(x.hi), span)?;
        let c = self.cast(v, ty, out);
        Ok(self.push(
            NewVal {
                op: Op::Shl(c, k),
                ty,
                frac,
                lo,
                hi,
                err: x.err,
            },
            out,
        ))
    }

    /// Drops `n` fraction bits with the program's rounding. Where the result can take only
    /// one value it is a constant, and a shift is never as wide as its operand: `floor` of a
    /// value in `[-2^(w-1), 2^(w-1))` shifted by `n ≥ w - 1` is its sign, `x >> (w - 1)`.
    pub(super) fn round(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        if n == 0 {
            return Ok(v);
        }
        if let Some(r) = self.round_then_clamp(v, n, span, out)? {
            return Ok(r);
        }
        let x = self.v(v).clone();
        let (lo, hi) = self.rounded(x.lo, x.hi, n);
        let frac = x.frac - n as i32;
        let added = self.rounding_added(x.frac, n);
        if lo == hi {
            let err = if x.lo == x.hi && n <= 126 {
                // A constant rounded at compile time: its exact rounding error, from the
                // integers (the difference of the two values in f64 would cancel).
                err_bound::magnitude(x.lo - (lo << n), x.frac)
            } else if x.lo == x.hi {
                // Rounded by more bits than an i128 shifts: at most one LSB of the result.
                pow2(-frac)
            } else {
                added
            };
            let ty = self.working(lo, lo, span)?;
            return Ok(self.push(
                NewVal::constant(lo, ty, frac, err_bound::add(x.err, err)),
                out,
            ));
        }
        let mut src = v;
        let mut x = x;
        if self.prog.rounding == Rounding::Nearest {
            let h = 1i128 << (n - 1);
            if IntTy::signed_for(x.lo, x.hi + h, 8).is_none() {
                return Ok(self.round_nearest_in_place(v, n, frac, added, out));
            }
            // The type holds the operand as well as the sum.
            let ty = self.working(x.lo, x.hi + h, span)?;
            let c = self.cast(src, ty, out);
            let hv = self.push(NewVal::constant(h, ty, x.frac, 0.0), out);
            src = self.push(
                NewVal {
                    op: Op::Add(c, hv),
                    ty,
                    frac: x.frac,
                    lo: x.lo + h,
                    hi: x.hi + h,
                    err: x.err,
                },
                out,
            );
            x = self.v(src).clone();
        }
        let k = n.min(x.ty.bits - 1);
        Ok(self.push(
            NewVal {
                op: Op::Shr(src, k),
                ty: x.ty,
                frac,
                lo,
                hi,
                err: err_bound::add(x.err, added),
            },
            out,
        ))
    }

    /// Nearest rounding of a full-width 64-bit value, where `x + 2^(n-1)` would overflow:
    /// `(x >> n) + b` with `b = (x >> (n-1)) − 2·(x >> n)`, bit `n − 1` of `x`. Equal to
    /// `(x + 2^(n-1)) >> n` (write `x = q·2^n + r`: both are `q + [r ≥ 2^(n-1)]`), and no
    /// intermediate is wider than `x`. `b ∈ {0, 1}` is a fact about the two shifts of one `x`
    /// that interval arithmetic cannot see, so it is marked claimed: the prover discharges it
    /// with a whole-step query.
    pub(super) fn round_nearest_in_place(
        &mut self,
        v: ValId,
        n: u32,
        frac: i32,
        added: f64,
        out: &mut Vec<LStmt>,
    ) -> ValId {
        let x = self.v(v).clone();
        let (ty, f) = (x.ty, x.frac);
        let q = self.push(
            NewVal {
                op: Op::Shr(v, n),
                ty,
                frac,
                lo: x.lo >> n,
                hi: x.hi >> n,
                err: x.err,
            },
            out,
        );
        let (ql, qh) = (x.lo >> n, x.hi >> n);
        let half = self.push(
            NewVal {
                op: Op::Shr(v, n - 1),
                ty,
                frac: f - n as i32 + 1,
                lo: x.lo >> (n - 1),
                hi: x.hi >> (n - 1),
                err: x.err,
            },
            out,
        );
        let twice = self.push(
            NewVal {
                op: Op::Shl(q, 1),
                ty,
                frac: f - n as i32 + 1,
                lo: 2 * ql,
                hi: 2 * qh,
                err: x.err,
            },
            out,
        );
        let bit = self.push(
            NewVal::exact(Op::Sub(half, twice), ty, f - n as i32 + 1, (0, 1)),
            out,
        );
        self.vals[bit.0].claimed = true;
        self.push(
            NewVal {
                op: Op::Add(q, bit),
                ty,
                frac,
                lo: ql,
                hi: qh + 1,
                err: err_bound::add(x.err, added),
            },
            out,
        )
    }

    /// The most one rounding of `n` bits adds to a value with `frac` fraction bits: floor drops
    /// up to 2^n − 1 source LSBs, nearest half of 2^n.
    fn rounding_added(&self, frac: i32, n: u32) -> f64 {
        let lsb_src = pow2(-frac);
        match self.prog.rounding {
            Rounding::Floor => (pow2(n as i32) - 1.0) * lsb_src,
            Rounding::Nearest => pow2(n as i32 - 1) * lsb_src,
        }
    }

    /// `round(clamp(x, LO, HI))` computed as `clamp(round(x), round(LO), round(HI))` (either
    /// bound alone too: `min`, `max` with a constant), where the rounded `x` fits a narrower
    /// word than the clamp: the comparisons then run in that word (on the Cortex-M4 a 64-bit
    /// bound is five instructions, a 32-bit one three; on the AVR a library call). The same
    /// value, error bound and interval: the program's rounding is a non-decreasing function
    /// `g`, and `g(clamp(x, LO, HI)) = clamp(g(x), g(LO), g(HI))` for every `x` (below `LO`,
    /// `g(x) ≤ g(LO)`; above `HI`, `g(x) ≥ g(HI)`). `None` where the pattern or the gain is
    /// absent, or `v` is a named or claimed value.
    fn round_then_clamp(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        let x = self.v(v).clone();
        if x.name.is_some() || x.claimed || x.boolean {
            return Ok(None);
        }
        let konst = |me: &Self, id: ValId| match me.v(id).op {
            Op::Const(c) => Some(c),
            _ => None,
        };
        // Through the widening casts `clamp` puts before each side.
        let strip = |me: &Self, mut id: ValId| {
            while let Op::Cast(a) = me.v(id).op {
                let w = me.v(id);
                let src = me.v(a);
                if w.name.is_some() || w.claimed || src.ty.bits > w.ty.bits || src.frac != w.frac {
                    break;
                }
                id = a;
            }
            id
        };
        let (mut lo, mut hi, mut cur) = (None, None, v);
        for _ in 0..2 {
            match self.v(cur).op {
                Op::Min(a, c) if hi.is_none() && konst(self, c).is_some() => {
                    hi = konst(self, c);
                    cur = strip(self, a);
                }
                Op::Max(a, c) if lo.is_none() && konst(self, c).is_some() => {
                    lo = konst(self, c);
                    cur = strip(self, a);
                }
                _ => break,
            }
        }
        if cur == v || self.v(cur).frac != x.frac || self.v(cur).boolean {
            return Ok(None);
        }
        let inner = self.v(cur).clone();
        let (rl, rh) = self.rounded(inner.lo, inner.hi, n);
        let narrower = IntTy::signed_for(rl, rh, self.target.min_work_bits())
            .is_some_and(|t| t.bits < x.ty.bits);
        if !narrower {
            return Ok(None);
        }
        let bound = |c: Option<i128>, none: i128| c.map_or(none, |c| self.rounded(c, c, n).0);
        let (bl, bh) = (bound(lo, i128::MIN), bound(hi, i128::MAX));
        // Each bound inside the rounded range (else the clamp's constant may not fit the
        // clamp's word, and the value is a constant anyway).
        if bl > bh || (lo.is_some() && bl > rh) || (hi.is_some() && bh < rl) {
            return Ok(None);
        }
        let first_new = self.vals.len();
        let r = self.round(cur, n, span, out)?;
        let mut r = self.clamp(r, bl, bh, out)?;
        // The error bound is the clamp's own, rounded: `x`'s bound can hold more than its
        // operand's (a table look-up's interpolation error is set on its final clamp).
        let err = err_bound::add(x.err, self.rounding_added(x.frac, n)).max(self.v(r).err);
        if self.v(r).err != err {
            if r.0 < first_new {
                // A value the statement computed before: a copy of it carries the bound.
                r = self.copy(r, err, out);
            } else {
                self.vals[r.0].err = err;
            }
        }
        let (want_lo, want_hi) = self.rounded(x.lo, x.hi, n);
        let got = self.v(r);
        debug_assert!(
            got.lo == want_lo && got.hi == want_hi,
            "round then clamp: [{}, {}] against [{want_lo}, {want_hi}]",
            got.lo,
            got.hi
        );
        if got.lo != want_lo || got.hi != want_hi {
            // Not expected (the identity holds for intervals too); keep the plain form.
            return Ok(None);
        }
        Ok(Some(r))
    }

    /// `v` re-expressed with `frac` fraction bits.
    pub(super) fn rescale(
        &mut self,
        v: ValId,
        frac: i32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let f = self.v(v).frac;
        if frac >= f {
            self.shl(v, (frac - f) as u32, span, out)
        } else {
            self.round(v, (f - frac) as u32, span, out)
        }
    }

    /// Saturates raw `v` into `[lo, hi]`, emitting only the sides the range analysis needs.
    pub(super) fn clamp(
        &mut self,
        v: ValId,
        lo: i128,
        hi: i128,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let mut cur = v;
        let x = self.v(v).clone();
        let tl = if x.lo < lo { x.lo.min(lo) } else { x.lo };
        let th = if x.hi > hi { x.hi.max(hi) } else { x.hi };
        let ty = self.working(tl, th, self.here)?;
        if x.lo < lo {
            cur = self.cast(cur, ty, out);
            let c = self.push(NewVal::constant(lo, ty, x.frac, 0.0), out);
            let y = self.v(cur).clone();
            cur = self.push(
                NewVal {
                    op: Op::Max(cur, c),
                    ty,
                    frac: x.frac,
                    lo: lo.max(y.lo),
                    hi: lo.max(y.hi),
                    err: y.err,
                },
                out,
            );
        }
        if x.hi > hi {
            cur = self.cast(cur, ty, out);
            let c = self.push(NewVal::constant(hi, ty, x.frac, 0.0), out);
            let y = self.v(cur).clone();
            cur = self.push(
                NewVal {
                    op: Op::Min(cur, c),
                    ty,
                    frac: x.frac,
                    lo: hi.min(y.lo),
                    hi: hi.min(y.hi),
                    err: y.err,
                },
                out,
            );
        }
        if cur == v {
            cur = self.cast(cur, ty, out);
        }
        Ok(cur)
    }

    /// The raw interval of `[lo, hi]` after dropping `n` fraction bits with the program's
    /// rounding (what [`Self::round`] computes).
    pub(super) fn rounded(&self, lo: i128, hi: i128, n: u32) -> (i128, i128) {
        let n = n.min(127);
        match self.prog.rounding {
            Rounding::Floor => (lo >> n, hi >> n),
            Rounding::Nearest if n == 0 => (lo, hi),
            Rounding::Nearest => {
                let h = 1i128 << (n - 1);
                ((lo + h) >> n, (hi + h) >> n)
            }
        }
    }
}
