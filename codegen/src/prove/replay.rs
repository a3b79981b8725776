//! Replaying counterexamples: a solver's model is run through the plan interpreter (the
//! executable semantics the generated Rust is tested bit-identical to) and the violated
//! condition is re-evaluated in exact big-integer arithmetic that shares no code with the SMT
//! encoder. Only a counterexample that replays is reported as a refutation.
//!
//! The encoders evaluate property expressions through one shared evaluator
//! ([`crate::prop_eval`]); this module keeps its own on purpose (`Q` below), so that a mistake
//! there cannot confirm its own counterexamples.

use super::obligations::{param_grids, Goal, Obligation};
use crate::interp::step_fixed;
use crate::ir::{CmpOp, PCond, PExpr, SigId, SigKind, When};
use crate::lower::Plan;
use num_bigint::BigInt;
use std::collections::BTreeMap;

/// A counterexample: raw values of the model's variables, by SMT name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cex {
    /// (SMT variable, signed raw value, width).
    pub values: Vec<(String, i128, u32)>,
}

impl Cex {
    /// From a solver model of unsigned bit patterns.
    pub fn from_model(model: &[(String, u128, u32)], signed: &dyn Fn(&str) -> bool) -> Cex {
        let values = model
            .iter()
            .map(|(n, v, w)| {
                let raw = if signed(n) {
                    twos_complement(*v, *w)
                } else {
                    *v as i128
                };
                (n.clone(), raw, *w)
            })
            .collect();
        Cex { values }
    }

    fn get(&self, name: &str) -> Option<i128> {
        self.values
            .iter()
            .find(|(n, ..)| n == name)
            .map(|(_, v, _)| *v)
    }
}

/// The signed value of a `width`-bit two's-complement pattern (width 128: the pattern as is,
/// as for integer-sorted model values).
pub fn twos_complement(bits: u128, width: u32) -> i128 {
    if width < 128 && (bits >> (width - 1)) & 1 == 1 {
        bits as i128 - (1i128 << width)
    } else {
        bits as i128
    }
}

/// Whether the SMT variable `name` holds a signed value.
pub fn var_is_signed(plan: &Plan, name: &str) -> bool {
    let prog = &plan.prog;
    for (i, s) in prog.signals.iter().enumerate() {
        if name == super::smt::input_var(prog, SigId(i))
            || name == super::smt::pre_var(prog, SigId(i))
        {
            return plan.format(SigId(i)).ty.signed;
        }
        let _ = s;
    }
    true
}

/// What the replay found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Replay {
    /// The violation happens: the description says what.
    Confirmed(String),
    /// The model does not violate the obligation when executed: a spurious counterexample.
    NotConfirmed(String),
    /// The model is not a program state (a local query's operands).
    NotApplicable,
}

/// An exact rational `raw · 2^-frac`.
#[derive(Clone, Debug)]
pub(super) struct Q {
    /// The integer.
    pub(super) raw: BigInt,
    /// Its binary point.
    pub(super) frac: i32,
}

impl Q {
    fn at(&self, f: i32) -> BigInt {
        &self.raw << ((f - self.frac).max(0) as usize)
    }
    fn bin(a: Q, b: Q, op: impl Fn(BigInt, BigInt) -> BigInt) -> Q {
        let f = a.frac.max(b.frac);
        Q {
            raw: op(a.at(f), b.at(f)),
            frac: f,
        }
    }
    fn cmp(a: &Q, b: &Q) -> std::cmp::Ordering {
        let f = a.frac.max(b.frac);
        a.at(f).cmp(&b.at(f))
    }
}

fn constant(c: f64) -> Option<Q> {
    let (m, frac) = super::smt::exact_binary(c)?;
    Some(Q {
        raw: BigInt::from(m),
        frac,
    })
}

/// Values a property reads, by signal and side.
pub(super) struct Frame<'a> {
    /// The plan.
    pub(super) plan: &'a Plan,
    /// Raw slots before the step (inputs and states).
    pub(super) pre: &'a [i128],
    /// Raw slots after the step (states and outputs).
    pub(super) post: &'a [i128],
    /// The free parameters' values.
    pub(super) params: &'a [Q],
}

impl Frame<'_> {
    /// The expression evaluated exactly; `None` where a constant is not a binary fraction.
    pub(super) fn expr(&self, e: &PExpr) -> Option<Q> {
        Some(match e {
            PExpr::Const(c) => constant(*c)?,
            PExpr::Sig(id, when) => {
                let q = self.plan.format(*id);
                let kind = self.plan.prog.sig(*id).kind;
                let raw = match (kind, when) {
                    (SigKind::Input, _) | (SigKind::State, When::Pre) => self.pre[id.0],
                    _ => self.post[id.0],
                };
                Q {
                    raw: BigInt::from(raw),
                    frac: q.frac,
                }
            }
            PExpr::Param(i) => self.params.get(*i)?.clone(),
            PExpr::Neg(a) => {
                let a = self.expr(a)?;
                Q {
                    raw: -a.raw,
                    frac: a.frac,
                }
            }
            PExpr::Abs(a) => {
                let a = self.expr(a)?;
                Q {
                    raw: if a.raw < BigInt::from(0) {
                        -a.raw
                    } else {
                        a.raw
                    },
                    frac: a.frac,
                }
            }
            PExpr::Add(a, b) => Q::bin(self.expr(a)?, self.expr(b)?, |x, y| x + y),
            PExpr::Sub(a, b) => Q::bin(self.expr(a)?, self.expr(b)?, |x, y| x - y),
            PExpr::Min(a, b) => Q::bin(self.expr(a)?, self.expr(b)?, |x, y| x.min(y)),
            PExpr::Max(a, b) => Q::bin(self.expr(a)?, self.expr(b)?, |x, y| x.max(y)),
            PExpr::Mul(a, b) => {
                let (a, b) = (self.expr(a)?, self.expr(b)?);
                Q {
                    raw: a.raw * b.raw,
                    frac: a.frac + b.frac,
                }
            }
        })
    }

    /// The condition evaluated exactly; `None` where a constant is not a binary fraction.
    pub(super) fn cond(&self, c: &PCond) -> Option<bool> {
        Some(match c {
            PCond::Cmp(op, a, b) => {
                let o = Q::cmp(&self.expr(a)?, &self.expr(b)?);
                use std::cmp::Ordering::*;
                match op {
                    CmpOp::Lt => o == Less,
                    CmpOp::Le => o != Greater,
                    CmpOp::Gt => o == Greater,
                    CmpOp::Ge => o != Less,
                    CmpOp::Eq => o == Equal,
                    CmpOp::Ne => o != Equal,
                }
            }
            PCond::And(a, b) => self.cond(a)? && self.cond(b)?,
            PCond::Or(a, b) => self.cond(a)? || self.cond(b)?,
            PCond::Not(a) => !self.cond(a)?,
        })
    }
}

/// Replays a counterexample for an obligation.
pub fn replay(plan: &Plan, ob: &Obligation, cex: &Cex, initial: bool) -> Replay {
    let prog = &plan.prog;
    if let Goal::Val { local: true, .. } = ob.goal {
        return Replay::NotApplicable;
    }
    // Pre-step slots: inputs and states from the model (initial queries: the initial state).
    let mut pre = vec![0i128; prog.signals.len()];
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        pre[i] = match s.kind {
            SigKind::Input => cex
                .get(&super::smt::input_var(prog, id))
                .unwrap_or_else(|| absent_input(plan, id)),
            SigKind::State => cex
                .get(&super::smt::pre_var(prog, id))
                .unwrap_or_else(|| plan.raw_init(id)),
            _ => 0,
        };
    }
    let bounds_ok = |vals: &[i128], id: SigId| {
        let (lo, hi) = plan.bounds(id);
        (lo..=hi).contains(&vals[id.0])
    };
    if initial {
        return match &ob.goal {
            Goal::StateBound(id) if !bounds_ok(&pre, *id) => Replay::Confirmed(format!(
                "initial {} = raw {} is outside its range",
                prog.sig(*id).name,
                pre[id.0]
            )),
            Goal::Invariant(k) => {
                let f = Frame {
                    plan,
                    pre: &pre,
                    post: &pre,
                    params: &[],
                };
                match f.cond(&prog.invariants[*k].cond) {
                    Some(false) => Replay::Confirmed(format!(
                        "invariant {} is false initially",
                        prog.invariants[*k].name
                    )),
                    Some(true) => Replay::NotConfirmed("the invariant holds initially".into()),
                    None => Replay::NotConfirmed("cannot evaluate exactly".into()),
                }
            }
            _ => Replay::NotConfirmed("the initial state is inside its range".into()),
        };
    }
    // The model must meet the query's premises: an over-approximate encoding (products as
    // envelopes, cut points) can satisfy them in its own terms with a pre-state that breaks
    // them in exact arithmetic, and a step from there proves nothing.
    if let Some(why) = premise_broken(plan, ob, &pre) {
        return Replay::NotConfirmed(why);
    }
    let mut post = pre.clone();
    let run = step_fixed(plan, &mut post);
    if let Err(v) = &run {
        let val = plan.val(v.val);
        let what = format!(
            "value {} (line {}) computes {} outside its proved interval [{}, {}] ({}): the generated code {}",
            val.name.clone().unwrap_or_else(|| format!("_{}", v.val.0)),
            val.line,
            v.got,
            v.range.0,
            v.range.1,
            val.ty,
            if val.ty.holds(v.got, v.got) { "leaves its claimed range" } else { "overflows its type" }
        );
        return Replay::Confirmed(what);
    }
    match &ob.goal {
        Goal::Val { .. } => Replay::NotConfirmed("every value stays in its interval".into()),
        // Decided without a solver (`prove::table_claims`): nothing of the step to replay.
        Goal::Table(_) => Replay::NotConfirmed("a table claim has no solver model".into()),
        Goal::StateBound(id) => {
            if bounds_ok(&post, *id) {
                Replay::NotConfirmed("the state stays in its range".into())
            } else {
                Replay::Confirmed(format!(
                    "{} leaves its range: raw {}",
                    prog.sig(*id).name,
                    post[id.0]
                ))
            }
        }
        Goal::Invariant(k) => {
            let f = Frame {
                plan,
                pre: &post,
                post: &post,
                params: &[],
            };
            match f.cond(&prog.invariants[*k].cond) {
                Some(false) => Replay::Confirmed(format!(
                    "invariant {} is false after the step",
                    prog.invariants[*k].name
                )),
                Some(true) => Replay::NotConfirmed("the invariant holds after the step".into()),
                None => Replay::NotConfirmed("cannot evaluate exactly".into()),
            }
        }
        Goal::Property(k) => {
            let p = &prog.properties[*k];
            let grids = param_grids(plan, *k);
            let raw = |g: &crate::prop_eval::ParamGrid| cex.get(&g.var).unwrap_or(0);
            if let Some(g) = grids.iter().find(|g| !(g.lo..=g.hi).contains(&raw(g))) {
                return Replay::NotConfirmed(format!(
                    "the model's parameter {} = raw {} is outside its range (a spurious model)",
                    g.var,
                    raw(g)
                ));
            }
            let params: Vec<Q> = grids
                .iter()
                .map(|g| Q {
                    raw: BigInt::from(raw(g)),
                    frac: g.frac,
                })
                .collect();
            let f = Frame {
                plan,
                pre: &pre,
                post: &post,
                params: &params,
            };
            let assumed = p
                .assumes
                .iter()
                .map(|c| f.cond(c))
                .collect::<Option<Vec<bool>>>();
            let ensured = p
                .ensures
                .iter()
                .map(|c| f.cond(c))
                .collect::<Option<Vec<bool>>>();
            match (assumed, ensured) {
                (Some(a), Some(e)) if a.iter().all(|x| *x) && e.iter().any(|x| !x) => {
                    Replay::Confirmed(format!(
                        "property {} fails: its assumptions hold and a conclusion is false",
                        p.name
                    ))
                }
                (Some(_), Some(_)) => {
                    Replay::NotConfirmed("the property holds on this input".into())
                }
                _ => Replay::NotConfirmed("cannot evaluate exactly".into()),
            }
        }
    }
}

/// Why the pre-step slots `pre` are not a state the query of `ob` quantifies over: a state
/// outside its range, an invariant false, or (properties, which assume them) an input
/// outside its range; `None` when they are one.
fn premise_broken(plan: &Plan, ob: &Obligation, pre: &[i128]) -> Option<String> {
    let prog = &plan.prog;
    let outside = |id: SigId| {
        let (lo, hi) = plan.bounds(id);
        !(lo..=hi).contains(&pre[id.0])
    };
    if let Some(id) = prog.ids_of(SigKind::State).find(|&id| outside(id)) {
        return Some(format!(
            "the model's pre-state {} = raw {} is outside its range (a spurious model)",
            prog.sig(id).name,
            pre[id.0]
        ));
    }
    let f = Frame {
        plan,
        pre,
        post: pre,
        params: &[],
    };
    for inv in &prog.invariants {
        if f.cond(&inv.cond) != Some(true) {
            return Some(format!(
                "the model's pre-state does not satisfy invariant {} (a spurious model)",
                inv.name
            ));
        }
    }
    if matches!(ob.goal, Goal::Property(_)) {
        if let Some(id) = prog.ids_of(SigKind::Input).find(|&id| outside(id)) {
            return Some(format!(
                "the model's input {} = raw {} is outside its range (a spurious model)",
                prog.sig(id).name,
                pre[id.0]
            ));
        }
    }
    None
}

/// Physical-unit rendering of a counterexample.
pub fn describe(plan: &Plan, ob: &Obligation, cex: &Cex) -> Vec<String> {
    let prog = &plan.prog;
    let mut by_name: BTreeMap<String, String> = BTreeMap::new();
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let q = plan.format(id);
        let unit = s.unit.clone().unwrap_or_default();
        for var in [
            super::smt::input_var(prog, id),
            super::smt::pre_var(prog, id),
        ] {
            if let Some(v) = cex.get(&var) {
                let what = if var.starts_with("in_") {
                    "input"
                } else {
                    "state"
                };
                let mut line = format!("{what} {} = {} {unit} (raw {v}, {q})", s.name, q.value(v));
                if let (true, Some((lo, hi))) = (what == "input", s.range) {
                    if q.value(v) < lo || q.value(v) > hi {
                        line.push_str(&format!("; step clamps it to [{lo}, {hi}]"));
                    }
                }
                by_name.insert(var, line);
            }
        }
    }
    if let Goal::Property(k) = ob.goal {
        for (g, fp) in param_grids(plan, k).iter().zip(&prog.properties[k].params) {
            if let Some(v) = cex.get(&g.var) {
                by_name.insert(
                    g.var.clone(),
                    format!(
                        "parameter {} = {} (raw {v} · 2^-{})",
                        fp.name,
                        v as f64 * 2f64.powi(-g.frac),
                        g.frac
                    ),
                );
            }
        }
    }
    // A local query's model is its operands; a step query's other variables are the
    // encoding's own (cut points, abstracted products), not part of the counterexample.
    if let Goal::Val { local: true, .. } = ob.goal {
        for (n, v, w) in &cex.values {
            by_name
                .entry(n.clone())
                .or_insert_with(|| format!("operand {n} = raw {v} ({w} bits)"));
        }
    }
    let named = by_name.len();
    let mut lines: Vec<String> = by_name.into_values().collect();
    let step_vars = prog
        .signals
        .iter()
        .filter(|s| matches!(s.kind, SigKind::Input | SigKind::State))
        .count();
    if !matches!(ob.goal, Goal::Val { local: true, .. }) && named < step_vars {
        lines.push(
            "every other state at its initial value, every other input at 0 or the nearest \
             value in its range (the query does not name them, or only through a value it \
             cuts: these are the values the replay ran)"
                .into(),
        );
    }
    lines.extend(explain(plan, ob, cex));
    lines
}

/// The value a replay gives an input that the model does not name (the query left it out:
/// nothing it asks depends on it): 0, or the nearest value inside the input's range.
fn absent_input(plan: &Plan, id: SigId) -> i128 {
    let (lo, hi) = plan.bounds(id);
    0i128.clamp(lo.min(hi), hi.max(lo))
}

/// The pre-step slots of a model: inputs and states from it, the rest as the query left them.
fn pre_slots(plan: &Plan, cex: &Cex) -> Vec<i128> {
    let prog = &plan.prog;
    prog.signals
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let id = SigId(i);
            match s.kind {
                SigKind::Input => cex
                    .get(&super::smt::input_var(prog, id))
                    .unwrap_or_else(|| absent_input(plan, id)),
                SigKind::State => cex
                    .get(&super::smt::pre_var(prog, id))
                    .unwrap_or_else(|| plan.raw_init(id)),
                _ => 0,
            }
        })
        .collect()
}

/// What the step does on a counterexample (a property's or invariant's, not a local query's):
/// the post-state and outputs from the plan interpreter, in units and raw, then each `assume`
/// and each conjunct of each `ensure` (or the invariant's conjuncts) evaluated exactly, with
/// both sides of each comparison.
fn explain(plan: &Plan, ob: &Obligation, cex: &Cex) -> Vec<String> {
    let prog = &plan.prog;
    let k = match ob.goal {
        Goal::Property(k) => Some(k),
        Goal::Invariant(_) if ob.kind != super::obligations::Kind::Initial => None,
        _ => return Vec::new(),
    };
    let pre = pre_slots(plan, cex);
    let mut post = pre.clone();
    if step_fixed(plan, &mut post).is_err() {
        return vec![
            "after the step: a value leaves its proved interval (see the overflow obligations)"
                .into(),
        ];
    }
    let mut out = Vec::new();
    for (i, s) in prog.signals.iter().enumerate() {
        if matches!(s.kind, SigKind::State | SigKind::Output) {
            let q = plan.format(SigId(i));
            let what = if s.kind == SigKind::State {
                format!("state next({})", s.name)
            } else {
                format!("output {}", s.name)
            };
            out.push(format!(
                "after the step: {what} = {} {} (raw {}, {q})",
                q.value(post[i]),
                s.unit.as_deref().unwrap_or(""),
                post[i]
            ));
        }
    }
    let params: Vec<Q> = match k {
        Some(k) => param_grids(plan, k)
            .iter()
            .map(|g| Q {
                raw: BigInt::from(cex.get(&g.var).unwrap_or(0)),
                frac: g.frac,
            })
            .collect(),
        None => Vec::new(),
    };
    let f = Frame {
        plan,
        pre: &pre,
        post: &post,
        params: &params,
    };
    let names: Vec<String> = k
        .map(|k| {
            prog.properties[k]
                .params
                .iter()
                .map(|p| p.name.clone())
                .collect()
        })
        .unwrap_or_default();
    let mut clause = |role: &str, c: &PCond| {
        let mut parts = Vec::new();
        conjuncts(c, &mut parts);
        for part in parts {
            let value = match f.cond(part) {
                Some(true) => "true",
                Some(false) => "FALSE",
                None => "not exactly evaluable",
            };
            let sides = match part {
                PCond::Cmp(_, a, b) => match (f.expr(a), f.expr(b)) {
                    (Some(x), Some(y)) => format!(
                        " ({} vs {})",
                        crate::report::g(q_value(&x)),
                        crate::report::g(q_value(&y))
                    ),
                    _ => String::new(),
                },
                _ => String::new(),
            };
            out.push(format!(
                "{role} `{}`: {value}{sides}",
                pcond_text(prog, &names, part)
            ));
        }
    };
    match (k, &ob.goal) {
        (Some(k), _) => {
            let p = &prog.properties[k];
            for a in &p.assumes {
                clause("assume", a);
            }
            for e in &p.ensures {
                clause("ensure", e);
            }
        }
        (None, Goal::Invariant(i)) => {
            let f2 = Frame {
                plan,
                pre: &post,
                post: &post,
                params: &[],
            };
            let mut parts = Vec::new();
            conjuncts(&prog.invariants[*i].cond, &mut parts);
            for part in parts {
                let v = match f2.cond(part) {
                    Some(true) => "true",
                    Some(false) => "FALSE",
                    None => "not exactly evaluable",
                };
                out.push(format!(
                    "invariant after the step `{}`: {v}",
                    pcond_text(prog, &names, part)
                ));
            }
        }
        _ => {}
    }
    out
}

/// The conjuncts of `c` (`a && b && c` → a, b, c).
fn conjuncts<'a>(c: &'a PCond, out: &mut Vec<&'a PCond>) {
    match c {
        PCond::And(a, b) => {
            conjuncts(a, out);
            conjuncts(b, out);
        }
        other => out.push(other),
    }
}

/// An exact value as f64 (for display).
fn q_value(q: &Q) -> f64 {
    q.raw.to_string().parse::<f64>().unwrap_or(f64::NAN) * 2f64.powi(-q.frac)
}

/// A property condition as spec-like text.
fn pcond_text(prog: &qloop_core::ir::Program, params: &[String], c: &PCond) -> String {
    match c {
        PCond::Cmp(op, a, b) => format!(
            "{} {} {}",
            pexpr_text(prog, params, a),
            op.symbol(),
            pexpr_text(prog, params, b)
        ),
        PCond::And(a, b) => format!(
            "({}) && ({})",
            pcond_text(prog, params, a),
            pcond_text(prog, params, b)
        ),
        PCond::Or(a, b) => format!(
            "({}) || ({})",
            pcond_text(prog, params, a),
            pcond_text(prog, params, b)
        ),
        PCond::Not(a) => format!("!({})", pcond_text(prog, params, a)),
    }
}

/// A property expression as spec-like text.
fn pexpr_text(prog: &qloop_core::ir::Program, params: &[String], e: &PExpr) -> String {
    let t = |x: &PExpr| pexpr_text(prog, params, x);
    match e {
        PExpr::Const(c) => crate::report::g(*c),
        PExpr::Sig(id, When::Post) if prog.sig(*id).kind == SigKind::State => {
            format!("next({})", prog.sig(*id).name)
        }
        PExpr::Sig(id, _) => prog.sig(*id).name.clone(),
        PExpr::Param(i) => params.get(*i).cloned().unwrap_or_else(|| format!("p{i}")),
        PExpr::Neg(a) => format!("-{}", t(a)),
        PExpr::Abs(a) => format!("abs({})", t(a)),
        PExpr::Add(a, b) => format!("({} + {})", t(a), t(b)),
        PExpr::Sub(a, b) => format!("({} - {})", t(a), t(b)),
        PExpr::Mul(a, b) => format!("{} * {}", t(a), t(b)),
        PExpr::Min(a, b) => format!("min({}, {})", t(a), t(b)),
        PExpr::Max(a, b) => format!("max({}, {})", t(a), t(b)),
    }
}

/// Evaluates property `k` exactly on raw pre-step values (inputs and states, by signal id),
/// raw post-step values (states and outputs) and raw free parameters (on their grids):
/// `Some(true)` if the assumptions fail or every conclusion holds.
pub fn property_holds(
    plan: &Plan,
    k: usize,
    pre: &[i128],
    post: &[i128],
    params: &[i128],
) -> Option<bool> {
    let grids = param_grids(plan, k);
    let params: Vec<Q> = grids
        .iter()
        .zip(params)
        .map(|(g, v)| Q {
            raw: BigInt::from(*v),
            frac: g.frac,
        })
        .collect();
    let f = Frame {
        plan,
        pre,
        post,
        params: &params,
    };
    let p = &plan.prog.properties[k];
    for a in &p.assumes {
        if !f.cond(a)? {
            return Some(true);
        }
    }
    for e in &p.ensures {
        if !f.cond(e)? {
            return Some(false);
        }
    }
    Some(true)
}
