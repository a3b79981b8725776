//! The whole-program question that overflow (for claimed values and loads), inductive and
//! bit-precise property obligations share: one step of the bit-precise encoding, from any
//! state inside the ranges and invariants, with the other values' intervals as lemmas.
//!
//! Lemmas are sound because each is an obligation of its own, proved separately; each is
//! guarded by the path condition of the branch that computes the value, and only the values
//! in the cone of influence of the goal are included.

use super::cone::Cone;
use super::path::Paths;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;
use crate::prove::smt::{self, encode_step, in_range, resize, vname, PropEnv, StepEncoding};
use crate::prove::solver::Query;
use std::collections::BTreeSet;
use std::fmt::Write;

/// What the whole-program queries of a plan share, computed once.
pub(super) struct Step<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// The bit-precise encoding of one step.
    pub enc: StepEncoding,
    /// The path condition of every value.
    pub paths: Paths,
    /// What each value and each post-step signal depends on.
    pub cone: Cone,
    /// The step's free variables (inputs and pre-states): the model a counterexample reports.
    pub want: Vec<String>,
}

impl<'a> Step<'a> {
    /// Encodes the step of `plan` and the facts its queries draw on.
    pub fn new(plan: &'a Plan) -> Self {
        Step {
            plan,
            enc: encode_step(plan),
            paths: Paths::of(plan),
            cone: Cone::of(plan),
            want: step_vars(plan),
        }
    }

    /// Premises of every whole-step query: states inside their ranges and the invariants.
    pub fn state_premises(&self) -> Vec<String> {
        let plan = self.plan;
        let prog = &plan.prog;
        let mut v: Vec<String> = prog
            .ids_of(SigKind::State)
            .map(|id| state_bound(plan, id, &smt::pre_var(prog, id)))
            .collect();
        let none: Vec<(String, u32, i32)> = Vec::new();
        let env = PropEnv {
            plan,
            post: &self.enc.post,
            params: &none,
            pre_as_post: false,
        };
        v.extend(prog.invariants.iter().filter_map(|inv| env.cond(&inv.cond)));
        v
    }

    /// Lemmas: the values in `needed` (but `skip`) inside their intervals, each guarded by its
    /// path condition.
    pub fn lemmas(&self, needed: &BTreeSet<ValId>, skip: Option<ValId>) -> Vec<String> {
        self.plan
            .vals
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
                self.paths.guard(ValId(i), in_range(&t, w, v.lo, v.hi))
            })
            .collect()
    }

    /// A whole-step query: premises (states, invariants, inputs in range if asked, lemmas for
    /// `needed`, `extra`) ⇒ `goal`, reporting `want` on a counterexample.
    pub fn query(
        &self,
        needed: &BTreeSet<ValId>,
        extra: &[String],
        goal: &str,
        want: &[String],
        inputs_in_range: bool,
    ) -> Query {
        let plan = self.plan;
        let mut premises = self.state_premises();
        if inputs_in_range {
            let prog = &plan.prog;
            for id in prog.ids_of(SigKind::Input) {
                let (lo, hi) = plan.bounds(id);
                let (t, w) = signed_view(plan, id, &smt::input_var(prog, id));
                premises.push(in_range(&t, w, lo, hi));
            }
        }
        premises.extend(self.lemmas(needed, None));
        premises.extend(extra.iter().cloned());
        Query {
            script: script(&self.enc.text, &premises, goal),
            want: want.to_vec(),
        }
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
pub(super) fn state_bound(plan: &Plan, id: SigId, term: &str) -> String {
    let (t, w) = signed_view(plan, id, term);
    let (lo, hi) = plan.bounds(id);
    in_range(&t, w, lo, hi)
}

/// A QF_BV script: declarations, premises asserted, the goal's negation asserted.
pub(super) fn script(decls: &str, premises: &[String], goal: &str) -> String {
    let mut s = String::from("(set-logic QF_BV)\n");
    s.push_str(decls);
    for p in premises {
        let _ = writeln!(s, "(assert {p})");
    }
    let _ = writeln!(s, "(assert (not {goal}))");
    s
}
