//! The checked intermediate representation: names resolved, constants folded, real-valued.
//!
//! The IR says *what* a controller computes, in real arithmetic; the fixed-point plan
//! ([`crate::lower`]) says *how*. Signals live in one table indexed by [`SigId`], and all of
//! them are scalars: a vector or matrix declaration (`state theta[3]`) becomes one signal per
//! element, marked with its [`Elem`], so range analysis, format choice, proofs and the step's
//! code see scalars only, and only the emitters' APIs group the elements back into arrays.

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
    /// The fixed-step reciprocals (`newton_recip`) of the step.
    pub recips: Vec<Recip>,
    /// The reciprocal trackers (`recip_track`) of the step.
    pub tracks: Vec<Track>,
    /// The tables (`table NAME(x: [A, B]) = EXPR, step H;`), in declaration order.
    pub tables: Vec<Table>,
    /// The `tune` items: candidate values of constants for `qloop tune`. They do not change
    /// the controller.
    pub tunes: Vec<Tune>,
}

/// A `tune` item, checked: a `param` or `const` and its candidate values, in its unit.
#[derive(Clone, Debug)]
pub struct Tune {
    /// The constant's name.
    pub name: String,
    /// The candidates, ascending, without repeats.
    pub values: Vec<f64>,
    /// Whether the candidates are powers of two (`pow2`): shift gains.
    pub pow2: bool,
    /// The span of the constant's value expression, which `qloop tune` rewrites.
    pub value_span: proc_macro2::Span,
    /// The `tune` keyword.
    pub span: proc_macro2::Span,
}

/// A table: a function of one value given by a compile-time expression, sampled at
/// `lo, lo + step, .., hi` and interpolated linearly between the samples.
///
/// Its value in real arithmetic (what the interpreter, the f64 reference and the exact
/// semantics of the tests compute) is that interpolant of the f64 samples, with the argument
/// clamped to `[lo, hi]`; [`Table::interp_err`] bounds its distance from the expression
/// itself, and `qloop check` adds that bound to the error column of every value it feeds.
#[derive(Clone, Debug)]
pub struct Table {
    /// Name.
    pub name: String,
    /// The grid's first point `A`.
    pub lo: f64,
    /// The grid's last point `B`.
    pub hi: f64,
    /// The grid step `H`, a power of two.
    pub step: f64,
    /// `f(A + i·H)` for `i = 0..=N`: the f64 nearest the middle of an exact enclosure of the
    /// expression's value (rational arithmetic; `check::enclose`), not an f64 evaluation.
    pub samples: Vec<f64>,
    /// The argument's unit.
    pub in_unit: Option<String>,
    /// The result's unit (`None` if dimensionless).
    pub unit: Option<String>,
    /// A proved bound on `|L(x) − f(x)|` over `[lo, hi]`: `H²/8·max |f''|` per segment (the
    /// remainder of linear interpolation, with `f''` bounded by interval arithmetic), plus the
    /// largest distance of a sample from the exact value (exact rationals), rounded up.
    pub interp_err: f64,
    /// `, error E`: the interpolation error the spec claims, a proof obligation.
    pub claim: Option<f64>,
    /// f64 bounds on the claim's exact value `[lower, upper]` (a decimal such as 0.01 is not
    /// an f64): proved against the lower, refuted against the upper.
    pub claim_bounds: Option<(f64, f64)>,
    /// The largest lower bound on `|L(x) − f(x)|` found at the grid points and 15 points
    /// inside each segment (L exact over the samples, f enclosed in exact arithmetic), and
    /// where: a claim below it is false.
    pub witness: (f64, f64),
    /// Doc lines.
    pub docs: Vec<String>,
    /// The samples' format pinned by `#[q(TYPE, FRAC)]` (checked to hold every sample
    /// rounded to nearest), instead of the best one in the default word.
    pub format: Option<QFormat>,
    /// Declaration site.
    pub span: Span,
}

/// What is known of a table's claimed interpolation error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TableClaim {
    /// The curvature bound is at most the claim.
    Proved,
    /// `|L(x) − f(x)|` exceeds the claim at `x`, in exact arithmetic.
    Refuted {
        /// Where.
        x: f64,
        /// `|L(x) − f(x)|` there.
        err: f64,
    },
    /// Neither: the bound is above the claim, but no sampled point exceeds it.
    Unknown,
}

impl Table {
    /// The format its samples are stored in (`lower::table`): the best for their range in
    /// `word`-bit words, the range widened by its magnitude (at least 1) when every sample is
    /// the same; `None` if no format of that width holds them.
    pub fn stored_format(&self, word: u32) -> Option<QFormat> {
        if self.format.is_some() {
            return self.format;
        }
        let (lo, hi) = self.sample_hull(0, self.samples.len().saturating_sub(1));
        let pad = if lo == hi { lo.abs().max(1.0) } else { 0.0 };
        QFormat::best_for(crate::qformat::IntTy::signed(word), lo - pad, hi + pad)
    }

    /// The smallest and largest of samples `first..=last` (clamped to the samples).
    pub fn sample_hull(&self, first: usize, last: usize) -> (f64, f64) {
        let last = last.min(self.samples.len().saturating_sub(1));
        self.samples
            .get(first..=last)
            .unwrap_or_default()
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            })
    }

    /// The verdict on the claimed interpolation error, if there is a claim.
    pub fn claim_verdict(&self) -> Option<TableClaim> {
        let c = self.claim?;
        let (lo, hi) = self.claim_bounds.unwrap_or((c, c));
        let (x, err) = self.witness;
        Some(if self.interp_err <= lo {
            TableClaim::Proved
        } else if err > hi {
            TableClaim::Refuted { x, err }
        } else {
            TableClaim::Unknown
        })
    }

    /// The number of segments `N`.
    pub fn segments(&self) -> usize {
        self.samples.len() - 1
    }

    /// The table's value in real arithmetic, evaluated in f64 with exactly the operations of
    /// the f64 reference module: `x` clamped, `u = (x − lo)·(1/step)`, `i = min(u as usize, N − 1)` (the floor),
    /// `s_i + (u − i)·(s_{i+1} − s_i)`.
    pub fn eval(&self, x: f64) -> f64 {
        let x = x.max(self.lo).min(self.hi);
        let u = (x - self.lo) * (1.0 / self.step);
        // `u ≥ 0`, so the truncating cast is the floor (and needs no `std` in the reference).
        let i = (u as usize).min(self.segments() - 1);
        let t = u - i as f64;
        self.samples[i] + t * (self.samples[i + 1] - self.samples[i])
    }
}

/// A reciprocal tracker `recip_track(r, x, G);` (see `check::track`): the state `r` follows
/// `1/x` by `r ← r + G·(1 − x·r)`, the division-free loop of Koren & Masory (1981)
/// eqs. 12-13.
#[derive(Clone, Debug)]
pub struct Track {
    /// The tracking state.
    pub r: SigId,
    /// The input or state it tracks the reciprocal of.
    pub x: SigId,
    /// The gain `G`.
    pub gain: f64,
    /// `max |1 − G·x|` over the range of `x`, the contraction in real arithmetic.
    pub rho: f64,
    /// The factor the generated property claims (a binary fraction above `rho`).
    pub claimed_rho: f64,
    /// The rounding allowance the property adds.
    pub eps: f64,
    /// The generated property's name.
    pub property: String,
    /// The statement's site.
    pub span: Span,
}

/// A fixed-step reciprocal `newton_recip(d, [LO, HI], K)` ([`crate::lang::expand`]): the
/// `let`s holding `d` and the iterates, and what real arithmetic guarantees of the result.
#[derive(Clone, Debug)]
pub struct Recip {
    /// The claimed `d`.
    pub d: SigId,
    /// The result `r` (the last iterate).
    pub r: SigId,
    /// The range of `d`.
    pub lo: f64,
    /// See `lo`.
    pub hi: f64,
    /// Newton steps.
    pub steps: u32,
    /// The constant seed: 2/(lo + hi) to 6 significant bits (a short dyadic, exact in any
    /// format); NaN where a table seeds the iteration.
    pub seed: f64,
    /// The table that seeds it (an index into [`Program::tables`]), and the `let` holding
    /// its value at `d`.
    pub seed_table: Option<(usize, SigId)>,
    /// The call's site.
    pub span: Span,
}

impl Recip {
    /// An upper bound on `|1 − d·s|` over `d ∈ [lo, hi]` for the seed `s` in real arithmetic
    /// (attained at an end for a constant; for a table seed, the largest over each segment's
    /// quadratic `1 − d·L(d)`), nudged up by a relative 1e-12, far above its f64 rounding.
    pub fn seed_error(&self, tables: &[Table]) -> f64 {
        let e = match self.seed_table {
            None => {
                let s = self.seed;
                (1.0 - self.lo * s).abs().max((1.0 - self.hi * s).abs())
            }
            Some((t, _)) => table_recip_error(&tables[t], self.lo, self.hi),
        };
        e * (1.0 + 1e-12)
    }

    /// An upper bound on `1 − d·r` over `d ∈ [lo, hi]` in real arithmetic: `1 − d·r_{k+1}
    /// = (1 − d·r_k)²`, so it is the seed's error to the power `2^K` (and `0 ≤ 1 − d·r`
    /// after the first step).
    pub fn real_error(&self, tables: &[Table]) -> f64 {
        self.seed_error(tables).powi(1 << self.steps) * (1.0 + 1e-12)
    }
}

/// `max |1 − d·L(d)|` over `d ∈ [lo, hi]` for the interpolant `L` of table `t`: on each
/// segment `1 − d·L(d)` is a quadratic in `d`, so its extremes are at the segment's ends (cut
/// to `[lo, hi]`) or at its vertex. (Outside the table's range `L` is its end value.)
fn table_recip_error(t: &Table, lo: f64, hi: f64) -> f64 {
    let mut pts = vec![lo, hi];
    for i in 0..t.segments() {
        let (a, b) = (t.lo + i as f64 * t.step, t.lo + (i + 1) as f64 * t.step);
        pts.extend([a, b]);
        // L(d) = α + β·d on [a, b]; 1 − α·d − β·d² has its vertex at −α/(2β).
        let beta = (t.samples[i + 1] - t.samples[i]) / t.step;
        let alpha = t.samples[i] - beta * a;
        if beta != 0.0 {
            pts.push(-alpha / (2.0 * beta));
        }
    }
    pts.into_iter()
        .filter(|d| (lo..=hi).contains(d))
        .map(|d| (1.0 - d * t.eval(d)).abs())
        .fold(0f64, f64::max)
        // The f64 evaluation: a few roundings of values near 1.
        + 4e-16
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
    /// A rule parameter in a written port's unit, moved down to a multiple of that signal's
    /// LSB ([`crate::lang::rules::PortParam`]): what the spec wrote.
    pub quantised: Option<Quantised>,
}

/// A rule parameter `check` moved onto its port's grid: `value` is `k·2^-frac`, the greatest
/// multiple of the port signal's LSB at or below the value the spec wrote, or the least at or
/// above it where `up` ([`crate::lang::rules::PortParam`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Quantised {
    /// The value the spec wrote (or the rule's default).
    pub written: f64,
    /// The spec's signal bound to the port.
    pub signal: String,
    /// The signal's fraction bits: its LSB is `2^-frac`.
    pub frac: i32,
    /// Moved up (the code only subtracts it), not down.
    pub up: bool,
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

/// Where a scalar signal sits in a declared vector or matrix (`state P[2][2]` has the elements
/// `P[0][0]`, `P[0][1]`, `P[1][0]`, `P[1][1]`, named `P_0_0` .. `P_1_1` in generated code).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Elem {
    /// The declared name of the whole vector or matrix.
    pub group: String,
    /// This element's index, one entry per dimension.
    pub index: Vec<usize>,
    /// The declared dimensions (`[3]`, or `[rows, cols]`).
    pub dims: Vec<usize>,
}

impl Elem {
    /// The element's name in generated code: `theta_0`, `P_1_0`.
    pub fn ident(group: &str, index: &[usize]) -> String {
        let mut s = group.to_string();
        for i in index {
            s.push_str(&format!("_{i}"));
        }
        s
    }

    /// The element as the spec writes it: `theta[0]`, `P[1][0]`.
    pub fn label(&self) -> String {
        let mut s = self.group.clone();
        for i in &self.index {
            s.push_str(&format!("[{i}]"));
        }
        s
    }

    /// The row-major position of this element within its group.
    pub fn flat(&self) -> usize {
        self.index
            .iter()
            .zip(&self.dims)
            .fold(0, |acc, (i, d)| acc * d + i)
    }

    /// The number of elements of the group.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Whether the group has no elements (never: a declared dimension is at least 1).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// An error budget, `#[error(E)]`.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    /// The bound, in the signal's unit (positive).
    pub err: f64,
    /// The attribute, for errors.
    pub span: Span,
}

/// One signal.
#[derive(Clone, Debug)]
pub struct Signal {
    /// Name in generated code: as written, or `theta_0` for the element `theta[0]`.
    pub name: String,
    /// Role.
    pub kind: SigKind,
    /// The vector or matrix this signal is an element of, if any.
    pub elem: Option<Elem>,
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
    /// Error budget, `#[error(5e-4)]` on a state or output: the bound on one step's error
    /// against real arithmetic (in the signal's unit) that the formats chosen for it and for
    /// the `let`s before it must meet ([`crate::lower::budget`]).
    pub budget: Option<Budget>,
    /// A claimed range, `#[range(LO, HI)]` on a `let`: trusted when sizing the computation,
    /// and an obligation for the prover.
    pub claim: Option<(f64, f64)>,
    /// `#[unsaturated]` on a state: stores do not clamp; the range is an obligation instead.
    pub unsaturated: bool,
    /// `#[flag]` on an output: a 0/1 value (true above 1/2), a `bit` pin in the LinuxCNC
    /// component; the same output everywhere else.
    pub flag: bool,
    /// Doc lines.
    pub docs: Vec<String>,
    /// Declaration site.
    pub span: Span,
}

impl Signal {
    /// The name as the spec writes it: `fc`, or `theta[0]` for an element of a vector.
    pub fn label(&self) -> String {
        match &self.elem {
            Some(e) => e.label(),
            None => self.name.clone(),
        }
    }
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
    /// `NAME(x)`: table `table` (an index into [`Program::tables`]) at `x`.
    Table(usize, Box<Expr>, Span),
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
            Expr::Table(_, _, span) => *span,
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
            Expr::Table(_, a, _) => a.comparisons(),
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

    /// Whether the condition multiplies two values that are not constants (signals or free
    /// parameters): a product a bit-precise encoding must bit-blast into a multiplier.
    pub fn multiplies_variables(&self) -> bool {
        fn constant(e: &PExpr) -> bool {
            let mut c = true;
            e.walk(&mut |x| {
                if matches!(x, PExpr::Sig(..) | PExpr::Param(_)) {
                    c = false;
                }
            });
            c
        }
        let mut found = false;
        self.walk(&mut |x| {
            if let PExpr::Mul(a, b) = x {
                found |= !constant(a) && !constant(b);
            }
        });
        found
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
