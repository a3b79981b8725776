//! Monte-Carlo sweeps: each draw picks a scenario and every uncertain plant parameter
//! ([`crate::Plant::params`]) uniformly in its range, with its own sensor-noise seed, all from
//! one 64-bit draw seed, so any draw can be replayed exactly from its seed. [`Envelope`]
//! keeps the worst case of each metric and the seed that produced it.

use crate::metrics::Metrics;
use crate::plant::Plant;
use crate::scenario::Scenario;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The seed of draw `i` of a sweep seeded with `base` (SplitMix64 of both: distinct, well
/// mixed seeds for consecutive draws).
pub fn draw_seed(base: u64, i: u64) -> u64 {
    let mut z = base
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add(i.wrapping_add(1).wrapping_mul(0xbf58_476d_1ce4_e5b9));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// One draw: the plant with its drawn parameters, the scenario (noise seed set), and the
/// parameter values.
pub struct Draw {
    /// The draw's seed.
    pub seed: u64,
    /// The plant, parameters set.
    pub plant: Box<dyn Plant>,
    /// The scenario, with the draw's noise seed.
    pub scenario: Scenario,
    /// The drawn parameter values, in [`Plant::params`] order.
    pub params: Vec<(&'static str, f64)>,
}

/// Draws plant parameters and a scenario (one of `scenarios`) from `seed`.
pub fn draw(nominal: &dyn Plant, scenarios: &[Scenario], seed: u64) -> Result<Draw, String> {
    if scenarios.is_empty() {
        return Err("a sweep needs at least one scenario".into());
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut sc = scenarios[rng.random_range(0..scenarios.len())].clone();
    sc.seed = rng.random();
    let mut plant = nominal.fresh();
    let mut params = Vec::new();
    for p in nominal.params() {
        let (lo, hi) = p.range;
        let v = if hi > lo {
            rng.random_range(lo..=hi)
        } else {
            lo
        };
        plant.set_param(p.name, v)?;
        params.push((p.name, v));
    }
    Ok(Draw {
        seed,
        plant,
        scenario: sc,
        params,
    })
}

/// What one draw gave, reduced to the numbers a sweep compares.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The draw's seed.
    pub seed: u64,
    /// The scenario's name.
    pub scenario: String,
    /// The drawn parameters.
    pub params: Vec<(&'static str, f64)>,
    /// Whether the fixed-point loop stayed stable.
    pub stable: bool,
    /// Whether the f64 reference loop stayed stable.
    pub stable_ref: bool,
    /// Frequency of the fixed-point loop's first oscillation, if any.
    pub osc_hz: Option<f64>,
    /// Largest |steady-state error| over cutting segments (fixed-point loop).
    pub ss_error: f64,
    /// Largest overshoot fraction over cutting segments.
    pub overshoot: f64,
    /// Largest loop overshoot ([`crate::metrics::Segment::loop_overshoot`]) over cutting
    /// segments.
    pub loop_overshoot: f64,
    /// Longest settling time over cutting segments (∞ if some does not settle).
    pub settling_s: f64,
    /// Longest rise time over cutting segments (∞ if some never comes near the reference).
    pub rise_s: f64,
    /// Lowest damping ratio over cutting segments that swing through the reference (1 if
    /// none does: no overshoot beyond the band to measure).
    pub damping: f64,
    /// Largest late ringing over cutting segments ([`crate::metrics::Segment::ringing`]),
    /// as a fraction of the reference; 0 if none rings.
    pub ringing: f64,
    /// max |fixed − f64| per compared signal.
    pub max_diff: Vec<(String, f64)>,
}

impl Outcome {
    /// Reduces a run's metrics.
    pub fn new(d: &Draw, m: &Metrics) -> Outcome {
        let cut = || m.fixed.segments.iter().filter(|s| s.cutting);
        Outcome {
            seed: d.seed,
            scenario: d.scenario.name.clone(),
            params: d.params.clone(),
            stable: m.fixed.stable(),
            stable_ref: m.reference.stable(),
            osc_hz: m.fixed.first_oscillation().map(|s| s.osc_hz),
            ss_error: cut().map(|s| s.ss_error.abs()).fold(0.0, f64::max),
            overshoot: cut().map(|s| s.overshoot).fold(0.0, f64::max),
            loop_overshoot: cut().map(|s| s.loop_overshoot).fold(0.0, f64::max),
            settling_s: cut()
                .map(|s| s.settling_s.unwrap_or(f64::INFINITY))
                .fold(0.0, f64::max),
            rise_s: cut()
                .map(|s| s.rise_s.unwrap_or(f64::INFINITY))
                .fold(0.0, f64::max),
            damping: cut().filter_map(|s| s.damping).fold(1.0, f64::min),
            ringing: cut().filter_map(|s| s.ringing).fold(0.0, f64::max),
            max_diff: m.max_diff.clone(),
        }
    }
}

/// A worst case: the value and the draw that gave it.
#[derive(Clone, Debug, PartialEq)]
pub struct Worst {
    /// The metric's worst value.
    pub value: f64,
    /// The draw.
    pub outcome: Outcome,
}

/// The envelope of a sweep: counts and the worst case of each metric. Performance metrics
/// (steady-state error, overshoot, settling) are taken over the draws whose fixed-point loop
/// stayed stable; an unstable draw is counted and reported on its own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Envelope {
    /// Draws seen.
    pub draws: usize,
    /// Draws whose fixed-point loop was unstable.
    pub unstable: usize,
    /// Draws whose f64 reference loop was unstable.
    pub unstable_ref: usize,
    /// Draws where exactly one of the two loops was unstable.
    pub disagree: usize,
    /// The unstable draw with the lowest seed, if any.
    pub first_unstable: Option<Outcome>,
    /// Worst |steady-state error| (stable draws).
    pub ss_error: Option<Worst>,
    /// Worst overshoot (stable draws).
    pub overshoot: Option<Worst>,
    /// Worst loop overshoot (stable draws).
    pub loop_overshoot: Option<Worst>,
    /// Worst settling time (stable draws).
    pub settling_s: Option<Worst>,
    /// Worst rise time (stable draws).
    pub rise_s: Option<Worst>,
    /// Worst (lowest) damping ratio (stable draws); its `value` is 1 − ζ, so that worse is
    /// larger as for the other metrics.
    pub underdamping: Option<Worst>,
    /// Stable draws that ring later than [`crate::metrics::RING_AFTER_S`] into a segment.
    pub ringing: usize,
    /// Worst late ringing (stable draws), as a fraction of the reference.
    pub ringing_worst: Option<Worst>,
    /// Worst |fixed − f64| per signal (stable draws), in signal order.
    pub max_diff: Vec<(String, Worst)>,
}

/// Replaces `w` by (`value`, `o`) if that is worse. Ties go to the lower seed, so the result
/// does not depend on the order of the draws.
fn keep_worse(w: &mut Worst, value: f64, o: &Outcome) {
    if value > w.value || (value == w.value && o.seed < w.outcome.seed) {
        *w = Worst {
            value,
            outcome: o.clone(),
        };
    }
}

fn keep_max(slot: &mut Option<Worst>, value: f64, o: &Outcome) {
    match slot {
        Some(w) => keep_worse(w, value, o),
        None => {
            *slot = Some(Worst {
                value,
                outcome: o.clone(),
            })
        }
    }
}

impl Envelope {
    /// Adds one draw.
    pub fn add(&mut self, o: &Outcome) {
        self.draws += 1;
        if !o.stable_ref {
            self.unstable_ref += 1;
        }
        if o.stable != o.stable_ref {
            self.disagree += 1;
        }
        if !o.stable {
            self.unstable += 1;
            if self.first_unstable.as_ref().is_none_or(|u| o.seed < u.seed) {
                self.first_unstable = Some(o.clone());
            }
            return;
        }
        keep_max(&mut self.ss_error, o.ss_error, o);
        keep_max(&mut self.overshoot, o.overshoot, o);
        keep_max(&mut self.loop_overshoot, o.loop_overshoot, o);
        keep_max(&mut self.settling_s, o.settling_s, o);
        keep_max(&mut self.rise_s, o.rise_s, o);
        keep_max(&mut self.underdamping, 1.0 - o.damping, o);
        if o.ringing > 0.0 {
            self.ringing += 1;
            keep_max(&mut self.ringing_worst, o.ringing, o);
        }
        for (name, d) in &o.max_diff {
            match self.max_diff.iter_mut().find(|(n, _)| n == name) {
                Some((_, w)) => keep_worse(w, *d, o),
                None => self.max_diff.push((
                    name.clone(),
                    Worst {
                        value: *d,
                        outcome: o.clone(),
                    },
                )),
            }
        }
    }

    /// Merges another envelope (for parallel reduction).
    pub fn merge(mut self, other: Envelope) -> Envelope {
        self.draws += other.draws;
        self.unstable += other.unstable;
        self.unstable_ref += other.unstable_ref;
        self.disagree += other.disagree;
        self.ringing += other.ringing;
        if let Some(u) = other.first_unstable {
            if self.first_unstable.as_ref().is_none_or(|s| u.seed < s.seed) {
                self.first_unstable = Some(u);
            }
        }
        for (mine, theirs) in [
            (&mut self.ss_error, other.ss_error),
            (&mut self.overshoot, other.overshoot),
            (&mut self.loop_overshoot, other.loop_overshoot),
            (&mut self.settling_s, other.settling_s),
            (&mut self.rise_s, other.rise_s),
            (&mut self.underdamping, other.underdamping),
            (&mut self.ringing_worst, other.ringing_worst),
        ] {
            if let Some(w) = theirs {
                keep_max(mine, w.value, &w.outcome);
            }
        }
        for (name, w) in other.max_diff {
            match self.max_diff.iter_mut().find(|(n, _)| *n == name) {
                Some((_, mine)) => keep_worse(mine, w.value, &w.outcome),
                None => self.max_diff.push((name, w)),
            }
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::turning::{scenarios, Turning, TurningParams};

    #[test]
    fn draws_are_reproducible_from_their_seed_and_inside_the_ranges() {
        let nominal = Turning::new(TurningParams::default());
        let scs = scenarios();
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..200 {
            let s = draw_seed(7, i);
            let a = draw(&nominal, &scs, s).unwrap();
            let b = draw(&nominal, &scs, s).unwrap();
            assert_eq!(
                (a.params.clone(), &a.scenario),
                (b.params.clone(), &b.scenario)
            );
            for ((name, v), p) in a.params.iter().zip(nominal.params()) {
                assert_eq!(*name, p.name);
                assert!(p.range.0 <= *v && *v <= p.range.1, "{name} = {v}");
            }
            // The plant really carries the drawn values.
            for (p, (_, v)) in a.plant.params().iter().zip(&a.params) {
                assert_eq!(p.value, *v);
            }
            seen.insert(a.scenario.name.clone());
        }
        assert_eq!(seen.len(), scs.len(), "every scenario gets drawn");
        assert_ne!(draw_seed(7, 0), draw_seed(7, 1));
        assert_ne!(draw_seed(7, 0), draw_seed(8, 0));
    }

    fn outcome(seed: u64, stable: bool, ss: f64, diff: f64) -> Outcome {
        Outcome {
            seed,
            scenario: "s".into(),
            params: vec![],
            stable,
            stable_ref: stable,
            osc_hz: None,
            ss_error: ss,
            overshoot: ss,
            loop_overshoot: ss,
            settling_s: ss,
            rise_s: ss,
            damping: 1.0 / (1.0 + ss),
            ringing: if seed.is_multiple_of(2) { ss } else { 0.0 },
            max_diff: vec![("x".into(), diff)],
        }
    }

    #[test]
    fn envelope_keeps_the_worst_and_merging_is_order_free() {
        let os: Vec<Outcome> = (0..20)
            .map(|i| outcome(100 - i, i % 7 != 3, ((i * 37) % 11) as f64, (i % 5) as f64))
            .collect();
        let mut all = Envelope::default();
        os.iter().for_each(|o| all.add(o));
        let (mut a, mut b) = (Envelope::default(), Envelope::default());
        os[..9].iter().for_each(|o| a.add(o));
        os[9..].iter().for_each(|o| b.add(o));
        let merged = b.merge(a);
        assert_eq!(merged, all);
        assert_eq!(all.draws, 20);
        assert_eq!(all.unstable, 3); // i = 3, 10, 17
        assert_eq!(all.first_unstable.as_ref().unwrap().seed, 83); // i = 17
        let stable_max = os
            .iter()
            .filter(|o| o.stable)
            .map(|o| o.ss_error)
            .fold(0.0, f64::max);
        assert_eq!(all.ss_error.as_ref().unwrap().value, stable_max);
        assert_eq!(all.max_diff[0].1.value, 4.0);
    }
}
