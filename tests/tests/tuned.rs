//! Issue 18, item 2: the tuned 1981 controller (`verified/specs/koren_masory_tuned.qloop`,
//! written by `qloop tune`) meets its goals over the sweep envelope of the turning plant, run
//! as the *compiled* `qloop-verified` module: every draw of the plant's parameters (cutting
//! force exponent u ∈ [0.70, 0.85], specific force K_s ±30 %, servo lag, sensor gain) in the
//! depth-steps scenario (Koren & Masory 1981, Fig. 5) stays stable, does not ring, overshoots the reference by
//! at most 20 % after first reaching it, and settles within ±5 % in at most 3 s after every
//! depth step. The draws are not the tuner's (another seed, four times as many), and the
//! controller is the macro-compiled code, not the tuner's interpreter.
//!
//! The paper's tuning fails the same goals (K = 1.25 sits at 93 % of the stability limit), so
//! the test can fail.

use qloop_plant::metrics::metrics;
use qloop_plant::sweep::{draw, draw_seed, Envelope, Outcome};
use qloop_plant::turning::{scenario_named, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, Controller, RunConfig};

const DRAWS: u64 = 200;
const SEED: u64 = 2026;

/// The envelope of the depth-steps runs of a controller over `DRAWS` plant draws.
fn envelope(
    fixed: &dyn Fn() -> Box<dyn Controller + Send>,
    reference: &dyn Fn() -> Box<dyn Controller + Send>,
) -> (Envelope, (f64, f64)) {
    let nominal = Turning::new(TurningParams::default());
    let scs = vec![scenario_named("depth-steps").unwrap()];
    let mut env = Envelope::default();
    let mut u_span = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..DRAWS {
        let d = draw(&nominal, &scs, draw_seed(SEED, i)).unwrap();
        let u = d.params.iter().find(|p| p.0 == "u").unwrap().1;
        u_span = (u_span.0.min(u), u_span.1.max(u));
        let trace = run(
            d.plant.as_ref(),
            fixed(),
            reference(),
            &d.scenario,
            RunConfig::default(),
        )
        .unwrap();
        let m = metrics(
            &trace,
            "fc",
            &|_| 1.5,
            &d.scenario.breakpoints(),
            d.scenario.duration_s,
            &["km", "kc", "u", "feed"],
        );
        env.add(&Outcome::new(&d, &m));
    }
    (env, u_span)
}

#[test]
fn tuned_controller_meets_its_goals_over_the_sweep_envelope() {
    let (e, u) = envelope(
        &|| fixed_controller!(qloop_verified::koren_masory_tuned),
        &|| reference_controller!(qloop_verified::koren_masory_tuned_ref, 0.1),
    );
    // The draws cover the exponent's range.
    assert!(u.0 < 0.71 && u.1 > 0.84, "u drawn over {u:?}");
    assert_eq!((e.unstable, e.unstable_ref), (0, 0), "{e:#?}");
    assert_eq!(
        e.ringing, 0,
        "a draw rings after 3 s: {:?}",
        e.ringing_worst
    );
    let os = e.loop_overshoot.as_ref().unwrap();
    assert!(
        os.value <= 0.20,
        "loop overshoot {:.3} (seed {:#x})",
        os.value,
        os.outcome.seed
    );
    let st = e.settling_s.as_ref().unwrap();
    assert!(
        st.value <= 3.0,
        "settling {} s (seed {:#x})",
        st.value,
        st.outcome.seed
    );
    eprintln!(
        "tuned over {DRAWS} draws: loop overshoot ≤ {:.1}%, settling ≤ {:.2} s, rise ≤ {:.2} s, peak ≤ {:.0}%",
        100.0 * os.value,
        st.value,
        e.rise_s.as_ref().unwrap().value,
        100.0 * e.overshoot.as_ref().unwrap().value
    );
}

#[test]
fn paper_tuning_misses_the_same_goals() {
    let (e, _) = envelope(
        &|| fixed_controller!(qloop_verified::koren_masory_1981),
        &|| reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
    );
    let settles = e.settling_s.as_ref().is_some_and(|w| w.value <= 3.0);
    let low_os = e.loop_overshoot.as_ref().is_some_and(|w| w.value <= 0.20);
    assert!(
        e.unstable > 0 && !settles && !low_os && e.ringing > 0,
        "the paper's K = 1.25 was expected to oscillate in some draws and ring in others: {e:#?}"
    );
    eprintln!(
        "paper tuning over {DRAWS} draws: {} unstable, {} of the stable ring after 3 s",
        e.unstable, e.ringing
    );
}
