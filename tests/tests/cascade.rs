//! Issue 19, item 6: the layer above the loop sets the loop's set point. RCB₂ chooses the
//! force reference F_r for each next part (`qloop_aco::cascade`), and the generated
//! Koren–Masory controller with `input fr` (`aco/specs/koren_masory_setpoint.qloop`, compiled
//! here by `controller!`) holds it within the part on the turning plant. The part's time comes
//! from that closed loop.

use qloop_aco::cascade::{self, Cascade, CascadeRun, StaticModel, SETPOINT_SPEC};
use qloop_plant::{fixed_controller, reference_controller, Controller};

qloop_macros::controller!("../aco/specs/koren_masory_setpoint.qloop");
qloop_macros::controller!("../aco/specs/koren_masory_setpoint.qloop", reference);

fn compiled() -> Box<dyn Controller> {
    fixed_controller!(koren_masory_setpoint)
}

fn reference() -> Box<dyn Controller> {
    reference_controller!(koren_masory_setpoint_ref, 0.1)
}

fn example() -> CascadeRun {
    let run = cascade::run(&Cascade::example(), &compiled).expect("cascade runs");
    print!("{}", qloop_aco::report::cascade_table(&run));
    run
}

/// The inner loop's spec proves for every F_r in its input range, with both solvers.
#[test]
fn setpoint_spec_is_proved() {
    let plan = qloop::compile_str(SETPOINT_SPEC, &qloop::Target::default()).expect("compiles");
    let r = qloop::prove::prove(&plan, &qloop_tests::both_solvers(60_000), &mut |_| {});
    assert!(r.proved(), "{}", r.table(&plan));
}

/// In LinuxCNC the reference is a pin the host-side layer writes between parts: the
/// component generated from the spec has `fr` as a float input pin, next to the spindle load.
#[test]
fn the_linuxcnc_component_takes_the_reference_as_a_pin() {
    let plan = qloop::compile_str(SETPOINT_SPEC, &qloop::Target::default()).expect("compiles");
    let comp = qloop::gen_linuxcnc(&plan).expect("a component");
    assert!(
        comp.lines().any(|l| l.starts_with("pin in float fr ")),
        "{comp}"
    );
    assert!(
        comp.lines()
            .any(|l| l.starts_with("pin in float spindle_load ")),
        "{comp}"
    );
}

/// The loop holds the reference it is given: the median force the sensor read over each part
/// is within 2 % of its F_r, and the part's closed-loop time is at least the time at exactly
/// F_r in every section (the static model with the plant's true K_s) and at most 3 % above it
/// (the transients at the start and at each depth change).
#[test]
fn the_loop_holds_each_parts_reference() {
    let run = example();
    let truth = StaticModel {
        ks: run.true_ks,
        ..StaticModel::nominal()
    };
    for p in &run.parts {
        assert!(p.finished, "part {} not finished", p.index);
        let mut f = p.force.clone();
        f.sort_by(f64::total_cmp);
        let median = f[f.len() / 2];
        assert!(
            (median / p.fr - 1.0).abs() < 0.02,
            "part {}: median force {median} against F_r {}",
            p.index,
            p.fr
        );
        let steady = truth.cycle_time(&run.cascade.part, p.fr);
        let ratio = p.time / steady;
        assert!(
            (1.0..=1.03).contains(&ratio),
            "part {}: {} s against {steady} s",
            p.index,
            p.time
        );
    }
}

/// The outer layer's effect, as Ivester & Danai's Table 2 shows it for machine settings: starting from a
/// conservative 1 kN, the cycle time falls by more than a quarter over ten parts, and no part
/// is out of specification (peak force, roughness).
#[test]
fn rcb2_shortens_the_cycle_without_violation() {
    let run = example();
    let (first, last) = (&run.parts[0], &run.parts[run.parts.len() - 1]);
    assert!(
        last.time < 0.75 * first.time,
        "{} -> {}",
        first.time,
        last.time
    );
    assert!(last.fr > first.fr);
    for p in &run.parts {
        assert!(
            p.excess() <= 0.0,
            "part {} out of specification by {}",
            p.index,
            p.excess()
        );
        assert!(p.nlp_error.is_none(), "part {}: {:?}", p.index, p.nlp_error);
    }
}

/// The f64 reference controller of the same spec, in the same cascade (same draws), chooses
/// nearly the same references: the fixed-point loop's rounding does not change the outer
/// layer's decisions by more than 1 %.
#[test]
fn fixed_point_and_reference_loops_agree() {
    let fixed = example();
    let float = cascade::run(&Cascade::example(), &reference).expect("cascade runs");
    for (a, b) in fixed.parts.iter().zip(&float.parts) {
        println!(
            "part {}: F_r {:.4} (fixed) {:.4} (f64), t {:.2} {:.2}",
            a.index, a.fr, b.fr, a.time, b.time
        );
        assert!((a.fr / b.fr - 1.0).abs() < 0.01, "part {}", a.index);
        assert!((a.time / b.time - 1.0).abs() < 0.01, "part {}", a.index);
    }
}
