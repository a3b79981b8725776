//! The nonlinear program, solved by SLSQP (the `slsqp` crate, a pure-Rust translation of
//! NLopt's SLSQP). Ivester & Danai re-solve "by nonlinear programming" after every cycle, citing
//! Luenberger (its ref. 10); sequential quadratic programming is the textbook method for a smooth
//! objective under smooth inequality constraints, which both of qloop's problems are.
//!
//! Variables are scaled to [0, 1] by their bounds, so that a speed in m/min and a feed in
//! mm/rev weigh alike in the solver. The caller gives the objective and constraints with their
//! gradients in the natural variables; a constraint is feasible where it is ≤ 0.
//!
//! The solver's answer is checked here, not trusted: the answer is the best point SLSQP
//! evaluated that lies in the box and violates no constraint by more than [`FEAS_TOL`]; if it
//! evaluated none, the program is infeasible from the start given, whatever status SLSQP
//! returned.

use std::cell::RefCell;
use std::fmt;

/// A function of the variables with its gradient.
pub type Smooth<'a> = &'a dyn Fn(&[f64]) -> (f64, Vec<f64>);

/// How far (in the constraint's own unit) a returned point may violate a constraint and still
/// be accepted.
pub const FEAS_TOL: f64 = 1e-6;

/// Why no optimum was returned.
#[derive(Clone, Debug, PartialEq)]
pub enum NlpError {
    /// The solver stopped at a point that violates a constraint by `by` (constraint `index`):
    /// the program is infeasible from there, or the solver failed.
    Infeasible {
        /// Which constraint.
        index: usize,
        /// By how much (its unit).
        by: f64,
        /// The solver's status.
        status: String,
    },
}

impl fmt::Display for NlpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NlpError::Infeasible { index, by, status } => write!(
                f,
                "the nonlinear program found no feasible point: constraint {} is violated by {by:.3e} (SLSQP: {status})",
                index + 1
            ),
        }
    }
}

impl std::error::Error for NlpError {}

/// An optimum.
#[derive(Clone, Debug, PartialEq)]
pub struct Optimum {
    /// The variables.
    pub x: Vec<f64>,
    /// The objective there.
    pub value: f64,
}

/// Restarts of SLSQP from its own answer, at most: a restart drops the quasi-Newton
/// Hessian that sometimes stalls a run short of the optimum.
pub const RESTARTS: usize = 8;

/// Minimises `objective` subject to `constraints[i](x) ≤ 0` and the box `bounds`, from
/// `start` (clamped into the box). SLSQP is restarted from its answer while that improves
/// the objective, at most [`RESTARTS`] times.
pub fn minimise(
    objective: Smooth<'_>,
    constraints: &[Smooth<'_>],
    start: &[f64],
    bounds: &[(f64, f64)],
) -> Result<Optimum, NlpError> {
    let mut best = solve(objective, constraints, start, bounds)?;
    for _ in 0..RESTARTS {
        match solve(objective, constraints, &best.x, bounds) {
            Ok(o) if o.value < best.value - 1e-12 * best.value.abs().max(1.0) => best = o,
            _ => break,
        }
    }
    Ok(best)
}

/// One SLSQP run.
fn solve(
    objective: Smooth<'_>,
    constraints: &[Smooth<'_>],
    start: &[f64],
    bounds: &[(f64, f64)],
) -> Result<Optimum, NlpError> {
    let n = bounds.len();
    let width: Vec<f64> = bounds.iter().map(|(lo, hi)| hi - lo).collect();
    let width = &width;
    let to_x =
        move |z: &[f64]| -> Vec<f64> { (0..n).map(|i| bounds[i].0 + z[i] * width[i]).collect() };
    let z0: Vec<f64> = (0..n)
        .map(|i| ((start[i] - bounds[i].0) / width[i]).clamp(0.0, 1.0))
        .collect();
    let scaled = |f: Smooth<'_>, z: &[f64], grad: Option<&mut [f64]>| -> f64 {
        let (value, g) = f(&to_x(z));
        if let Some(out) = grad {
            for i in 0..n {
                out[i] = g[i] * width[i];
            }
        }
        value
    };
    // Every point the objective is evaluated at: the crate's error path (RoundoffLimited,
    // which NLopt's SLSQP also returns at a converged optimum whose final test fails by
    // rounding) hands back the starting point, not the iterate, so the answer is taken from
    // here.
    let seen = RefCell::new(Vec::<Vec<f64>>::new());
    let obj = |z: &[f64], g: Option<&mut [f64]>, _: &mut ()| {
        seen.borrow_mut().push(z.to_vec());
        scaled(objective, z, g)
    };
    let cons: Vec<Box<dyn slsqp::Func<()> + '_>> = constraints
        .iter()
        .map(|&c| {
            let scaled = &scaled;
            Box::new(move |z: &[f64], g: Option<&mut [f64]>, _: &mut ()| scaled(c, z, g))
                as Box<dyn slsqp::Func<()> + '_>
        })
        .collect();
    let cons_ref: Vec<&dyn slsqp::Func<()>> = cons.iter().map(|c| c.as_ref()).collect();
    let unit = vec![(0.0, 1.0); n];
    let tols = slsqp::StopTols {
        ftol_rel: 1e-9,
        xtol_abs: vec![1e-9; n],
        ..Default::default()
    };
    let (status, z) = match slsqp::minimize(obj, &z0, &unit, &cons_ref, (), 500, Some(tols)) {
        Ok((s, z, _)) => (format!("{s:?}"), z),
        Err((s, z, _)) => (format!("{s:?}"), z),
    };
    if std::env::var_os("ACO_DEBUG").is_some() {
        eprintln!(
            "slsqp {status} {z:?} after {} evaluations",
            seen.borrow().len()
        );
    }
    let mut candidates = seen.into_inner();
    candidates.push(z);
    let violation = |x: &[f64]| -> (usize, f64) {
        constraints
            .iter()
            .enumerate()
            .map(|(i, c)| (i, c(x).0))
            .fold((0, f64::NEG_INFINITY), |a, b| {
                if b.1.is_nan() || b.1 > a.1 {
                    b
                } else {
                    a
                }
            })
    };
    let mut best: Option<Optimum> = None;
    let mut least = (0, f64::INFINITY);
    for z in &candidates {
        if z.iter().any(|v| !(-1e-12..=1.0 + 1e-12).contains(v)) {
            continue;
        }
        let x = to_x(z);
        let (i, by) = violation(&x);
        if by.is_nan() || by > FEAS_TOL {
            if by < least.1 {
                least = (i, by);
            }
            continue;
        }
        let value = objective(&x).0;
        if best.as_ref().is_none_or(|b| value < b.value) {
            best = Some(Optimum { x, value });
        }
    }
    best.ok_or(NlpError::Infeasible {
        index: least.0,
        by: least.1,
        status,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// min x² + y² subject to x + y ≥ 1: (1/2, 1/2), value 1/2 (by Lagrange).
    #[test]
    fn solves_a_problem_with_a_known_optimum() {
        let obj = |x: &[f64]| (x[0] * x[0] + x[1] * x[1], vec![2.0 * x[0], 2.0 * x[1]]);
        let con = |x: &[f64]| (1.0 - x[0] - x[1], vec![-1.0, -1.0]);
        let o = minimise(&obj, &[&con], &[2.0, -1.0], &[(-3.0, 3.0), (-3.0, 3.0)]).unwrap();
        assert!(
            (o.x[0] - 0.5).abs() < 1e-6 && (o.x[1] - 0.5).abs() < 1e-6,
            "{o:?}"
        );
        assert!((o.value - 0.5).abs() < 1e-9);
    }

    /// A constraint no point of the box meets is an error, not a point.
    #[test]
    fn an_infeasible_program_is_an_error() {
        let obj = |x: &[f64]| (x[0], vec![1.0]);
        let con = |x: &[f64]| (2.0 - x[0], vec![-1.0]);
        let e = minimise(&obj, &[&con], &[0.5], &[(0.0, 1.0)]).unwrap_err();
        assert!(matches!(e, NlpError::Infeasible { index: 0, .. }), "{e}");
    }
}
