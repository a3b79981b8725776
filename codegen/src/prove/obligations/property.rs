//! Property obligations: each step property, for all inputs in range, states in the ranges
//! and invariants, and free parameters in range meeting its `assume`s.
//!
//! Each property is tried in a portfolio of encodings, cheapest first: the exact-term ones
//! ([`super::ExactEncoding`]) and the bit-precise one; `prove` merges them (any sound proof
//! counts). A separate witness query per property checks that its premises can be met at
//! all, since a property with unsatisfiable premises holds vacuously.

use super::exact_query::{
    exact_query, stores, Cuts, Side, ABSTRACT_BV, EXACT_BV, INTEGER, INTEGER_LETS, LINEAR,
    LINEAR_LETS,
};
use super::step::{deferred_query, Step, BIT_PRECISE, PRODUCTS_CUT};
use super::{param_grids, ExactEncoding, Goal, Kind, Obligation};
use crate::prove::exact::{PropTerms, B};
use crate::prove::smt::{in_range, PropEnv};
use crate::prove::solver::Query;
use std::collections::BTreeSet;
use std::fmt::Write;
use std::rc::Rc;

/// The portfolio of property `k`, one obligation per encoding it can be written in.
pub(super) fn portfolio(step: &Step, k: usize) -> Vec<Obligation> {
    let plan = step.plan;
    let p = &plan.prog.properties[k];
    let grids = param_grids(plan, k);
    let goal = |pt: &PropTerms| -> Option<Rc<B>> {
        let parts: Option<Vec<Rc<B>>> = p.ensures.iter().map(|c| pt.cond(c)).collect();
        parts?.into_iter().reduce(|x, y| Rc::new(B::And(x, y)))
    };
    let exact = |how: ExactEncoding| {
        let query = exact_query(
            step,
            Side::Property,
            &p.assumes,
            &p.ensures,
            &goal,
            &grids,
            how,
        );
        (query, how.label)
    };
    let line = p.span.start().line;
    // A tracker of a value the step assigns first: cut where that value is stored.
    let tracked = plan
        .prog
        .tracks
        .iter()
        .find(|t| p.name == t.property)
        .filter(|t| stores(&plan.body, &|s, _| s == t.x))
        .map(|t| Cuts::Stores(t.x));
    let at_tracked = tracked.into_iter().flat_map(|cuts| {
        [
            exact(ExactEncoding {
                cuts,
                label: "linear envelope, cut at the tracked value",
                ..LINEAR
            }),
            exact(ExactEncoding {
                cuts,
                label: "exact integers, cut at the tracked value",
                ..INTEGER
            }),
            (
                direct_query(step, k, false, cuts),
                "bit-precise, cut at the tracked value",
            ),
        ]
    });
    // Cheapest first: each solver stops at its first proof.
    at_tracked
        .chain([
            exact(LINEAR),
            exact(LINEAR_LETS),
            exact(INTEGER),
            exact(INTEGER_LETS),
            (direct_query(step, k, false, Cuts::Products), PRODUCTS_CUT),
            exact(EXACT_BV),
            exact(ABSTRACT_BV),
            (
                if step.defer_whole {
                    Some(deferred_query())
                } else {
                    direct_query(step, k, false, Cuts::None)
                },
                BIT_PRECISE,
            ),
        ])
        .filter_map(|(query, how)| {
            Some(Obligation {
                name: format!("property {}", p.name),
                kind: Kind::Property,
                query: query?,
                goal: Goal::Property(k),
                line,
                encoding: Some(how),
            })
        })
        .collect()
}

/// A bit-precise query whose models are states, inputs and parameters meeting the premises
/// of property `k` (state ranges, invariants, input ranges, `assume`s): `unsat` means the
/// property holds vacuously.
pub(super) fn witness(step: &Step, k: usize) -> Option<Query> {
    direct_query(step, k, true, Cuts::None)
}

/// The bit-precise (SSA) encoding of property `k`, with lemmas for its cone of influence
/// (with `cuts`, for what the goal reaches through the definitions not cut); as a
/// `witness`, with the goal `false`.
pub(super) fn direct_query(step: &Step, k: usize, witness: bool, cuts: Cuts) -> Option<Query> {
    let plan = step.plan;
    let p = &plan.prog.properties[k];
    let grids = &param_grids(plan, k);
    let params: Vec<(String, u32, i32)> = grids
        .iter()
        .map(|g| (g.var.clone(), g.width, g.frac))
        .collect();
    let env = PropEnv {
        plan,
        post: &step.enc.post,
        params: &params,
        pre_as_post: false,
    };
    let mut premises: Vec<String> = p
        .assumes
        .iter()
        .map(|c| env.cond(c))
        .collect::<Option<_>>()?;
    let ensures: Vec<String> = p
        .ensures
        .iter()
        .map(|c| env.cond(c))
        .collect::<Option<_>>()?;
    for g in grids {
        premises.push(in_range(&g.var, g.width, g.lo, g.hi));
    }
    let mut sigs = BTreeSet::new();
    for c in p.assumes.iter().chain(&p.ensures) {
        c.post_signals(&mut sigs, false);
    }
    // A witness needs no lemmas: each holds in every state the premises allow (it is proved
    // from the state ranges and invariants alone), so it cannot change whether the premises
    // are satisfiable, and its wide products only slow the search for a model.
    let needed = if witness {
        BTreeSet::new()
    } else {
        step.cone.post_of(&sigs)
    };
    let mut want = step.want.clone();
    want.extend(grids.iter().map(|g| g.var.clone()));
    let mut decls = String::new();
    for g in grids {
        let _ = writeln!(decls, "(declare-fun {} () (_ BitVec {}))", g.var, g.width);
    }
    // A witness query asks only for a pre-state, input and parameters meeting the premises.
    let goal = if witness {
        "false".to_string()
    } else {
        conj(&ensures)
    };
    let mut q = match cuts {
        Cuts::None => step.query(&needed, &premises, &goal, &want, true),
        _ => step.cut_query(cuts, None, &premises, &goal, &want, true),
    };
    q.script = q.script.replacen(
        "(set-logic QF_BV)\n",
        &format!("(set-logic QF_BV)\n{decls}"),
        1,
    );
    Some(q)
}

/// The conjunction of SMT-LIB terms (`true` when there are none).
fn conj(terms: &[String]) -> String {
    match terms {
        [] => "true".into(),
        [t] => t.clone(),
        _ => format!("(and {})", terms.join(" ")),
    }
}
