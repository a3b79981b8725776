//! Test inputs for one compiled spec, aimed at where claims break: raw input bits beyond the
//! declared ranges (the entry clamp), the range bounds themselves, states at their saturation
//! bounds, and raw values on and next to every constant threshold a comparison tests.

use qloop::ir::{SigId, SigKind};
use qloop::lower::lir::{Op, ValId};
use qloop::Plan;

/// One step's starting point: raw input bits and raw states, in declaration order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Case {
    /// Raw bits of each input (any value of its storage type).
    pub inputs: Vec<i128>,
    /// Raw value of each state (inside its saturation bounds).
    pub states: Vec<i128>,
}

/// A xorshift step: a raw value in `[lo, hi]`.
pub fn pick(seed: &mut u64, lo: i128, hi: i128) -> i128 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    lo + (*seed as i128).rem_euclid(hi - lo + 1)
}

/// The value a comparison compares, followed back through casts.
fn source(plan: &Plan, mut v: ValId) -> ValId {
    while let Op::Cast(a) = plan.val(v).op {
        v = a;
    }
    v
}

/// The constant thresholds compared with the value `v` (its clamped input value or its
/// loaded state), as raw values in `v`'s format.
fn thresholds(plan: &Plan, of: impl Fn(ValId) -> bool) -> Vec<i128> {
    let mut t = Vec::new();
    for v in &plan.vals {
        if let Op::Cmp(_, a, b) = v.op {
            for (x, k) in [(a, b), (b, a)] {
                if let Op::Const(c) = plan.val(k).op {
                    let s = source(plan, x);
                    if of(s) && plan.val(s).frac == plan.val(k).frac {
                        t.extend([c - 1, c, c + 1]);
                    }
                }
            }
        }
    }
    t
}

/// Candidate raw values of each input and state: type limits, bounds and one step beyond,
/// zero, and every threshold with its neighbours, each clamped to what the signal may hold.
fn candidates(plan: &Plan) -> (Vec<Vec<i128>>, Vec<Vec<i128>>) {
    let prog = &plan.prog;
    let inputs: Vec<Vec<i128>> = prog
        .ids_of(SigKind::Input)
        .map(|id| {
            let q = plan.format(id);
            let (tmin, tmax) = (q.ty.min(), q.ty.max().min(i64::MAX as i128));
            let (lo, hi) = plan.bounds(id);
            let name = &prog.sig(id).name;
            let mut c = vec![tmin, tmax, lo, hi, lo - 1, hi + 1, 0];
            c.extend(thresholds(plan, |v| {
                plan.val(v).name.as_deref() == Some(name.as_str())
                    && !matches!(plan.val(v).op, Op::Input(_))
            }));
            c.retain(|&x| (tmin..=tmax).contains(&x));
            c.sort();
            c.dedup();
            c
        })
        .collect();
    let states: Vec<Vec<i128>> = prog
        .ids_of(SigKind::State)
        .map(|id| {
            let (lo, hi) = plan.raw_bounds(id).expect("states have ranges");
            let mut c = vec![lo, hi, lo + 1, hi - 1, plan.raw_init(id)];
            c.extend(thresholds(
                plan,
                |v| matches!(plan.val(v).op, Op::Load(s) if s == id),
            ));
            c.retain(|&x| (lo..=hi).contains(&x));
            c.sort();
            c.dedup();
            c
        })
        .collect();
    (inputs, states)
}

/// Candidate cases past which [`cases`] packs its sweep into rounds.
pub const SWEEP_BUDGET: usize = 1_000;

/// Cases for `plan`: each candidate of each signal once (the others drawn at random inside
/// their ranges, or anywhere in their type for inputs), then `random` cases drawn among all
/// candidates and random values.
///
/// Where that sweep would be more than [`SWEEP_BUDGET`] cases (a vector of 256 inputs and
/// states, the multi-model controller), it is packed: in round `r` every signal `k` takes its
/// candidate `(r + k) mod n_k`, the rest of the case drawn as above, for as many rounds as the
/// longest candidate list. Every candidate of every signal is still taken once at least, in
/// cases whose number grows with the candidates of one signal, not with the number of signals
/// (the 256-element vector spec: 7 rounds instead of 3,072 cases, each an exact evaluation of
/// its 3,079 values).
pub fn cases(plan: &Plan, seed: &mut u64, random: usize) -> Vec<Case> {
    let prog = &plan.prog;
    let in_ids: Vec<SigId> = prog.ids_of(SigKind::Input).collect();
    let st_ids: Vec<SigId> = prog.ids_of(SigKind::State).collect();
    let (ci, cs) = candidates(plan);
    let rand_input = |seed: &mut u64, k: usize| {
        let id = in_ids[k];
        let q = plan.format(id);
        if pick(seed, 0, 3) == 0 {
            pick(seed, q.ty.min(), q.ty.max().min(i64::MAX as i128))
        } else {
            let (lo, hi) = plan.bounds(id);
            pick(seed, lo, hi)
        }
    };
    let rand_state = |seed: &mut u64, k: usize| {
        let (lo, hi) = plan.raw_bounds(st_ids[k]).expect("ranged");
        pick(seed, lo, hi)
    };
    let random_case = |seed: &mut u64| Case {
        inputs: (0..in_ids.len()).map(|k| rand_input(seed, k)).collect(),
        states: (0..st_ids.len()).map(|k| rand_state(seed, k)).collect(),
    };
    let mut out = Vec::new();
    let sweep: usize = ci.iter().chain(&cs).map(Vec::len).sum();
    if sweep > SWEEP_BUDGET {
        let rounds = ci.iter().chain(&cs).map(Vec::len).max().unwrap_or(0);
        let at = |c: &Vec<i128>, r: usize, k: usize| c.get((r + k) % c.len().max(1)).copied();
        for r in 0..rounds {
            let mut case = random_case(seed);
            for (k, c) in ci.iter().enumerate() {
                if let Some(x) = at(c, r, k) {
                    case.inputs[k] = x;
                }
            }
            for (k, c) in cs.iter().enumerate() {
                if let Some(x) = at(c, r, k + ci.len()) {
                    case.states[k] = x;
                }
            }
            out.push(case);
        }
    } else {
        for (k, c) in ci.iter().enumerate() {
            for &x in c {
                let mut case = random_case(seed);
                case.inputs[k] = x;
                out.push(case);
            }
        }
        for (k, c) in cs.iter().enumerate() {
            for &x in c {
                let mut case = random_case(seed);
                case.states[k] = x;
                out.push(case);
            }
        }
    }
    for _ in 0..random {
        let mut case = random_case(seed);
        for (k, c) in ci.iter().enumerate() {
            if pick(seed, 0, 1) == 0 {
                case.inputs[k] = c[pick(seed, 0, c.len() as i128 - 1) as usize];
            }
        }
        for (k, c) in cs.iter().enumerate() {
            if pick(seed, 0, 1) == 0 {
                case.states[k] = c[pick(seed, 0, c.len() as i128 - 1) as usize];
            }
        }
        out.push(case);
    }
    out
}
