//! Word widths against an error budget (issue 37, item 2; `qloop_core::lower::budget`): the
//! GAC seed with its hand-chosen 32-bit formats replaced by `#[error(..)]` budgets
//! ([`qloop_tests::gac_with_budgets`]), planned for the ATmega328P.
//!
//! The plan's printed bounds are checked against exact arithmetic in `exact_bounds.rs`
//! (acceptance tier); here: the search's result meets every budget, keeps `pred` (no budget)
//! as accurate as without budgets, is narrower and cheaper in the cost model than the default
//! formats, and its C, built for the host with UBSan, computes what the plan interpreter does.

use qloop::ir::SigKind;
use qloop_tests::c_harness::{fixed_c_matches_interpreter, trajectory_and_states, Rng};
use qloop_tests::{scratch, sig, tool};

fn avr() -> qloop::Target {
    qloop::targets::by_name("atmega328p").expect("built-in target")
}

/// The same spec with no budget: the formats a budget narrows from.
fn without_budgets(src: &str) -> String {
    src.lines()
        .filter(|l| !l.trim_start().starts_with("#[error("))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn budgets_hold_and_the_chosen_formats_are_narrower_and_cheaper() {
    let src = qloop_tests::gac_with_budgets();
    let plan = qloop::compile_str(&src, &avr()).unwrap_or_else(|e| panic!("{}", e.message));
    let base = qloop::compile_str(&without_budgets(&src), &avr())
        .unwrap_or_else(|e| panic!("{}", e.message));
    assert!(base.tuning.is_none());
    let t = plan
        .tuning
        .as_ref()
        .expect("a spec with budgets is searched");
    // Every budget, from the plan's own summary (what `check` prints), not the report's copy.
    let mut budgeted = 0;
    for (i, s) in plan.prog.signals.iter().enumerate() {
        if let Some(b) = s.budget {
            budgeted += 1;
            let err = plan.summary[i].err;
            assert!(
                err <= b.err,
                "{}: {err:e} over its budget {:e}",
                s.label(),
                b.err
            );
        }
    }
    assert_eq!(budgeted, 1 + 1 + 2 + 4, "f, feed, theta[2], P[2][2]");
    let pred = sig(&plan, "pred");
    assert!(
        plan.summary[pred.0].err <= base.summary[pred.0].err,
        "pred, unbudgeted, lost accuracy: {:e} > {:e}",
        plan.summary[pred.0].err,
        base.summary[pred.0].err
    );
    // Narrower: the covariance leaves 32 bits.
    let p00 = sig(&plan, "P_0_0");
    assert!(
        plan.format(p00).ty.bits < base.format(p00).ty.bits,
        "P stays {}",
        plan.format(p00)
    );
    // Cheaper, by the same estimate the search ranks by, recomputed here.
    let (chosen, default) = (
        qloop::lower::cost::estimate(&plan),
        qloop::lower::cost::estimate(&base),
    );
    assert_eq!(chosen, t.chosen_cost);
    assert_eq!(default, t.default_cost);
    assert!(chosen.cycles < default.cycles, "{chosen:?} vs {default:?}");
    // Deterministic: the macro and the command line must agree.
    let again = qloop::compile_str(&src, &avr()).unwrap();
    for id in plan.prog.ids_of(SigKind::State) {
        assert_eq!(plan.format(id), again.format(id));
    }
    // The report lists the budgets.
    let report = qloop::report::check_report(&plan, "gac_budgeted.qloop");
    assert!(
        report.contains("Formats chosen against the error budgets"),
        "{report}"
    );
    assert!(report.contains("P[..] (4 elements)"), "{report}");
}

#[test]
fn the_budgeted_plans_c_matches_the_interpreter() {
    let Some(gcc) = tool("gcc") else { return };
    let src = qloop_tests::gac_with_budgets();
    let plan = qloop::compile_str(&src, &avr()).unwrap_or_else(|e| panic!("{}", e.message));
    let cases = trajectory_and_states(&plan, &mut Rng(0x00b0_d9e7), 400, 1_000);
    let n = fixed_c_matches_interpreter(&plan, &gcc, &scratch("budget_gac_c"), &cases);
    assert_eq!(n, 1_400);
}
