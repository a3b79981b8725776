//! Initial obligations: the initial state lies inside the state ranges and satisfies the
//! invariants. With the inductive obligations they prove the ranges and invariants for every
//! reachable state.

use super::exact_query::{invariant_query, Side, EXACT_BV};
use super::step::{query_of, state_bound, Step};
use super::{Goal, Kind, Obligation};
use crate::ir::{SigId, SigKind};
use crate::lower::Plan;
use crate::prove::smt::{self, lit};
use crate::prove::solver::Query;
use std::fmt::Write;

/// State `id` starts inside its range.
pub(super) fn state_range(plan: &Plan, id: SigId) -> Obligation {
    let prog = &plan.prog;
    let s = prog.sig(id);
    Obligation {
        name: format!("initial {} inside its range", s.name),
        kind: Kind::Initial,
        query: initial_query(plan, &state_bound(plan, id, &smt::pre_var(prog, id))),
        goal: Goal::StateBound(id),
        line: s.span.start().line,
        encoding: None,
    }
}

/// Invariant `k` holds in the initial state (exact terms, as bit-vectors); `None` when the
/// invariant cannot be encoded.
pub(super) fn invariant(step: &Step, k: usize) -> Option<Obligation> {
    let inv = &step.plan.prog.invariants[k];
    Some(Obligation {
        name: format!("invariant {} holds initially", inv.name),
        kind: Kind::Initial,
        query: invariant_query(step, Side::Initial, k, EXACT_BV)?,
        goal: Goal::Invariant(k),
        line: inv.span.start().line,
        encoding: None,
    })
}

/// An initial-state query: pre-state variables fixed to the initial values.
fn initial_query(plan: &Plan, goal: &str) -> Query {
    let prog = &plan.prog;
    let mut decls = String::new();
    let mut premises = Vec::new();
    let mut want = Vec::new();
    for id in prog.ids_of(SigKind::State) {
        let v = smt::pre_var(prog, id);
        let w = plan.format(id).ty.bits;
        let _ = writeln!(decls, "(declare-fun {v} () (_ BitVec {w}))");
        premises.push(format!("(= {v} {})", lit(plan.raw_init(id), w)));
        want.push(v);
    }
    query_of(&decls, &premises, goal, &want)
}
