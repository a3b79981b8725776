//! Issue 18, item 5 (first part): the turning plant's fault scenarios, run with the tuned 1981
//! controller compiled by `controller!`, which has **no safety rules**. The states stay in
//! their declared ranges through every fault (saturation makes that so), but the faults do
//! what a machinist fears: a dropped-out sensor reads as an air cut, and the feed runs to its
//! ceiling while the tool is in the work. These tests pin that behaviour down; the safe spec
//! (item 4) must change it.

use qloop_plant::turning::{fault_scenarios, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, RunConfig, Trace};

/// The fault scenario `name` run with a controller and its f64 reference.
fn run_fault(
    name: &str,
    fixed: Box<dyn qloop_plant::Controller>,
    reference: Box<dyn qloop_plant::Controller>,
) -> Trace {
    let sc = fault_scenarios()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap();
    run(
        &Turning::new(TurningParams::default()),
        fixed,
        reference,
        &sc,
        RunConfig::default(),
    )
    .unwrap()
}

/// The tuned controller, without rules.
fn faulted(name: &str) -> Trace {
    run_fault(
        name,
        fixed_controller!(qloop_verified::koren_masory_tuned),
        reference_controller!(qloop_verified::koren_masory_tuned_ref, 0.1),
    )
}

/// The values of column `c` at times in `[t0, t1)`.
fn during(tr: &Trace, c: &str, t0: f64, t1: f64) -> Vec<f64> {
    let t = tr.col("t").unwrap();
    let x = tr.col(c).unwrap();
    t.iter()
        .zip(x)
        .filter(|(t, _)| **t >= t0 && **t < t1)
        .map(|(_, x)| x)
        .collect()
}

#[test]
fn states_stay_in_range_through_every_fault() {
    // The declared ranges of koren_masory_tuned (K = 0.2: kc in [K/6, K/0.25]).
    let ranges = [
        ("km", 0.25, 6.0),
        ("kc", 0.2 / 6.0, 0.8),
        ("u", 0.05, 5.0),
        ("feed", 0.05, 5.0),
    ];
    for sc in fault_scenarios() {
        let tr = faulted(&sc.name);
        for (c, lo, hi) in ranges {
            for v in tr.col(c).unwrap() {
                // One LSB of slack for the quantised bounds (Q12 or Q15).
                assert!(
                    v >= lo - 2.5e-4 && v <= hi + 2.5e-4,
                    "{}: {c} = {v} outside [{lo}, {hi}]",
                    sc.name
                );
            }
        }
    }
}

#[test]
fn without_rules_a_sensor_dropout_runs_the_feed_to_its_ceiling_in_the_cut() {
    let tr = faulted("sensor-dropout");
    // Healthy before the fault: holding 1.5 kN at 3 mm.
    let before = during(&tr, "force_n", 8.0, 10.0);
    assert!(
        before.iter().all(|f| (f - 1500.0).abs() < 80.0),
        "{before:?}"
    );
    // The sensor reads 0 from 10 s: the loop sees an air cut and speeds up to 5 mm/s while
    // the true force climbs far past the reference.
    let feed = during(&tr, "feed", 15.0, 20.0);
    assert!(feed.iter().all(|f| *f > 4.99), "{feed:?}");
    let force = during(&tr, "force_n", 15.0, 20.0);
    assert!(force.iter().all(|f| *f > 2.0 * 1500.0), "{force:?}");
    // The estimator froze (air-cut rule of the 1981 spec), so the loop recovers after it.
    let after = during(&tr, "force_n", 27.0, 30.0);
    assert!(after.iter().all(|f| (f - 1500.0).abs() < 80.0), "{after:?}");
}

#[test]
fn without_rules_a_saturated_sensor_drives_the_feed_to_its_floor() {
    let tr = faulted("adc-saturation");
    let feed = during(&tr, "feed", 12.0, 14.0);
    assert!(feed.iter().all(|f| *f < 0.06), "{feed:?}");
}

// ---- The safe spec (issue 18, items 4 and 5): the same law with qloop's `feed_safety` rules.

/// FMAX, FMIN, the air-cut feed and the rules' counts in `koren_masory_safe.qloop`.
const FMAX: f64 = 4.0;
const FIDL: f64 = 1.0;
const N_OVERLOAD: f64 = 5.0;
const N_UNKNOWN: f64 = 10.0;
const PERIOD: f64 = 0.1;

fn safe(name: &str) -> Trace {
    run_fault(
        name,
        fixed_controller!(qloop_verified::koren_masory_safe),
        reference_controller!(qloop_verified::koren_masory_safe_ref, 0.1),
    )
}

/// The first time the feed hold is set, if it is.
fn hold_at(tr: &Trace) -> Option<f64> {
    let t = tr.col("t").unwrap();
    let h = tr.col("feed_hold").unwrap();
    t.iter().zip(h).find(|(_, h)| *h > 0.5).map(|(t, _)| *t)
}

/// The fault code at the end of the run.
fn fault_code(tr: &Trace) -> f64 {
    *tr.col("fault").unwrap().last().unwrap()
}

#[test]
fn with_the_rules_states_stay_in_range_and_the_feed_never_exceeds_fmax() {
    let ranges = [
        ("km", 0.25, 6.0),
        ("kc", 0.2 / 6.0, 0.8),
        ("u", 0.05, 5.0),
        ("held", 0.0, 1.0),
        ("fault_code", 0.0, 3.0),
        ("overload_count", 0.0, N_OVERLOAD),
        ("unknown_load_stale", 0.0, N_UNKNOWN),
        ("feed", 0.0, FMAX),
    ];
    for sc in fault_scenarios() {
        let tr = safe(&sc.name);
        for (c, lo, hi) in ranges {
            for v in tr.col(c).unwrap() {
                assert!(
                    v >= lo - 2.5e-4 && v <= hi + 2.5e-4,
                    "{}: {c} = {v} outside [{lo}, {hi}]",
                    sc.name
                );
            }
        }
        // Healthy before the fault: no hold in the first 10 s (approach, engagement, a
        // noisy steady cut that the stuck-sensor rule must not mistake for a stuck one).
        if let Some(t) = hold_at(&tr) {
            assert!(t >= 10.0, "{}: hold at {t} s before the fault", sc.name);
        }
        // Once held, the feed is 0 to the end.
        if let Some(t) = hold_at(&tr) {
            let feed = during(&tr, "feed", t + PERIOD, 30.0);
            assert!(feed.iter().all(|f| *f == 0.0), "{}: {feed:?}", sc.name);
        }
    }
}

#[test]
fn with_the_rules_a_stuck_sensor_holds_the_feed_within_its_periods() {
    let tr = safe("stuck-sensor");
    let t = hold_at(&tr).expect("held");
    // The reading freezes at 10 s; the 10th unchanged reading sets the hold (one more
    // period for the sample that first repeats, one for the output's sample).
    assert!(
        t <= 10.0 + (N_UNKNOWN + 2.0) * PERIOD + 1e-9,
        "hold at {t} s"
    );
    assert_eq!(fault_code(&tr), 3.0);
}

#[test]
fn with_the_rules_a_saturated_sensor_holds_the_feed_within_its_periods() {
    let tr = safe("adc-saturation");
    let t = hold_at(&tr).expect("held");
    // The reading is at full scale (5 kN) from 10 s. The law (K_c·(F_r − 5 kN), about
    // −0.5 mm/s a period) and the back-off take the command from about 1 mm/s below FMIN
    // (1/8 mm/s) on the 3rd period, and FMIN holds the feed (fault 1) before the overload
    // count reaches its 5.
    assert!(
        t <= 10.0 + (N_OVERLOAD + 2.0) * PERIOD + 1e-9,
        "hold at {t} s"
    );
    assert_eq!(fault_code(&tr), 1.0);
}

#[test]
fn with_the_rules_a_sensor_dropout_runs_at_the_air_cut_feed_not_the_ceiling() {
    let tr = safe("sensor-dropout");
    // The reading is 0 from 10 to 20 s: an air cut to the rules, so the feed goes to FIDL
    // (1 mm/s) at once, and the true force stays near the reference instead of passing 3 kN.
    let feed = during(&tr, "feed", 10.3, 20.0);
    assert!(feed.iter().all(|f| (f - FIDL).abs() < 1e-3), "{feed:?}");
    let force = during(&tr, "force_n", 10.5, 20.0);
    assert!(force.iter().all(|f| *f < 1.2 * 1500.0), "{force:?}");
    assert_eq!(hold_at(&tr), None);
}

/// The feed and the reading at each period: (t, reading, feed, u).
fn rows(tr: &Trace) -> Vec<(f64, f64, f64, f64)> {
    let c = |n: &str| tr.col(n).unwrap();
    let (t, fc, feed, u) = (c("t"), c("fc"), c("feed"), c("u"));
    (0..t.len()).map(|k| (t[k], fc[k], feed[k], u[k])).collect()
}

/// Speed-up at most UP = 1/8 mm/s per period (the back-off rule's proved property), checked
/// on the compiled controller's trace.
fn speed_up_is_limited(name: &str, tr: &Trace) {
    for w in rows(tr).windows(2) {
        let ((_, _, _, u0), (t, _, _, u1)) = (w[0], w[1]);
        assert!(
            u1 - u0 <= 0.125 + 1e-9,
            "{name}: u rose {} at {t} s",
            u1 - u0
        );
    }
}

#[test]
fn with_the_rules_a_breaking_tool_backs_the_feed_off_at_every_spike() {
    let tr = safe("tool-breakage");
    speed_up_is_limited("tool-breakage", &tr);
    let mut spikes = 0;
    for w in rows(&tr).windows(2) {
        let ((_, _, _, u0), (t, fc, _, u1)) = (w[0], w[1]);
        // A reading above LOAD = 2 kN: the command falls by at least K·UP = 1/4 mm/s (it
        // starts well above the floor's 1/4 margin here).
        if fc > 2.0 && u0 >= 0.05 + 0.25 {
            spikes += 1;
            assert!(u1 <= u0 - 0.25 + 1e-9, "fell {} at {t} s", u0 - u1);
        }
    }
    // Two spikes a second for 4 s.
    assert!(spikes >= 8, "{spikes} spikes seen");
    assert_eq!(hold_at(&tr), None);
}

#[test]
fn with_the_rules_a_noise_burst_neither_holds_nor_speeds_up_fast() {
    let tr = safe("noise-burst");
    speed_up_is_limited("noise-burst", &tr);
    assert_eq!(hold_at(&tr), None);
    // The true force stays within 60 % of the reference through the burst.
    let force = during(&tr, "force_n", 10.0, 14.0);
    assert!(force.iter().all(|f| *f < 1.6 * 1500.0), "{force:?}");
}

#[test]
fn with_the_rules_a_spindle_stall_holds_the_feed() {
    let tr = safe("spindle-stall");
    // The spindle falls to 30 % in 0.2 s from 10 s: the chip thickens and the force rises;
    // the law and the back-off cut the command below FMIN, which holds the feed (fault 1)
    // within half a second, before the true force reaches 2.5 times the reference.
    let t = hold_at(&tr).expect("held");
    assert!(t <= 10.5 + 1e-9, "hold at {t} s");
    assert_eq!(fault_code(&tr), 1.0);
    let force = tr.col("force_n").unwrap();
    let peak = force.iter().fold(0.0f64, |a, b| a.max(*b));
    assert!(peak < 2.5 * 1500.0, "peak {peak} N");
}
