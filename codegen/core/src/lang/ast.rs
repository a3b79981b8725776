//! The spec's syntax tree, as parsed, with spans. Nothing here is checked yet.

use proc_macro2::Span;
use syn::{Attribute, Block, Expr, Ident, LitStr};

/// A whole `controller NAME { ... }` item.
#[derive(Clone)]
pub struct SpecAst {
    /// `///` doc lines above `controller`.
    pub docs: Vec<String>,
    /// The controller's name (snake_case; becomes the generated module name).
    pub name: Ident,
    /// Items in source order.
    pub items: Vec<Item>,
}

/// One item inside the controller's braces.
#[derive(Clone)]
pub enum Item {
    /// `period 0.1 "s";` — the sample period.
    Period {
        /// Value expression (constant).
        value: Expr,
        /// Unit string; only `"s"` and `"ms"` are accepted.
        unit: Option<LitStr>,
        /// The `period` keyword.
        span: Span,
    },
    /// `rounding floor;` or `rounding nearest;`.
    Rounding {
        /// `floor` or `nearest`.
        mode: Ident,
    },
    /// `word 16;` — default storage word width for inputs, states and outputs.
    Word {
        /// The width literal.
        bits: syn::LitInt,
    },
    /// `input`, `state` or `output` declaration.
    Signal(Box<SignalDecl>),
    /// `param` or `const` declaration.
    Constant(ConstDecl),
    /// `table NAME(x: [A, B] "unit") = EXPR, step H;` — a function of one value, sampled
    /// on a grid and interpolated linearly.
    Table(Box<TableDecl>),
    /// `step { ... }` — the update body.
    Step(Block),
    /// `tune NAME in {A, B, ..};`, `tune NAME in [LO, HI], step H;` or
    /// `tune NAME in [LO, HI], pow2;`: the candidate values of a `param` or `const` for
    /// `qloop tune`. The controller does not change: its value stays the declared one.
    Tune(Box<TuneDecl>),
    /// `rule NAME(PARAM: DEFAULT "unit", ..) on (PORT, ..) { .. }`: a safety rule, a spec
    /// fragment reused by `apply` (see [`crate::lang::rules`]).
    Rule(Box<RuleDef>),
    /// `apply NAME(PARAM = VALUE, ..) on (PORT = SIGNAL, ..) [as ALIAS];`: an instance of a
    /// rule, expanded in place by [`crate::lang::rules`].
    Apply(Box<ApplyDecl>),
    /// `use LIBRARY;`: the rules of one of qloop's rule libraries (`feed_safety`).
    Use {
        /// The library's name.
        name: Ident,
    },
    /// `prove { ... }` — invariants and step properties to prove.
    Prove {
        /// The items inside the braces.
        items: Vec<PropItem>,
        /// The `prove` keyword.
        span: Span,
    },
}

/// A `tune` item: a constant's candidate values.
#[derive(Clone)]
pub struct TuneDecl {
    /// The tuned `param` or `const`.
    pub name: Ident,
    /// The candidates.
    pub set: TuneSet,
    /// The `tune` keyword.
    pub span: Span,
}

/// The candidates of a [`TuneDecl`].
#[derive(Clone)]
pub enum TuneSet {
    /// `{A, B, ..}`: these values.
    List(Vec<Expr>),
    /// `[LO, HI], step H`: `LO, LO + H, ..` up to `HI`.
    Step(Box<RangeAst>, Box<Expr>),
    /// `[LO, HI], pow2`: every power of two in `[LO, HI]` (shift gains).
    Pow2(Box<RangeAst>),
}

/// Which kind of signal a declaration introduces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKw {
    /// `input`
    Input,
    /// `state`
    State,
    /// `output`
    Output,
}

/// `input NAME: [LO, HI] "unit";`, `state NAME: [LO, HI] "unit" = INIT;`, `output NAME ...;`,
/// and their vector and matrix forms `state theta[3]: ..`, `state P[3][3]: ..`.
#[derive(Clone)]
pub struct SignalDecl {
    /// Outer attributes: docs, `#[q(i32, 20)]`, `#[lsb(1e-3)]`.
    pub attrs: Vec<Attribute>,
    /// Declaration keyword.
    pub kind: SignalKw,
    /// The keyword's span.
    pub kw_span: Span,
    /// Signal name.
    pub name: Ident,
    /// `[N]` or `[ROWS][COLS]` after the name: a vector or matrix of signals.
    pub dims: Vec<Expr>,
    /// `[LO, HI]`, or per-element ranges `[[LO, HI], ..]` for a vector or matrix.
    pub range: Option<RangeDecl>,
    /// Physical unit, free text.
    pub unit: Option<LitStr>,
    /// `= INIT` for states (an array literal `[a, b, ..]` for a vector or matrix).
    pub init: Option<Expr>,
    /// Set by [`crate::lang::expand`] on the scalar declarations it makes from a vector's.
    pub elem: Option<crate::ir::Elem>,
}

/// A declared range: one for the signal (or for every element), or one per element.
#[derive(Clone)]
pub enum RangeDecl {
    /// `[LO, HI]`.
    One(Box<RangeAst>),
    /// `[[LO, HI], [LO, HI], ..]`, row-major (nested rows allowed), one per element.
    PerElement(syn::ExprArray),
}

/// A `[LO, HI]` range with its span.
#[derive(Clone)]
pub struct RangeAst {
    /// Lower bound expression.
    pub lo: Expr,
    /// Upper bound expression.
    pub hi: Expr,
    /// The bracket span.
    pub span: Span,
}

/// `param NAME: VALUE "unit";` or `const NAME: VALUE;`
#[derive(Clone)]
pub struct ConstDecl {
    /// Outer attributes: docs, `#[q(...)]`.
    pub attrs: Vec<Attribute>,
    /// `true` for `param` (a tunable compile-time value), `false` for `const`.
    pub is_param: bool,
    /// Name.
    pub name: Ident,
    /// Value expression (folded at compile time).
    pub value: Expr,
    /// Physical unit.
    pub unit: Option<LitStr>,
}

/// `table NAME(VAR: [A, B] "unit") = EXPR, step H, error E;`: `EXPR` (a compile-time
/// expression of `VAR`) sampled at `A, A + H, .., B` and interpolated linearly between the
/// samples; `H` a power of two; the optional `error E` claims a bound on the interpolation
/// error.
#[derive(Clone)]
pub struct TableDecl {
    /// Doc lines and attributes.
    pub attrs: Vec<Attribute>,
    /// The table's name (called as `NAME(x)` in `step`).
    pub name: Ident,
    /// The variable of `EXPR`.
    pub var: Ident,
    /// `[A, B]`.
    pub range: RangeAst,
    /// The variable's unit.
    pub unit: Option<LitStr>,
    /// The generator.
    pub value: Expr,
    /// The grid step `H`.
    pub step: Expr,
    /// The claimed interpolation error, if any.
    pub error: Option<Expr>,
}

/// One item of a `prove { .. }` block.
#[derive(Clone)]
pub enum PropItem {
    /// `invariant NAME: COND;` over the states: holds initially and after every step.
    Invariant {
        /// Doc lines.
        docs: Vec<String>,
        /// Name.
        name: Ident,
        /// The condition.
        cond: Expr,
    },
    /// `property NAME { forall P in [LO, HI] "unit"; assume COND; ensure COND; }`: a step property
    /// over pre-state (`x`), post-state (`next(x)`), inputs, outputs and free parameters.
    Property {
        /// Doc lines.
        docs: Vec<String>,
        /// Name.
        name: Ident,
        /// Free parameters, their ranges and units (`forall kp in [0.25, 6.0] "kN/(mm/s)";`).
        foralls: Vec<(Ident, RangeAst, Option<LitStr>)>,
        /// Premises.
        assumes: Vec<Expr>,
        /// Conclusions.
        ensures: Vec<Expr>,
    },
    /// `for l in A..B { items }`: the items once per `l`, each named `NAME_l` (one invariant
    /// per estimator of a stack, say); unrolled by `expand`, so no later stage sees it.
    For(Box<PropFor>),
}

/// A `for` loop over `prove` items.
#[derive(Clone)]
pub struct PropFor {
    /// The loop variable.
    pub var: Ident,
    /// The range `A..B` or `A..=B`.
    pub range: syn::ExprRange,
    /// The items of the body.
    pub items: Vec<PropItem>,
}

/// A `rule` definition: a reusable fragment of a spec (issue 18, item 4).
#[derive(Clone)]
pub struct RuleDef {
    /// Doc lines.
    pub docs: Vec<String>,
    /// The rule's name.
    pub name: Ident,
    /// Its parameters: name, default value, unit.
    pub params: Vec<RuleParam>,
    /// Its ports: names in the body bound to the host's signals by `apply`.
    pub ports: Vec<Ident>,
    /// The body's tokens (items: `const`, `state`, `output`, `table`, `pre { .. }`,
    /// `step { .. }`, `prove { .. }`), parsed per instance after renaming.
    pub body: proc_macro2::TokenStream,
    /// Whether the rule comes from a library (its spans are not the spec's).
    pub library: bool,
}

/// One parameter of a [`RuleDef`].
#[derive(Clone)]
pub struct RuleParam {
    /// Name.
    pub name: Ident,
    /// Default value, if any.
    pub default: Option<Expr>,
    /// Unit.
    pub unit: Option<LitStr>,
}

/// An `apply` item: one instance of a rule.
#[derive(Clone)]
pub struct ApplyDecl {
    /// Doc lines: what this instance is for (they document its parameters' constants).
    pub docs: Vec<String>,
    /// The rule applied.
    pub rule: Ident,
    /// `PARAM = VALUE` arguments.
    pub args: Vec<(Ident, Expr)>,
    /// `PORT = SIGNAL` bindings.
    pub ports: Vec<(Ident, Ident)>,
    /// `as ALIAS`: the instance's name (default: the rule's).
    pub alias: Option<Ident>,
    /// The `apply` keyword.
    pub span: Span,
}
