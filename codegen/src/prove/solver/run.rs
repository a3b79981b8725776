//! One solver on one query: the text sent, the verdict cache, the proof's deadline, and the
//! solver's output turned into an [`Answer`].
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
//! script's `(set-logic ...)`. The whole script goes in at once (not command by command, as
//! a REPL driver would): the solver's answer to `check-sat` is the first S-expression it
//! prints, and the text is also what the cache key hashes.
//!
//! # Interpreting the run
//!
//! A cancelled run is [`Answer::Cancelled`] and a killed one [`Answer::Timeout`], whatever it
//! printed; otherwise [`super::response`] reads standard output, and when that holds no
//! verdict, cvc5's `interrupted by timeout` on standard error (its own `--tlimit`) is a
//! timeout too. Anything else is an [`Answer::Error`] quoting both streams.

use super::cache::{cache_key, cache_load, cache_store};
use super::process::{run_process, Finished};
use super::response::parse_output;
use super::{Answer, Config, Query, Run, Solver};
use std::io;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// The exact text fed to a solver's standard input for `query`.
pub(super) fn solver_text(query: &Query) -> String {
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
pub(super) fn run_one(
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
            shared: false,
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
                shared: false,
            };
        }
    }
    let start = Instant::now();
    let Some(timeout_ms) = timeout_ms(cfg, start) else {
        return Run {
            solver,
            answer: Answer::Error(
                "not run: the proof's time limit (--timeout) was reached first".into(),
            ),
            millis: 0,
            cached: false,
            shared: false,
        };
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
        shared: false,
    }
}

/// The time limit of a run starting at `start`: the per-query timeout, cut short by the
/// proof's deadline; `None` when the deadline has passed.
pub(super) fn timeout_ms(cfg: &Config, start: Instant) -> Option<u64> {
    match cfg.deadline {
        None => Some(cfg.timeout_ms),
        Some(end) => {
            let left = end.saturating_duration_since(start).as_millis();
            (left > 0).then(|| cfg.timeout_ms.min(u64::try_from(left).unwrap_or(u64::MAX)))
        }
    }
}

/// Runs one solver binary on `text` and interprets what it printed.
pub(super) fn execute(
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
pub(super) fn interpret(program: &str, want: &[String], fin: &Finished) -> Answer {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::process::probe_version;
    use crate::prove::solver::testing::*;
    use std::path::PathBuf;

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
}
