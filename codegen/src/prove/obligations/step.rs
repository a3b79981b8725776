//! The whole-program question that overflow (for claimed values and loads), inductive and
//! bit-precise property obligations share: one step of the bit-precise encoding, from any
//! state inside the ranges and invariants, with the other values' intervals as lemmas.
//!
//! Lemmas are sound because each is an obligation of its own, proved separately; each is
//! guarded by the path condition of the branch that computes the value, and only the values
//! in the cone of influence of the goal are included.

use super::cone::Cone;
use super::exact_query::{Cuts, Side};
use super::path::Paths;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;
use crate::prove::exact;
use crate::prove::smt::{self, encode_step, in_range, resize, vname, PropEnv, StepEncoding};
use crate::prove::solver::Query;
use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::fmt::Write;
use std::rc::Rc;

/// The label of the bit-precise encoding of the step, where an obligation is tried in
/// several.
pub const BIT_PRECISE: &str = "bit-precise";
/// The label of the bit-precise encoding with every product a cut point
/// ([`Cuts::Products`]).
pub const PRODUCTS_CUT: &str = "bit-precise, products cut";
/// The label of the bit-precise encoding with every product and every test a cut point
/// ([`Cuts::Tests`]).
pub const TESTS_CUT: &str = "bit-precise, tests cut";
/// The label of the bit-precise encoding of a value's linear cone ([`Cuts::NonLinear`]).
pub const LINEAR_CONE: &str = "bit-precise, linear cone";

/// The placeholder of a deferred query: no script, no model.
pub(super) fn deferred_query() -> Query {
    Query {
        script: String::new(),
        want: Vec::new(),
    }
}

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
    /// The encoding's lines, indexed once for every query's slicing.
    pub decls: Decls,
    /// The plan's exact terms per side and cuts, built on first use (`exact_query`).
    pub terms: RefCell<HashMap<(Side, Cuts), Rc<exact::Terms>>>,
    /// The cut lines of each kind of cut, built on first use ([`Step::cut_lines`]).
    cuts: RefCell<HashMap<Cuts, Rc<HashMap<usize, String>>>>,
    /// [`Step::build_premises`] for `false` and `true`, built and indexed once.
    premises: [PlainSet; 2],
    /// Each value's lemma ([`Step::lemmas`]), built once.
    lemma_text: Vec<Option<String>>,
    /// Whether the whole-step fallbacks ([`BIT_PRECISE`]) of goals that have a cheaper
    /// encoding are left out, as [`super::Obligation::deferred`] placeholders: they are
    /// most of a big controller's script text and are asked only where the cheaper
    /// encodings did not prove the goal ([`super::whole_query`]).
    pub defer_whole: bool,
}

impl<'a> Step<'a> {
    /// Encodes the step of `plan` and the facts its queries draw on.
    pub fn new(plan: &'a Plan) -> Self {
        let enc = encode_step(plan);
        let mut step = Step {
            plan,
            decls: Decls::of(&enc.text),
            terms: RefCell::new(HashMap::new()),
            cuts: RefCell::new(HashMap::new()),
            premises: [
                PlainSet::of(&Decls::of(""), Vec::new()),
                PlainSet::of(&Decls::of(""), Vec::new()),
            ],
            lemma_text: Vec::new(),
            enc,
            paths: Paths::of(plan),
            cone: Cone::of(plan, true),
            want: step_vars(plan),
            defer_whole: false,
        };
        step.premises = [
            PlainSet::of(&step.decls, step.build_premises(false)),
            PlainSet::of(&step.decls, step.build_premises(true)),
        ];
        step.lemma_text = step.build_lemmas();
        step
    }

    /// Premises of every whole-step query: states inside their ranges and the invariants;
    /// without the invariants that multiply variables when `linear_only` (a weaker premise,
    /// so a proof from it still holds).
    fn build_premises(&self, linear_only: bool) -> Vec<String> {
        let plan = self.plan;
        let prog = &plan.prog;
        let mut v: Vec<String> = prog
            .ids_of(SigKind::State)
            .map(|id| state_bound(plan, id, &smt::pre_var(prog, id)))
            .collect();
        let env = PropEnv::invariants(plan, &self.enc.post, false);
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
        needed
            .iter()
            .filter(|&&id| Some(id) != skip)
            .filter_map(|id| self.lemma_text.get(id.0).cloned().flatten())
            .collect()
    }

    /// The lemma of each value (none for Booleans and inputs), built once.
    fn build_lemmas(&self) -> Vec<Option<String>> {
        self.plan
            .vals
            .iter()
            .enumerate()
            .map(|(i, v)| {
                if v.boolean || matches!(v.op, Op::Input(_)) {
                    return None;
                }
                let (t, w) = if v.ty.signed {
                    (vname(ValId(i)), v.ty.bits)
                } else {
                    (
                        resize(&vname(ValId(i)), v.ty.bits, v.ty.bits + 1, false),
                        v.ty.bits + 1,
                    )
                };
                Some(self.paths.guard(ValId(i), in_range(&t, w, v.lo, v.hi)))
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

    /// The lines of the step's encoding that `cuts` makes cut points, each with the
    /// declaration that replaces its definition (a free Boolean for a test, a number that its
    /// lemma bounds otherwise); built once per kind of cut.
    fn cut_lines(&self, cuts: Cuts) -> Rc<HashMap<usize, String>> {
        let plan = self.plan;
        self.cuts
            .borrow_mut()
            .entry(cuts)
            .or_insert_with(|| {
                let mut lines = HashMap::new();
                for (i, v) in plan.vals.iter().enumerate() {
                    let id = ValId(i);
                    let selected = (!v.boolean || matches!(cuts, Cuts::Tests | Cuts::NonLinear))
                        && !matches!(v.op, Op::Input(_) | Op::Load(_) | Op::Const(_))
                        && cuts.selects(plan, id);
                    if !selected {
                        continue;
                    }
                    if let Some(&line) = self.decls.index.get(&vname(id)) {
                        let sort = if v.boolean {
                            "Bool".to_string()
                        } else {
                            format!("(_ BitVec {})", v.ty.bits)
                        };
                        lines.insert(line, format!("(declare-fun {} () {sort})", vname(id)));
                    }
                }
                Rc::new(lines)
            })
            .clone()
    }

    /// A whole-step query over the step's encoding with exactly these premises.
    pub fn query_whole(&self, premises: &[String], goal: &str, want: &[String]) -> Query {
        query_in(&self.decls, &Cut::NONE, None, premises, goal, want)
    }

    /// [`Step::query_whole`] with the state premises ([`Step::build_premises`]) too.
    pub fn query_with_states(&self, premises: &[String], goal: &str, want: &[String]) -> Query {
        query_in(
            &self.decls,
            &Cut::NONE,
            Some(&self.premises[0]),
            premises,
            goal,
            want,
        )
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
        let mut premises = Vec::new();
        if inputs_in_range {
            premises.extend(self.input_premises());
        }
        premises.extend(self.lemmas(needed, None));
        premises.extend(extra.iter().cloned());
        self.query_with_states(&premises, goal, want)
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
            (self.whole(needed, goal), BIT_PRECISE),
        ]
    }

    /// The whole-step query of `goal` with lemmas for `needed` ([`BIT_PRECISE`]), or, when
    /// the fallbacks are deferred, an empty placeholder.
    pub fn whole(&self, needed: &BTreeSet<ValId>, goal: &str) -> Query {
        if self.defer_whole {
            deferred_query()
        } else {
            self.query(needed, &[], goal, &self.want, false)
        }
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
        let d = &self.decls;
        let lines = self.cut_lines(cuts);
        let cut_lines = Cut {
            lines: Some(&lines),
            except: keep.and_then(|id| d.index.get(&vname(id)).copied()),
        };
        // With the products cut, an invariant that multiplies states is dropped from the
        // premises too (a weaker premise: sound), or its multipliers would be all the query
        // holds (the GAC covariance's determinant: 0.2 s to 3 s for each range of P).
        let states = &self.premises[usize::from(cuts != Cuts::None && cuts != Cuts::Lets)];
        let mut premises = Vec::new();
        if inputs_in_range {
            premises.extend(self.input_premises());
        }
        premises.extend(extra.iter().cloned());
        // Lemmas for what the goal, the premises and the lemmas' own path conditions reach.
        let mut lemma_vals: BTreeSet<ValId> = BTreeSet::new();
        loop {
            let lemmas = self.lemmas(&lemma_vals, keep);
            let roots = premises.iter().chain(&lemmas).map(String::as_str);
            let reached: BTreeSet<ValId> = d
                .reach(&cut_lines, roots.chain([goal]))
                .into_iter()
                .filter_map(|i| d.name(i).and_then(value_of))
                .filter(|&id| !plan.val(id).boolean)
                .collect();
            if reached.is_subset(&lemma_vals) {
                premises.extend(lemmas);
                break;
            }
            lemma_vals.extend(reached);
        }
        query_in(d, &cut_lines, Some(states), &premises, goal, want)
    }
}

/// The plan value a definition's name (`v12`) stands for.
fn value_of(name: &str) -> Option<ValId> {
    name.strip_prefix('v')?.parse().ok().map(ValId)
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

/// The lines a query keeps: a bitmap and the list of marked lines, in marking order.
struct Kept {
    on: Vec<bool>,
    list: Vec<usize>,
}

impl Kept {
    fn new(n: usize) -> Kept {
        Kept {
            on: vec![false; n],
            list: Vec::new(),
        }
    }

    fn mark(&mut self, i: usize) {
        if !self.on[i] {
            self.on[i] = true;
            self.list.push(i);
        }
    }
}

/// Premises over the pre-state only (ranges and invariants), with the lines each mentions,
/// indexed once per step: a query keeps those that bear on its goal ([`script_in`]).
pub(super) struct PlainSet {
    texts: Vec<String>,
    mentions: Vec<Vec<usize>>,
}

impl PlainSet {
    fn of(d: &Decls, texts: Vec<String>) -> PlainSet {
        let mentions = texts
            .iter()
            .map(|t| {
                sexp_tokens(t)
                    .filter_map(|x| d.index.get(x).copied())
                    .collect()
            })
            .collect();
        PlainSet { texts, mentions }
    }
}

/// Lines of [`Decls`] that a query replaces by declarations (cut points), but `except`.
pub(super) struct Cut<'a> {
    lines: Option<&'a HashMap<usize, String>>,
    except: Option<usize>,
}

impl<'a> Cut<'a> {
    /// No cut.
    const NONE: Cut<'static> = Cut {
        lines: None,
        except: None,
    };

    /// The declaration that replaces line `i`, if it is cut.
    fn get(&self, i: usize) -> Option<&'a String> {
        if Some(i) == self.except {
            return None;
        }
        self.lines?.get(&i)
    }
}

/// The lines of a script's declarations, indexed: the name each `define-fun` and
/// `declare-fun` line introduces, and for each definition the lines its body mentions. The
/// step's encoding is indexed once ([`Step::decls`]) and sliced for each of its queries.
pub(super) struct Decls {
    lines: Vec<String>,
    /// Name → line, for `define-fun` and `declare-fun` lines.
    index: HashMap<String, usize>,
    /// The names, by line (`None`: a line kept as it is).
    names: Vec<Option<String>>,
    /// For each `define-fun` line: the lines its body mentions.
    refs: Vec<Vec<usize>>,
    /// The lines that name nothing (options, comments), kept in every script.
    unnamed: Vec<usize>,
}

impl Decls {
    /// Indexes `text`, one declaration or definition per line.
    pub fn of(text: &str) -> Decls {
        let lines: Vec<String> = text.lines().map(String::from).collect();
        let names: Vec<Option<String>> = lines
            .iter()
            .map(|l| {
                defined_name(l, "(define-fun ")
                    .or_else(|| defined_name(l, "(declare-fun "))
                    .map(String::from)
            })
            .collect();
        let index: HashMap<String, usize> = names
            .iter()
            .enumerate()
            .filter_map(|(i, n)| n.clone().map(|n| (n, i)))
            .collect();
        let refs = lines
            .iter()
            .map(|l| {
                match l
                    .strip_prefix("(define-fun ")
                    .and_then(|r| r.split_once(' '))
                {
                    Some((_, body)) => sexp_tokens(body)
                        .filter_map(|t| index.get(t).copied())
                        .collect(),
                    None => Vec::new(),
                }
            })
            .collect();
        let unnamed = (0..lines.len()).filter(|&i| names[i].is_none()).collect();
        Decls {
            lines,
            index,
            names,
            refs,
            unnamed,
        }
    }

    /// The name line `i` introduces.
    fn name(&self, i: usize) -> Option<&str> {
        self.names.get(i)?.as_deref()
    }

    /// The lines that `roots` reach through the definitions (a `cut` line is a declaration:
    /// its definition is not followed).
    fn reach<'a>(&self, cut: &Cut, roots: impl Iterator<Item = &'a str>) -> Vec<usize> {
        let mut keep = Kept::new(self.lines.len());
        for r in roots {
            self.visit(r, cut, &mut keep);
        }
        keep.list
    }

    /// Marks in `keep` the lines `text` reaches.
    fn visit(&self, text: &str, cut: &Cut, keep: &mut Kept) {
        let from = keep.list.len();
        for t in sexp_tokens(text) {
            if let Some(&i) = self.index.get(t) {
                keep.mark(i);
            }
        }
        self.close(cut, keep, from);
    }

    /// Follows the definitions of the lines marked from position `from` of `keep`'s list.
    fn close(&self, cut: &Cut, keep: &mut Kept, mut from: usize) {
        while from < keep.list.len() {
            let i = keep.list[from];
            from += 1;
            if cut.get(i).is_some() {
                continue;
            }
            for &j in &self.refs[i] {
                keep.mark(j);
            }
        }
    }
}

/// A query of `script`, asking on `sat` for the values of those `want` variables that the
/// script still declares (the others do not bear on the goal; a replay takes their initial
/// value, which meets every premise left out with them).
/// Every premise here must be one that the initial state meets, such as a range of a
/// state or its initial value: those that do not bear on the goal are left out.
pub(super) fn query_of(decls: &str, premises: &[String], goal: &str, want: &[String]) -> Query {
    let d = Decls::of(decls);
    let states = PlainSet::of(&d, premises.to_vec());
    query_in(&d, &Cut::NONE, Some(&states), &[], goal, want)
}

/// [`query_of`] over indexed declarations, the `cut` lines replaced by their declarations.
fn query_in(
    d: &Decls,
    cut: &Cut,
    states: Option<&PlainSet>,
    premises: &[String],
    goal: &str,
    want: &[String],
) -> Query {
    let script = script_in(d, cut, states, premises, goal);
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
/// * of the state premises (ranges and invariants of the pre-state, or initial values),
///   those that share a variable with the goal, the other premises, or a premise kept so far
///   (to a fixed point): the rest constrain variables that nothing kept mentions, and since
///   each holds of the initial state they are jointly satisfiable, so leaving them out changes
///   no verdict. Other premises (assumptions, input ranges, lemmas) are always kept. A controller with seven estimators then asks about one
///   estimator without the other six's covariance invariants, and the queries of its copies
///   become identical up to names (`solver/dedup.rs`);
/// * the declarations of the variables kept.
#[cfg(test)]
fn script(decls: &str, premises: &[String], goal: &str) -> String {
    let d = Decls::of(decls);
    let states = PlainSet::of(&d, premises.to_vec());
    script_in(&d, &Cut::NONE, Some(&states), &[], goal)
}

/// [`script`] over indexed declarations, the `cut` lines replaced by their declarations.
fn script_in(
    d: &Decls,
    cut: &Cut,
    states: Option<&PlainSet>,
    premises: &[String],
    goal: &str,
) -> String {
    let mut keep = Kept::new(d.lines.len());
    // The premises over declared variables only (after the cuts) as their mentions: those of
    // `states` indexed already, those of `premises` here; the rest are kept whole.
    let empty = PlainSet {
        texts: Vec::new(),
        mentions: Vec::new(),
    };
    let states = states.unwrap_or(&empty);
    let mut mentions: Vec<&[usize]> = states.mentions.iter().map(Vec::as_slice).collect();
    let mut texts: Vec<&str> = states.texts.iter().map(String::as_str).collect();
    let own: Vec<Vec<usize>> = premises
        .iter()
        .map(|p| {
            sexp_tokens(p)
                .filter_map(|t| d.index.get(t).copied())
                .collect()
        })
        .collect();
    // The state premises are kept when they bear on the goal; every other premise always
    // (an assumption or an input range may be what makes the query unsatisfiable: a
    // vacuity check asks exactly that).
    let mut taken: Vec<bool> = vec![false; texts.len()];
    for (p, m) in premises.iter().zip(&own) {
        texts.push(p);
        mentions.push(m);
        taken.push(true);
    }
    d.visit(goal, cut, &mut keep);
    for (k, m) in mentions.iter().enumerate() {
        if taken[k] {
            let from = keep.list.len();
            m.iter().for_each(|&i| keep.mark(i));
            d.close(cut, &mut keep, from);
        }
    }
    loop {
        let mut grew = false;
        for (k, m) in mentions.iter().enumerate() {
            if taken[k] {
                continue;
            }
            if m.is_empty() || m.iter().any(|&i| keep.on[i]) {
                taken[k] = true;
                let from = keep.list.len();
                m.iter().for_each(|&i| keep.mark(i));
                d.close(cut, &mut keep, from);
                grew = true;
            }
        }
        if !grew {
            break;
        }
    }
    // The kept lines and every line that names nothing, in the declarations' order.
    let mut lines: Vec<usize> = keep.list;
    lines.extend(d.unnamed.iter().copied());
    lines.sort_unstable();
    let mut s = String::from("(set-logic QF_BV)\n");
    for i in lines {
        s.push_str(cut.get(i).map_or(d.lines[i].as_str(), String::as_str));
        s.push('\n');
    }
    for (p, _) in texts.iter().zip(&taken).filter(|(_, t)| **t) {
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

    #[test]
    fn premises_that_are_not_state_premises_are_always_kept() {
        // An assumption on w alone may be unsatisfiable: a vacuity check must see it.
        let d = super::Decls::of(DECLS);
        let states = super::PlainSet::of(&d, vec!["(bvult w #x03)".to_string()]);
        let q = super::query_in(
            &d,
            &super::Cut::NONE,
            Some(&states),
            &["(bvult w #x00)".to_string()],
            "(bvsle v10 x)",
            &[],
        );
        assert!(q.script.contains("(assert (bvult w #x00))"), "{}", q.script);
        // With w now in the query, its state premise bears on it too.
        assert!(q.script.contains("(assert (bvult w #x03))"), "{}", q.script);
    }
}
