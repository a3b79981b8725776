//! The Pareto front of the scored candidates and the order in which `qloop tune` tries to
//! prove them: the goals first, then speed.

use super::score::Score;

/// The objectives, all minimised: unstable fraction, worst overshoot, worst settling time,
/// worst rise time, worst |steady-state error|.
pub fn objectives(s: &Score) -> [f64; 5] {
    [
        1.0 - s.stable_frac(),
        s.overshoot(),
        s.settling(),
        s.rise(),
        s.ss_error(),
    ]
}

/// Whether `a` dominates `b`: no worse in every objective and better in one.
pub fn dominates(a: &[f64; 5], b: &[f64; 5]) -> bool {
    a.iter().zip(b).all(|(x, y)| x <= y) && a.iter().zip(b).any(|(x, y)| x < y)
}

/// The indices of `scores` that no other dominates (`None` entries are not candidates).
pub fn front(scores: &[Option<&Score>]) -> Vec<usize> {
    let obj: Vec<Option<[f64; 5]>> = scores.iter().map(|s| s.map(objectives)).collect();
    (0..obj.len())
        .filter(|&i| {
            obj[i].is_some_and(|a| !obj.iter().any(|b| b.is_some_and(|b| dominates(&b, &a))))
        })
        .collect()
}

/// The closed-loop goals.
#[derive(Clone, Copy, Debug)]
pub struct Goals {
    /// Largest worst-case overshoot, as a fraction of the reference.
    pub overshoot: f64,
    /// Largest worst-case 5 % settling time, in seconds.
    pub settling_s: f64,
}

impl Goals {
    /// Whether a score meets the goals: every draw of both loops stable, and the worst
    /// overshoot and settling time within them.
    pub fn met(&self, s: &Score) -> bool {
        s.all_stable() && s.overshoot() <= self.overshoot && s.settling() <= self.settling_s
    }

    /// How far a score misses the goals: the larger ratio of its worst overshoot and settling
    /// time to theirs (≤ 1 when met), ∞ when some draw is unstable.
    pub fn excess(&self, s: &Score) -> f64 {
        if !s.all_stable() {
            return f64::INFINITY;
        }
        (s.overshoot() / self.overshoot).max(s.settling() / self.settling_s)
    }
}

/// The order in which to try candidates: first those meeting the goals, fastest worst rise
/// first (the goals bought with the least speed; ties to the smaller overshoot); then every
/// other stable candidate by how far it misses the goals (so that when the prover refutes
/// every candidate meeting them, the closest that proves is found). Ties go to the candidate
/// that changes fewer constants of the spec (`changes[i]`).
pub fn preference(scores: &[Option<&Score>], goals: &Goals, changes: &[usize]) -> Vec<usize> {
    let key = |i: usize| {
        let s = scores[i].expect("scored");
        (s.rise(), s.overshoot(), s.settling())
    };
    let mut ok: Vec<usize> = (0..scores.len())
        .filter(|&i| scores[i].is_some_and(|s| goals.met(s)))
        .collect();
    ok.sort_by(|&a, &b| {
        let (x, y) = (key(a), key(b));
        x.0.total_cmp(&y.0)
            .then(x.1.total_cmp(&y.1))
            .then(x.2.total_cmp(&y.2))
            .then(changes[a].cmp(&changes[b]))
            .then(a.cmp(&b))
    });
    let mut rest: Vec<usize> = (0..scores.len())
        .filter(|&i| scores[i].is_some_and(|s| !goals.met(s) && goals.excess(s).is_finite()))
        .collect();
    rest.sort_by(|&a, &b| {
        let ex = |i: usize| goals.excess(scores[i].expect("scored"));
        ex(a)
            .total_cmp(&ex(b))
            .then(changes[a].cmp(&changes[b]))
            .then(a.cmp(&b))
    });
    ok.extend(rest);
    ok
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domination_is_strict_and_the_front_keeps_the_undominated() {
        let a = [0.0, 0.1, 2.0, 1.0, 0.0];
        let b = [0.0, 0.2, 2.0, 1.0, 0.0];
        let c = [0.0, 0.05, 3.0, 1.0, 0.0];
        assert!(dominates(&a, &b) && !dominates(&b, &a));
        assert!(!dominates(&a, &a), "a point does not dominate itself");
        assert!(!dominates(&a, &c) && !dominates(&c, &a));
    }
}
