//! The fixed-point plan ("LIR"): straight-line integer operations with structured `if`s.
//!
//! Every value has a machine type, a binary point (`frac`), the exact interval of raw values
//! it can take (proved by interval analysis from the declared ranges), and a bound on its
//! error against real arithmetic. The Rust emitter, the interpreter and, later, the C and
//! SMT emitters all read this one plan, so they agree bit for bit by construction.

use crate::ir::{CmpOp, SigId};
use crate::qformat::IntTy;

/// Index into [`Plan::vals`](super::Plan::vals).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ValId(pub usize);

/// One SSA value.
#[derive(Clone, Debug)]
pub struct Val {
    /// The operation producing it.
    pub op: Op,
    /// Working type (signed for arithmetic; a storage type only for [`Op::Cast`] to storage).
    pub ty: IntTy,
    /// Fraction bits of the raw value.
    pub frac: i32,
    /// Smallest raw value (proved).
    pub lo: i128,
    /// Largest raw value (proved).
    pub hi: i128,
    /// Bound on |value − real-arithmetic value| in physical units, for one step started from
    /// the same state and inputs, assuming the same branch decisions.
    pub err: f64,
    /// Source name, for `let` bindings and clamped inputs.
    pub name: Option<String>,
    /// A boolean (comparison) value; `ty`, `frac`, `lo`, `hi` are then meaningless.
    pub boolean: bool,
    /// The interval `[lo, hi]` is trusted from a user claim (`#[range]`, `#[unsaturated]`)
    /// rather than derived from the operands: only a whole-program proof can discharge it.
    pub claimed: bool,
    /// A shifted term of a shift-add network. Emitters keep it opaque to the optimiser, so
    /// that GCC or LLVM cannot fold the network back into a multiply (a library call on
    /// cores without a fast multiplier).
    pub network: bool,
    /// Spec line of the statement this value was lowered from (0 if unknown).
    pub line: usize,
    /// For a comparison: its static number among the spec's comparisons
    /// ([`crate::ir::comparisons_in`]), so that the fixed step's decisions can be matched with
    /// the reference's, also where a dead comparison was removed.
    pub decision: Option<usize>,
}

/// An integer operation. Operand types equal the result type except where noted.
#[derive(Clone, Debug)]
pub enum Op {
    /// The raw bits of an input, in its storage type.
    Input(SigId),
    /// The current raw value of a state or output variable, in its storage type.
    Load(SigId),
    /// An integer constant.
    Const(i128),
    /// Conversion from the operand's type to this value's type; the range analysis proves
    /// that it never truncates.
    Cast(ValId),
    /// `a + b`
    Add(ValId, ValId),
    /// `a - b`
    Sub(ValId, ValId),
    /// `-a`
    Neg(ValId),
    /// `a << k` (exact: multiplies by 2^k).
    Shl(ValId, u32),
    /// `a >> k`, arithmetic: floor(a / 2^k).
    Shr(ValId, u32),
    /// `a * b`, both operands already widened to the product type.
    Mul(ValId, ValId),
    /// `min(a, b)`
    Min(ValId, ValId),
    /// `max(a, b)`
    Max(ValId, ValId),
    /// `if c { a } else { b }`
    Select(ValId, ValId, ValId),
    /// Comparison, boolean result; operands share type and frac.
    Cmp(CmpOp, ValId, ValId),
    /// Boolean and.
    And(ValId, ValId),
    /// Boolean or.
    Or(ValId, ValId),
    /// Boolean not.
    Not(ValId),
    /// The low `k` bits of a non-negative value, `a & (2^k − 1)` (the position inside a
    /// table segment).
    Low(ValId, u32),
    /// Entry `idx` of table array `table` ([`crate::lower::Plan::tables`]): its samples, or
    /// (`delta`) the differences of consecutive samples.
    Lookup {
        /// Index into [`crate::lower::Plan::tables`].
        table: usize,
        /// The differences `T[i+1] − T[i]` (0 at the last entry) rather than the samples.
        delta: bool,
        /// The index, in `0..=N`.
        idx: ValId,
    },
}

impl Op {
    /// The values this operation reads.
    pub fn operands(&self) -> Vec<ValId> {
        match *self {
            Op::Input(_) | Op::Load(_) | Op::Const(_) => vec![],
            Op::Cast(a)
            | Op::Neg(a)
            | Op::Shl(a, _)
            | Op::Shr(a, _)
            | Op::Not(a)
            | Op::Low(a, _)
            | Op::Lookup { idx: a, .. } => vec![a],
            Op::Add(a, b)
            | Op::Sub(a, b)
            | Op::Mul(a, b)
            | Op::Min(a, b)
            | Op::Max(a, b)
            | Op::Cmp(_, a, b)
            | Op::And(a, b)
            | Op::Or(a, b) => vec![a, b],
            Op::Select(c, a, b) => vec![c, a, b],
        }
    }

    /// The same operation reading `f(v)` wherever it read `v`.
    pub fn map_operands(&self, f: impl Fn(ValId) -> ValId) -> Op {
        match *self {
            ref op @ (Op::Input(_) | Op::Load(_) | Op::Const(_)) => op.clone(),
            Op::Cast(a) => Op::Cast(f(a)),
            Op::Neg(a) => Op::Neg(f(a)),
            Op::Not(a) => Op::Not(f(a)),
            Op::Shl(a, k) => Op::Shl(f(a), k),
            Op::Shr(a, k) => Op::Shr(f(a), k),
            Op::Low(a, k) => Op::Low(f(a), k),
            Op::Lookup { table, delta, idx } => Op::Lookup {
                table,
                delta,
                idx: f(idx),
            },
            Op::Add(a, b) => Op::Add(f(a), f(b)),
            Op::Sub(a, b) => Op::Sub(f(a), f(b)),
            Op::Mul(a, b) => Op::Mul(f(a), f(b)),
            Op::Min(a, b) => Op::Min(f(a), f(b)),
            Op::Max(a, b) => Op::Max(f(a), f(b)),
            Op::Cmp(op, a, b) => Op::Cmp(op, f(a), f(b)),
            Op::And(a, b) => Op::And(f(a), f(b)),
            Op::Or(a, b) => Op::Or(f(a), f(b)),
            Op::Select(c, a, b) => Op::Select(f(c), f(a), f(b)),
        }
    }
}

/// A statement of the plan.
#[derive(Clone, Debug)]
pub enum LStmt {
    /// Compute a value.
    Def(ValId),
    /// Write a value (already rounded, saturated and cast to storage) to a state or output.
    Store(SigId, ValId),
    /// Branch on a boolean value.
    If(ValId, Vec<LStmt>, Vec<LStmt>),
}
