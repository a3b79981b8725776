//! Loops kept as loops (issue 37, item 3; `qloop_core::emit::repeat`): the copies of a `for`
//! body the expander unrolled are emitted once, as a function the step calls per index on rows
//! of the state. Checked on `bank.qloop` (three estimators, one row of `th` and one element of
//! `err` each, reading a state every copy shares):
//! * the run found is the loop, on every built-in target, and the C and the Rust carry its body
//!   once;
//! * the C (host gcc, UBSan) of every target's plan computes what qloop's plan interpreter
//!   computes, from the initial state and from corner and random states; the Rust
//!   (`controller!`) too, along a trajectory;
//! * the shared body's values carry the hull of every copy's interval;
//! * a variant whose copies read an element another copy writes stays unrolled (and still
//!   computes the interpreter's values).
//!
//! The multi-model seed, the large case, is covered by the seed tests (c_output's bit-for-bit
//! comparison against the interpreter and `qloop-verified` on every target).

use qloop::emit::repeat;
use qloop::ir::SigKind;
use qloop::Plan;
use qloop_tests::c_harness::{fixed_c_matches_interpreter, ids, interpreted, raw_input};
use qloop_tests::c_harness::{trajectory_and_states, Case, Rng};
use qloop_tests::{scratch, tool};

qloop_macros::controller!("tests/bank.qloop");

const BANK: &str = include_str!("bank.qloop");

/// `bank.qloop` with the step size read from `err[3]`, which the third copy writes: the
/// copies are no longer independent.
fn crossed() -> String {
    let from = "let ge = gain * MU * e;";
    assert!(BANK.contains(from));
    BANK.replace(from, "let ge = gain * MU * e - 0.001 * err[3];")
}

fn plans(src: &str) -> Vec<Plan> {
    qloop::targets::builtin()
        .iter()
        .map(|t| qloop::compile_str(src, t).unwrap_or_else(|e| panic!("{}: {e}", t.name)))
        .collect()
}

#[test]
fn the_bank_is_one_body_on_rows_of_th_and_err() {
    for plan in plans(BANK) {
        let t = &plan.target.name;
        let found = repeat::find(&plan);
        assert_eq!(found.len(), 1, "{t}: {found:?}");
        let r = &found[0];
        assert_eq!(r.count, 3, "{t}");
        let rows: Vec<(&str, usize)> = r.rows.iter().map(|w| (w.group.as_str(), w.lead)).collect();
        assert_eq!(rows, [("th", 0), ("err", 1)], "{t}");
        assert_eq!(
            r.lines,
            (25, 30),
            "{t}: the loop body's lines in bank.qloop"
        );
        assert!(
            r.params.contains(&repeat::Param::Sig(sig(&plan, "gain"))),
            "{t}: gain is passed by value"
        );
        // Emitted once: one definition, one call in a loop.
        let (_, c) = qloop::emit::c::files(&plan);
        assert_eq!(c.matches("static void bank_loop_0(").count(), 1, "{t}");
        assert_eq!(c.matches("bank_loop_0(").count(), 2, "{t}");
        assert!(
            c.contains("for (int qloop_l = 0; qloop_l < 3; ++qloop_l)"),
            "{t}"
        );
        assert!(c.contains("self->err[qloop_l + 1]"), "{t}");
        let rust = qloop::gen_rust(&plan);
        assert_eq!(rust.matches("fn qloop_loop_0(").count(), 1, "{t}");
        // The body's update of th[l][2] is written once, not per index.
        assert_eq!(c.matches("th_0_2 = _").count(), 1, "{t}: {c}");
        assert!(!c.contains("th_1_2 = _"), "{t}");
    }
}

#[test]
fn the_shared_body_holds_for_every_copys_interval() {
    for plan in plans(BANK) {
        let t = &plan.target.name;
        // The bank's copies have the same intervals (every row saturates to one declared
        // range), so widen one value of the last copy by hand: the shared body, and every
        // copy, must then carry the wider interval.
        let r = repeat::find(&plan).remove(0);
        let map = r.maps.last().unwrap();
        let (&vl, &v0) = map
            .iter()
            .find(|(v, _)| plan.val(**v).hi > plan.val(**v).lo)
            .unwrap();
        let mut doctored = plan.clone();
        doctored.vals[vl.0].lo -= 1;
        let em = repeat::emit(&doctored);
        assert_eq!(
            em.plan.val(v0).lo,
            doctored.val(vl).lo,
            "{t}: the first copy's value"
        );
        let v1 = *r.maps[0].iter().find(|(_, a)| **a == v0).unwrap().0;
        assert_eq!(
            em.plan.val(v1).lo,
            doctored.val(vl).lo,
            "{t}: the second copy's value"
        );
        // And undoctored: every copy's interval inside its shared value's.
        let em = repeat::emit(&plan);
        for map in &em.repeats[0].maps {
            for (&vl, &v0) in map {
                let (h, c) = (em.plan.val(v0), plan.val(vl));
                assert!(h.lo <= c.lo && c.hi <= h.hi, "{t}: {vl:?}");
            }
        }
    }
}

#[test]
fn the_bank_in_c_computes_the_interpreters_values_on_every_target() {
    let Some(gcc) = tool("gcc") else { return };
    for plan in plans(BANK) {
        let dir = scratch(&format!("loops-bank-{}", plan.target.name));
        let cases = trajectory_and_states(&plan, &mut Rng(0x5eed_0b4c), 2_000, 2_000);
        assert_eq!(
            fixed_c_matches_interpreter(&plan, &gcc, &dir, &cases),
            4_000
        );
    }
}

#[test]
fn the_bank_in_rust_computes_the_interpreters_values() {
    let plan = qloop::compile_str(BANK, &qloop::Target::default()).unwrap();
    let mut rng = Rng(0xba_4c);
    let inputs = ids(&plan, SigKind::Input);
    let cases: Vec<Case> = (0..5_000)
        .map(|_| Case {
            states: None,
            inputs: inputs
                .iter()
                .map(|id| raw_input(&plan, *id, &mut rng))
                .collect(),
        })
        .collect();
    let want = interpreted(&plan, &cases);
    let mut c = bank::Controller::new();
    for (k, case) in cases.iter().enumerate() {
        let i: Vec<i64> = case.inputs.iter().map(|v| *v as i64).collect();
        let o = c.step_bits(i.try_into().unwrap());
        let got: Vec<i64> = o.iter().copied().chain(c.state_bits()).collect();
        assert_eq!(got, want[k], "step {k}: Rust vs interpreter");
    }
}

#[test]
fn copies_that_read_what_another_writes_stay_unrolled() {
    let src = crossed();
    for plan in plans(&src) {
        assert!(repeat::find(&plan).is_empty(), "{}", plan.target.name);
        let (_, c) = qloop::emit::c::files(&plan);
        assert!(!c.contains("_loop_0"), "{}", plan.target.name);
    }
    let Some(gcc) = tool("gcc") else { return };
    let plan = qloop::compile_str(&src, &qloop::targets::by_name("host").unwrap()).unwrap();
    let dir = scratch("loops-crossed");
    let cases = trajectory_and_states(&plan, &mut Rng(7), 1_000, 1_000);
    fixed_c_matches_interpreter(&plan, &gcc, &dir, &cases);
}

fn sig(plan: &Plan, name: &str) -> qloop::ir::SigId {
    qloop::ir::SigId(
        plan.prog
            .signals
            .iter()
            .position(|s| s.name == name)
            .unwrap(),
    )
}
