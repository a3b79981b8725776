//! The portfolio: every query on every configured solver, at most [`Config::jobs`] processes
//! at once, on a pool of worker threads fed from one task counter.
//!
//! Tasks are handed out solver-major (every query's first solver, then every query's
//! second), so the encodings of one obligation run side by side. Queries are grouped (the
//! encodings of one question share a group): a solver's first proof in a group cancels its
//! runs on the group's other queries, and a counterexample that replays cancels every run of
//! the group. Cancellation reaches a running solver through a flag that `process`
//! polls, which kills the child.

use super::batch::{run_batch, BATCH};
use super::dedup::{classes, share};
use super::run::{run_one, solver_text};
use super::{Answer, Config, Query, Run};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::thread;

/// Runs every query on every configured solver, at most `jobs` processes at once, and returns,
/// for each query in order, one Run per solver (in Config.solvers order).
/// `progress` is called after each finished run with (done, total) so a CLI can draw a bar.
pub fn run_all(
    queries: &[Query],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize),
) -> Vec<Vec<Run>> {
    let groups: Vec<usize> = (0..queries.len()).collect();
    run_all_grouped(
        queries,
        &groups,
        cfg,
        &mut |done, total, _| progress(done, total),
        &mut |_, _| false,
    )
}

/// Like [`run_all`], where `groups[i]` names the group of query `i`: queries of one group
/// are alternative encodings of one obligation. Once a solver proves one of them (`unsat`),
/// that solver's runs on the group's other queries are cancelled ([`Answer::Cancelled`]);
/// the other solvers go on. Groups of one query run every solver to the end.
///
/// `progress(done, total, i)` is called after each finished run, `i` the run's query.
/// `confirm(i, run)` is called (on the calling thread) for each `sat` answer to query `i`;
/// when it returns true (the counterexample replays: the obligation is refuted) every other
/// run of the group is cancelled, for every solver.
pub fn run_all_grouped(
    queries: &[Query],
    groups: &[usize],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize, usize),
    confirm: &mut dyn FnMut(usize, &Run) -> bool,
) -> Vec<Vec<Run>> {
    run_all_batched(queries, groups, &[], cfg, progress, confirm)
}

/// Like [`run_all_grouped`], where the queries marked in `small` (missing entries: not small)
/// may share a solver process, 32 at a time (`solver/batch.rs`: the same verdicts, a
/// fraction of the process starts). A query of a group that holds a small query runs after
/// every batch of its solver: it is the small query's fallback, and usually cancelled by its
/// proof.
pub fn run_all_batched(
    queries: &[Query],
    groups: &[usize],
    small: &[bool],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize, usize),
    confirm: &mut dyn FnMut(usize, &Run) -> bool,
) -> Vec<Vec<Run>> {
    // Alpha-equivalent groups run once (`dedup`); the others take their answers.
    let c = classes(queries, groups, small);
    if c.runs.len() == queries.len() {
        return run_distinct(queries, groups, small, cfg, progress, confirm);
    }
    let pick = |v: &[usize]| -> Vec<usize> {
        c.runs
            .iter()
            .map(|&qi| v.get(qi).copied().unwrap_or(qi))
            .collect()
    };
    let sub_queries: Vec<Query> = c.runs.iter().map(|&qi| queries[qi].clone()).collect();
    // Group names in the subset: the position of the group's first query.
    // Group names in the subset: the position of the group's first query (one pass, not a
    // search per query: a big spec has tens of thousands).
    let mut first_at: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let sub_groups: Vec<usize> = pick(groups)
        .into_iter()
        .enumerate()
        .map(|(ri, g)| *first_at.entry(g).or_insert(ri))
        .collect();
    let sub_small: Vec<bool> = c
        .runs
        .iter()
        .map(|&qi| small.get(qi).copied().unwrap_or(false))
        .collect();
    // Every query that takes a run's answers, for the progress count.
    let mut takers: Vec<Vec<usize>> = vec![Vec::new(); c.runs.len()];
    for (qi, &src) in c.source.iter().enumerate() {
        takers[src].push(qi);
    }
    let total = queries.len() * cfg.solvers.len();
    let mut done = 0;
    let sub = run_distinct(
        &sub_queries,
        &sub_groups,
        &sub_small,
        cfg,
        &mut |_, _, ri| {
            for &qi in &takers[ri] {
                done += 1;
                progress(done, total, qi);
            }
        },
        &mut |ri, run| confirm(c.runs[ri], run),
    );
    (0..queries.len())
        .map(|qi| {
            let row = &sub[c.source[qi]];
            if c.shared[qi] {
                row.iter().map(|r| share(r, &queries[qi])).collect()
            } else {
                row.clone()
            }
        })
        .collect()
}

/// [`run_all_batched`] on queries of which no two groups are alike.
fn run_distinct(
    queries: &[Query],
    groups: &[usize],
    small: &[bool],
    cfg: &Config,
    progress: &mut dyn FnMut(usize, usize, usize),
    confirm: &mut dyn FnMut(usize, &Run) -> bool,
) -> Vec<Vec<Run>> {
    let solvers = &cfg.solvers;
    let total = queries.len() * solvers.len();
    if total == 0 {
        return vec![Vec::new(); queries.len()];
    }
    let schedule = Schedule::new(queries, groups, small, cfg);
    let mut slots: Vec<Vec<Option<Run>>> = vec![vec![None; solvers.len()]; queries.len()];
    let mut done = 0;
    let workers = cfg.jobs.clamp(1, schedule.tasks.len().max(1));
    on_workers(&schedule, workers, &mut |(qi, si, run)| {
        if matches!(run.answer, Answer::Sat(_)) && confirm(qi, &run) {
            schedule.stop_group(qi);
        }
        slots[qi][si] = Some(run);
        done += 1;
        progress(done, total, qi);
    });
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
                        shared: false,
                    })
                })
                .collect()
        })
        .collect()
}

/// One task's result: (query index, solver index, run).
type Done = (usize, usize, Run);

/// The tasks of one [`run_all_grouped`] call, shared by its workers.
struct Schedule<'a> {
    /// The queries.
    queries: &'a [Query],
    /// The group of each query.
    groups: &'a [usize],
    /// Solvers, timeout, cache and deadline.
    cfg: &'a Config,
    /// How many queries each group holds.
    sizes: Vec<usize>,
    /// One flag per (group, solver): a solver that has proved one encoding of a group stops
    /// working on the others, while the other solver goes on to its own proof (the report
    /// aims for both solvers on every obligation). A replayed counterexample sets every
    /// solver's flag of its group.
    stop: Vec<AtomicBool>,
    /// Each solver's version line (part of the cache key), probed once.
    versions: Vec<Option<&'static str>>,
    /// The text sent for each query.
    texts: Vec<String>,
    /// The tasks, in the order they are handed out.
    tasks: Vec<Task>,
    /// The next task to hand out.
    next: AtomicUsize,
}

/// One unit of work: one solver on one query, or on a batch of small queries.
struct Task {
    /// Index into the configured solvers.
    solver: usize,
    /// The queries (more than one: a batch).
    queries: Vec<usize>,
}

impl<'a> Schedule<'a> {
    /// The schedule of `queries` in `groups` on `cfg.solvers`, the `small` ones in batches.
    fn new(queries: &'a [Query], groups: &'a [usize], small: &[bool], cfg: &'a Config) -> Self {
        let ngroups = groups.iter().copied().max().map_or(0, |g| g + 1);
        let mut sizes = vec![0usize; ngroups];
        for g in groups {
            sizes[*g] += 1;
        }
        let is_small = |qi: usize| small.get(qi).copied().unwrap_or(false);
        let group_of = |qi: usize| groups.get(qi).copied().unwrap_or(qi);
        let mut with_small = vec![false; ngroups.max(queries.len())];
        for qi in (0..queries.len()).filter(|&qi| is_small(qi)) {
            with_small[group_of(qi)] = true;
        }
        // Solver-major order: every query's first solver, then the second: the encodings
        // of one obligation run side by side, and a solver's first proof cancels its
        // runs on the rest.
        let mut tasks = Vec::new();
        for si in 0..cfg.solvers.len() {
            let mut batch: Vec<usize> = Vec::new();
            let mut late = Vec::new();
            for qi in 0..queries.len() {
                if is_small(qi) {
                    batch.push(qi);
                    if batch.len() == BATCH {
                        tasks.push(Task {
                            solver: si,
                            queries: std::mem::take(&mut batch),
                        });
                    }
                    continue;
                }
                let task = Task {
                    solver: si,
                    queries: vec![qi],
                };
                if with_small[group_of(qi)] {
                    late.push(task);
                } else {
                    tasks.push(task);
                }
            }
            if !batch.is_empty() {
                tasks.push(Task {
                    solver: si,
                    queries: batch,
                });
            }
            tasks.extend(late);
        }
        Schedule {
            queries,
            groups,
            cfg,
            sizes,
            stop: (0..ngroups * cfg.solvers.len())
                .map(|_| AtomicBool::new(false))
                .collect(),
            versions: cfg.solvers.iter().map(|s| s.version()).collect(),
            texts: queries.iter().map(solver_text).collect(),
            tasks,
            next: AtomicUsize::new(0),
        }
    }

    /// The group of query `qi`.
    fn group(&self, qi: usize) -> usize {
        self.groups.get(qi).copied().unwrap_or(0)
    }

    /// The stop flag of query `qi`'s group for solver `si`, when the group has alternatives.
    fn flag(&self, qi: usize, si: usize) -> Option<&AtomicBool> {
        let g = self.group(qi);
        let shared = self.sizes.get(g).copied().unwrap_or(1) > 1;
        self.stop
            .get(g * self.cfg.solvers.len() + si)
            .filter(|_| shared)
    }

    /// Takes the next task and runs it (or cancels it, when its solver has stopped working on
    /// its group); `None` when every task has been handed out.
    fn run_next(&self) -> Option<Vec<Done>> {
        let t = self.next.fetch_add(1, Ordering::Relaxed);
        let task = self.tasks.get(t)?;
        let si = task.solver;
        let solver = self.cfg.solvers[si];
        let cancelled = Run {
            solver,
            answer: Answer::Cancelled,
            millis: 0,
            cached: false,
            shared: false,
        };
        let stopped = |qi: usize| self.flag(qi, si).is_some_and(|f| f.load(Ordering::Relaxed));
        let (off, on): (Vec<usize>, Vec<usize>) = task.queries.iter().partition(|&&qi| stopped(qi));
        let mut out: Vec<Done> = off
            .into_iter()
            .map(|qi| (qi, si, cancelled.clone()))
            .collect();
        let runs = match on.as_slice() {
            [] => Vec::new(),
            &[qi] => vec![run_one(
                solver,
                self.versions[si],
                &self.texts[qi],
                &self.queries[qi].want,
                self.cfg,
                self.flag(qi, si),
            )],
            many => {
                let qs: Vec<&Query> = many.iter().map(|&qi| &self.queries[qi]).collect();
                run_batch(solver, self.versions[si], &qs, self.cfg)
            }
        };
        for (qi, run) in on.into_iter().zip(runs) {
            if run.answer == Answer::Unsat {
                if let Some(f) = self.flag(qi, si) {
                    f.store(true, Ordering::Relaxed);
                }
            }
            out.push((qi, si, run));
        }
        Some(out)
    }

    /// Stops every solver's work on the group of query `qi` (its counterexample replayed).
    fn stop_group(&self, qi: usize) {
        let per_query = self.cfg.solvers.len();
        let g = self.group(qi);
        for f in self.stop.iter().skip(g * per_query).take(per_query) {
            f.store(true, Ordering::Relaxed);
        }
    }
}

/// Runs every task of `schedule` on up to `workers` threads and hands each result to
/// `record`, on the calling thread, as it arrives.
fn on_workers(schedule: &Schedule, workers: usize, record: &mut dyn FnMut(Done)) {
    let (tx, rx) = mpsc::channel::<Done>();
    thread::scope(|scope| {
        let mut spawned = 0;
        for _ in 0..workers {
            let tx = tx.clone();
            let worker = thread::Builder::new()
                .name("qloop-smt".to_string())
                .spawn_scoped(scope, move || {
                    'work: while let Some(results) = schedule.run_next() {
                        for result in results {
                            if tx.send(result).is_err() {
                                break 'work;
                            }
                        }
                    }
                });
            if worker.is_ok() {
                spawned += 1;
            }
        }
        drop(tx);
        if spawned == 0 {
            // No thread could be started: do the work here, one process at a time.
            while let Some(results) = schedule.run_next() {
                results.into_iter().for_each(&mut *record);
            }
        } else {
            for result in rx {
                record(result);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::testing::*;
    use crate::prove::solver::Solver;
    use std::fs;
    use std::path::PathBuf;
    use std::time::{Duration, Instant};

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
        // Two different queries (identical ones would run once: `dedup`).
        let other = Query {
            script: hard.script.replace(
                "#x00000001))\n(assert (bvugt ((_ extract 31 0) q)",
                "#x00000002))\n(assert (bvugt ((_ extract 31 0) q)",
            ),
            want: vec![],
        };
        assert_ne!(other.script, hard.script);
        let runs = run_all(&[hard, other], &cfg, &mut |_, _| {});
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
            &mut |_, _, _| {},
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
            &mut |_, _, _| {},
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
