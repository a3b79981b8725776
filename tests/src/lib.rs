//! Helpers shared by the workspace integration tests.

pub mod avr;
pub mod c_harness;
pub mod cases;
pub mod claims;
pub mod exact;
pub mod random_spec;
pub mod rls;
pub mod snapshot;

use qloop::ir::SigId;
use qloop::{Plan, Target};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

/// A prover configuration with both solvers, two jobs, no cache and the given per-query time
/// limit; panics (with how to install them) when z3 or cvc5 is missing.
pub fn both_solvers(timeout_ms: u64) -> qloop::prove::solver::Config {
    use qloop::prove::solver::{Config, Solver};
    assert!(
        Solver::ALL.iter().all(|s| s.available()),
        "z3 and cvc5 must be installed (apt-get install z3 cvc5)"
    );
    Config {
        solvers: Solver::ALL.to_vec(),
        timeout_ms,
        cache_dir: None,
        jobs: 2,
        deadline: None,
    }
}

/// `verified/specs`.
pub fn specs_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../verified/specs")
}

/// Every seed spec, as (file stem, source text), sorted by name.
pub fn all_specs() -> Vec<(String, String)> {
    qloop_files(&specs_dir())
}

/// Every `*.qloop` file of `dir`, as (file stem, source text), sorted by name.
fn qloop_files(dir: &std::path::Path) -> Vec<(String, String)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "qloop"))
        .map(|p| {
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            (stem, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    v.sort();
    v
}

/// The claim corpus (`tests/fixtures/claims`), as (file stem, source text), sorted by name.
pub fn claim_corpus() -> Vec<(String, String)> {
    qloop_files(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/claims"))
}

/// What the first line of a corpus spec expects: `None` for `// expect: compiles`, else the
/// error's (line, column, text) from `// expect-error LINE:COL: TEXT`.
pub fn corpus_expectation(src: &str) -> Option<(usize, usize, String)> {
    let first = src.lines().next().unwrap_or("");
    if first.trim() == "// expect: compiles" {
        return None;
    }
    let rest = first
        .strip_prefix("// expect-error ")
        .unwrap_or_else(|| panic!("corpus spec without an expectation: {first}"));
    let (at, text) = rest.split_once(": ").expect("`LINE:COL: TEXT`");
    let (l, c) = at.split_once(':').expect("LINE:COL");
    Some((
        l.parse().expect("line"),
        c.parse().expect("column"),
        text.to_string(),
    ))
}

/// The source text of a seed spec.
pub fn spec_source(stem: &str) -> String {
    let path = specs_dir().join(format!("{stem}.qloop"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The GAC seed with its hand-chosen 32-bit formats (`#[q(i32, ..)]`) removed and error
/// budgets in their place (`#[error(..)]`, issue 37): 1e-4 mm/rev on the feed and its
/// state, 4e-2 µm on θ, 8e-2 on the covariance, none on `pred` (which must then stay as
/// accurate as without budgets). The 16-bit table samples stay pinned.
pub fn gac_with_budgets() -> String {
    let src = spec_source("gac_surface_finish");
    let unpinned: Vec<&str> = src
        .lines()
        .filter(|l| !l.trim_start().starts_with("#[q(i32,"))
        .collect();
    let mut s = unpinned.join("\n");
    for (decl, budget) in [
        ("    state f: ", "1e-4"),
        ("    output feed: ", "1e-4"),
        ("    state theta[2]", "4e-2"),
        ("    state P[2]", "8e-2"),
    ] {
        assert!(s.contains(decl), "the GAC seed declares `{decl}`");
        s = s.replacen(decl, &format!("    #[error({budget})]\n{decl}"), 1);
    }
    s.replacen(
        "controller gac_surface_finish ",
        "controller gac_budgeted ",
        1,
    )
}

/// The harness module `qloop gen --lang kani` writes for a seed spec (default target),
/// generated once per test process and kept: the workspace's integration tests are one
/// binary, so the multi-model controller's 27 MB module is generated once per run however many
/// tests read it. Tests that ask for the same spec at once wait for one generation; different
/// specs generate in parallel. (Plans hold `proc_macro2` spans, which are neither `Send` nor
/// `Sync`, so they are compiled where they are used.)
pub fn kani_text(stem: &str) -> &'static str {
    static KANI: Mutex<BTreeMap<String, &'static OnceLock<String>>> = Mutex::new(BTreeMap::new());
    // One cell per spec, leaked so that the text lives as long as the process.
    let cell: &'static OnceLock<String> = KANI
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(stem.to_string())
        .or_insert_with(|| Box::leak(Box::default()));
    cell.get_or_init(|| qloop::gen_kani(&plan(stem)))
}

/// The compiled plan of a seed spec, for the default target.
pub fn plan(stem: &str) -> Plan {
    qloop::compile_str(&spec_source(stem), &Target::default())
        .unwrap_or_else(|e| panic!("{stem}: {e}"))
}

/// The id of the signal called `name`.
pub fn sig(plan: &Plan, name: &str) -> SigId {
    SigId(
        plan.prog
            .signals
            .iter()
            .position(|s| s.name == name)
            .unwrap_or_else(|| panic!("no signal {name}")),
    )
}

/// The compiled plan of a seed spec for a built-in target.
pub fn plan_for(stem: &str, target: &str) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    qloop::compile_str(&spec_source(stem), &t).unwrap_or_else(|e| panic!("{stem}: {e}"))
}

/// Seed spec stems, sorted.
pub fn spec_stems() -> Vec<String> {
    all_specs().into_iter().map(|(s, _)| s).collect()
}

/// External tools (compilers, simulators, analysers): [`tool`] finds one on `PATH` or skips the
/// calling test with a note, and the skips are listed at the end of `cargo test --workspace`;
/// with `QLOOP_REQUIRE_TOOLS` set (as `.ci/run` does, after installing them) a missing tool
/// fails the test. Shared with `codegen/tests` through the `test-tools` crate.
pub use test_tools::{hidden, rust_target, skip, tool};

/// A fresh scratch directory under the target directory, named after the test.
pub fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../target/qloop-tests")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs a command, panicking with its output if it fails; returns stdout.
pub fn run(cmd: &mut std::process::Command) -> String {
    let o = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    );
    assert!(
        o.status.success(),
        "{cmd:?} failed ({}):\n{out}\n{err}",
        o.status
    );
    out
}

/// Proves `plan` with both solvers (per-query limit `timeout_ms`), asserts that every
/// obligation is proved and that for each of `names` some obligation's name contains it, and
/// returns the report.
pub fn assert_proved(plan: &Plan, timeout_ms: u64, names: &[&str]) -> qloop::prove::Report {
    let r = qloop::prove::prove(plan, &both_solvers(timeout_ms), &mut |_| {});
    assert!(r.proved(), "{}", r.table(plan));
    for name in names {
        assert!(
            r.outcomes.iter().any(|o| o.ob.name.contains(name)),
            "no obligation for {name}"
        );
    }
    r
}

/// Asserts that the obligation called `name` was proved (unsat) by each solver on its own.
pub fn assert_proved_by_each_solver(r: &qloop::prove::Report, name: &str) {
    use qloop::prove::solver::{Answer, Solver};
    let o = r
        .outcomes
        .iter()
        .find(|o| o.ob.name == name)
        .unwrap_or_else(|| panic!("no obligation `{name}`"));
    for s in Solver::ALL {
        assert!(
            o.runs
                .iter()
                .any(|run| run.solver == s && run.answer == Answer::Unsat),
            "{name}: not proved by {}",
            s.name()
        );
    }
}
