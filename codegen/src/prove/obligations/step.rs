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
use std::collections::{BTreeSet, HashMap, HashSet};
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
        query_of(&self.enc.text, &premises, goal, want)
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
        query_of(&text, &premises, goal, want)
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

/// A query of `script`, asking on `sat` for the values of those `want` variables that the
/// script still declares (the others do not bear on the goal; a replay takes their initial
/// value, which meets every premise left out with them).
pub(super) fn query_of(decls: &str, premises: &[String], goal: &str, want: &[String]) -> Query {
    let script = script(decls, premises, goal);
    let declared: HashSet<&str> = script
        .lines()
        .filter_map(|l| l.strip_prefix("(declare-fun ")?.split_whitespace().next())
        .collect();
    let want = want
        .iter()
        .filter(|w| declared.contains(w.as_str()))
        .cloned()
        .collect();
    Query { script, want }
}

/// A QF_BV script: declarations, premises asserted, the goal's negation asserted.
///
/// Only what bears on the goal is kept:
/// * the `define-fun`s that the goal and the kept premises reach: z3 expands every definition
///   of a script, used or not, and a step with a few dozen 64-bit products then takes it most
///   of a minute even on a query that one premise decides (a load of a state against that
///   state's range: 44 s sliced to 0.01 s on the GAC spec);
/// * of the premises over declared variables only (ranges and invariants of the pre-state),
///   those that share a variable with the goal, the other premises, or a premise kept so far
///   (to a fixed point): the rest constrain variables that nothing kept mentions, and since
///   every premise holds of the initial state they are jointly satisfiable, so leaving them
///   out changes no verdict. A controller with seven estimators then asks about one
///   estimator without the other six's covariance invariants, and the queries of its copies
///   become identical up to names (`solver/dedup.rs`);
/// * the declarations of the variables kept.
pub(super) fn script(decls: &str, premises: &[String], goal: &str) -> String {
    let lines: Vec<&str> = decls.lines().collect();
    let mut defs: HashMap<&str, usize> = HashMap::new();
    let mut vars: HashMap<&str, usize> = HashMap::new();
    for (i, l) in lines.iter().enumerate() {
        if let Some(n) = defined_name(l, "(define-fun ") {
            defs.insert(n, i);
        } else if let Some(n) = defined_name(l, "(declare-fun ") {
            vars.insert(n, i);
        }
    }
    let mut keep = vec![false; lines.len()];
    // Marks what `text` reaches through the definitions: kept lines, declared variables.
    let visit = |text: &str, keep: &mut Vec<bool>| {
        let mut todo: Vec<usize> = Vec::new();
        let mark = |t: &str, keep: &mut Vec<bool>, todo: &mut Vec<usize>| {
            if let Some(&i) = defs.get(t).or_else(|| vars.get(t)) {
                if !keep[i] {
                    keep[i] = true;
                    todo.push(i);
                }
            }
        };
        for t in sexp_tokens(text) {
            mark(t, keep, &mut todo);
        }
        while let Some(i) = todo.pop() {
            if let Some(body) = lines[i]
                .strip_prefix("(define-fun ")
                .and_then(|r| r.split_once(' '))
                .map(|(_, b)| b)
            {
                for t in sexp_tokens(body) {
                    mark(t, keep, &mut todo);
                }
            }
        }
    };
    // Premises over declared variables only, and the rest (kept whole).
    let plain: Vec<bool> = premises
        .iter()
        .map(|p| sexp_tokens(p).all(|t| !defs.contains_key(t)))
        .collect();
    let mut taken: Vec<bool> = plain.iter().map(|p| !p).collect();
    visit(goal, &mut keep);
    for (p, _) in premises.iter().zip(&taken).filter(|(_, t)| **t) {
        visit(p, &mut keep);
    }
    loop {
        let mut grew = false;
        for (k, p) in premises.iter().enumerate() {
            if taken[k] {
                continue;
            }
            let mut its_vars = sexp_tokens(p).filter_map(|t| vars.get(t)).peekable();
            let relevant = its_vars.peek().is_none() || its_vars.any(|&i| keep[i]);
            if relevant {
                taken[k] = true;
                visit(p, &mut keep);
                grew = true;
            }
        }
        if !grew {
            break;
        }
    }
    let mut named = vec![false; lines.len()];
    for &i in defs.values().chain(vars.values()) {
        named[i] = true;
    }
    let mut s = String::from("(set-logic QF_BV)\n");
    for (i, l) in lines.iter().enumerate() {
        if keep[i] || !named[i] {
            s.push_str(l);
            s.push('\n');
        }
    }
    for (p, _) in premises.iter().zip(&taken).filter(|(_, t)| **t) {
        let _ = writeln!(s, "(assert {p})");
    }
    let _ = writeln!(s, "(assert (not {goal}))");
    s
}

/// The name a `define-fun`/`declare-fun` line (as `prefix` says) defines or declares.
fn defined_name<'a>(line: &'a str, prefix: &str) -> Option<&'a str> {
    line.strip_prefix(prefix)?.split_whitespace().next()
}

/// The atoms of an S-expression text (no parentheses, no whitespace).
fn sexp_tokens(text: &str) -> impl Iterator<Item = &str> {
    text.split(|c: char| c == '(' || c == ')' || c.is_whitespace())
        .filter(|t| !t.is_empty())
}

#[cfg(test)]
mod tests {
    use super::{query_of, script};

    const DECLS: &str = "(declare-fun x () (_ BitVec 8))\n\
                         (declare-fun y () (_ BitVec 8))\n\
                         (declare-fun z () (_ BitVec 8))\n\
                         (declare-fun w () (_ BitVec 8))\n\
                         (define-fun v0 () (_ BitVec 8) x)\n\
                         (define-fun v1 () (_ BitVec 8) (bvmul v0 v0))\n\
                         (define-fun v2 () (_ BitVec 8) (bvadd v0 x))\n\
                         (define-fun v10 () (_ BitVec 8) v2)\n";

    #[test]
    fn a_script_keeps_what_the_goal_reaches() {
        let s = script(DECLS, &[], "(bvsle v10 x)");
        assert!(s.contains("(declare-fun x"), "{s}");
        assert!(s.contains("(define-fun v0 "), "{s}");
        assert!(s.contains("(define-fun v2 "), "{s}");
        assert!(s.contains("(define-fun v10 "), "{s}");
        // v1 is unused; `v1` must not match inside `v10`. Nor is y, z or w.
        assert!(!s.contains("(define-fun v1 "), "{s}");
        assert!(!s.contains("(declare-fun y"), "{s}");
    }

    #[test]
    fn premises_are_kept_when_they_reach_the_goal_through_each_other() {
        // x ~ y (the goal), y ~ z (through the premise on both), w alone: w's premise goes.
        let premises = [
            "(bvult z #x05)".to_string(),
            "(bvult y z)".to_string(),
            "(bvult w #x03)".to_string(),
            "(bvule v0 y)".to_string(),
            "true".to_string(),
        ];
        let want: Vec<String> = ["x", "y", "z", "w"].map(String::from).to_vec();
        let q = query_of(DECLS, &premises, "(bvsle v10 x)", &want);
        for kept in [
            "(assert (bvult z #x05))",
            "(assert (bvult y z))",
            "(assert (bvule v0 y))",
            "(assert true)",
        ] {
            assert!(q.script.contains(kept), "{kept}: {}", q.script);
        }
        assert!(!q.script.contains("bvult w"), "{}", q.script);
        assert!(!q.script.contains("(declare-fun w"), "{}", q.script);
        assert_eq!(q.want, ["x", "y", "z"]);
    }
}
