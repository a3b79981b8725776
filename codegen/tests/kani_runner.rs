//! `qloop kani` against a fake `cargo kani` (a shell script printing Kani 0.67's terse output):
//! the table, the named failed check, a Kani timeout, the backstop kill of a hung run, the
//! exit codes, and the message when Kani is missing. (The runner on real Kani is measured in
//! BENCHMARKS.md.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const FAKE: &str = r#"#!/bin/sh
# cargo kani, faked: harnesses m::ok, m::bad, m::slow, m::hang
[ "$1" = kani ] || exit 101
case "$*" in
  *--version*) echo "Kani Rust Verifier 0.67.0 (cargo plugin)"; exit 0 ;;
  *"--harness m::stubbed "*"-Z function-contracts -Z stubbing "*) printf 'VERIFICATION:- SUCCESSFUL\nVerification Time: 0.5s\n'; exit 0 ;;
  *"--harness m::stubbed "*) printf 'VERIFICATION:- FAILED\n'; exit 1 ;;
  *" list "*) printf '%s' '{"kani-version":"0.67.0","standard-harnesses":{"src/lib.rs":["m::ok","m::bad","m::slow","m::hang"]},"contract-harnesses":{"src/lib.rs":["m::stubbed"]}}' > kani-list.json; exit 0 ;;
  *"--harness m::ok "*) printf 'VERIFICATION RESULT:\n ** 0 of 90 failed\n\nVERIFICATION:- SUCCESSFUL\nVerification Time: 0.12s\n'; exit 0 ;;
  *"--harness m::bad "*) printf 'VERIFICATION RESULT:\n ** 1 of 459 failed (2 unreachable)\n\nFailed Checks: property `p`: `x <= 1` is false after the step\n File: "src/lib.rs", line 3\n\nVERIFICATION:- FAILED\nVerification Time: 6.5s\n'; exit 1 ;;
  *"--harness m::slow "*) printf 'CBMC failed\nVERIFICATION:- FAILED\nCBMC timed out. You may want to rerun your proof with a larger timeout.\n'; exit 1 ;;
  *"--harness m::hang "*) sleep 60; exit 0 ;;
esac
exit 101
"#;

fn fake_dir(tag: &str) -> PathBuf {
    // One directory per test: `cargo kani list` writes kani-list.json into it.
    let dir = std::env::temp_dir().join(format!("qloop-kani-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cargo = dir.join("cargo");
    std::fs::write(&cargo, FAKE).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&cargo, std::fs::Permissions::from_mode(0o755)).unwrap();
    dir
}

fn qloop(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qloop"))
        .arg("kani")
        .args(["--cargo", &dir.join("cargo").display().to_string()])
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run qloop")
}

/// Every harness runs with contracts and stubbing enabled (the property harnesses
/// `stub_verified` their products); the fake fails the harness otherwise.
#[test]
fn harnesses_run_with_contracts_and_stubbing_enabled() {
    let dir = fake_dir("contracts");
    let o = qloop(&dir, &["--only", "m::stubbed"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("1 harnesses: 1 successful"), "{out}");
}

#[test]
fn the_table_names_verdicts_checks_and_the_failed_clause() {
    let dir = fake_dir("table");
    let start = std::time::Instant::now();
    let o = qloop(
        &dir,
        &[
            "--timeout",
            "1",
            "--grace-secs",
            "1",
            "--only",
            "m::ok",
            "--only",
            "m::bad",
        ]
        .into_iter()
        .chain(["--only", "m::slow", "--only", "m::hang"])
        .collect::<Vec<_>>(),
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{out}");
    let row = |h: &str| {
        out.lines()
            .find(|l| l.starts_with(h))
            .unwrap_or_default()
            .to_string()
    };
    assert!(
        row("m::ok ").contains("SUCCESSFUL") && row("m::ok ").contains("0 of 90"),
        "{out}"
    );
    assert!(
        row("m::bad ").contains("FAILED") && row("m::bad ").contains("1 of 459"),
        "{out}"
    );
    assert!(row("m::slow ").contains("TIMEOUT"), "{out}");
    assert!(row("m::hang ").contains("TIMEOUT"), "{out}");
    assert!(
        out.contains("failed check: property `p`: `x <= 1` is false after the step"),
        "{out}"
    );
    assert!(out.contains("killed 1 s after the time limit"), "{out}");
    assert!(
        out.contains("4 harnesses: 1 successful, 1 failed, 2 timed out"),
        "{out}"
    );
    // The hung run was killed at its deadline (2 s), not after its 60 s.
    assert!(start.elapsed().as_secs() < 30, "{:?}", start.elapsed());
    assert!(
        !dir.join("kani-list.json").exists(),
        "the list file is left behind"
    );
}

#[test]
fn a_passing_selection_exits_0_and_writes_json() {
    let dir = fake_dir("json");
    let json = dir.join("k.json");
    let o = qloop(
        &dir,
        &["--only", "m::ok", "--json", &json.display().to_string()],
    );
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["harnesses"][0]["verdict"], "SUCCESSFUL");
    assert_eq!(v["harnesses"][0]["checks"], 90);
    let o = qloop(&dir, &["--only", "nothing_matches"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no harness"));
}

#[test]
fn missing_kani_says_how_to_get_it() {
    let dir = fake_dir("missing");
    let o = Command::new(env!("CARGO_BIN_EXE_qloop"))
        .args(["kani", "--cargo", "/nonexistent/cargo"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("build Kani from source"));
}
