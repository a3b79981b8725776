//! Exact-term queries: the step's values as exact (non-wrapping) terms over the pre-state,
//! inputs and free parameters, written in one of several encodings ([`ExactEncoding`]):
//! integers or bit-vectors, products exact or over-approximated. The invariant and property
//! obligations try each question in several of them (a portfolio).

use super::step::Step;
use super::ParamGrid;
use crate::ir::{PCond, SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use crate::prove::exact::{self, PropTerms, B, T};
use crate::prove::smt::signed_bits;
use crate::prove::solver::Query;
use qloop_core::terms::{add, param_shift, param_state_pairs, shl};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::rc::Rc;

/// How an exact-term query is written: its sort and its treatment of products. The prover
/// tries a property or invariant in several of these (a portfolio); the label names the one
/// that proved it. (The bit-precise step itself is a [`crate::prove::smt::StepEncoding`].)
#[derive(Clone, Copy, Debug)]
pub struct ExactEncoding {
    /// Bit-vectors or integers.
    pub sort: exact::Sort,
    /// Exact or over-approximated products.
    pub products: exact::Products,
    /// Which values are cut points (free in their intervals) rather than their definitions.
    pub cuts: Cuts,
    /// An invariant after the step written case by case over its states' update guards
    /// ([`qloop_core::terms::case_split`]); encodings with it are tried only for invariants
    /// whose states have between one and `MAX_GUARDS` guards.
    pub split: bool,
    /// Name in reports (`property P [label]`).
    pub label: &'static str,
}

/// Which values of the step a query replaces by cut points: variables ranging over the
/// value's proved interval ([`qloop_core::terms::terms_cut`] for exact terms,
/// [`super::step::Step::cut_query`] bit for bit). Sound because every interval is an overflow
/// obligation of its own; a counterexample may be spurious and is replayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cuts {
    /// No cut: every value is its definition.
    None,
    /// The values of the spec's `let`s: a property that relates a few named intermediate
    /// results (the clamped covariance entries and the determinant test on them) is proved
    /// over those names, whatever computed them.
    Lets,
    /// Every product of two variables: what saturation, clamps and branches decide (a state
    /// stays in its range, a branch not taken holds the state) needs no multiplier.
    Products,
    /// Every product and every test (a Boolean value: a comparison, a conjunction): a state
    /// that every branch stores inside its range stays inside it whatever the tests decide,
    /// so the query need not hold the tests (the covariance update of `tests/rls5.qloop`:
    /// five leading minors, 73 products of five entries in the largest, decide which branch
    /// runs, and cvc5 took 18 s per entry of P with them, products cut). Bit-precise
    /// queries only ([`super::step::Step::cut_query`]).
    Tests,
    /// Everything but additions, subtractions, negations, shifts, casts and constants: a
    /// shift-add network (a constant factor as `x·2^a ± x·2^b ± ..`) is decided over the
    /// interval of its operand `x`, whatever computed `x` (the reference feed of
    /// `milling_multimodel.qloop`, 0.3 times a law coefficient that seven branches select,
    /// took z3 40 s per partial sum with the products cut). Bit-precise queries only.
    NonLinear,
    /// The values the step stores into one signal: a reciprocal tracker that reads an
    /// estimate the step has just updated (`recip_track(r, theta, G)` after `theta += ..`)
    /// contracts for every `theta` in its range, whatever computed it, so its property is
    /// proved over that range instead of through the estimator's products (cvc5 timed out on
    /// every encoding of the whole step). Only the trackers' properties use it.
    Stores(SigId),
}

impl Cuts {
    /// Whether value `id` of `plan` is a cut point.
    pub fn selects(self, plan: &Plan, id: ValId) -> bool {
        let v = plan.val(id);
        match self {
            Cuts::None => false,
            Cuts::Lets => v.name.is_some() && !matches!(v.op, Op::Input(_)),
            Cuts::Products => matches!(v.op, Op::Mul(..) | Op::MulHi(..)),
            Cuts::Tests => matches!(v.op, Op::Mul(..) | Op::MulHi(..)) || v.boolean,
            Cuts::NonLinear => !matches!(
                v.op,
                Op::Add(..) | Op::Sub(..) | Op::Neg(_) | Op::Shl(..) | Op::Shr(..) | Op::Cast(_)
            ),
            Cuts::Stores(sig) => stores(&plan.body, &|s, v| s == sig && v == id),
        }
    }
}

/// Whether `stmts` store some value `v` into some signal `s` with `hit(s, v)`.
pub(super) fn stores(stmts: &[LStmt], hit: &dyn Fn(SigId, ValId) -> bool) -> bool {
    stmts.iter().any(|s| match s {
        LStmt::Store(s, v) => hit(*s, *v),
        LStmt::If(_, a, b) => stores(a, hit) || stores(b, hit),
        LStmt::Def(_) => false,
    })
}

/// Linear integer arithmetic, products replaced by their linear envelopes: decided in
/// milliseconds by both solvers when the envelope is tight enough for the property.
pub const LINEAR: ExactEncoding = ExactEncoding {
    sort: exact::Sort::Int,
    products: exact::Products::Relaxed,
    cuts: Cuts::None,
    split: false,
    label: "linear envelope",
};
/// Non-linear integer arithmetic, exact (cvc5's incremental linearisation is fast on it).
pub const INTEGER: ExactEncoding = ExactEncoding {
    sort: exact::Sort::Int,
    products: exact::Products::Exact,
    cuts: Cuts::None,
    split: false,
    label: "exact integers",
};
/// Exact terms as bit-vectors at the narrowest widths.
pub const EXACT_BV: ExactEncoding = ExactEncoding {
    sort: exact::Sort::BitVec,
    products: exact::Products::Exact,
    cuts: Cuts::None,
    split: false,
    label: "exact terms",
};
/// Bit-vectors, products outside the free parameters bounded by their intervals.
pub const ABSTRACT_BV: ExactEncoding = ExactEncoding {
    sort: exact::Sort::BitVec,
    products: exact::Products::Interval,
    cuts: Cuts::None,
    split: false,
    label: "abstracted products",
};
/// [`LINEAR`] over the `let`s as cut points ([`Cuts::Lets`]).
pub const LINEAR_LETS: ExactEncoding = ExactEncoding {
    cuts: Cuts::Lets,
    label: "linear envelope, cut at lets",
    ..LINEAR
};
/// [`INTEGER`] over the `let`s as cut points ([`Cuts::Lets`]).
pub const INTEGER_LETS: ExactEncoding = ExactEncoding {
    cuts: Cuts::Lets,
    label: "exact integers, cut at lets",
    ..INTEGER
};
/// [`LINEAR_LETS`] case by case over the update guards (`split`): a law stored only when
/// its run-time check of the invariant passes (`verified/specs/milling_multimodel.qloop`'s
/// `law_places_the_poles`: each coefficient's test and the invariant read alike once the
/// guards are fixed) is proved without distributing products over `ite`s, in which form z3
/// and cvc5 timed out at 60 s in every other encoding.
pub const LINEAR_LETS_SPLIT: ExactEncoding = ExactEncoding {
    split: true,
    label: "linear envelope, cut at lets, split on updates",
    ..LINEAR_LETS
};
/// The most update guards an invariant is split on (2^n cases).
pub const MAX_GUARDS: usize = 3;

/// Which question an exact query asks.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Side {
    /// The initial state (states fixed to their initial values, goal over pre-state).
    Initial,
    /// One step from any state in the invariants and any input bits (goal over post-state).
    Step,
    /// One step from any state in the invariants and inputs in range (goal over both).
    Property,
}

/// A query over exact terms: premises (state ranges, invariants, input ranges for
/// properties, parameter ranges, `assumes`) ⇒ `goal`.
pub(super) fn exact_query(
    step: &Step,
    side: Side,
    assumes: &[PCond],
    goal_conds: &[PCond],
    goal: &dyn Fn(&PropTerms) -> Option<Rc<B>>,
    grids: &[ParamGrid],
    how: ExactEncoding,
) -> Option<Query> {
    let plan = step.plan;
    let prog = &plan.prog;
    let ranges = |id: SigId| -> (i128, i128) {
        let q = plan.format(id);
        let s = prog.sig(id);
        match (s.kind, side) {
            (SigKind::State, Side::Initial) => (plan.raw_init(id), plan.raw_init(id)),
            (SigKind::State, _) | (SigKind::Input, Side::Property) => plan.bounds(id),
            _ => (q.ty.min(), q.ty.max()),
        }
    };
    // The plan's terms depend on the side (the ranges) and the cuts only: built once each.
    let terms = step
        .terms
        .borrow_mut()
        .entry((side, how.cuts))
        .or_insert_with(|| {
            Rc::new(exact::terms_cut(plan, &ranges, &|id| {
                how.cuts.selects(plan, id)
            }))
        })
        .clone();
    // Over-approximations (products as fresh variables bounded by their interval, or by
    // their linear envelope) are sound: more behaviours, not fewer; a counterexample they
    // find may be spurious, and the replay says so.
    let mut em = exact::Emitter::new(how.sort, how.products);
    em.keep = grids
        .iter()
        .flat_map(|g| [g.var.clone(), format!("d_{}", g.var)])
        .collect();
    // A free parameter p compared with a state s (`p - s` in the property) is rewritten as
    // p = s + D with a fresh D: a change of variables (exact, both ways), after which the
    // linear normal form cancels s and shares s's products with the step's own terms.
    let subst = match side {
        Side::Property => param_state_pairs(plan, assumes, goal_conds),
        _ => BTreeMap::new(),
    };
    let (params_t, mut premises) = param_terms(plan, grids, &subst, &ranges, &terms, &mut em);
    let pre_env = PropTerms {
        plan,
        terms: &terms,
        params: params_t.clone(),
        pre_as_post: false,
        distribute: !how.split,
    };
    let post_env = PropTerms {
        plan,
        terms: &terms,
        params: params_t.clone(),
        pre_as_post: true,
        distribute: !how.split,
    };
    let mut g = match side {
        Side::Step => goal(&post_env)?,
        _ => goal(&pre_env)?,
    };
    if how.split {
        // The guards of the goal's states' updates (the states of `goal_conds`).
        let mut sigs = BTreeSet::new();
        for c in goal_conds {
            c.post_signals(&mut sigs, side == Side::Step);
        }
        let mut guards = Vec::new();
        for s in &sigs {
            if let (Some(t), Some(pre)) = (terms.post.get(s), terms.pre.get(s)) {
                exact::update_guards(t, pre, &mut guards);
            }
        }
        g = exact::case_split(&g, &guards, MAX_GUARDS)?;
    }
    let invariants: Vec<Rc<B>> = if side != Side::Initial {
        prog.invariants
            .iter()
            .map(|inv| pre_env.cond(&inv.cond))
            .collect::<Option<_>>()?
    } else {
        Vec::new()
    };
    let assumed: Vec<Rc<B>> = assumes
        .iter()
        .map(|a| pre_env.cond(a))
        .collect::<Option<_>>()?;
    // Only what bears on the goal (as `step::script` does for bit-precise queries): the
    // invariants that share a variable with the goal, the assumptions or an invariant kept
    // so far, to a fixed point, and the ranges of the variables kept. What is left out
    // constrains other variables only and holds of the initial state, so no verdict changes.
    let mut relevant: BTreeSet<String> = exact::var_names(&g);
    for a in &assumed {
        relevant.extend(exact::var_names(a));
    }
    for (t, _) in &params_t {
        relevant.extend(exact::vars_of(t).iter().filter_map(|v| match &**v {
            T::Var(n, ..) => Some(n.clone()),
            _ => None,
        }));
    }
    let inv_vars: Vec<BTreeSet<String>> = invariants.iter().map(exact::var_names).collect();
    let mut kept = vec![false; invariants.len()];
    loop {
        let mut grew = false;
        for (k, vs) in inv_vars.iter().enumerate() {
            if !kept[k] && (vs.is_empty() || !vs.is_disjoint(&relevant)) {
                kept[k] = true;
                relevant.extend(vs.iter().cloned());
                grew = true;
            }
        }
        if !grew {
            break;
        }
    }
    // Every variable kept inside its assumed range.
    let mut vars: Vec<Rc<T>> = terms.pre.values().cloned().collect();
    vars.extend(terms.cuts.iter().cloned());
    vars.extend(params_t.iter().map(|(t, _)| t.clone()));
    vars.extend(
        grids
            .iter()
            .map(|g| Rc::new(T::Var(g.var.clone(), g.width, true, g.lo, g.hi))),
    );
    let vars: Vec<Rc<T>> = vars.iter().flat_map(exact::vars_of).collect();
    for v in &vars {
        if let T::Var(name, _, _, lo, hi) = &**v {
            if relevant.contains(name) || em.keep.contains(name) {
                premises.push(em.in_range(v, *lo, *hi));
            }
        }
    }
    for (inv, _) in invariants.iter().zip(&kept).filter(|(_, k)| **k) {
        premises.push(em.boolean(inv));
    }
    for a in &assumed {
        premises.push(em.boolean(a));
    }
    let goal = em.boolean(&g);
    // Widths sized from intervals that did not fit an i128 could wrap: no such encoding.
    if em.overflowed() {
        return None;
    }
    Some(finish(em, premises, &goal))
}

/// The terms of the free parameters (in `grids` order, with their binary points), and the
/// premises tying each parameter `p` in `subst` to its state: `p = s·2^shift + D`.
fn param_terms(
    plan: &Plan,
    grids: &[ParamGrid],
    subst: &BTreeMap<usize, SigId>,
    ranges: &dyn Fn(SigId) -> (i128, i128),
    terms: &exact::Terms,
    em: &mut exact::Emitter,
) -> (Vec<(Rc<T>, i32)>, Vec<String>) {
    let mut premises = Vec::new();
    let mut params_t: Vec<(Rc<T>, i32)> = Vec::new();
    for (i, g) in grids.iter().enumerate() {
        let pv = Rc::new(T::Var(g.var.clone(), g.width, true, g.lo, g.hi));
        let shifted = subst
            .get(&i)
            .and_then(|&s| Some((s, param_shift(plan, g, s, ranges(s))?)));
        match shifted {
            Some((s, (shift, dlo, dhi))) => {
                let d = Rc::new(T::Var(
                    format!("d_{}", g.var),
                    signed_bits(dlo, dhi),
                    true,
                    dlo,
                    dhi,
                ));
                let t = add(shl(terms.pre[&s].clone(), shift), d);
                // Keep p in the model (for replay): p = s·2^shift + D, inside p's grid range.
                premises.push(em.equal(&pv, &t));
                params_t.push((t, g.frac));
            }
            _ => params_t.push((pv, g.frac)),
        }
    }
    (params_t, premises)
}

/// The script of an exact-term query: the emitter's logic, declarations and definitions,
/// `premises` then the emitter's own premises asserted, `goal` negated; the model asked for
/// is every declared variable.
pub(super) fn finish(mut em: exact::Emitter, mut premises: Vec<String>, goal: &str) -> Query {
    premises.append(&mut em.premises);
    let mut text = format!("(set-logic {})\n", em.logic());
    text.push_str(&em.declarations());
    text.push_str(&em.text);
    for p in &premises {
        let _ = writeln!(text, "(assert {p})");
    }
    let _ = writeln!(text, "(assert (not {goal}))");
    let want = em
        .declarations()
        .lines()
        .filter_map(|l| l.split_whitespace().nth(1).map(String::from))
        .collect();
    Query { script: text, want }
}

/// Invariant `k` of the program as an exact-term question: initially ([`Side::Initial`]) or
/// after one step ([`Side::Step`]), written as `how` says.
pub(super) fn invariant_query(
    step: &Step,
    side: Side,
    k: usize,
    how: ExactEncoding,
) -> Option<Query> {
    let inv = &step.plan.prog.invariants[k];
    let conds = [inv.cond.clone()];
    exact_query(step, side, &[], &conds, &|pt| pt.cond(&inv.cond), &[], how)
}
