//! Several small queries in one solver process.
//!
//! Most obligations of a spec are tiny (a constant, a cast or a sum inside its interval) and a
//! solver decides each in about a millisecond, while starting the solver takes 15-30 ms: on
//! the GAC spec (`verified/specs/gac_surface_finish.qloop`) 490 such queries took z3 13.4 s
//! one process each and 4.1 s in processes of 32 (cvc5: 9.0 s and 4.5 s). A batch sends the
//! queries one after another, each after `(reset)`, so each is decided alone, exactly as
//! its own process would decide it:
//!
//! ```text
//! <script 1>
//! (check-sat)
//! (reset)
//! <script 2>
//! (check-sat)
//! ...
//! (exit)
//! ```
//!
//! The solver prints one verdict line per `check-sat`. Only `unsat` is taken from a batch
//! (with the batch's time shared evenly among its queries) and cached under the query's own
//! key, the key of the text [`super::run::run_one`] would send. Every other query (`sat`,
//! whose model the batch does not ask for, `unknown`, or any query of a batch whose output
//! is not exactly one verdict per query, a timeout or a crash included) runs again in its own
//! process, so a batch never decides anything a single run would not.

use super::cache::{cache_key, cache_load, cache_store};
use super::process::run_process;
use super::run::{run_one, solver_text, timeout_ms};
use super::{Answer, Config, Query, Run, Solver};
use std::time::{Duration, Instant};

/// At most this many queries share a process (the measured gain levels off well below it,
/// and a batch is not cancellable).
pub(super) const BATCH: usize = 32;

/// The text of one batch: each script, its `check-sat`, and a `(reset)` before the next.
fn batch_text(queries: &[&Query]) -> String {
    let mut text = String::new();
    for (i, q) in queries.iter().enumerate() {
        if i > 0 {
            text.push_str("(reset)\n");
        }
        text.push_str(&q.script);
        text.push_str("\n(check-sat)\n");
    }
    text.push_str("(exit)\n");
    text
}

/// One verdict per query, when the output is exactly that; `None` otherwise.
fn verdicts(stdout: &str, n: usize) -> Option<Vec<&str>> {
    let lines: Vec<&str> = stdout
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let ok = lines.len() == n
        && lines
            .iter()
            .all(|l| matches!(*l, "sat" | "unsat" | "unknown"));
    ok.then_some(lines)
}

/// `solver` on each of `queries`: from the cache, else in one process for all that are not
/// cached, else (anything but `unsat` there) one process each.
pub(super) fn run_batch(
    solver: Solver,
    version: Option<&str>,
    queries: &[&Query],
    cfg: &Config,
) -> Vec<Run> {
    let single = |q: &Query| run_one(solver, version, &solver_text(q), &q.want, cfg, None);
    let Some(version) = version else {
        return queries.iter().map(|q| single(q)).collect();
    };
    let keys: Vec<Option<String>> = queries
        .iter()
        .map(|q| {
            cfg.cache_dir
                .as_ref()
                .map(|_| cache_key(solver, version, &solver_text(q)))
        })
        .collect();
    let mut out: Vec<Option<Run>> = queries
        .iter()
        .zip(&keys)
        .map(|(q, key)| {
            let dir = cfg.cache_dir.as_deref()?;
            let answer = cache_load(dir, key.as_deref()?, &q.want)?;
            Some(Run {
                solver,
                answer,
                millis: 0,
                cached: true,
                shared: false,
            })
        })
        .collect();
    let pending: Vec<usize> = (0..queries.len()).filter(|&i| out[i].is_none()).collect();
    if pending.len() > 1 {
        if let Some(limit) = timeout_ms(cfg, Instant::now()) {
            let sent: Vec<&Query> = pending.iter().map(|&i| queries[i]).collect();
            let start = Instant::now();
            let run = run_process(
                solver.name(),
                &solver.args(limit),
                &batch_text(&sent),
                Duration::from_millis(limit),
                None,
            );
            let each = u64::try_from(start.elapsed().as_millis() / pending.len() as u128)
                .unwrap_or(u64::MAX);
            let lines = match &run {
                Ok(fin) if !fin.timed_out && !fin.cancelled => verdicts(&fin.stdout, pending.len()),
                _ => None,
            };
            if let Some(lines) = lines {
                for (&i, verdict) in pending.iter().zip(lines) {
                    if verdict != "unsat" {
                        continue;
                    }
                    if let (Some(dir), Some(key)) = (cfg.cache_dir.as_deref(), &keys[i]) {
                        // The cache is an optimisation: failing to write it is not an error.
                        let _ = cache_store(dir, key, &Answer::Unsat);
                    }
                    out[i] = Some(Run {
                        solver,
                        answer: Answer::Unsat,
                        millis: each,
                        cached: false,
                        shared: false,
                    });
                }
            }
        }
    }
    out.into_iter()
        .zip(queries)
        .map(|(run, q)| run.unwrap_or_else(|| single(q)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::testing::*;

    #[test]
    fn a_batch_answers_like_single_runs() {
        let queries = [
            query(UNSAT_SCRIPT, &["x"]),
            query(SAT_SCRIPT, &["x", "y"]),
            query(UNSAT_SCRIPT, &[]),
            query(SAT_SCRIPT, &["y"]),
        ];
        let refs: Vec<&Query> = queries.iter().collect();
        for s in Solver::ALL {
            let cfg = both(30_000);
            let batch = run_batch(s, s.version(), &refs, &cfg);
            let single: Vec<Run> = queries
                .iter()
                .map(|q| run_one(s, s.version(), &solver_text(q), &q.want, &cfg, None))
                .collect();
            let answers = |runs: &[Run]| runs.iter().map(|r| r.answer.clone()).collect::<Vec<_>>();
            assert_eq!(answers(&batch), answers(&single), "{}", s.name());
            // The models of `sat` come from a run of their own.
            assert!(matches!(&batch[1].answer, Answer::Sat(m) if m.len() == 2));
        }
    }

    #[test]
    fn output_that_is_not_one_verdict_per_query_is_not_used() {
        assert_eq!(verdicts("unsat\nsat\n", 2), Some(vec!["unsat", "sat"]));
        assert_eq!(verdicts("unsat\n", 2), None);
        assert_eq!(verdicts("unsat\n(error \"x\")\nunsat\n", 2), None);
        assert_eq!(verdicts("unsat\nunsat\nunsat\n", 2), None);
    }

    #[test]
    fn a_broken_batch_falls_back_to_single_runs() {
        // The second script does not parse: the solver's batch output is not one verdict per
        // query, so each query runs alone, and the good ones are still proved.
        let bad = query("(set-logic QF_BV)\n(assert (bvfoo))", &[]);
        let good = query(UNSAT_SCRIPT, &[]);
        for s in Solver::ALL {
            let runs = run_batch(s, s.version(), &[&good, &bad, &good], &both(30_000));
            assert_eq!(runs[0].answer, Answer::Unsat, "{}", s.name());
            assert!(matches!(runs[1].answer, Answer::Error(_)), "{:?}", runs[1]);
            assert_eq!(runs[2].answer, Answer::Unsat, "{}", s.name());
        }
    }
}
