//! The switching supervisor of Rubio & De la Sen, Sec. IV.B (tests/supervisor.qloop), the integer part of
//! issue 17's multi-model controller: its residence-time properties are proved by both
//! solvers on the generated code, and the compiled supervisor makes the same decisions as an
//! independent model of Rubio & De la Sen's rule (window sums in exact integers, argmin, residence time)
//! over long random runs, in which no two switches are closer than N_R periods.

use fixed::types::extra::U24;
use fixed::FixedI32;
use rand::{Rng, SeedableRng};
use std::collections::VecDeque;

qloop_macros::controller!("tests/supervisor.qloop");

const NM: usize = 7;
const M: usize = 8;
const NR: usize = 2;

#[test]
fn residence_time_and_valid_index_are_proved() {
    let p = qloop::compile_str(include_str!("supervisor.qloop"), &qloop::Target::default())
        .expect("supervisor.qloop compiles");
    qloop_tests::assert_proved(
        &p,
        120_000,
        &[
            "switch_only_after_residence",
            "switch_restarts_the_count",
            "count_advances_by_one",
            "active_is_a_model",
        ],
    );
}

/// Rubio & De la Sen's rule, written independently: J_l = Σ of the last M squared errors (raw integers,
/// exact), best = the lowest index of the smallest J, switch when N_R periods have passed.
struct Model {
    hist: Vec<VecDeque<i64>>,
    active: usize,
    since: usize,
}

impl Model {
    fn step(&mut self, e2: &[i64; NM]) -> usize {
        for (h, e) in self.hist.iter_mut().zip(e2) {
            h.push_front(*e);
            h.truncate(M);
        }
        let j: Vec<i64> = self.hist.iter().map(|h| h.iter().sum()).collect();
        let best = (0..NM).min_by_key(|&l| (j[l], l)).expect("models");
        if self.since >= NR && best != self.active {
            self.active = best;
            self.since = 0;
        } else {
            self.since = (self.since + 1).min(NR);
        }
        self.active
    }
}

#[test]
fn compiled_supervisor_follows_the_rule_and_keeps_the_residence_time() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    for run in 0..20 {
        let mut c = supervisor::Controller::new();
        let mut m = Model {
            hist: vec![VecDeque::from(vec![0; M]); NM],
            active: 1,
            since: 0,
        };
        let mut last_switch: Option<usize> = None;
        let mut prev = 1;
        for k in 0..2000 {
            // Errors on a coarse grid in some runs, so that ties between windows happen.
            let e2: [i64; NM] = std::array::from_fn(|_| {
                if run % 2 == 0 {
                    rng.random_range(0..=4) << 22
                } else {
                    rng.random_range(0..=(4i64 << 24))
                }
            });
            let out = c.step(supervisor::Inputs {
                e2: e2.map(|b| FixedI32::<U24>::from_bits(b as i32)),
            });
            let want = m.step(&e2);
            let got = out.model.to_num::<usize>();
            assert_eq!(got, want, "run {run}, period {k}");
            if got != prev {
                if let Some(s) = last_switch {
                    assert!(k - s >= NR, "run {run}: switches at {s} and {k}");
                }
                last_switch = Some(k);
                prev = got;
            }
        }
        assert!(
            last_switch.is_some(),
            "run {run} never switched: the test would be vacuous"
        );
    }
}
