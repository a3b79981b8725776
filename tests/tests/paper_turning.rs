//! Reproduces Koren & Masory (1981) on the turning plant, running the *compiled* seed
//! controllers of `qloop-verified` and their f64 references (000_b8cbacf29caa8fe2.txt,
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

/// 000, text on Fig. 5b: K_c adapts 1.5 → 0.52 → 0.33 at 2 → 4 → 6 mm. The plant's K_s is
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

/// 000 Fig. 5a: the conventional ACC (K_c = 0.5) is stable at 2 and 4 mm and unstable at
/// 6 mm, oscillating at "approximately 2 Hz" (002, text on Fig. 6).
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

/// 000 Figs. 6-7: the conventional loop goes unstable on the depth ramp and after the
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
