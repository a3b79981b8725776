//! The whole-program question that overflow (for claimed values and loads), inductive and
//! bit-precise property obligations share: one step of the bit-precise encoding, from any
//! state inside the ranges and invariants, with the other values' intervals as lemmas.
//!
//! Lemmas are sound because each is an obligation of its own, proved separately; each is
//! guarded by the path condition of the branch that computes the value, and only the values
//! in the cone of influence of the goal are included.

use super::cone::Cone;
use super::exact_query::Cuts;
use super::path::Paths;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;
use crate::prove::smt::{self, encode_step, in_range, resize, vname, PropEnv, StepEncoding};
use crate::prove::solver::Query;
use std::collections::{BTreeSet, HashMap};
use std::fmt::Write;

/// The label of the bit-precise encoding of the step, where an obligation is tried in
/// several.
pub const BIT_PRECISE: &str = "bit-precise";
/// The label of the bit-precise encoding with every product a cut point
/// ([`Cuts::Products`]).
pub const PRODUCTS_CUT: &str = "bit-precise, products cut";
/// The label of the bit-precise encoding with every product and every test a cut point
/// ([`Cuts::Tests`]).
pub const TESTS_CUT: &str = "bit-precise, tests cut";

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
        self.state_premises_but(false)
    }

    /// [`Step::state_premises`], without the invariants that multiply variables when
    /// `linear_only` (a weaker premise, so a proof from it still holds).
    fn state_premises_but(&self, linear_only: bool) -> Vec<String> {
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
        v.extend(
            prog.invariants
                .iter()
                .filter(|inv| !(linear_only && inv.cond.multiplies_variables()))
                .filter_map(|inv| env.cond(&inv.cond)),
        );
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

    /// Premises of the queries that assume inputs in range (properties): each input inside
    /// its declared range.
    fn input_premises(&self) -> Vec<String> {
        let plan = self.plan;
        let prog = &plan.prog;
        prog.ids_of(SigKind::Input)
            .map(|id| {
                let (lo, hi) = plan.bounds(id);
                let (t, w) = signed_view(plan, id, &smt::input_var(prog, id));
                in_range(&t, w, lo, hi)
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
        let mut premises = self.state_premises();
        if inputs_in_range {
            premises.extend(self.input_premises());
        }
        premises.extend(self.lemmas(needed, None));
        premises.extend(extra.iter().cloned());
        Query {
            script: script(&self.enc.text, &premises, goal),
            want: want.to_vec(),
        }
    }
}

impl Step<'_> {
    /// The two bit-precise queries of a goal over the step (inputs arbitrary), cheapest
    /// first: with the products cut ([`PRODUCTS_CUT`]), then whole with lemmas for `needed`
    /// ([`BIT_PRECISE`]).
    pub fn cut_then_whole(
        &self,
        needed: &BTreeSet<ValId>,
        goal: &str,
    ) -> [(Query, &'static str); 2] {
        [
            (
                self.cut_query(Cuts::Products, None, &[], goal, &self.want, false),
                PRODUCTS_CUT,
            ),
            (
                self.query(needed, &[], goal, &self.want, false),
                BIT_PRECISE,
            ),
        ]
    }

    /// A whole-step query like [`Step::query`] in which the values that `cuts` selects (but
    /// `keep`, the goal's own value) are cut points: declared, not defined, and bounded by
    /// their intervals (lemmas, each an obligation of its own; see
    /// [`super::exact_query::Cuts`]). Lemmas are added for the values the goal and premises
    /// reach through definitions that are not cut, so the script holds only what lies
    /// between the goal and the cut, not the multipliers behind it.
    pub fn cut_query(
        &self,
        cuts: Cuts,
        keep: Option<ValId>,
        extra: &[String],
        goal: &str,
        want: &[String],
        inputs_in_range: bool,
    ) -> Query {
        let plan = self.plan;
        let cut = |id: ValId| {
            let v = plan.val(id);
            Some(id) != keep
                && (!v.boolean || cuts == Cuts::Tests)
                && !matches!(v.op, Op::Input(_) | Op::Load(_) | Op::Const(_))
                && cuts.selects(plan, id)
        };
        // Definitions by name; a cut value has none.
        let mut bodies: HashMap<String, &str> = HashMap::new();
        for line in self.enc.text.lines() {
            if let Some((name, body)) = definition(line) {
                let is_cut = value_of(name).is_some_and(cut);
                if !is_cut {
                    bodies.insert(name.to_string(), body);
                }
            }
        }
        // With the products cut, an invariant that multiplies states is dropped from the
        // premises too (a weaker premise: sound), or its multipliers would be all the query
        // holds (the GAC covariance's determinant: 0.2 s to 3 s for each range of P).
        let mut premises = self.state_premises_but(matches!(cuts, Cuts::Products | Cuts::Tests));
        if inputs_in_range {
            premises.extend(self.input_premises());
        }
        premises.extend(extra.iter().cloned());
        // Lemmas for what the goal, the premises and the lemmas' own path conditions reach.
        let mut lemma_vals: BTreeSet<ValId> = BTreeSet::new();
        loop {
            let lemmas = self.lemmas(&lemma_vals, keep);
            let roots = premises.iter().chain(&lemmas).map(String::as_str);
            let reached: BTreeSet<ValId> = reach(&bodies, roots.chain([goal]))
                .iter()
                .filter_map(|n| value_of(n))
                .collect();
            if reached.is_subset(&lemma_vals) {
                premises.extend(lemmas);
                break;
            }
            lemma_vals.extend(reached);
        }
        // The step's text with each cut value declared, and only the reached ones kept.
        let mut text = String::with_capacity(self.enc.text.len());
        for line in self.enc.text.lines() {
            match definition(line).and_then(|(n, _)| value_of(n).map(|id| (n, id))) {
                Some((_, id)) if cut(id) => {
                    // A cut test is a free Boolean; a cut number ranges over its lemma.
                    let v = plan.val(id);
                    if v.boolean {
                        let _ = writeln!(text, "(declare-fun {} () Bool)", vname(id));
                    } else if lemma_vals.contains(&id) {
                        let w = v.ty.bits;
                        let _ = writeln!(text, "(declare-fun {} () (_ BitVec {w}))", vname(id));
                    }
                }
                _ => {
                    text.push_str(line);
                    text.push('\n');
                }
            }
        }
        Query {
            script: script(&text, &premises, goal),
            want: want.to_vec(),
        }
    }
}

/// The name and body of a `define-fun` line of the step's encoding.
fn definition(line: &str) -> Option<(&str, &str)> {
    line.strip_prefix("(define-fun ")?.split_once(' ')
}

/// The plan value a definition's name (`v12`) stands for.
fn value_of(name: &str) -> Option<ValId> {
    name.strip_prefix('v')?.parse().ok().map(ValId)
}

/// The names that `roots` reach through the definitions in `bodies`, the roots' own tokens
/// included.
fn reach<'a>(
    bodies: &HashMap<String, &str>,
    roots: impl Iterator<Item = &'a str>,
) -> BTreeSet<String> {
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut todo: Vec<String> = Vec::new();
    let tokens = |text: &str| -> Vec<String> {
        text.split(|c: char| c == '(' || c == ')' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    for r in roots {
        todo.extend(tokens(r));
    }
    while let Some(t) = todo.pop() {
        if seen.contains(&t) {
            continue;
        }
        if let Some(body) = bodies.get(&t) {
            todo.extend(tokens(body));
        }
        seen.insert(t);
    }
    seen
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
///
/// Only the `define-fun`s that the premises and the goal reach are kept: z3 expands every
/// definition of a script, used or not, and a step with a few dozen 64-bit products then
/// takes it most of a minute even on a query that one premise decides (a load of a state
/// against that state's range: 44 s sliced to 0.01 s on the GAC spec).
pub(super) fn script(decls: &str, premises: &[String], goal: &str) -> String {
    let mut s = String::from("(set-logic QF_BV)\n");
    s.push_str(&slice(
        decls,
        premises.iter().map(String::as_str).chain([goal]),
    ));
    for p in premises {
        let _ = writeln!(s, "(assert {p})");
    }
    let _ = writeln!(s, "(assert (not {goal}))");
    s
}

/// The lines of `decls` that the `roots` need: every line but the `define-fun`s, and those
/// `define-fun`s that the roots reach through other definitions. Definitions are one per line
/// (as `smt::encode_step` writes them); anything else is kept whole.
fn slice<'a>(decls: &str, roots: impl Iterator<Item = &'a str>) -> String {
    use std::collections::HashMap;
    let name_of = |line: &str| -> Option<String> {
        let rest = line.strip_prefix("(define-fun ")?;
        rest.split_whitespace().next().map(str::to_string)
    };
    let lines: Vec<&str> = decls.lines().collect();
    let defs: HashMap<String, usize> = lines
        .iter()
        .enumerate()
        .filter_map(|(i, l)| name_of(l).map(|n| (n, i)))
        .collect();
    let mut keep = vec![false; lines.len()];
    let mut todo: Vec<usize> = Vec::new();
    let visit = |text: &str, todo: &mut Vec<usize>, keep: &mut Vec<bool>| {
        for t in text
            .split(|c: char| c == '(' || c == ')' || c.is_whitespace())
            .filter(|t| !t.is_empty())
        {
            if let Some(&i) = defs.get(t) {
                if !keep[i] {
                    keep[i] = true;
                    todo.push(i);
                }
            }
        }
    };
    for r in roots {
        visit(r, &mut todo, &mut keep);
    }
    while let Some(i) = todo.pop() {
        // The body: what follows the defined name.
        let body = lines[i]
            .strip_prefix("(define-fun ")
            .and_then(|r| r.split_once(' '))
            .map_or("", |(_, b)| b);
        visit(body, &mut todo, &mut keep);
    }
    let mut out = String::with_capacity(decls.len());
    for (i, l) in lines.iter().enumerate() {
        if keep[i] || name_of(l).is_none() {
            out.push_str(l);
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::slice;

    #[test]
    fn slice_keeps_what_the_roots_reach_and_every_declaration() {
        let decls = "(declare-fun x () (_ BitVec 8))\n\
                     (define-fun v0 () (_ BitVec 8) x)\n\
                     (define-fun v1 () (_ BitVec 8) (bvmul v0 v0))\n\
                     (define-fun v2 () (_ BitVec 8) (bvadd v0 x))\n\
                     (define-fun v10 () (_ BitVec 8) v2)\n";
        let s = slice(decls, ["(bvsle v10 x)"].into_iter());
        assert!(s.contains("(declare-fun x"), "{s}");
        assert!(s.contains("(define-fun v0 "), "{s}");
        assert!(s.contains("(define-fun v2 "), "{s}");
        assert!(s.contains("(define-fun v10 "), "{s}");
        // v1 is unused; `v1` must not match inside `v10`.
        assert!(!s.contains("(define-fun v1 "), "{s}");
    }
}
