//! External tools for the workspace's tests (`codegen/tests`, `tests/tests`): find one, skip
//! the calling test without it, and say at the end of `cargo test` what was skipped and why.
//!
//! A test that needs a program the workspace does not build (a C cross-compiler, simavr,
//! QEMU, Frama-C, LinuxCNC, ...) asks [`tool`] for it, or [`rust_target`] for a Rust target's
//! standard library, or calls [`skip`] itself when what is missing is something else (a C
//! library, root rights). When it is missing, the test returns early and passes, and [`skip`]:
//!
//! * writes a note to the terminal at once, through the standard-error stream itself: libtest
//!   captures what a test prints with `eprintln!` and shows it only if the test fails, so an
//!   `eprintln!` note of a passing, skipped test is never seen;
//! * appends a line to the record file of this `cargo test` run ([`record_file`]), which the
//!   test target `skipped_tools` of this package prints after every other test binary of
//!   `cargo test --workspace` (`tests/skipped_tools.rs` says how it gets to run last).
//!
//! With `QLOOP_REQUIRE_TOOLS` set (to anything but empty or `0`), as `.ci/run` does after
//! installing every tool, a missing tool fails the test instead, so CI cannot pass by
//! skipping. `QLOOP_HIDE_TOOLS=avr-gcc,frama-c` makes [`tool`] and [`rust_target`] report
//! those names as missing, to see what a machine without them runs.

use std::fmt::Display;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, SystemTime};

/// Whether a missing tool fails the test: `QLOOP_REQUIRE_TOOLS` is set, and not to `0`.
pub fn required() -> bool {
    std::env::var_os("QLOOP_REQUIRE_TOOLS").is_some_and(|v| !v.is_empty() && v != "0")
}

/// Whether `QLOOP_HIDE_TOOLS` (a comma-separated list) names `name`: a test that finds a tool
/// by other means than [`find`] treats it as missing.
pub fn hidden(name: &str) -> bool {
    std::env::var("QLOOP_HIDE_TOOLS").is_ok_and(|v| {
        v.split(',')
            .any(|h| !h.trim().is_empty() && h.trim() == name)
    })
}

/// An executable file.
fn executable(p: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        p.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        p.is_file()
    }
}

/// An external program, by name on `PATH` (or by path, if `name` has a `/`), unless
/// `QLOOP_HIDE_TOOLS` names it. Only looks: a test that cannot run without it calls [`tool`].
pub fn find(name: &str) -> Option<PathBuf> {
    if hidden(name) {
        None
    } else if name.contains('/') {
        Some(PathBuf::from(name)).filter(|p| executable(p))
    } else {
        std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|d| d.join(name))
                .find(|p| executable(p))
        })
    }
}

/// An external program, as [`find`] finds it. Missing, it [`skip`]s the calling test (which
/// then returns) with the reason, and returns `None`; under `QLOOP_REQUIRE_TOOLS` it fails the
/// test.
pub fn tool(name: &str) -> Option<PathBuf> {
    let found = find(name);
    if found.is_none() {
        skip(format!("`{name}` is not installed"));
    }
    found
}

/// Whether the standard library of Rust target `triple` is installed in the sysroot of the
/// `rustc` cargo uses. Missing, it [`skip`]s the calling test with the `rustup` command that
/// installs it; under `QLOOP_REQUIRE_TOOLS` it fails the test.
pub fn rust_target(triple: &str) -> bool {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let sysroot = Command::new(rustc)
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    let ok = !hidden(triple)
        && sysroot.is_some_and(|s| s.join("lib/rustlib").join(triple).join("lib").is_dir());
    if !ok {
        skip(format!(
            "the Rust target {triple} is not installed (rustup target add {triple})"
        ));
    }
    ok
}

/// Skips the calling test, which should return right after: writes a note to the terminal and
/// records `reason` for the list printed at the end of `cargo test --workspace`. Under
/// `QLOOP_REQUIRE_TOOLS` it panics with `reason` instead.
pub fn skip(reason: impl Display) {
    let reason = reason.to_string();
    if required() {
        panic!("{reason}, and QLOOP_REQUIRE_TOOLS is set: a missing tool fails the test");
    }
    let s = Skip::here(&reason);
    // Straight to the stream: `eprintln!` would be captured by libtest and never shown.
    let note = format!("note: skipped {}: {}\n", s.name(), s.reason);
    let _ = std::io::stderr().lock().write_all(note.as_bytes());
    let file = record_file();
    let appended = file
        .parent()
        .is_some_and(|d| std::fs::create_dir_all(d).is_ok())
        && std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&file)
            // One write of one whole line, so that parallel tests do not interleave.
            .and_then(|mut f| f.write_all(s.line().as_bytes()))
            .is_ok();
    if !appended {
        let _ = std::io::stderr()
            .lock()
            .write_all(format!("note: cannot record the skip in {}\n", file.display()).as_bytes());
    }
}

/// One skipped test: its package, test binary and test name, and why it was skipped.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Skip {
    pub package: String,
    pub binary: String,
    pub test: String,
    pub reason: String,
}

impl Skip {
    /// The test running on this thread: libtest names each test's thread after the test, and
    /// cargo sets `CARGO_PKG_NAME` for the test binaries it runs.
    fn here(reason: &str) -> Skip {
        let exe = std::env::current_exe().ok();
        let binary = exe
            .as_ref()
            .and_then(|p| p.file_stem())
            .map(|s| {
                let s = s.to_string_lossy();
                // `NAME-<16 hex digits>`: cargo's hash of the build.
                match s.rsplit_once('-') {
                    Some((n, h)) if h.len() == 16 && h.bytes().all(|b| b.is_ascii_hexdigit()) => {
                        n.to_string()
                    }
                    _ => s.into_owned(),
                }
            })
            .unwrap_or_else(|| "?".into());
        let test = std::thread::current()
            .name()
            .filter(|n| *n != "main")
            .unwrap_or("?")
            .to_string();
        Skip {
            package: std::env::var("CARGO_PKG_NAME").unwrap_or_else(|_| "?".into()),
            binary,
            test,
            reason: reason.to_string(),
        }
    }

    /// `package/binary::test`.
    pub fn name(&self) -> String {
        format!("{}/{}::{}", self.package, self.binary, self.test)
    }

    /// The record: the four fields, tab-separated, on one line.
    fn line(&self) -> String {
        let clean = |s: &str| s.replace(['\t', '\n', '\r'], " ");
        format!(
            "{}\t{}\t{}\t{}\n",
            clean(&self.package),
            clean(&self.binary),
            clean(&self.test),
            clean(&self.reason)
        )
    }

    fn parse(line: &str) -> Option<Skip> {
        let mut f = line.splitn(4, '\t');
        Some(Skip {
            package: f.next()?.to_string(),
            binary: f.next()?.to_string(),
            test: f.next()?.to_string(),
            reason: f.next()?.to_string(),
        })
    }
}

/// Where the record files are: `qloop-skipped-tools/` in the directory of the build profile
/// (test binaries are `<target dir>/<profile>/deps/NAME-HASH`), so every test binary of one
/// build finds the same place.
pub fn records_dir() -> PathBuf {
    std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent()?.parent().map(Path::to_path_buf))
        .unwrap_or_else(std::env::temp_dir)
        .join("qloop-skipped-tools")
}

/// The record file of this run, named after the process that started this test binary:
/// `cargo test` runs every test binary as its own child, so they all share it, and two runs
/// at once (or one after the other) never mix their records.
pub fn record_file() -> PathBuf {
    #[cfg(unix)]
    let run = std::os::unix::process::parent_id();
    #[cfg(not(unix))]
    let run = 0;
    records_dir().join(format!("{run}.txt"))
}

/// The skips recorded in `file`, sorted, each once (a test records the same tool once per
/// call).
pub fn read_records(file: &Path) -> Vec<Skip> {
    let mut v: Vec<Skip> = std::fs::read_to_string(file)
        .unwrap_or_default()
        .lines()
        .filter_map(Skip::parse)
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Removes the record files no summary will read: those of runs that never got to it (a
/// single test binary, a run that stopped at a failure), once their `cargo` process has
/// exited (where `/proc` tells), or else once they are older than `age`.
pub fn remove_stale_records(age: Duration) {
    let Ok(dir) = std::fs::read_dir(records_dir()) else {
        return;
    };
    let proc = Path::new("/proc/self").is_dir();
    let now = SystemTime::now();
    for e in dir.filter_map(Result::ok) {
        let path = e.path();
        let pid = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        let exited = proc && !Path::new("/proc").join(pid).exists();
        let old = e
            .metadata()
            .and_then(|m| m.modified())
            .is_ok_and(|t| now.duration_since(t).is_ok_and(|d| d > age));
        if exited || old {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// Whether this is the acceptance tier's run: `QLOOP_ACCEPTANCE` is set, and not to `0`
/// (`.ci/run` sets it for the acceptance tier; the book's "Tests and their tiers").
pub fn acceptance() -> bool {
    std::env::var_os("QLOOP_ACCEPTANCE").is_some_and(|v| !v.is_empty() && v != "0")
}

/// Random cases for a sampling test (proptest): `full` in the acceptance tier
/// ([`acceptance`]), an eighth of it (at least 32) in the default run, which keeps every such
/// test but spends seconds, not minutes, on it.
pub fn cases(full: u32) -> u32 {
    if acceptance() {
        full
    } else {
        (full / 8).max(32)
    }
}

/// The workspace root (this crate is `tests/tools/`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The stems of the `*.qloop` files of `folder` (relative to the workspace root), sorted.
pub fn spec_stems_in(folder: &str) -> Vec<String> {
    let dir = workspace_root().join(folder);
    let mut v: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "qloop"))
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    v.sort();
    v
}

/// Asserts that `listed` names every `*.qloop` file of `folder` (relative to the workspace
/// root) exactly once, and nothing else: a spec added to the folder without a test, or a test
/// left after its spec was removed, fails here by name. Used by [`spec_tests!`].
pub fn assert_lists_folder(folder: &str, listed: &[&str]) {
    let files = spec_stems_in(folder);
    let mut names: Vec<&str> = listed.to_vec();
    names.sort_unstable();
    let twice: Vec<&&str> = names
        .windows(2)
        .filter(|w| w[0] == w[1])
        .map(|w| &w[0])
        .collect();
    assert!(twice.is_empty(), "listed twice: {twice:?}");
    let missing: Vec<&String> = files
        .iter()
        .filter(|f| !names.contains(&f.as_str()))
        .collect();
    let extra: Vec<&&str> = names
        .iter()
        .filter(|n| !files.iter().any(|f| f == *n))
        .collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "the specs of {folder} and the tests listed for them differ: without a test {missing:?}, \
         without a spec {extra:?}; list each spec under `default` or `acceptance`"
    );
}

/// One `#[test]` per spec of a folder, so that a failure names its spec and the specs run in
/// parallel. `spec_tests! { NAME in "FOLDER"; default: [..]; acceptance: [..]; }` next to a
/// function `fn NAME(stem: &str)` declares a module `NAME` holding a test per listed stem,
/// `NAME::<stem>`, which calls the function with it. The stems under `default` run in `cargo
/// test`; those under `acceptance` are `#[ignore]`d, and the acceptance tier runs them (the
/// book's "Tests and their tiers"). A last test, `NAME::every_spec_of_the_folder_has_a_test`, checks that the two lists
/// together name every `*.qloop` file of `FOLDER` (relative to the workspace root), and only
/// those. Several checks with the same tiers share one call: `spec_tests! { A, B in "FOLDER";
/// .. }` declares modules `A` and `B`.
///
/// ```ignore
/// /// Every seed spec is proved from scratch.
/// fn proved(stem: &str) {
///     prove(&format!("verified/specs/{stem}.qloop"));
/// }
/// test_tools::spec_tests! {
///     proved in "verified/specs";
///     default: [koren_masory_1981, grinding_pi];
///     acceptance: [milling_multimodel];
/// }
/// ```
#[macro_export]
macro_rules! spec_tests {
    (
        @one $name:ident in $folder:literal;
        default: [$($d:ident),* $(,)?];
        acceptance: [$($a:ident),* $(,)?]
    ) => {
        /// One test per spec of the folder (`test_tools::spec_tests!`).
        mod $name {
            $(
                #[test]
                fn $d() {
                    super::$name(stringify!($d))
                }
            )*
            $(
                #[test]
                #[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
                fn $a() {
                    super::$name(stringify!($a))
                }
            )*
            #[test]
            fn every_spec_of_the_folder_has_a_test() {
                $crate::assert_lists_folder(
                    $folder,
                    &[$(stringify!($d),)* $(stringify!($a),)*],
                );
            }
        }
    };
    // Several checks over the same folder with the same tiers: one module each.
    (
        $($name:ident),+ in $folder:literal;
        default: $d:tt;
        acceptance: $a:tt $(;)?
    ) => {
        $($crate::spec_tests!(@one $name in $folder; default: $d; acceptance: $a);)+
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_reads_back() {
        let s = Skip {
            package: "qloop-tests".into(),
            binary: "c_output".into(),
            test: "c_compiles".into(),
            reason: "`avr-gcc`\tis\nnot installed".into(),
        };
        let back = Skip::parse(s.line().trim_end_matches('\n')).unwrap();
        assert_eq!(back.name(), "qloop-tests/c_output::c_compiles");
        assert_eq!(back.reason, "`avr-gcc` is not installed");
    }

    /// `.ci/run`'s acceptance tier runs the default tier's sampling tests again at full scale
    /// through a nextest filter (`scaled=`) and, apart from those, only the `#[ignore]`d
    /// tests: a module that calls [`cases`] must be named there, or its full case count
    /// would never run.
    #[test]
    fn every_module_that_scales_its_cases_is_in_the_acceptance_filter() {
        let root = workspace_root();
        let ci = std::fs::read_to_string(root.join(".ci/run")).unwrap();
        let filter = ci
            .split_once("scaled='")
            .and_then(|(_, r)| r.split_once('\''))
            .expect(".ci/run defines the filter `scaled='...'`")
            .0;
        assert!(filter.contains("package(qloop-verified)"), "{filter}");
        // The module list of the clause that names `binary`, as `^(a|b|c)::`.
        let modules = |binary: &str| -> Vec<String> {
            let clause = filter
                .split('|')
                .map(str::trim)
                .collect::<Vec<_>>()
                .join("|");
            let at = clause
                .find(&format!("binary_id({binary})"))
                .unwrap_or_else(|| panic!("no clause for {binary} in {filter}"));
            let rest = &clause[at..];
            let list = rest
                .split_once("test(/^(")
                .and_then(|(_, r)| r.split_once(")::/)"))
                .unwrap_or_else(|| panic!("clause for {binary}: {rest}"))
                .0;
            list.split('|').map(str::to_string).collect()
        };
        let mut checked = 0;
        for (dir, binary) in [
            ("tests/tests", "qloop-tests::integration"),
            ("codegen/tests", "qloop::integration"),
        ] {
            let listed = modules(binary);
            for e in std::fs::read_dir(root.join(dir)).unwrap() {
                let path = e.unwrap().path();
                if path.extension().is_none_or(|x| x != "rs") {
                    continue;
                }
                let text = std::fs::read_to_string(&path).unwrap();
                if !text.contains("test_tools::cases(") {
                    continue;
                }
                let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
                assert!(
                    listed.contains(&stem),
                    "{}: calls test_tools::cases but `{stem}` is not in .ci/run's `scaled` \
                     filter for {binary}: add it there",
                    path.display()
                );
                checked += 1;
            }
        }
        assert!(checked >= 5, "found only {checked} modules calling cases()");
    }

    /// The summary runs last only while this package's name sorts after every other
    /// package of the workspace (cargo orders test binaries by package name).
    #[test]
    fn this_package_sorts_after_every_other_workspace_member() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let ws = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
        let members = ws
            .split_once("members = [")
            .and_then(|(_, r)| r.split_once(']'))
            .expect("workspace members")
            .0;
        let mut names = Vec::new();
        for m in members.split(',').map(|m| m.trim().trim_matches('"')) {
            if m.is_empty() {
                continue;
            }
            let manifest = std::fs::read_to_string(root.join(m).join("Cargo.toml")).unwrap();
            let name = manifest
                .lines()
                .find_map(|l| l.strip_prefix("name = \""))
                .and_then(|l| l.strip_suffix('"'))
                .unwrap_or_else(|| panic!("{m}: no package name"));
            names.push(name.to_string());
        }
        assert!(
            names.iter().any(|n| n == env!("CARGO_PKG_NAME")),
            "{names:?}"
        );
        for n in names.iter().filter(|n| *n != env!("CARGO_PKG_NAME")) {
            assert!(
                n.as_str() < env!("CARGO_PKG_NAME"),
                "package `{n}` sorts after `{}`, so the skipped-tools summary would not run \
                 last: rename one of them",
                env!("CARGO_PKG_NAME")
            );
        }
    }
}
