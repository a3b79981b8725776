//! `qloop prove` end to end, as a user runs it (needs z3 and cvc5; skipped without them, and
//! listed at the end of `cargo test --workspace`, unless QLOOP_REQUIRE_TOOLS is set):
//!
//! * every seed spec in `verified/specs/` is proved from scratch (`--no-cache`): exit 0, and
//!   the `--json` report says every obligation is proved;
//! * every spec of the refutation corpus `tests/fixtures/refute/` is refuted by the command:
//!   exit 1, and a `REFUTED: ` line names the obligation the spec's first line names
//!   (`// expect-refuted: NAME`). `tests/tests/refute.rs` replays each counterexample in the
//!   compiled code.

mod common;
use common::{qloop, text};
use std::path::{Path, PathBuf};

/// The `*.qloop` files of `dir` (relative to the workspace root), sorted.
fn specs_in(dir: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(dir);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "qloop"))
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no spec in {}", dir.display());
    v
}

fn solvers_present() -> bool {
    // Both: a proof by one solver alone is not what CI accepts.
    test_tools::tool("z3").is_some() && test_tools::tool("cvc5").is_some()
}

#[test]
fn every_seed_spec_is_proved() {
    if !solvers_present() {
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("prove-seeds");
    std::fs::create_dir_all(&dir).expect("tmp dir");
    for spec in specs_in("verified/specs") {
        let stem = spec.file_stem().unwrap().to_string_lossy().into_owned();
        let json = dir.join(format!("{stem}.proof.json"));
        let _ = std::fs::remove_file(&json);
        // --timeout bounds the whole proof: most take seconds, `gac_surface_finish` (the
        // recursive least squares through two Newton reciprocals) took 8 minutes on 2 cores.
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
}

#[test]
fn every_refutation_corpus_spec_is_refuted_on_its_obligation() {
    if !solvers_present() {
        return;
    }
    for spec in specs_in("tests/fixtures/refute") {
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
}
