//! Sensor faults a scenario can inject between the plant and the controller (issue 18, item
//! 5): what a force or power sensor does when its electronics or the tool fail. Each acts on
//! the sensor's reading over a time window, before the ADC quantises it:
//!
//! * `saturate`: the amplifier rails: the reading is the ADC's full scale;
//! * `stuck`: the reading freezes at its value when the fault starts;
//! * `dropout`: a broken cable or amplifier: the reading is the ADC's bottom (zero force);
//! * `spikes`: a tool breaking: pulses of `height` (sensor units), `width_s` long, every
//!   `period_s`, added to the true value;
//! * `noise-burst`: extra Gaussian noise of standard deviation `sigma`, from its own seeded
//!   stream (the scenario's noise stream is not disturbed).
//!
//! A spindle stall is no sensor fault: the turning scenario `spindle-stall` drives the `n_rpm`
//! channel down to 30 % within 0.2 s.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Deserialize;

/// What a fault does to the reading.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum FaultKind {
    /// The reading is the ADC's full scale.
    Saturate,
    /// The reading holds its value from the fault's start.
    Stuck,
    /// The reading is the ADC's bottom (zero).
    Dropout,
    /// Pulses of `height` added to the true value, `width_s` long, every `period_s`.
    Spikes {
        /// Pulse height, in the sensor's unit.
        height: f64,
        /// Time between pulse starts.
        period_s: f64,
        /// Pulse length.
        width_s: f64,
    },
    /// Extra Gaussian noise.
    NoiseBurst {
        /// Its standard deviation, in the sensor's unit.
        sigma: f64,
    },
}

/// A fault over `[from_s, to_s)`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Fault {
    /// What it does.
    #[serde(flatten)]
    pub kind: FaultKind,
    /// Start time.
    pub from_s: f64,
    /// End time (the reading is healthy again from here).
    pub to_s: f64,
}

impl Fault {
    /// Whether the fault acts at `t`.
    pub fn active(&self, t: f64) -> bool {
        t >= self.from_s && t < self.to_s
    }

    /// Checks the window and the kind's numbers.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |v: f64| v.is_finite();
        if !(finite(self.from_s) && finite(self.to_s) && self.from_s < self.to_s) {
            return Err(format!(
                "fault window [{}, {}) must be finite and not empty",
                self.from_s, self.to_s
            ));
        }
        match self.kind {
            FaultKind::Spikes {
                height,
                period_s,
                width_s,
            } if !(finite(height) && period_s > 0.0 && width_s > 0.0 && width_s <= period_s) => {
                Err("spikes need a finite height and 0 < width_s ≤ period_s".into())
            }
            FaultKind::NoiseBurst { sigma } if !(sigma > 0.0 && finite(sigma)) => {
                Err("noise-burst needs sigma > 0".into())
            }
            _ => Ok(()),
        }
    }
}

/// The faults of a scenario, applied to one sensor's readings (one per loop, so the fixed-point
/// and reference loops see the same fault stream).
#[derive(Clone, Debug)]
pub struct Faults {
    faults: Vec<Fault>,
    /// The reading each `stuck` fault holds, once started.
    held: Vec<Option<f64>>,
    rng: ChaCha8Rng,
}

impl Faults {
    /// The faults `f`, with the noise-burst stream seeded from `seed`.
    pub fn new(f: &[Fault], seed: u64) -> Faults {
        Faults {
            faults: f.to_vec(),
            held: vec![None; f.len()],
            // A stream of its own: the scenario's sensor noise is drawn from `seed` itself.
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x6661_756c_7473),
        }
    }

    /// The sensor's value `x` at `t` (gain and noise applied) as the faulty sensor passes it
    /// to the ADC; `Err(v)` when a `stuck` fault fixes the quantised reading to `v`, the last
    /// reading `last` before it started. `range` is the ADC's.
    pub fn apply(&mut self, t: f64, x: f64, last: f64, range: (f64, f64)) -> Result<f64, f64> {
        let mut v = x;
        for (k, f) in self.faults.iter().enumerate() {
            if !f.active(t) {
                continue;
            }
            match f.kind {
                FaultKind::Saturate => return Ok(range.1),
                FaultKind::Dropout => return Ok(range.0),
                FaultKind::Stuck => return Err(*self.held[k].get_or_insert(last)),
                FaultKind::Spikes {
                    height,
                    period_s,
                    width_s,
                } => {
                    if (t - f.from_s).rem_euclid(period_s) < width_s {
                        v += height;
                    }
                }
                FaultKind::NoiseBurst { sigma } => {
                    if let Ok(n) = Normal::new(0.0, sigma) {
                        v += n.sample(&mut self.rng);
                    }
                }
            }
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_fault_acts_in_its_window_only() {
        let w = |kind| Fault {
            kind,
            from_s: 1.0,
            to_s: 2.0,
        };
        let mut f = Faults::new(
            &[
                w(FaultKind::Stuck),
                w(FaultKind::Spikes {
                    height: 3.0,
                    period_s: 0.5,
                    width_s: 0.1,
                }),
            ],
            1,
        );
        assert_eq!(f.apply(0.5, 1.2, 1.1, (0.0, 5.0)), Ok(1.2));
        // Stuck at the reading before the fault, whatever the true value does.
        assert_eq!(f.apply(1.0, 4.0, 1.1, (0.0, 5.0)), Err(1.1));
        assert_eq!(f.apply(1.7, 0.3, 2.0, (0.0, 5.0)), Err(1.1));
        assert_eq!(f.apply(2.0, 0.3, 1.1, (0.0, 5.0)), Ok(0.3));
        let mut s = Faults::new(
            &[w(FaultKind::Spikes {
                height: 3.0,
                period_s: 0.5,
                width_s: 0.1,
            })],
            1,
        );
        assert_eq!(s.apply(1.05, 1.0, 0.0, (0.0, 5.0)), Ok(4.0));
        assert_eq!(s.apply(1.2, 1.0, 0.0, (0.0, 5.0)), Ok(1.0));
        assert_eq!(s.apply(1.55, 1.0, 0.0, (0.0, 5.0)), Ok(4.0));
        let mut d = Faults::new(&[w(FaultKind::Dropout), w(FaultKind::Saturate)], 1);
        assert_eq!(d.apply(1.5, 2.0, 2.0, (0.0, 5.0)), Ok(0.0));
    }

    #[test]
    fn bad_windows_and_numbers_are_refused() {
        let f = Fault {
            kind: FaultKind::Stuck,
            from_s: 2.0,
            to_s: 2.0,
        };
        assert!(f.validate().is_err());
        let f = Fault {
            kind: FaultKind::Spikes {
                height: 1.0,
                period_s: 0.1,
                width_s: 0.2,
            },
            from_s: 0.0,
            to_s: 1.0,
        };
        assert!(f.validate().is_err());
        let f = Fault {
            kind: FaultKind::NoiseBurst { sigma: 0.0 },
            from_s: 0.0,
            to_s: 1.0,
        };
        assert!(f.validate().is_err());
    }
}
