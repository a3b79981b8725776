//! The SMT proof backend: obligations of a plan, discharged by z3 and cvc5 in parallel, with
//! counterexamples replayed before anything is called refuted.
//!
//! Verdicts: **proved** when at least one solver answers `unsat` and none finds a
//! counterexample; **refuted** when a solver's counterexample replays (see [`replay`]);
//! otherwise **unknown** (timeouts, errors, a counterexample that does not replay, or the two
//! solvers disagreeing, which would be a bug in qloop or a solver and is said so).

pub mod exact;
pub mod obligations;
pub mod replay;
pub mod smt;
pub mod solver;
pub mod witness;

use crate::lower::Plan;
use obligations::{Goal, Kind, Obligation};
use replay::{Cex, Replay};
use solver::{Answer, Config, Query, Run, Solver};
use std::collections::HashMap;
use std::fmt::Write;
use std::time::Instant;

/// Verdict of one obligation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Proved by at least one solver; no counterexample.
    Proved,
    /// A counterexample that replays.
    Refuted,
    /// Neither.
    Unknown,
}

impl Verdict {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Proved => "proved",
            Verdict::Refuted => "refuted",
            Verdict::Unknown => "unknown",
        }
    }
}

/// The result of one obligation.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The obligation.
    pub ob: Obligation,
    /// Verdict.
    pub verdict: Verdict,
    /// One run per solver: its best answer over the obligation's encodings.
    pub runs: Vec<Run>,
    /// Every run of every encoding, with what the replay made of its counterexample.
    pub attempts: Vec<Attempt>,
    /// The counterexample, if refuted (or offered but not replayed).
    pub cex: Option<Cex>,
    /// What the replay found, or why the verdict is unknown.
    pub note: Option<String>,
}

/// What one solver said on one encoding of an obligation.
#[derive(Clone, Debug)]
pub struct Attempt {
    /// The encoding (`exact`, `abstracted`, ...; `None` where an obligation has one).
    pub encoding: Option<&'static str>,
    /// The run.
    pub run: Run,
    /// A counterexample (`sat`) that the replay rejected: an over-approximate encoding's
    /// spurious model, not a refutation.
    pub spurious: bool,
}

/// Progress of a proof, for a command line to show.
#[derive(Clone, Copy, Debug)]
pub enum Progress<'a> {
    /// A solver run finished: `done` of `total`.
    Runs {
        /// Runs finished.
        done: usize,
        /// All runs.
        total: usize,
    },
    /// Every run of one kind of obligation (overflow, initial, ...) finished.
    Group {
        /// The kind.
        kind: &'a str,
        /// How many obligations of that kind (counting each encoding).
        queries: usize,
        /// Seconds since the proof started.
        secs: f64,
    },
}

/// The proof report of a spec.
#[derive(Clone, Debug)]
pub struct Report {
    /// Spec name.
    pub spec: String,
    /// One outcome per obligation.
    pub outcomes: Vec<Outcome>,
    /// Wall-clock time.
    pub wall_ms: u64,
    /// Solver processes run at once.
    pub jobs: usize,
    /// The runs that check each property's premises are satisfiable (not vacuous).
    pub witness_runs: Vec<Run>,
    /// Properties whose premises a run of the plan met ([`witness::concrete`]), so that no
    /// solver had to check them.
    pub witnessed_by_run: usize,
}

impl Report {
    /// Whether every obligation is proved.
    pub fn proved(&self) -> bool {
        self.outcomes.iter().all(|o| o.verdict == Verdict::Proved)
    }
}

/// Proves every obligation of `plan`.
pub fn prove(plan: &Plan, cfg: &Config, progress: &mut dyn FnMut(Progress)) -> Report {
    prove_filtered(plan, cfg, None, progress)
}

/// Proves the obligations whose name contains `only` (all if `None`).
pub fn prove_filtered(
    plan: &Plan,
    cfg: &Config,
    only: Option<&str>,
    progress: &mut dyn FnMut(Progress),
) -> Report {
    let start = Instant::now();
    // The whole-step fallbacks wait for phase 2 (below): asked only where needed.
    let (all, witnesses) = obligations::with_witnesses_staged(plan, true);
    let (deferred, obs): (Vec<Obligation>, Vec<Obligation>) = all
        .into_iter()
        .filter(|o| only.is_none_or(|t| o.label().contains(t)))
        .partition(Obligation::deferred);
    let mut queries: Vec<Query> = obs.iter().map(|o| o.query.clone()).collect();
    // The encodings of one question form a group: a solver's first proof cancels its runs on
    // the others.
    let mut first_of: HashMap<(Goal, obligations::Kind), usize> = HashMap::new();
    let mut groups: Vec<usize> = obs
        .iter()
        .enumerate()
        .map(|(i, o)| match o.encoding {
            // Alternatives (`alternatives`): encodings of one goal and kind.
            Some(_) => *first_of.entry((o.goal.clone(), o.kind)).or_insert(i),
            None => i,
        })
        .collect();
    // One witness query per property under test (own group): its premises must be
    // satisfiable, or the property holds vacuously.
    let mut witnessed: Vec<usize> = Vec::new();
    let mut witnessed_by_run = 0;
    for (k, w) in witnesses.into_iter().enumerate() {
        let tested = obs.iter().any(|o| o.goal == Goal::Property(k));
        // A run of the plan that meets the premises settles it without a solver.
        if tested && witness::concrete(plan, k).is_some() {
            witnessed_by_run += 1;
            continue;
        }
        if let (true, Some(w)) = (tested, w) {
            witnessed.push(k);
            groups.push(queries.len());
            queries.push(w);
        }
    }
    // A counterexample that replays settles its group: the other encodings stop.
    let mut confirm = |i: usize, run: &Run| {
        obs.get(i)
            .is_some_and(|o| judge(plan, o.clone(), vec![run.clone()]).verdict == Verdict::Refuted)
    };
    // Runs left per kind of obligation (witnesses count with properties), for the group lines.
    let kind_of = |qi: usize| obs.get(qi).map_or("property", |o| o.kind.name());
    let mut left: Vec<(&str, usize, usize)> = Vec::new();
    for qi in 0..queries.len() {
        let k = kind_of(qi);
        match left.iter_mut().find(|e| e.0 == k) {
            Some(e) => {
                e.1 += cfg.solvers.len();
                e.2 += 1;
            }
            None => left.push((k, cfg.solvers.len(), 1)),
        }
    }
    let mut on_run = |done: usize, total: usize, qi: usize| {
        progress(Progress::Runs { done, total });
        let k = kind_of(qi);
        if let Some(e) = left.iter_mut().find(|e| e.0 == k) {
            e.1 -= 1;
            if e.1 == 0 {
                progress(Progress::Group {
                    kind: e.0,
                    queries: e.2,
                    secs: start.elapsed().as_secs_f64(),
                });
            }
        }
    };
    let small: Vec<bool> = obs.iter().map(Obligation::small).collect();
    let mut runs =
        solver::run_all_batched(&queries, &groups, &small, cfg, &mut on_run, &mut confirm);
    let witness_runs = runs.split_off(obs.len());
    let mut outcomes: Vec<Outcome> = obs
        .into_iter()
        .zip(runs)
        .map(|(ob, runs)| judge(plan, ob, runs))
        .collect();
    // A local overflow query refuted: its operands are free, so the model is not a program
    // state. Ask the whole-program question for that value; only that can be replayed.
    for o in outcomes.iter_mut() {
        if let (Goal::Val { val, local: true }, Verdict::Unknown) = (&o.ob.goal, o.verdict) {
            // The bit-vector query decides; a product's linear envelope is its shortcut.
            if o.ob
                .encoding
                .is_none_or(|how| how == obligations::overflow::BIT_VECTOR)
                && o.runs.iter().any(|r| matches!(r.answer, Answer::Sat(_)))
            {
                let g = obligations::global_for(plan, *val);
                let runs = solver::run_all(std::slice::from_ref(&g.query), cfg, &mut |_, _| {});
                let mut again = judge(plan, g, runs.into_iter().next().unwrap_or_default());
                // Still one of the value's encodings, merged with the others below.
                again.ob.encoding = o.ob.encoding;
                again.ob.goal = o.ob.goal.clone();
                again.note = Some(format!(
                    "local query refuted (analysis/encoding mismatch: a qloop bug); whole-program query: {}",
                    again.note.clone().unwrap_or_else(|| again.verdict.name().into())
                ));
                *o = again;
            }
        }
    }
    outcomes.extend(phase_two(plan, cfg, deferred, &outcomes));
    let mut outcomes = merge_portfolio(outcomes);
    outcomes.extend(
        table_claims(plan)
            .into_iter()
            .filter(|o| only.is_none_or(|t| o.ob.label().contains(t))),
    );
    let all_witness_runs: Vec<Run> = witness_runs.iter().flatten().cloned().collect();
    for (k, runs) in witnessed.into_iter().zip(witness_runs) {
        if !runs.iter().any(|r| r.answer == Answer::Unsat) {
            continue;
        }
        for o in outcomes
            .iter_mut()
            .filter(|o| o.ob.goal == Goal::Property(k))
        {
            if o.verdict == Verdict::Proved {
                o.verdict = Verdict::Unknown;
                o.note = Some(
                    "vacuous: no state in the ranges and invariants, input in range and \
parameter value meets the `assume`s, so the property says nothing; check its assumptions"
                        .into(),
                );
            }
        }
    }
    Report {
        spec: plan.prog.name.clone(),
        outcomes,
        wall_ms: start.elapsed().as_millis() as u64,
        jobs: cfg.jobs.max(1),
        witness_runs: all_witness_runs,
        witnessed_by_run,
    }
}

/// Phase 2 of [`prove_filtered`]: the deferred whole-step fallbacks
/// ([`Obligation::deferred`]) that a solver still needs, asked of that solver alone. A
/// solver needs the fallback of a goal when none of its runs on the goal's other encodings
/// proved it, and no counterexample refuted it; the rest are not asked, and the report
/// lists only the encodings that ran.
fn phase_two(
    plan: &Plan,
    cfg: &Config,
    deferred: Vec<Obligation>,
    outcomes: &[Outcome],
) -> Vec<Outcome> {
    let mut settled: HashMap<(Goal, obligations::Kind), (bool, Vec<Solver>)> = HashMap::new();
    for o in outcomes {
        let e = settled.entry((o.ob.goal.clone(), o.ob.kind)).or_default();
        e.0 |= o.verdict == Verdict::Refuted;
        for r in &o.runs {
            if r.answer == Answer::Unsat && !e.1.contains(&r.solver) {
                e.1.push(r.solver);
            }
        }
    }
    // Which solvers need each deferred fallback; each needed query is made once.
    let need: Vec<Vec<Solver>> = deferred
        .iter()
        .map(|o| {
            let s = settled.get(&(o.goal.clone(), o.kind));
            cfg.solvers
                .iter()
                .copied()
                .filter(|v| s.is_none_or(|(refuted, proved)| !refuted && !proved.contains(v)))
                .collect()
        })
        .collect();
    if need.iter().all(Vec::is_empty) {
        return Vec::new();
    }
    let step = obligations::WholeStep::new(plan);
    let made: Vec<Option<Obligation>> = deferred
        .into_iter()
        .zip(&need)
        .map(|(o, n)| {
            let query = if n.is_empty() {
                None
            } else {
                obligations::whole_query(&step, &o.goal, o.kind)
            };
            query.map(|query| Obligation { query, ..o })
        })
        .collect();
    let mut out = Vec::new();
    for &solver in &cfg.solvers {
        let obs: Vec<&Obligation> = made
            .iter()
            .zip(&need)
            .filter(|(_, n)| n.contains(&solver))
            .filter_map(|(o, _)| o.as_ref())
            .collect();
        if obs.is_empty() {
            continue;
        }
        let queries: Vec<Query> = obs.iter().map(|o| o.query.clone()).collect();
        let groups: Vec<usize> = (0..queries.len()).collect();
        let one = Config {
            solvers: vec![solver],
            ..cfg.clone()
        };
        let mut confirm = |i: usize, run: &Run| {
            obs.get(i).is_some_and(|o| {
                judge(plan, (*o).clone(), vec![run.clone()]).verdict == Verdict::Refuted
            })
        };
        let runs = solver::run_all_batched(
            &queries,
            &groups,
            &[],
            &one,
            &mut |_, _, _| {},
            &mut confirm,
        );
        out.extend(
            obs.iter()
                .map(|o| (*o).clone())
                .zip(runs)
                .map(|(ob, runs)| judge(plan, ob, runs)),
        );
    }
    out
}

/// The claimed interpolation errors of the tables (`table .., error E;`), decided by qloop:
/// proved where the bound (second derivative in interval arithmetic plus the samples' distance
/// from the exact values, [`crate::ir::Table::interp_err`]) is at most the claim; refuted, with
/// the table's argument as the counterexample (variable `x`, its value in units of 2^-40),
/// where the interpolant misses the expression, enclosed in exact arithmetic, by more than the
/// claim at a sampled point; else unknown.
fn table_claims(plan: &Plan) -> Vec<Outcome> {
    use crate::ir::TableClaim;
    plan.prog
        .tables
        .iter()
        .enumerate()
        .filter_map(|(i, t)| {
            let v = t.claim_verdict()?;
            let claim = t.claim.unwrap_or(0.0);
            let ob = Obligation {
                name: format!(
                    "table {} claim: |L(x) - f(x)| <= {} over [{}, {}]",
                    t.name,
                    crate::text::g(claim),
                    crate::text::g(t.lo),
                    crate::text::g(t.hi)
                ),
                kind: Kind::Table,
                query: Query {
                    script: String::new(),
                    want: Vec::new(),
                },
                goal: Goal::Table(i),
                line: t.span.start().line,
                encoding: None,
            };
            let (verdict, cex, note) = match v {
                TableClaim::Proved => (
                    Verdict::Proved,
                    None,
                    format!(
                        "by qloop: the bound {} (curvature and samples, exact) is at most the claim",
                        crate::text::bound(t.interp_err)
                    ),
                ),
                TableClaim::Refuted { x, err } => (
                    Verdict::Refuted,
                    Some(replay::Cex {
                        values: vec![("x".into(), (x * 2f64.powi(40)).round() as i128, 64)],
                    }),
                    format!(
                        "by qloop: at x = {}, |L(x) - f(x)| >= {} (exact) exceeds the claim",
                        crate::text::g(x),
                        crate::text::bound_down(err)
                    ),
                ),
                TableClaim::Unknown => (
                    Verdict::Unknown,
                    None,
                    format!(
                        "by qloop: the bound {} is above the claim and no sampled point exceeds it",
                        crate::text::bound(t.interp_err)
                    ),
                ),
            };
            Some(Outcome {
                ob,
                verdict,
                runs: Vec::new(),
                attempts: Vec::new(),
                cex,
                note: Some(note),
            })
        })
        .collect()
}

/// The start of the note of an obligation on which two solvers disagree.
pub const DISAGREE: &str = "SOLVER DISAGREEMENT";

/// Whether `a` and `b` are two encodings of one question.
fn alternatives(a: &Obligation, b: &Obligation) -> bool {
    a.encoding.is_some() && b.encoding.is_some() && a.goal == b.goal && a.kind == b.kind
}

/// Merges the encodings of one question into one outcome: refuted if any replays a
/// counterexample, else proved if any is proved. Each solver's answer is its best over the
/// encodings, and the note says which encoding each solver proved it in.
fn merge_portfolio(outcomes: Vec<Outcome>) -> Vec<Outcome> {
    let rank = |v: Verdict| match v {
        Verdict::Refuted => 2,
        Verdict::Proved => 1,
        Verdict::Unknown => 0,
    };
    // A proof outranks a (possibly spurious) model of an over-approximation.
    let answer_rank = |x: &Answer| match x {
        Answer::Unsat => 4,
        Answer::Sat(_) => 3,
        Answer::Timeout => 2,
        Answer::Cancelled => 1,
        Answer::Error(_) => 0,
    };
    let mut out: Vec<Outcome> = Vec::new();
    // The merged outcome of each (goal, kind) that has encodings.
    let mut merged_at: HashMap<(Goal, obligations::Kind), usize> = HashMap::new();
    // Per merged outcome: (solver, encoding) of each solver's first proof.
    let mut provers: Vec<Vec<(Solver, &str)>> = Vec::new();
    // The encodings on which two solvers disagreed, with their notes.
    let disagreements: Vec<(Obligation, String)> = outcomes
        .iter()
        .filter_map(|o| {
            o.note
                .as_ref()
                .filter(|n| n.starts_with(DISAGREE))
                .map(|n| (o.ob.clone(), n.clone()))
        })
        .collect();
    for o in outcomes {
        let Some(how) = o.ob.encoding else {
            out.push(o);
            provers.push(Vec::new());
            continue;
        };
        let proofs: Vec<(Solver, &str)> = o
            .runs
            .iter()
            .filter(|r| r.answer == Answer::Unsat)
            .map(|r| (r.solver, how))
            .collect();
        let same = merged_at
            .get(&(o.ob.goal.clone(), o.ob.kind))
            .copied()
            .filter(|&k| alternatives(&out[k].ob, &o.ob));
        let Some(k) = same else {
            merged_at.insert((o.ob.goal.clone(), o.ob.kind), out.len());
            out.push(o);
            provers.push(proofs);
            continue;
        };
        for (solver, how) in proofs {
            if !provers[k].iter().any(|(s, _)| *s == solver) {
                provers[k].push((solver, how));
            }
        }
        let prev = &mut out[k];
        prev.attempts.extend(o.attempts.iter().cloned());
        if rank(o.verdict) > rank(prev.verdict) {
            prev.verdict = o.verdict;
            prev.cex = o.cex.clone();
            prev.note = o.note.clone();
        }
        for r in o.runs {
            match prev.runs.iter_mut().find(|p| p.solver == r.solver) {
                Some(p) if answer_rank(&r.answer) > answer_rank(&p.answer) => *p = r,
                Some(_) => {}
                None => prev.runs.push(r),
            }
        }
    }
    for (o, proofs) in out.iter_mut().zip(provers) {
        // A disagreement on any encoding is a bug somewhere: never hidden by a proof in
        // another encoding.
        if let Some(n) = disagreements.iter().find(|(k, _)| alternatives(k, &o.ob)) {
            o.verdict = Verdict::Unknown;
            o.note = Some(n.1.clone());
            continue;
        }
        if o.verdict == Verdict::Proved && !proofs.is_empty() {
            let each: Vec<String> = proofs
                .iter()
                .map(|(s, how)| format!("{} in the {how} encoding", s.name()))
                .collect();
            o.note = Some(format!("proved by {}", each.join(", ")));
        }
    }
    out
}

fn judge(plan: &Plan, ob: Obligation, runs: Vec<Run>) -> Outcome {
    let unsat = runs.iter().any(|r| r.answer == Answer::Unsat);
    let model = runs.iter().find_map(|r| match &r.answer {
        Answer::Sat(m) => Some(m.clone()),
        _ => None,
    });
    let attempts = runs
        .iter()
        .map(|r| Attempt {
            encoding: ob.encoding,
            run: r.clone(),
            spurious: false,
        })
        .collect();
    let mut out = Outcome {
        ob,
        verdict: Verdict::Unknown,
        runs,
        attempts,
        cex: None,
        note: None,
    };
    match (unsat, model) {
        (true, None) => out.verdict = Verdict::Proved,
        (true, Some(_)) => {
            out.note = Some(format!(
                "{DISAGREE}: on one encoding one solver proved and another found a model; a bug in qloop's encoding or a solver, please report it"
            ));
        }
        (false, Some(m)) => {
            let cex = Cex::from_model(&m, &|n| replay::var_is_signed(plan, n));
            let initial = out.ob.kind == Kind::Initial;
            match replay::replay(plan, &out.ob, &cex, initial) {
                Replay::Confirmed(what) => {
                    out.verdict = Verdict::Refuted;
                    out.note = Some(what);
                }
                Replay::NotConfirmed(why) => {
                    out.note = Some(format!(
                        "spurious counterexample (over-approximation): replay says {why}"
                    ));
                    // Only the model that was replayed is known to be spurious.
                    for a in &mut out.attempts {
                        a.spurious = matches!(&a.run.answer, Answer::Sat(x) if *x == m);
                    }
                }
                Replay::NotApplicable => {}
            }
            out.cex = Some(cex);
        }
        (false, None) => {
            let why: Vec<String> = out
                .runs
                .iter()
                .map(|r| format!("{}: {}", r.solver.name(), answer_name(&r.answer)))
                .collect();
            out.note = Some(why.join(", "));
        }
    }
    out
}

/// Short name of a solver answer.
pub fn answer_name(a: &Answer) -> String {
    match a {
        Answer::Unsat => "proved".into(),
        Answer::Sat(_) => "refuted".into(),
        Answer::Timeout => "timeout".into(),
        Answer::Cancelled => "cancelled".into(),
        Answer::Error(e) => format!("error ({})", e.lines().next().unwrap_or("")),
    }
}

fn json_answer(a: &Answer) -> &'static str {
    match a {
        Answer::Unsat => "proved",
        Answer::Sat(_) => "refuted",
        Answer::Timeout => "timeout",
        Answer::Cancelled => "cancelled",
        Answer::Error(_) => "error",
    }
}

/// Milliseconds as text: `45 ms`, `12.3 s`.
fn duration_text(ms: u64) -> String {
    if ms < 10_000 {
        format!("{ms} ms")
    } else {
        format!("{:.1} s", ms as f64 / 1000.0)
    }
}

impl Outcome {
    /// What `solver` said about this obligation, over every encoding it ran, and its total
    /// time: the proof where it proved one (`proved`), a counterexample that replays
    /// (`refuted`), otherwise each distinct answer with its encoding (`spurious cex
    /// (abstracted) + timeout (exact)`: a model of an over-approximation that the replay
    /// rejected is never shown as `refuted`, nor is one that was not replayed: `sat (not
    /// replayed)`).
    pub fn solver_answer(&self, solver: Solver) -> Option<(String, u64, bool)> {
        let mine: Vec<&Attempt> = self
            .attempts
            .iter()
            .filter(|a| a.run.solver == solver)
            .collect();
        if mine.is_empty() {
            return None;
        }
        let total = self.solver_ms(solver);
        let cached = mine.iter().all(|a| a.run.cached);
        let several = mine.len() > 1;
        let with_enc = |label: &str, a: &Attempt| match (several, a.encoding) {
            (true, Some(e)) => format!("{label} ({e})"),
            _ => label.to_string(),
        };
        let label = |a: &Attempt| match &a.run.answer {
            Answer::Sat(_) if a.spurious => "spurious cex".to_string(),
            // A model nobody replayed (a local query's, or beside a replayed one) is no
            // refutation.
            Answer::Sat(_) => "sat (not replayed)".to_string(),
            other => answer_name(other),
        };
        let text = if let Some(a) = mine.iter().find(|a| a.run.answer == Answer::Unsat) {
            with_enc("proved", a)
        } else if let Some(a) = mine
            .iter()
            .find(|a| matches!(a.run.answer, Answer::Sat(_)) && !a.spurious)
            .filter(|_| self.verdict == Verdict::Refuted)
        {
            with_enc("refuted", a)
        } else {
            let first = label(mine[0]);
            if mine.iter().all(|a| label(a) == first) {
                first
            } else {
                let mut parts: Vec<String> = Vec::new();
                for a in &mine {
                    let p = with_enc(&label(a), a);
                    if !parts.contains(&p) {
                        parts.push(p);
                    }
                }
                parts.join(" + ")
            }
        };
        Some((text, total, cached))
    }

    /// The time `solver` spent on this obligation, over all its encodings.
    pub fn solver_ms(&self, solver: Solver) -> u64 {
        self.attempts
            .iter()
            .filter(|a| a.run.solver == solver)
            .map(|a| a.run.millis)
            .sum()
    }

    /// The longest any one solver spent on this obligation (all its encodings).
    pub fn slowest_ms(&self) -> u64 {
        Solver::ALL
            .iter()
            .map(|s| self.solver_ms(*s))
            .max()
            .unwrap_or(0)
    }
}

impl Report {
    /// The solvers of the report, in column order.
    fn solvers(&self) -> Vec<Solver> {
        self.outcomes
            .first()
            .map(|x| x.runs.iter().map(|r| r.solver).collect())
            .unwrap_or_default()
    }

    /// One solver's cell of the table.
    fn cell(x: &Outcome, s: Solver) -> String {
        let shared = x
            .attempts
            .iter()
            .filter(|a| a.run.solver == s)
            .all(|a| a.run.shared);
        x.solver_answer(s).map_or("-".into(), |(text, ms, cached)| {
            if shared {
                format!("{text} (same query as another obligation's, asked once)")
            } else if cached {
                format!("{text} (cached)")
            } else {
                format!("{text} {}", duration_text(ms))
            }
        })
    }

    /// The full table (`qloop prove --verbose`), then the [`Report::summary`].
    pub fn table(&self, plan: &Plan) -> String {
        let mut o = String::new();
        let solvers = self.solvers();
        let mut rows: Vec<Vec<String>> = Vec::new();
        for x in &self.outcomes {
            let line = if x.ob.line > 0 {
                x.ob.line.to_string()
            } else {
                String::new()
            };
            let mut r = vec![
                line,
                x.ob.name.clone(),
                x.ob.kind.name().into(),
                x.verdict.name().into(),
            ];
            r.extend(solvers.iter().map(|s| Self::cell(x, *s)));
            rows.push(r);
        }
        let mut head = vec![
            "line".to_string(),
            "obligation".into(),
            "kind".into(),
            "verdict".into(),
        ];
        head.extend(solvers.iter().map(|s| s.name().to_string()));
        o.push_str(&crate::report::table(&head, &rows));
        o.push_str(&self.summary(plan));
        let _ = writeln!(
            o,
            "\nOverflow obligations assume only the state ranges and invariants; with the initial and \
inductive obligations they hold for every reachable state, by induction over one step, for unbounded time. \
Inputs are arbitrary bits (step clamps them), except in properties, which assume inputs in range. The obligations lean on each other: whole-program queries take other values' intervals as lemmas, and the integer encodings of properties and invariants rely on no value wrapping, so the spec is proved only when every obligation is. Over-approximate encodings (abstracted products, linear envelopes, cut points) can only yield spurious counterexamples, and the replay rejects those: a model whose pre-state breaks a range or an invariant, or whose step does not break the obligation."
        );
        o
    }

    /// The summary (`qloop prove`'s default output): the counts, where the time went (each
    /// solver's total over every run, against the wall time and the parallel jobs), the five
    /// slowest obligations, and everything not proved with its counterexample.
    pub fn summary(&self, plan: &Plan) -> String {
        let mut o = String::new();
        let solvers = self.solvers();
        let count = |v: Verdict| self.outcomes.iter().filter(|x| x.verdict == v).count();
        let both = self
            .outcomes
            .iter()
            .filter(|x| {
                x.verdict == Verdict::Proved
                    && solvers.len() > 1
                    && solvers.iter().all(|s| {
                        x.attempts
                            .iter()
                            .any(|a| a.run.solver == *s && a.run.answer == Answer::Unsat)
                    })
            })
            .count();
        let _ = writeln!(
            o,
            "\n{} obligations: {} proved ({both} by every solver), {} refuted, {} unknown; wall {:.2} s",
            self.outcomes.len(),
            count(Verdict::Proved),
            count(Verdict::Refuted),
            count(Verdict::Unknown),
            self.wall_ms as f64 / 1000.0
        );
        let per: Vec<String> = solvers
            .iter()
            .map(|s| {
                let ms: u64 = self.outcomes.iter().map(|x| x.solver_ms(*s)).sum::<u64>()
                    + self
                        .witness_runs
                        .iter()
                        .filter(|r| r.solver == *s)
                        .map(|r| r.millis)
                        .sum::<u64>();
                format!("{} {:.2} s", s.name(), ms as f64 / 1000.0)
            })
            .collect();
        let attempts = || self.outcomes.iter().flat_map(|x| &x.attempts);
        let runs = attempts().filter(|a| !a.run.shared).count();
        let shared = match attempts().filter(|a| a.run.shared).count() {
            0 => String::new(),
            n => format!(
                " ({n} more answers taken from them: queries identical up to the names of \
                 their variables are asked once)"
            ),
        };
        let wit_ms: u64 = self.witness_runs.iter().map(|r| r.millis).sum();
        let _ = writeln!(
            o,
            "solver time: {} over {runs} runs{shared} and {} premise (vacuity) checks taking \
             {:.2} s ({} more met by a run of the plan); {} parallel job(s), so the wall time \
             is about the larger of the total over the jobs and the longest single run",
            per.join(", "),
            self.witness_runs.len(),
            wit_ms as f64 / 1000.0,
            self.witnessed_by_run,
            self.jobs
        );
        let mut slow: Vec<&Outcome> = self.outcomes.iter().collect();
        slow.sort_by_key(|x| std::cmp::Reverse(x.slowest_ms()));
        let _ = writeln!(o, "slowest:");
        for x in slow.iter().take(5) {
            let cells: Vec<String> = solvers
                .iter()
                .map(|s| format!("{} {}", s.name(), Self::cell(x, *s)))
                .collect();
            let _ = writeln!(
                o,
                "  {:<9} {} (line {}): {}",
                x.ob.kind.name(),
                x.ob.name,
                x.ob.line,
                cells.join("; ")
            );
        }
        for x in self
            .outcomes
            .iter()
            .filter(|x| x.verdict != Verdict::Proved)
        {
            let _ = writeln!(
                o,
                "\n{}: {} (spec line {})",
                x.verdict.name().to_uppercase(),
                x.ob.name,
                x.ob.line
            );
            for s in &solvers {
                let _ = writeln!(o, "  {}: {}", s.name(), Self::cell(x, *s));
            }
            if let Some(n) = &x.note {
                let _ = writeln!(o, "  {n}");
            }
            if let Some(c) = &x.cex {
                for l in replay::describe(plan, &x.ob, c) {
                    let _ = writeln!(o, "  {l}");
                }
            }
        }
        o
    }

    /// The JSON report.
    pub fn json(&self) -> String {
        let obs: Vec<serde_json::Value> = self
            .outcomes
            .iter()
            .map(|x| {
                let mut m = serde_json::Map::new();
                m.insert("name".into(), x.ob.name.clone().into());
                m.insert("kind".into(), x.ob.kind.name().into());
                m.insert("verdict".into(), x.verdict.name().into());
                m.insert("line".into(), x.ob.line.into());
                for r in &x.runs {
                    let (text, ms, _) = x
                        .solver_answer(r.solver)
                        .unwrap_or_else(|| (json_answer(&r.answer).into(), r.millis, false));
                    m.insert(r.solver.name().into(), text.into());
                    m.insert(format!("{}_ms", r.solver.name()), ms.into());
                }
                if let Some(n) = &x.note {
                    m.insert("note".into(), n.clone().into());
                }
                serde_json::Value::Object(m)
            })
            .collect();
        let v = serde_json::json!({
            "spec": self.spec,
            "proved": self.proved(),
            "wall_ms": self.wall_ms,
            "obligations": obs,
        });
        serde_json::to_string_pretty(&v).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A solver disagreement on one encoding (one proves, the other finds a model) is never
    /// a verdict: the obligation is unknown, the spec is not proved (so `qloop prove` exits
    /// 1), and the summary says SOLVER DISAGREEMENT with both answers.
    #[test]
    fn a_solver_disagreement_fails_loudly() {
        let src = include_str!("../../../verified/specs/acc_fixed_gain.qloop");
        let plan = crate::compile_str(src, &crate::Target::default()).unwrap();
        let ob = obligations::obligations(&plan)
            .into_iter()
            .next()
            .expect("an obligation");
        let run = |solver, answer| Run {
            solver,
            answer,
            millis: 5,
            cached: false,
            shared: false,
        };
        let runs = vec![
            run(Solver::Z3, Answer::Unsat),
            run(Solver::Cvc5, Answer::Sat(Vec::new())),
        ];
        let out = judge(&plan, ob, runs);
        assert_eq!(out.verdict, Verdict::Unknown);
        assert!(out.note.as_deref().unwrap_or("").starts_with(DISAGREE));
        let report = Report {
            spec: "acc_fixed_gain".into(),
            outcomes: vec![out],
            wall_ms: 10,
            jobs: 2,
            witness_runs: Vec::new(),
            witnessed_by_run: 0,
        };
        assert!(!report.proved());
        let s = report.summary(&plan);
        assert!(s.contains("UNKNOWN: ") && s.contains(DISAGREE), "{s}");
        assert!(
            s.contains("z3: proved") && s.contains("cvc5: sat (not replayed)"),
            "{s}"
        );
    }

    /// A model of an over-approximate encoding that the replay rejects shows as `spurious
    /// cex`, never as `refuted`, in the solver's column; with a proof in another encoding the
    /// column says `proved`, with the encoding.
    #[test]
    fn spurious_models_are_not_shown_as_refutations() {
        let attempt = |encoding, answer, spurious| Attempt {
            encoding: Some(encoding),
            run: Run {
                solver: Solver::Z3,
                answer,
                millis: 100,
                cached: false,
                shared: false,
            },
            spurious,
        };
        let src = include_str!("../../../verified/specs/acc_fixed_gain.qloop");
        let plan = crate::compile_str(src, &crate::Target::default()).unwrap();
        let ob = obligations::obligations(&plan).into_iter().next().unwrap();
        let mut o = Outcome {
            ob,
            verdict: Verdict::Unknown,
            runs: Vec::new(),
            attempts: vec![
                attempt("abstracted products", Answer::Sat(Vec::new()), true),
                attempt("exact terms", Answer::Timeout, false),
            ],
            cex: None,
            note: None,
        };
        let (text, ms, _) = o.solver_answer(Solver::Z3).unwrap();
        assert_eq!(
            text,
            "spurious cex (abstracted products) + timeout (exact terms)"
        );
        assert_eq!(ms, 200);
        o.attempts[1].run.answer = Answer::Unsat;
        o.verdict = Verdict::Proved;
        let (text, _, _) = o.solver_answer(Solver::Z3).unwrap();
        assert_eq!(text, "proved (exact terms)");
    }
}
