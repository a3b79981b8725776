//! `qloop kani`: runs every Kani harness of a crate (default `qloop-verified`) one at a time,
//! each with a time limit, and prints a table: harness, verdict, checks, seconds.
//!
//! One at a time because parallel CBMC runs on a small machine inflate each other's times, and
//! the table is a measurement. Each harness runs as `cargo kani --tests --package=P --exact
//! --harness H --output-format terse -Z unstable-options -Z function-contracts -Z stubbing
//! --harness-timeout T` (the abstracted property harnesses `kani::stub` the step's products;
//! `-Z function-contracts` lets a crate's own contract harnesses run too). Kani stops
//! CBMC at `T` and reports "CBMC timed out", shown here as TIMEOUT. As a backstop the whole
//! `cargo kani` process group is killed `--grace-secs` after `T` (compiling happens once,
//! when the harnesses are listed, so a run needs little more than its verification time).
//!
//! Exit code 0 when every harness is SUCCESSFUL, 1 otherwise (a FAILED, TIMEOUT or ERROR
//! harness, or `cargo kani` missing), 2 for bad arguments or an unwritable `--json`.

mod outcome;
mod process;

use super::error::{CliError, CliResult};
pub use outcome::{parse_list, parse_outcome, Outcome, Verdict};
use std::path::Path;
use std::time::{Duration, Instant};

/// What `qloop kani` was asked to do.
pub struct KaniArgs<'a> {
    /// The package whose test harnesses to run.
    pub package: &'a str,
    /// Time limit per harness (Kani's `--harness-timeout`), in seconds.
    pub timeout: u64,
    /// Only harnesses whose name contains one of these (all if empty).
    pub only: &'a [String],
    /// SAT solver for every harness (overrides the harnesses' `kani::solver` attributes).
    pub solver: Option<&'a str>,
    /// Also write the table as JSON here.
    pub json: Option<&'a Path>,
    /// The cargo binary (tests use a fake one).
    pub cargo: &'a str,
    /// Seconds after the time limit at which the process group is killed.
    pub grace: u64,
}

/// Lists the harnesses, runs each, prints the table.
pub fn run(a: &KaniArgs) -> CliResult {
    let version = kani_version(a.cargo)?;
    let all = list(a)?;
    let harnesses: Vec<&String> = all
        .iter()
        .filter(|h| a.only.is_empty() || a.only.iter().any(|o| h.contains(o.as_str())))
        .collect();
    if harnesses.is_empty() {
        return Err(CliError::input(format!(
            "no harness of `{}` matches {:?} (it has {})",
            a.package,
            a.only,
            all.len()
        )));
    }
    let start = Instant::now();
    let mut rows = Vec::new();
    for (i, h) in harnesses.iter().enumerate() {
        eprintln!("[{}/{}] {h} ...", i + 1, harnesses.len());
        let row = run_one(a, h)?;
        eprintln!(
            "[{}/{}] {h}: {} in {:.1} s",
            i + 1,
            harnesses.len(),
            row.outcome.verdict,
            row.wall_s
        );
        rows.push(row);
    }
    let total = start.elapsed().as_secs_f64();
    print!("{}", table(&version, a, &rows, total));
    if let Some(path) = a.json {
        let text = json(&version, a, &rows, total);
        super::files::write_atomic(path, &text)?;
        println!("wrote {}", path.display());
    }
    let bad = rows
        .iter()
        .filter(|r| r.outcome.verdict != Verdict::Successful)
        .count();
    if bad > 0 {
        return Err(CliError::failed(format!(
            "{bad} of {} harnesses did not verify",
            rows.len()
        )));
    }
    Ok(())
}

/// One harness's result.
pub struct Row {
    /// Harness path.
    pub name: String,
    /// What Kani reported.
    pub outcome: Outcome,
    /// Wall-clock seconds of the `cargo kani` run.
    pub wall_s: f64,
}

/// `cargo kani --version`, or the error that says how to get Kani.
fn kani_version(cargo: &str) -> CliResult<String> {
    let out = std::process::Command::new(cargo)
        .args(["kani", "--version"])
        .output();
    match out {
        Ok(o) if o.status.success() => Ok(String::from_utf8_lossy(&o.stdout).trim().to_string()),
        _ => Err(CliError::tool(
            "`cargo kani` is not installed: `cargo install --locked kani-verifier && cargo kani \
             setup`, or where that cannot download, build Kani from source (docs/book/src/reference/kani.md)",
        )),
    }
}

/// The package's harnesses, from `cargo kani list --format json` (which compiles the crate).
fn list(a: &KaniArgs) -> CliResult<Vec<String>> {
    eprintln!(
        "listing the harnesses of `{}` (compiles the crate) ...",
        a.package
    );
    let args: Vec<String> = [
        "kani".to_string(),
        "--tests".into(),
        format!("--package={}", a.package),
        "list".into(),
        "-Z".into(),
        "function-contracts".into(),
        "-Z".into(),
        "stubbing".into(),
        "--format".into(),
        "json".into(),
    ]
    .into();
    let out = std::process::Command::new(a.cargo)
        .args(&args)
        .output()
        .map_err(|e| CliError::tool(format!("cannot run `{}`: {e}", a.cargo)))?;
    // `cargo kani list --format json` writes kani-list.json in the current directory.
    let file = Path::new("kani-list.json");
    let text = std::fs::read_to_string(file);
    let _ = std::fs::remove_file(file);
    match (out.status.success(), text) {
        (true, Ok(t)) => parse_list(&t).map_err(CliError::tool),
        _ => Err(CliError::tool(format!(
            "`cargo {}` failed:\n{}",
            args.join(" "),
            tail(&String::from_utf8_lossy(&out.stderr), 30)
        ))),
    }
}

/// Runs one harness with its time limit.
fn run_one(a: &KaniArgs, harness: &str) -> CliResult<Row> {
    let mut args: Vec<String> = vec![
        "kani".into(),
        "--tests".into(),
        format!("--package={}", a.package),
        "--exact".into(),
        "--harness".into(),
        harness.into(),
        "--output-format".into(),
        "terse".into(),
        "-Z".into(),
        "unstable-options".into(),
        "-Z".into(),
        "function-contracts".into(),
        "-Z".into(),
        "stubbing".into(),
        "--harness-timeout".into(),
        format!("{}s", a.timeout),
    ];
    if let Some(s) = a.solver {
        args.extend(["--solver".into(), s.into()]);
    }

    let backstop = Duration::from_secs(a.timeout + a.grace);
    let start = Instant::now();
    let done = process::run(a.cargo, &args, backstop)
        .map_err(|e| CliError::tool(format!("cannot run `{}`: {e}", a.cargo)))?;
    let wall_s = start.elapsed().as_secs_f64();
    let mut outcome = parse_outcome(&done.stdout);
    if done.killed {
        outcome.verdict = Verdict::Timeout;
        outcome.detail = Some(format!(
            "killed {} s after the time limit (backstop)",
            a.grace
        ));
    } else if outcome.verdict == Verdict::Timeout {
        outcome.detail = Some(format!("CBMC stopped at the {} s time limit", a.timeout));
    } else if outcome.verdict == Verdict::Error {
        outcome.detail = Some(tail(&format!("{}{}", done.stdout, done.stderr), 12));
    }
    Ok(Row {
        name: harness.to_string(),
        outcome,
        wall_s,
    })
}

/// The last `n` lines of `s`.
fn tail(s: &str, n: usize) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// The table, the failed checks and a summary line.
fn table(version: &str, a: &KaniArgs, rows: &[Row], total: f64) -> String {
    let w = rows.iter().map(|r| r.name.len()).max().unwrap_or(7).max(7);
    let mut o = format!(
        "{version}, package `{}`, time limit {} s per harness, one at a time{}\n\n",
        a.package,
        a.timeout,
        a.solver
            .map(|s| format!(", solver {s}"))
            .unwrap_or_default()
    );
    o.push_str(&format!(
        "{:<w$}  {:<10}  {:>15}  {:>9}  {:>7}\n",
        "harness", "verdict", "checks failed", "verify s", "wall s"
    ));
    for r in rows {
        let checks = match r.outcome.checks {
            Some((f, t)) => format!("{f} of {t}"),
            None => "-".into(),
        };
        let verify = r
            .outcome
            .verification_s
            .map(|s| format!("{s:.1}"))
            .unwrap_or_else(|| "-".into());
        o.push_str(&format!(
            "{:<w$}  {:<10}  {:>15}  {:>9}  {:>7.1}\n",
            r.name, r.outcome.verdict, checks, verify, r.wall_s
        ));
    }
    for r in rows
        .iter()
        .filter(|r| r.outcome.verdict != Verdict::Successful)
    {
        o.push_str(&format!("\n{} ({}):\n", r.name, r.outcome.verdict));
        for c in &r.outcome.failed_checks {
            o.push_str(&format!("  failed check: {c}\n"));
        }
        if let Some(d) = &r.outcome.detail {
            for l in d.lines() {
                o.push_str(&format!("  {l}\n"));
            }
        }
    }
    let count = |v: Verdict| rows.iter().filter(|r| r.outcome.verdict == v).count();
    o.push_str(&format!(
        "\n{} harnesses: {} successful, {} failed, {} timed out, {} errors; {:.0} s in all\n",
        rows.len(),
        count(Verdict::Successful),
        count(Verdict::Failed),
        count(Verdict::Timeout),
        count(Verdict::Error),
        total
    ));
    o
}

/// The table as JSON.
fn json(version: &str, a: &KaniArgs, rows: &[Row], total: f64) -> String {
    let harnesses: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            serde_json::json!({
                "harness": r.name,
                "verdict": r.outcome.verdict.to_string(),
                "checks_failed": r.outcome.checks.map(|c| c.0),
                "checks": r.outcome.checks.map(|c| c.1),
                "verification_s": r.outcome.verification_s,
                "wall_s": (r.wall_s * 10.0).round() / 10.0,
                "failed_checks": r.outcome.failed_checks,
            })
        })
        .collect();
    let v = serde_json::json!({
        "kani": version,
        "package": a.package,
        "timeout_s": a.timeout,
        "solver": a.solver,
        "total_s": (total * 10.0).round() / 10.0,
        "harnesses": harnesses,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default() + "\n"
}
