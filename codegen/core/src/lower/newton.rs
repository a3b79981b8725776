//! The error bound of a fixed-step reciprocal (`newton_recip`, [`crate::lang::expand`]) in
//! the fixed-point code as lowered.
//!
//! Write `e(r) = 1 − d·r` for the clamped `d` as computed. A Newton step in real arithmetic
//! maps `e` to `e²` exactly. The fixed-point step computes `r·(2 − d·r)` plus a rounding `ρ`,
//! so `|e|` becomes at most `e² + HI·|ρ|`; its clamp to an interval that contains `1/d` only
//! moves `r` toward `1/d`, so it never increases `|e|`. Hence, from the seed's `ε₀` (exact:
//! the seed is a short dyadic constant),
//!
//! ```text
//!     ε_{k+1} = ε_k² + HI·δ_{k+1},     |1 − d·r_K| ≤ ε_K,
//! ```
//!
//! where `δ_k` bounds the rounding of step `k` alone: the error of the lowered operations
//! from the exact fixed-point values of `d` and `r_{k−1}` (the shifts that drop bits, and
//! their propagation through the products), computed here from the plan's value intervals.
//! The same contraction bounds each iterate's error against the real iteration,
//! `|r̂_k − r_k|` ([`iterate_err`]), which `qloop check` prints for the iterates and the
//! result where it is below what interval arithmetic gives (interval propagation cannot see
//! that Newton's iteration contracts, and multiplied the error by about 3 per step).

use super::err_bound::{add, magnitude, mul};
use super::lir::{Op, Val, ValId};
use super::Plan;
use crate::ir::{Program, Recip};
use std::collections::HashMap;

/// `v` rounded to `bits` significant bits (to nearest): a dyadic with at most `bits` ones.
pub fn short_dyadic(v: f64, bits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let e = v.abs().log2().floor() as i32;
    let scale = 2f64.powi(bits - 1 - e);
    (v * scale).round() / scale
}

/// The bound `ε_K ≥ |1 − d·r|` of `r` over the clamped `d` (see the module docs), or `None`
/// if the lowered code of a step has an operation this analysis does not cover.
pub fn recip_bound(plan: &Plan, r: &Recip) -> Option<f64> {
    bound_over(&plan.prog, &plan.vals, r)
}

/// A bound on `|r − r_real|`, the error `qloop check` reports for the result: with `d` and
/// `d_real` both in `[LO, HI]` (clamped), `|r − 1/d| ≤ ε_K/LO` (this module),
/// `|r_real − 1/d_real| ≤ E_K/LO` (the real iteration, [`Recip::real_error`]) and
/// `|1/d − 1/d_real| ≤ err(d)/LO²`.
pub fn result_err(prog: &Program, vals: &[Val], r: &Recip, d_err: f64) -> Option<f64> {
    let eps = bound_over(prog, vals, r)?;
    let lo = r.lo;
    Some(add(
        mul(
            add(eps, r.real_error(&prog.tables)),
            1.0 / lo * (1.0 + 1e-15),
        ),
        mul(d_err, 1.0 / (lo * lo) * (1.0 + 1e-15)),
    ))
}

/// [`recip_bound`] over the values lowered so far.
fn bound_over(p: &Program, vals: &[Val], r: &Recip) -> Option<f64> {
    trace(p, vals, r, r.steps).map(|t| t.eps[r.steps as usize])
}

/// The iterates of a `newton_recip` up to step `upto`, as lowered so far: `eps[k]` bounds
/// `|1 − d·r_k|` (the module's `ε_k`, `eps[0]` the seed's), `delta[k − 1]` the rounding of
/// step `k` alone, `mag[k]` the magnitude of iterate `k`, and `err0` the error of the seed
/// (0 for a constant one).
struct Trace {
    eps: Vec<f64>,
    delta: Vec<f64>,
    mag: Vec<f64>,
    err0: f64,
}

fn trace(p: &Program, vals: &[Val], r: &Recip, upto: u32) -> Option<Trace> {
    let d_name = &p.sig(r.d).name;
    let site = d_name.strip_suffix("_d")?;
    let named = |n: &str| {
        vals.iter()
            .rposition(|v| v.name.as_deref() == Some(n))
            .map(ValId)
    };
    let mag = |v: &Val| magnitude(v.lo.abs().max(v.hi.abs()), v.frac);
    let mut t = Trace {
        eps: vec![r.seed_error(&p.tables)],
        delta: Vec::new(),
        mag: vec![r.seed.abs()],
        err0: 0.0,
    };
    let mut prev = d_name.clone();
    if let Some((_, r0)) = r.seed_table {
        // A table seed: the fixed-point value differs from the interpolant by its rounded
        // entries (half an LSB) and the rounding of its product (at most one LSB).
        let v = &vals[named(&p.sig(r0).name)?.0];
        t.eps[0] = add(t.eps[0], mul(r.hi, 1.5 * 2f64.powi(-v.frac)));
        t.mag[0] = mag(v);
        t.err0 = v.err;
        prev = p.sig(r0).name.clone();
    }
    for k in 1..=upto {
        let name = format!("{site}_r{k}");
        let leaves = [d_name.as_str(), prev.as_str()];
        let target = named(&name)?;
        let delta = local_rounding(vals, target, &leaves)?;
        // A constant seed is not a value: step 1 reads it exactly (its `err` is 0).
        let e = t.eps[k as usize - 1];
        t.eps.push(add(mul(e, e), mul(r.hi, delta)));
        t.delta.push(delta);
        t.mag.push(mag(&vals[target.0]));
        prev = name;
    }
    Some(t)
}

/// A bound on `|r̂_k − r_k|`, the error of iterate `k` (lowered so far) against the same
/// iteration in real arithmetic from the real `d` (`d_err` off the clamped `d` as computed),
/// from Newton's contraction rather than interval propagation. With `f(d, r) = r·(2 − d·r)`,
///
/// ```text
///     |r̂_{k+1} − r_{k+1}| ≤ |f(d̂, r̂_k) − f(d̂, r_k)| + |f(d̂, r_k) − f(d, r_k)| + δ_{k+1}
///                         ≤ 2·max(ε_k, E_k + d_err·m_k)·|r̂_k − r_k| + μ_k²·d_err + δ_{k+1},
/// ```
///
/// since `∂f/∂r = 2·(1 − d̂·ξ)` for `ξ` between `r̂_k` and `r_k`, where `|1 − d̂·r̂_k| ≤ ε_k`
/// and `|1 − d̂·r_k| ≤ |1 − d·r_k| + d_err·r_k ≤ E_k + d_err·m_k`; and `|∂f/∂d| = r_k²`
/// (both `d`s clamped to `[LO, HI]`, a clamp moves neither further apart). `E_k` is the
/// real iteration's `|1 − d·r_k|` (the seed's error to the power `2^k`), `μ_k` bounds the
/// real iterate (`1/LO`, since `1 − d·r_k ≥ 0` after a step; a constant seed itself, a table
/// seed `(1 + E_0)/LO`) and `m_k` both iterates (`μ_k` and `r̂_k`'s interval). Near
/// convergence the factor is far below 1, where interval propagation multiplies the error by
/// about 3 per step.
pub fn iterate_err(p: &Program, vals: &[Val], r: &Recip, k: u32, d_err: f64) -> Option<f64> {
    let t = trace(p, vals, r, k)?;
    let inv_lo = mul(1.0 / r.lo, 1.0 + 1e-15);
    let mut real = r.seed_error(&p.tables);
    let mut err = t.err0;
    for j in 0..k as usize {
        // The real iterate's magnitude: the constant seed itself, a table seed's at most
        // (1 + E_0)/LO, then 1/LO.
        let real_mag = match (j, r.seed_table) {
            (0, None) => r.seed.abs(),
            (0, Some(_)) => mul(inv_lo, add(1.0, real)),
            _ => inv_lo,
        };
        let m = t.mag[j].max(real_mag);
        let lip = mul(2.0, t.eps[j].max(add(real, mul(d_err, m))));
        err = add(
            add(mul(lip, err), mul(mul(real_mag, real_mag), d_err)),
            t.delta[j],
        );
        real = mul(real, real);
    }
    Some(err)
}

/// A bound on the rounding the operations computing `target` add, in physical units, when
/// the values named in `leaves` are taken as exact (see the module docs).
fn local_rounding(vals: &[Val], target: ValId, leaves: &[&str]) -> Option<f64> {
    fn walk(
        vals: &[Val],
        id: ValId,
        leaves: &[&str],
        memo: &mut HashMap<usize, Option<f64>>,
    ) -> Option<f64> {
        if let Some(e) = memo.get(&id.0) {
            return *e;
        }
        let v = &vals[id.0];
        let mag = |x: ValId| {
            let w = &vals[x.0];
            magnitude(w.lo.abs().max(w.hi.abs()), w.frac)
        };
        let e = if v.name.as_deref().is_some_and(|n| leaves.contains(&n)) {
            Some(0.0)
        } else {
            match v.op {
                // A constant's own quantisation (0 for the exact 2 and the dyadic seed).
                Op::Const(_) => Some(v.err),
                Op::Cast(a) | Op::Neg(a) | Op::Shl(a, _) => walk(vals, a, leaves, memo),
                Op::Shr(a, k) => {
                    let drop = (2f64.powi(k as i32) - 1.0) * 2f64.powi(-vals[a.0].frac);
                    Some(add(walk(vals, a, leaves, memo)?, drop))
                }
                Op::Add(a, b) | Op::Sub(a, b) => Some(add(
                    walk(vals, a, leaves, memo)?,
                    walk(vals, b, leaves, memo)?,
                )),
                Op::Mul(a, b) => {
                    let (ea, eb) = (walk(vals, a, leaves, memo)?, walk(vals, b, leaves, memo)?);
                    Some(add(add(mul(mag(a), eb), mul(mag(b), ea)), mul(ea, eb)))
                }
                // The exact product's, plus the high product's truncation: below 3 LSBs.
                Op::MulHi(a, b) => {
                    let (ea, eb) = (walk(vals, a, leaves, memo)?, walk(vals, b, leaves, memo)?);
                    let exact = add(add(mul(mag(a), eb), mul(mag(b), ea)), mul(ea, eb));
                    Some(add(exact, 3.0 * 2f64.powi(-v.frac)))
                }
                // |min(a', b') − min(a, b)| ≤ max(|a' − a|, |b' − b|); the clamp's bounds are
                // taken as exact, see the module docs.
                Op::Min(a, b) | Op::Max(a, b) => {
                    let (ea, eb) = (walk(vals, a, leaves, memo)?, walk(vals, b, leaves, memo)?);
                    let is_const = |x: ValId| matches!(vals[x.0].op, Op::Const(_));
                    Some(match (is_const(a), is_const(b)) {
                        (false, true) => ea,
                        (true, false) => eb,
                        _ => ea.max(eb),
                    })
                }
                _ => None,
            }
        };
        memo.insert(id.0, e);
        e
    }
    walk(vals, target, leaves, &mut HashMap::new())
}

#[cfg(test)]
mod tests {
    use super::short_dyadic;

    #[test]
    fn short_dyadics_keep_the_leading_bits() {
        assert_eq!(short_dyadic(0.4, 6), 0.3984375); // 51/128: 0.0110011 in binary
        assert_eq!(short_dyadic(2.0 / 3.0, 4), 0.6875); // 11/16
        assert_eq!(short_dyadic(0.75, 6), 0.75);
        assert_eq!(short_dyadic(3.0, 1), 4.0);
    }
}
