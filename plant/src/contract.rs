//! The plant contract as data: what a plant measures and what it is commanded, in which units,
//! which scenario channels it reads, and the reference a loop on it is measured against.
//! `qloop plants` prints it; `qloop sim` checks a spec against it before compiling.
//!
//! How a controller binds to a plant: its **first input** reads the plant's measurement
//! (through the sensor) and its **first output** is the plant's command. A unit of the same
//! dimension is converted ([`Binding`]: N for kN, mm/min for mm/s); a dimensionless output (a
//! feed override, in `%` or as a fraction) becomes a feed through a nominal feed. **Every
//! further input** reads the scenario channel of its name, in the unit of the contract's
//! [`Channel`].

use crate::plant::Plant;
use crate::scenario::Scenario;

/// A scenario channel a plant reads (or a controller input may read).
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// The channel's name in scenarios (`a_mm`, `n_rpm`).
    pub name: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// Its value where a scenario does not give it.
    pub default: f64,
    /// What it is.
    pub what: &'static str,
}

/// What a plant offers a controller.
#[derive(Clone, Debug, PartialEq)]
pub struct Contract {
    /// The plant's name.
    pub plant: &'static str,
    /// The measured signal (read by the controller's first input): name, unit, what.
    pub measured: (&'static str, &'static str, &'static str),
    /// The command (the controller's first output): name, unit, what.
    pub command: (&'static str, &'static str, &'static str),
    /// The scenario channels the plant reads, and `fr` (the reference) where it has one.
    pub channels: Vec<Channel>,
    /// The default reference, in the measured unit.
    pub reference: f64,
}

impl Contract {
    /// The contract of `plant`.
    pub fn of(plant: &dyn Plant) -> Contract {
        let (m, c) = (plant.measured(), plant.command());
        let (mw, cw) = plant.describe();
        Contract {
            plant: plant.name(),
            measured: (m.0, m.1, mw),
            command: (c.0, c.1, cw),
            channels: plant.channels(),
            reference: plant.reference(&Scenario::new("contract", 1.0, 0.0, &[]), 0.0),
        }
    }

    /// The channel named `name`, if the plant has it.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// The contract as text, for `qloop plants` and for errors.
    pub fn describe(&self) -> String {
        let mut s = format!("plant `{}`\n", self.plant);
        s += &format!(
            "  measures  {} in {} ({}): the controller's FIRST INPUT reads it\n",
            self.measured.0, self.measured.1, self.measured.2
        );
        s += &format!(
            "  command   {} in {} ({}): the controller's FIRST OUTPUT{}\n",
            self.command.0,
            self.command.1,
            self.command.2,
            if self.command.0 == "feed" {
                "; a dimensionless or % output is a feed override (needs a nominal feed)"
            } else {
                ""
            }
        );
        s += &format!(
            "  reference {} {} by default; a `#[reference]` param (or one named FR), a `fr` input or a `fr` scenario channel overrides it\n",
            self.reference, self.measured.1
        );
        s += "  scenario channels (a further controller input of the same name reads one):\n";
        for c in &self.channels {
            s += &format!(
                "    {:<11} {:<5} default {:<6} {}\n",
                c.name, c.unit, c.default, c.what
            );
        }
        s
    }
}

/// How a controller's units map onto the plant's: `plant measurement × measured_scale` is the
/// controller's first input; `controller output × command_scale` is the plant's command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Binding {
    /// Plant measurement → controller input.
    pub measured_scale: f64,
    /// Controller output → plant command.
    pub command_scale: f64,
}

impl Default for Binding {
    fn default() -> Self {
        Binding {
            measured_scale: 1.0,
            command_scale: 1.0,
        }
    }
}

/// Where a run's reference comes from (for metrics and plots), in the unit of the
/// controller's first input (the trace column the metrics compare it with).
#[derive(Clone, Debug, PartialEq)]
pub enum Reference {
    /// The plant's own ([`Plant::reference`]: its default, or the scenario's `fr` channel),
    /// times `scale` (the binding's `measured_scale`: plant unit → the input's unit).
    Plant {
        /// Plant unit → the controller input's unit.
        scale: f64,
    },
    /// A constant: the spec's reference parameter, in the unit of the controller's input.
    Constant {
        /// The value.
        value: f64,
        /// Where it comes from (`param FR = 1.25 kN`).
        source: String,
    },
}

impl Reference {
    /// The reference at time `t`.
    pub fn at(&self, plant: &dyn Plant, sc: &Scenario, t: f64) -> f64 {
        match self {
            Reference::Plant { scale } => plant.reference(sc, t) * scale,
            Reference::Constant { value, .. } => *value,
        }
    }

    /// Where it comes from, for summaries.
    pub fn source(&self, plant: &dyn Plant, sc: &Scenario) -> String {
        match self {
            Reference::Constant { source, .. } => source.clone(),
            Reference::Plant { .. } if sc.channels.contains_key("fr") => {
                format!("the scenario's `fr` channel ({})", plant.measured().1)
            }
            Reference::Plant { .. } => format!(
                "the {} plant's default, {} {}",
                plant.name(),
                plant.reference(sc, 0.0),
                plant.measured().1
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::catalog::{plant_named, scenarios_of, PLANTS};

    use super::*;

    /// Every channel a built-in scenario sets is in its plant's contract, in the unit its
    /// name says, and the contract's defaults are what the plant uses without the channel.
    #[test]
    fn contracts_cover_every_scenario_channel() {
        for p in PLANTS {
            let plant = plant_named(p).unwrap();
            let c = Contract::of(plant.as_ref());
            for sc in scenarios_of(p) {
                for name in sc.channels.keys() {
                    assert!(
                        c.channel(name).is_some(),
                        "{p}: `{name}` not in the contract"
                    );
                }
            }
            let text = c.describe();
            assert!(
                text.contains(c.measured.1) && text.contains(c.command.1),
                "{text}"
            );
        }
    }
}
