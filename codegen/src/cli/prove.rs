//! `qloop prove`: every obligation (overflow, initial, inductive, properties) with z3 and cvc5,
//! the report table on standard output and, optionally, as JSON and the SMT-LIB scripts.

use super::args::Solvers;
use super::error::{CliError, CliResult};
use super::files::{create_dir, load, write_atomic};
use qloop::prove::solver::{Config, Solver};
use qloop::prove::Progress;
use qloop::Plan;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What `qloop prove` was asked to do.
pub struct ProveArgs<'a> {
    /// The spec file.
    pub spec: &'a Path,
    /// `--json FILE`.
    pub json: Option<&'a Path>,
    /// `--timeout SECS` for the whole proof.
    pub timeout: Option<u64>,
    /// `--query-timeout SECS` per solver per query.
    pub query_timeout: u64,
    /// `--jobs N`.
    pub jobs: Option<usize>,
    /// `--solvers`.
    pub solvers: Solvers,
    /// `--cache DIR`.
    pub cache: Option<PathBuf>,
    /// `--no-cache`.
    pub no_cache: bool,
    /// `--smt-dir DIR`.
    pub smt_dir: Option<&'a Path>,
    /// `--only TEXT`.
    pub only: Option<&'a str>,
    /// `--target`.
    pub target: &'a str,
    /// `--verbose`: the full table, not only the summary.
    pub verbose: bool,
}

/// Proves the spec and prints the table; fails (exit 1) unless everything is proved.
pub fn run(a: ProveArgs) -> CliResult {
    let (plan, _) = load(a.spec, a.target)?;
    if let Some(dir) = a.smt_dir {
        write_smt(&plan, dir)?;
    }
    let mut cfg = solver_config(a.solvers, a.query_timeout, a.jobs, a.cache, a.no_cache)?;
    let start = Instant::now();
    cfg.deadline = a.timeout.map(|t| start + Duration::from_secs(t));
    let report = prove_with_progress(&plan, &cfg, a.only);
    if a.verbose {
        print!("{}", report.table(&plan));
    } else {
        print!("{}", report.summary(&plan));
        println!("\n(every obligation's row and what the verdicts mean: `qloop prove --verbose`)");
    }
    if let Some(j) = a.json {
        write_atomic(j, &report.json())?;
    }
    if report.proved() {
        Ok(())
    } else {
        // The table says what is refuted or unknown.
        Err(CliError::Failed(None))
    }
}

/// The solver configuration: the wanted solvers that are installed (a warning names each
/// missing one), the per-query limit, the jobs and the verdict cache. Fails (a tool error)
/// when no wanted solver is installed.
pub fn solver_config(
    which: Solvers,
    timeout: u64,
    jobs: Option<usize>,
    cache: Option<PathBuf>,
    no_cache: bool,
) -> CliResult<Config> {
    let wanted: Vec<Solver> = match which {
        Solvers::Both => Solver::ALL.to_vec(),
        Solvers::Z3 => vec![Solver::Z3],
        Solvers::Cvc5 => vec![Solver::Cvc5],
    };
    let solvers: Vec<Solver> = wanted.iter().copied().filter(|s| s.available()).collect();
    for s in wanted.iter().filter(|s| !s.available()) {
        eprintln!(
            "warning: {} is not installed (on Debian: apt-get install {})",
            s.name(),
            s.name()
        );
    }
    if solvers.is_empty() {
        return Err(CliError::tool(
            "no SMT solver available; install z3 and cvc5 (apt-get install z3 cvc5)",
        ));
    }
    let mut cfg = Config {
        solvers,
        timeout_ms: timeout.saturating_mul(1000),
        ..Config::default()
    };
    if let Some(j) = jobs {
        cfg.jobs = j.max(1);
    }
    cfg.cache_dir = if no_cache {
        None
    } else {
        cache
            .or_else(|| std::env::var_os("QLOOP_CACHE").map(PathBuf::from))
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/qloop")))
    };
    Ok(cfg)
}

/// Writes every obligation's SMT-LIB script to `dir` (one `.smt2` file each).
fn write_smt(plan: &Plan, dir: &Path) -> CliResult {
    create_dir(dir)?;
    for (i, ob) in qloop::prove::obligations::obligations(plan)
        .iter()
        .enumerate()
    {
        let text = format!(
            "; qloop obligation {i}: {} ({})\n(set-option :produce-models true)\n{}(check-sat)\n",
            ob.label(),
            ob.kind.name(),
            ob.query.script
        );
        write_atomic(&dir.join(format!("{i:03}-{}.smt2", ob.kind.name())), &text)?;
    }
    Ok(())
}

/// Runs the prover with a progress bar on standard error (hidden when it is not a terminal;
/// then a plain line every 10 s instead).
pub fn prove_with_progress(plan: &Plan, cfg: &Config, only: Option<&str>) -> qloop::prove::Report {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} proving {pos}/{len} solver runs [{elapsed}] {wide_bar}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Without a terminal (CI logs), a plain line every 10 s instead of the bar.
    let quiet = bar.is_hidden();
    let start = Instant::now();
    let mut last = start;
    let report = qloop::prove::prove_filtered(plan, cfg, only, &mut |p| match p {
        Progress::Runs { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            if quiet && (last.elapsed().as_secs() >= 10 || done == total) {
                last = Instant::now();
                eprintln!(
                    "qloop prove: {done}/{total} solver runs done, {:.0} s",
                    start.elapsed().as_secs_f64()
                );
            }
        }
        Progress::Group {
            kind,
            queries,
            secs,
        } => {
            let line =
                format!("qloop prove: {kind} obligations done ({queries} queries), {secs:.1} s");
            if quiet {
                eprintln!("{line}");
            } else {
                bar.println(line);
            }
        }
    });
    bar.finish_and_clear();
    report
}
