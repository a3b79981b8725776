//! Issue 18, item 5 (first part): the turning plant's fault scenarios, run with the tuned 1981
//! controller compiled by `controller!`, which has **no safety rules**. The states stay in
//! their declared ranges through every fault (saturation makes that so), but the faults do
//! what a machinist fears: a dropped-out sensor reads as an air cut, and the feed runs to its
//! ceiling while the tool is in the work. These tests pin that behaviour down; the safe spec
//! (item 4) must change it.

use qloop_plant::turning::{fault_scenarios, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, RunConfig, Trace};

fn faulted(name: &str) -> Trace {
    let sc = fault_scenarios()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap();
    run(
        &Turning::new(TurningParams::default()),
        fixed_controller!(qloop_verified::koren_masory_tuned),
        reference_controller!(qloop_verified::koren_masory_tuned_ref, 0.1),
        &sc,
        RunConfig::default(),
    )
    .unwrap()
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
