//! Conditions: comparisons and their combinations. A comparison with a constant is exact on
//! every representable operand (the constant becomes the integer threshold on the operand's
//! grid, rounded per operator); two constants are compared at compile time; other
//! comparisons align their operands exactly and carry a *band*, the sum of their error
//! bounds, within which the fixed-point decision may differ from the real one.

use super::lir::{LStmt, Op, ValId};
use super::{Bin, Lowerer, NewVal};
use crate::diag::Result;
use crate::ir::*;
use crate::qformat::IntTy;
use proc_macro2::Span;

impl Lowerer<'_> {
    /// A condition. A comparison's `err` is its *band*: the fixed-point decision equals the
    /// real-arithmetic one whenever the real operands differ by more than the band (the sum of
    /// the operands' error bounds; 0 for exact operands, such as inputs compared with
    /// constants).
    pub(super) fn cond(&mut self, c: &Cond, out: &mut Vec<LStmt>) -> Result<ValId> {
        if let Cond::Cmp(..) = c {
            let k = self.decisions;
            self.decisions += 1;
            let id = self.comparison(c, out)?;
            self.vals[id.0].decision = Some(k);
            return Ok(id);
        }
        self.comparison(c, out)
    }

    /// [`Self::cond`] without numbering its comparison.
    pub(super) fn comparison(&mut self, c: &Cond, out: &mut Vec<LStmt>) -> Result<ValId> {
        let (op, err) = match c {
            Cond::Cmp(op, Expr::Const { value: x, .. }, Expr::Const { value: y, .. }) => {
                return self.decided(op.eval(x, y), out);
            }
            Cond::Cmp(op, x, Expr::Const { value, .. }) => {
                return self.threshold(*op, x, *value, out);
            }
            Cond::Cmp(op, Expr::Const { value, .. }, x) => {
                return self.threshold(op.mirror(), x, *value, out);
            }
            Cond::Cmp(op, a, b) => {
                let (a, b) = self.pair(a, b, 0, out)?;
                if let Some(cmp) = self.coarse_compare(*op, a, b, out) {
                    // Exact: the operands' own bounds.
                    (cmp, super::err_bound::add(self.v(a).err, self.v(b).err))
                } else {
                    // The aligned operands' bounds: alignment rounds where exact needs > 64 bits.
                    let (a, b, _, _) = self.align(a, b, Bin::Hull, self.here, out)?;
                    let band = super::err_bound::add(self.v(a).err, self.v(b).err);
                    (Op::Cmp(*op, a, b), band)
                }
            }
            Cond::And(a, b) => (Op::And(self.cond(a, out)?, self.cond(b, out)?), 0.0),
            Cond::Or(a, b) => (Op::Or(self.cond(a, out)?, self.cond(b, out)?), 0.0),
            Cond::Not(a) => (Op::Not(self.cond(a, out)?), 0.0),
        };
        Ok(self.boolean(op, err, out))
    }

    /// `a OP b` for operands of at most 32 bits at different binary points whose exact
    /// alignment needs a wider word, on a target whose word is narrower than 64 bits: decided
    /// at the coarser operand's binary point, exactly. With `c` the coarser operand, `f` the
    /// finer by `k` bits and `y = f/2^k`, for an integer `c`: `c > y ⟺ c > ⌊y⌋`,
    /// `c ≤ y ⟺ c ≤ ⌊y⌋`, `c ≥ y ⟺ c ≥ ⌈y⌉` and `c < y ⟺ c < ⌈y⌉`, with
    /// `⌈y⌉ = ⌊(f + 2^k − 1)/2^k⌋` (a floor is an arithmetic right shift). The same decision
    /// on every raw value, so the same band. `None` for `==` and `!=`, and where the
    /// alignment fits 32 bits or the shifted operand does not.
    fn coarse_compare(
        &mut self,
        op: CmpOp,
        a: ValId,
        b: ValId,
        out: &mut Vec<LStmt>,
    ) -> Option<Op> {
        let (va, vb) = (self.v(a).clone(), self.v(b).clone());
        let fits = |v: &super::lir::Val| v.ty.bits <= 32 && super::rounding::fits_i32(v.lo, v.hi);
        if self.target.word_bits >= 64
            || matches!(op, CmpOp::Eq | CmpOp::Ne)
            || va.frac == vb.frac
            || !fits(&va)
            || !fits(&vb)
        {
            return None;
        }
        let (c, f, op) = if va.frac < vb.frac {
            (a, b, op)
        } else {
            (b, a, op.mirror())
        };
        let (vc, vf) = (self.v(c).clone(), self.v(f).clone());
        let k = (vf.frac - vc.frac) as u32;
        // Where the coarser operand aligned exactly fits 32 bits, the plain comparison does.
        let aligned = super::shl_exact(vc.lo, k as i32).zip(super::shl_exact(vc.hi, k as i32));
        if k >= 31 || aligned.is_some_and(|(lo, hi)| super::rounding::fits_i32(lo, hi)) {
            return None;
        }
        let i32t = IntTy::signed(32);
        let mut src = self.cast(f, i32t, out);
        let (mut lo, mut hi) = (vf.lo, vf.hi);
        if matches!(op, CmpOp::Ge | CmpOp::Lt) {
            // ⌈y⌉ = ⌊(f + 2^k − 1)/2^k⌋.
            let up = (1i128 << k) - 1;
            if !super::rounding::fits_i32(lo, hi + up) {
                return None;
            }
            let u = self.push(NewVal::constant(up, i32t, vf.frac, 0.0), out);
            src = self.push(
                NewVal::exact(Op::Add(src, u), i32t, vf.frac, (lo + up, hi + up)),
                out,
            );
            (lo, hi) = (lo + up, hi + up);
        }
        let t = self.push(
            NewVal::exact(Op::Shr(src, k), i32t, vc.frac, (lo >> k, hi >> k)),
            out,
        );
        let (tl, th) = (lo >> k, hi >> k);
        let ty = IntTy::signed_for(tl.min(vc.lo), th.max(vc.hi), self.target.min_work_bits())?;
        let c = self.cast(c, ty, out);
        let t = self.cast(t, ty, out);
        Some(Op::Cmp(op, c, t))
    }

    pub(super) fn boolean(&mut self, op: Op, err: f64, out: &mut Vec<LStmt>) -> ValId {
        let id = self.push(
            NewVal {
                op,
                ty: IntTy::signed(8),
                frac: 0,
                lo: 0,
                hi: 1,
                err,
            },
            out,
        );
        self.vals[id.0].boolean = true;
        id
    }

    /// `x OP c` for a constant `c`, decided exactly on every raw value of `x`: `c` becomes the
    /// integer threshold `t` on `x`'s grid that gives the same answer (`x ≥ c ⟺ raw ≥ ⌈c·2^f⌉`,
    /// `x > c ⟺ raw > ⌊c·2^f⌋`, likewise `<` with the ceiling and `≤` with the floor; `x == c`
    /// for a `c` off the grid is never true), clamped to just outside `x`'s interval. The
    /// comparison's band is `x`'s own error bound.
    pub(super) fn threshold(
        &mut self,
        op: CmpOp,
        x: &Expr,
        c: f64,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let v = self.expr(x, 0, out)?;
        let xv = self.v(v).clone();
        let (fl, ce) = floor_ceil_scaled(c, xv.frac);
        let t = match op {
            CmpOp::Ge | CmpOp::Lt => ce,
            CmpOp::Gt | CmpOp::Le => fl,
            CmpOp::Eq | CmpOp::Ne if fl == ce => fl,
            // Off the grid: `==` never holds, `!=` always does; any raw outside x's interval
            // says so.
            CmpOp::Eq | CmpOp::Ne => xv.hi + 1,
        };
        let t = t.clamp(xv.lo - 1, xv.hi + 1);
        let ty = self.working(xv.lo.min(t), xv.hi.max(t), self.here)?;
        let a = self.cast(v, ty, out);
        let k = self.push(NewVal::constant(t, ty, xv.frac, 0.0), out);
        Ok(self.boolean(Op::Cmp(op, a, k), xv.err, out))
    }

    /// A comparison of two constants, decided at compile time on their exact values (as the
    /// reference decides it): `0 < 1` or `1 < 0`.
    pub(super) fn decided(&mut self, truth: bool, out: &mut Vec<LStmt>) -> Result<ValId> {
        let ty = IntTy::signed(self.target.min_work_bits());
        let zero = self.push(NewVal::constant(0, ty, 0, 0.0), out);
        let one = self.push(NewVal::constant(1, ty, 0, 0.0), out);
        let (a, b) = if truth { (zero, one) } else { (one, zero) };
        Ok(self.boolean(Op::Cmp(CmpOp::Lt, a, b), 0.0, out))
    }
}

/// The non-constant operand and the constant (value, site) of a pair with exactly one
/// constant.
pub(super) fn const_side<'e>(a: &'e Expr, b: &'e Expr) -> Option<(&'e Expr, (f64, Span))> {
    match (a, b) {
        (Expr::Const { .. }, Expr::Const { .. }) => None,
        (Expr::Const { value, span, .. }, x) | (x, Expr::Const { value, span, .. }) => {
            Some((x, (*value, *span)))
        }
        _ => None,
    }
}

/// `(⌊c·2^f⌋, ⌈c·2^f⌉)`, exact for every finite `c` (from its binary mantissa and exponent),
/// saturated to ±2^100 (far beyond any 64-bit raw value, which is all a threshold is compared
/// with).
pub(super) fn floor_ceil_scaled(c: f64, f: i32) -> (i128, i128) {
    const CAP: i128 = 1 << 100;
    if c == 0.0 {
        return (0, 0);
    }
    let (m, e) = crate::qformat::significand_exponent(c);
    let s = e + f;
    if s >= 0 {
        let v = if s >= 47 { m.signum() * CAP } else { m << s };
        return (v, v);
    }
    let r = (-s).min(127) as u32;
    let fl = m >> r;
    let exact = r < 127 && (fl << r) == m;
    (fl, if exact { fl } else { fl + 1 })
}
