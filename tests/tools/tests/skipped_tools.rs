//! The list, at the end of `cargo test --workspace`, of the tool-dependent tests that were
//! skipped in this run and why, so that a user without, say, avr-gcc knows what did not run.
//!
//! How it gets to the end. cargo has no hook after the last test, so this is a test binary
//! that cargo runs after all the others:
//! * cargo sorts the test binaries of a run by package name, then by kind (library unit tests,
//!   binaries, then test targets), then by target name, and runs them in that order; the
//!   doc-tests of every package follow. This package, `test-tools`, sorts after every `qloop-*`
//!   package (a unit test of the library checks that against the workspace's members), and
//!   this is its only test target. So it runs after every other test binary, and only the
//!   `Doc-tests` blocks (with no or ignored tests in this workspace) print after it. It runs
//!   when the run reaches it: after a failing binary cargo stops, unless `--no-fail-fast`
//!   (which `.ci/run` passes), and `cargo test -p PKG` without this package does not run it;
//!   the note each skip writes to the terminal at once is shown in every case.
//! * `harness = false`: a libtest harness would capture what a passing test prints.
//! * Each skipped test appended its line to the record file of this run
//!   ([`test_tools::record_file`]: named after the `cargo` process, the parent of every test
//!   binary it runs), so this binary reads exactly this run's skips, then removes the file.
//!
//! The first line, `tool-dependent tests skipped: N`, is read by `.ci/run`'s closing tally.

use std::time::Duration;

fn main() {
    // `--list` (cargo test -- --list, nextest): there is no test to list here.
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let file = test_tools::record_file();
    let skips = test_tools::read_records(&file);
    let _ = std::fs::remove_file(&file);
    // Records of runs that never got here (a single test binary, a run that stopped early).
    test_tools::remove_stale_records(Duration::from_secs(24 * 3600));

    let require = if test_tools::required() {
        " (QLOOP_REQUIRE_TOOLS is set: a missing tool fails its test)"
    } else {
        ""
    };
    if skips.is_empty() {
        println!("tool-dependent tests skipped: 0{require}");
        return;
    }
    let tests: std::collections::BTreeSet<String> = skips.iter().map(|s| s.name()).collect();
    println!(
        "tool-dependent tests skipped: {} (each passed without the check that needs the tool):",
        tests.len()
    );
    for s in &skips {
        println!("  {}: {}", s.name(), s.reason);
    }
    println!(
        "Install what is missing (.ci/run lists the packages), or set QLOOP_REQUIRE_TOOLS=1 to \
         make a missing tool fail its test."
    );
}
