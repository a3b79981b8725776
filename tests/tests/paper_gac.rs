//! Reproduces the geometric adaptive control (GAC) of the surface finish in Ulsoy & Koren's
//! survey (Koren's survey, eq. 29 and the text on Figs. 10-11) on the finishing
//! plant, running the *compiled* `verified/specs/gac_surface_finish.qloop` of
//! `qloop-verified` beside its f64 reference.
//!
//! The survey's four numbers (text on Figs. 10 and 11):
//! 1. Ra 1.5 µm is reached at f = 0.23 mm/rev with a new tool;
//! 2. a worn tool at the same feed gives about 3 µm;
//! 3. GAC brings the feed down to about 0.15 mm/rev and holds 1.5 µm with the worn tool;
//! 4. starting from 0.18 mm/rev, the target is reached within about 10 parts.
//!
//! Numbers 1 and 2 are properties of the plant (its coefficients are chosen to meet them,
//! `plant/src/finishing.rs`); they are re-checked here through the plant's API because the
//! closed-loop numbers rest on them. Numbers 3 and 4 are closed-loop results: their
//! tolerances are derived from the plant itself (one part's wear drift, the profilometer's
//! resolution and noise), not fitted to the runs.
//!
//! Time is in parts: the controller runs once a part (period 1 s, one part a second). Row k
//! of a trace is step k: the controller has read `ra`, the roughness of part k − 1, and
//! commanded `feed`, the feed of part k.

use qloop_plant::finishing::{scenarios, Finishing, FinishingParams};
use qloop_plant::{fixed_controller, reference_controller, run, RunConfig, Scenario, Trace};

/// The controller period, as the compiled controller reports it.
fn period() -> f64 {
    qloop_plant::controller::period_s(qloop_verified::gac_surface_finish::Controller::PERIOD_US)
}

fn scenario(name: &str) -> Scenario {
    scenarios().into_iter().find(|s| s.name == name).unwrap()
}

fn plant() -> Finishing {
    Finishing::new(FinishingParams::default())
}

/// The compiled GAC and its f64 reference on the finishing plant.
fn gac(sc: &Scenario) -> Trace {
    run(
        &plant(),
        fixed_controller!(qloop_verified::gac_surface_finish),
        reference_controller!(qloop_verified::gac_surface_finish_ref, period()),
        sc,
        RunConfig::default(),
    )
    .expect("run")
}

/// Per part n (from 0): (feed, true Ra) of the fixed-point loop, from the trace rows (the
/// plant's `ra_um` at row n + 1 is part n's roughness, before noise and quantisation).
fn parts(tr: &Trace) -> Vec<(f64, f64)> {
    let feed = tr.col("feed_mm_rev").unwrap();
    let ra = tr.col("ra_um").unwrap();
    (0..feed.len() - 1).map(|n| (feed[n], ra[n + 1])).collect()
}

/// The largest change of Ra from one part to the next that the tool's wear causes at a
/// fixed feed in [0.14, 0.24] mm/rev over parts `from..to`: how far a loop that corrects
/// fully each part can lag the target.
fn wear_drift(from: usize, to: usize) -> f64 {
    let p = plant();
    let mut worst: f64 = 0.0;
    for n in from..to {
        for i in 0..=100 {
            let f = 0.14 + 0.1 * i as f64 / 100.0;
            let d = p.roughness(n as f64 + 1.0, f) - p.roughness(n as f64, f);
            worst = worst.max(d.abs());
        }
    }
    worst
}

/// The fraction of the Newton step the spec takes each part (its `param STEP`).
const STEP: f64 = 0.5;

/// The profilometer's step (0-20 µm in 11 bits).
fn resolution() -> f64 {
    let s = FinishingParams::default().sensor;
    (s.range.1 - s.range.0) / f64::from(1u32 << s.bits)
}

#[test]
fn survey_numbers_1_and_2_new_and_worn_tool_at_a_fixed_feed() {
    let p = plant();
    let worn = FinishingParams::default().worn_at;
    // 1: a new tool holds Ra 1.5 µm at 0.23 mm/rev (Fig. 10a).
    assert!((p.roughness(0.0, 0.23) - 1.5).abs() < 1e-9);
    // 2: the worn tool at the same feed: 3 µm (Fig. 10b).
    assert!((p.roughness(worn, 0.23) - 3.0).abs() < 1e-9);
}

/// 4: from 0.18 mm/rev, the target within about 10 parts (text on Fig. 11: "the desired
/// surface finish (60 µinch) is achieved after 10 parts"). "Reached" is read as the first
/// part within ±0.1 µm of 1.5 µm, two standard deviations of the scenario's profilometer
/// noise (0.05 µm), and "about 10" as at most 10: a loop that gets there sooner meets the
/// claim. The run is the noisy `tool-life` scenario.
#[test]
fn survey_number_4_target_reached_within_about_ten_parts() {
    let sc = scenario("tool-life");
    let tr = gac(&sc);
    let ps = parts(&tr);
    assert!(
        (ps[0].0 - 0.18).abs() < 1e-6,
        "the first part at 0.18 mm/rev"
    );
    for (n, (f, ra)) in ps.iter().enumerate().take(14) {
        eprintln!("part {n:2}: feed {f:.4} mm/rev, Ra {ra:.3} µm");
    }
    let reached = ps.iter().position(|&(_, ra)| (ra - 1.5).abs() <= 0.1);
    eprintln!("target first reached at part {reached:?} (survey: after 10 parts)");
    assert!(reached.is_some_and(|n| n <= 10), "{reached:?}");
}

/// 3: the worn tool: GAC brings the feed down to about 0.15 mm/rev and holds 1.5 µm (Fig.
/// 10c; Fig. 11's steady region). On the noiseless `worn-tool` scenario, from part 10 until
/// the tool is worn (part 40):
/// * every part's Ra is within drift/STEP of 1.5 µm: the loop corrects the fraction STEP = 1/2
///   of the error each part (the spec's damped Newton step, through an estimated slope), so
///   against a wear ramp of `drift` per part it lags by drift/STEP; plus the profilometer's
///   step and 0.01 µm for the slope estimate's own error;
/// * the feed of the worn tool (parts 39-41, around `worn_at` = 40) is within the feed
///   change that the same drift allows, through the worn tool's slope dRa/df, of the feed
///   0.15 mm/rev that gives the worn tool 1.5 µm exactly (the plant's construction).
#[test]
fn survey_number_3_worn_tool_feed_about_0_15_holding_1_5() {
    let sc = scenario("worn-tool");
    let tr = gac(&sc);
    let ps = parts(&tr);
    let drift = wear_drift(10, 41);
    let tol = drift / STEP + 2.0 * resolution() + 0.01;
    let worst = ps[10..=40]
        .iter()
        .map(|&(_, ra)| (ra - 1.5).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "parts 10-40: worst |Ra - 1.5| = {worst:.4} µm (tolerance {tol:.4}: drift {drift:.4})"
    );
    assert!(worst <= tol, "{worst} > {tol}");
    let p = FinishingParams::default();
    let slope = p.c1_worn + 2.0 * p.c2_worn * 0.15;
    let ftol = tol / slope;
    for (n, &(f, ra)) in ps.iter().enumerate().take(42).skip(39) {
        eprintln!("part {n}: feed {f:.4} mm/rev, Ra {ra:.3} µm (survey: 0.15 mm/rev, 1.5 µm)");
        assert!((f - 0.15).abs() <= ftol, "part {n}: {f} vs 0.15 ± {ftol}");
    }
}

/// The fixed-point loop follows its f64 reference: the same feeds within the profilometer's
/// step carried through the slope (the two loops read the same plant, so a feed difference
/// shows up in the next part's Ra and is corrected), on the noiseless scenario.
#[test]
fn fixed_point_follows_the_f64_reference() {
    let sc = scenario("worn-tool");
    let tr = gac(&sc);
    let d = tr.fixed_vs_ref("feed").unwrap();
    let worst = d.iter().fold(0.0, |a: f64, &b| a.max(b));
    eprintln!("max |feed - feed_ref| = {worst:.3e} mm/rev");
    // Each step's error bound is 3e-6 mm/rev (`qloop check`); a quantisation step of the
    // measurement (0.01 µm) moves the feed by at most STEP·0.01 µm over the flattest slope
    // the loop clamps to (0.5 µm per unit of x = f/0.25).
    assert!(worst <= STEP * resolution() / 0.5 * 0.25 + 1e-5, "{worst}");
}
