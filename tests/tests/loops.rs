//! Loops kept as loops (issue 37, item 3; `qloop_core::emit::repeat`): the copies of a `for`
//! body the expander unrolled are emitted once, as a function the step calls per index on rows
//! of the state. Checked on `bank.qloop` (three estimators, one row of `th` and one element of
//! `err` each, reading a state every copy shares; then a second loop over `th` that writes
//! `last[l]` without reading it):
//! * the runs found are the two loops, on every built-in target, and the C and the Rust carry
//!   each body once;
//! * the C (host gcc, UBSan) of every target's plan computes what qloop's plan interpreter
//!   computes, from the initial state and from corner and random states; the Rust
//!   (`controller!`) too, along a trajectory;
//! * the shared body's values carry the hull of every copy's interval;
//! * a variant whose copies read an element another copy writes stays unrolled, and one whose
//!   copies read an element of the first copy's row is not shared with the first copy (both
//!   still compute the interpreter's values);
//! * the random specs of `random_compile.rs` include such banks.
//!
//! The multi-model seed, the large case, is covered by the seed tests (c_output's bit-for-bit
//! comparison against the interpreter and `qloop-verified` on every target).

use qloop::emit::repeat;
use qloop::Plan;
use qloop_tests::c_harness::{fixed_c_matches_interpreter, interpreted};
use qloop_tests::c_harness::{trajectory_and_states, Rng};
use qloop_tests::{scratch, tool};

qloop_macros::controller!("tests/bank.qloop");

const BANK: &str = include_str!("bank.qloop");

/// `bank.qloop` with the first loop's step size read from `err[3]`, which its third copy
/// writes: those copies are no longer independent.
fn crossed() -> String {
    let from = "let ge = gain * MU * e;";
    assert!(BANK.contains(from));
    BANK.replace(from, "let ge = gain * MU * e - 0.001 * err[3];")
}

/// `bank.qloop` with a read-only state `c[3][2]` that copy `l` reads at its own row, `c[l][0]`,
/// and at the first row, `c[0][0]`: in the first copy the two are one element.
fn aliased() -> String {
    let from = "let ge = gain * MU * e;";
    let decl = "    state gain: [0.5, 1.0] = 1.0;";
    assert!(BANK.contains(from) && BANK.contains(decl));
    BANK.replace(from, "let ge = gain * MU * e * c[l][0] * c[0][0];")
        .replace(
            decl,
            &format!("{decl}\n    state c[3][2]: [0.5, 1.0] = 1.0;"),
        )
}

fn plans(src: &str) -> Vec<Plan> {
    qloop::targets::builtin()
        .iter()
        .map(|t| qloop::compile_str(src, t).unwrap_or_else(|e| panic!("{}: {e}", t.name)))
        .collect()
}

#[test]
fn the_bank_is_two_bodies_on_rows_of_th_err_and_last() {
    for plan in plans(BANK) {
        let t = &plan.target.name;
        let found = repeat::find(&plan);
        assert_eq!(found.len(), 2, "{t}: {found:?}");
        let rows = |r: &repeat::Repeat| -> Vec<(String, usize)> {
            r.rows.iter().map(|w| (w.group.clone(), w.lead)).collect()
        };
        let s = |g: &str, k| (g.to_string(), k);
        let r = &found[0];
        assert_eq!(r.count, 3, "{t}");
        assert_eq!(rows(r), [s("th", 0), s("err", 1)], "{t}");
        assert_eq!(r.lines, (28, 33), "{t}: the first loop body's lines");
        assert!(
            r.params.contains(&repeat::Param::Sig(sig(&plan, "gain"))),
            "{t}: gain is passed by value"
        );
        assert_eq!(found[1].count, 3, "{t}");
        assert_eq!(rows(&found[1]), [s("th", 0), s("last", 0)], "{t}");
        assert_eq!(
            found[1].lines,
            (37, 41),
            "{t}: the second loop body's lines"
        );
        assert_eq!(found[1].rows[1].stored.len(), 1, "{t}: last[l] is written");
        // Emitted once each: one definition, one call in a loop.
        let (_, c) = qloop::emit::c::files(&plan);
        for k in 0..2 {
            assert_eq!(
                c.matches(&format!("static void bank_loop_{k}(")).count(),
                1,
                "{t}"
            );
            assert_eq!(c.matches(&format!("bank_loop_{k}(")).count(), 2, "{t}");
        }
        assert!(
            c.contains("for (int qloop_l = 0; qloop_l < 3; ++qloop_l)"),
            "{t}"
        );
        assert!(c.contains("self->err[qloop_l + 1]"), "{t}");
        let rust = qloop::gen_rust(&plan);
        assert_eq!(rust.matches("fn qloop_loop_0(").count(), 1, "{t}");
        assert_eq!(rust.matches("fn qloop_loop_1(").count(), 1, "{t}");
        // The bodies' updates of th[l][2] are written once each, not per index.
        assert_eq!(c.matches("th_0_2 = _").count(), 2, "{t}: {c}");
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
        for r in &em.repeats {
            for map in &r.maps {
                for (&vl, &v0) in map {
                    let (h, c) = (em.plan.val(v0), plan.val(vl));
                    assert!(h.lo <= c.lo && c.hi <= h.hi, "{t}: {vl:?}");
                }
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
    let cases = trajectory_and_states(&plan, &mut Rng(0xba_4c), 5_000, 0);
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
        // The first loop stays unrolled; the second is still shared.
        let found = repeat::find(&plan);
        let lines: Vec<(usize, usize)> = found.iter().map(|r| r.lines).collect();
        assert_eq!(lines, [(37, 41)], "{}", plan.target.name);
        let (_, c) = qloop::emit::c::files(&plan);
        assert!(!c.contains("_loop_1"), "{}", plan.target.name);
    }
    let Some(gcc) = tool("gcc") else { return };
    let plan = qloop::compile_str(&src, &qloop::targets::by_name("host").unwrap()).unwrap();
    let dir = scratch("loops-crossed");
    let cases = trajectory_and_states(&plan, &mut Rng(7), 1_000, 1_000);
    fixed_c_matches_interpreter(&plan, &gcc, &dir, &cases);
}

/// Every copy reading an element of the first copy's row (`c[0][0]`, which the first copy reads
/// as its own `c[l][0]`): the first copy is not shared (its body would read its own row
/// there), the others may be, and the C computes the interpreter's values.
#[test]
fn a_row_element_every_copy_reads_at_the_first_row_is_not_shared_with_it() {
    let src = aliased();
    for plan in plans(&src) {
        let c00 = sig(&plan, "c_0_0");
        for r in repeat::find(&plan).iter().filter(|r| r.lines == (28, 33)) {
            assert!(r.start > 0 && r.count == 2, "{}: {r:?}", plan.target.name);
            assert!(r.params.contains(&repeat::Param::Sig(c00)));
            for row in &r.rows {
                assert!(!row.elems.contains(&c00), "{}: {r:?}", plan.target.name);
            }
        }
    }
    let Some(gcc) = tool("gcc") else { return };
    let plan = qloop::compile_str(&src, &qloop::targets::by_name("host").unwrap()).unwrap();
    let dir = scratch("loops-aliased");
    let cases = trajectory_and_states(&plan, &mut Rng(11), 1_000, 1_000);
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

/// The random specs of `random_compile.rs` (Rust = C = interpreter) include banks whose loop
/// the emitters share: a fair share of the banks that compile are kept as loops, so those
/// tests cover the shared form (`qloop_tests::random_spec`).
#[test]
fn random_banks_are_kept_as_loops() {
    let t = qloop::Target::default();
    let (mut banks, mut shared) = (0, 0);
    for sp in qloop_tests::random_spec::sample(37, 400) {
        if !sp.src.contains("for j in") {
            continue;
        }
        let Ok(plan) = qloop::compile_str(&sp.src, &t) else {
            continue;
        };
        banks += 1;
        shared += usize::from(!repeat::find(&plan).is_empty());
    }
    eprintln!("{shared} of {banks} banks shared");
    assert!(
        banks >= 40 && shared * 3 >= banks,
        "{shared} of {banks} banks shared"
    );
}
