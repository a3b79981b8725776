//! Runs SMT solvers (z3, cvc5) as processes on SMT-LIB 2 scripts, in parallel, with timeouts,
//! and caches verdicts keyed by a hash of the script.
//!
//! # What is sent
//!
//! For a [`Query`] the solver's standard input receives exactly
//!
//! ```text
//! (set-option :produce-models true)
//! <script>
//! (check-sat)
//! (get-value (<want 1> <want 2> ...))   ; only when `want` is non-empty
//! (exit)
//! ```
//!
//! The option comes first because SMT-LIB requires `:produce-models` to be set before the
//! script's `(set-logic ...)`.
//!
//! # How the solvers are run
//!
//! * z3: `z3 -in -smt2 -T:<seconds>`, the timeout rounded up to whole seconds (at least 1);
//! * cvc5: `cvc5 --lang=smt2 --tlimit=<timeout ms + 1000>`.
//!
//! The solver's own limit is only a backstop for when this process dies: the timeout is
//! enforced here, by killing the child at the deadline and reaping it. Standard input is fed
//! and standard output and error are drained by helper threads, so no pipe can fill up.
//! (A solver that exits without reading all its input makes the feeding write fail with
//! `EPIPE`; that is harmless because Rust programs ignore `SIGPIPE`, as std sets up before
//! `main`.)
//!
//! # Reading the answer
//!
//! The first S-expression on standard output decides: `unsat` is [`Answer::Unsat`]; `sat` is
//! [`Answer::Sat`] once the `get-value` response that follows it has been parsed (values may be
//! `#b...`, `#x...` or `(_ bvN W)`); z3's `timeout` is [`Answer::Timeout`]; `unknown`,
//! `(error "...")`, no output, truncated output or anything else is [`Answer::Error`].
//!
//! # Cache
//!
//! With [`Config::cache_dir`] set, `unsat` and `sat` verdicts are stored one file per key, the
//! key being the SHA-256 (implemented here, so stable across Rust versions) of the solver's
//! name, the first line of its `--version` output and the full text sent. Files are written to
//! a temporary name and renamed into place; a file that does not parse is treated as a miss
//! and replaced by the next verdict.

use std::fmt::Write as _;
use std::fs;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, OnceLock};
use std::thread;
use std::time::{Duration, Instant};

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

/// How long `--version` may take before the binary is considered unusable.
const VERSION_TIMEOUT: Duration = Duration::from_secs(10);

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
    fn version(self) -> Option<&'static str> {
        let slot = match self {
            Solver::Z3 => &VERSIONS[0],
            Solver::Cvc5 => &VERSIONS[1],
        };
        slot.get_or_init(|| probe_version(self.name())).as_deref()
    }

    /// Command-line arguments for one run with the given timeout.
    fn args(self, timeout_ms: u64) -> Vec<String> {
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
    /// Timeout per solver per query, in milliseconds (default 60 000).
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

/// Runs every query on every configured solver, at most `jobs` processes at once, and returns,
/// for each query in order, one Run per solver (in Config.solvers order).
/// `progress` is called after each finished run with (done, total) so a CLI can draw a bar.
pub fn run_all(
    queries: &[Query],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize),
) -> Vec<Vec<Run>> {
    let groups: Vec<usize> = (0..queries.len()).collect();
    run_all_grouped(queries, &groups, cfg, progress, &mut |_, _| false)
}

/// Like [`run_all`], where `groups[i]` names the group of query `i`: queries of one group
/// are alternative encodings of one obligation. Once a solver proves one of them (`unsat`),
/// that solver's runs on the group's other queries are cancelled ([`Answer::Cancelled`]);
/// the other solvers go on. Groups of one query run every solver to the end.
///
/// `confirm(i, run)` is called (on the calling thread) for each `sat` answer to query `i`;
/// when it returns true (the counterexample replays: the obligation is refuted) every other
/// run of the group is cancelled, for every solver.
pub fn run_all_grouped(
    queries: &[Query],
    groups: &[usize],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize),
    confirm: &mut dyn FnMut(usize, &Run) -> bool,
) -> Vec<Vec<Run>> {
    let ngroups = groups.iter().copied().max().map_or(0, |g| g + 1);
    let mut sizes = vec![0usize; ngroups];
    for g in groups {
        sizes[*g] += 1;
    }
    let solvers = &cfg.solvers;
    // One flag per (group, solver): a solver that has proved one encoding of a group stops
    // working on the others, while the other solver goes on to its own proof (the report
    // aims for both solvers on every obligation).
    let proved: Vec<AtomicBool> = (0..ngroups * solvers.len())
        .map(|_| AtomicBool::new(false))
        .collect();
    let per_query = solvers.len();
    let total = queries.len() * per_query;
    let mut slots: Vec<Vec<Option<Run>>> = vec![vec![None; per_query]; queries.len()];

    if total > 0 {
        let versions: Vec<Option<&'static str>> = solvers.iter().map(|s| s.version()).collect();
        let texts: Vec<String> = queries.iter().map(solver_text).collect();
        let next = AtomicUsize::new(0);
        let (tx, rx) = mpsc::channel::<(usize, usize, Run)>();

        // Takes the next task, or `None` when all have been handed out.
        let task = |next: &AtomicUsize| -> Option<(usize, usize, Run)> {
            let t = next.fetch_add(1, Ordering::Relaxed);
            if t >= total {
                return None;
            }
            // Solver-major order: every query's first solver, then the second: the encodings
            // of one obligation run side by side, and a solver's first proof cancels its
            // runs on the rest.
            let nq = queries.len();
            let (qi, si) = (t % nq, t / nq);
            let g = groups.get(qi).copied().unwrap_or(0);
            let shared = sizes.get(g).copied().unwrap_or(1) > 1;
            let flag = proved.get(g * per_query + si).filter(|_| shared);
            if flag.is_some_and(|f| f.load(Ordering::Relaxed)) {
                let run = Run {
                    solver: solvers[si],
                    answer: Answer::Cancelled,
                    millis: 0,
                    cached: false,
                };
                return Some((qi, si, run));
            }
            let run = run_one(
                solvers[si],
                versions[si],
                &texts[qi],
                &queries[qi].want,
                cfg,
                flag,
            );
            if run.answer == Answer::Unsat {
                if let Some(f) = flag {
                    f.store(true, Ordering::Relaxed);
                }
            }
            Some((qi, si, run))
        };

        thread::scope(|scope| {
            let workers = cfg.jobs.clamp(1, total);
            let mut spawned = 0;
            for _ in 0..workers {
                let tx = tx.clone();
                let (task, next) = (&task, &next);
                let worker = thread::Builder::new()
                    .name("qloop-smt".to_string())
                    .spawn_scoped(scope, move || {
                        while let Some(result) = task(next) {
                            if tx.send(result).is_err() {
                                break;
                            }
                        }
                    });
                if worker.is_ok() {
                    spawned += 1;
                }
            }
            drop(tx);

            let mut done = 0;
            let mut record = |(qi, si, run): (usize, usize, Run)| {
                if matches!(run.answer, Answer::Sat(_)) && confirm(qi, &run) {
                    let g = groups.get(qi).copied().unwrap_or(0);
                    for f in proved.iter().skip(g * per_query).take(per_query) {
                        f.store(true, Ordering::Relaxed);
                    }
                }
                slots[qi][si] = Some(run);
                done += 1;
                progress(done, total);
            };
            if spawned == 0 {
                // No thread could be started: do the work here, one process at a time.
                while let Some(result) = task(&next) {
                    record(result);
                }
            } else {
                for result in rx {
                    record(result);
                }
            }
        });
    }

    slots
        .into_iter()
        .map(|row| {
            row.into_iter()
                .zip(solvers)
                .map(|(run, &solver)| {
                    run.unwrap_or_else(|| Run {
                        solver,
                        answer: Answer::Error("internal error: the run produced no result".into()),
                        millis: 0,
                        cached: false,
                    })
                })
                .collect()
        })
        .collect()
}

/// The exact text fed to a solver's standard input for `query`.
fn solver_text(query: &Query) -> String {
    let mut text = String::with_capacity(query.script.len() + 128);
    text.push_str("(set-option :produce-models true)\n");
    text.push_str(&query.script);
    text.push_str("\n(check-sat)\n");
    if !query.want.is_empty() {
        text.push_str("(get-value (");
        text.push_str(&query.want.join(" "));
        text.push_str("))\n");
    }
    text.push_str("(exit)\n");
    text
}

/// One solver on one query: from the cache if possible, otherwise by running the solver (and
/// caching a definite verdict).
fn run_one(
    solver: Solver,
    version: Option<&str>,
    text: &str,
    want: &[String],
    cfg: &Config,
    cancel: Option<&AtomicBool>,
) -> Run {
    let Some(version) = version else {
        return Run {
            solver,
            answer: Answer::Error(format!(
                "{0} is not installed (`{0} --version` did not run)",
                solver.name()
            )),
            millis: 0,
            cached: false,
        };
    };
    let cache = cfg
        .cache_dir
        .as_deref()
        .map(|dir| (dir, cache_key(solver, version, text)));
    if let Some((dir, key)) = &cache {
        if let Some(answer) = cache_load(dir, key, want) {
            return Run {
                solver,
                answer,
                millis: 0,
                cached: true,
            };
        }
    }
    let start = Instant::now();
    // The per-query timeout, cut short by the proof's deadline.
    let timeout_ms = match cfg.deadline {
        None => cfg.timeout_ms,
        Some(end) => {
            let left = end.saturating_duration_since(start).as_millis();
            if left == 0 {
                return Run {
                    solver,
                    answer: Answer::Error(
                        "not run: the proof's time limit (--timeout) was reached first".into(),
                    ),
                    millis: 0,
                    cached: false,
                };
            }
            cfg.timeout_ms.min(u64::try_from(left).unwrap_or(u64::MAX))
        }
    };
    let answer = execute(
        solver.name(),
        &solver.args(timeout_ms),
        text,
        want,
        Duration::from_millis(timeout_ms),
        cancel,
    );
    let millis = u64::try_from(start.elapsed().as_millis()).unwrap_or(u64::MAX);
    if let Some((dir, key)) = &cache {
        if matches!(answer, Answer::Unsat | Answer::Sat(_)) {
            // The cache is an optimisation: failing to write it is not an error.
            let _ = cache_store(dir, key, &answer);
        }
    }
    Run {
        solver,
        answer,
        millis,
        cached: false,
    }
}

// ---------------------------------------------------------------------------------------------
// Processes
// ---------------------------------------------------------------------------------------------

/// At most this much of a child's stdout or stderr is kept; the rest is read and dropped.
const OUTPUT_LIMIT: u64 = 16 << 20;

/// How long to wait for the output readers once the child has been reaped (they only outlive
/// it if something else holds the pipes open).
const DRAIN_GRACE: Duration = Duration::from_secs(2);

/// A child process that has been reaped.
#[derive(Debug)]
struct Finished {
    /// Its standard output (lossily decoded).
    stdout: String,
    /// Its standard error (lossily decoded).
    stderr: String,
    /// Its exit status, if `wait` reported one.
    status: Option<ExitStatus>,
    /// Whether the deadline passed and it was killed.
    timed_out: bool,
    /// Whether it was killed because its group was already proved.
    cancelled: bool,
    /// Its process id (for tests checking that it is gone).
    #[cfg_attr(not(test), allow(dead_code))]
    pid: u32,
}

/// Runs `program args`, feeding `input` on stdin, and kills it once `timeout` has passed.
/// The child is always reaped before this returns; `Err` only when it could not be started.
fn run_process(
    program: &str,
    args: &[String],
    input: &str,
    timeout: Duration,
    cancel: Option<&AtomicBool>,
) -> io::Result<Finished> {
    let start = Instant::now();
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let pid = child.id();

    let helpers = (|| -> io::Result<_> {
        let stdin = child.stdin.take();
        let input = input.as_bytes().to_vec();
        // The writer is detached: once the child is gone its write fails and it ends.
        thread::Builder::new()
            .name("qloop-smt-stdin".to_string())
            .spawn(move || {
                if let Some(mut stdin) = stdin {
                    // A solver that exits early (say on a parse error) closes the pipe.
                    let _ = stdin.write_all(&input);
                }
            })?;
        let out = spawn_reader(child.stdout.take())?;
        let err = spawn_reader(child.stderr.take())?;
        Ok((out, err))
    })();
    let (out_rx, err_rx) = match helpers {
        Ok(rxs) => rxs,
        Err(e) => {
            let _ = child.kill();
            let _ = child.wait();
            return Err(e);
        }
    };

    // A timeout too large to represent means no deadline.
    let deadline = start.checked_add(timeout);
    let mut nap = Duration::from_millis(1);
    let mut cancelled = false;
    let (status, timed_out) = loop {
        if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            let _ = child.kill();
            cancelled = true;
            break (child.wait().ok(), false);
        }
        match child.try_wait() {
            Ok(Some(status)) => break (Some(status), false),
            Ok(None) => {}
            Err(_) => {
                // Cannot poll: fall back to a blocking wait (the solver's own limit ends it).
                break (child.wait().ok(), false);
            }
        }
        let now = Instant::now();
        let left = match deadline {
            Some(deadline) if now >= deadline => {
                let _ = child.kill();
                break (child.wait().ok(), true);
            }
            Some(deadline) => deadline - now,
            None => nap,
        };
        thread::sleep(nap.min(left));
        nap = (nap * 2).min(Duration::from_millis(10));
    };

    let collect = |rx: mpsc::Receiver<Vec<u8>>| {
        rx.recv_timeout(DRAIN_GRACE)
            .map(|bytes| String::from_utf8_lossy(&bytes).into_owned())
            .unwrap_or_default()
    };
    Ok(Finished {
        stdout: collect(out_rx),
        stderr: collect(err_rx),
        status,
        timed_out,
        cancelled,
        pid,
    })
}

/// Reads `pipe` to the end on a thread; the bytes (up to [`OUTPUT_LIMIT`]) arrive on the
/// returned channel.
fn spawn_reader<R: Read + Send + 'static>(pipe: Option<R>) -> io::Result<mpsc::Receiver<Vec<u8>>> {
    let (tx, rx) = mpsc::channel();
    if let Some(mut pipe) = pipe {
        thread::Builder::new()
            .name("qloop-smt-output".to_string())
            .spawn(move || {
                let mut bytes = Vec::new();
                let _ = (&mut pipe).take(OUTPUT_LIMIT).read_to_end(&mut bytes);
                let _ = io::copy(&mut pipe, &mut io::sink());
                let _ = tx.send(bytes);
            })?;
    }
    Ok(rx)
}

/// The first line of `program --version`, if it runs, exits successfully and prints one.
fn probe_version(program: &str) -> Option<String> {
    let fin = run_process(
        program,
        &["--version".to_string()],
        "",
        VERSION_TIMEOUT,
        None,
    )
    .ok()?;
    if fin.timed_out || !fin.status.is_some_and(|s| s.success()) {
        return None;
    }
    let line = fin.stdout.lines().map(str::trim).find(|l| !l.is_empty())?;
    Some(line.to_string())
}

/// Runs one solver binary on `text` and interprets what it printed.
fn execute(
    program: &str,
    args: &[String],
    text: &str,
    want: &[String],
    timeout: Duration,
    cancel: Option<&AtomicBool>,
) -> Answer {
    match run_process(program, args, text, timeout, cancel) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            Answer::Error(format!("{program} is not installed ({e})"))
        }
        Err(e) => Answer::Error(format!("could not run {program}: {e}")),
        Ok(fin) => interpret(program, want, &fin),
    }
}

/// Turns a finished solver process into an [`Answer`].
fn interpret(program: &str, want: &[String], fin: &Finished) -> Answer {
    if fin.cancelled {
        return Answer::Cancelled;
    }
    if fin.timed_out {
        return Answer::Timeout;
    }
    match parse_output(&fin.stdout, want) {
        Ok(answer) => answer,
        // cvc5's own `--tlimit` aborts with this message and no verdict.
        Err(_) if fin.stderr.contains("interrupted by timeout") => Answer::Timeout,
        Err(why) => {
            let status = match fin.status {
                Some(s) => s.to_string(),
                None => "unknown exit status".to_string(),
            };
            Answer::Error(format!(
                "{program}: {why} ({status}); stdout: {}; stderr: {}",
                excerpt(&fin.stdout),
                excerpt(&fin.stderr)
            ))
        }
    }
}

/// The first few non-empty lines of `text`, on one line, for error messages.
fn excerpt(text: &str) -> String {
    const LINES: usize = 5;
    const CHARS: usize = 400;
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    if lines.is_empty() {
        return "<empty>".to_string();
    }
    let mut out = lines[..lines.len().min(LINES)].join(" | ");
    if lines.len() > LINES {
        out.push_str(" | ...");
    }
    if out.chars().count() > CHARS {
        out = out.chars().take(CHARS).collect::<String>() + "...";
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Output parsing
// ---------------------------------------------------------------------------------------------

/// An S-expression as solvers print them.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Sexp {
    /// A symbol, keyword or literal, as written (quoted symbols keep their bars).
    Atom(String),
    /// A string literal, unescaped.
    Str(String),
    /// A parenthesised list.
    List(Vec<Sexp>),
}

impl Sexp {
    /// The atom's text, if this is an atom.
    fn atom(&self) -> Option<&str> {
        match self {
            Sexp::Atom(a) => Some(a),
            _ => None,
        }
    }
}

/// The deepest list nesting accepted in solver output (get-value responses need 3).
const MAX_DEPTH: usize = 256;

/// Reads S-expressions one at a time, so that whatever follows the one needed (say the error
/// for `get-value` after `unsat`) cannot spoil it.
struct SexpReader<'a> {
    /// The text being read.
    text: &'a [u8],
    /// Position of the next unread byte.
    pos: usize,
}

impl<'a> SexpReader<'a> {
    /// A reader at the start of `text`.
    fn new(text: &'a str) -> Self {
        SexpReader {
            text: text.as_bytes(),
            pos: 0,
        }
    }

    /// Skips whitespace and `;` comments.
    fn skip_blank(&mut self) {
        while let Some(&b) = self.text.get(self.pos) {
            if b.is_ascii_whitespace() {
                self.pos += 1;
            } else if b == b';' {
                while self.text.get(self.pos).is_some_and(|&c| c != b'\n') {
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
    }

    /// The text between two byte positions (always on character boundaries here, since the
    /// delimiters are ASCII).
    fn slice(&self, from: usize, to: usize) -> String {
        String::from_utf8_lossy(&self.text[from..to]).into_owned()
    }

    /// The next top-level S-expression, `None` at the end of the text, or an error for
    /// unbalanced or unterminated input.
    fn next_sexp(&mut self) -> Option<Result<Sexp, String>> {
        self.skip_blank();
        if self.pos >= self.text.len() {
            return None;
        }
        Some(self.read())
    }

    /// Reads one S-expression starting at a non-blank byte.
    fn read(&mut self) -> Result<Sexp, String> {
        // Lists are read with an explicit stack, and nesting is bounded, so that no output can
        // overflow the thread's stack (here or when the result is dropped).
        let mut stack: Vec<Vec<Sexp>> = Vec::new();
        loop {
            self.skip_blank();
            let Some(&b) = self.text.get(self.pos) else {
                return Err("output ends inside a parenthesised expression".to_string());
            };
            let item = match b {
                b'(' => {
                    if stack.len() >= MAX_DEPTH {
                        return Err("output nested too deeply".to_string());
                    }
                    self.pos += 1;
                    stack.push(Vec::new());
                    continue;
                }
                b')' => {
                    self.pos += 1;
                    match stack.pop() {
                        Some(items) => Sexp::List(items),
                        None => return Err("unbalanced `)` in output".to_string()),
                    }
                }
                b'"' => self.read_string()?,
                b'|' => {
                    let start = self.pos;
                    self.pos += 1;
                    while self.text.get(self.pos).is_some_and(|&c| c != b'|') {
                        self.pos += 1;
                    }
                    if self.pos >= self.text.len() {
                        return Err("unterminated |quoted symbol| in output".to_string());
                    }
                    self.pos += 1;
                    Sexp::Atom(self.slice(start, self.pos))
                }
                _ => {
                    let start = self.pos;
                    while self.text.get(self.pos).is_some_and(|&c| {
                        !c.is_ascii_whitespace() && !matches!(c, b'(' | b')' | b'"' | b'|' | b';')
                    }) {
                        self.pos += 1;
                    }
                    Sexp::Atom(self.slice(start, self.pos))
                }
            };
            match stack.last_mut() {
                Some(list) => list.push(item),
                None => return Ok(item),
            }
        }
    }

    /// Reads a string literal; `""` (SMT-LIB 2.6) and `\"` both stand for a quote.
    fn read_string(&mut self) -> Result<Sexp, String> {
        let mut bytes = Vec::new();
        self.pos += 1;
        loop {
            match self.text.get(self.pos) {
                None => return Err("unterminated string in output".to_string()),
                Some(b'"') if self.text.get(self.pos + 1) == Some(&b'"') => {
                    bytes.push(b'"');
                    self.pos += 2;
                }
                Some(b'"') => {
                    self.pos += 1;
                    return Ok(Sexp::Str(String::from_utf8_lossy(&bytes).into_owned()));
                }
                Some(b'\\') if matches!(self.text.get(self.pos + 1), Some(b'"' | b'\\')) => {
                    bytes.push(self.text[self.pos + 1]);
                    self.pos += 2;
                }
                Some(&c) => {
                    bytes.push(c);
                    self.pos += 1;
                }
            }
        }
    }
}

/// Interprets a solver's standard output; `Err` says why it is not a usable answer.
fn parse_output(stdout: &str, want: &[String]) -> Result<Answer, String> {
    let mut reader = SexpReader::new(stdout);
    let verdict = loop {
        match reader.next_sexp() {
            None => return Err("no verdict in output".to_string()),
            Some(Err(e)) => return Err(e),
            Some(Ok(Sexp::List(items)))
                if items.first().and_then(Sexp::atom) == Some("warning") =>
            {
                continue
            }
            Some(Ok(sexp)) => break sexp,
        }
    };
    match &verdict {
        Sexp::Atom(a) if a == "unsat" => Ok(Answer::Unsat),
        Sexp::Atom(a) if a == "sat" => {
            if want.is_empty() {
                return Ok(Answer::Sat(Vec::new()));
            }
            match reader.next_sexp() {
                None => Err("`sat` but no get-value response".to_string()),
                Some(Err(e)) => Err(format!("`sat` but {e}")),
                Some(Ok(values)) => parse_values(&values, want).map(Answer::Sat),
            }
        }
        Sexp::Atom(a) if a == "unknown" => Err("the solver answered `unknown`".to_string()),
        Sexp::Atom(a) if a == "timeout" => Ok(Answer::Timeout),
        other => match error_message(other) {
            Some(msg) => Err(format!("solver error: {msg}")),
            None => Err("unexpected output".to_string()),
        },
    }
}

/// The message of an `(error "...")` response.
fn error_message(sexp: &Sexp) -> Option<String> {
    match sexp {
        Sexp::List(items) if items.first().and_then(Sexp::atom) == Some("error") => {
            Some(match items.get(1) {
                // On one line: cvc5's messages quote the offending source line under a caret.
                Some(Sexp::Str(msg)) => msg.split_whitespace().collect::<Vec<_>>().join(" "),
                _ => "(no message)".to_string(),
            })
        }
        _ => None,
    }
}

/// `|x|` and `x` are the same SMT-LIB symbol.
fn unquote(symbol: &str) -> &str {
    symbol
        .strip_prefix('|')
        .and_then(|s| s.strip_suffix('|'))
        .unwrap_or(symbol)
}

/// Parses a `get-value` response `((v1 val1) (v2 val2) ...)` into the values of `want`, in
/// `want`'s order.
fn parse_values(response: &Sexp, want: &[String]) -> Result<Vec<(String, u128, u32)>, String> {
    if let Some(msg) = error_message(response) {
        return Err(format!("get-value failed: {msg}"));
    }
    let Sexp::List(pairs) = response else {
        return Err("the get-value response is not a list".to_string());
    };
    let mut found: Vec<(&str, u128, u32)> = Vec::with_capacity(pairs.len());
    for pair in pairs {
        match pair {
            Sexp::List(kv) if kv.len() == 2 => {
                let name = kv[0]
                    .atom()
                    .ok_or("a get-value entry's name is not a symbol")?;
                let (value, width) =
                    parse_bv_literal(&kv[1]).map_err(|e| format!("value of `{name}`: {e}"))?;
                found.push((unquote(name), value, width));
            }
            _ => return Err("a get-value entry is not a (name value) pair".to_string()),
        }
    }
    want.iter()
        .map(|w| {
            found
                .iter()
                .find(|(name, _, _)| *name == unquote(w))
                .map(|&(_, value, width)| (w.clone(), value, width))
                .ok_or_else(|| format!("no value for `{w}` in the get-value response"))
        })
        .collect()
}

/// Reads a bit-vector literal `#b0101`, `#x00ff` or `(_ bv123 16)` as (unsigned value, width),
/// or an integer `123` / `(- 123)` as its two's complement with width 128.
fn parse_bv_literal(sexp: &Sexp) -> Result<(u128, u32), String> {
    let too_wide = |w: usize| format!("{w}-bit value is wider than 128 bits");
    match sexp {
        Sexp::Atom(lit) if lit.starts_with("#b") => {
            let digits = &lit[2..];
            if digits.is_empty() || !digits.bytes().all(|b| b == b'0' || b == b'1') {
                return Err(format!("bad binary literal `{lit}`"));
            }
            if digits.len() > 128 {
                return Err(too_wide(digits.len()));
            }
            let value = digits
                .bytes()
                .fold(0u128, |v, b| (v << 1) | u128::from(b - b'0'));
            Ok((value, digits.len() as u32))
        }
        Sexp::Atom(lit) if lit.starts_with("#x") => {
            let digits = &lit[2..];
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(format!("bad hexadecimal literal `{lit}`"));
            }
            if digits.len() > 32 {
                return Err(too_wide(digits.len() * 4));
            }
            let value = u128::from_str_radix(digits, 16)
                .map_err(|e| format!("bad hexadecimal literal `{lit}`: {e}"))?;
            Ok((value, digits.len() as u32 * 4))
        }
        Sexp::List(items) => {
            let atoms: Option<Vec<&str>> = items.iter().map(Sexp::atom).collect();
            let (value, width) = match atoms.as_deref() {
                Some(["-", digits]) if digits.bytes().all(|b| b.is_ascii_digit()) => {
                    return int_value(digits, true);
                }
                Some(["_", bv, width]) => match bv.strip_prefix("bv") {
                    Some(value) => (value, *width),
                    None => return Err("unexpected indexed term (not `(_ bvN W)`)".to_string()),
                },
                _ => return Err("not a bit-vector literal".to_string()),
            };
            let decimal = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
            if !decimal(value) || !decimal(width) {
                return Err(format!("bad literal `(_ bv{value} {width})`"));
            }
            let width: u32 = match width.parse() {
                Ok(w) if (1..=128).contains(&w) => w,
                Ok(0) => return Err("zero-width bit-vector".to_string()),
                _ => return Err(format!("{width}-bit value is wider than 128 bits")),
            };
            let value: u128 = value
                .parse()
                .map_err(|_| format!("value `{value}` does not fit in 128 bits"))?;
            if width < 128 && value >> width != 0 {
                return Err(format!("value {value} does not fit in {width} bits"));
            }
            Ok((value, width))
        }
        Sexp::Atom(lit) if !lit.is_empty() && lit.bytes().all(|b| b.is_ascii_digit()) => {
            int_value(lit, false)
        }
        _ => Err("not a bit-vector literal".to_string()),
    }
}

/// An integer model value `123` or `(- 123)` (integer encodings), as its 128-bit two's
/// complement with width 128.
fn int_value(digits: &str, negative: bool) -> Result<(u128, u32), String> {
    let v: i128 = digits
        .parse()
        .map_err(|_| format!("integer `{digits}` does not fit in 128 bits"))?;
    Ok(((if negative { -v } else { v }) as u128, 128))
}

// ---------------------------------------------------------------------------------------------
// Verdict cache
// ---------------------------------------------------------------------------------------------

/// First line of every cache file; bump when the format or key derivation changes.
const CACHE_MAGIC: &str = "qloop-smt-verdict v1";

/// The cache key: hex SHA-256 of the solver's name, its version line and the text sent.
fn cache_key(solver: Solver, version: &str, text: &str) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    for part in [CACHE_MAGIC, solver.name(), version, text] {
        // Length-prefixed, so the parts cannot run into each other.
        h.update((part.len() as u64).to_be_bytes());
        h.update(part.as_bytes());
    }
    h.finalize()
        .iter()
        .fold(String::with_capacity(64), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

/// The file holding the verdict for `key`.
fn cache_path(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("{key}.verdict"))
}

/// The cached answer for `key`, if there is a well-formed entry whose names match `want`.
fn cache_load(dir: &Path, key: &str, want: &[String]) -> Option<Answer> {
    let text = fs::read_to_string(cache_path(dir, key)).ok()?;
    let answer = decode_entry(key, &text)?;
    if let Answer::Sat(values) = &answer {
        let names_match = values.len() == want.len()
            && values.iter().zip(want).all(|((name, _, _), w)| name == w);
        if !names_match {
            return None;
        }
    }
    Some(answer)
}

/// Writes the entry for `key` atomically (temporary file, then rename).
fn cache_store(dir: &Path, key: &str, answer: &Answer) -> io::Result<()> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let Some(entry) = encode_entry(key, answer) else {
        return Ok(());
    };
    fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(
        ".{key}.{}.{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let written = (|| {
        let mut file = fs::File::create(&tmp)?;
        file.write_all(entry.as_bytes())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, cache_path(dir, key))
    })();
    if written.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    written
}

/// The cache file text for a definite answer; `None` for answers that are not cached.
///
/// ```text
/// qloop-smt-verdict v1
/// key <hex>
/// sat <n>                  (or: unsat)
/// <width> <value> <name>   (n lines; name escaped: \\ \n \r)
/// end
/// ```
fn encode_entry(key: &str, answer: &Answer) -> Option<String> {
    let mut out = format!("{CACHE_MAGIC}\nkey {key}\n");
    match answer {
        Answer::Unsat => out.push_str("unsat\n"),
        Answer::Sat(values) => {
            let _ = writeln!(out, "sat {}", values.len());
            for (name, value, width) in values {
                let _ = writeln!(out, "{width} {value} {}", escape_name(name));
            }
        }
        Answer::Timeout | Answer::Cancelled | Answer::Error(_) => return None,
    }
    out.push_str("end\n");
    Some(out)
}

/// Parses a cache file; `None` if it is not a well-formed entry for `key`.
fn decode_entry(key: &str, text: &str) -> Option<Answer> {
    let mut lines = text.split('\n');
    if lines.next()? != CACHE_MAGIC || lines.next()?.strip_prefix("key ")? != key {
        return None;
    }
    let answer = match lines.next()? {
        "unsat" => Answer::Unsat,
        verdict => {
            let count: usize = verdict.strip_prefix("sat ")?.parse().ok()?;
            let mut values = Vec::new();
            for _ in 0..count {
                let mut fields = lines.next()?.splitn(3, ' ');
                let width: u32 = fields.next()?.parse().ok()?;
                let value: u128 = fields.next()?.parse().ok()?;
                let name = unescape_name(fields.next()?)?;
                if !(1..=128).contains(&width) || (width < 128 && value >> width != 0) {
                    return None;
                }
                values.push((name, value, width));
            }
            Answer::Sat(values)
        }
    };
    if lines.next()? != "end" || !lines.next()?.is_empty() || lines.next().is_some() {
        return None;
    }
    Some(answer)
}

/// Escapes `\`, newline and carriage return so a name fits on one line.
fn escape_name(name: &str) -> String {
    name.replace('\\', "\\\\")
        .replace('\n', "\\n")
        .replace('\r', "\\r")
}

/// Inverse of [`escape_name`]; `None` on a malformed escape.
fn unescape_name(text: &str) -> Option<String> {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            out.push(match chars.next()? {
                '\\' => '\\',
                'n' => '\n',
                'r' => '\r',
                _ => return None,
            });
        } else {
            out.push(c);
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x + y = 16, x < 5, y = 14: the only model is x = 2, y = 14.
    const SAT_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun x () (_ BitVec 8))
(declare-fun y () (_ BitVec 8))
(assert (= (bvadd x y) #x10))
(assert (bvult x #x05))
(assert (= y #x0e))";

    /// 2x is never odd.
    const UNSAT_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun x () (_ BitVec 8))
(assert (= ((_ extract 0 0) (bvmul x #x02)) #b1))";

    /// Factoring 3301746797 * 3356063771 (both prime): far beyond a few hundred milliseconds.
    const HARD_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun p () (_ BitVec 32))
(declare-fun q () (_ BitVec 32))
(assert (= (bvmul ((_ zero_extend 32) p) ((_ zero_extend 32) q)) #x99c72b1bc45ddb7f))
(assert (bvugt p #x00000001))
(assert (bvugt q #x00000001))";

    fn query(script: &str, want: &[&str]) -> Query {
        Query {
            script: script.to_string(),
            want: want.iter().map(|s| s.to_string()).collect(),
        }
    }

    fn both(timeout_ms: u64) -> Config {
        for s in Solver::ALL {
            assert!(
                s.available(),
                "{} must be installed for these tests",
                s.name()
            );
        }
        Config {
            solvers: Solver::ALL.to_vec(),
            timeout_ms,
            cache_dir: None,
            jobs: 4,
            deadline: None,
        }
    }

    fn want(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    /// A fresh, empty directory under the system temp dir.
    fn temp_dir(tag: &str) -> PathBuf {
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "qloop-solver-test-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn sat_and_unsat_on_both_solvers_in_order() {
        let queries = [
            query(SAT_SCRIPT, &["x", "y"]),
            query(UNSAT_SCRIPT, &["x"]),
            query(SAT_SCRIPT, &["y"]),
        ];
        let mut calls = Vec::new();
        let runs = run_all(&queries, &both(30_000), &mut |done, total| {
            calls.push((done, total))
        });
        assert_eq!(calls, (1..=6).map(|d| (d, 6)).collect::<Vec<_>>());
        assert_eq!(runs.len(), 3);
        for row in &runs {
            let solvers: Vec<Solver> = row.iter().map(|r| r.solver).collect();
            assert_eq!(solvers, Solver::ALL.to_vec());
            assert!(row.iter().all(|r| !r.cached));
        }
        for run in &runs[0] {
            assert_eq!(
                run.answer,
                Answer::Sat(vec![("x".into(), 2, 8), ("y".into(), 14, 8)]),
                "{run:?}"
            );
        }
        for run in &runs[1] {
            assert_eq!(run.answer, Answer::Unsat, "{run:?}");
        }
        for run in &runs[2] {
            assert_eq!(
                run.answer,
                Answer::Sat(vec![("y".into(), 14, 8)]),
                "{run:?}"
            );
        }
    }

    #[test]
    fn odd_widths_and_quoted_names_come_back() {
        let script = "(set-logic QF_BV)
(declare-fun |a b| () (_ BitVec 7))
(declare-fun w () (_ BitVec 128))
(assert (= |a b| #b1010101))
(assert (= w (bvnot (_ bv0 128))))";
        let runs = run_all(
            &[query(script, &["|a b|", "w"])],
            &both(30_000),
            &mut |_, _| {},
        );
        for run in &runs[0] {
            assert_eq!(
                run.answer,
                Answer::Sat(vec![
                    ("|a b|".into(), 0x55, 7),
                    ("w".into(), u128::MAX, 128)
                ]),
                "{run:?}"
            );
        }
    }

    #[test]
    fn hard_query_times_out_promptly() {
        let start = Instant::now();
        let runs = run_all(
            &[query(HARD_SCRIPT, &["p", "q"])],
            &both(300),
            &mut |_, _| {},
        );
        let elapsed = start.elapsed();
        for run in &runs[0] {
            assert_eq!(run.answer, Answer::Timeout, "{run:?}");
            assert!(run.millis >= 300, "{run:?}");
        }
        assert!(elapsed < Duration::from_millis(2300), "took {elapsed:?}");
    }

    #[test]
    fn killed_child_is_reaped() {
        for s in Solver::ALL {
            // The solver's own limit is a minute away: only our kill can end it in time.
            let text = solver_text(&query(HARD_SCRIPT, &[]));
            let start = Instant::now();
            let fin = run_process(
                s.name(),
                &s.args(60_000),
                &text,
                Duration::from_millis(200),
                None,
            )
            .unwrap_or_else(|e| panic!("{} did not start: {e}", s.name()));
            let elapsed = start.elapsed();
            assert!(fin.timed_out, "{fin:?}");
            assert!(elapsed < Duration::from_millis(2200), "took {elapsed:?}");
            assert_eq!(interpret(s.name(), &[], &fin), Answer::Timeout);
            if cfg!(target_os = "linux") {
                let proc_dir = PathBuf::from(format!("/proc/{}", fin.pid));
                assert!(
                    !proc_dir.exists(),
                    "{} (pid {}) still exists",
                    s.name(),
                    fin.pid
                );
            }
        }
    }

    #[test]
    fn cache_hits_and_survives_corruption() {
        let dir = temp_dir("cache");
        let cfg = Config {
            cache_dir: Some(dir.clone()),
            ..both(30_000)
        };
        let queries = [query(UNSAT_SCRIPT, &["x"]), query(SAT_SCRIPT, &["x", "y"])];
        let first = run_all(&queries, &cfg, &mut |_, _| {});
        let second = run_all(&queries, &cfg, &mut |_, _| {});
        for (a, b) in first.iter().flatten().zip(second.iter().flatten()) {
            assert!(!a.cached && b.cached, "{a:?} {b:?}");
            assert_eq!(a.answer, b.answer);
            assert_eq!(b.millis, 0);
        }
        assert_eq!(second[0][0].answer, Answer::Unsat);
        assert!(matches!(second[1][1].answer, Answer::Sat(_)));

        // One file per (query, solver); corrupt all of them.
        let files: Vec<PathBuf> = fs::read_dir(&dir)
            .expect("cache dir exists")
            .map(|e| e.expect("dir entry").path())
            .collect();
        assert_eq!(files.len(), 4, "{files:?}");
        for (i, f) in files.iter().enumerate() {
            let junk: &[u8] = match i % 2 {
                0 => b"garbage",
                _ => b"qloop-smt-verdict v1\nkey 00\nunsat\nend\n",
            };
            fs::write(f, junk).expect("overwrite cache file");
        }
        let third = run_all(&queries, &cfg, &mut |_, _| {});
        for (a, c) in first.iter().flatten().zip(third.iter().flatten()) {
            assert!(!c.cached, "{c:?}");
            assert_eq!(a.answer, c.answer);
        }
        // ...and the entries were rewritten.
        let fourth = run_all(&queries, &cfg, &mut |_, _| {});
        assert!(fourth.iter().flatten().all(|r| r.cached));
        assert_eq!(fourth, second);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn timeouts_and_errors_are_not_cached() {
        let dir = temp_dir("nocache");
        let cfg = Config {
            cache_dir: Some(dir.clone()),
            ..both(200)
        };
        let queries = [
            query(HARD_SCRIPT, &[]),
            query("(set-logic QF_BV) (assert", &[]),
        ];
        run_all(&queries, &cfg, &mut |_, _| {});
        let again = run_all(&queries, &cfg, &mut |_, _| {});
        assert!(again.iter().flatten().all(|r| !r.cached), "{again:?}");
        let entries = fs::read_dir(&dir).map(|d| d.count()).unwrap_or(0);
        assert_eq!(entries, 0);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn broken_scripts_are_errors() {
        let scripts = [
            // unbalanced parentheses
            "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8)\n(assert (= x",
            // undeclared symbol (z3 reports it and carries on to `sat`)
            "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8))\n(assert (= x zz))",
        ];
        let queries: Vec<Query> = scripts.iter().map(|s| query(s, &["x"])).collect();
        let runs = run_all(&queries, &both(30_000), &mut |_, _| {});
        for run in runs.iter().flatten() {
            assert!(
                matches!(&run.answer, Answer::Error(m) if m.contains("error")),
                "{run:?}"
            );
        }
        // A name that is not declared: `sat`, but get-value fails.
        let runs = run_all(
            &[query(SAT_SCRIPT, &["nope"])],
            &both(30_000),
            &mut |_, _| {},
        );
        for run in &runs[0] {
            assert!(matches!(run.answer, Answer::Error(_)), "{run:?}");
        }
    }

    #[test]
    fn missing_binary_is_an_error() {
        let missing = "qloop-no-such-solver-binary";
        assert_eq!(probe_version(missing), None);
        let answer = execute(
            missing,
            &[],
            "(check-sat)",
            &[],
            Duration::from_secs(5),
            None,
        );
        assert!(
            matches!(&answer, Answer::Error(m) if m.contains("not installed")),
            "{answer:?}"
        );
        let run = run_one(Solver::Z3, None, "(check-sat)", &[], &both(1000), None);
        assert!(
            matches!(&run.answer, Answer::Error(m) if m.contains("not installed")),
            "{run:?}"
        );
    }

    #[test]
    fn the_deadline_stops_running_queries_and_skips_the_rest() {
        let hard = Query {
            script: "(set-logic QF_BV)\n(declare-fun p () (_ BitVec 64))\n(declare-fun q () (_ BitVec 64))\n\
(assert (= (bvmul ((_ zero_extend 32) ((_ extract 31 0) p)) ((_ zero_extend 32) ((_ extract 31 0) q))) #x0000c5beb0f6e7b1))\n\
(assert (bvugt ((_ extract 31 0) p) #x00000001))\n(assert (bvugt ((_ extract 31 0) q) #x00000001))\n".into(),
            want: vec![],
        };
        if !Solver::Z3.available() {
            return;
        }
        let start = Instant::now();
        let cfg = Config {
            solvers: vec![Solver::Z3],
            timeout_ms: 60_000,
            cache_dir: None,
            jobs: 1,
            deadline: Some(start + Duration::from_secs(2)),
        };
        let runs = run_all(&[hard.clone(), hard], &cfg, &mut |_, _| {});
        assert_eq!(runs[0][0].answer, Answer::Timeout, "{:?}", runs[0][0]);
        assert!(
            matches!(&runs[1][0].answer, Answer::Error(m) if m.contains("time limit")),
            "{:?}",
            runs[1][0]
        );
        // Stopped at the deadline, not after the 60 s per-query timeout.
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{:?}",
            start.elapsed()
        );
    }

    #[test]
    fn a_proof_cancels_the_rest_of_its_group() {
        // Query 0 is proved at once; query 1 (same group) would run for a minute.
        let easy = Query {
            script: "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8))\n(assert (= ((_ extract 0 0) (bvmul x #x02)) #b1))\n".into(),
            want: vec![],
        };
        let hard = Query {
            script: "(set-logic QF_BV)\n(declare-fun p () (_ BitVec 64))\n(declare-fun q () (_ BitVec 64))\n\
(assert (= (bvmul ((_ zero_extend 32) ((_ extract 31 0) p)) ((_ zero_extend 32) ((_ extract 31 0) q))) #x0000c5beb0f6e7b1))\n\
(assert (bvugt ((_ extract 31 0) p) #x00000001))\n(assert (bvugt ((_ extract 31 0) q) #x00000001))\n".into(),
            want: vec![],
        };
        let cfg = Config {
            solvers: vec![Solver::Z3],
            timeout_ms: 60_000,
            cache_dir: None,
            jobs: 1,
            deadline: None,
        };
        let start = Instant::now();
        let runs = run_all_grouped(
            &[easy, hard.clone()],
            &[0, 0],
            &cfg,
            &mut |_, _| {},
            &mut |_, _| false,
        );
        assert_eq!(runs[0][0].answer, Answer::Unsat);
        assert_eq!(runs[1][0].answer, Answer::Cancelled);
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "{:?}",
            start.elapsed()
        );

        // A confirmed counterexample cancels the group for every solver.
        let refutable = Query {
            script: "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8))\n(assert (= x #x05))\n"
                .into(),
            want: vec!["x".into()],
        };
        let mut confirmed = Vec::new();
        let runs = run_all_grouped(
            &[refutable, hard],
            &[0, 0],
            &Config {
                solvers: vec![Solver::Z3, Solver::Cvc5],
                ..cfg
            },
            &mut |_, _| {},
            &mut |i, run| {
                confirmed.push((i, run.solver));
                true
            },
        );
        assert_eq!(runs[0][0].answer, Answer::Sat(vec![("x".into(), 5, 8)]));
        assert!(confirmed.contains(&(0, Solver::Z3)), "{confirmed:?}");
        assert_eq!(runs[1][0].answer, Answer::Cancelled);
        assert_eq!(runs[1][1].answer, Answer::Cancelled);
    }

    #[test]
    fn crashes_and_silence_are_errors() {
        let sh = |script: &str| {
            execute(
                "sh",
                &["-c".to_string(), script.to_string()],
                "",
                &want(&["x"]),
                Duration::from_secs(10),
                None,
            )
        };
        for script in [
            "true",
            "echo sat",
            "echo sat; echo '((x #b1'",
            "echo unknown",
            "echo hello",
            "kill -SEGV $$",
        ] {
            assert!(matches!(sh(script), Answer::Error(_)), "{script}");
        }
        assert_eq!(
            sh("echo sat; echo '((x #b1))'"),
            Answer::Sat(vec![("x".into(), 1, 1)])
        );
        assert_eq!(sh("echo unsat; echo '(error \"no model\")'"), Answer::Unsat);
        // No representable deadline: no timeout, still a normal run.
        let answer = execute(
            "sh",
            &["-c".to_string(), "cat >/dev/null; echo unsat".to_string()],
            &"; padding\n".repeat(100_000),
            &[],
            Duration::from_millis(u64::MAX),
            None,
        );
        assert_eq!(answer, Answer::Unsat);
    }

    #[test]
    fn solvers_accept_the_exact_text() {
        let text = solver_text(&query(SAT_SCRIPT, &["x", "y"]));
        assert!(text.starts_with("(set-option :produce-models true)\n(set-logic QF_BV)\n"));
        assert!(text.ends_with("(check-sat)\n(get-value (x y))\n(exit)\n"));
        let text = solver_text(&query(UNSAT_SCRIPT, &[]));
        assert!(text.ends_with("#b1))\n(check-sat)\n(exit)\n"), "{text}");
        for s in Solver::ALL {
            let fin = run_process(
                s.name(),
                &s.args(30_000),
                &text,
                Duration::from_secs(30),
                None,
            )
            .unwrap_or_else(|e| panic!("{} did not start: {e}", s.name()));
            assert_eq!(fin.stdout.trim(), "unsat", "{}: {fin:?}", s.name());
            assert!(fin.stderr.trim().is_empty(), "{}: {fin:?}", s.name());
            assert!(fin.status.is_some_and(|st| st.success()), "{fin:?}");
        }
    }

    #[test]
    fn parses_get_value_forms() {
        let cases = [
            // z3 prints #x when the width is a multiple of 4, #b otherwise.
            ("sat\n((x #x02)\n (y #x0e))\n", vec![("x", 2, 8), ("y", 14, 8)]),
            // cvc5 1.0.3 prints #b.
            (
                "sat\n((x #b00000010) (y #b00001110))\n",
                vec![("x", 2, 8), ("y", 14, 8)],
            ),
            // cvc5 with --bv-print-consts-as-indexed-symbols.
            (
                "sat\n((x (_ bv2 8)) (y (_ bv14 8)))\n",
                vec![("x", 2, 8), ("y", 14, 8)],
            ),
            (
                "  \n sat \n ( ( y\n#b1 ) ( x\t(_\nbv340282366920938463463374607431768211455 128) ) )",
                vec![("x", u128::MAX, 128), ("y", 1, 1)],
            ),
            (
                "sat\n((|a b| #b0000000) (x #xffffffffffffffffffffffffffffffff))",
                vec![("x", u128::MAX, 128), ("|a b|", 0, 7)],
            ),
            // Integer encodings: two's complement at width 128.
            (
                "sat\n((x 12) (y (- 3)))\n",
                vec![("x", 12, 128), ("y", (-3i128) as u128, 128)],
            ),
        ];
        for (out, expect) in cases {
            let names: Vec<&str> = expect.iter().map(|e| e.0).collect();
            let expect: Vec<(String, u128, u32)> = expect
                .iter()
                .map(|&(n, v, w)| (n.to_string(), v, w))
                .collect();
            assert_eq!(
                parse_output(out, &want(&names)),
                Ok(Answer::Sat(expect)),
                "{out}"
            );
        }
        // `x` and `|x|` are one symbol.
        assert_eq!(
            parse_output("sat ((|x| #x7))", &want(&["x"])),
            Ok(Answer::Sat(vec![("x".into(), 7, 4)]))
        );
        assert_eq!(parse_output("sat", &[]), Ok(Answer::Sat(vec![])));
        assert_eq!(
            parse_output("unsat\n(error \"model is not available\")", &want(&["x"])),
            Ok(Answer::Unsat)
        );
        assert_eq!(parse_output("timeout\n", &[]), Ok(Answer::Timeout));
        assert_eq!(
            parse_output("(warning \"w\")\nunsat", &[]),
            Ok(Answer::Unsat)
        );
    }

    #[test]
    fn rejects_bad_output() {
        let x = want(&["x"]);
        for out in [
            "",
            "unknown",
            "(error \"line 3: bad\")\nsat\n((x #x00))",
            "sat",
            "sat\n((x #x0",
            "sat\n((x #x0g))",
            "sat\n((x #x+f))",
            "sat\n((x #b012))",
            "sat\n((x #b))",
            "sat\n((y #x00))",
            "sat\n((x (_ bv256 8)))",
            "sat\n((x (_ bv1 0)))",
            "sat\n((x (_ bv1 129)))",
            "sat\n((x (_ bv+1 8)))",
            "sat\n((x (bvadd #x01 #x02)))",
            "sat\n((x #b0 #b1))",
            "sat\n(x #b0)",
            "sat\n(error \"cannot get value\")",
            "sat\n((x #x000000000000000000000000000000000))",
            "Sat\n((x #x00))",
            ")",
            "\"unterminated",
        ] {
            assert!(parse_output(out, &x).is_err(), "{out:?}");
        }
    }

    #[test]
    fn sexp_reader_handles_strings_comments_and_quotes() {
        let mut r = SexpReader::new("; c\n(error \"a \"\"b\"\" \\\" ; (\") |x ) y| z ");
        assert_eq!(
            r.next_sexp(),
            Some(Ok(Sexp::List(vec![
                Sexp::Atom("error".into()),
                Sexp::Str("a \"b\" \" ; (".into())
            ])))
        );
        assert_eq!(r.next_sexp(), Some(Ok(Sexp::Atom("|x ) y|".into()))));
        assert_eq!(r.next_sexp(), Some(Ok(Sexp::Atom("z".into()))));
        assert_eq!(r.next_sexp(), None);
        let nested = |n: usize| "(".repeat(n) + &")".repeat(n);
        assert!(matches!(
            SexpReader::new(&nested(MAX_DEPTH)).next_sexp(),
            Some(Ok(_))
        ));
        let deep = nested(MAX_DEPTH + 1);
        assert!(matches!(SexpReader::new(&deep).next_sexp(), Some(Err(_))));
        assert!(parse_output(&nested(1_000_000), &[]).is_err());
    }

    #[test]
    fn cache_entries_round_trip_and_reject_damage() {
        let key = "ab".repeat(32);
        let sat = Answer::Sat(vec![
            ("x".into(), 5, 8),
            ("|a\nb\\c|".into(), u128::MAX, 128),
        ]);
        for answer in [Answer::Unsat, sat.clone(), Answer::Sat(vec![])] {
            let text = encode_entry(&key, &answer).expect("cacheable");
            assert_eq!(decode_entry(&key, &text), Some(answer.clone()));
            // Any truncation or wrong key is a miss.
            for cut in 0..text.len() {
                assert_eq!(decode_entry(&key, &text[..cut]), None, "{cut}");
            }
            assert_eq!(decode_entry(&"cd".repeat(32), &text), None);
            assert_eq!(decode_entry(&key, &(text.clone() + "x")), None);
        }
        assert_eq!(encode_entry(&key, &Answer::Timeout), None);
        assert_eq!(encode_entry(&key, &Answer::Error("e".into())), None);
        let bad = format!("{CACHE_MAGIC}\nkey {key}\nsat 1\n8 256 x\nend\n");
        assert_eq!(decode_entry(&key, &bad), None);

        // A stored Sat must match the names asked for.
        let dir = temp_dir("entries");
        cache_store(&dir, &key, &sat).expect("store");
        assert_eq!(
            cache_load(&dir, &key, &want(&["x", "|a\nb\\c|"])),
            Some(sat)
        );
        assert_eq!(cache_load(&dir, &key, &want(&["x"])), None);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn cache_key_depends_on_every_part() {
        let k = cache_key(Solver::Z3, "v1", "text");
        assert_eq!(k.len(), 64);
        assert_eq!(k, cache_key(Solver::Z3, "v1", "text"));
        assert_ne!(k, cache_key(Solver::Cvc5, "v1", "text"));
        assert_ne!(k, cache_key(Solver::Z3, "v2", "text"));
        assert_ne!(k, cache_key(Solver::Z3, "v1", "text "));
        assert_ne!(
            cache_key(Solver::Z3, "ab", "c"),
            cache_key(Solver::Z3, "a", "bc")
        );
    }

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

    #[test]
    fn empty_inputs() {
        let mut calls = 0;
        assert!(run_all(&[], &both(1000), &mut |_, _| calls += 1).is_empty());
        let cfg = Config {
            solvers: vec![],
            ..both(1000)
        };
        let runs = run_all(&[query(SAT_SCRIPT, &[])], &cfg, &mut |_, _| calls += 1);
        assert_eq!(runs, vec![Vec::<Run>::new()]);
        assert_eq!(calls, 0);
    }
}
