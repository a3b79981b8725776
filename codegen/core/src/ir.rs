//! The checked intermediate representation: names resolved, constants folded, real-valued.
//!
//! The IR says *what* a controller computes, in real arithmetic; the fixed-point plan
//! ([`crate::lower`]) says *how*. Signals live in one table indexed by [`SigId`]; every signal
//! has a [`Shape`], so vector and matrix states (RLS estimators) extend the table, not the
//! statement forms, and table look-ups become one more [`Expr`] variant.

use crate::qformat::{QFormat, Rounding};
use proc_macro2::Span;

/// Index into [`Program::signals`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SigId(pub usize);

/// A checked controller.
#[derive(Clone, Debug)]
pub struct Program {
    /// Name, snake_case.
    pub name: String,
    /// Doc lines.
    pub docs: Vec<String>,
    /// Sample period in seconds.
    pub period: f64,
    /// Rounding for every right shift that drops fraction bits.
    pub rounding: Rounding,
    /// Default storage word width.
    pub word: u32,
    /// Folded `param` and `const` values, in declaration order.
    pub constants: Vec<Constant>,
    /// Inputs, states, outputs and `let` locals.
    pub signals: Vec<Signal>,
    /// The update body.
    pub body: Vec<Stmt>,
    /// Invariants over the states (`prove { invariant .. }`).
    pub invariants: Vec<Invariant>,
    /// Step properties (`prove { property .. }`).
    pub properties: Vec<Property>,
}

impl Program {
    /// The signal with id `id`.
    pub fn sig(&self, id: SigId) -> &Signal {
        &self.signals[id.0]
    }

    /// Ids of all signals of one kind, in declaration order.
    pub fn ids_of(&self, kind: SigKind) -> impl Iterator<Item = SigId> + '_ {
        self.signals
            .iter()
            .enumerate()
            .filter(move |(_, s)| s.kind == kind)
            .map(|(i, _)| SigId(i))
    }
}

/// A named compile-time value.
#[derive(Clone, Debug)]
pub struct Constant {
    /// Name.
    pub name: String,
    /// `param` (tunable) rather than `const`.
    pub is_param: bool,
    /// Folded value.
    pub value: f64,
    /// Unit.
    pub unit: Option<String>,
    /// Doc lines.
    pub docs: Vec<String>,
    /// `#[reference]`: the set point the loop holds (closed-loop runs measure against it).
    pub reference: bool,
    /// `#[nominal]`: the nominal feed a dimensionless (override) output multiplies.
    pub nominal: bool,
}

/// Role of a signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SigKind {
    /// Read once per step, clamped to its range on entry.
    Input,
    /// Persists across steps; saturates to its range on every write.
    State,
    /// Returned by `step`.
    Output,
    /// A `let` binding inside `step`.
    Local,
}

/// Shape of a signal's value. Only scalars exist today; vectors and matrices (RLS
/// covariance, regressors) are added here with element-wise formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// One value.
    Scalar,
}

/// One signal.
#[derive(Clone, Debug)]
pub struct Signal {
    /// Name as written.
    pub name: String,
    /// Role.
    pub kind: SigKind,
    /// Shape.
    pub shape: Shape,
    /// Declared physical range (inputs, states; optional for outputs; none for locals).
    pub range: Option<(f64, f64)>,
    /// Initial value (states).
    pub init: Option<f64>,
    /// Unit text.
    pub unit: Option<String>,
    /// User-pinned format, `#[q(i32, 20)]`.
    pub pin: Option<QFormat>,
    /// Requested resolution, `#[lsb(1e-3)]`: the format must have LSB ≤ this.
    pub lsb: Option<f64>,
    /// A claimed range, `#[range(LO, HI)]` on a `let`: trusted when sizing the computation,
    /// and an obligation for the prover.
    pub claim: Option<(f64, f64)>,
    /// `#[unsaturated]` on a state: stores do not clamp; the range is an obligation instead.
    pub unsaturated: bool,
    /// Doc lines.
    pub docs: Vec<String>,
    /// Declaration site.
    pub span: Span,
}

/// A statement of the body.
#[derive(Clone, Debug)]
pub enum Stmt {
    /// `target = value`. For states the value is rounded and saturated to the state's range;
    /// for locals this is the single `let` definition.
    Assign {
        /// Written signal.
        target: SigId,
        /// New value.
        value: Expr,
        /// Statement site.
        span: Span,
    },
    /// `if cond { then } else { els }`.
    If {
        /// Condition.
        cond: Cond,
        /// Then branch.
        then: Vec<Stmt>,
        /// Else branch (possibly empty).
        els: Vec<Stmt>,
    },
}

/// A real-valued expression.
#[derive(Clone, Debug)]
pub enum Expr {
    /// A folded constant; `name` if it came from a `param`/`const`.
    Const {
        /// Value.
        value: f64,
        /// Source name, if any.
        name: Option<String>,
        /// Site.
        span: Span,
    },
    /// Read of a signal's current value.
    Var(SigId, Span),
    /// `-a`
    Neg(Box<Expr>),
    /// `a + b`
    Add(Box<Expr>, Box<Expr>),
    /// `a - b`
    Sub(Box<Expr>, Box<Expr>),
    /// `a * b`
    Mul(Box<Expr>, Box<Expr>, Span),
    /// `min(a, b)`
    Min(Box<Expr>, Box<Expr>),
    /// `max(a, b)`
    Max(Box<Expr>, Box<Expr>),
    /// `if c { a } else { b }` as an expression.
    Select(Box<Cond>, Box<Expr>, Box<Expr>),
}

/// Comparisons are numbered statically, in pre-order over the body: statements in order; an
/// `if`'s condition, then its branch, then its `else`; a comparison before its operands; a
/// value `if`'s condition, then its arms. The lowering numbers the plan's comparisons this way
/// ([`crate::lower::lir::Val::decision`]) and the interpreters report decisions by these
/// numbers, skipping those of a branch not taken, so that decisions can be matched across
/// models.
pub fn comparisons_in(stmts: &[Stmt]) -> usize {
    stmts
        .iter()
        .map(|s| match s {
            Stmt::Assign { value, .. } => value.comparisons(),
            Stmt::If { cond, then, els } => {
                cond.comparisons() + comparisons_in(then) + comparisons_in(els)
            }
        })
        .sum()
}

impl Expr {
    /// Where the expression starts in the spec (its first operand's site).
    pub fn span(&self) -> Span {
        match self {
            Expr::Const { span, .. } | Expr::Var(_, span) => *span,
            Expr::Mul(a, ..) => a.span(),
            Expr::Neg(a)
            | Expr::Add(a, _)
            | Expr::Sub(a, _)
            | Expr::Min(a, _)
            | Expr::Max(a, _) => a.span(),
            Expr::Select(c, ..) => c.span(),
        }
    }

    /// How many comparisons the expression holds (see [`comparisons_in`]).
    pub fn comparisons(&self) -> usize {
        match self {
            Expr::Const { .. } | Expr::Var(..) => 0,
            Expr::Neg(a) => a.comparisons(),
            Expr::Add(a, b)
            | Expr::Sub(a, b)
            | Expr::Mul(a, b, _)
            | Expr::Min(a, b)
            | Expr::Max(a, b) => a.comparisons() + b.comparisons(),
            Expr::Select(c, a, b) => c.comparisons() + a.comparisons() + b.comparisons(),
        }
    }
}

impl Cond {
    /// Where the condition starts in the spec.
    pub fn span(&self) -> Span {
        match self {
            Cond::Cmp(_, a, _) => a.span(),
            Cond::And(a, _) | Cond::Or(a, _) | Cond::Not(a) => a.span(),
        }
    }

    /// How many comparisons the condition holds (see [`comparisons_in`]).
    pub fn comparisons(&self) -> usize {
        match self {
            Cond::Cmp(_, a, b) => 1 + a.comparisons() + b.comparisons(),
            Cond::And(a, b) | Cond::Or(a, b) => a.comparisons() + b.comparisons(),
            Cond::Not(a) => a.comparisons(),
        }
    }
}

/// Comparison operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CmpOp {
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
}

impl CmpOp {
    /// Evaluates the comparison on any ordered values.
    pub fn eval<T: PartialOrd>(self, a: T, b: T) -> bool {
        match self {
            CmpOp::Lt => a < b,
            CmpOp::Le => a <= b,
            CmpOp::Gt => a > b,
            CmpOp::Ge => a >= b,
            CmpOp::Eq => a == b,
            CmpOp::Ne => a != b,
        }
    }

    /// The operator with its operands swapped: `a OP b ⟺ b OP.mirror() a`.
    pub fn mirror(self) -> Self {
        match self {
            CmpOp::Lt => CmpOp::Gt,
            CmpOp::Le => CmpOp::Ge,
            CmpOp::Gt => CmpOp::Lt,
            CmpOp::Ge => CmpOp::Le,
            CmpOp::Eq | CmpOp::Ne => self,
        }
    }

    /// Rust spelling.
    pub fn symbol(self) -> &'static str {
        match self {
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
            CmpOp::Eq => "==",
            CmpOp::Ne => "!=",
        }
    }
}

/// A boolean condition.
#[derive(Clone, Debug)]
pub enum Cond {
    /// `a OP b`
    Cmp(CmpOp, Expr, Expr),
    /// `a && b`
    And(Box<Cond>, Box<Cond>),
    /// `a || b`
    Or(Box<Cond>, Box<Cond>),
    /// `!a`
    Not(Box<Cond>),
}

/// Which side of a step a property reads a signal from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    /// Before the step: states' old values, inputs (clamped to their ranges).
    Pre,
    /// After the step: `next(state)`, outputs.
    Post,
}

/// An expression in a property, evaluated exactly (no rounding) on the fixed-point values.
#[derive(Clone, Debug)]
pub enum PExpr {
    /// A constant, taken at its exact binary (f64) value.
    Const(f64),
    /// A signal's value before or after the step.
    Sig(SigId, When),
    /// A free parameter (index into [`Property::params`]).
    Param(usize),
    /// `-a`
    Neg(Box<PExpr>),
    /// `a + b`
    Add(Box<PExpr>, Box<PExpr>),
    /// `a - b`
    Sub(Box<PExpr>, Box<PExpr>),
    /// `a * b`
    Mul(Box<PExpr>, Box<PExpr>),
    /// `abs(a)`
    Abs(Box<PExpr>),
    /// `min(a, b)`
    Min(Box<PExpr>, Box<PExpr>),
    /// `max(a, b)`
    Max(Box<PExpr>, Box<PExpr>),
}

impl PExpr {
    /// Visits this expression and every subexpression, parents first.
    pub fn walk(&self, f: &mut dyn FnMut(&PExpr)) {
        f(self);
        match self {
            PExpr::Neg(a) | PExpr::Abs(a) => a.walk(f),
            PExpr::Add(a, b)
            | PExpr::Sub(a, b)
            | PExpr::Mul(a, b)
            | PExpr::Min(a, b)
            | PExpr::Max(a, b) => {
                a.walk(f);
                b.walk(f);
            }
            PExpr::Const(_) | PExpr::Sig(..) | PExpr::Param(_) => {}
        }
    }
}

impl PCond {
    /// Visits every expression in the condition and all their subexpressions.
    pub fn walk(&self, f: &mut dyn FnMut(&PExpr)) {
        match self {
            PCond::Cmp(_, a, b) => {
                a.walk(f);
                b.walk(f);
            }
            PCond::And(a, b) | PCond::Or(a, b) => {
                a.walk(f);
                b.walk(f);
            }
            PCond::Not(a) => a.walk(f),
        }
    }

    /// Adds the signals the condition reads after the step (`next(s)`, outputs) to `out`, and
    /// the pre-step states as well if `pre_as_post` (an invariant read after a step).
    pub fn post_signals(&self, out: &mut std::collections::BTreeSet<SigId>, pre_as_post: bool) {
        self.walk(&mut |x| match x {
            PExpr::Sig(id, When::Post) => {
                out.insert(*id);
            }
            PExpr::Sig(id, When::Pre) if pre_as_post => {
                out.insert(*id);
            }
            _ => {}
        });
    }
}

/// A condition in a property.
#[derive(Clone, Debug)]
pub enum PCond {
    /// `a OP b`
    Cmp(CmpOp, PExpr, PExpr),
    /// `a && b`
    And(Box<PCond>, Box<PCond>),
    /// `a || b`
    Or(Box<PCond>, Box<PCond>),
    /// `!a`
    Not(Box<PCond>),
}

/// A free parameter of a property: universally quantified over its range.
#[derive(Clone, Debug)]
pub struct FreeParam {
    /// Name.
    pub name: String,
    /// Range.
    pub range: (f64, f64),
}

/// `invariant NAME: COND;` — over the states; must hold initially and be inductive.
#[derive(Clone, Debug)]
pub struct Invariant {
    /// Name.
    pub name: String,
    /// Doc lines.
    pub docs: Vec<String>,
    /// Condition over pre-state values.
    pub cond: PCond,
    /// Site.
    pub span: Span,
}

/// `property NAME { .. }` — for all inputs in range, states satisfying the invariants and
/// parameters in range: the assumptions imply the conclusions after one step.
#[derive(Clone, Debug)]
pub struct Property {
    /// Name.
    pub name: String,
    /// Doc lines.
    pub docs: Vec<String>,
    /// Free parameters.
    pub params: Vec<FreeParam>,
    /// Premises.
    pub assumes: Vec<PCond>,
    /// Conclusions.
    pub ensures: Vec<PCond>,
    /// Site.
    pub span: Span,
}
