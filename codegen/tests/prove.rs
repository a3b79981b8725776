//! `qloop prove` end to end, as a user runs it (needs z3 and cvc5; skipped without them, and
//! listed at the end of `cargo test --workspace`, unless QLOOP_REQUIRE_TOOLS is set), one test
//! per spec (`test_tools::spec_tests!`):
//!
//! * `every_seed_spec_is_proved::<stem>`: the seed spec `verified/specs/<stem>.qloop` is proved
//!   from scratch (`--no-cache`): exit 0, and the `--json` report says every obligation is
//!   proved. The default run proves three seeds of different kinds in seconds (the 1981
//!   adaptive loop, the fixed-gain ACC, the grinding PI law); the others are the acceptance
//!   tier's (the multi-model controller alone, 14,136 obligations, takes about 3 minutes in a
//!   debug build, most of it building the obligations).
//! * `every_refutation_corpus_spec_is_refuted_on_its_obligation::<stem>`: the spec
//!   `tests/fixtures/refute/<stem>.qloop` is refuted by the command: exit 1, and a `REFUTED: `
//!   line names the obligation the spec's first line names (`// expect-refuted: NAME`).
//!   `tests/tests/refute.rs` replays each counterexample in the compiled code. The nine corpus
//!   specs whose refutation takes seconds run by default; the five slow ones are the
//!   acceptance tier's (`refute.rs` replays their counterexamples in the default run).

use crate::common::{qloop, text};
use std::path::PathBuf;

fn solvers_present() -> bool {
    // Both: a proof by one solver alone is not what CI accepts.
    test_tools::tool("z3").is_some() && test_tools::tool("cvc5").is_some()
}

/// The seed spec is proved from scratch, every obligation by both solvers.
fn every_seed_spec_is_proved(stem: &str) {
    proved(
        stem,
        &test_tools::workspace_root().join(format!("verified/specs/{stem}.qloop")),
    );
}

/// Issue 35, item 3: qloop's safety rules with decimal parameters under round-to-nearest
/// (`fixtures/decimal_rules.qloop`) are proved, every obligation by both solvers: no library
/// rule is refuted by its own property (`rules.rs` checks the same properties on every raw
/// command without a solver). Two seconds in a debug build.
#[test]
fn the_safety_rules_with_decimal_parameters_are_proved() {
    let spec = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/decimal_rules.qloop");
    proved("decimal_rules", &spec);
}

/// `spec` is proved from scratch, every obligation by both solvers.
fn proved(stem: &str, spec: &std::path::Path) {
    if !solvers_present() {
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("prove-seeds");
    std::fs::create_dir_all(&dir).expect("tmp dir");
    let json = dir.join(format!("{stem}.proof.json"));
    let _ = std::fs::remove_file(&json);
    // --timeout bounds the whole proof: each takes seconds in a debug build, the
    // multi-model controller about 3 minutes (BENCHMARKS.md).
    let o = qloop(&[
        "prove",
        spec.to_str().unwrap(),
        "--no-cache",
        "--timeout",
        "1200",
        "--json",
        json.to_str().unwrap(),
    ]);
    let out = text(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{stem}: not proved:\n{out}\n{}",
        text(&o.stderr)
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("--json written"))
            .expect("valid JSON");
    assert_eq!(j["proved"], true, "{stem}: {out}");
    let obligations = j["obligations"].as_array().expect("obligations");
    assert!(!obligations.is_empty(), "{stem}: no obligation");
    for ob in obligations {
        assert_eq!(ob["verdict"], "proved", "{stem}: {ob}");
    }
}
test_tools::spec_tests! {
    every_seed_spec_is_proved in "verified/specs";
    default: [acc_fixed_gain, grinding_pi, koren_masory_1981];
    acceptance: [
        gac_surface_finish, grinding_adaptive_pzc, koren_masory_safe, koren_masory_tuned,
        milling_acc, milling_multimodel,
    ];
}

/// The refutation corpus spec is refuted by `qloop prove`, on the obligation its first line
/// names, with a counterexample that shows the step.
fn every_refutation_corpus_spec_is_refuted_on_its_obligation(stem: &str) {
    if !solvers_present() {
        return;
    }
    let spec = test_tools::workspace_root().join(format!("tests/fixtures/refute/{stem}.qloop"));
    let src = std::fs::read_to_string(&spec).unwrap();
    let expect = src
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("// expect-refuted: "))
        .unwrap_or_else(|| panic!("{}: no `// expect-refuted: ` line", spec.display()))
        .trim()
        .to_string();
    let o = qloop(&[
        "prove",
        spec.to_str().unwrap(),
        "--no-cache",
        "--timeout",
        "60",
    ]);
    let out = text(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}: want exit 1 (refuted):\n{out}\n{}",
        spec.display(),
        text(&o.stderr)
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("REFUTED: ") && l.contains(&expect)),
        "{}: no `REFUTED: ` line naming `{expect}`:\n{out}",
        spec.display()
    );
    // A refuted property shows the step: the post-state and each clause evaluated, one of
    // its conclusions false.
    if expect.starts_with("property") {
        assert!(
            out.contains("after the step: ") && out.contains("`: FALSE ("),
            "{}: the counterexample does not show the step:\n{out}",
            spec.display()
        );
    }
}
test_tools::spec_tests! {
    every_refutation_corpus_spec_is_refuted_on_its_obligation in "tests/fixtures/refute";
    default: [
        backoff_factor_at_range_edge, claimed_range_too_narrow, csd_partial_sum,
        determinant_bound_too_high, law_check_looser_than_invariant, missing_saturation,
        property_sign_error, rule_counter_off_by_one, table_claim_cancellation,
        table_claim_too_small,
    ];
    acceptance: [
        c2_too_large, pole_placement_sign_error, recip_tracker_gain_too_large,
        rls_unbounded_covariance, supervisor_switches_early,
    ];
}
