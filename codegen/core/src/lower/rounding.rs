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
        if let Some(r) = self.const_split(v, n, span, out)? {
            return Ok(r);
        }
        if let Some(r) = self.const_sum_split(v, n, span, out)? {
            return Ok(r);
        }
        if let Some(r) = self.high_product(v, n, span, out)? {
            return Ok(r);
        }
        if let Some(r) = self.high_sum(v, n, span, out)? {
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

    /// `round(K ± x·m, n)` (or `x·m − K`) for a constant `K` on the result's grid (a
    /// multiple of 2^n) and an exact constant product that [`Self::const_split`] rounds in
    /// 32 bits: `K/2^n ± round(x·m, n)`, exact (`K` moves out of the rounding unchanged), where
    /// the sum fits `i32`; `1 + 1.125·x` is `1 + x + round(x/8)`. `None` otherwise.
    fn const_sum_split(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        let x = self.v(v).clone();
        if x.name.is_some() || x.claimed || x.boolean || x.ty.bits <= 32 {
            return Ok(None);
        }
        let strip = |me: &Self, id: ValId| me.under_widenings(id);
        let konst = |me: &Self, id: ValId| match me.v(strip(me, id)).op {
            Op::Const(c) if c % (1i128 << n) == 0 => Some(c >> n),
            _ => None,
        };
        let product = |me: &Self, id: ValId| {
            let id = strip(me, id);
            me.const_products.contains_key(&id).then_some(id)
        };
        // (K/2^n, the product, whether the product is subtracted)
        let (k, p, minus) = match x.op {
            Op::Add(a, b) => match (
                konst(self, a),
                product(self, b),
                konst(self, b),
                product(self, a),
            ) {
                (Some(k), Some(p), ..) | (_, _, Some(k), Some(p)) => (k, p, false),
                _ => return Ok(None),
            },
            Op::Sub(a, b) => match (product(self, a), konst(self, b)) {
                (Some(p), Some(k)) => (-k, p, false),
                _ => match (konst(self, a), product(self, b)) {
                    (Some(k), Some(p)) => (k, p, true),
                    _ => return Ok(None),
                },
            },
            _ => return Ok(None),
        };
        let Some(r) = self.const_split(p, n, span, out)? else {
            return Ok(None);
        };
        let rv = self.v(r).clone();
        let (lo, hi) = if minus {
            (k - rv.hi, k - rv.lo)
        } else {
            (k + rv.lo, k + rv.hi)
        };
        if !fits_i32(lo, hi) || !fits_i32(k, k) {
            return Ok(None);
        }
        let i32t = IntTy::signed(32);
        let kv = self.push(NewVal::constant(k, i32t, rv.frac, 0.0), out);
        let r = self.cast(r, i32t, out);
        let op = if minus {
            Op::Sub(kv, r)
        } else {
            Op::Add(kv, r)
        };
        let added = self.rounding_added(x.frac, n);
        Ok(Some(self.push(
            NewVal {
                op,
                ty: i32t,
                frac: rv.frac,
                lo,
                hi,
                err: err_bound::add(x.err, added),
            },
            out,
        )))
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
    pub(super) fn rounding_added(&self, frac: i32, n: u32) -> f64 {
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
        // Through the widening casts `clamp` puts before each side.
        let strip = |me: &Self, id: ValId| me.under_widenings(id);
        // A bound, also a narrower constant widened to the clamp's word.
        let konst = |me: &Self, id: ValId| match me.v(strip(me, id)).op {
            Op::Const(c) => Some(c),
            _ => None,
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
            return self.high_clamp(x.err, cur, n, (lo, hi), span, out);
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
        let err = if self.target.multiplier.high_product {
            // The inner rounding may be a high product's or a sum's term by term: what it
            // added to the operand's bound (with a margin for the subtraction's rounding), on
            // the larger of the clamp's own bound and the operand's.
            let rv = self.v(r).err;
            let extra = err_bound::add(rv - inner.err, rv * 1e-15).max(0.0);
            err_bound::add(x.err.max(inner.err), extra)
        } else {
            err_bound::add(x.err, self.rounding_added(x.frac, n)).max(self.v(r).err)
        };
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
            self.target.multiplier.high_product || (got.lo == want_lo && got.hi == want_hi),
            "round then clamp: [{}, {}] against [{want_lo}, {want_hi}]",
            got.lo,
            got.hi
        );
        // With high products the inner rounding is not a function of `x` alone, and the
        // interval is the one derived for the operations as computed (sound either way).
        if !self.target.multiplier.high_product && (got.lo != want_lo || got.hi != want_hi) {
            // Not expected (the identity holds for intervals too); keep the plain form.
            return Ok(None);
        }
        Ok(Some(r))
    }

    /// A 64-bit product of two values of at most 32 bits, rounded by `n`, as the high word of
    /// their product ([`Op::MulHi`]: three 16×16→32-bit pieces, within 3 LSBs below
    /// `a·b/2^32`), then shifted to the result's format in 32 bits: right by `n − 32` with the
    /// program's rounding, or left by `32 − n` (exact). Only on a target that asks for it
    /// ([`crate::lower::target::Multiplier::high_product`]), and only where the result fits
    /// `i32` and the truncation (3 LSBs of the high word, `3·2^(32 − n)` of the result's) is
    /// at most 2^-16 of the result's magnitude: a value of 32 bits keeps 16 bits of accuracy
    /// or more, which is what the word is for on the AVR. The error bound adds the
    /// truncation. `None` where the pattern or the conditions are absent.
    fn high_product(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        if !self.target.multiplier.high_product {
            return Ok(None);
        }
        let x = self.v(v).clone();
        if x.name.is_some() || x.claimed || x.boolean || x.ty.bits != 64 || !(16..64).contains(&n) {
            return Ok(None);
        }
        // A product shifted left by k is the product with k more fraction bits.
        if let Op::Shl(s, k) = x.op {
            if k < n && self.is_rescale(v) && matches!(self.v(s).op, Op::Mul(..)) {
                return self.high_product(s, n - k, span, out);
            }
            return Ok(None);
        }
        let Op::Mul(a, b) = x.op else {
            return Ok(None);
        };
        // Each factor: a value of at most 32 bits, not a constant (a constant factor is the
        // shift-add network's or the multiplier's).
        let is_const = |me: &Self, id: ValId| matches!(me.v(id).op, Op::Const(_));
        if is_const(self, a) || is_const(self, b) {
            return Ok(None);
        }
        let (Some(a), Some(b)) = (self.narrow32(a, 4, out), self.narrow32(b, 4, out)) else {
            return Ok(None);
        };
        if let Some(r) = self.short_product(&x, a, b, n, span, out)? {
            return Ok(Some(r));
        }
        let i32t = IntTy::signed(32);
        let (va, vb) = (self.v(a).clone(), self.v(b).clone());
        let (lo, hi) = super::lir::mul_hi_range((va.lo, va.hi), (vb.lo, vb.hi));
        let frac = x.frac - 32;
        let trunc = 3.0 * pow2(-frac);
        let up = 32u32.saturating_sub(n);
        let (rl, rh) = (lo << up, hi << up);
        let magnitude = err_bound::magnitude(rl.abs().max(rh.abs()), x.frac - n as i32);
        if !fits_i32(rl, rh) || trunc > magnitude * pow2(-16) {
            return Ok(None);
        }
        let ca = self.cast(a, i32t, out);
        let cb = self.cast(b, i32t, out);
        let m = self.push(
            NewVal {
                op: Op::MulHi(ca, cb),
                ty: i32t,
                frac,
                lo,
                hi,
                err: err_bound::add(x.err, trunc),
            },
            out,
        );
        let r = if n >= 32 {
            self.round(m, n - 32, span, out)?
        } else {
            self.shl(m, up, span, out)?
        };
        Ok(Some(r))
    }

    /// The product `x = a·b` (`a`, `b` of at most 32 bits, one of them within `i16`) rounded
    /// by `n ≥ 16`, from two 16×16→32-bit products and no truncation: with `h(b) = ⌊b/2^16⌋`
    /// and `l(b) = b − 2^16·h(b) ∈ [0, 2^16)`, `a·b = 2^16·a·h(b) + a·l(b)`, so
    /// `⌊a·b/2^16⌋ = a·h(b) + ⌊a·l(b)/2^16⌋` exactly; then rounded by the other `n − 16` bits.
    /// The pieces are typed so that a C compiler sees 16-bit operands (`int16_t` and
    /// `uint16_t` widened to `int32_t`), which avr-gcc multiplies in four `MUL`s each. The error
    /// bound adds the floor of 16 bits (`2^16 − 1` LSBs of the product, whatever the
    /// program's rounding) to `x`'s. `None` where neither factor fits `i16` or a piece or the
    /// result does not fit `i32`.
    fn short_product(
        &mut self,
        x: &super::lir::Val,
        a: ValId,
        b: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        let i16t = IntTy::signed(16);
        let in16 = |me: &Self, id: ValId| i16t.holds(me.v(id).lo, me.v(id).hi);
        let (a, b) = match (in16(self, a), in16(self, b)) {
            (true, _) => (a, b),
            (false, true) => (b, a),
            (false, false) => return Ok(None),
        };
        let (va, vb) = (self.v(a).clone(), self.v(b).clone());
        if va.frac + vb.frac != x.frac {
            return Ok(None);
        }
        let product = |(al, ah): (i128, i128), (bl, bh): (i128, i128)| {
            let c = [al * bl, al * bh, ah * bl, ah * bh];
            (
                c.iter().copied().min().unwrap_or(0),
                c.iter().copied().max().unwrap_or(0),
            )
        };
        let (hl, hh) = (vb.lo >> 16, vb.hi >> 16);
        let (p1l, p1h) = product((va.lo, va.hi), (hl, hh));
        let (p2l, p2h) = product((va.lo, va.hi), (0, 0xFFFF));
        let (rl, rh) = (p1l + (p2l >> 16), p1h + (p2h >> 16));
        if !(fits_i32(p1l, p1h) && fits_i32(p2l, p2h) && fits_i32(rl, rh)) {
            return Ok(None);
        }
        let (i32t, u16t) = (IntTy::signed(32), IntTy::unsigned(16));
        let frac = va.frac + vb.frac;
        let first_new = self.vals.len();
        let a16 = self.cast(a, i16t, out);
        let a32 = self.cast(a16, i32t, out);
        let b32 = self.cast(b, i32t, out);
        let mut piece = |me: &mut Self, op: Op, ty: IntTy, frac: i32, (lo, hi): (i128, i128)| {
            me.push(
                NewVal {
                    op,
                    ty,
                    frac,
                    lo,
                    hi,
                    err: 0.0,
                },
                out,
            )
        };
        let h = piece(self, Op::Shr(b32, 16), i32t, vb.frac - 16, (hl, hh));
        let h = piece(self, Op::Cast(h), i16t, vb.frac - 16, (hl, hh));
        let h = piece(self, Op::Cast(h), i32t, vb.frac - 16, (hl, hh));
        let l = piece(self, Op::Low(b32, 16), i32t, vb.frac, (0, 0xFFFF));
        let l = piece(self, Op::Cast(l), u16t, vb.frac, (0, 0xFFFF));
        let l = piece(self, Op::Cast(l), i32t, vb.frac, (0, 0xFFFF));
        // The 16-bit factors stay opaque to the optimiser (as a network's terms do): else
        // avr-gcc sees through the truncations and multiplies in 32 bits (`__mulsi3`, not
        // `__mulhisi3` and `__usmulhisi3`).
        for f in [a32, h, l] {
            let src = match self.v(f).op {
                Op::Cast(s) => s,
                _ => f,
            };
            if src.0 >= first_new {
                self.vals[src.0].network = true;
            }
        }
        let p1 = piece(self, Op::Mul(a32, h), i32t, frac - 16, (p1l, p1h));
        let p2 = piece(self, Op::Mul(a32, l), i32t, frac, (p2l, p2h));
        let p2 = piece(
            self,
            Op::Shr(p2, 16),
            i32t,
            frac - 16,
            (p2l >> 16, p2h >> 16),
        );
        let floor16 = (pow2(16) - 1.0) * pow2(-x.frac);
        let r = self.push(
            NewVal {
                op: Op::Add(p1, p2),
                ty: i32t,
                frac: frac - 16,
                lo: rl,
                hi: rh,
                err: err_bound::add(x.err, floor16),
            },
            out,
        );
        Ok(Some(self.round(r, n - 16, span, out)?))
    }

    /// The value under `id`'s unnamed widening casts that keep the binary point: the same
    /// integer, in a narrower or equal word.
    fn under_widenings(&self, mut id: ValId) -> ValId {
        while let Op::Cast(a) = self.v(id).op {
            let (w, src) = (self.v(id), self.v(a));
            if w.name.is_some() || w.claimed || src.ty.bits > w.ty.bits || src.frac != w.frac {
                break;
            }
            id = a;
        }
        id
    }

    /// Whether `id` is `s << k` that only moves the binary point (`s`'s value re-expressed
    /// with `k` more fraction bits), not a product by 2^k (a shift-add network's term).
    fn is_rescale(&self, id: ValId) -> bool {
        let w = self.v(id);
        matches!(w.op, Op::Shl(s, k) if !w.network && self.v(s).frac + k as i32 == w.frac)
    }

    /// The value under `id`'s wider-than-32-bit widening casts and changes of binary point
    /// ([`Self::is_rescale`]): the same physical value, perhaps with fewer fraction bits.
    fn under_rescales(&self, mut id: ValId) -> ValId {
        while self.v(id).ty.bits > 32 {
            match self.v(id).op {
                Op::Cast(s) if self.v(s).frac == self.v(id).frac => id = s,
                Op::Shl(s, _) if self.is_rescale(id) => id = s,
                _ => break,
            }
        }
        id
    }

    /// `id` as a value of at most 32 bits, where its interval fits `i32`: itself, the source of
    /// its widening casts, or (to `depth` levels) its sum, difference, negation or exact left
    /// shift recomputed in `i32` from operands that are such values. The same integer: each
    /// operation is exact, and every interval is inside `i32`. `None` otherwise.
    pub(super) fn narrow32(
        &mut self,
        id: ValId,
        depth: u32,
        out: &mut Vec<LStmt>,
    ) -> Option<ValId> {
        let w = self.v(id).clone();
        if w.boolean || !fits_i32(w.lo, w.hi) {
            return None;
        }
        if w.ty.bits <= 32 {
            return Some(id);
        }
        if depth == 0 || w.claimed || w.network {
            return None;
        }
        let i32t = IntTy::signed(32);
        let op = match w.op {
            Op::Cast(s) if self.v(s).frac == w.frac => return self.narrow32(s, depth, out),
            Op::Const(c) => Op::Const(c),
            Op::Add(a, b) => Op::Add(
                self.narrow32(a, depth - 1, out)?,
                self.narrow32(b, depth - 1, out)?,
            ),
            Op::Sub(a, b) => Op::Sub(
                self.narrow32(a, depth - 1, out)?,
                self.narrow32(b, depth - 1, out)?,
            ),
            Op::Neg(a) => Op::Neg(self.narrow32(a, depth - 1, out)?),
            Op::Shl(a, k) => Op::Shl(self.narrow32(a, depth - 1, out)?, k),
            _ => return None,
        };
        let ops: Vec<ValId> = op.operands();
        let mut cast_ops = Vec::with_capacity(ops.len());
        for o in ops {
            cast_ops.push(self.cast(o, i32t, out));
        }
        let op = match op {
            Op::Add(..) => Op::Add(cast_ops[0], cast_ops[1]),
            Op::Sub(..) => Op::Sub(cast_ops[0], cast_ops[1]),
            Op::Neg(_) => Op::Neg(cast_ops[0]),
            Op::Shl(_, k) => Op::Shl(cast_ops[0], k),
            other => other,
        };
        Some(self.push(
            NewVal {
                op,
                ty: i32t,
                frac: w.frac,
                lo: w.lo,
                hi: w.hi,
                err: w.err,
            },
            out,
        ))
    }

    /// A 64-bit sum of products, constants and (shifted) values of at most 32 bits, rounded by
    /// `n`, as the sum of its terms each rounded on its own and added in 32 bits: each
    /// product by [`Self::high_product`], each other term by the program's rounding (or an
    /// exact shift), a constant at compile time. Where the target asks for high products, the
    /// whole sum fits `i32`, and the terms' roundings together stay within 2^-16 of the
    /// result's magnitude (the accuracy [`Self::high_product`] keeps). The error bound is the
    /// sum of the terms'. `None` otherwise; the values tried are then dead, and
    /// [`super::dce`] drops them.
    fn high_sum(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        if !self.target.multiplier.high_product {
            return Ok(None);
        }
        let x = self.v(v).clone();
        if x.name.is_some()
            || x.claimed
            || x.boolean
            || x.ty.bits != 64
            || !matches!(x.op, Op::Add(..) | Op::Sub(..))
        {
            return Ok(None);
        }
        // The terms, with their signs (true: subtracted).
        fn terms(me: &Lowerer<'_>, id: ValId, neg: bool, acc: &mut Vec<(bool, ValId)>) {
            let w = me.v(id);
            let inner = w.name.is_none() && !w.claimed && !w.network && w.ty.bits == 64;
            match w.op {
                Op::Add(a, b) if inner => {
                    terms(me, a, neg, acc);
                    terms(me, b, neg, acc);
                }
                Op::Sub(a, b) if inner => {
                    terms(me, a, neg, acc);
                    terms(me, b, !neg, acc);
                }
                Op::Neg(a) if inner => terms(me, a, !neg, acc),
                Op::Cast(a) if inner && me.v(a).frac == w.frac && me.v(a).ty.bits == 64 => {
                    terms(me, a, neg, acc)
                }
                _ => acc.push((neg, id)),
            }
        }
        let mut ts = Vec::new();
        terms(self, v, false, &mut ts);
        // A constant's product is split on its own ([`Self::const_split`]).
        let product = |me: &Self, t: ValId| match me.v(t).op {
            _ if me.const_products.contains_key(&t) => false,
            Op::Mul(..) => true,
            Op::Shl(s, _) => matches!(me.v(s).op, Op::Mul(..)) && me.is_rescale(t),
            _ => false,
        };
        let products = ts.iter().any(|&(_, t)| product(self, t));
        if products && !(16..64).contains(&n) {
            return Ok(None);
        }
        // With products, the terms are added at the high products' binary point, then
        // shifted left exactly to the result's (a product rounded by less than 32 bits);
        // where every product has a factor within `i16`, at the result's
        // ([`Self::short_product`], which keeps every bit above the rounding).
        let short = |me: &Self, t: ValId| {
            // A rescaled product `p << k` is `p` rounded by `n − k`, which must be 16 or more.
            let (t, k) = match me.v(t).op {
                Op::Shl(s, k) if me.is_rescale(t) => (s, k),
                _ => (t, 0),
            };
            let Op::Mul(a, b) = me.v(t).op else {
                return false;
            };
            if n < k + 16 {
                return false;
            }
            let i16t = IntTy::signed(16);
            let (va, vb) = (me.v(a), me.v(b));
            (i16t.holds(va.lo, va.hi) && fits_i32(vb.lo, vb.hi))
                || (i16t.holds(vb.lo, vb.hi) && fits_i32(va.lo, va.hi))
        };
        let all_short = ts.iter().all(|&(_, t)| !product(self, t) || short(self, t));
        let m = if products && !all_short { n.max(32) } else { n };
        // A term of at most 32 bits under widening casts and changes of binary point (each
        // term is rescaled to the sum's format after).
        let narrow = |me: &mut Self, id: ValId, out: &mut Vec<LStmt>| {
            let id = me.under_rescales(id);
            me.narrow32(id, 4, out)
        };
        let frac = x.frac - m as i32;
        let fits = |w: &super::lir::Val| w.ty.bits <= 32 && fits_i32(w.lo, w.hi);
        let i32t = IntTy::signed(32);
        let mut rounded = Vec::with_capacity(ts.len());
        for &(neg, t) in &ts {
            let r = match self.v(t).op {
                _ if self.const_products.contains_key(&t) => {
                    match self.const_split(t, m, span, out)? {
                        Some(r) => r,
                        None => return Ok(None),
                    }
                }
                _ if product(self, t) => match self.high_product(t, m, span, out)? {
                    Some(r) => r,
                    None => return Ok(None),
                },
                Op::Const(_) => self.round(t, m, span, out)?,
                // A clamped term (a saturated update): rounded, then clamped, in 32 bits where
                // [`Self::round_then_clamp`] can (else the term does not fit, below).
                Op::Min(..) | Op::Max(..) => self.round(t, m, span, out)?,
                // A shifted term of a constant's shift-add network, `x·2^k` with the binary
                // point unchanged: `x` re-expressed with `frac + k` fraction bits has the raw
                // value of `x·2^k` with `frac` (a cast that moves the binary point), kept
                // opaque as the network's own terms are, so that no compiler folds the sum back
                // into a multiply.
                Op::Shl(s, k) if self.v(t).network && self.v(s).frac == self.v(t).frac => {
                    let Some(y) = narrow(self, s, out) else {
                        return Ok(None);
                    };
                    let y = self.rescale(y, frac + k as i32, span, out)?;
                    let yv = self.v(y).clone();
                    if !fits_i32(yv.lo, yv.hi) || yv.ty.bits > 32 {
                        return Ok(None);
                    }
                    let r = self.push(
                        NewVal {
                            op: Op::Cast(y),
                            ty: i32t,
                            frac,
                            lo: yv.lo,
                            hi: yv.hi,
                            err: yv.err * pow2(k as i32),
                        },
                        out,
                    );
                    self.vals[r.0].network = true;
                    r
                }
                _ => match narrow(self, t, out) {
                    Some(y) => self.rescale(y, frac, span, out)?,
                    None => return Ok(None),
                },
            };
            if !fits(self.v(r)) || self.v(r).frac != frac {
                return Ok(None);
            }
            rounded.push((neg, r));
        }
        // A subtracted term first would need a negation: start from an added one.
        if let Some(i) = rounded.iter().position(|&(neg, _)| !neg) {
            rounded.swap(0, i);
        }
        let (neg0, first) = rounded[0];
        let mut acc = self.cast(first, i32t, out);
        if neg0 {
            let a = self.v(acc).clone();
            if !fits_i32(-a.hi, -a.lo) {
                return Ok(None);
            }
            acc = self.push(
                NewVal {
                    op: Op::Neg(acc),
                    ty: i32t,
                    frac,
                    lo: -a.hi,
                    hi: -a.lo,
                    err: a.err,
                },
                out,
            );
        }
        for &(neg, r) in &rounded[1..] {
            let r = self.cast(r, i32t, out);
            let (a, b) = (self.v(acc).clone(), self.v(r).clone());
            let (op, lo, hi) = if neg {
                (Op::Sub(acc, r), a.lo - b.hi, a.hi - b.lo)
            } else {
                (Op::Add(acc, r), a.lo + b.lo, a.hi + b.hi)
            };
            if !fits_i32(lo, hi) {
                return Ok(None);
            }
            acc = self.push(
                NewVal {
                    op,
                    ty: i32t,
                    frac,
                    lo,
                    hi,
                    err: err_bound::add(a.err, b.err),
                },
                out,
            );
        }
        if m > n {
            acc = self.shl(acc, m - n, span, out)?;
            if !fits(self.v(acc)) {
                return Ok(None);
            }
        }
        let got = self.v(acc).clone();
        let magnitude = err_bound::magnitude(got.lo.abs().max(got.hi.abs()), got.frac);
        let added = got.err - x.err;
        if added > magnitude * pow2(-16) {
            return Ok(None);
        }
        Ok(Some(acc))
    }

    /// `round(clamp(p, LO, HI), n)` for a product `p` rounded by `n < 32` bits whose rounded
    /// value needs more than 32 bits while the clamp's bounds do not, on a target that asks for
    /// high products: the high word of the product ([`Self::high_product`] by 32 bits), clamped
    /// there to the bounds rounded by 32 bits, then shifted left by `32 − n` (exact). Within
    /// the clamp's own error bound (`err`) plus the rounding of 32 bits, as clamping is
    /// 1-Lipschitz. `None` where the result does not fit `i32`.
    fn high_clamp(
        &mut self,
        err: f64,
        p: ValId,
        n: u32,
        (lo, hi): (Option<i128>, Option<i128>),
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        if !self.target.multiplier.high_product || n >= 32 {
            return Ok(None);
        }
        let (pf, p_err) = (self.v(p).frac, self.v(p).err);
        let Some(r) = self.high_product(p, 32, span, out)? else {
            return Ok(None);
        };
        let bound = |c: Option<i128>, none: i128| c.map_or(none, |c| self.rounded(c, c, 32).0);
        let (bl, bh) = (bound(lo, i128::MIN), bound(hi, i128::MAX));
        let rv = self.v(r).clone();
        if bl > bh || (lo.is_some() && bl > rv.hi) || (hi.is_some() && bh < rv.lo) {
            return Ok(None);
        }
        let c = self.clamp(r, bl, bh, out)?;
        let s = self.shl(c, 32 - n, span, out)?;
        let sv = self.v(s).clone();
        if sv.ty.bits > 32 {
            return Ok(None);
        }
        // The clamp's own bound (which can hold more than the product's: a table's
        // interpolation error sits on its clamp), the truncation (what the high product's
        // bound adds to the product's, with a margin for the subtraction's rounding), and
        // the bounds' rounding.
        let trunc = err_bound::add(sv.err - p_err, sv.err * 1e-15);
        let e = err_bound::add(
            err_bound::add(err.max(p_err), trunc),
            self.rounding_added(pf, 32),
        );
        let s = if sv.err == e { s } else { self.copy(s, e, out) };
        let magnitude = err_bound::magnitude(sv.lo.abs().max(sv.hi.abs()), sv.frac);
        if e - err > magnitude * pow2(-16) {
            return Ok(None);
        }
        Ok(Some(s))
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

/// Whether the integers `lo..=hi` are all inside `i32`.
pub(super) fn fits_i32(lo: i128, hi: i128) -> bool {
    lo >= i128::from(i32::MIN) && hi <= i128::from(i32::MAX)
}
