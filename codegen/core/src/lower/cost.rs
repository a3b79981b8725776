//! The cost model's estimate of a whole plan: cycles of one step on its worst path, and a
//! static cost (every branch counted once) that stands for code size.
//!
//! The per-operation prices are [`Target`]'s (the ones the lowering already uses to choose
//! between a multiply and a shift-add network, or how to split a shift). The estimate
//! ranks plans of one spec on one target against each other (the error-budget search,
//! [`super::budget`]); it is not a cycle count. The measured figures are `qloop bench`'s, in
//! the target's simulator.

use super::lir::{LStmt, Op, Val};
use super::target::Target;
use super::Plan;
use crate::qformat::IntTy;

/// An estimate, in the target model's cycles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct Cost {
    /// One step on its most expensive path.
    pub cycles: u64,
    /// Every operation once, both sides of every branch: the proxy for flash.
    pub size: u64,
}

/// The estimate of `plan` on its target.
pub fn estimate(plan: &Plan) -> Cost {
    block(plan, &plan.target, &plan.body)
}

fn block(plan: &Plan, t: &Target, body: &[LStmt]) -> Cost {
    let mut c = Cost::default();
    for st in body {
        match st {
            LStmt::Def(id) => {
                let k = u64::from(op_cost(plan, t, plan.val(*id)));
                c.cycles += k;
                c.size += k;
            }
            LStmt::Store(s, _) => {
                let bits = plan.format(*s).ty.bits;
                let k = u64::from(t.costs.store * words(t, bits));
                c.cycles += k;
                c.size += k;
            }
            LStmt::If(_, a, b) => {
                let (a, b) = (block(plan, t, a), block(plan, t, b));
                // A test of the boolean and a jump around one side.
                let branch = u64::from(2 * t.costs.add);
                c.cycles += branch + a.cycles.max(b.cycles);
                c.size += branch + a.size + b.size;
            }
        }
    }
    c
}

fn words(t: &Target, bits: u32) -> u32 {
    bits.div_ceil(t.word_bits).max(1)
}

/// The narrowest signed width that holds `v`'s proved interval (a product's operand is
/// widened to the product's type first; the multiply needs only its own limbs).
fn value_bits(v: &Val) -> u32 {
    IntTy::signed_for(v.lo, v.hi, 8).map_or(v.ty.bits, |t| t.bits)
}

/// The price of one operation, at its working width.
fn op_cost(plan: &Plan, t: &Target, v: &Val) -> u32 {
    let bits = v.ty.bits;
    let add = t.add_cost(bits);
    let operand = |id| plan.val(id);
    match v.op {
        Op::Input(_) | Op::Load(_) | Op::Lookup { .. } => t.costs.load * words(t, bits),
        Op::Const(_) => 0,
        Op::Cast(a) => {
            // Sign or zero extension fills the new words; a narrowing cast is free.
            let from = words(t, operand(a).ty.bits);
            t.costs.add * words(t, bits).saturating_sub(from)
        }
        Op::Add(..) | Op::Sub(..) | Op::Neg(_) | Op::Cmp(..) => add,
        Op::Min(..) | Op::Max(..) => add + t.costs.add * words(t, bits),
        Op::Select(..) => t.costs.add * (words(t, bits) + 1),
        Op::And(..) | Op::Or(..) | Op::Not(_) => t.costs.add,
        Op::Low(_, _) => t.costs.add * words(t, bits),
        Op::Shl(a, k) | Op::Shr(a, k) => {
            // Room to round a split shift up: the operand is narrower than its type.
            let room = value_bits(operand(a)) < bits;
            t.shift_cost(bits, k, room)
        }
        Op::Mul(a, b) => {
            let ob = value_bits(operand(a)).max(value_bits(operand(b)));
            t.widening_mul_cost(bits, ob)
        }
        Op::MulHi(..) => {
            // Three 16×16→32 pieces, two 32-bit adds, two 16-bit shifts (word moves).
            3 * t.widening_mul_cost(32, 16) + 2 * t.add_cost(32) + 2 * t.shift_cost(32, 16, false)
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::lower::target::{MulKind, Target};

    /// An 8-bit core with an 8×8 multiplier and no barrel shifter, as the AVR targets.
    fn small_core() -> Target {
        let mut t = Target {
            word_bits: 8,
            ..Default::default()
        };
        t.multiplier.kind = MulKind::M8x8;
        t.multiplier.cycles = 2;
        t.shifter.barrel = false;
        t.shifter.loop_cycles = 3;
        t.costs.libcall_bits = 64;
        t.c.int_bits = 16;
        t
    }

    fn plan(src: &str, t: &Target) -> crate::lower::Plan {
        crate::compile_str(src, t).unwrap_or_else(|e| panic!("{}", e.message))
    }

    const SPEC: &str = "controller c { period 1 \"s\"; input x: [-1.0, 1.0]; \
        state s: [-4.0, 4.0] = 0.0; output y: [-4.0, 4.0]; \
        step { s = s + 0.75 * x; y = s * x; } }";

    /// A wider word costs more on a small core, and a branch counts its dearer side in
    /// cycles and both in size.
    #[test]
    fn wider_words_and_both_branches_cost_more() {
        let t = small_core();
        let narrow = super::estimate(&plan(&SPEC.replace("period", "word 16; period"), &t));
        let wide = super::estimate(&plan(SPEC, &t));
        assert!(narrow.cycles < wide.cycles, "{narrow:?} vs {wide:?}");
        let branchy = SPEC.replace("y = s * x;", "if x > 0.0 { y = s * x; } else { y = s; }");
        let b = super::estimate(&plan(&branchy, &t));
        assert!(b.size > b.cycles, "{b:?}");
    }
}
