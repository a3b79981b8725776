//! Runs SMT solvers (z3, cvc5) as processes on SMT-LIB 2 scripts, in parallel, with timeouts,
//! and caches verdicts keyed by a hash of the script.
//!
//! One job per module:
//!
//! | module      | job                                                                    |
//! |-------------|------------------------------------------------------------------------|
//! | this one    | the vocabulary: [`Solver`], [`Query`], [`Answer`], [`Run`], [`Config`] |
//! | `portfolio` | every query on every solver, `jobs` at a time, with group cancellation |
//! | `run`       | one solver on one query: the text sent, cache, deadline, answer        |
//! | `batch`     | one solver on several small queries in one process                     |
//! | `process`   | a child process with a time limit and a cancel flag, always reaped     |
//! | `sexp`      | reading the S-expressions solvers print                                |
//! | `response`  | a solver's standard output as an [`Answer`] (verdict, bit-vector model) |
//! | `cache`     | the on-disk verdict cache                                              |
//! | `dedup`     | obligations equal up to the names of their symbols, asked once          |
//!
//! # Why no SMT crate
//!
//! Two well-kept crates were checked against what the prover needs; neither fits, for reasons
//! that are properties of their designs, not missing features one could add around them.
//!
//! * **easy-smt** (0.3.2) drives a solver as an interactive REPL. Its `Context` owns the child
//!   process privately and reads each response with a blocking line read on the calling
//!   thread, with no time limit: the only way to stop a solver is to drop the `Context`, which
//!   the blocked thread owns. So neither the per-query timeout, nor the proof's `--timeout`
//!   deadline, nor the portfolio's cancellation (a solver's proof of one encoding stops its
//!   runs on the other encodings of the same obligation; a replayed counterexample stops all
//!   of them) can be had without forking its process code. It also builds terms in its own
//!   arena and has no public parser for text, while qloop's obligations are SMT-LIB text
//!   (written to `--smt-dir` and hashed for the cache) that would have to be parsed back; it
//!   adds `(set-option :print-success true)` and sends command by command, so the text a
//!   solver sees, and with it every cache key, would change. Its `get_value` panics
//!   (`assert_eq!`, `unreachable!`) on a malformed pair instead of returning an error, its
//!   `get_u128` drops the bit-vector width that [`Answer::Sat`] reports and does not read
//!   `(_ bvN W)`, and the solver's standard error is inherited rather than read (cvc5's
//!   `interrupted by timeout` is how its own time limit is recognised).
//! * **lexpr** (0.2.7) reads Scheme-style S-expressions, not SMT-LIB's: `#x02` and
//!   `#b00000010` come back as the number 2, so the width is lost (`#b0000000`, 7 bits, cannot
//!   be told from `#b0`), and a 128-bit `#xff..ff` becomes a floating-point number;
//!   `|a b|` quoted symbols are rejected; the SMT-LIB 2.6 string `"a ""b"""` reads as three
//!   strings. The reader here is about 160 lines (`sexp`) and keeps atoms as written.
//!
//! Using either crate would mean writing around it as much code as `process` and `sexp`
//! hold, so both stay hand-written, each in its own module with its own tests.

mod batch;
mod cache;
mod dedup;
mod portfolio;
mod process;
mod response;
mod run;
mod sexp;
#[cfg(test)]
mod testing;

pub use portfolio::{run_all, run_all_batched, run_all_grouped};

use process::probe_version;
use std::path::PathBuf;
use std::sync::OnceLock;
use std::thread;
use std::time::Instant;

/// A solver qloop can drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Solver {
    /// Microsoft Research's Z3, run as `z3 -in -smt2`.
    Z3,
    /// cvc5, run as `cvc5 --lang=smt2`.
    Cvc5,
}

/// Memoised first lines of `--version`, indexed like [`Solver::ALL`]; `None` when it did not run.
static VERSIONS: [OnceLock<Option<String>>; 2] = [OnceLock::new(), OnceLock::new()];

impl Solver {
    /// Every solver qloop knows, in the default order.
    pub const ALL: [Solver; 2] = [Solver::Z3, Solver::Cvc5];

    /// The solver's name, which is also the binary looked up on `PATH`: `"z3"` or `"cvc5"`.
    pub fn name(self) -> &'static str {
        match self {
            Solver::Z3 => "z3",
            Solver::Cvc5 => "cvc5",
        }
    }

    /// Whether the binary runs (`z3 --version` / `cvc5 --version` succeeds and prints a line).
    /// Checked once per process and memoised.
    pub fn available(self) -> bool {
        self.version().is_some()
    }

    /// The first line of `<solver> --version`, memoised; `None` when the binary does not run.
    pub(super) fn version(self) -> Option<&'static str> {
        let slot = match self {
            Solver::Z3 => &VERSIONS[0],
            Solver::Cvc5 => &VERSIONS[1],
        };
        slot.get_or_init(|| probe_version(self.name())).as_deref()
    }

    /// Command-line arguments for one run with the given timeout.
    pub(super) fn args(self, timeout_ms: u64) -> Vec<String> {
        match self {
            Solver::Z3 => vec![
                "-in".to_string(),
                "-smt2".to_string(),
                format!("-T:{}", timeout_ms.div_ceil(1000).max(1)),
            ],
            Solver::Cvc5 => vec![
                "--lang=smt2".to_string(),
                format!("--tlimit={}", timeout_ms.saturating_add(1000)),
            ],
        }
    }
}

/// What one solver said about one script.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    /// `unsat`: no counterexample: the obligation is proved.
    Unsat,
    /// `sat`, with the values of the requested variables as (name, value) where value is the
    /// bit-vector read as an UNSIGNED integer (u128) together with its width in bits.
    /// Entries follow [`Query::want`], names exactly as given there.
    Sat(Vec<(String, u128, u32)>),
    /// Stopped early because the same solver proved another query of the same group
    /// (another encoding of the same obligation) first.
    Cancelled,
    /// No answer within the timeout (the process was killed; or the solver's own time limit,
    /// set a little later as a backstop, stopped it first).
    Timeout,
    /// `unknown`, a crash, a missing binary, or unparsable output: the message says which.
    Error(String),
}

/// One solver's answer and how long it took (wall clock, ms).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Run {
    /// The solver that answered.
    pub solver: Solver,
    /// What it answered.
    pub answer: Answer,
    /// Wall-clock time of the run in milliseconds; 0 for a cached answer.
    pub millis: u64,
    /// Whether the answer came from the verdict cache rather than a solver process.
    pub cached: bool,
    /// Whether the answer is that of another obligation's identical query (the same script
    /// up to the names of its declared symbols, `dedup`), taken without a run of its own.
    pub shared: bool,
}

/// A query: the full SMT-LIB script WITHOUT (check-sat)/(get-value), plus the variable names
/// whose model values are wanted on `sat` (each declared in the script as a bit-vector).
#[derive(Clone, Debug)]
pub struct Query {
    /// The SMT-LIB 2 script: `(set-logic ...)`, declarations and assertions.
    pub script: String,
    /// Names for `(get-value (...))`, written as SMT-LIB symbols (quote with `|...|` if needed).
    pub want: Vec<String>,
}

/// Settings.
#[derive(Clone, Debug)]
pub struct Config {
    /// Which solvers to run, in the order their [`Run`]s are returned (default: those of
    /// [`Solver::ALL`] that are available).
    pub solvers: Vec<Solver>,
    /// Timeout per solver per query, in milliseconds (default 60 Koren & Masory (1981)).
    pub timeout_ms: u64,
    /// Directory of the verdict cache; `None` (the default) disables caching.
    pub cache_dir: Option<PathBuf>,
    /// Maximum number of solver processes at once (default: the available parallelism);
    /// 0 is treated as 1.
    pub jobs: usize,
    /// When the whole proof must end (default: never). A run still going then is stopped (a
    /// timeout); a run not yet started is not started, and says so.
    pub deadline: Option<Instant>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            solvers: Solver::ALL.into_iter().filter(|s| s.available()).collect(),
            timeout_ms: 60_000,
            cache_dir: None,
            jobs: thread::available_parallelism().map_or(1, |n| n.get()),
            deadline: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solver_names_and_versions() {
        assert_eq!(Solver::Z3.name(), "z3");
        assert_eq!(Solver::Cvc5.name(), "cvc5");
        assert_eq!(Solver::ALL, [Solver::Z3, Solver::Cvc5]);
        for s in Solver::ALL {
            assert!(s.available(), "{}", s.name());
            let v = s.version().unwrap_or_default();
            assert!(v.to_lowercase().contains(s.name()), "{v}");
        }
        assert_eq!(Solver::Z3.args(300), ["-in", "-smt2", "-T:1"]);
        assert_eq!(Solver::Z3.args(60_001), ["-in", "-smt2", "-T:61"]);
        assert_eq!(Solver::Cvc5.args(300), ["--lang=smt2", "--tlimit=1300"]);
        let d = Config::default();
        assert_eq!(d.solvers, Solver::ALL.to_vec());
        assert_eq!(d.timeout_ms, 60_000);
        assert!(d.cache_dir.is_none() && d.jobs >= 1);
    }
}
