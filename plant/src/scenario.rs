//! Scenarios as data: named channels (depth of cut, spindle speed, ...) given as
//! piecewise-linear schedules of `[time_s, value]` points. Two points at the same time make a
//! step. Scenarios are built in code (the paper experiments in [`crate::turning`]) or read
//! from TOML files:
//!
//! ```toml
//! name = "depth-steps"
//! duration_s = 31.0
//! noise_sigma = 0.0      # sensor noise, in the sensor's unit (optional)
//! seed = 1               # noise seed (optional)
//! [channels]
//! a_mm = [[0, 0], [1, 0], [1, 2], [11, 2], [11, 4], [21, 4], [21, 6]]
//! n_rpm = [[0, 500]]
//! ```

use crate::fault::Fault;
use serde::Deserialize;
use std::collections::BTreeMap;

/// A piecewise-linear schedule: points sorted by time; constant before the first and after
/// the last point.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(try_from = "Vec<Vec<f64>>")]
pub struct Schedule(pub Vec<[f64; 2]>);

impl TryFrom<Vec<Vec<f64>>> for Schedule {
    type Error = String;
    fn try_from(v: Vec<Vec<f64>>) -> Result<Self, String> {
        v.into_iter()
            .map(|p| match p.as_slice() {
                [t, x] => Ok([*t, *x]),
                _ => Err(format!("a schedule point is [time_s, value], not {p:?}")),
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Schedule)
    }
}

impl Schedule {
    /// From `(time_s, value)` points.
    pub fn from_points(points: &[(f64, f64)]) -> Schedule {
        Schedule(points.iter().map(|&(t, v)| [t, v]).collect())
    }

    /// A constant.
    pub fn constant(v: f64) -> Schedule {
        Schedule(vec![[0.0, v]])
    }

    /// The value at time `t` (at a step, the later point wins).
    pub fn at(&self, t: f64) -> f64 {
        let p = &self.0;
        let Some(first) = p.first() else { return 0.0 };
        if t < first[0] {
            return first[1];
        }
        // The last point with time ≤ t, and the one after it.
        let i = p.partition_point(|q| q[0] <= t);
        let a = p[i - 1];
        match p.get(i) {
            Some(b) if b[0] > a[0] => a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0]),
            _ => a[1],
        }
    }

    /// Times where the schedule has a step or a kink (each point's time, deduplicated).
    pub fn breakpoints(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.0.iter().map(|p| p[0]).collect();
        v.dedup();
        v
    }
}

/// A scenario: channel schedules, duration and sensor noise.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Scenario {
    /// Name.
    pub name: String,
    /// Simulated time.
    pub duration_s: f64,
    /// Sensor noise standard deviation, in the sensor's unit.
    #[serde(default)]
    pub noise_sigma: f64,
    /// Noise seed.
    #[serde(default = "one")]
    pub seed: u64,
    /// The channels, by name (e.g. `a_mm`, `n_rpm`).
    pub channels: BTreeMap<String, Schedule>,
    /// Sensor faults ([`crate::fault`]): `[[faults]]` tables in TOML, e.g.
    /// `kind = "stuck"`, `from_s = 10.0`, `to_s = 15.0`.
    #[serde(default)]
    pub faults: Vec<Fault>,
}

fn one() -> u64 {
    1
}

impl Scenario {
    /// A scenario with noise seed 1 and the given channels.
    pub fn new(
        name: &str,
        duration_s: f64,
        noise_sigma: f64,
        channels: &[(&str, Schedule)],
    ) -> Scenario {
        Scenario {
            name: name.into(),
            duration_s,
            noise_sigma,
            seed: 1,
            channels: channels
                .iter()
                .map(|(n, s)| (n.to_string(), s.clone()))
                .collect(),
            faults: Vec::new(),
        }
    }

    /// The scenario with `faults` injected.
    pub fn with_faults(mut self, faults: Vec<Fault>) -> Scenario {
        self.faults = faults;
        self
    }

    /// A channel's value at `t`, or `default` if the scenario does not set it.
    pub fn value(&self, channel: &str, t: f64, default: f64) -> f64 {
        self.channels.get(channel).map_or(default, |s| s.at(t))
    }

    /// Reads a scenario from TOML text; errors name the line and column.
    pub fn from_toml(text: &str) -> Result<Scenario, String> {
        let s: Scenario = toml::from_str(text).map_err(|e| e.to_string())?;
        s.validate()?;
        Ok(s)
    }

    /// Checks times are sorted and finite and the duration is positive.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(format!(
                "scenario `{}`: duration_s must be a positive number of seconds",
                self.name
            ));
        }
        for (name, s) in &self.channels {
            if s.0.is_empty() {
                return Err(format!(
                    "channel `{name}` has no points; give at least one [t, value]"
                ));
            }
            for w in s.0.windows(2) {
                if w[1][0] < w[0][0] {
                    return Err(format!(
                        "channel `{name}`: times must not decrease ({} after {})",
                        w[1][0], w[0][0]
                    ));
                }
            }
            if s.0.iter().flatten().any(|v| !v.is_finite()) {
                return Err(format!(
                    "channel `{name}`: every time and value must be finite"
                ));
            }
        }
        for (i, f) in self.faults.iter().enumerate() {
            f.validate()
                .map_err(|e| format!("scenario `{}`, fault {}: {e}", self.name, i + 1))?;
        }
        Ok(())
    }

    /// Every time at which some channel steps or kinks, sorted, inside `(0, duration)`.
    pub fn breakpoints(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .channels
            .values()
            .flat_map(Schedule::breakpoints)
            .filter(|t| *t > 0.0 && *t < self.duration_s)
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_and_ramps() {
        let s = Schedule(vec![[1.0, 0.0], [1.0, 2.0], [3.0, 6.0]]);
        assert_eq!(s.at(0.0), 0.0);
        assert_eq!(s.at(0.999), 0.0);
        assert_eq!(s.at(1.0), 2.0);
        assert_eq!(s.at(2.0), 4.0);
        assert_eq!(s.at(10.0), 6.0);
    }

    #[test]
    fn toml_round_trip_and_errors() {
        let s = Scenario::from_toml(
            "name = \"x\"\nduration_s = 5.0\n[channels]\na_mm = [[0, 2], [2, 2], [2, 4]]\n",
        )
        .unwrap();
        assert_eq!(s.value("a_mm", 3.0, 0.0), 4.0);
        assert_eq!(s.value("n_rpm", 3.0, 500.0), 500.0);
        assert_eq!(s.breakpoints(), vec![2.0]);
        let e = Scenario::from_toml(
            "name = \"x\"\nduration_s = 5.0\n[channels]\na_mm = [[3, 2], [2, 4]]\n",
        )
        .unwrap_err();
        assert!(e.contains("must not decrease"), "{e}");
        let e =
            Scenario::from_toml("name = \"x\"\nduration_s = 5.0\n[channels]\na_mm = [[3, 2, 1]]\n")
                .unwrap_err();
        assert!(e.contains("line 4") && e.contains("[time_s, value]"), "{e}");
    }

    #[test]
    fn faults_read_from_toml_and_are_checked() {
        let s = Scenario::from_toml(
            "name = \"f\"\nduration_s = 5.0\n[channels]\na_mm = [[0, 2]]\n\
             [[faults]]\nkind = \"stuck\"\nfrom_s = 1.0\nto_s = 2.0\n\
             [[faults]]\nkind = \"spikes\"\nheight = 3.0\nperiod_s = 0.5\nwidth_s = 0.1\nfrom_s = 2.0\nto_s = 3.0\n",
        )
        .unwrap();
        assert_eq!(s.faults.len(), 2);
        assert_eq!(s.faults[0].kind, crate::fault::FaultKind::Stuck);
        let e = Scenario::from_toml(
            "name = \"f\"\nduration_s = 5.0\n[channels]\na_mm = [[0, 2]]\n\
             [[faults]]\nkind = \"noise-burst\"\nsigma = -1.0\nfrom_s = 1.0\nto_s = 2.0\n",
        )
        .unwrap_err();
        assert!(e.contains("fault 1") && e.contains("sigma"), "{e}");
        let e = Scenario::from_toml(
            "name = \"f\"\nduration_s = 5.0\n[channels]\na_mm = [[0, 2]]\n\
             [[faults]]\nkind = \"melt\"\nfrom_s = 1.0\nto_s = 2.0\n",
        )
        .unwrap_err();
        assert!(e.contains("melt"), "{e}");
    }
}
