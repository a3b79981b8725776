//! The encoding that splits an invariant over its states' update guards
//! (`linear envelope, cut at lets, split on updates`) is an exact rewriting: on a law stored
//! under a check that matches the invariant, z3 and cvc5 prove it; on the refutation
//! corpus's law stored under a check twice as loose as the invariant
//! (`tests/fixtures/refute/law_check_looser_than_invariant.qloop`), both find a model.
//! The other encodings must not decide it for this test: each solver is asked the split
//! query alone.

use std::io::Write as _;
use std::process::{Command, Stdio};

const LOOSE: &str =
    include_str!("../../tests/fixtures/refute/law_check_looser_than_invariant.qloop");

/// The split query of `spec`'s invariant, as SMT-LIB text.
fn split_query(spec: &str) -> String {
    let plan = qloop::compile_str(spec, &qloop::Target::default()).expect("compiles");
    let obs = qloop::prove::obligations::obligations(&plan);
    let mut split = obs.iter().filter(|o| {
        o.name.contains("law_matches_its_model is inductive")
            && o.encoding == Some("linear envelope, cut at lets, split on updates")
    });
    let o = split.next().expect("a split obligation for the invariant");
    assert!(split.next().is_none(), "one split obligation");
    o.query.script.clone()
}

/// The answer (`sat`/`unsat`) of each available solver on `script`.
fn answers(script: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (solver, args) in [("z3", vec!["-in"]), ("cvc5", vec!["--lang=smt2"])] {
        let Some(path) = test_tools::tool(solver) else {
            continue;
        };
        let mut child = Command::new(path)
            .args(&args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("solver starts");
        let text = format!("{script}\n(check-sat)\n");
        child
            .stdin
            .take()
            .expect("stdin")
            .write_all(text.as_bytes())
            .expect("write");
        let o = child.wait_with_output().expect("solver runs");
        let first = String::from_utf8_lossy(&o.stdout)
            .lines()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("")
            .trim()
            .to_string();
        out.push((solver.to_string(), first));
    }
    out
}

#[test]
fn a_check_matching_the_invariant_is_proved_case_by_case() {
    // The same law with the check the invariant states: TOL, not 2·TOL.
    let exact = LOOSE.replace("<= 2.0 * TOL", "<= TOL");
    assert_ne!(
        exact, LOOSE,
        "the fixture's check changed: update this test"
    );
    for (solver, answer) in answers(&split_query(&exact)) {
        assert_eq!(answer, "unsat", "{solver} on the matching check");
    }
}

#[test]
fn a_check_looser_than_the_invariant_is_not_proved_case_by_case() {
    for (solver, answer) in answers(&split_query(LOOSE)) {
        assert_eq!(answer, "sat", "{solver} on the loose check");
    }
}
