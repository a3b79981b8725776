//! Concrete witnesses of a property's premises: a state, input and parameter values that
//! meet them, found by running the plan, so that the vacuity check needs no solver.
//!
//! A property whose premises (state ranges, invariants, input ranges, parameter ranges and
//! `assume`s) no state meets holds vacuously, so `qloop prove` asks a bit-precise solver
//! query for such a state. Where the premises hold in a state the controller reaches anyway,
//! a run of the plan finds one in microseconds, while the solver query carries every product
//! of the invariants (the determinant of a 3 × 3 covariance: a minute of z3). The search
//! here tries the initial state and the states of a few seeded random runs (each also with
//! its values rounded to a few significant bits), each with a few input and parameter
//! choices; an `assume` that an input equals an expression of the pre-state (`ra == θᵀφ`:
//! "a measurement the model predicts exactly") is met by setting that input, where the value
//! is representable. Every premise is then checked exactly (the replay's evaluator): a witness
//! found is a real one. When none is found, the solver query runs as before.

use super::obligations::param_grids;
use super::replay::{Frame, Q};
use crate::interp::step_fixed;
use crate::ir::{CmpOp, PCond, PExpr, SigId, SigKind, When};
use crate::lower::Plan;
use num_bigint::BigInt;

/// Steps of each random run, and how many runs.
const STEPS: usize = 24;
const RUNS: usize = 4;

/// A small deterministic generator (xorshift64*): reproducible witnesses, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A value of `[lo, hi]`: an end, the middle, zero (if inside) or uniform.
    fn pick(&mut self, lo: i128, hi: i128) -> i128 {
        let span = (hi - lo) as u128;
        match self.next() % 5 {
            0 => lo,
            1 => hi,
            2 => lo + (hi - lo) / 2,
            3 if lo <= 0 && 0 <= hi => 0,
            _ if span == u128::MAX => lo,
            _ => {
                lo + ((u128::from(self.next()) << 64 | u128::from(self.next())) % (span + 1))
                    as i128
            }
        }
    }
}

/// A state, input and parameter values meeting every premise of property `k`, described in
/// words (`the initial state`, `step 7 of run 2`), if the search finds one.
pub fn concrete(plan: &Plan, k: usize) -> Option<String> {
    let prog = &plan.prog;
    let prop = &prog.properties[k];
    let grids = param_grids(plan, k);
    let inputs: Vec<SigId> = prog.ids_of(SigKind::Input).collect();
    let states: Vec<SigId> = prog.ids_of(SigKind::State).collect();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ k as u64);
    let mut init = vec![0i128; prog.signals.len()];
    for &id in &states {
        init[id.0] = plan.raw_init(id);
    }
    // Whether the premises hold at pre-slots `pre` for some inputs and parameters tried.
    let meets = |pre: &[i128], rng: &mut Rng| -> bool {
        let in_range = |id: SigId, v: i128| {
            let (lo, hi) = plan.bounds(id);
            (lo..=hi).contains(&v)
        };
        if !states.iter().all(|&id| in_range(id, pre[id.0])) {
            return false;
        }
        let frame = Frame {
            plan,
            pre,
            post: pre,
            params: &[],
        };
        if !prog
            .invariants
            .iter()
            .all(|i| frame.cond(&i.cond) == Some(true))
        {
            return false;
        }
        for _ in 0..8 {
            let mut slots = pre.to_vec();
            for &id in &inputs {
                let (lo, hi) = plan.bounds(id);
                slots[id.0] = rng.pick(lo, hi);
            }
            let params: Vec<Q> = grids
                .iter()
                .map(|g| Q {
                    raw: BigInt::from(rng.pick(g.lo, g.hi)),
                    frac: g.frac,
                })
                .collect();
            solve_equalities(plan, &prop.assumes, &mut slots, &params);
            let mut post = slots.clone();
            if step_fixed(plan, &mut post).is_err() {
                continue;
            }
            let f = Frame {
                plan,
                pre: &slots,
                post: &post,
                params: &params,
            };
            if prop.assumes.iter().all(|c| f.cond(c) == Some(true)) {
                return true;
            }
        }
        false
    };
    // A state and, rounded to a few significant bits, a coarser one (an exact equality with
    // products of states is easier to meet with short values).
    let meets_either = |pre: &[i128], rng: &mut Rng| -> Option<&'static str> {
        if meets(pre, rng) {
            return Some("");
        }
        let mut coarse = pre.to_vec();
        for &id in &states {
            coarse[id.0] = coarsen(pre[id.0], COARSE_BITS);
        }
        meets(&coarse, rng).then_some(", rounded to a few bits")
    };
    if let Some(how) = meets_either(&init, &mut rng) {
        return Some(format!("the initial state{how}"));
    }
    for run in 1..=RUNS {
        let mut slots = init.clone();
        for step in 1..=STEPS {
            for &id in &inputs {
                let (lo, hi) = plan.bounds(id);
                slots[id.0] = rng.pick(lo, hi);
            }
            if step_fixed(plan, &mut slots).is_err() {
                break;
            }
            if let Some(how) = meets_either(&slots, &mut rng) {
                return Some(format!(
                    "step {step} of run {run} from the initial state{how}"
                ));
            }
        }
    }
    None
}

/// Significant bits kept by [`coarsen`].
const COARSE_BITS: u32 = 3;

/// `v` rounded toward zero to its `bits` most significant bits.
fn coarsen(v: i128, bits: u32) -> i128 {
    let mag = v.unsigned_abs();
    let width = 128 - mag.leading_zeros();
    let drop = width.saturating_sub(bits);
    let kept = (mag >> drop) << drop;
    if v < 0 {
        -(kept as i128)
    } else {
        kept as i128
    }
}

/// For each `assume` of the form `INPUT == e` (or `e == INPUT`) where `e` reads neither that
/// input nor any value after the step, sets the input's raw slot to `e`'s exact value when
/// its format and range hold it (otherwise leaves it).
fn solve_equalities(plan: &Plan, assumes: &[PCond], slots: &mut [i128], params: &[Q]) {
    let reads = |e: &PExpr, id: SigId| {
        let mut r = false;
        e.walk(&mut |x| {
            if let PExpr::Sig(s, w) = x {
                r |= *s == id || *w == When::Post;
            }
        });
        r
    };
    for c in assumes {
        let PCond::Cmp(CmpOp::Eq, a, b) = c else {
            continue;
        };
        for (x, e) in [(a, b), (b, a)] {
            let PExpr::Sig(id, _) = x else { continue };
            if plan.prog.sig(*id).kind != SigKind::Input || reads(e, *id) {
                continue;
            }
            let frame = Frame {
                plan,
                pre: slots,
                post: slots,
                params,
            };
            let Some(v) = frame.expr(e) else { continue };
            let f = plan.format(*id).frac;
            // Representable at the input's binary point: no bits below it.
            let shift = v.frac - f;
            let raw = if shift > 0 {
                let unit = BigInt::from(1) << shift as usize;
                if &v.raw % &unit != BigInt::from(0) {
                    continue;
                }
                &v.raw / &unit
            } else {
                &v.raw << (-shift) as usize
            };
            let (lo, hi) = plan.bounds(*id);
            if let Ok(raw) = i128::try_from(raw) {
                if (lo..=hi).contains(&raw) {
                    slots[id.0] = raw;
                }
            }
        }
    }
}
