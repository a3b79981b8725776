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

use crate::lower::Plan;
use obligations::{Goal, Kind, Obligation};
use replay::{Cex, Replay};
use solver::{Answer, Config, Query, Run, Solver};
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
    /// One run per solver.
    pub runs: Vec<Run>,
    /// The counterexample, if refuted (or offered but not replayed).
    pub cex: Option<Cex>,
    /// What the replay found, or why the verdict is unknown.
    pub note: Option<String>,
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
}

impl Report {
    /// Whether every obligation is proved.
    pub fn proved(&self) -> bool {
        self.outcomes.iter().all(|o| o.verdict == Verdict::Proved)
    }
}

/// Proves every obligation of `plan`.
pub fn prove(plan: &Plan, cfg: &Config, progress: &mut dyn FnMut(usize, usize)) -> Report {
    prove_filtered(plan, cfg, None, progress)
}

/// Proves the obligations whose name contains `only` (all if `None`).
pub fn prove_filtered(
    plan: &Plan,
    cfg: &Config,
    only: Option<&str>,
    progress: &mut dyn FnMut(usize, usize),
) -> Report {
    let start = Instant::now();
    let (all, witnesses) = obligations::with_witnesses(plan);
    let obs: Vec<Obligation> = all
        .into_iter()
        .filter(|o| only.is_none_or(|t| o.label().contains(t)))
        .collect();
    let mut queries: Vec<Query> = obs.iter().map(|o| o.query.clone()).collect();
    // The encodings of one question form a group: a solver's first proof cancels its runs on
    // the others.
    let mut groups: Vec<usize> = obs
        .iter()
        .enumerate()
        .map(|(i, o)| obs.iter().position(|x| alternatives(x, o)).unwrap_or(i))
        .collect();
    // One witness query per property under test (own group): its premises must be
    // satisfiable, or the property holds vacuously.
    let mut witnessed: Vec<usize> = Vec::new();
    for (k, w) in witnesses.into_iter().enumerate() {
        let tested = obs.iter().any(|o| o.goal == Goal::Property(k));
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
    let mut runs = solver::run_all_grouped(&queries, &groups, cfg, progress, &mut confirm);
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
            if o.runs.iter().any(|r| matches!(r.answer, Answer::Sat(_))) {
                let g = obligations::global_for(plan, *val);
                let runs = solver::run_all(std::slice::from_ref(&g.query), cfg, &mut |_, _| {});
                let mut again = judge(plan, g, runs.into_iter().next().unwrap_or_default());
                again.note = Some(format!(
                    "local query refuted (analysis/encoding mismatch: a qloop bug); whole-program query: {}",
                    again.note.clone().unwrap_or_else(|| again.verdict.name().into())
                ));
                *o = again;
            }
        }
    }
    let mut outcomes = merge_portfolio(outcomes);
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
    }
}

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
    // Per merged outcome: (solver, encoding) of each solver's first proof.
    let mut provers: Vec<Vec<(Solver, &str)>> = Vec::new();
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
        let same = out.iter().position(|x| alternatives(&x.ob, &o.ob));
        let Some(k) = same else {
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
    let mut out = Outcome {
        ob,
        verdict: Verdict::Unknown,
        runs,
        cex: None,
        note: None,
    };
    match (unsat, model) {
        (true, None) => out.verdict = Verdict::Proved,
        (true, Some(_)) => {
            out.note = Some("the solvers disagree (one proved, one refuted): a bug in qloop's encoding or a solver; please report it".into());
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

impl Report {
    /// The human-readable table.
    pub fn table(&self, plan: &Plan) -> String {
        let mut o = String::new();
        let solvers: Vec<Solver> = self
            .outcomes
            .first()
            .map(|x| x.runs.iter().map(|r| r.solver).collect())
            .unwrap_or_default();
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
            for s in &solvers {
                r.push(
                    x.runs
                        .iter()
                        .find(|run| run.solver == *s)
                        .map_or("-".into(), |run| {
                            if run.cached {
                                format!("{} (cached)", answer_name(&run.answer))
                            } else {
                                format!("{} {} ms", answer_name(&run.answer), run.millis)
                            }
                        }),
                );
            }
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
        let proved = self
            .outcomes
            .iter()
            .filter(|x| x.verdict == Verdict::Proved)
            .count();
        let both = self
            .outcomes
            .iter()
            .filter(|x| {
                x.verdict == Verdict::Proved
                    && x.runs.len() > 1
                    && x.runs.iter().all(|r| r.answer == Answer::Unsat)
            })
            .count();
        let _ = writeln!(
            o,
            "\n{} obligations: {proved} proved ({both} by every solver), {} refuted, {} unknown; wall {:.2} s",
            self.outcomes.len(),
            self.outcomes.iter().filter(|x| x.verdict == Verdict::Refuted).count(),
            self.outcomes.iter().filter(|x| x.verdict == Verdict::Unknown).count(),
            self.wall_ms as f64 / 1000.0
        );
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
            if let Some(n) = &x.note {
                let _ = writeln!(o, "  {n}");
            }
            if let Some(c) = &x.cex {
                for l in replay::describe(plan, &x.ob, c) {
                    let _ = writeln!(o, "  {l}");
                }
            }
        }
        let _ = writeln!(
            o,
            "\nOverflow obligations assume only the state ranges and invariants; with the initial and \
inductive obligations they hold for every reachable state, by induction over one step, for unbounded time. \
Inputs are arbitrary bits (step clamps them), except in properties, which assume inputs in range. The obligations lean on each other: whole-program queries take other values' intervals as lemmas, and the integer encodings of properties and invariants rely on no value wrapping, so the spec is proved only when every obligation is. Over-approximate encodings (abstracted products, linear envelopes) can only yield spurious counterexamples, and the replay rejects those."
        );
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
                    m.insert(r.solver.name().into(), json_answer(&r.answer).into());
                    m.insert(format!("{}_ms", r.solver.name()), r.millis.into());
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
