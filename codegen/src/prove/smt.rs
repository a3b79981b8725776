//! SMT-LIB 2 (QF_BV) encoding of a fixed-point plan, bit for bit.
//!
//! Every plan value becomes a `define-fun` of its machine width: `bvadd`, `bvsub`, `bvneg`,
//! `bvmul`, `bvshl`, `bvashr` (the arithmetic shift, floor), sign extension for widening casts
//! of signed values, zero extension for unsigned storage, `extract` for narrowing casts,
//! `ite` with `bvslt` for min/max/select. Branches are encoded in SSA form: values computed in
//! a branch are pure terms, and a state or output written in a branch becomes an `ite` on the
//! branch condition at the merge. Wrapping is modelled exactly, so the overflow obligations
//! are about the real machine semantics.
//!
//! Property expressions are evaluated *exactly*: every operand is sign-extended and aligned to
//! a common binary point, with widths grown so that nothing wraps.

use crate::ir::{CmpOp, PCond, PExpr, SigId, SigKind, When};
use crate::lower::lir::{LStmt, Op, Val, ValId};
use crate::lower::Plan;
use crate::prop_eval::{self, Arith, ExactDomain};
use std::collections::BTreeMap;
use std::fmt::Write;

/// A bit-vector literal of `width` bits holding `v` in two's complement.
pub fn lit(v: i128, width: u32) -> String {
    let m = if width >= 128 {
        v as u128
    } else {
        (v as u128) & ((1u128 << width) - 1)
    };
    format!("(_ bv{m} {width})")
}

/// `t` (a `from`-bit value, signed or not) resized to `to` bits.
pub fn resize(t: &str, from: u32, to: u32, signed: bool) -> String {
    use std::cmp::Ordering::*;
    match to.cmp(&from) {
        Equal => t.to_string(),
        Greater => format!(
            "((_ {} {}) {t})",
            if signed { "sign_extend" } else { "zero_extend" },
            to - from
        ),
        Less => format!("((_ extract {} 0) {t})", to - 1),
    }
}

pub use crate::prop_eval::signed_bits;

/// A signed comparison of two terms of one width.
pub fn signed_cmp(op: CmpOp, x: &str, y: &str) -> String {
    match op {
        CmpOp::Lt => format!("(bvslt {x} {y})"),
        CmpOp::Le => format!("(bvsle {x} {y})"),
        CmpOp::Gt => format!("(bvsgt {x} {y})"),
        CmpOp::Ge => format!("(bvsge {x} {y})"),
        CmpOp::Eq => format!("(= {x} {y})"),
        CmpOp::Ne => format!("(not (= {x} {y}))"),
    }
}

/// `lo ≤ t ≤ hi` for a signed `width`-bit term.
pub fn in_range(t: &str, width: u32, lo: i128, hi: i128) -> String {
    format!(
        "(and (bvsle {} {t}) (bvsle {t} {}))",
        lit(lo, width),
        lit(hi, width)
    )
}

pub use qloop_core::terms::{input_var, pre_var};

pub use crate::prop_eval::param_var;

/// The bit-precise (SSA) encoding of one step of the plan, as definitions over `in_*` and
/// `pre_*` variables: the shared body of the whole-program queries. (Not to be confused with
/// [`super::obligations::ExactEncoding`], which picks how an exact-term query is written.)
pub struct StepEncoding {
    /// Declarations and definitions, in order.
    pub text: String,
    /// Term of each state/output after the step (storage width).
    pub post: BTreeMap<SigId, String>,
}

/// The SMT sort of a value.
fn sort(v: &Val) -> String {
    if v.boolean {
        "Bool".into()
    } else {
        format!("(_ BitVec {})", v.ty.bits)
    }
}

/// Name of value `id` in the encoding.
pub fn vname(id: ValId) -> String {
    format!("v{}", id.0)
}

/// Declares inputs and pre-states and defines every plan value.
pub fn encode_step(plan: &Plan) -> StepEncoding {
    let prog = &plan.prog;
    let mut text = String::new();
    let mut env: BTreeMap<SigId, String> = BTreeMap::new();
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let w = plan.format(id).ty.bits;
        match s.kind {
            SigKind::Input => {
                let _ = writeln!(
                    text,
                    "(declare-fun {} () (_ BitVec {w}))",
                    input_var(prog, id)
                );
            }
            SigKind::State => {
                let _ = writeln!(
                    text,
                    "(declare-fun {} () (_ BitVec {w}))",
                    pre_var(prog, id)
                );
                env.insert(id, pre_var(prog, id));
            }
            SigKind::Output => {
                env.insert(id, lit(0, w));
            }
            SigKind::Local => {}
        }
    }
    let mut merges = 0usize;
    block(plan, &plan.body, &mut env, &mut text, &mut merges);
    StepEncoding { text, post: env }
}

fn block(
    plan: &Plan,
    stmts: &[LStmt],
    env: &mut BTreeMap<SigId, String>,
    text: &mut String,
    merges: &mut usize,
) {
    for s in stmts {
        match s {
            LStmt::Def(id) => {
                let v = plan.val(*id);
                let e = op_term(plan, *id, env);
                let _ = writeln!(text, "(define-fun {} () {} {e})", vname(*id), sort(v));
            }
            LStmt::Store(sig, id) => {
                env.insert(*sig, vname(*id));
            }
            LStmt::If(c, t, e) => {
                let mut et = env.clone();
                block(plan, t, &mut et, text, merges);
                let mut ee = env.clone();
                block(plan, e, &mut ee, text, merges);
                for (sig, tt) in &et {
                    let te = &ee[sig];
                    if tt != te {
                        let name = format!("m{merges}");
                        *merges += 1;
                        let w = plan.format(*sig).ty.bits;
                        let _ = writeln!(
                            text,
                            "(define-fun {name} () (_ BitVec {w}) (ite {} {tt} {te}))",
                            vname(*c)
                        );
                        env.insert(*sig, name);
                    } else {
                        env.insert(*sig, tt.clone());
                    }
                }
            }
        }
    }
}

/// The bit-precise term of value `id`, over earlier definitions.
fn op_term(plan: &Plan, id: ValId, env: &BTreeMap<SigId, String>) -> String {
    let v = plan.val(id);
    let w = v.ty.bits;
    let n = |x: &ValId| vname(*x);
    match &v.op {
        Op::Input(s) => input_var(&plan.prog, *s),
        Op::Load(s) => env[s].clone(),
        Op::Const(c) => lit(*c, w),
        Op::Cast(a) => {
            let av = plan.val(*a);
            resize(&n(a), av.ty.bits, w, av.ty.signed)
        }
        Op::Add(a, b) => format!("(bvadd {} {})", n(a), n(b)),
        Op::Sub(a, b) => format!("(bvsub {} {})", n(a), n(b)),
        Op::Neg(a) => format!("(bvneg {})", n(a)),
        Op::Shl(a, k) => format!("(bvshl {} {})", n(a), lit(*k as i128, w)),
        Op::Shr(a, k) => format!("(bvashr {} {})", n(a), lit(*k as i128, w)),
        Op::Mul(a, b) => format!("(bvmul {} {})", n(a), n(b)),
        Op::MulHi(a, b) => mul_hi_term(&n(a), &n(b), w),
        Op::Min(a, b) => format!("(ite (bvslt {a} {b}) {a} {b})", a = n(a), b = n(b)),
        Op::Max(a, b) => format!("(ite (bvslt {a} {b}) {b} {a})", a = n(a), b = n(b)),
        Op::Select(c, a, b) => format!("(ite {} {} {})", n(c), n(a), n(b)),
        Op::Cmp(op, a, b) => signed_cmp(*op, &n(a), &n(b)),
        Op::And(a, b) => format!("(and {} {})", n(a), n(b)),
        Op::Or(a, b) => format!("(or {} {})", n(a), n(b)),
        Op::Not(a) => format!("(not {})", n(a)),
        Op::Low(a, k) => format!("(bvand {} {})", n(a), lit((1i128 << k) - 1, w)),
        Op::Lookup { table, delta, idx } => {
            let iv = plan.val(*idx);
            lookup_term(plan, *table, *delta, &n(idx), iv.ty.bits, (iv.lo, iv.hi), w)
        }
    }
}

/// [`qloop_core::lower::lir::mul_hi`] of two `w`-bit terms (`w ≥ 32`), bit for bit: each
/// piece and the sum fit 32 bits for operands of `i32`, so no operation wraps.
fn mul_hi_term(a: &str, b: &str, w: u32) -> String {
    let k = lit(16, w);
    let m = lit(0xFFFF, w);
    format!(
        "(let ((ha (bvashr {a} {k})) (hb (bvashr {b} {k}))) \
         (bvadd (bvadd (bvmul ha hb) (bvashr (bvmul ha (bvand {b} {m})) {k})) \
         (bvashr (bvmul (bvand {a} {m}) hb) {k})))"
    )
}

/// Entry `idx` of a table array as a balanced `ite` tree over the index's interval `lo..=hi`
/// (`idx` a term of `iw` bits), at width `w`.
pub fn lookup_term(
    plan: &Plan,
    table: usize,
    delta: bool,
    idx: &str,
    iw: u32,
    (lo, hi): (i128, i128),
    w: u32,
) -> String {
    let t = &plan.tables[table];
    let arr = if delta { &t.deltas } else { &t.entries };
    let last = arr.len() as i128 - 1;
    fn tree(arr: &[i128], idx: &str, iw: u32, lo: i128, hi: i128, w: u32) -> String {
        if lo >= hi {
            return lit(arr[lo as usize], w);
        }
        let mid = (lo + hi + 1) / 2;
        format!(
            "(ite (bvslt {idx} {}) {} {})",
            lit(mid, iw),
            tree(arr, idx, iw, lo, mid - 1, w),
            tree(arr, idx, iw, mid, hi, w)
        )
    }
    tree(arr, idx, iw, lo.clamp(0, last), hi.clamp(0, last), w)
}

/// The exact (non-wrapping) result of value `id`'s operation, from operand terms given by
/// `operand` (each a signed term of the returned width, or narrower), as (term, width).
/// Used by the overflow obligations: the plan's value is correct iff this lies in the type.
pub fn exact_term(
    plan: &Plan,
    id: ValId,
    operand: &dyn Fn(ValId) -> (String, u32),
) -> Option<(String, u32)> {
    let v = plan.val(id);
    let sx = |a: &ValId, to: u32| {
        let (t, w) = operand(*a);
        resize(&t, w, to, true)
    };
    let wid = |a: &ValId| operand(*a).1;
    Some(match &v.op {
        Op::Add(a, b) | Op::Sub(a, b) => {
            let w = wid(a).max(wid(b)) + 1;
            let f = if matches!(v.op, Op::Add(..)) {
                "bvadd"
            } else {
                "bvsub"
            };
            (format!("({f} {} {})", sx(a, w), sx(b, w)), w)
        }
        Op::Neg(a) => {
            let w = wid(a) + 1;
            (format!("(bvneg {})", sx(a, w)), w)
        }
        // Sign and magnitude: |a|·|b| as an unsigned product, negated when the signs differ.
        // The same exact integer as `(bvmul (sext a) (sext b))`, but a bit-blaster's
        // multiplier of two bounded magnitudes is far easier: cvc5 1.0 proves the range of a
        // 32×32 product this way in under a second, against 37 s for the signed product.
        Op::Mul(a, b) => {
            let w = wid(a) + wid(b) + 1;
            let (x, y) = (sx(a, w), sx(b, w));
            let zero = lit(0, w);
            let (na, nb) = (format!("(bvslt {x} {zero})"), format!("(bvslt {y} {zero})"));
            let mag = |t: &str, neg: &str| format!("(ite {neg} (bvneg {t}) {t})");
            let m = format!("(bvmul {} {})", mag(&x, &na), mag(&y, &nb));
            (format!("(ite (xor {na} {nb}) (bvneg {m}) {m})"), w)
        }
        // Exact at 33 bits: the operands fit 32, every piece and the sum 32 (signed).
        Op::MulHi(a, b) => {
            let w = wid(a).max(wid(b)).max(32) + 1;
            (mul_hi_term(&sx(a, w), &sx(b, w), w), w)
        }
        Op::Shl(a, k) => {
            let w = wid(a) + k;
            (format!("(bvshl {} {})", sx(a, w), lit(*k as i128, w)), w)
        }
        Op::Shr(a, k) => {
            let w = wid(a);
            (format!("(bvashr {} {})", sx(a, w), lit(*k as i128, w)), w)
        }
        Op::Low(a, k) => {
            let w = wid(a);
            (
                format!("(bvand {} {})", sx(a, w), lit((1i128 << k) - 1, w)),
                w,
            )
        }
        Op::Lookup { table, delta, idx } => {
            let (lo, hi) = plan.tables[*table].range(*delta);
            let w = signed_bits(lo, hi);
            let (it, iw) = operand(*idx);
            let iv = plan.val(*idx);
            (
                lookup_term(plan, *table, *delta, &it, iw, (iv.lo, iv.hi), w),
                w,
            )
        }
        Op::Min(a, b) | Op::Max(a, b) => {
            let w = wid(a).max(wid(b));
            let (x, y) = (sx(a, w), sx(b, w));
            let t = if matches!(v.op, Op::Min(..)) {
                format!("(ite (bvslt {x} {y}) {x} {y})")
            } else {
                format!("(ite (bvslt {x} {y}) {y} {x})")
            };
            (t, w)
        }
        Op::Select(c, a, b) => {
            let w = wid(a).max(wid(b));
            let (ct, _) = operand(*c);
            (format!("(ite {ct} {} {})", sx(a, w), sx(b, w)), w)
        }
        Op::Cast(a) => {
            let (t, w) = operand(*a);
            (t, w)
        }
        Op::Const(c) => {
            let w = signed_bits(*c, *c);
            (lit(*c, w), w)
        }
        Op::Input(_) | Op::Load(_) | Op::Cmp(..) | Op::And(..) | Op::Or(..) | Op::Not(..) => {
            return None
        }
    })
}

/// An exactly evaluated property term: signed, `width` bits, `frac` fraction bits.
#[derive(Clone, Debug)]
pub struct Exact {
    /// SMT term.
    pub term: String,
    /// Width in bits.
    pub width: u32,
    /// Binary point.
    pub frac: i32,
}

impl Exact {
    fn to(&self, width: u32, frac: i32) -> String {
        let shift = (frac - self.frac) as u32;
        let t = resize(&self.term, self.width, width, true);
        if shift == 0 {
            t
        } else {
            format!("(bvshl {t} {})", lit(shift as i128, width))
        }
    }
}

pub use crate::prop_eval::exact_binary;

/// Property-encoding context: where signals and parameters come from.
pub struct PropEnv<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Post-step terms.
    pub post: &'a BTreeMap<SigId, String>,
    /// Free parameters: (variable, width, frac).
    pub params: &'a [(String, u32, i32)],
    /// Read states' pre-step values from the post-step terms (invariants after a step).
    pub pre_as_post: bool,
}

impl<'a> PropEnv<'a> {
    /// An environment for invariants, which have no free parameters: states read before
    /// the step (`pre_as_post` false) or after it (true).
    pub fn invariants(
        plan: &'a Plan,
        post: &'a BTreeMap<SigId, String>,
        pre_as_post: bool,
    ) -> PropEnv<'a> {
        PropEnv {
            plan,
            post,
            params: &[],
            pre_as_post,
        }
    }
}

impl PropEnv<'_> {
    /// Exact term of a property expression.
    pub fn expr(&self, e: &PExpr) -> Option<Exact> {
        prop_eval::expr(&mut &*self, e).ok()
    }

    /// Exact term of a property condition.
    pub fn cond(&self, c: &PCond) -> Option<String> {
        prop_eval::cond(&mut &*self, c).ok()
    }
}

/// SMT bit-vector terms: every value a signed term at the narrowest width that holds it.
impl ExactDomain for &PropEnv<'_> {
    type Value = Exact;
    type Bool = String;
    type Error = ();

    fn frac(v: &Exact) -> i32 {
        v.frac
    }

    fn inexact(&self, _: f64) {}

    fn constant(&mut self, m: i128, frac: i32) -> Result<Exact, ()> {
        let width = signed_bits(m, m);
        Ok(Exact {
            term: lit(m, width),
            width,
            frac,
        })
    }

    fn signal(&mut self, id: SigId, when: When) -> Result<Exact, ()> {
        let q = self.plan.format(id);
        let prog = &self.plan.prog;
        let raw = match (prog.sig(id).kind, when) {
            (SigKind::Input, _) => input_var(prog, id),
            (SigKind::State, When::Pre) if !self.pre_as_post => pre_var(prog, id),
            _ => self.post[&id].clone(),
        };
        // Unsigned storage: zero-extend by one bit to make it a signed term.
        let (term, width) = if q.ty.signed {
            (raw, q.ty.bits)
        } else {
            (resize(&raw, q.ty.bits, q.ty.bits + 1, false), q.ty.bits + 1)
        };
        Ok(Exact {
            term,
            width,
            frac: q.frac,
        })
    }

    fn param(&mut self, i: usize) -> Result<Exact, ()> {
        let (v, w, f) = self.params.get(i).ok_or(())?;
        Ok(Exact {
            term: v.clone(),
            width: *w,
            frac: *f,
        })
    }

    fn neg(&mut self, a: Exact) -> Result<Exact, ()> {
        let w = a.width + 1;
        Ok(Exact {
            term: format!("(bvneg {})", a.to(w, a.frac)),
            width: w,
            frac: a.frac,
        })
    }

    fn abs(&mut self, a: Exact) -> Result<Exact, ()> {
        let w = a.width + 1;
        let t = a.to(w, a.frac);
        Ok(Exact {
            term: format!("(ite (bvslt {t} {z}) (bvneg {t}) {t})", z = lit(0, w)),
            width: w,
            frac: a.frac,
        })
    }

    fn arith(&mut self, op: Arith, a: Exact, b: Exact, f: i32) -> Result<Exact, ()> {
        let w = (a.width + (f - a.frac) as u32).max(b.width + (f - b.frac) as u32) + 1;
        let (x, y) = (a.to(w, f), b.to(w, f));
        let term = match op {
            Arith::Add => format!("(bvadd {x} {y})"),
            Arith::Sub => format!("(bvsub {x} {y})"),
            Arith::Min => format!("(ite (bvslt {x} {y}) {x} {y})"),
            Arith::Max => format!("(ite (bvslt {x} {y}) {y} {x})"),
        };
        Ok(Exact {
            term,
            width: w,
            frac: f,
        })
    }

    fn mul(&mut self, a: Exact, b: Exact) -> Result<Exact, ()> {
        let w = a.width + b.width;
        Ok(Exact {
            term: format!("(bvmul {} {})", a.to(w, a.frac), b.to(w, b.frac)),
            width: w,
            frac: a.frac + b.frac,
        })
    }

    fn cmp(&mut self, op: CmpOp, a: Exact, b: Exact, f: i32) -> Result<String, ()> {
        let w = (a.width + (f - a.frac) as u32).max(b.width + (f - b.frac) as u32);
        let (x, y) = (a.to(w, f), b.to(w, f));
        Ok(signed_cmp(op, &x, &y))
    }

    fn and(&mut self, a: String, b: String) -> Result<String, ()> {
        Ok(format!("(and {a} {b})"))
    }

    fn or(&mut self, a: String, b: String) -> Result<String, ()> {
        Ok(format!("(or {a} {b})"))
    }

    fn not(&mut self, a: String) -> Result<String, ()> {
        Ok(format!("(not {a})"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_are_twos_complement() {
        assert_eq!(lit(-1, 8), "(_ bv255 8)");
        assert_eq!(lit(5, 4), "(_ bv5 4)");
        assert_eq!(
            lit(i64::MIN as i128, 64),
            format!("(_ bv{} 64)", 1u128 << 63)
        );
    }

    #[test]
    fn signed_bits_is_tight() {
        assert_eq!(signed_bits(-128, 127), 8);
        assert_eq!(signed_bits(-129, 0), 9);
        assert_eq!(signed_bits(0, 128), 9);
        assert_eq!(signed_bits(0, 0), 1);
        assert_eq!(signed_bits(-1, 0), 1);
    }
}
