//! One evaluator of property expressions (`prove { .. }`: [`PExpr`], [`PCond`]) over an exact
//! domain, shared by the encoders that need one: SMT bit-vector terms
//! (`prove::smt::PropEnv`), exact integer/bit-vector terms (`prove::exact::PropTerms`) and the
//! `i128` Rust of the Kani harnesses (`emit::kani`).
//!
//! Property arithmetic is exact: a value is `raw · 2^-frac`; sums, differences, minima, maxima
//! and comparisons first align both operands to the larger binary point (an exact left
//! shift); a product's binary point is the sum of its factors'; a constant is the exact binary
//! value of its f64 literal ([`exact_binary`]). This module owns that arithmetic of binary
//! points and the recursion over the expression; a domain ([`ExactDomain`]) says how to write
//! each operation in its own language.
//!
//! The counterexample replay (`prove::replay`) evaluates properties with its own big-integer
//! code on purpose: it is the independent check of what the encoders claim.

use crate::ir::{CmpOp, PCond, PExpr, SigId, When};
use crate::lower::Plan;

/// `+`, `-`, `min`, `max`: the operations whose operands share a binary point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arith {
    /// `a + b`
    Add,
    /// `a - b`
    Sub,
    /// `min(a, b)`
    Min,
    /// `max(a, b)`
    Max,
}

/// How one encoder writes exact property arithmetic.
pub trait ExactDomain {
    /// An exact value (it knows its own binary point).
    type Value;
    /// A truth value.
    type Bool;
    /// Why a term cannot be written.
    type Error;

    /// The binary point of `v`: its value is `raw · 2^-frac`.
    fn frac(v: &Self::Value) -> i32;
    /// The error for a constant with no exact binary value.
    fn inexact(&self, c: f64) -> Self::Error;
    /// The constant `m · 2^-frac`.
    fn constant(&mut self, m: i128, frac: i32) -> Result<Self::Value, Self::Error>;
    /// A signal's value before or after the step.
    fn signal(&mut self, id: SigId, when: When) -> Result<Self::Value, Self::Error>;
    /// Free parameter `i` of the property.
    fn param(&mut self, i: usize) -> Result<Self::Value, Self::Error>;
    /// `-a`.
    fn neg(&mut self, a: Self::Value) -> Result<Self::Value, Self::Error>;
    /// `|a|`.
    fn abs(&mut self, a: Self::Value) -> Result<Self::Value, Self::Error>;
    /// `a op b`, both first aligned to `frac` (the larger of their binary points).
    fn arith(
        &mut self,
        op: Arith,
        a: Self::Value,
        b: Self::Value,
        frac: i32,
    ) -> Result<Self::Value, Self::Error>;
    /// `a · b`, at the binary point `frac(a) + frac(b)`.
    fn mul(&mut self, a: Self::Value, b: Self::Value) -> Result<Self::Value, Self::Error>;
    /// `a op b`, both first aligned to `frac`.
    fn cmp(
        &mut self,
        op: CmpOp,
        a: Self::Value,
        b: Self::Value,
        frac: i32,
    ) -> Result<Self::Bool, Self::Error>;
    /// `a && b`.
    fn and(&mut self, a: Self::Bool, b: Self::Bool) -> Result<Self::Bool, Self::Error>;
    /// `a || b`.
    fn or(&mut self, a: Self::Bool, b: Self::Bool) -> Result<Self::Bool, Self::Error>;
    /// `!a`.
    fn not(&mut self, a: Self::Bool) -> Result<Self::Bool, Self::Error>;
}

/// `e` in the domain `d`.
pub fn expr<D: ExactDomain>(d: &mut D, e: &PExpr) -> Result<D::Value, D::Error> {
    match e {
        PExpr::Const(c) => {
            let (m, frac) = exact_binary(*c).ok_or_else(|| d.inexact(*c))?;
            d.constant(m, frac)
        }
        PExpr::Sig(id, when) => d.signal(*id, *when),
        PExpr::Param(i) => d.param(*i),
        PExpr::Neg(a) => {
            let a = expr(d, a)?;
            d.neg(a)
        }
        PExpr::Abs(a) => {
            let a = expr(d, a)?;
            d.abs(a)
        }
        PExpr::Add(a, b) | PExpr::Sub(a, b) | PExpr::Min(a, b) | PExpr::Max(a, b) => {
            let op = match e {
                PExpr::Add(..) => Arith::Add,
                PExpr::Sub(..) => Arith::Sub,
                PExpr::Min(..) => Arith::Min,
                _ => Arith::Max,
            };
            let (a, b) = (expr(d, a)?, expr(d, b)?);
            let frac = D::frac(&a).max(D::frac(&b));
            d.arith(op, a, b, frac)
        }
        PExpr::Mul(a, b) => {
            let (a, b) = (expr(d, a)?, expr(d, b)?);
            d.mul(a, b)
        }
    }
}

/// `c` in the domain `d`.
pub fn cond<D: ExactDomain>(d: &mut D, c: &PCond) -> Result<D::Bool, D::Error> {
    match c {
        PCond::Cmp(op, a, b) => {
            let (a, b) = (expr(d, a)?, expr(d, b)?);
            let frac = D::frac(&a).max(D::frac(&b));
            d.cmp(*op, a, b, frac)
        }
        PCond::And(a, b) => {
            let (a, b) = (cond(d, a)?, cond(d, b)?);
            d.and(a, b)
        }
        PCond::Or(a, b) => {
            let (a, b) = (cond(d, a)?, cond(d, b)?);
            d.or(a, b)
        }
        PCond::Not(a) => {
            let a = cond(d, a)?;
            d.not(a)
        }
    }
}

/// A property's free parameter (`forall p in [LO, HI]`) as the obligations and harnesses
/// quantify it: on the grid of the finest storage format of the spec, within its range.
#[derive(Clone, Debug)]
pub struct ParamGrid {
    /// The variable the solvers know it by (`p_NAME`).
    pub var: String,
    /// Bits of the narrowest signed integer holding every grid point.
    pub width: u32,
    /// Fraction bits: those of the finest signal format.
    pub frac: i32,
    /// Smallest raw grid point.
    pub lo: i128,
    /// Largest raw grid point.
    pub hi: i128,
}

/// The grids of property `p`'s free parameters.
pub fn param_grids(plan: &Plan, p: usize) -> Vec<ParamGrid> {
    let finest = plan.storage_formats().map(|q| q.frac).max().unwrap_or(0);
    plan.prog.properties[p]
        .params
        .iter()
        .map(|fp| {
            let scale = 2f64.powi(finest);
            let (lo, hi) = (
                (fp.range.0 * scale).ceil() as i128,
                (fp.range.1 * scale).floor() as i128,
            );
            ParamGrid {
                var: param_var(&fp.name),
                width: signed_bits(lo, hi),
                frac: finest,
                lo,
                hi,
            }
        })
        .collect()
}

/// The solver variable of the free parameter `name`.
pub fn param_var(name: &str) -> String {
    format!("p_{name}")
}

/// The fewest bits of a signed integer holding every value in `[lo, hi]`.
pub fn signed_bits(lo: i128, hi: i128) -> u32 {
    let need = |v: i128| {
        if v >= 0 {
            129 - v.leading_zeros()
        } else {
            129 - (!v).leading_zeros()
        }
    };
    need(lo).max(need(hi)).max(1)
}

/// The exact binary value of an f64 as `m · 2^-frac` with `frac ≥ 0` as small as possible
/// (`None` for non-finite values and magnitudes beyond 2^120).
pub fn exact_binary(c: f64) -> Option<(i128, i32)> {
    if !c.is_finite() {
        return None;
    }
    for frac in 0..1100 {
        let scaled = c * 2f64.powi(frac);
        if scaled.fract() == 0.0 {
            return (scaled.abs() < 2f64.powi(120)).then_some((scaled as i128, frac));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_binary_values() {
        assert_eq!(exact_binary(0.9375), Some((15, 4)));
        assert_eq!(exact_binary(-3.0), Some((-3, 0)));
        let (m, f) = exact_binary(0.1).unwrap();
        assert_eq!(m as f64 / 2f64.powi(f), 0.1);
    }
}
