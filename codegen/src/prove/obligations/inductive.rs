//! Inductive obligations: one step from any state inside the ranges and invariants, with any
//! input bits, lands inside them again. With the initial obligations this proves the ranges
//! and invariants for every reachable state, for unbounded time.

use super::exact_query::{
    invariant_query, Cuts, Side, EXACT_BV, INTEGER, INTEGER_LETS, LINEAR, LINEAR_LETS,
    LINEAR_LETS_SPLIT,
};
use super::step::{state_bound, Step, TESTS_CUT};
use super::{Goal, Kind, Obligation};
use crate::ir::SigId;
use crate::lower::lir::ValId;
use crate::prove::smt::PropEnv;
use crate::prove::solver::Query;
use std::collections::BTreeSet;

/// State `id` stays inside its range after one step: bit-precise, first with the products and
/// the tests cut (every branch stores a value in range), then with the products cut
/// (saturation on the store, a clamp or a branch that holds the state decide most ranges
/// without a multiplier), then whole.
pub(super) fn state_range(step: &Step, id: SigId) -> Vec<Obligation> {
    let plan = step.plan;
    let s = plan.prog.sig(id);
    let (goal, needed) = state_range_goal(step, id);
    // Cheapest first: with the tests cut too, a state that each branch keeps in range is
    // proved without the tests that choose the branch.
    let tests_cut = (
        step.cut_query(Cuts::Tests, None, &[], &goal, &step.want, false),
        TESTS_CUT,
    );
    std::iter::once(tests_cut)
        .chain(step.cut_then_whole(&needed, &goal))
        .map(|(query, how)| Obligation {
            name: format!("{} stays inside its range", s.name),
            kind: Kind::Inductive,
            query,
            goal: Goal::StateBound(id),
            line: s.span.start().line,
            encoding: Some(how),
        })
        .collect()
}

/// The bit-precise goal of state `id`'s range after the step, and the values it needs.
fn state_range_goal(step: &Step, id: SigId) -> (String, BTreeSet<ValId>) {
    let goal = state_bound(step.plan, id, &step.enc.post[&id]);
    (goal, step.cone.post_of(&BTreeSet::from([id])))
}

/// The whole-step query of state `id`'s range after the step ([`super::step::BIT_PRECISE`]).
pub(super) fn state_range_whole(step: &Step, id: SigId) -> Query {
    let (goal, needed) = state_range_goal(step, id);
    step.query(&needed, &[], &goal, &step.want, false)
}

/// The bit-precise goal of invariant `k` after the step, and the values it needs.
fn invariant_goal(step: &Step, k: usize) -> Option<(String, BTreeSet<ValId>)> {
    let plan = step.plan;
    let inv = &plan.prog.invariants[k];
    let post_env = PropEnv::invariants(plan, &step.enc.post, true);
    let goal = post_env.cond(&inv.cond)?;
    let mut sigs = BTreeSet::new();
    inv.cond.post_signals(&mut sigs, true);
    Some((goal, step.cone.post_of(&sigs)))
}

/// The whole-step query of invariant `k` after the step ([`super::step::BIT_PRECISE`]).
pub(super) fn invariant_whole(step: &Step, k: usize) -> Option<Query> {
    let (goal, needed) = invariant_goal(step, k)?;
    Some(step.query(&needed, &[], &goal, &step.want, false))
}

/// Invariant `k` holds after one step: a portfolio of exact-term encodings, cheapest first,
/// then the bit-precise one (products of post-states distribute badly in exact terms).
/// Encodings the invariant cannot be written in are left out, and so is the split one
/// ([`LINEAR_LETS_SPLIT`]) for an invariant whose states have no update guard or too many.
pub(super) fn invariant(step: &Step, k: usize) -> Vec<Obligation> {
    let plan = step.plan;
    let inv = &plan.prog.invariants[k];
    let line = inv.span.start().line;
    let name = format!("invariant {} is inductive", inv.name);
    let mut out = Vec::new();
    for how in [
        LINEAR,
        LINEAR_LETS,
        LINEAR_LETS_SPLIT,
        INTEGER,
        INTEGER_LETS,
        EXACT_BV,
    ] {
        if let Some(query) = invariant_query(step, Side::Step, k, how) {
            out.push(Obligation {
                name: name.clone(),
                kind: Kind::Inductive,
                query,
                goal: Goal::Invariant(k),
                line,
                encoding: Some(how.label),
            });
        }
    }
    if let Some((goal, needed)) = invariant_goal(step, k) {
        for (query, how) in step.cut_then_whole(&needed, &goal) {
            out.push(Obligation {
                name: name.clone(),
                kind: Kind::Inductive,
                query,
                goal: Goal::Invariant(k),
                line,
                encoding: Some(how),
            });
        }
    }
    out
}
