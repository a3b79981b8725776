//! The assembled multi-model controller of issue 17 (verified/specs/milling_multimodel.qloop; Rubio &
//! De la Sen, Rubio & De la Sen): it compiles, with one estimator stack of six
//! five-parameter models and their invariants unrolled from `for` loops, and its step has no
//! division. (Its closed-loop runs are in `paper_multimodel.rs`.)

fn plan() -> qloop::Plan {
    qloop::compile_str(
        include_str!("../../verified/specs/milling_multimodel.qloop"),
        &qloop::Target::default(),
    )
    .expect("milling_multimodel.qloop compiles")
}

// Compiles the multi-model controller (14,000 values): the acceptance tier's, with its other checks.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn the_assembled_controller_compiles_with_every_invariant_unrolled() {
    let plan = plan();
    let prog = &plan.prog;
    let names: Vec<&str> = prog.invariants.iter().map(|i| i.name.as_str()).collect();
    for l in 0..6 {
        for k in 2..=5 {
            let n = format!("covariance_minor_{k}_{l}");
            assert!(names.contains(&n.as_str()), "{n} missing: {names:?}");
        }
        let n = format!("law_places_the_poles_{l}");
        assert!(names.contains(&n.as_str()), "{n} missing");
    }
    // Four ZOH covariance invariants, five per β ≠ 0 model, seven laws.
    assert_eq!(names.len(), 4 + 6 * 5 + 7, "{names:?}");
    // The outputs the closed-loop runner needs: the feed first, then the hold's β.
    let outputs: Vec<&str> = prog
        .signals
        .iter()
        .filter(|s| s.kind == qloop::ir::SigKind::Output)
        .map(|s| s.name.as_str())
        .collect();
    assert_eq!(outputs, ["feed", "hold_beta", "model"]);
    let code = qloop::gen_rust(&plan);
    assert!(
        !code.contains(" / ") && !code.contains(" % "),
        "a division in the step"
    );
    assert!(
        !code.contains("f32") && !code.contains("f64"),
        "floating point in the step"
    );
}

qloop_macros::controller!("tests/stack3.qloop");

/// A three-dimensional state through the macro: the generated arrays nest three deep, and
/// `det` of a matrix of the stack plus a leading minor of order 1 is `ad − bc + a`.
#[test]
fn a_stack_of_matrices_compiles_and_computes_its_determinants() {
    use fixed::types::extra::U30;
    use fixed::FixedI32;
    let vals = [[[0.5, -0.25], [0.125, 0.75]], [[-0.5, 0.5], [0.25, -1.0]]];
    let x = vals.map(|m| m.map(|r| r.map(FixedI32::<U30>::from_num)));
    let mut c = stack3::Controller::new();
    // The initial state nests three deep.
    assert_eq!(c.states().P[1][1][1].to_num::<f64>(), 0.5);
    let out = c.step(stack3::Inputs { x });
    for (l, (m, y)) in vals.iter().zip(out.y).enumerate() {
        let want = m[0][0] * m[1][1] - m[0][1] * m[1][0] + m[0][0];
        let got = y.to_num::<f64>();
        assert!((got - want).abs() < 1e-6, "l = {l}: {got} vs {want}");
    }
    let plan = qloop::compile_str(include_str!("stack3.qloop"), &qloop::Target::default())
        .expect("compiles");
    let names: Vec<&str> = plan
        .prog
        .invariants
        .iter()
        .map(|i| i.name.as_str())
        .collect();
    assert_eq!(names, ["bounded_0", "bounded_1"]);
}
