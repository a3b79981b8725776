//! The Koren & Masory (1981) adaptive ACC on the milling plant of Rubio & De la Sen
//! (Rubio & De la Sen): the *compiled* `milling_acc` controller of `qloop-verified` and
//! its f64 reference, through the work-piece profile of Rubio & De la Sen, Fig. 1 (b = 3 → 5 → 3 → 2 mm, see
//! `qloop_plant::milling::FIG1_PROFILE`) at F_r = 1.2 kN, T = 0.0839 s (Rubio & De la Sen, Sec. V).
//!
//! Truths the tests use, independent of the controller: the process gain
//! K_p = K_c·a·b/(N·n) of Rubio & De la Sen, eq. 3 (so the feed that holds F_r is F_r/K_p), the instant force
//! jump b₂/b₁ at a depth step, and Rubio & De la Sen's reference model G_m(s) = 98.62/(s² + 15.89s + 98.62).

use qloop_plant::milling::{scenario_named, scenarios, Milling, MillingParams, FIG1_PROFILE};
use qloop_plant::{
    fixed_controller, metrics, reference_controller, run, Metrics, Plant, RunConfig, Trace,
};

/// F_r (Rubio & De la Sen, Sec. V), kN.
const FR: f64 = 1.2;
/// The spec's loop gain K = K_c·K_m (`K_LOOP` in milling_acc.qloop).
const K_LOOP: f64 = 0.5;
/// The spec's feed limit (the range of `u` in milling_acc.qloop), mm/s.
const U_MAX: f64 = 32.0;

/// Runs the adaptive milling controller (fixed-point and f64) on `plant` through `sc`.
fn run_on(plant: &Milling, sc: &str) -> (Trace, Metrics) {
    let sc = scenario_named(sc).expect("scenario");
    let trace = run(
        plant,
        fixed_controller!(qloop_verified::milling_acc),
        reference_controller!(qloop_verified::milling_acc_ref, 0.0839),
        &sc,
        RunConfig::default(),
    )
    .expect("run");
    let m = metrics(
        &trace,
        "fc",
        &|_| FR,
        &sc.breakpoints(),
        sc.duration_s,
        &["km", "kc", "u", "feed"],
    );
    (trace, m)
}

fn adaptive(sc: &str) -> (Trace, Metrics) {
    run_on(&Milling::new(MillingParams::default()), sc)
}

/// Every milling scenario.
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
    assert!(!v.is_empty(), "no samples of {c} in [{t0}, {t1})");
    v.iter().sum::<f64>() / v.len() as f64
}

/// The value of column `c` at the first sample at or after `t0`.
fn first_after(tr: &Trace, c: &str, t0: f64) -> f64 {
    let (t, x) = (tr.col("t").unwrap(), tr.col(c).unwrap());
    x[t.iter().position(|t| *t >= t0).expect("sample")]
}

/// Fig. 1's segments as (start, end, depth b).
fn fig1_segments() -> Vec<(f64, f64, f64)> {
    let mut t = 0.0;
    FIG1_PROFILE
        .iter()
        .map(|&(b, len)| {
            let s = (t, t + len, b);
            t += len;
            s
        })
        .collect()
}

/// 5% settling time of Rubio & De la Sen's reference model G_m(s) = ω²/(s² + 2ζωs + ω²) (Sec. V:
/// ω² = 98.62, 2ζω = 15.89), from its closed-form unit-step response.
fn reference_model_settling() -> f64 {
    let w = 98.62f64.sqrt();
    let z = 15.89 / (2.0 * w);
    let wd = w * (1.0 - z * z).sqrt();
    let y = |t: f64| 1.0 - (-z * w * t).exp() * ((wd * t).cos() + z * w / wd * (wd * t).sin());
    // The last time |y − 1| > 5% on a 1 ms grid over 5 s (its envelope is below 10⁻¹⁶ there).
    let last = (0..5000)
        .map(|k| k as f64 * 1e-3)
        .filter(|t| (y(*t) - 1.0).abs() > 0.05)
        .fold(0.0, f64::max);
    last + 1e-3
}

/// Rubio & De la Sen, Sec. V: "the steady-state force tracks the reference force which is set to 1.2 KN,
/// except for the peaks appreciated when the axial depth of cut ... is suddenly altered".
/// After each depth step of Fig. 1 the adaptive loop must (a) enter and stay in the ±5% band
/// within twice the 5% settling time of Rubio & De la Sen's reference model G_m (the integral loop's poles
/// cannot be faster than √α = e^{-T/2τ_c} = 0.61 per period, G_m's are 0.51; a depth step
/// starts from up to 67% error), and (b) hold the *true* force (the plant's, not the sensor
/// reading) at F_r within 1.5 N over the last 20% of the segment: one ADC step (1.22 N, the
/// band in which an integral loop behind a quantising sensor may come to rest) plus the force
/// of one feed LSB, 2^-9 mm/s × K_p ≤ 0.13 kN·s/mm (0.25 N). The settled feed must be the one
/// eq. 3 predicts, F_r/K_p, within the same force tolerance over K_p.
#[test]
fn force_settles_to_1_2_kn_after_each_fig1_depth_step() {
    let (tr, m) = adaptive("depth-profile");
    let ts_model = reference_model_settling();
    eprintln!("G_m 5% settling time: {ts_model:.3} s");
    let p = MillingParams::default();
    let segs = fig1_segments();
    assert_eq!(m.fixed.segments.len(), segs.len());
    for ((t0, t1, b), s) in segs.into_iter().zip(&m.fixed.segments) {
        assert_eq!(s.span.0, t0);
        let tail = t1 - 0.2 * (t1 - t0);
        let force = mean(&tr, "force_n", tail, t1);
        let feed = mean(&tr, "feed_mm_s", tail, t1);
        let kp = p.process_gain(b, 1.0, 715.0);
        let feed_eq3 = FR / kp;
        eprintln!(
            "b = {b} mm [{t0:.2}, {t1:.2}): settled force {force:.2} N, feed {feed:.3} mm/s \
             (eq. 3: {feed_eq3:.3}), settling {:?} s, overshoot {:.1}%, sensor mean error {:+.2} N",
            s.settling_s,
            s.overshoot * 100.0,
            s.ss_error * 1000.0
        );
        assert!((force - 1000.0 * FR).abs() <= 1.5, "b = {b}: {force} N");
        assert!(
            (feed - feed_eq3).abs() <= 1.5e-3 / kp,
            "b = {b}: feed {feed} vs {feed_eq3}"
        );
        let settling = s.settling_s.expect("never settles");
        assert!(
            settling <= 2.0 * ts_model,
            "b = {b}: settles in {settling} s > 2 × {ts_model} s"
        );
        assert!(!s.oscillating, "{s:?}");
        // The f64 reference loop too.
        let force_ref = mean(&tr, "force_n_ref", tail, t1);
        assert!(
            (force_ref - 1000.0 * FR).abs() <= 1.5,
            "reference: {force_ref} N"
        );
    }
}

/// Rubio & De la Sen, Sec. V: "there are abruptly and oscillating overshoots in the output when the axial
/// depth of cut changes suddenly ... due to the intrinsic structure of the closed-loop". The
/// first sample after a step, before the controller can react, reads the settled force times
/// b₂/b₁ (eq. 3: K_p ∝ b): 2.0 kN at 3 → 5 mm, 0.72 kN at 5 → 3 and 0.8 kN at 3 → 2, within
/// 1% (the force before the step is F_r to 0.13%, previous test, and the feed has not moved:
/// the controller acts only at samples, and the sample comes 3 ms after the step).
#[test]
fn each_depth_step_gives_the_papers_peak() {
    let (tr, m) = adaptive("depth-profile");
    let segs = fig1_segments();
    for w in segs.windows(2) {
        let ((_, _, b1), (t0, _, b2)) = (w[0], w[1]);
        let expect = 1000.0 * FR * b2 / b1;
        let got = first_after(&tr, "force_n", t0);
        eprintln!(
            "step {b1} → {b2} mm at {t0:.2} s: first sample {got:.1} N (F_r·b₂/b₁ = {expect:.1} N)"
        );
        assert!((got - expect).abs() <= 0.01 * expect, "{got} vs {expect}");
    }
    // The step up overshoots by b₂/b₁ − 1 = 2/3; the loop then pulls it back into the band
    // (previous test), so the overshoot is the paper's "peak", not a divergence.
    let up = &m.fixed.segments[1];
    assert!((up.overshoot - 2.0 / 3.0).abs() < 0.01, "{up:?}");
}

/// The 1981 estimator (Koren & Masory 1981, eqs. 8-9) recovers Rubio & De la Sen's process gain K_p = K_c·a·b/(N·n)
/// (eq. 3) at every depth of Fig. 1, because the milling force is linear in the feed; the
/// gain loop (Koren & Masory 1981, eqs. 12-13) then holds K_c·K_m at K = 1/2. Tolerance: 1% of K_p (the
/// force tolerance of the settling test is 0.13%).
#[test]
fn estimator_recovers_the_process_gain_of_eq_3() {
    let (tr, _) = adaptive("depth-profile");
    for (t0, t1, b) in fig1_segments() {
        let tail = t1 - 0.2 * (t1 - t0);
        let kp = mean(&tr, "kp_kn_s_mm", tail, t1);
        let km = mean(&tr, "km", tail, t1);
        let kc = mean(&tr, "kc", tail, t1);
        eprintln!(
            "b = {b} mm: K_p = {kp:.5}, K_m = {km:.5} ({:+.2}%), K_c = {kc:.3}, K_c·K_m = {:.4}",
            (km / kp - 1.0) * 100.0,
            kc * km
        );
        assert!(
            (km / kp - 1.0).abs() < 0.01,
            "b = {b}: K_m {km} vs K_p {kp}"
        );
        assert!(
            (kc * km / K_LOOP - 1.0).abs() < 0.01,
            "b = {b}: {}",
            kc * km
        );
    }
}

/// The loop is stable on every milling scenario (fixed-point and f64) and settles in every
/// noise-free cutting segment. On the depth profile it is also stable at every corner of the
/// plant's uncertain-parameter box (`Plant::params`: K_c ±30%, τ_c from a tooth period to two
/// revolutions, τ_m up to 30 ms, sensor gain ±5%), where in every segment it settles the
/// measured force at F_r or, where holding F_r would take more than the feed limit
/// U_max = 32 mm/s (K_c −30% at 2 mm), at the force of U_max, g·K_p·U_max (g the sensor
/// gain): mean error below 1% of F_r.
#[test]
fn stable_on_every_scenario_and_parameter_corner() {
    for scenario in scenarios() {
        let sc = scenario.name;
        let (_, m) = adaptive(&sc);
        assert!(m.fixed.stable(), "{sc}: {:?}", m.fixed.first_oscillation());
        assert!(m.reference.stable(), "{sc}: reference");
        for s in m.fixed.segments.iter().filter(|s| s.cutting) {
            eprintln!(
                "{sc} [{:.2}, {:.2}): settling {:?} s, overshoot {:.1}%, mean error {:+.2} N, \
                 oscillation amplitude {:.1} N",
                s.span.0,
                s.span.1,
                s.settling_s,
                s.overshoot * 100.0,
                s.ss_error * 1000.0,
                s.osc_amplitude * 1000.0
            );
            // With sensor noise the reading's ±5% band is 1.5σ wide: the noise test checks
            // settling on the true force instead.
            if scenario.noise_sigma == 0.0 {
                assert!(s.settling_s.is_some(), "{sc}: {s:?}");
            }
        }
    }
    let nominal = Milling::new(MillingParams::default());
    let params = nominal.params();
    for corner in 0..1u32 << params.len() {
        let mut plant = nominal.clone();
        let mut set = Vec::new();
        for (i, p) in params.iter().enumerate() {
            let v = if corner >> i & 1 == 0 {
                p.range.0
            } else {
                p.range.1
            };
            plant.set_param(p.name, v).unwrap();
            set.push(format!("{}={v}", p.name));
        }
        let (_, m) = run_on(&plant, "depth-profile");
        assert!(
            m.fixed.stable(),
            "{set:?}: {:?}",
            m.fixed.first_oscillation()
        );
        let slowest = m
            .fixed
            .segments
            .iter()
            .filter_map(|s| s.settling_s)
            .fold(0.0, f64::max);
        eprintln!("{set:?}: slowest settling {slowest:.2} s");
        for ((_, _, b), s) in fig1_segments().into_iter().zip(&m.fixed.segments) {
            let at_limit = plant.p.sensor.gain * plant.p.process_gain(b, 1.0, 715.0) * U_MAX;
            let expect = FR.min(at_limit);
            let got = FR + s.ss_error;
            assert!(
                (got - expect).abs() < 0.01 * FR,
                "{set:?}, b = {b}: settled at {got} kN, expected {expect}"
            );
            if at_limit > FR {
                assert!(s.settling_s.is_some(), "{set:?}, b = {b}: {s:?}");
            }
        }
    }
}

/// With 40 N (1σ) sensor noise on the Fig. 1 profile, the *true* force (the plant's, not
/// the reading) still settles into ±5% of F_r in every segment, and the loop attenuates the
/// noise instead of amplifying it: the true force's oscillation amplitude (√2·RMS) stays
/// below the noise's own √2·σ. Linear analysis of the loop (K = 1/2, α = e^{-1}) gives a
/// noise-to-force H2 gain of 0.53, i.e. an expected amplitude of 30 N against the 57 N bound.
#[test]
fn sensor_noise_is_attenuated_on_the_fig1_profile() {
    let sc = scenario_named("noise").unwrap();
    let (tr, _) = adaptive("noise");
    let truth = metrics(
        &tr,
        "force_n",
        &|_| 1000.0 * FR,
        &sc.breakpoints(),
        sc.duration_s,
        &[],
    );
    let noise_amp = 2f64.sqrt() * sc.noise_sigma * 1000.0;
    assert_eq!(truth.fixed.segments.len(), FIG1_PROFILE.len());
    for s in &truth.fixed.segments {
        eprintln!(
            "noise, true force [{:.2}, {:.2}): settling {:?} s, amplitude {:.1} N (noise {noise_amp:.1} N), mean error {:+.1} N",
            s.span.0, s.span.1, s.settling_s, s.osc_amplitude, s.ss_error
        );
        assert!(s.settling_s.is_some() && !s.oscillating, "{s:?}");
        assert!(s.osc_amplitude < noise_amp, "{s:?}");
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
/// (63/64) for K_m, the proved `gain_loop_contraction` factor (15/16) for K_c, and for U the
/// feed loop's pole radius √α = e^{−T/(2τ_c)} (module docs of `qloop_plant::milling`). U
/// gets one more term: an integral loop behind a quantising sensor comes to rest anywhere in
/// a force band of one ADC step (the fixed loop, whose F_r is itself on the ADC's grid,
/// rests; the f64 loop hunts across a code boundary), so its feed is fixed only to within
/// LSB_ADC/K_p, largest at the smallest K_p of the scenarios (2 mm). A derived bound, not a
/// proof: the loops are coupled. The last 10% of each run must respect it too (no
/// divergence).
#[test]
fn fixed_point_tracks_the_f64_reference_within_the_derived_bound() {
    let p = MillingParams::default();
    let tau_c = p.tau_c_rev * 60.0 / p.n_rpm;
    let rho = [
        ("km", 63.0 / 64.0),
        ("kc", 15.0 / 16.0),
        ("u", (-0.0839 / (2.0 * tau_c)).exp()),
    ];
    let (lo, hi) = p.sensor.range;
    let adc_lsb = (hi - lo) / 2f64.powi(p.sensor.bits as i32);
    let bounds = step_bounds("milling_acc");
    for sc in scenario_names() {
        let (tr, _) = adaptive(&sc);
        let kp_min = tr
            .col("kp_kn_s_mm")
            .unwrap()
            .into_iter()
            .filter(|k| *k > 0.0)
            .fold(f64::INFINITY, f64::min);
        for (name, r) in rho {
            let e = bounds.iter().find(|(n, _)| n == name).expect("state").1;
            let dead_zone = if name == "u" { adc_lsb / kp_min } else { 0.0 };
            let bound = e / (1.0 - r) + dead_zone;
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
