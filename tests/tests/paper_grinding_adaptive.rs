//! Jenkins & Kurfess, "Adaptive Pole-Zero Cancellation in Grinding Force Control, Part II"
//! (Jenkins & Kurfess), the adaptive controller of eqs. 16-22: the *compiled*
//! `qloop_verified::grinding_adaptive_pzc` (`verified/specs/grinding_adaptive_pzc.qloop`) and its
//! f64 reference on the grinding plant, beside the fixed-gain PI of `grinding_pi.qloop`, on the
//! plant's `force-step`, `eta-varying` and `noise` scenarios, with the paper's Table 1
//! statistics for both.
//!
//! The truth the runs are held to is the analysis of the sampled loop, computed here from the
//! paper's constants (K_F = 200 1/s, eq. 5; the position loop 203/(s + 224), eq. 1;
//! K_s = 233 N/mm), not from the spec:
//!
//! * With the zero at a = f1(η) = e^{−ηT} (eq. 20) the loop of eq. 21 is K_EFF/(z − C_o) with
//!   K_EFF = K_F·(1 − C_o)/224 (the ZOH of eq. 14). The process zero at z = 1 (eq. 18) has
//!   cancelled the PI's integrator, so the loop is **type 0**: the closed loop
//!   K_EFF/(z − C_o + K_EFF) settles at F_r·K_F/(K_F + 224), **11.79 N at a 25 N
//!   reference**, for every η > 0. The paper reports adaptive means of 24.78-25.92 N at 25 N
//!   (Table 1) and asks for zero steady-state error; its own eqs. 14 and 21 do not give that
//!   (see the spec's doc comment). These tests assert the analysis, and print the paper's
//!   numbers beside qloop's.
//! * The zero cancels the process pole, which stays in the loop as a mode the controller
//!   cannot move: a disturbance of the process state decays at the open-loop rate η.
//! * The estimator's fixed point is the plant's own e^{−ηT} (the windowed data obey eq. 18
//!   exactly).
//!
//! Table 1 (the paper's 4.5 s records at 25 N, fixed gain vs adaptive on four steels) and
//! qloop's (`cargo test -p qloop-tests --test integration paper_grinding_adaptive:: -- --nocapture` prints
//! the table, the measured force as Table 1 gives it and the true force): on `noise` (0.5 N
//! sensor noise, η = 2 1/s) the adaptive loop has the smaller standard deviation and range of
//! the force, **in absolute terms, as the paper finds**, because its lower loop gain at DC
//! passes less of the sensor noise (both sds are the linear loops' noise transmission); but
//! it holds 11.8 N instead of 24.4 N, so relative to its level its spread is larger. On
//! `eta-varying` (η ×4 ramp, a step to ×¼, recovery; no noise) the adaptive loop has the
//! **larger** standard deviation and range once settled: each change of η moves the force
//! until the estimate follows, and what the estimator lag leaves in the process state decays
//! only at the cancelled rate η. So qloop's runs agree with the paper's finding on sensor
//! noise and disagree on process variation, and disagree with its mean force.

use qloop_plant::discrete::{exp_diff, zoh_first_order};
use qloop_plant::grinding::{scenario_named, Grinding, GrindingParams, STEP_AT_S};
use qloop_plant::{fixed_controller, metrics, reference_controller, run, RunConfig};
use qloop_plant::{Scenario, Trace};

/// The controller period: what the compiled controller reports (whole microseconds).
fn period() -> f64 {
    qloop_plant::controller::period_s(qloop_verified::grinding_adaptive_pzc::Controller::PERIOD_US)
}

/// The paper's design loop gain K_F = 203·K_s·K_PROP = 200 1/s (eq. 5, text on Fig. 7).
const KF: f64 = 200.0;
/// The position-loop pole, 224 1/s (eq. 1).
const POLE: f64 = 224.0;
/// The plant's ADC step, N (12 bits over 0-100 N).
const LSB: f64 = 100.0 / 4096.0;
/// The `noise` scenario's sensor noise, N (1σ).
const NOISE_SIGMA: f64 = 0.5;
/// The paper's Table 1 (4.5 s records at 25 N): material, then mean, sd, max, min, range of
/// the normal force in N, fixed gain and adaptive.
const TABLE_1: [(&str, [f64; 5], [f64; 5]); 4] = [
    (
        "4142",
        [24.34, 1.060, 27.51, 20.43, 7.09],
        [25.18, 0.962, 27.88, 21.67, 6.21],
    ),
    (
        "A2",
        [26.06, 1.017, 29.48, 22.94, 6.54],
        [24.78, 0.975, 27.48, 21.94, 5.54],
    ),
    (
        "O1",
        [25.23, 0.900, 27.72, 21.11, 6.62],
        [25.52, 0.800, 27.66, 22.41, 5.25],
    ),
    (
        "8119",
        [25.57, 2.193, 31.11, 20.25, 10.86],
        [25.92, 1.979, 30.97, 21.17, 9.80],
    ),
];

/// C_o = e^{−224T} (eq. 17).
fn c0() -> f64 {
    zoh_first_order(203.0, POLE, period()).a1
}

/// K_EFFECTIVE (eq. 22) held at the ZOH of eq. 14's K_F/(s + 224): K_F·(1 − C_o)/224.
fn keff() -> f64 {
    KF * (1.0 - c0()) / POLE
}

/// The settled force of the cancelled, type-0 loop: F_r·K_EFF/(K_EFF + 1 − C_o) =
/// F_r·K_F/(K_F + 224) (module docs).
fn level(fr: f64) -> f64 {
    fr * KF / (KF + POLE)
}

/// The plant's zero distance 1 − a = 1 − e^{−ηT} (eq. 17).
fn b_of(eta: f64) -> f64 {
    1.0 - (-eta * period()).exp()
}

/// Runs the compiled adaptive controller and its f64 reference on the grinding plant.
fn adaptive(sc: &Scenario) -> Trace {
    run(
        &Grinding::new(GrindingParams::default()),
        fixed_controller!(qloop_verified::grinding_adaptive_pzc),
        reference_controller!(qloop_verified::grinding_adaptive_pzc_ref, period()),
        sc,
        RunConfig::default(),
    )
    .expect("run")
}

/// Runs the compiled fixed-gain PI (`grinding_pi.qloop`, eq. 8) and its f64 reference.
fn fixed_pi(sc: &Scenario) -> Trace {
    run(
        &Grinding::new(GrindingParams::default()),
        fixed_controller!(qloop_verified::grinding_pi),
        reference_controller!(qloop_verified::grinding_pi_ref, period()),
        sc,
        RunConfig::default(),
    )
    .expect("run")
}

/// The sampled closed loop in contact as a linear system with state (x, δ, I): the plant
/// advanced exactly over one period under the held command (eqs. 1, 11; eqs. 16-18 in
/// transfer-function form) and a PI x_d = I + k_p·E, I += k_i·E. For the adaptive controller
/// k_p = k_c·a and k_i = k_c·(1 − a) with the exact zero a = f1(η) and gain k_c = K_EFF/f2(η)
/// (the estimator and normaliser converged); for the fixed gain the PI of eq. 8. Perturbations
/// enter as the measurement error `nu` (N) and the rounding `ri`, `rp` (mm) of the integrator
/// and the command.
struct LinLoop {
    ks: f64,
    gp: f64,
    c0: f64,
    f1: f64,
    ed: f64,
    kp: f64,
    ki: f64,
}

impl LinLoop {
    fn plant(eta: f64, kp: f64, ki: f64) -> LinLoop {
        let t = period();
        LinLoop {
            ks: 233.0,
            gp: 203.0 / POLE,
            c0: c0(),
            f1: (-eta * t).exp(),
            ed: exp_diff(eta, POLE, t),
            kp,
            ki,
        }
    }

    /// The adaptive loop at η with exact cancellation: f2(η) = 203·K_s·ed (eq. 17).
    fn adaptive(eta: f64) -> LinLoop {
        let f2 = 203.0 * 233.0 * exp_diff(eta, POLE, period());
        let (kc, a) = (keff() / f2, (-eta * period()).exp());
        LinLoop::plant(eta, kc * a, kc * (1.0 - a))
    }

    /// The fixed-gain PI of eq. 8: K_PROP = K_F/(203·K_s), K_I·T = 100·K_PROP·T.
    fn fixed(eta: f64) -> LinLoop {
        let kp = KF / (203.0 * 233.0);
        LinLoop::plant(eta, kp, 100.0 * kp * period())
    }

    /// One period from state `s` with reference `fr`: returns the force measured at its
    /// start and the command issued.
    fn step(&self, s: &mut [f64; 3], fr: f64, nu: f64, ri: f64, rp: f64) -> (f64, f64) {
        let f = self.ks * s[1];
        let e = fr - (f + nu);
        s[2] += self.ki * e + ri;
        let u = s[2] + self.kp * e + rp;
        let c = s[0] - self.gp * u;
        s[1] = self.f1 * s[1] - POLE * c * self.ed;
        s[0] = self.gp * u + c * self.c0;
        (f, u)
    }

    /// Force samples of the response to a unit force-command step from rest.
    fn unit_step(&self, n: usize) -> Vec<f64> {
        let mut s = [0.0; 3];
        (0..n)
            .map(|_| self.step(&mut s, 1.0, 0.0, 0.0, 0.0).0)
            .collect()
    }

    /// The closed loop's roots in contact, where the process zero at z = 1 cancels the PI's
    /// pole: (z − f1)(z − C_o) + f2·((k_p + k_i)·z − k_p) = 0 with f2 = 203·K_s·ed (eq. 17).
    /// For the adaptive loop (k_p + k_i = k_c, k_p = k_c·f1) one root is f1, the cancelled
    /// process pole, and the other C_o − K_EFF.
    fn roots(&self) -> (f64, f64) {
        let g = 203.0 * self.ks * self.ed;
        let b = -(self.f1 + self.c0) + g * (self.kp + self.ki);
        let c = self.f1 * self.c0 - g * self.kp;
        let d = (b * b - 4.0 * c).sqrt();
        ((-b + d) / 2.0, (-b - d) / 2.0)
    }

    /// Force samples of the response to a unit measurement error in the first period.
    fn noise_impulse(&self, n: usize) -> Vec<f64> {
        let mut s = [0.0; 3];
        (0..n)
            .map(|k| {
                let nu = if k == 0 { 1.0 } else { 0.0 };
                self.step(&mut s, 0.0, nu, 0.0, 0.0);
                self.ks * s[1]
            })
            .collect()
    }

    /// ℓ1 norms over `n` periods of the force's impulse responses from `nu`, `ri`, `rp`.
    fn force_l1(&self, n: usize) -> [f64; 3] {
        let mut g = [0.0; 3];
        for (i, gi) in g.iter_mut().enumerate() {
            let mut s = [0.0; 3];
            for k in 0..n {
                let mut d = [0.0; 3];
                if k == 0 {
                    d[i] = 1.0;
                }
                self.step(&mut s, 0.0, d[0], d[1], d[2]);
                *gi += (self.ks * s[1]).abs();
            }
        }
        g
    }
}

/// Index of the first sample at or after `t0`.
fn first_at(t: &[f64], t0: f64) -> usize {
    t.iter().position(|&x| x >= t0 - 1e-12).expect("sample")
}

/// The samples of column `col` with t in [t0, t1).
fn window(tr: &Trace, col: &str, t0: f64, t1: f64) -> Vec<f64> {
    let (t, x) = (tr.col("t").unwrap(), tr.col(col).unwrap());
    t.iter()
        .zip(&x)
        .filter(|(&tk, _)| tk >= t0 - 1e-12 && tk < t1 - 1e-12)
        .map(|(_, &v)| v)
        .collect()
}

/// Table 1's statistics: mean, standard deviation, max, min, range.
fn stats(x: &[f64]) -> [f64; 5] {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let (lo, hi) = x
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    [mean, sd, hi, lo, hi - lo]
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// The standard error of the mean of a correlated record by batch means: the record cut into
/// 10 consecutive batches (each far longer than the loop's correlation time), the standard
/// deviation of their means over √10.
fn batch_se(x: &[f64]) -> f64 {
    let m = x.len() / 10;
    let means: Vec<f64> = (0..10).map(|i| mean(&x[i * m..(i + 1) * m])).collect();
    let mm = mean(&means);
    (means.iter().map(|v| (v - mm).powi(2)).sum::<f64>() / 9.0).sqrt() / 10f64.sqrt()
}

/// One-step error bound of a signal of the adaptive spec (the figures `qloop check` prints).
fn step_bound(name: &str) -> f64 {
    let p = qloop_tests::plan("grinding_adaptive_pzc");
    let i = p
        .prog
        .signals
        .iter()
        .position(|s| s.name == name)
        .expect("signal");
    p.summary[i].err
}

/// The zero's estimate 1 − â = b32/32 of a trace, fixed-point or f64 (`suffix` "" or "_ref").
fn b_hat(tr: &Trace, suffix: &str, t0: f64, t1: f64) -> Vec<f64> {
    window(tr, &format!("b32{suffix}"), t0, t1)
        .iter()
        .map(|v| v / 32.0)
        .collect()
}

/// The type-0 loop: on the noise-free Table 1 benchmark (20 N, then 25 N at 1 s; η = 2 1/s)
/// the force settles at F_r·K_F/(K_F + 224) before and after the step (9.43 N and 11.79 N,
/// where the paper measured 24.78-25.92 N at 25 N), never exceeds its final value (the closed
/// loop's only root, C_o − K_EFF = 0.260, is positive) and rises in the analytic time of the
/// cancelled loop, ±1 period. Tolerance for the level: one ADC step (the loop settles on the
/// quantised measurement) plus what the proved gain band |1 − k_c·f2/K_EFF| ≤ 2^-10 (property
/// `effective_gain_band`) can move it: ΔF = F·(1 − C_o)/(K_EFF + 1 − C_o)·2^-10.
#[test]
fn cancelled_loop_is_type_0_and_settles_at_the_analytic_level() {
    let sc = scenario_named("force-step").unwrap();
    let tr = adaptive(&sc);
    let k = keff();
    let band = |f: f64| f * (1.0 - c0()) / (k + 1.0 - c0()) * 2f64.powi(-10);
    let root = c0() - k;
    let y = LinLoop::adaptive(2.0).unit_step(200);
    let rise_k = y.iter().position(|&v| v >= 0.95 * y[199]).unwrap();
    eprintln!(
        "cancelled loop K_EFF/(z − C_o + K_EFF): K_EFF = {k:.4}, root {root:.3}, DC gain {:.4}; 95% rise {rise_k} periods",
        level(1.0)
    );
    assert!((y[199] - level(1.0)).abs() < 1e-9, "{}", y[199]);
    for (col, ctl) in [("force_n", "fixed-point"), ("force_n_ref", "f64")] {
        let before = mean(&window(&tr, col, 0.5, STEP_AT_S));
        let after = mean(&window(&tr, col, STEP_AT_S + 0.5, sc.duration_s));
        let (t, f) = (tr.col("t").unwrap(), tr.col(col).unwrap());
        let k0 = first_at(&t, STEP_AT_S);
        let rise = (k0..f.len())
            .find(|&j| f[j] - before >= 0.95 * (after - before))
            .unwrap()
            - k0;
        let peak = f[k0..].iter().copied().fold(f64::MIN, f64::max);
        eprintln!(
            "force-step, {ctl}: {before:.3} → {after:.3} N (analysis {:.3} → {:.3} N; paper's adaptive means at 25 N: 24.78-25.92 N), 95% rise {rise} periods = {:.4} s (analysis {rise_k}; paper 0.124-0.149 s), peak − final {:+.4} N",
            level(20.0),
            level(25.0),
            rise as f64 * period(),
            peak - after
        );
        assert!(
            (before - level(20.0)).abs() <= LSB + band(20.0),
            "{ctl}: {before}"
        );
        assert!(
            (after - level(25.0)).abs() <= LSB + band(25.0),
            "{ctl}: {after}"
        );
        assert!(rise.abs_diff(rise_k) <= 1, "{ctl}: {rise} vs {rise_k}");
        assert!(peak - after <= LSB, "{ctl}: overshoot {}", peak - after);
    }
    // The paper's Table 1 adaptive means are not the cancelled loop's.
    for (m, _, a) in TABLE_1 {
        assert!(a[0] - level(25.0) > 10.0, "{m}");
    }
}

/// The type-0 verdict does not depend on the gain. Eq. 21's loop K/(z − C_o) closed around a
/// unit feedback is y(k+1) = C_o·y(k) + K·(F_r − y(k)): it settles at F_r·K/(1 − C_o + K),
/// which grows with K. It has no overshoot only while its root C_o − K is not negative
/// (K ≤ C_o: at most F_r·C_o, 15.2 N at 25 N) and is stable only while |C_o − K| < 1
/// (K < 1 + C_o: below F_r·(1 + C_o)/2, 20.1 N). Table 1's adaptive means, 24.78-25.92 N at
/// 25 N, lie above both for every K: they cannot come from eqs. 19-22 as printed. Checked
/// against the recursion itself over a fine grid of K.
#[test]
fn no_gain_brings_the_cancelled_loop_to_the_papers_force() {
    let (co, fr) = (c0(), 25.0);
    let (no_overshoot, stable) = (fr * co, fr * (1.0 + co) / 2.0);
    eprintln!("C_o = {co:.4}: without overshoot at most {no_overshoot:.2} N, stable below {stable:.2} N at {fr} N");
    assert!((no_overshoot - 15.2).abs() < 0.05 && (stable - 20.1).abs() < 0.05);
    let mut best_monotone = 0.0f64;
    let mut best_stable = 0.0f64;
    for i in 1..400 {
        let k = (1.0 + co) * i as f64 / 400.0;
        let (mut y, mut peak) = (0.0f64, 0.0f64);
        for _ in 0..200_000 {
            y = co * y + k * (fr - y);
            peak = peak.max(y);
        }
        let settled = fr * k / (1.0 - co + k);
        assert!((y - settled).abs() < 1e-6, "K = {k}: {y} vs {settled}");
        best_stable = best_stable.max(y);
        if peak <= y + 1e-9 {
            best_monotone = best_monotone.max(y);
        }
    }
    assert!(best_monotone <= no_overshoot + 1e-9 && best_stable < stable);
    for (m, _, a) in TABLE_1 {
        assert!(a[0] > stable + 4.0, "{m}: {}", a[0]);
    }
}

/// The estimator's fixed point is the plant's own zero: on the noise-free runs, wherever η
/// has been constant for 0.5 s, the mean of 1 − â equals 1 − e^{−ηT} of the plant (2 1/s,
/// and 0.5 1/s on `eta-varying` after the η step), within the error budget of its fixed
/// point b̂ = s_q/s_w: the ADC's bias on the measured force (at most half a step, relative
/// ½·LSB/F), the rounding of F(k−1) and of s_w in the windowed w ((C_o·e_fp + e_sw)/w, with
/// w = (1 − C_o)·F), and the estimator's dead zone (an update below half an LSB of b32 is
/// lost: |b̂ − b| < e_b32/s_w). F is the analytic level. The f64 reference has only the ADC
/// term, and is held to the same budget.
#[test]
fn estimate_converges_to_the_plant_zero() {
    let (e_fp, e_sw, e_b32) = (step_bound("fp"), step_bound("sw"), step_bound("b32"));
    let cases = [
        ("force-step", 0.5, STEP_AT_S, 2.0, 20.0),
        ("force-step", STEP_AT_S + 0.5, 5.5, 2.0, 25.0),
        ("eta-varying", 0.5, STEP_AT_S, 2.0, 20.0),
        ("eta-varying", 3.5, 4.5, 0.5, 25.0),
    ];
    for (name, t0, t1, eta, fr) in cases {
        let tr = adaptive(&scenario_named(name).unwrap());
        let etas = window(&tr, "eta_1_s", t0 - 0.5, t1);
        assert!(etas.iter().all(|&e| (e - eta).abs() < 1e-12), "{name}");
        let f = level(fr);
        let w = (1.0 - c0()) * f;
        let b = b_of(eta);
        let tol = b * (0.5 * LSB / f + (c0() * e_fp + e_sw) / w) + e_b32 / w;
        for suffix in ["", "_ref"] {
            let m = mean(&b_hat(&tr, suffix, t0, t1));
            eprintln!(
                "{name} [{t0}, {t1}) s, η = {eta}: 1 − â = {m:.7}{suffix}, plant 1 − e^(−ηT) = {b:.7} ({:+.3}%), tolerance {:.3}%",
                (m / b - 1.0) * 100.0,
                tol / b * 100.0
            );
            assert!((m - b).abs() <= tol, "{name} {t0}{suffix}: {m} vs {b}");
        }
    }
}

/// η varying (`eta-varying`, no noise): the loop stays stable (no oscillating segment,
/// fixed-point or f64), and the pole-zero cancellation shows as a mode the controller cannot
/// move. After the step of η to 0.5 1/s at 3 s the estimate follows within 0.2 s, but what
/// the lag left in the process state then decays at the open-loop rate of the cancelled
/// pole, η: the force's distance from the level, fitted as an exponential over 3.3-4.4 s,
/// falls at η. Tolerance: the level is known to one ADC step plus the gain band (as in
/// `cancelled_loop_is_type_0_and_settles_at_the_analytic_level`); an error δ there moves
/// ln(F − level) by at most δ/(F − level) at each end of the fit, so the rate by at most
/// δ·(1/D_start + 1/D_end)/Δt.
#[test]
fn eta_step_leaves_the_cancelled_process_mode() {
    let sc = scenario_named("eta-varying").unwrap();
    let tr = adaptive(&sc);
    let m = metrics(
        &tr,
        "f",
        &|t| sc.value("fr", t, 25.0),
        &sc.breakpoints(),
        sc.duration_s,
        &["b32", "xd"],
    );
    assert!(m.fixed.stable(), "{:?}", m.fixed.first_oscillation());
    assert!(
        m.reference.stable(),
        "{:?}",
        m.reference.first_oscillation()
    );
    let eta = 0.5;
    let (t0, t1) = (3.3, 4.4);
    let lvl = level(25.0);
    let delta = LSB + lvl * (1.0 - c0()) / (keff() + 1.0 - c0()) * 2f64.powi(-10);
    let b_after = mean(&b_hat(&tr, "", 3.2, 3.3));
    for (col, ctl) in [("force_n", "fixed-point"), ("force_n_ref", "f64")] {
        let (t, f) = (window(&tr, "t", t0, t1), window(&tr, col, t0, t1));
        let y: Vec<f64> = f.iter().map(|v| (v - lvl).ln()).collect();
        let (mt, my) = (mean(&t), mean(&y));
        let slope = t
            .iter()
            .zip(&y)
            .map(|(a, b)| (a - mt) * (b - my))
            .sum::<f64>()
            / t.iter().map(|a| (a - mt).powi(2)).sum::<f64>();
        let (d0, d1) = (f[0] - lvl, f[f.len() - 1] - lvl);
        let tol = delta * (1.0 / d0 + 1.0 / d1) / (t1 - t0);
        eprintln!(
            "eta-varying, {ctl}: F − level {d0:.3} → {d1:.3} N over {t0}-{t1} s, decay rate {:.4} 1/s (η = {eta}, tolerance {tol:.4}); 1 − â at 3.2-3.3 s {b_after:.6} (plant {:.6})",
            -slope,
            b_of(eta)
        );
        assert!((-slope - eta).abs() <= tol, "{ctl}: {}", -slope);
    }
}

/// Table 1, in the paper's form, for both controllers on `noise` and `eta-varying`: the mean,
/// standard deviation, max, min and range of the normal force over the 4.5 s record from the
/// 20 → 25 N step (the paper's record: its minima of 20.25-22.94 N include the step), and the
/// same over the settled part (0.5 s after the step on). Printed with the paper's rows; the
/// assertions are on the settled part against the analysis:
///
/// * `noise`, means: the adaptive loop's settled mean true force is the type-0 level
///   F_r·K_F/(K_F + 224), and the fixed PI's is its standing-error level
///   F_r − F_r·224η/(α·K_F + 224η) (`grinding_pi.qloop`), each within three batch-means
///   standard errors plus one ADC step.
/// * `noise`, standard deviations: each loop's true force varies as its linear loop passes the
///   sensor noise (σ = 0.5 N, plus the ADC's LSB²/12): sd = σ·‖h_ν→F‖₂, within 3 standard
///   errors of a sample sd, sd·√((1 + ρ²)/(2N(1 − ρ²))), with ρ the loop's slowest root that
///   the noise excites. For the adaptive loop this is the cancelled loop's analysis: what the
///   estimator adds to the spread (its estimate moves with the noise) is not in it, and the
///   check is that it stays within the tolerance. The adaptive loop's sd is the smaller:
///   0.181 against 0.233 N.
/// * `noise`, range: smaller for the adaptive loop (it follows the sd: extremes of ~2000
///   near-Gaussian samples are ≈ ±3.3 sd).
/// * `eta-varying`: the adaptive loop's settled sd and range are the larger (the estimator
///   lag and the cancelled mode, `eta_step_leaves_the_cancelled_process_mode`).
#[test]
fn table_1_statistics_fixed_gain_and_adaptive() {
    let hdr = "case                 |  mean N |   sd N |  max N |  min N | range N";
    let row = |name: &str, s: [f64; 5]| {
        format!(
            "{name:<20} | {:7.2} | {:6.3} | {:6.2} | {:6.2} | {:7.2}",
            s[0], s[1], s[2], s[3], s[4]
        )
    };
    eprintln!("Table 1 (Jenkins & Kurfess), 4.5 s records at 25 N:\n{hdr}");
    for (m, f, a) in TABLE_1 {
        eprintln!("{}", row(&format!("paper fixed {m}"), f));
        eprintln!("{}", row(&format!("paper adaptive {m}"), a));
    }
    let mut settled = Vec::new();
    for name in ["noise", "eta-varying"] {
        let sc = scenario_named(name).unwrap();
        let runs = [("fixed", fixed_pi(&sc)), ("adaptive", adaptive(&sc))];
        eprintln!("qloop `{name}`:\n{hdr}");
        for (ctl, tr) in &runs {
            for (col, what) in [("f", "measured"), ("force_n", "true")] {
                let rec = stats(&window(tr, col, STEP_AT_S, STEP_AT_S + 4.5));
                let set = stats(&window(tr, col, STEP_AT_S + 0.5, STEP_AT_S + 4.5));
                eprintln!("{}", row(&format!("{ctl} {what}"), rec));
                eprintln!("{}", row("  settled", set));
                if col == "force_n" {
                    eprintln!("  settled sd/mean {:.2}%", 100.0 * set[1] / set[0]);
                }
            }
            let x = window(tr, "force_n", STEP_AT_S + 0.5, STEP_AT_S + 4.5);
            settled.push((name, *ctl, stats(&x), batch_se(&x), x.len() as f64));
        }
    }
    let get = |name: &str, ctl: &str| {
        settled
            .iter()
            .find(|s| s.0 == name && s.1 == ctl)
            .map(|s| (s.2, s.3, s.4))
            .unwrap()
    };
    // `noise`: the means.
    let eta = GrindingParams::default().eta_1_s;
    let pi_level = 25.0 - 25.0 * 224.0 * eta / (100.0 * KF + 224.0 * eta);
    for (ctl, expected) in [("adaptive", level(25.0)), ("fixed", pi_level)] {
        let (s, se, _) = get("noise", ctl);
        let tol = 3.0 * se + LSB;
        eprintln!(
            "noise, {ctl}: settled mean {:.4} N, analysis {expected:.4} N, tolerance {tol:.4} N",
            s[0]
        );
        assert!(
            (s[0] - expected).abs() <= tol,
            "{ctl}: {} vs {expected}",
            s[0]
        );
    }
    // `noise`: the standard deviations against the linear loops' noise transmission.
    let sigma = (NOISE_SIGMA.powi(2) + LSB * LSB / 12.0).sqrt();
    for (ctl, lin) in [
        ("adaptive", LinLoop::adaptive(eta)),
        ("fixed", LinLoop::fixed(eta)),
    ] {
        let h = lin.noise_impulse(20_000);
        let sd = sigma * h.iter().map(|v| v * v).sum::<f64>().sqrt();
        // The slowest root that the noise excites (the adaptive loop's other root, f1, is the
        // cancelled process pole: no path from the measurement reaches it).
        let (r1, r2) = lin.roots();
        let rho = if ctl == "adaptive" {
            c0() - keff()
        } else {
            r1.abs().max(r2.abs())
        };
        if ctl == "adaptive" {
            assert!(
                (r1 - lin.f1).abs().min((r2 - lin.f1).abs()) < 1e-9
                    && (r1 - rho).abs().min((r2 - rho).abs()) < 1e-9,
                "{r1} {r2}"
            );
        }
        let (s, _, n) = get("noise", ctl);
        let se = sd * ((1.0 + rho * rho) / (2.0 * n * (1.0 - rho * rho))).sqrt();
        eprintln!(
            "noise, {ctl}: settled sd {:.4} N, analysis {sd:.4} N (ρ = {rho:.3}, tolerance {:.4} N)",
            s[1],
            3.0 * se
        );
        assert!((s[1] - sd).abs() <= 3.0 * se, "{ctl}: {} vs {sd}", s[1]);
    }
    let ((a, ..), (f, ..)) = (get("noise", "adaptive"), get("noise", "fixed"));
    // Agrees with the paper in absolute terms: smaller sd and range ...
    assert!(a[1] < f[1] && a[4] < f[4], "{a:?} {f:?}");
    // ... but relative to the force it holds, the adaptive loop's spread is the larger.
    assert!(a[1] / a[0] > f[1] / f[0], "{a:?} {f:?}");
    // `eta-varying`: disagrees with the paper: larger sd and range once settled.
    let ((a, ..), (f, ..)) = (get("eta-varying", "adaptive"), get("eta-varying", "fixed"));
    eprintln!(
        "eta-varying settled: adaptive sd {:.3} N range {:.2} N, fixed sd {:.3} N range {:.2} N",
        a[1], a[4], f[1], f[4]
    );
    assert!(a[1] > f[1] && a[4] > f[4], "{a:?} {f:?}");
}

/// Fixed vs float, closed loop. Each period the two loops differ by the controller's
/// rounding (at most the one-step bounds e_I and e_xd of `qloop check`) and by their ADC
/// readings (each within ½ LSB of its own plant's force, so at most 1 LSB apart beyond the
/// force difference itself). Linearised about exact cancellation, the force difference is then
/// at most ‖h_ν→F‖₁·LSB + ‖h_ri→F‖₁·e_I + ‖h_rp→F‖₁·e_xd over the run, at the η of the
/// scenario that makes it largest. The estimates 1 − â differ as their data do: at the
/// fixed point b̂ = b·F/F_measured (`estimate_converges_to_the_plant_zero`), by at most
/// b_max·(ΔF + LSB)/F_min (ΔF the force bound, F_min the lower level, 9.43 N), plus the
/// fixed-point estimator's own budget from that test; compared as means over 0.25 s windows
/// (the estimates dither with the ADC from sample to sample) that start 0.5 s or more after
/// the start and every breakpoint of the scenario. Derived bounds, not proofs: they leave
/// out the estimates' transients, the one-sided contact and the varying η.
#[test]
fn fixed_point_tracks_the_f64_reference() {
    let (e_i, e_xd) = (step_bound("xi"), step_bound("xd"));
    let (e_fp, e_sw, e_b32) = (step_bound("fp"), step_bound("sw"), step_bound("b32"));
    let (f_min, w_min) = (level(20.0), (1.0 - c0()) * level(20.0));
    eprintln!("one-step bounds: xi {e_i:.3e} mm, xd {e_xd:.3e} mm; ADC step {LSB:.4} N");
    for name in ["force-step", "eta-varying", "noise"] {
        let sc = scenario_named(name).unwrap();
        let tr = adaptive(&sc);
        let n = tr.rows.len();
        let factors: Vec<f64> = sc
            .channels
            .get("eta_factor")
            .map_or(vec![1.0], |s| s.0.iter().map(|p| p[1]).collect());
        let eta0 = GrindingParams::default().eta_1_s;
        let bound = factors
            .iter()
            .map(|f| {
                let g = LinLoop::adaptive(eta0 * f).force_l1(n);
                g[0] * LSB + g[1] * e_i + g[2] * e_xd
            })
            .fold(0.0, f64::max);
        let d = tr.fixed_vs_ref("force_n").unwrap();
        let worst = d.iter().copied().fold(0.0, f64::max);
        let b_max = factors.iter().map(|f| b_of(eta0 * f)).fold(0.0, f64::max);
        let db_bound =
            b_max * ((bound + LSB) / f_min + (c0() * e_fp + e_sw) / w_min) + e_b32 / w_min;
        let mut quiet = vec![0.0];
        quiet.extend(sc.breakpoints());
        let db = (0..(sc.duration_s / 0.25) as usize)
            .map(|j| j as f64 * 0.25)
            .filter(|&t| quiet.iter().all(|&b| !(b - 0.25..b + 0.5).contains(&t)))
            .map(|t| {
                let (x, y) = (b_hat(&tr, "", t, t + 0.25), b_hat(&tr, "_ref", t, t + 0.25));
                (mean(&x) - mean(&y)).abs()
            })
            .fold(0.0, f64::max);
        eprintln!(
            "{name}: max |fixed − f64| of the force {worst:.4} N, bound {bound:.4} N; of 1 − â (0.25 s means) {db:.2e}, bound {db_bound:.2e}"
        );
        assert!(worst <= bound, "{name}: {worst} > {bound}");
        assert!(db <= db_bound, "{name}: {db} > {db_bound}");
    }
}
