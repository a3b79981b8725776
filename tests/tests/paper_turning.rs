//! Reproduces Koren & Masory (1981) on the turning plant, running the *compiled* seed
//! controllers of `qloop-verified` and their f64 references (Koren & Masory 1981,
//! Figs. 5-7 and the text on them).

use qloop_plant::turning::{scenario_named, scenarios, Turning, TurningParams};
use qloop_plant::{
    fixed_controller, metrics, reference_controller, run, Controller, Metrics, RunConfig, Trace,
};

/// Runs a seed controller (compiled fixed-point and f64 reference) on the turning plant.
fn turning(
    sc: &str,
    fixed: Box<dyn Controller + Send>,
    reference: Box<dyn Controller + Send>,
    signals: &[&str],
) -> (Trace, Metrics) {
    let sc = scenario_named(sc).expect("scenario");
    let plant = Turning::new(TurningParams::default());
    let trace = run(&plant, fixed, reference, &sc, RunConfig::default()).expect("run");
    let m = metrics(
        &trace,
        "fc",
        &|_| 1.5,
        &sc.breakpoints(),
        sc.duration_s,
        signals,
    );
    (trace, m)
}

fn variable_gain(sc: &str) -> (Trace, Metrics) {
    turning(
        sc,
        fixed_controller!(qloop_verified::koren_masory_1981),
        reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
        &["km", "kc", "u", "feed"],
    )
}

fn conventional(sc: &str) -> (Trace, Metrics) {
    turning(
        sc,
        fixed_controller!(qloop_verified::acc_fixed_gain),
        reference_controller!(qloop_verified::acc_fixed_gain_ref, 0.1),
        &["u", "vf"],
    )
}

/// Every turning scenario.
fn scenario_names() -> Vec<String> {
    scenarios().into_iter().map(|s| s.name).collect()
}

/// Mean of column `c` over `[t0, t1)`.
fn mean(tr: &Trace, c: &str, t0: f64, t1: f64) -> f64 {
    let (t, x) = (tr.col("t").unwrap(), tr.col(c).unwrap());
    let v: Vec<f64> = t
        .iter()
        .zip(&x)
        .filter(|(t, _)| **t >= t0 && **t < t1)
        .map(|(_, x)| *x)
        .collect();
    v.iter().sum::<f64>() / v.len() as f64
}

/// Koren & Masory (1981), text on Fig. 5b: K_c adapts 1.5 → 0.52 → 0.33 at 2 → 4 → 6 mm. The plant's K_s is
/// calibrated once, at 2 mm (to K_c = 1.5); the 4 and 6 mm values come out of the force model
/// F = K_s·a·f^u and must be within 15% of the paper's.
#[test]
fn variable_gain_kc_follows_the_paper_at_2_4_6_mm() {
    let (tr, m) = variable_gain("depth-steps");
    // Segments: 2 mm [1, 16), 4 mm [16, 31), 6 mm [31, 46): the last 3 s of each.
    for (t1, paper, tol) in [(16.0, 1.5, 0.02), (31.0, 0.52, 0.15), (46.0, 0.33, 0.15)] {
        let kc = mean(&tr, "kc", t1 - 3.0, t1);
        let rel = (kc - paper) / paper;
        eprintln!(
            "K_c before t = {t1} s: {kc:.3} (paper {paper}, {:+.1}%)",
            rel * 100.0
        );
        assert!(rel.abs() <= tol, "K_c = {kc} vs paper {paper}");
        // The f64 reference agrees.
        let kr = mean(&tr, "kc_ref", t1 - 3.0, t1);
        assert!(((kr - paper) / paper).abs() <= tol, "reference K_c = {kr}");
    }
    // And the force is held at F_r = 1.5 kN in every cutting segment.
    for s in m.fixed.segments.iter().filter(|s| s.cutting) {
        assert!(s.ss_error.abs() < 0.01, "{s:?}");
        assert!(!s.oscillating, "{s:?}");
    }
}

/// How close any force exponent can bring the plant to the paper's K_c values. At the
/// reference force the feed is U ∝ a^(−1/u) (F = K_s·a·f^u = F_r), the estimate K_m ≈ F_r/U
/// ∝ a^(1/u), and K_c = K/K_m ∝ a^(−1/u): so K_c(4 mm)/K_c(2 mm) = 2^(−1/u) and
/// K_c(6 mm)/K_c(2 mm) = 3^(−1/u). The paper's 1.5 → 0.52 → 0.33 asks for 1/u = 1.53 from the
/// first ratio and 1.38 from the second; the best single exponent (u = 0.695) still misses both
/// by 6.4 %. u = 0.70 gives 0.557 / 0.312 with a stability limit 1/u = 1.43; the plant's
/// u = 0.74 gives 0.588 / 0.340 and puts the limit at 1.35, next to the paper's 1.33: the plant
/// matches the limit and accepts +13 % at 4 mm. The simulated K_c follows this closed form.
#[test]
fn no_single_force_exponent_gives_both_of_the_papers_kc_values() {
    let (k2, k4, k6) = (1.5f64, 0.52f64, 0.33f64);
    let from4 = (k2 / k4).log2();
    let from6 = (k2 / k6).ln() / 3f64.ln();
    assert!(
        (from4 - 1.53).abs() < 0.005 && (from6 - 1.38).abs() < 0.005,
        "{from4} {from6}"
    );
    // The relative misses at 4 and 6 mm of an exponent 1/x: decreasing in x, so the best
    // single x is where they are equal and opposite (bisection).
    let miss = |x: f64| (k2 * 2f64.powf(-x) / k4 - 1.0, k2 * 3f64.powf(-x) / k6 - 1.0);
    let (mut lo, mut hi) = (from6, from4);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        let (a, b) = miss(mid);
        if a + b > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (a, b) = miss(lo);
    eprintln!(
        "best single exponent u = {:.4}: {:+.1} % at 4 mm, {:+.1} % at 6 mm",
        1.0 / lo,
        a * 100.0,
        b * 100.0
    );
    assert!((1.0 / lo - 0.695).abs() < 0.001 && (a - 0.064).abs() < 0.001);
    let at = |u: f64| (k2 * 2f64.powf(-1.0 / u), k2 * 3f64.powf(-1.0 / u));
    let (a7, b7) = at(0.70);
    assert!(
        (a7 - 0.557).abs() < 5e-4 && (b7 - 0.312).abs() < 5e-4,
        "{a7} {b7}"
    );
    let u = qloop_plant::turning::TurningParams::default().u;
    assert_eq!(u, 0.74, "the plant's force exponent");
    let (a4, b6) = at(u);
    assert!(
        (a4 - 0.588).abs() < 5e-4 && (b6 - 0.340).abs() < 5e-4,
        "{a4} {b6}"
    );
    // The closed loop agrees with the closed form within 1 %.
    let (tr, _) = variable_gain("depth-steps");
    for (t1, want) in [(31.0, a4), (46.0, b6)] {
        let kc = mean(&tr, "kc", t1 - 3.0, t1);
        assert!(
            ((kc - want) / want).abs() < 0.01,
            "K_c {kc} before {t1} s, closed form {want}"
        );
    }
}

/// Koren & Masory (1981), Fig. 5a: the conventional ACC (K_c = 0.5) is stable at 2 and 4 mm and unstable at
/// 6 mm, oscillating at "approximately 2 Hz" (Koren's survey, text on Fig. 6).
#[test]
fn conventional_acc_goes_unstable_at_6_mm_only() {
    let (_, m) = conventional("depth-steps");
    let seg = |t0: f64| {
        m.fixed
            .segments
            .iter()
            .find(|s| s.span.0 == t0)
            .expect("segment")
            .clone()
    };
    assert!(
        !seg(1.0).oscillating && seg(1.0).cutting,
        "2 mm: {:?}",
        seg(1.0)
    );
    assert!(!seg(16.0).oscillating, "4 mm: {:?}", seg(16.0));
    let s6 = seg(31.0);
    assert!(s6.oscillating, "6 mm: {s6:?}");
    eprintln!(
        "conventional at 6 mm: {:.2} Hz, amplitude {:.2} kN",
        s6.osc_hz, s6.osc_amplitude
    );
    assert!((1.5..=2.5).contains(&s6.osc_hz), "{} Hz", s6.osc_hz);
    // The f64 reference loop agrees on the verdict.
    assert!(m
        .reference
        .segments
        .iter()
        .any(|s| s.span.0 == 31.0 && s.oscillating));
}

/// Koren & Masory (1981), Figs. 6-7: the conventional loop goes unstable on the depth ramp and after the
/// spindle-speed drop; the variable-gain loop stays stable on every scenario.
#[test]
fn variable_gain_stays_stable_where_the_conventional_does_not() {
    for sc in ["depth-ramp", "speed-drop"] {
        let (_, conv) = conventional(sc);
        assert!(!conv.fixed.stable(), "{sc}: conventional should oscillate");
    }
    for sc in scenario_names() {
        let (_, vg) = variable_gain(&sc);
        assert!(
            vg.fixed.stable(),
            "{sc}: {:?}",
            vg.fixed.first_oscillation()
        );
        assert!(vg.reference.stable(), "{sc}: reference");
    }
}

/// Per-step error bound of each state, from the compiler's one-step error analysis (the
/// figures `qloop check` prints).
fn step_bounds(stem: &str) -> Vec<(String, f64)> {
    let p = qloop_tests::plan(stem);
    p.prog
        .signals
        .iter()
        .enumerate()
        .filter(|(_, s)| s.kind == qloop::ir::SigKind::State)
        .map(|(i, s)| (s.name.clone(), p.summary[i].err))
        .collect()
}

/// Fixed vs float, closed loop: on every scenario the fixed-point trace of each state stays
/// within `e/(1 − ρ)` of the f64 trace, where `e` is the state's one-step error bound from
/// `qloop check` and `ρ` its per-step contraction: the proved `estimator_contraction` factor
/// (253/256) for K_m, the proved `gain_loop_contraction` factor (15/16) for K_c, and for U the
/// feed loop's linearised pole radius √(u·K) = √(0.74·1.25). A derived bound, not a proof:
/// the plant is non-linear and the loops are coupled. The last 10% of each run must respect
/// it too (no divergence).
#[test]
fn fixed_point_tracks_the_f64_reference_within_the_derived_bound() {
    let rho = [
        ("km", 253.0 / 256.0),
        ("kc", 15.0 / 16.0),
        ("u", (TurningParams::default().u * 1.25).sqrt()),
    ];
    let bounds = step_bounds("koren_masory_1981");
    for sc in scenario_names() {
        let (tr, _) = variable_gain(&sc);
        for (name, r) in rho {
            let e = bounds.iter().find(|(n, _)| n == name).expect("state").1;
            let bound = e / (1.0 - r);
            let d = tr.fixed_vs_ref(name).unwrap();
            let worst = d.iter().copied().fold(0.0, f64::max);
            let tail = d[d.len() * 9 / 10..].iter().copied().fold(0.0, f64::max);
            eprintln!(
                "{sc} {name}: max |fixed − f64| = {worst:.2e} (tail {tail:.2e}), bound {bound:.2e}"
            );
            assert!(worst <= bound, "{sc} {name}: {worst} > {bound}");
            assert!(tail <= bound, "{sc} {name}: diverging");
        }
    }
}
