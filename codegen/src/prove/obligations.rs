//! The proof obligations of a plan, each a complete QF_BV script whose satisfiability means a
//! counterexample.
//!
//! * **overflow**: every plan value stays inside the interval the range analysis assigned to
//!   it, which lies inside its machine type. For a value the analysis *derived*, the
//!   obligation is local: its operands, declared at the narrowest widths that hold their own
//!   intervals, produce an exact result inside its interval. By induction over the
//!   straight-line plan (each operand's interval is its own obligation) this proves that no
//!   value of the step ever leaves its width. Values whose interval is a user *claim*
//!   (`#[range]`, `#[unsaturated]`) get a whole-program obligation instead.
//! * **initial**: the initial state is inside the state ranges and satisfies the invariants.
//! * **inductive**: one step from any state inside the ranges and invariants, with any input
//!   bits, lands inside them again. With (initial) this proves the ranges and invariants for
//!   every reachable state, for unbounded time.
//! * **property**: each step property, for all inputs in range, states in the invariants and
//!   free parameters in range.
//!
//! Whole-program obligations assume the other values' intervals as lemmas (each guarded by
//! the path condition of the branch that computes it): sound because each lemma is an
//! obligation of its own, proved separately.

use super::exact::{self, PropTerms, B, T};
use super::smt::{self, encode_step, in_range, lit, resize, signed_bits, vname, PropEnv};
use super::solver::Query;
use crate::ir::PCond;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::rc::Rc;

/// What kind of obligation, as in the JSON report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// No value leaves its interval / width.
    Overflow,
    /// The initial state satisfies the ranges and invariants.
    Initial,
    /// The ranges and invariants are preserved by one step.
    Inductive,
    /// A user step property.
    Property,
}

impl Obligation {
    /// The name with its encoding, if any: `property P [linear envelope]`.
    pub fn label(&self) -> String {
        match self.encoding {
            Some(how) => format!("{} [{how}]", self.name),
            None => self.name.clone(),
        }
    }
}

impl Kind {
    /// Lower-case name used in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Overflow => "overflow",
            Kind::Initial => "initial",
            Kind::Inductive => "inductive",
            Kind::Property => "property",
        }
    }
}

/// What a counterexample must show when replayed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Goal {
    /// Value leaves its interval. `local`: the query was over the operands only.
    Val {
        /// The value.
        val: ValId,
        /// Whether the query is local (operands as free variables).
        local: bool,
    },
    /// State leaves its declared range (initially, or after a step).
    StateBound(SigId),
    /// Invariant `i` fails (initially, or after a step).
    Invariant(usize),
    /// Property `i` fails.
    Property(usize),
}

/// One obligation.
#[derive(Clone, Debug)]
pub struct Obligation {
    /// Human-readable name.
    pub name: String,
    /// Kind.
    pub kind: Kind,
    /// The SMT query.
    pub query: Query,
    /// What a counterexample breaks.
    pub goal: Goal,
    /// Spec line of the operation or property (0 if unknown).
    pub line: usize,
    /// The encoding, when the question is tried in several (a portfolio): obligations with
    /// the same goal and kind and an encoding are alternatives, merged in the report.
    pub encoding: Option<&'static str>,
}

pub use crate::prop_eval::{param_grids, ParamGrid};

/// How an exact-term query is written: its sort and its treatment of products. The prover
/// tries a property or invariant in several of these (a portfolio); the label names the one
/// that proved it. (The bit-precise step itself is a [`smt::StepEncoding`].)
#[derive(Clone, Copy, Debug)]
pub struct ExactEncoding {
    /// Bit-vectors or integers.
    pub sort: exact::Sort,
    /// Exact or over-approximated products.
    pub products: exact::Products,
    /// Name in reports (`property P [label]`).
    pub label: &'static str,
}

/// Linear integer arithmetic, products replaced by their linear envelopes: decided in
/// milliseconds by both solvers when the envelope is tight enough for the property.
pub const LINEAR: ExactEncoding = ExactEncoding {
    sort: exact::Sort::Int,
    products: exact::Products::Relaxed,
    label: "linear envelope",
};
/// Non-linear integer arithmetic, exact (cvc5's incremental linearisation is fast on it).
pub const INTEGER: ExactEncoding = ExactEncoding {
    sort: exact::Sort::Int,
    products: exact::Products::Exact,
    label: "exact integers",
};
/// Exact terms as bit-vectors at the narrowest widths.
pub const EXACT_BV: ExactEncoding = ExactEncoding {
    sort: exact::Sort::BitVec,
    products: exact::Products::Exact,
    label: "exact terms",
};
/// Bit-vectors, products outside the free parameters bounded by their intervals.
pub const ABSTRACT_BV: ExactEncoding = ExactEncoding {
    sort: exact::Sort::BitVec,
    products: exact::Products::Interval,
    label: "abstracted products",
};

/// Builds every obligation of the plan.
pub fn obligations(plan: &Plan) -> Vec<Obligation> {
    with_witnesses(plan).0
}

/// Every obligation of the plan, and per property a bit-precise query whose models are
/// states, inputs and parameters meeting its premises (state ranges, invariants, input
/// ranges, `assume`s): `unsat` there means the property holds vacuously.
pub fn with_witnesses(plan: &Plan) -> (Vec<Obligation>, Vec<Option<Query>>) {
    let prog = &plan.prog;
    let mut out = Vec::new();
    let enc = encode_step(plan);
    let paths = path_conditions(plan);
    let cone = cone(plan);
    let post_cone = |sigs: &BTreeSet<SigId>| cone.post_of(sigs);
    let want_step = step_vars(plan);

    // (a) overflow, one per value.
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
        let query = if global {
            global_val_query(plan, &enc, &paths, id, &want_step)
        } else {
            local_val_query(plan, id)
        };
        out.push(Obligation {
            name,
            kind: Kind::Overflow,
            query,
            goal: Goal::Val {
                val: id,
                local: !global,
            },
            line: v.line,
            encoding: None,
        });
    }

    // (b) initial and (c) inductive, per state range and per invariant.
    for id in prog.ids_of(SigKind::State) {
        let s = prog.sig(id);
        out.push(Obligation {
            name: format!("initial {} inside its range", s.name),
            kind: Kind::Initial,
            query: initial_query(plan, &state_bound(plan, id, &smt::pre_var(prog, id))),
            goal: Goal::StateBound(id),
            line: s.span.start().line,
            encoding: None,
        });
        let goal = state_bound(plan, id, &enc.post[&id]);
        let needed = post_cone(&BTreeSet::from([id]));
        out.push(Obligation {
            name: format!("{} stays inside its range", s.name),
            kind: Kind::Inductive,
            query: step_query(plan, &enc, &paths, &needed, &[], &goal, &want_step, false),
            goal: Goal::StateBound(id),
            line: s.span.start().line,
            encoding: None,
        });
    }
    for (k, inv) in prog.invariants.iter().enumerate() {
        let line = inv.span.start().line;
        let query = |side: Side, how: ExactEncoding| {
            exact_query(
                plan,
                side,
                &[],
                &[],
                &|pt| pt.cond(&inv.cond),
                0..0,
                &[],
                how,
            )
        };
        if let Some(init) = query(Side::Initial, EXACT_BV) {
            out.push(Obligation {
                name: format!("invariant {} holds initially", inv.name),
                kind: Kind::Initial,
                query: init,
                goal: Goal::Invariant(k),
                line,
                encoding: None,
            });
        }
        for how in [LINEAR, INTEGER, EXACT_BV] {
            if let Some(query) = query(Side::Step, how) {
                out.push(Obligation {
                    name: format!("invariant {} is inductive", inv.name),
                    kind: Kind::Inductive,
                    query,
                    goal: Goal::Invariant(k),
                    line,
                    encoding: Some(how.label),
                });
            }
        }
        // The bit-precise encoding too: products of post-states distribute badly.
        let none: Vec<(String, u32, i32)> = Vec::new();
        let post_env = PropEnv {
            plan,
            post: &enc.post,
            params: &none,
            pre_as_post: true,
        };
        if let Some(goal) = post_env.cond(&inv.cond) {
            let mut sigs = BTreeSet::new();
            post_signals(&inv.cond, &mut sigs, true);
            let needed = post_cone(&sigs);
            out.push(Obligation {
                name: format!("invariant {} is inductive", inv.name),
                kind: Kind::Inductive,
                query: step_query(plan, &enc, &paths, &needed, &[], &goal, &want_step, false),
                goal: Goal::Invariant(k),
                line,
                encoding: Some("bit-precise"),
            });
        }
    }

    // (d) properties: a portfolio of encodings, merged by `prove` (any sound proof counts).
    for (k, p) in prog.properties.iter().enumerate() {
        let grids = param_grids(plan, k);
        let goal = |pt: &PropTerms| -> Option<Rc<B>> {
            let parts: Option<Vec<Rc<B>>> = p.ensures.iter().map(|c| pt.cond(c)).collect();
            parts?.into_iter().reduce(|x, y| Rc::new(B::And(x, y)))
        };
        let exact = |how: ExactEncoding| {
            let query = exact_query(
                plan,
                Side::Property,
                &p.assumes,
                &p.ensures,
                &goal,
                0..grids.len(),
                &grids,
                how,
            );
            (query, how.label)
        };
        let direct = direct_property_query(plan, &enc, &paths, &post_cone, k, &want_step, false);
        let line = p.span.start().line;
        // Cheapest first: each solver stops at its first proof.
        for (query, how) in [
            exact(LINEAR),
            exact(INTEGER),
            exact(EXACT_BV),
            exact(ABSTRACT_BV),
            (direct, "bit-precise"),
        ] {
            if let Some(query) = query {
                out.push(Obligation {
                    name: format!("property {}", p.name),
                    kind: Kind::Property,
                    query,
                    goal: Goal::Property(k),
                    line,
                    encoding: Some(how),
                });
            }
        }
    }
    let witnesses = (0..prog.properties.len())
        .map(|k| direct_property_query(plan, &enc, &paths, &post_cone, k, &want_step, true))
        .collect();
    (out, witnesses)
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
        Op::Shl(a, k) => (r(a).0 << k, r(a).1 << k),
        Op::Shr(a, k) => (r(a).0 >> k, r(a).1 >> k),
        Op::Cast(a) => r(a),
        Op::Min(a, b) => (r(a).0.min(r(b).0), r(a).1.min(r(b).1)),
        Op::Max(a, b) => (r(a).0.max(r(b).0), r(a).1.max(r(b).1)),
        Op::Select(_, a, b) => (r(a).0.min(r(b).0), r(a).1.max(r(b).1)),
        _ => return true,
    };
    v.lo <= lo && hi <= v.hi
}

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
        Op::Min(..) => "min",
        Op::Max(..) => "max",
        Op::Select(..) => "select",
        Op::Cmp(..) | Op::And(..) | Op::Or(..) | Op::Not(..) => "bool",
    }
}

fn conj(terms: &[String]) -> String {
    match terms {
        [] => "true".into(),
        [t] => t.clone(),
        _ => format!("(and {})", terms.join(" ")),
    }
}

/// The SMT variables of one step: every input and pre-step state.
fn step_vars(plan: &Plan) -> Vec<String> {
    let prog = &plan.prog;
    prog.signals
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s.kind {
            SigKind::Input => Some(smt::input_var(prog, SigId(i))),
            SigKind::State => Some(smt::pre_var(prog, SigId(i))),
            _ => None,
        })
        .collect()
}

/// Cone of influence: the values each value, and each post-step signal, depends on.
struct Cone {
    val: Vec<BTreeSet<ValId>>,
    post: BTreeMap<SigId, BTreeSet<ValId>>,
}

impl Cone {
    /// The values the post-step values of `sigs` depend on.
    fn post_of(&self, sigs: &BTreeSet<SigId>) -> BTreeSet<ValId> {
        sigs.iter()
            .flat_map(|s| self.post.get(s).into_iter().flatten().copied())
            .collect()
    }
}

fn cone(plan: &Plan) -> Cone {
    fn walk(
        plan: &Plan,
        stmts: &[LStmt],
        env: &mut BTreeMap<SigId, BTreeSet<ValId>>,
        val: &mut Vec<BTreeSet<ValId>>,
    ) {
        for s in stmts {
            match s {
                LStmt::Def(id) => {
                    let v = plan.val(*id);
                    let mut d: BTreeSet<ValId> = BTreeSet::from([*id]);
                    for o in v.op.operands() {
                        d.extend(val[o.0].iter().copied());
                    }
                    if let Op::Load(sig) = v.op {
                        d.extend(env.get(&sig).into_iter().flatten().copied());
                    }
                    val[id.0] = d;
                }
                LStmt::Store(sig, id) => {
                    env.insert(*sig, val[id.0].clone());
                }
                LStmt::If(c, t, e) => {
                    let mut et = env.clone();
                    walk(plan, t, &mut et, val);
                    let mut ee = env.clone();
                    walk(plan, e, &mut ee, val);
                    let keys: BTreeSet<SigId> = et.keys().chain(ee.keys()).copied().collect();
                    for k in keys {
                        let mut d: BTreeSet<ValId> = et.get(&k).cloned().unwrap_or_default();
                        d.extend(ee.get(&k).into_iter().flatten().copied());
                        d.extend(val[c.0].iter().copied());
                        env.insert(k, d);
                    }
                }
            }
        }
    }
    let mut val = vec![BTreeSet::new(); plan.vals.len()];
    let mut post = BTreeMap::new();
    walk(plan, &plan.body, &mut post, &mut val);
    Cone { val, post }
}

/// Post-step signals a property condition reads (and pre-step states, if `pre_as_post`).
fn post_signals(c: &PCond, out: &mut BTreeSet<SigId>, pre_as_post: bool) {
    use crate::ir::{PExpr, When};
    c.walk(&mut |x| match x {
        PExpr::Sig(id, When::Post) => {
            out.insert(*id);
        }
        PExpr::Sig(id, When::Pre) if pre_as_post => {
            out.insert(*id);
        }
        _ => {}
    });
}

/// The path condition (conjunction of enclosing branch conditions) of every value.
fn path_conditions(plan: &Plan) -> BTreeMap<ValId, String> {
    fn walk(stmts: &[LStmt], path: &str, out: &mut BTreeMap<ValId, String>) {
        for s in stmts {
            match s {
                LStmt::Def(id) => {
                    out.insert(*id, path.to_string());
                }
                LStmt::Store(..) => {}
                LStmt::If(c, t, e) => {
                    let c = vname(*c);
                    let pt = if path == "true" {
                        c.clone()
                    } else {
                        format!("(and {path} {c})")
                    };
                    let pe = if path == "true" {
                        format!("(not {c})")
                    } else {
                        format!("(and {path} (not {c}))")
                    };
                    walk(t, &pt, out);
                    walk(e, &pe, out);
                }
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(&plan.body, "true", &mut out);
    out
}

/// A signed term (and width) for a storage-typed raw term: unsigned values get a zero bit.
fn signed_view(plan: &Plan, id: SigId, term: &str) -> (String, u32) {
    let t = plan.format(id).ty;
    if t.signed {
        (term.to_string(), t.bits)
    } else {
        (resize(term, t.bits, t.bits + 1, false), t.bits + 1)
    }
}

/// `term` (a storage-typed value of state `id`) lies within the state's saturation bounds.
fn state_bound(plan: &Plan, id: SigId, term: &str) -> String {
    let (t, w) = signed_view(plan, id, term);
    let (lo, hi) = plan.bounds(id);
    in_range(&t, w, lo, hi)
}

/// Premises shared by whole-step queries: states inside their ranges and the invariants.
fn state_premises(plan: &Plan, enc_post: &BTreeMap<SigId, String>) -> Vec<String> {
    let prog = &plan.prog;
    let mut v: Vec<String> = prog
        .ids_of(SigKind::State)
        .map(|id| state_bound(plan, id, &smt::pre_var(prog, id)))
        .collect();
    let none: Vec<(String, u32, i32)> = Vec::new();
    let env = PropEnv {
        plan,
        post: enc_post,
        params: &none,
        pre_as_post: false,
    };
    v.extend(prog.invariants.iter().filter_map(|inv| env.cond(&inv.cond)));
    v
}

/// Lemmas: the values in `needed` inside their intervals, each guarded by its path condition.
fn lemmas(
    plan: &Plan,
    paths: &BTreeMap<ValId, String>,
    needed: &BTreeSet<ValId>,
    skip: Option<ValId>,
) -> Vec<String> {
    plan.vals
        .iter()
        .enumerate()
        .filter(|(i, v)| {
            !v.boolean
                && Some(ValId(*i)) != skip
                && needed.contains(&ValId(*i))
                && !matches!(v.op, Op::Input(_))
        })
        .map(|(i, v)| {
            let (t, w) = if v.ty.signed {
                (vname(ValId(i)), v.ty.bits)
            } else {
                (
                    resize(&vname(ValId(i)), v.ty.bits, v.ty.bits + 1, false),
                    v.ty.bits + 1,
                )
            };
            let r = in_range(&t, w, v.lo, v.hi);
            match paths.get(&ValId(i)).map(String::as_str) {
                None | Some("true") => r,
                Some(p) => format!("(=> {p} {r})"),
            }
        })
        .collect()
}

fn script(decls: &str, premises: &[String], goal: &str) -> String {
    let mut s = String::from("(set-logic QF_BV)\n");
    s.push_str(decls);
    for p in premises {
        let _ = writeln!(s, "(assert {p})");
    }
    let _ = writeln!(s, "(assert (not {goal}))");
    s
}

/// A whole-step query: premises (states, invariants, lemmas, extra) ⇒ goal.
#[allow(clippy::too_many_arguments)]
fn step_query(
    plan: &Plan,
    enc: &smt::StepEncoding,
    paths: &BTreeMap<ValId, String>,
    needed: &BTreeSet<ValId>,
    extra: &[String],
    goal: &str,
    want: &[String],
    inputs_in_range: bool,
) -> Query {
    let mut premises = state_premises(plan, &enc.post);
    if inputs_in_range {
        let prog = &plan.prog;
        for id in prog.ids_of(SigKind::Input) {
            let (lo, hi) = plan.bounds(id);
            let (t, w) = signed_view(plan, id, &smt::input_var(prog, id));
            premises.push(in_range(&t, w, lo, hi));
        }
    }
    premises.extend(lemmas(plan, paths, needed, None));
    premises.extend(extra.iter().cloned());
    Query {
        script: script(&enc.text, &premises, goal),
        want: want.to_vec(),
    }
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
    Query {
        script: script(&decls, &premises, goal),
        want,
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
    Query {
        script: script(&decls, &premises, &goal),
        want,
    }
}

/// The whole-program overflow query of a claimed value or a load.
fn global_val_query(
    plan: &Plan,
    enc: &smt::StepEncoding,
    paths: &BTreeMap<ValId, String>,
    id: ValId,
    want: &[String],
) -> Query {
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
    let r = in_range(&resize(&t, w, w2, true), w2, v.lo, v.hi);
    let goal = match paths.get(&id).map(String::as_str) {
        None | Some("true") => r,
        Some(p) => format!("(=> {p} {r})"),
    };
    let mut premises = state_premises(plan, &enc.post);
    let needed = cone(plan).val[id.0].clone();
    premises.extend(lemmas(plan, paths, &needed, Some(id)));
    Query {
        script: script(&enc.text, &premises, &goal),
        want: want.to_vec(),
    }
}

/// The whole-program overflow obligation of one value (used when a local query is refuted,
/// to get a counterexample that is a program state).
pub fn global_for(plan: &Plan, id: ValId) -> Obligation {
    let enc = encode_step(plan);
    let paths = path_conditions(plan);
    let want = step_vars(plan);
    let v = plan.val(id);
    Obligation {
        name: format!(
            "{} stays in [{}, {}] (whole program)",
            v.name.clone().unwrap_or_else(|| format!("_{}", id.0)),
            v.lo,
            v.hi
        ),
        kind: Kind::Overflow,
        query: global_val_query(plan, &enc, &paths, id, &want),
        goal: Goal::Val {
            val: id,
            local: false,
        },
        line: v.line,
        encoding: None,
    }
}

/// Which question an exact query asks.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Side {
    /// The initial state (states fixed to their initial values, goal over pre-state).
    Initial,
    /// One step from any state in the invariants and any input bits (goal over post-state).
    Step,
    /// One step from any state in the invariants and inputs in range (goal over both).
    Property,
}

/// A query over exact terms: premises (state ranges, invariants, input ranges for
/// properties, parameter ranges, `assumes`) ⇒ `goal`.
#[allow(clippy::too_many_arguments)]
fn exact_query(
    plan: &Plan,
    side: Side,
    assumes: &[PCond],
    goal_conds: &[PCond],
    goal: &dyn Fn(&PropTerms) -> Option<Rc<B>>,
    params: std::ops::Range<usize>,
    grids: &[ParamGrid],
    how: ExactEncoding,
) -> Option<Query> {
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
    let terms = exact::terms(plan, &ranges);
    // Over-approximations (products as fresh variables bounded by their interval, or by
    // their linear envelope) are sound: more behaviours, not fewer; a counterexample they
    // find may be spurious, and the replay says so.
    let mut em = exact::Emitter::new(how.sort, how.products);
    em.keep = grids
        .iter()
        .flat_map(|g| [g.var.clone(), format!("d_{}", g.var)])
        .collect();
    let mut premises: Vec<String> = Vec::new();
    // A free parameter p compared with a state s (`p - s` in the property) is rewritten as
    // p = s + D with a fresh D: a change of variables (exact, both ways), after which the
    // linear normal form cancels s and shares s's products with the step's own terms.
    let subst = match side {
        Side::Property => param_state_pairs(plan, assumes, goal_conds),
        _ => BTreeMap::new(),
    };
    let mut params_t: Vec<(Rc<T>, i32)> = Vec::new();
    for (i, g) in grids[params].iter().enumerate() {
        let pv = Rc::new(T::Var(g.var.clone(), g.width, true, g.lo, g.hi));
        let state = subst.get(&i).copied();
        let shift = state.map_or(-1, |s| g.frac - plan.format(s).frac);
        match state {
            Some(s) if shift >= 0 => {
                let (slo, shi) = ranges(s);
                let (dlo, dhi) = (g.lo - (shi << shift), g.hi - (slo << shift));
                let d = Rc::new(T::Var(
                    format!("d_{}", g.var),
                    signed_bits(dlo, dhi),
                    true,
                    dlo,
                    dhi,
                ));
                let t = exact::add_terms(exact::shl_term(terms.pre[&s].clone(), shift as u32), d);
                // Keep p in the model (for replay): p = s·2^shift + D, inside p's grid range.
                premises.push(em.equal(&pv, &t));
                params_t.push((t, g.frac));
            }
            _ => params_t.push((pv, g.frac)),
        }
    }
    let pre_env = PropTerms {
        plan,
        terms: &terms,
        params: params_t.clone(),
        pre_as_post: false,
    };
    let post_env = PropTerms {
        plan,
        terms: &terms,
        params: params_t.clone(),
        pre_as_post: true,
    };
    // Every variable inside its assumed range.
    let mut vars: Vec<Rc<T>> = terms.pre.values().cloned().collect();
    vars.extend(params_t.iter().map(|(t, _)| t.clone()));
    vars.extend(
        grids
            .iter()
            .map(|g| Rc::new(T::Var(g.var.clone(), g.width, true, g.lo, g.hi))),
    );
    let vars: Vec<Rc<T>> = vars.iter().flat_map(exact::vars_of).collect();
    for v in &vars {
        if let T::Var(_, _, _, lo, hi) = &**v {
            premises.push(em.in_range(v, *lo, *hi));
        }
    }
    if side != Side::Initial {
        for inv in &prog.invariants {
            premises.push(em.boolean(&pre_env.cond(&inv.cond)?));
        }
    }
    for a in assumes {
        premises.push(em.boolean(&pre_env.cond(a)?));
    }
    let g = match side {
        Side::Step => goal(&post_env)?,
        _ => goal(&pre_env)?,
    };
    let goal = em.boolean(&g);
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
    Some(Query { script: text, want })
}

/// The bit-precise (SSA) encoding of property `k`, with lemmas for its cone of influence.
fn direct_property_query(
    plan: &Plan,
    enc: &smt::StepEncoding,
    paths: &BTreeMap<ValId, String>,
    post_cone: &dyn Fn(&BTreeSet<SigId>) -> BTreeSet<ValId>,
    k: usize,
    want_step: &[String],
    witness: bool,
) -> Option<Query> {
    let p = &plan.prog.properties[k];
    let grids = &param_grids(plan, k);
    let params: Vec<(String, u32, i32)> = grids
        .iter()
        .map(|g| (g.var.clone(), g.width, g.frac))
        .collect();
    let env = PropEnv {
        plan,
        post: &enc.post,
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
        post_signals(c, &mut sigs, false);
    }
    let needed = post_cone(&sigs);
    let mut want = want_step.to_vec();
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
    let mut q = step_query(plan, enc, paths, &needed, &premises, &goal, &want, true);
    q.script = q.script.replacen(
        "(set-logic QF_BV)\n",
        &format!("(set-logic QF_BV)\n{decls}"),
        1,
    );
    Some(q)
}

/// Free parameters that a property compares with a pre-step state (`p - s` or `s - p`).
fn param_state_pairs(plan: &Plan, assumes: &[PCond], ensures: &[PCond]) -> BTreeMap<usize, SigId> {
    use crate::ir::{PExpr, When};
    let mut out = BTreeMap::new();
    for c in assumes.iter().chain(ensures) {
        c.walk(&mut |x| {
            if let PExpr::Sub(a, b) = x {
                if let (PExpr::Param(i), PExpr::Sig(s, When::Pre))
                | (PExpr::Sig(s, When::Pre), PExpr::Param(i)) = (&**a, &**b)
                {
                    if plan.prog.sig(*s).kind == SigKind::State {
                        out.entry(*i).or_insert(*s);
                    }
                }
            }
        });
    }
    out
}
