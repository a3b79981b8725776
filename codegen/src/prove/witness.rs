//! Concrete witnesses of a property's premises: a state, input and parameter values that
//! meet them, found by running the plan, so that the vacuity check needs no solver.
//!
//! A property whose premises (state ranges, invariants, input ranges, parameter ranges and
//! `assume`s) no state meets holds vacuously, so `qloop prove` asks a bit-precise solver
//! query for such a state. Where the premises hold in a state the controller reaches anyway,
//! a run of the plan finds one in microseconds, while the solver query carries every product
//! of the invariants (the determinant of a 3 × 3 covariance: a minute of z3). The search
//! here tries the initial state and the states of a few seeded random runs, each with a few
//! input and parameter choices, and checks every premise exactly (the replay's evaluator): a
//! witness found is a real one. When none is found, the solver query runs as before.

use super::obligations::param_grids;
use super::replay::{Frame, Q};
use crate::interp::step_fixed;
use crate::ir::{SigId, SigKind};
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
    if meets(&init, &mut rng) {
        return Some("the initial state".into());
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
            if meets(&slots, &mut rng) {
                return Some(format!("step {step} of run {run} from the initial state"));
            }
        }
    }
    None
}
