//! The proof obligations of a plan, each a complete SMT-LIB script whose satisfiability means a
//! counterexample. One module per kind:
//!
//! * **overflow** ([`overflow`]): every plan value stays inside the interval the range
//!   analysis assigned to it, which lies inside its machine type: locally (operands free in
//!   their intervals) for derived values, over the whole program for claims and loads.
//! * **initial** (`initial`): the initial state is inside the state ranges and satisfies the
//!   invariants.
//! * **inductive** (`inductive`): one step from any state inside the ranges and invariants,
//!   with any input bits, lands inside them again. With (initial) this proves the ranges and
//!   invariants for every reachable state, for unbounded time.
//! * **property** (`property`): each step property, for all inputs in range, states in the
//!   invariants and free parameters in range.
//!
//! What they share: the whole-program step query with its lemmas (`step`), exact-term
//! queries in several encodings (`exact_query`), the cone of influence (`cone`) and the
//! typed path conditions (`path`). Whole-program obligations assume the other values'
//! intervals as lemmas (each guarded by the path condition of the branch that computes it):
//! sound because each lemma is an obligation of its own, proved separately.

pub(crate) mod cone;
mod exact_query;
mod inductive;
mod initial;
pub mod overflow;
mod path;
mod property;
mod step;

pub use crate::prop_eval::{param_grids, ParamGrid};
pub use exact_query::{ExactEncoding, ABSTRACT_BV, EXACT_BV, INTEGER, LINEAR};
pub use overflow::global_for;

use super::solver::Query;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::ValId;
use crate::lower::Plan;
use step::Step;

/// What kind of obligation, as in the JSON report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    /// No value leaves its interval / width.
    Overflow,
    /// The initial state satisfies the ranges and invariants.
    Initial,
    /// The ranges and invariants are preserved by one step.
    Inductive,
    /// A user step property.
    Property,
    /// A table's claimed interpolation error (`table .., error E;`), decided by qloop's own
    /// analysis: no SMT solver evaluates `exp` or `ln`.
    Table,
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

impl Obligation {
    /// Whether a solver decides it in about a millisecond, so that it may share a solver
    /// process with others ([`crate::prove::solver::run_all_batched`]): a local overflow
    /// query (its operands free in their intervals), but for the bit-vector form of a
    /// product, and an initial-state query (the state fixed to constants).
    pub fn small(&self) -> bool {
        match (&self.goal, self.kind) {
            (Goal::Val { local: true, .. }, _) => self.encoding != Some(overflow::BIT_VECTOR),
            (_, Kind::Initial) => true,
            _ => false,
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
            Kind::Table => "table",
        }
    }
}

/// What a counterexample must show when replayed.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
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
    /// Table `i`'s claimed interpolation error is exceeded.
    Table(usize),
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

/// Builds every obligation of the plan.
pub fn obligations(plan: &Plan) -> Vec<Obligation> {
    with_witnesses(plan).0
}

impl Obligation {
    /// Whether this is a deferred whole-step fallback ([`with_witnesses_staged`]): a
    /// placeholder with no script, asked (its query made by [`whole_query`]) only where the
    /// goal's other encodings did not prove it. Every real query has a script.
    pub fn deferred(&self) -> bool {
        self.encoding == Some(step::BIT_PRECISE) && self.query.script.is_empty()
    }
}

/// The whole-step fallback (the `bit-precise` encoding) of a deferred obligation's goal, made
/// as [`with_witnesses`] makes it; `None` for a goal that has none.
pub fn whole_query(step: &WholeStep, goal: &Goal, kind: Kind) -> Option<Query> {
    let step = &step.0;
    match (kind, goal) {
        (Kind::Overflow, Goal::Val { val, .. }) => Some(overflow::global_val_query(step, *val)),
        (Kind::Inductive, Goal::StateBound(id)) => Some(inductive::state_range_whole(step, *id)),
        (Kind::Inductive, Goal::Invariant(k)) => inductive::invariant_whole(step, *k),
        (Kind::Property, Goal::Property(k)) => {
            property::direct_query(step, *k, false, exact_query::Cuts::None)
        }
        _ => None,
    }
}

/// The shared encoding of a plan's step, for [`whole_query`] (built once: it encodes the
/// whole step bit for bit).
pub struct WholeStep<'a>(Step<'a>);

impl<'a> WholeStep<'a> {
    /// Encodes the step of `plan`.
    pub fn new(plan: &'a Plan) -> Self {
        WholeStep(Step::new(plan))
    }
}

/// Every obligation of the plan, and per property a bit-precise query whose models are
/// states, inputs and parameters meeting its premises (state ranges, invariants, input
/// ranges, `assume`s): `unsat` there means the property holds vacuously.
///
/// The order is the report's: overflow per value; per state, initial then inductive; per
/// invariant, initial then inductive (each encoding); per property, each encoding.
pub fn with_witnesses(plan: &Plan) -> (Vec<Obligation>, Vec<Option<Query>>) {
    with_witnesses_staged(plan, false)
}

/// [`with_witnesses`], with the whole-step fallbacks of goals that have cheaper encodings
/// left as [`Obligation::deferred`] placeholders when `defer` is set.
pub fn with_witnesses_staged(plan: &Plan, defer: bool) -> (Vec<Obligation>, Vec<Option<Query>>) {
    let prog = &plan.prog;
    let mut step = Step::new(plan);
    step.defer_whole = defer;
    let mut out = overflow::obligations(&step);
    for id in prog.ids_of(SigKind::State) {
        out.push(initial::state_range(plan, id));
        out.extend(inductive::state_range(&step, id));
    }
    for k in 0..prog.invariants.len() {
        out.extend(initial::invariant(&step, k));
        out.extend(inductive::invariant(&step, k));
    }
    for k in 0..prog.properties.len() {
        out.extend(property::portfolio(&step, k));
    }
    let witnesses = (0..prog.properties.len())
        .map(|k| property::witness(&step, k))
        .collect();
    (out, witnesses)
}
