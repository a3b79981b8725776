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
    /// The high word of the product of two `i32` values, from three 16×16→32 pieces
    /// ([`mul_hi`]): an `i32` within `(a·b/2^32 − 3, a·b/2^32]`. Where the target's 64-bit
    /// arithmetic is library calls, a product rounded to 32 bits is this, not a
    /// 32×32→64-bit `Mul` and a shift.
    MulHi(ValId, ValId),
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
            | Op::MulHi(a, b)
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
            Op::MulHi(a, b) => Op::MulHi(f(a), f(b)),
            Op::Min(a, b) => Op::Min(f(a), f(b)),
            Op::Max(a, b) => Op::Max(f(a), f(b)),
            Op::Cmp(op, a, b) => Op::Cmp(op, f(a), f(b)),
            Op::And(a, b) => Op::And(f(a), f(b)),
            Op::Or(a, b) => Op::Or(f(a), f(b)),
            Op::Select(c, a, b) => Op::Select(f(c), f(a), f(b)),
        }
    }
}

/// [`Op::MulHi`] of two values of `i32`, exactly as every emitter computes it: with
/// `h(x) = floor(x / 2^16)` (in `[−2^15, 2^15)`) and `l(x) = x − 2^16·h(x)` (in `[0, 2^16)`),
///
/// ```text
///     mul_hi(a, b) = h(a)·h(b) + floor(h(a)·l(b) / 2^16) + floor(l(a)·h(b) / 2^16).
/// ```
///
/// Since `a·b = 2^32·h(a)·h(b) + 2^16·(h(a)·l(b) + l(a)·h(b)) + l(a)·l(b)`, the difference
/// `a·b/2^32 − mul_hi(a, b)` is the two floors' fractions plus `l(a)·l(b)/2^32`: in `[0, 3)`.
/// Every piece fits `i32` (`|h(a)·h(b)| ≤ 2^30`, `|h(a)·l(b)| < 2^31`), and so does the
/// sum (below `2^30 + 2^16` in magnitude), for every pair of `i32` operands.
pub fn mul_hi(a: i128, b: i128) -> i128 {
    let (ha, hb) = (a >> 16, b >> 16);
    let (la, lb) = (a & 0xFFFF, b & 0xFFFF);
    ha * hb + ((ha * lb) >> 16) + ((la * hb) >> 16)
}

/// The interval of [`mul_hi`] over `a` in `[al, ah]` and `b` in `[bl, bh]`: the hull of two
/// sound intervals. One is from the exact product's,
/// `[floor(min a·b / 2^32) − 2, floor(max a·b / 2^32)]` (the value is an integer in
/// `(a·b/2^32 − 3, a·b/2^32]`), which the prover's envelope of the product uses. The other is
/// interval arithmetic on the formula's pieces, what an analyser of the emitted C without
/// relations between the pieces finds (Frama-C's Eva): a little wider, and every value the
/// plan derives from it then holds for that analyser too.
pub fn mul_hi_range(a: (i128, i128), b: (i128, i128)) -> (i128, i128) {
    let corners = |x: (i128, i128), y: (i128, i128)| {
        let c = [x.0 * y.0, x.0 * y.1, x.1 * y.0, x.1 * y.1];
        (*c.iter().min().unwrap_or(&0), *c.iter().max().unwrap_or(&0))
    };
    let (plo, phi) = corners(a, b);
    let high = |x: (i128, i128)| (x.0 >> 16, x.1 >> 16);
    let low = |x: (i128, i128)| {
        if x.0 >= 0 && x.1 <= 0xFFFF {
            x
        } else {
            (0, 0xFFFF)
        }
    };
    let hh = corners(high(a), high(b));
    let hl = corners(high(a), low(b));
    let lh = corners(low(a), high(b));
    let naive = (
        hh.0 + (hl.0 >> 16) + (lh.0 >> 16),
        hh.1 + (hl.1 >> 16) + (lh.1 >> 16),
    );
    (((plo >> 32) - 2).min(naive.0), (phi >> 32).max(naive.1))
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

#[cfg(test)]
mod tests {
    use super::{mul_hi, mul_hi_range};

    /// Edge factors: 0, ±1, each half's and each byte's boundaries, the extremes.
    const EDGE: [i128; 22] = [
        0,
        1,
        -1,
        255,
        256,
        -256,
        0x7fff,
        -0x8000,
        0xffff,
        0x10000,
        -0x10000,
        -0xffff,
        0x1_0001,
        -0x1_0001,
        0x00ff_00ff,
        -0x00ff_00ff,
        0x7fff_0000,
        -0x7fff_0000,
        0x7fff_fffe,
        0x7fff_ffff,
        -0x7fff_ffff,
        -0x8000_0000,
    ];

    /// Every pair of edge factors, and 200,000 random pairs of random widths.
    fn pairs() -> Vec<(i128, i128)> {
        let mut out: Vec<(i128, i128)> = EDGE
            .iter()
            .flat_map(|&a| EDGE.iter().map(move |&b| (a, b)))
            .collect();
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        for _ in 0..200_000 {
            let w = rnd();
            let a = i128::from((rnd() as u32 as i32) >> (w & 31));
            let b = i128::from((rnd() as u32 as i32) >> ((w >> 5) & 31));
            out.push((a, b));
        }
        out
    }

    /// `mul_hi(a, b)` is an integer in `(a·b/2^32 − 3, a·b/2^32]`, exactly (integers: `2^32·m ≤
    /// a·b < 2^32·(m + 3)`), and every piece and partial sum fits `i32`, as the emitters
    /// compute it in 32 bits.
    #[test]
    fn the_high_product_is_within_three_below_the_products_high_word() {
        for (a, b) in pairs() {
            let m = mul_hi(a, b);
            let p = a * b;
            assert!(m << 32 <= p && p < (m + 3) << 32, "{a} * {b}: {m}");
            let (ha, hb, la, lb) = (a >> 16, b >> 16, a & 0xffff, b & 0xffff);
            let i32r = i128::from(i32::MIN)..=i128::from(i32::MAX);
            for x in [ha * hb, ha * lb, la * hb, ha * hb + ((ha * lb) >> 16), m] {
                assert!(i32r.contains(&x), "{a} * {b}: a piece {x} leaves i32");
            }
        }
    }

    /// The interval holds every value over boxes of random factors, at the corners and inside.
    #[test]
    fn the_high_products_interval_holds_its_values() {
        let ps = pairs();
        for w in ps.windows(2).step_by(97) {
            let (a0, a1) = (w[0].0.min(w[1].0), w[0].0.max(w[1].0));
            let (b0, b1) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
            let (lo, hi) = mul_hi_range((a0, a1), (b0, b1));
            for a in [a0, a1, (a0 + a1) >> 1] {
                for b in [b0, b1, (b0 + b1) >> 1] {
                    let m = mul_hi(a, b);
                    assert!(lo <= m && m <= hi, "[{a0}, {a1}] x [{b0}, {b1}]: {m}");
                }
            }
        }
    }
}
