//! The multi-model adaptive force controller of Rubio & De la Sen (Secs. III–IV)
//! as a textbook f64 design: parallel RLS estimators on β-FROH models, a
//! model-following pole-placement law per estimate, and a switching supervisor with a
//! minimum residence time. It divides freely: it is the independent float oracle for the
//! generated, division-free controller of issue 17, and the design study behind it.
//!
//! **Models** ([`crate::froh`]). For β = 0 (ZOH) the estimated model is
//! `A = z² + a₁z + a₂`, `B = b₁z + b₂`; for β ≠ 0 the hold adds a pole at the origin,
//! `A = z(z² + a₁z + a₂)`, `B = b₁z² + b₂z + b₃` (Rubio & De la Sen after eq. 5: "n = 3 since a new pole at
//! the origin is automatically added"). The origin pole is structural, so it is not
//! estimated: θ = (a₁, a₂, b₁, b₂[, b₃]), regressor φ_k = (−y_{k−1}, −y_{k−2}, u_{k−1},
//! u_{k−2}[, u_{k−3}]), one estimator per β, each initialised from the β-FROH model of Rubio & De la Sen's
//! initial guess `(−3s + 150)/(s² + 20s + 550)` (Rubio & De la Sen, Sec. V).
//!
//! **RLS** (Rubio & De la Sen, eq. 11, with a forgetting factor λ, 1 in the paper):
//! `θ_k = θ_{k−1} + P_{k−1}φ_k·e_k/(λ + φ_kᵀP_{k−1}φ_k)`, `e_k = y_k − φ_kᵀθ_{k−1}`,
//! `P_k = (P_{k−1} − P_{k−1}φ_kφ_kᵀP_{k−1}/(λ + φ_kᵀP_{k−1}φ_k))/λ`.
//!
//! **Pole placement** (Rubio & De la Sen, eqs. 7–9; the extraction garbles the degree conditions, derived
//! here). Rubio & De la Sen's plant zeros include unstable ones (the ZOH zero of the initial model is at
//! z = −1.035), so no zero is cancelled: `B⁻ = B`, and the law `R·u = T·y_r − S·y` places
//! the closed-loop characteristic polynomial `A·R + B·S` on the reference model's poles
//! times an observer polynomial `A_o`:
//! * ZOH: `R = z + r₁`, `S = s₀z + s₁`, `A_o = z − ρ`, `A·R + B·S = A_m'·A_o`;
//! * β ≠ 0: `R = z² + r₁z + r₂`, `S = s₀z² + s₁z` (`s₂ = 0` is forced by the origin pole:
//!   the z⁰ coefficient of the equation reads `b₃s₂ = 0`), `A_o = z·(z − ρ)`,
//!   `A·R + B·S = z·A_m'·A_o`, i.e. after dividing by z:
//!   `(z² + a₁z + a₂)·R + B·(s₀z + s₁) = z·(z − ρ)·A_m'`,
//!
//! where `A_m' = z² + m₁z + m₂` is the reference model `98.62/(s² + 15.89s + 98.62)`
//! discretised (its poles do not depend on the hold), and ρ the observer root (Rubio & De la Sen asks only
//! that A_0 be stable and monic; ρ = 0 is deadbeat). `T = t₀·A_o` with
//! `t₀ = A_m'(1)/B(1)` gives `y/y_r = t₀·B/(z^d·A_m')` (d = 1 for β ≠ 0): the observer
//! cancels from reference to force, and the DC gain is 1. The linear
//! system is the Sylvester system of (A, B); its determinant vanishes exactly when A and B
//! share a root (Rubio & De la Sen: "provided that [A, B] are co-prime"). When it is too small, the
//! controller keeps its last solution.
//!
//! **Supervisor** (Rubio & De la Sen, Sec. IV.B; the index's formula is garbled, read as a window sum):
//! `J_l = Σ_{j=k−M+1}^{k} (ŷ_j^{(l)} − y_j)²` with `ŷ^{(l)}` the a-priori prediction of
//! estimator l, `c = argmin J_l`, and a switch to c only if at least `N_r` periods have
//! passed since the last switch (Rubio & De la Sen, Sec. V: N_r = 2).

use crate::controller::{Controller, Signals};
use crate::froh::{froh, ContinuousTf, PAPER_BETAS};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;

/// Parameters of the design (Rubio & De la Sen, Sec. V where it gives them).
#[derive(Clone, Debug)]
pub struct MultiModelParams {
    /// Sampling period T (Rubio & De la Sen, Sec. V: 0.0839 s).
    pub period: f64,
    /// The correcting gains β of the parallel estimators (Rubio & De la Sen, Sec. V: seven).
    pub betas: Vec<f64>,
    /// The estimator whose controller is active at the start (Rubio & De la Sen, Sec. V, Fig. 4: β = −0.3).
    pub initial: usize,
    /// Whether the supervisor switches (false: the initial controller throughout).
    pub switching: bool,
    /// Minimum residence time N_r in periods (Rubio & De la Sen, Sec. V: 2).
    pub residence: usize,
    /// Window M of the switching index, in periods (Rubio & De la Sen does not give it; chosen).
    pub window: usize,
    /// RLS forgetting factor λ (1 in Rubio & De la Sen, eq. 11).
    pub lambda: f64,
    /// Initial covariance P₀ = p0·I (Rubio & De la Sen: "arbitrary").
    pub p0: f64,
    /// Reference force F_r in kN (Rubio & De la Sen, Sec. V: 1.2 kN).
    pub force_ref: f64,
    /// Feed command limits in mm/s.
    pub feed: (f64, f64),
    /// Feed command before the first sample, mm/s.
    pub feed0: f64,
    /// The estimators' initial continuous model (Rubio & De la Sen, Sec. V).
    pub initial_model: ContinuousTf,
    /// The continuous reference model (Rubio & De la Sen, Sec. V).
    pub reference_model: ContinuousTf,
    /// Smallest |Sylvester determinant|, and smallest |B(1)| (t₀'s divisor), for which the
    /// controller is re-solved.
    pub min_det: f64,
    /// Whether the estimators adapt (false: every controller stays the initial model's).
    pub adapt: bool,
    /// The observer root ρ: `A_o = z − ρ` (ZOH) or `z·(z − ρ)` (β ≠ 0); 0 is deadbeat.
    /// Rubio & De la Sen asks only that A_0 be stable and monic.
    pub observer: f64,
}

impl Default for MultiModelParams {
    fn default() -> Self {
        MultiModelParams {
            period: 0.0839,
            betas: PAPER_BETAS.to_vec(),
            initial: 1,
            switching: true,
            residence: 2,
            window: 10,
            lambda: 1.0,
            p0: 100.0,
            force_ref: 1.2,
            feed: (0.5, 32.0),
            feed0: 4.0,
            initial_model: ContinuousTf::paper_initial_model(),
            reference_model: ContinuousTf::paper_reference_model(),
            min_det: 1e-9,
            adapt: true,
            observer: 0.0,
        }
    }
}

/// One estimator/controller pair.
#[derive(Clone, Debug)]
struct Pair {
    /// θ = (a₁, a₂, b₁, b₂[, b₃]).
    theta: DVector<f64>,
    p: DMatrix<f64>,
    /// (r₁[, r₂], s₀, s₁, t₀).
    law: Vec<f64>,
    /// Squared a-priori prediction errors over the window.
    errs: VecDeque<f64>,
}

impl Pair {
    fn nb(&self) -> usize {
        self.theta.len() - 2
    }
}

/// The multi-model controller (module docs). Input: measured force `fc` (kN); output: feed
/// command `feed` (mm/s); states: the active estimator's index and β.
pub struct MultiModel {
    p: MultiModelParams,
    pairs: Vec<Pair>,
    /// Reference denominator `A_m' = z² + m₁z + m₂`: (m₁, m₂).
    am: (f64, f64),
    active: usize,
    last_switch: usize,
    k: usize,
    /// Past forces y_{k−1}, y_{k−2} and feeds u_{k−1}, u_{k−2}, u_{k−3}.
    y_hist: [f64; 2],
    u_hist: [f64; 3],
    switches: usize,
    /// The reference at the previous sample (0 before the first).
    r_prev: f64,
    /// The Sylvester determinants of the initial models.
    det0: Vec<f64>,
}

impl MultiModel {
    /// A controller with parameters `p`; `Err` if a model cannot be discretised.
    pub fn new(p: MultiModelParams) -> Result<MultiModel, String> {
        if p.initial >= p.betas.len() {
            return Err(format!("initial index {} out of range", p.initial));
        }
        let m = froh(&p.reference_model, p.period, 0.0).map_err(|e| e.to_string())?;
        let am = (m.den[1], m.den[2]);
        let mut pairs = Vec::new();
        for &beta in &p.betas {
            let h = froh(&p.initial_model, p.period, beta).map_err(|e| e.to_string())?;
            let mut th = vec![h.den[1], h.den[2]];
            th.extend(&h.num[1..]);
            let n = th.len();
            let mut pair = Pair {
                theta: DVector::from_vec(th),
                p: DMatrix::identity(n, n) * p.p0,
                law: Vec::new(),
                errs: VecDeque::new(),
            };
            pair.law = solve(&pair.theta, am, p.observer, p.min_det)
                .ok_or("the initial model's A and B are not co-prime")?;
            pairs.push(pair);
        }
        Ok(MultiModel {
            active: p.initial,
            last_switch: 0,
            k: 0,
            y_hist: [0.0; 2],
            u_hist: [0.0; 3],
            switches: 0,
            r_prev: 0.0,
            det0: pairs
                .iter()
                .map(|p| sylvester(&p.theta).determinant())
                .collect(),
            am,
            pairs,
            p,
        })
    }

    /// How many times the supervisor has switched.
    pub fn switches(&self) -> usize {
        self.switches
    }

    /// The number of estimator/controller pairs.
    pub fn pairs(&self) -> usize {
        self.pairs.len()
    }

    /// The index of the active pair.
    pub fn active(&self) -> usize {
        self.active
    }

    /// The active estimate θ and law (r₁[, r₂], s₀, s₁, t₀).
    pub fn active_pair(&self) -> (Vec<f64>, Vec<f64>) {
        let p = &self.pairs[self.active];
        (p.theta.iter().copied().collect(), p.law.clone())
    }

    /// The Sylvester determinant of pair `l`'s estimate (0 exactly when its A and B share
    /// a root), relative to that of its initial model.
    pub fn relative_det(&self, l: usize) -> f64 {
        sylvester(&self.pairs[l].theta).determinant() / self.det0[l]
    }

    /// The β of the active controller.
    pub fn active_beta(&self) -> f64 {
        self.p.betas[self.active]
    }

    /// The closed-loop characteristic polynomial `A·R + B·S` of pair `l` (reduced by the
    /// origin pole for β ≠ 0) minus its target `z^{deg}·A_m'`: all zeros when the
    /// Diophantine equation is solved exactly.
    pub fn placement_residual(&self, l: usize) -> Vec<f64> {
        residual(
            &self.pairs[l].theta,
            &self.pairs[l].law,
            self.am,
            self.p.observer,
        )
    }

    fn regressor(&self, nb: usize) -> DVector<f64> {
        let mut v = vec![-self.y_hist[0], -self.y_hist[1]];
        v.extend(&self.u_hist[..nb]);
        DVector::from_vec(v)
    }
}

/// `(r₁[, r₂], s₀, s₁, t₀)` solving the Diophantine equation of the module docs for
/// θ, or `None` when the Sylvester determinant is below `min_det`.
fn solve(theta: &DVector<f64>, am: (f64, f64), rho: f64, min_det: f64) -> Option<Vec<f64>> {
    let (a1, a2) = (theta[0], theta[1]);
    let b: Vec<f64> = theta.iter().skip(2).copied().collect();
    let (m1, m2) = am;
    let c = target(am, rho);
    let mat = sylvester(theta);
    let mut rhs = DVector::zeros(mat.nrows());
    rhs[0] = c[0] - a1;
    rhs[1] = c[1] - a2;
    rhs[2] = c[2];
    let lu = mat.lu();
    if lu.determinant().abs() < min_det {
        return None;
    }
    let x = lu.solve(&rhs)?;
    let b_at_1: f64 = b.iter().sum();
    if b_at_1.abs() < min_det {
        return None;
    }
    let mut law: Vec<f64> = x.iter().copied().collect();
    law.push((1.0 + m1 + m2) / b_at_1);
    Some(law)
}

/// `[c₁, c₂, c₃]` of `(z² + m₁z + m₂)(z − ρ) = z³ + c₁z² + c₂z + c₃`: the closed-loop
/// polynomial of the ZOH law (for β ≠ 0 it is that times z², reduced by z).
fn target(am: (f64, f64), rho: f64) -> [f64; 3] {
    [am.0 - rho, am.1 - rho * am.0, -rho * am.1]
}

/// The Sylvester matrix of the Diophantine equation (module docs) for θ: unknowns
/// (r₁, s₀, s₁) for ZOH, (r₁, r₂, s₀, s₁) for β ≠ 0, rows the powers of z from the highest.
fn sylvester(theta: &DVector<f64>) -> DMatrix<f64> {
    let (a1, a2) = (theta[0], theta[1]);
    let b: Vec<f64> = theta.iter().skip(2).copied().collect();
    if b.len() == 2 {
        // z², z¹, z⁰ of (z²+a₁z+a₂)(z+r₁) + (b₁z+b₂)(s₀z+s₁) = z³+m₁z²+m₂z.
        let (b1, b2) = (b[0], b[1]);
        DMatrix::from_row_slice(3, 3, &[1.0, b1, 0.0, a1, b2, b1, a2, 0.0, b2])
    } else {
        // z³..z⁰ of (z²+a₁z+a₂)(z²+r₁z+r₂) + (b₁z²+b₂z+b₃)(s₀z+s₁) = z⁴+m₁z³+m₂z².
        let (b1, b2, b3) = (b[0], b[1], b[2]);
        #[rustfmt::skip]
        let m = DMatrix::from_row_slice(4, 4, &[
            1.0, 0.0, b1, 0.0,
            a1, 1.0, b2, b1,
            a2, a1, b3, b2,
            0.0, a2, 0.0, b3,
        ]);
        m
    }
}

/// Coefficients of `A·R + B·S − target` (module docs), highest power first.
fn residual(theta: &DVector<f64>, law: &[f64], am: (f64, f64), rho: f64) -> Vec<f64> {
    let c = target(am, rho);
    let a = [1.0, theta[0], theta[1]];
    let b: Vec<f64> = theta.iter().skip(2).copied().collect();
    let (r, s, target) = if b.len() == 2 {
        (
            vec![1.0, law[0]],
            vec![law[1], law[2]],
            vec![1.0, c[0], c[1], c[2]],
        )
    } else {
        (
            vec![1.0, law[0], law[1]],
            vec![law[2], law[3]],
            vec![1.0, c[0], c[1], c[2], 0.0],
        )
    };
    let mut out = mul(&a, &r);
    let bs = mul(&b, &s);
    let off = out.len() - bs.len();
    for (i, v) in bs.iter().enumerate() {
        out[off + i] += v;
    }
    out.iter().zip(&target).map(|(x, t)| x - t).collect()
}

fn mul(p: &[f64], q: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; p.len() + q.len() - 1];
    for (i, x) in p.iter().enumerate() {
        for (j, y) in q.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

impl Controller for MultiModel {
    fn signals(&self) -> Signals {
        Signals {
            inputs: vec![("fc", "kN")],
            states: vec![("active", ""), ("beta", "")],
            outputs: vec![("feed", "mm/s")],
        }
    }

    fn period(&self) -> f64 {
        self.p.period
    }

    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        let y = inputs[0];
        // Estimation (Rubio & De la Sen, eq. 11) and the switching index (Rubio & De la Sen, Sec. IV.B).
        for l in 0..self.pairs.len() {
            let nb = self.pairs[l].nb();
            let phi = self.regressor(nb);
            let pair = &mut self.pairs[l];
            let e = y - phi.dot(&pair.theta);
            pair.errs.push_back(e * e);
            if pair.errs.len() > self.p.window {
                pair.errs.pop_front();
            }
            if !self.p.adapt {
                continue;
            }
            let pphi = &pair.p * &phi;
            let den = self.p.lambda + phi.dot(&pphi);
            pair.theta += &pphi * (e / den);
            pair.p = (&pair.p - &pphi * pphi.transpose() / den) / self.p.lambda;
            if let Some(law) = solve(&pair.theta, self.am, self.p.observer, self.p.min_det) {
                pair.law = law;
            }
        }
        // Supervisor: argmin J, switched only after the residence time.
        if self.p.switching {
            let j = |l: usize| self.pairs[l].errs.iter().sum::<f64>();
            let best = (0..self.pairs.len())
                .min_by(|&x, &z| j(x).total_cmp(&j(z)))
                .unwrap_or(self.active);
            if best != self.active && self.k >= self.last_switch + self.p.residence {
                self.active = best;
                self.last_switch = self.k;
                self.switches += 1;
            }
        }
        // The active law: R·u = t₀·A_o·y_r − S·y.
        let law = &self.pairs[self.active].law;
        let (y1, u) = (self.y_hist[0], self.u_hist);
        // T·y_r = t₀·(y_r,k − ρ·y_r,k−1): the reference steps from 0 at the first sample.
        let tr = law[law.len() - 1] * (self.p.force_ref - self.p.observer * self.r_prev);
        self.r_prev = self.p.force_ref;
        let raw = if law.len() == 4 {
            -law[0] * u[0] + tr - law[1] * y - law[2] * y1
        } else {
            -law[0] * u[0] - law[1] * u[1] + tr - law[2] * y - law[3] * y1
        };
        let feed = raw.clamp(self.p.feed.0, self.p.feed.1);
        self.u_hist = [feed, u[0], u[1]];
        self.y_hist = [y, y1];
        self.k += 1;
        outputs[0] = feed;
    }

    fn states(&self, out: &mut [f64]) {
        out[0] = self.active as f64;
        out[1] = self.active_beta();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_laws_place_the_poles_of_the_initial_models() {
        let c = MultiModel::new(MultiModelParams::default()).expect("builds");
        for l in 0..c.pairs.len() {
            let r = c.placement_residual(l);
            assert!(
                r.iter().all(|x| x.abs() < 1e-12),
                "β = {}: {r:?}",
                c.p.betas[l]
            );
        }
    }
}
