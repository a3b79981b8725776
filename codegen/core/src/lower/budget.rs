//! Word widths against an error budget: `#[error(E)]` on a state or output.
//!
//! Without a budget every stored signal gets the best format of the spec's `word` for its
//! range, and every `let` the exact working format of what it computes; nothing trades a bit
//! of precision for a narrower word. A budget states the accuracy a signal needs: the bound
//! on one step's error against real arithmetic that `qloop check` prints for it (the same
//! step, from the same stored state and inputs, with the same branch decisions; see the
//! book's "Fixed-point semantics") must stay at or below `E`, in the signal's unit.
//!
//! The search (`tune`) starts from the formats chosen without budgets (the *default*
//! plan) and narrows one choice at a time, greedily, in declaration order:
//! * the storage format of each budgeted state or output (a vector's elements together, as
//!   its API shares one type), among the best formats of each narrower word for its range;
//! * the format of each `let`, pinned to a narrower word (it then rounds there).
//!
//! A narrower choice is kept when the plan still lowers (every intermediate is sized from
//! proved intervals, so no overflow is possible: a choice that would overflow is refused
//! by the lowering itself), every budget holds, every state and output without a budget is
//! at least as accurate as in the default plan, and the cost model's estimate
//! ([`super::cost`]: cycles, then size) falls. Passes repeat until one changes nothing; the
//! budgets that refused a narrower choice in that last pass are the ones that *bind*.
//!
//! Not searched: rule ports (`check` fixes their format), the operands of a
//! `recip_track` (its tolerance is sized from their format). Properties and invariants are not part of the search: `qloop
//! prove` proves them for the chosen formats as for any others.

use super::cost::{self, Cost};
use super::target::Target;
use super::Plan;
use crate::diag::{Diag, Result};
use crate::ir::{Program, SigId, SigKind};
use crate::qformat::{IntTy, QFormat, WIDTHS};

/// What the search chose, for the report.
#[derive(Clone, Debug)]
pub struct Tuning {
    /// Each choice that differs from the default plan's.
    pub choices: Vec<Choice>,
    /// Each budget, with the error the chosen plan bounds.
    pub budgets: Vec<BudgetUse>,
    /// States and outputs without a budget whose default accuracy refused a narrower
    /// choice in the last pass.
    pub kept: Vec<SigId>,
    /// The cost model's estimate of the default plan.
    pub default_cost: Cost,
    /// The estimate of the chosen plan.
    pub chosen_cost: Cost,
    /// Plans lowered by the search.
    pub plans: usize,
}

/// One narrowed format.
#[derive(Clone, Debug)]
pub struct Choice {
    /// The signals it applies to (a vector's elements, or one signal).
    pub ids: Vec<SigId>,
    /// The default plan's format (of the first element).
    pub default: QFormat,
    /// The chosen one.
    pub chosen: QFormat,
}

/// A budget and how the chosen plan meets it.
#[derive(Clone, Debug)]
pub struct BudgetUse {
    /// The budgeted signal.
    pub id: SigId,
    /// Its budget.
    pub budget: f64,
    /// Its one-step error bound in the default plan.
    pub default_err: f64,
    /// Its one-step error bound in the chosen plan.
    pub err: f64,
    /// It refused a narrower choice in the last pass that the cost model estimated cheaper.
    pub binds: bool,
}

/// One choice the search may narrow: a group of signals that take one format.
struct Knob {
    ids: Vec<SigId>,
    /// Storage (a state or output) rather than a `let`.
    storage: bool,
}

/// Why a candidate plan was refused.
enum Verdict {
    Keep,
    /// Budgets (the signals) or, for unbudgeted signals, their default accuracy.
    Over(Vec<SigId>),
    Dearer,
}

/// Lowers `prog` with formats searched against its `#[error]` budgets.
pub(super) fn tune(prog: &Program, target: &Target) -> Result<Plan> {
    let base = super::lower_formats(prog, target)?;
    for (i, s) in prog.signals.iter().enumerate() {
        let Some(b) = s.budget else { continue };
        let err = base.summary[i].err;
        if !within(err, b.err) {
            return Err(Diag::new(
                b.span,
                format!(
                    "the budget {} for `{}` is below what the default formats give, {}",
                    crate::text::g(b.err),
                    s.label(),
                    crate::text::g(err)
                ),
            )
            .label("cannot be met")
            .help(
                "`qloop check` lists each value's one-step error: raise the budget, or make \
                 the values that feed this signal more precise (a wider `word`, `#[lsb(..)]` \
                 or `#[q(..)]` on `let`s, more Newton steps)",
            ));
        }
    }
    let knobs = knobs(prog);
    let default_cost = cost::estimate(&base);
    let mut cur = prog.clone();
    let mut best = base.clone();
    let mut best_cost = default_cost;
    let mut plans = 1;
    let mut refused: Vec<SigId>;
    loop {
        refused = Vec::new();
        let mut changed = false;
        for k in &knobs {
            for q in candidates(&cur, &best, k) {
                let mut p = cur.clone();
                for id in &k.ids {
                    p.signals[id.0].pin = Some(q);
                }
                plans += 1;
                let Ok(plan) = super::lower_formats(&p, target) else {
                    continue;
                };
                let c = cost::estimate(&plan);
                match verdict(prog, &base, &plan, c, best_cost) {
                    Verdict::Keep => {
                        cur = p;
                        best = plan;
                        best_cost = c;
                        changed = true;
                        break;
                    }
                    Verdict::Over(ids) => {
                        for id in ids {
                            if !refused.contains(&id) {
                                refused.push(id);
                            }
                        }
                    }
                    Verdict::Dearer => {}
                }
            }
        }
        if !changed {
            break;
        }
    }
    let choices = knobs
        .iter()
        .filter_map(|k| {
            let (d, c) = (base.format(k.ids[0]), best.format(k.ids[0]));
            (d != c).then(|| Choice {
                ids: k.ids.clone(),
                default: d,
                chosen: c,
            })
        })
        .collect();
    let budgets = prog
        .signals
        .iter()
        .enumerate()
        .filter_map(|(i, s)| {
            s.budget.map(|b| BudgetUse {
                id: SigId(i),
                budget: b.err,
                default_err: base.summary[i].err,
                err: best.summary[i].err,
                binds: refused.contains(&SigId(i)),
            })
        })
        .collect();
    let kept = refused
        .into_iter()
        .filter(|id| prog.sig(*id).budget.is_none())
        .collect();
    // The chosen plan's program is the spec's with the chosen formats as pins: every
    // consumer (emitters, prover, interpreter) reads them from the plan as any other.
    let mut plan = best;
    plan.tuning = Some(Tuning {
        choices,
        budgets,
        kept,
        default_cost,
        chosen_cost: best_cost,
        plans,
    });
    Ok(plan)
}

/// `a ≤ b`, false where either is NaN (an unbounded error is never within a budget).
fn within(a: f64, b: f64) -> bool {
    a.partial_cmp(&b).is_some_and(|o| o.is_le())
}

/// Whether `plan` (estimated at `c`) may replace the best so far.
fn verdict(prog: &Program, base: &Plan, plan: &Plan, c: Cost, best: Cost) -> Verdict {
    let over: Vec<SigId> = prog
        .signals
        .iter()
        .enumerate()
        .filter(|(i, s)| {
            let err = plan.summary[*i].err;
            match (s.budget, s.kind) {
                (Some(b), _) => !within(err, b.err),
                (None, SigKind::State | SigKind::Output) => !within(err, base.summary[*i].err),
                _ => false,
            }
        })
        .map(|(i, _)| SigId(i))
        .collect();
    // The estimate first: a budget binds only where it refused a choice that was cheaper.
    if c >= best {
        Verdict::Dearer
    } else if !over.is_empty() {
        Verdict::Over(over)
    } else {
        Verdict::Keep
    }
}

/// The choices to search, in declaration order: budgeted states and outputs with a declared
/// range and no pin, then every `let` with neither a pin, a resolution, nor a claimed range.
/// A vector's elements are one choice.
fn knobs(prog: &Program) -> Vec<Knob> {
    let tracked: Vec<SigId> = prog.tracks.iter().flat_map(|t| [t.r, t.x]).collect();
    let mut out: Vec<Knob> = Vec::new();
    let push = |id: SigId, storage: bool, out: &mut Vec<Knob>| {
        let s = prog.sig(id);
        if let Some(e) = &s.elem {
            if let Some(k) = out.iter_mut().find(|k| {
                k.storage == storage
                    && prog
                        .sig(k.ids[0])
                        .elem
                        .as_ref()
                        .is_some_and(|f| f.group == e.group)
            }) {
                k.ids.push(id);
                return;
            }
        }
        out.push(Knob {
            ids: vec![id],
            storage,
        });
    };
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let free = s.pin.is_none() && !tracked.contains(&id);
        let storage = matches!(s.kind, SigKind::State | SigKind::Output);
        if storage && free && s.budget.is_some() && s.range.is_some() {
            push(id, true, &mut out);
        }
    }
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let free = s.pin.is_none() && !tracked.contains(&id);
        if s.kind == SigKind::Local && free && s.lsb.is_none() && s.claim.is_none() {
            push(id, false, &mut out);
        }
    }
    // A vector whose elements differ in what may be searched stays as it is.
    out.retain(|k| match &prog.sig(k.ids[0]).elem {
        Some(e) => {
            k.ids.len()
                == prog
                    .signals
                    .iter()
                    .filter(|s| s.elem.as_ref().is_some_and(|f| f.group == e.group))
                    .count()
        }
        None => true,
    });
    out
}

/// The cheaper formats to try for `k`, narrowest word first: for each signed (and, for a
/// non-negative storage range, unsigned) word, the format with the most fraction bits that
/// holds the range, and one or two bits fewer: a `let`'s rounded value may land one LSB
/// beyond its exact interval, and a state one bit coarser than its range needs may keep
/// the sums that update it inside the word (`theta + Δ` within 32 bits). A `let` tries only
/// narrower words than its own; a stored signal also its own word, with fewer bits.
fn candidates(prog: &Program, plan: &Plan, k: &Knob) -> Vec<QFormat> {
    let now = plan.format(k.ids[0]);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for id in &k.ids {
        let r = match prog.sig(*id).range {
            Some(r) if k.storage => r,
            _ => plan.summary[id.0].range,
        };
        lo = lo.min(r.0);
        hi = hi.max(r.1);
    }
    if !within(lo, hi) {
        return Vec::new();
    }
    let lsb = k
        .ids
        .iter()
        .filter_map(|id| prog.sig(*id).lsb)
        .fold(f64::INFINITY, f64::min);
    let widest = if k.storage {
        now.ty.bits
    } else {
        now.ty.bits - 1
    };
    let mut out = Vec::new();
    for &bits in WIDTHS.iter().filter(|&&b| b <= widest) {
        let mut tys = vec![IntTy::signed(bits)];
        if k.storage && lo >= 0.0 {
            tys.push(IntTy::unsigned(bits));
        }
        for ty in tys {
            let Some(best) = QFormat::best_for(ty, lo, hi) else {
                continue;
            };
            for drop in 0..3 {
                let q = QFormat {
                    frac: best.frac - drop,
                    ..best
                };
                // At least 2^4 steps across the range: a coarser format is no choice.
                let spans = q.raw_floor(hi) - q.raw_ceil(lo) >= 16;
                if q != now && spans && q.lsb() <= lsb && !out.contains(&q) {
                    out.push(q);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    /// A gain estimate and a command from the estimate the step starts with, on the default
    /// target (32-bit words, no multiplier): `BUDGET` is replaced by the test's attributes on
    /// the estimate.
    const SPEC: &str = "controller b {
    period 0.01 \"s\";
    input e: [-1.0, 1.0];
    BUDGET
    state k: [0.0, 4.0] = 1.0;
    output u: [-4.0, 4.0];
    step {
        u = k * e;
        let g = k * e;
        k = k + 0.01 * g;
    }
}";

    fn plan(budget: &str) -> crate::diag::Result<crate::lower::Plan> {
        crate::compile_str(&SPEC.replace("BUDGET", budget), &Default::default())
    }

    #[test]
    fn a_loose_budget_narrows_what_feeds_the_estimate_and_holds() {
        let base = plan("").unwrap();
        let p = plan("#[error(1e-2)]").unwrap();
        let (k, g) = (crate::ir::SigId(1), crate::ir::SigId(3));
        assert_eq!(p.prog.sig(g).name, "g");
        // The update's product `k·e` needs 64 bits exactly; rounded to a narrower word it
        // is within the budget of `k`.
        assert!(
            p.format(g).ty.bits < base.format(g).ty.bits,
            "{}",
            p.format(g)
        );
        assert!(p.summary[k.0].err <= 1e-2);
        // `u` has no budget: never less accurate than without the search.
        let u = crate::ir::SigId(2);
        assert!(p.summary[u.0].err <= base.summary[u.0].err);
        let t = p.tuning.as_ref().unwrap();
        assert!(t.chosen_cost < t.default_cost, "{t:?}");
    }

    #[test]
    fn a_budget_at_the_default_error_keeps_the_default_format() {
        let base = plan("").unwrap();
        let k = crate::ir::SigId(1);
        let at = base.summary[k.0].err;
        // Written out exactly (a budget is read as the f64 at or below its decimal).
        let p = plan(&format!("#[error({at:.120e})]")).unwrap();
        // Any coarser format of `k` rounds it more: its own store error grows.
        assert_eq!(p.format(k), base.format(k));
        let t = p.tuning.as_ref().unwrap();
        assert!(t.budgets[0].binds, "{t:?}");
    }

    #[test]
    fn a_budget_below_the_default_error_is_refused_at_the_attribute() {
        let e = plan("#[error(1e-30)]").expect_err("refused");
        assert!(
            e.message.contains("below what the default formats give"),
            "{}",
            e.message
        );
        assert_eq!(e.line_col(), (4, 5));
    }
}
