//! Overflow obligations: every plan value stays inside the interval the range analysis
//! assigned to it, which lies inside its machine type.
//!
//! For a value the analysis *derived*, the obligation is local: its operands, declared at the
//! narrowest widths that hold their own intervals, produce an exact result inside its
//! interval. By induction over the straight-line plan (each operand's interval is its own
//! obligation) this proves that no value of the step ever leaves its width. Values whose
//! interval is a user *claim* (`#[range]`, `#[unsaturated]`), loads, and values whose interval
//! is tighter than interval arithmetic on their operands gives get a whole-program query.

use super::exact_query::Cuts;
use super::step::{
    deferred_query, query_of, Step, BIT_PRECISE, LINEAR_CONE, PRODUCTS_CUT, TESTS_CUT,
};
use super::{Goal, Kind, Obligation, LINEAR};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;
use crate::prove::smt::{self, in_range, resize, signed_bits, vname};
use crate::prove::solver::Query;
use std::fmt::Write;

/// One overflow obligation per value that is neither boolean nor an input, in plan order.
pub(super) fn obligations(step: &Step) -> Vec<Obligation> {
    let plan = step.plan;
    let mut out = Vec::new();
    for (i, v) in plan.vals.iter().enumerate() {
        let id = ValId(i);
        if v.boolean || matches!(v.op, Op::Input(_)) {
            continue;
        }
        let label = v.name.clone().unwrap_or_else(|| format!("_{i}"));
        let claimed = if v.claimed { ", claimed" } else { "" };
        let name = format!(
            "{label} ({}{claimed}) in [{}, {}] ⊆ {}",
            op_name(&v.op),
            v.lo,
            v.hi,
            v.ty
        );
        let global = v.claimed || matches!(v.op, Op::Load(_)) || !interval_closed(plan, id);
        let goal = Goal::Val {
            val: id,
            local: !global,
        };
        // The question in one or more encodings, cheapest first.
        let encodings: Vec<(Query, &'static str)> = if global {
            // A load of the pre-state has a one-premise query; anything else is tried with
            // the products cut first (a clamp or a saturated store bounds most values
            // without the multipliers behind them), then whole.
            // A shift-add network is tried first over its linear cone alone.
            let cuts: Vec<(Cuts, &'static str)> = if pre_state_load(step, id).is_some() {
                Vec::new()
            } else if matches!(v.op, Op::Add(..) | Op::Sub(..) | Op::Neg(_)) {
                vec![
                    (Cuts::NonLinear, LINEAR_CONE),
                    (Cuts::Products, PRODUCTS_CUT),
                ]
            } else if matches!(v.op, Op::Load(_)) {
                // A state read after its update: every branch stores it inside its range (a
                // clamp, a saturated store, the value held), whatever the tests decide (the
                // multi-model controller's active law, one of seven laws each kept or
                // replaced: 2-7 s each with the products cut, the tests held).
                vec![(Cuts::Tests, TESTS_CUT), (Cuts::Products, PRODUCTS_CUT)]
            } else {
                vec![(Cuts::Products, PRODUCTS_CUT)]
            };
            let goal = global_goal(step, id);
            // The whole query is the fallback of the cut ones: deferred with them.
            let whole = if step.defer_whole && !cuts.is_empty() {
                deferred_query()
            } else {
                global_val_query(step, id)
            };
            cuts.into_iter()
                .map(|(c, how)| {
                    (
                        step.cut_query(c, Some(id), &[], &goal, &step.want, false),
                        how,
                    )
                })
                .chain([(whole, BIT_PRECISE)])
                .collect()
        } else {
            // A product's range, tried first in linear integer arithmetic (its McCormick
            // envelope decides it in milliseconds), then bit for bit: z3 4.8 takes 10-60 s on
            // one range query of a 32 x 32 -> 64-bit multiplier, and as long on it in
            // non-linear integers.
            product_envelope_query(plan, id)
                .map(|q| (q, LINEAR.label))
                .into_iter()
                .chain([(local_val_query(plan, id), BIT_VECTOR)])
                .collect()
        };
        let several = encodings.len() > 1;
        for (query, how) in encodings {
            out.push(Obligation {
                name: name.clone(),
                kind: Kind::Overflow,
                query,
                goal: goal.clone(),
                line: v.line,
                encoding: several.then_some(how),
            });
        }
    }
    out
}

/// The label of the bit-vector encoding of a local overflow query, where a product is also
/// tried in its linear envelope.
pub const BIT_VECTOR: &str = "bit-vector";

/// The local overflow query of a product `a·b` in linear integer arithmetic: the factors are
/// integers in their intervals and the product a fresh integer bounded by its McCormick
/// envelope over them (`(a − aₗ)(b − bₗ) ≥ 0` and the three others, facts of exact
/// multiplication). The envelope's extremes over the box are the corner products, so it
/// proves exactly the interval that interval multiplication gives. No wrapping to model: the
/// machine product of the widened factors equals the integer product whenever that lies in
/// the value's interval, which is inside its type.
fn product_envelope_query(plan: &Plan, id: ValId) -> Option<Query> {
    use crate::prove::exact::{Emitter, Products, Sort, T};
    use std::rc::Rc;
    let v = plan.val(id);
    let (a, b, high) = match v.op {
        Op::Mul(a, b) => (a, b, false),
        Op::MulHi(a, b) => (a, b, true),
        _ => return None,
    };
    let mut em = Emitter::new(Sort::Int, Products::Relaxed);
    let var = |j: ValId| {
        let o = plan.val(j);
        Rc::new(T::Var(
            format!("o{}", j.0),
            signed_bits(o.lo, o.hi),
            true,
            o.lo,
            o.hi,
        ))
    };
    let (x, y) = (var(a), var(b));
    let mut premises = Vec::new();
    for f in [&x, &y] {
        if let T::Var(_, _, _, lo, hi) = &**f {
            premises.push(em.in_range(f, *lo, *hi));
        }
    }
    let goal = if high {
        // `mul_hi(a, b)` lies in `[F − 2, F]` with `F = floor(a·b / 2^32)`
        // (`qloop_core::lower::lir::mul_hi`), so `F` in `[lo + 2, hi]` suffices.
        let f = Rc::new(T::Shr(Rc::new(T::Mul(x, y)), 32));
        em.in_range(&f, v.lo + 2, v.hi)
    } else {
        em.in_range(&Rc::new(T::Mul(x, y)), v.lo, v.hi)
    };
    if em.overflowed() {
        return None;
    }
    Some(super::exact_query::finish(em, premises, &goal))
}

/// Whether interval arithmetic on the operands' intervals alone yields a subset of the value's
/// interval, so that the local query can prove it. Values of a shift-add network are
/// correlated (`7x = 8x - x`): their intervals are tighter than their operands suggest, and
/// they get a whole-program query instead.
fn interval_closed(plan: &Plan, id: ValId) -> bool {
    let v = plan.val(id);
    let r = |j: &ValId| (plan.val(*j).lo, plan.val(*j).hi);
    let (lo, hi) = match &v.op {
        Op::Add(a, b) => {
            let ((al, ah), (bl, bh)) = (r(a), r(b));
            (al + bl, ah + bh)
        }
        Op::Sub(a, b) => {
            let ((al, ah), (bl, bh)) = (r(a), r(b));
            (al - bh, ah - bl)
        }
        Op::Neg(a) => (-r(a).1, -r(a).0),
        Op::Mul(a, b) => {
            let ((al, ah), (bl, bh)) = (r(a), r(b));
            let c = [al * bl, al * bh, ah * bl, ah * bh];
            (*c.iter().min().unwrap_or(&0), *c.iter().max().unwrap_or(&0))
        }
        Op::MulHi(a, b) => qloop_core::lower::lir::mul_hi_range(r(a), r(b)),
        Op::Shl(a, k) => (r(a).0 << k, r(a).1 << k),
        Op::Shr(a, k) => (r(a).0 >> k, r(a).1 >> k),
        Op::Cast(a) => r(a),
        Op::Min(a, b) => (r(a).0.min(r(b).0), r(a).1.min(r(b).1)),
        Op::Max(a, b) => (r(a).0.max(r(b).0), r(a).1.max(r(b).1)),
        Op::Select(_, a, b) => (r(a).0.min(r(b).0), r(a).1.max(r(b).1)),
        Op::Low(_, k) => (0, (1i128 << k) - 1),
        Op::Lookup { table, delta, .. } => plan.tables[*table].range(*delta),
        _ => return true,
    };
    v.lo <= lo && hi <= v.hi
}

/// The operation's name in obligation names: `_3 (mul) in [..]`.
fn op_name(op: &Op) -> &'static str {
    match op {
        Op::Input(_) => "input",
        Op::Load(_) => "load",
        Op::Const(_) => "const",
        Op::Cast(_) => "cast",
        Op::Add(..) => "add",
        Op::Sub(..) => "sub",
        Op::Neg(_) => "neg",
        Op::Shl(..) => "shl",
        Op::Shr(..) => "shr",
        Op::Mul(..) => "mul",
        Op::MulHi(..) => "high product",
        Op::Min(..) => "min",
        Op::Max(..) => "max",
        Op::Select(..) => "select",
        Op::Cmp(..) | Op::And(..) | Op::Or(..) | Op::Not(..) => "bool",
        Op::Low(..) => "low bits",
        Op::Lookup { .. } => "table",
    }
}

/// The local overflow query of a derived value: operands free within their intervals.
fn local_val_query(plan: &Plan, id: ValId) -> Query {
    let v = plan.val(id);
    let mut decls = String::new();
    let mut premises = Vec::new();
    let mut want = Vec::new();
    let operand = |j: ValId| -> (String, u32) {
        let o = plan.val(j);
        if o.boolean {
            (format!("o{}", j.0), 1)
        } else {
            (format!("o{}", j.0), signed_bits(o.lo, o.hi))
        }
    };
    for j in v.op.operands() {
        let o = plan.val(j);
        let (name, w) = operand(j);
        if want.contains(&name) {
            continue;
        }
        if o.boolean {
            let _ = writeln!(decls, "(declare-fun {name} () Bool)");
        } else {
            let _ = writeln!(decls, "(declare-fun {name} () (_ BitVec {w}))");
            premises.push(in_range(&name, w, o.lo, o.hi));
        }
        want.push(name);
    }
    let goal = match smt::exact_term(plan, id, &operand) {
        Some((t, w)) => {
            let w2 = w.max(signed_bits(v.lo, v.hi));
            in_range(&resize(&t, w, w2, true), w2, v.lo, v.hi)
        }
        None => "true".into(),
    };
    query_of(&decls, &premises, &goal, &want)
}

/// The goal of a whole-program overflow query: value `id`, on its path, inside its interval.
fn global_goal(step: &Step, id: ValId) -> String {
    let plan = step.plan;
    let v = plan.val(id);
    let operand = |j: ValId| -> (String, u32) {
        let o = plan.val(j);
        if o.boolean || o.ty.signed {
            (vname(j), o.ty.bits)
        } else {
            (
                resize(&vname(j), o.ty.bits, o.ty.bits + 1, false),
                o.ty.bits + 1,
            )
        }
    };
    let (t, w) = match smt::exact_term(plan, id, &operand) {
        Some(x) => x,
        None => operand(id),
    };
    let w2 = w.max(signed_bits(v.lo, v.hi));
    step.paths
        .guard(id, in_range(&resize(&t, w, w2, true), w2, v.lo, v.hi))
}

/// The whole-program overflow query of a claimed value or a load.
pub(super) fn global_val_query(step: &Step, id: ValId) -> Query {
    let plan = step.plan;
    let goal = global_goal(step, id);
    match pre_state_load(step, id) {
        // A load of a state not yet stored in this step is the pre-state itself, and its
        // interval holds the state's range: that premise alone proves it. The other
        // premises (invariants, lemmas with wide products) only slow the solver down.
        Some(sig) => step.query_whole(
            &[super::step::state_bound(
                plan,
                sig,
                &smt::pre_var(&plan.prog, sig),
            )],
            &goal,
            &step.want,
        ),
        None => step.query_with_states(
            &step.lemmas(&step.cone.val(id), Some(id)),
            &goal,
            &step.want,
        ),
    }
}

/// The state that value `id` loads, when it is the pre-state itself (no store before it in
/// the step, so its cone is only itself) and its interval holds the state's range.
fn pre_state_load(step: &Step, id: ValId) -> Option<crate::ir::SigId> {
    let v = step.plan.val(id);
    let Op::Load(sig) = v.op else { return None };
    let (lo, hi) = step.plan.bounds(sig);
    let alone = step.cone.alone(id);
    (alone && v.lo <= lo && hi <= v.hi).then_some(sig)
}

/// The whole-program overflow obligation of one value (used when a local query is refuted,
/// to get a counterexample that is a program state).
pub fn global_for(plan: &Plan, id: ValId) -> Obligation {
    let step = Step::new(plan);
    let v = plan.val(id);
    Obligation {
        name: format!(
            "{} stays in [{}, {}] (whole program)",
            v.name.clone().unwrap_or_else(|| format!("_{}", id.0)),
            v.lo,
            v.hi
        ),
        kind: Kind::Overflow,
        query: global_val_query(&step, id),
        goal: Goal::Val {
            val: id,
            local: false,
        },
        line: v.line,
        encoding: None,
    }
}
