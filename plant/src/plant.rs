//! The plant side of a closed loop.

use crate::contract::Channel;
use crate::controller::Named;
use crate::scenario::Scenario;
use crate::sensor::SensorParams;

/// A continuous-time plant, integrated by the runner at a substep of the controller period.
/// The controller's command is applied with zero-order hold, or, for a controller with a
/// [`HOLD_BETA`](crate::runner::HOLD_BETA) output, as one command per substep on the
/// fractional-order hold's line.
pub trait Plant: Send {
    /// Short name (`turning`, ...).
    fn name(&self) -> &'static str;
    /// The measured signal (the controller's first input): name and unit.
    fn measured(&self) -> Named;
    /// The command (the controller's first output): name and unit.
    fn command(&self) -> Named;
    /// What the measurement and the command are, in words (for the contract).
    fn describe(&self) -> (&'static str, &'static str);
    /// The scenario channels the plant reads (see [`crate::contract`]).
    fn channels(&self) -> Vec<Channel>;
    /// The sensor that measures [`Plant::measured`].
    fn sensor(&self) -> SensorParams;
    /// The reference the loop should hold at time `t` (for metrics), in the measured unit.
    fn reference(&self, sc: &Scenario, t: f64) -> f64;
    /// The controller issues `cmd` at sample time `t`.
    fn command_at(&mut self, t: f64, cmd: f64);
    /// Integrates from `t` to `t + h`.
    fn advance(&mut self, sc: &Scenario, t: f64, h: f64);
    /// The true value of the measured signal now, in its unit.
    fn output(&self, sc: &Scenario, t: f64) -> f64;
    /// Names of the recorded plant columns, with units (`a_mm`, `force_n`, ...).
    fn columns(&self) -> Vec<&'static str>;
    /// The recorded plant values now, in the order of [`Plant::columns`].
    fn record(&self, sc: &Scenario, t: f64, out: &mut Vec<f64>);
    /// A fresh copy in the initial state.
    fn fresh(&self) -> Box<dyn Plant>;
    /// The parameters a Monte-Carlo sweep may vary, with their nominal values and ranges.
    fn params(&self) -> Vec<Param>;
    /// Sets parameter `name` (one of [`Plant::params`]) to `value`.
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), String>;
}

/// A plant parameter that a sweep may vary.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// Name, with its unit as a suffix (`ks`, `tau_servo_s`, ...).
    pub name: &'static str,
    /// Current value.
    pub value: f64,
    /// The range a sweep draws from (uniformly), and why that range.
    pub range: (f64, f64),
    /// Source or reason for the range.
    pub why: &'static str,
}

/// The error for an unknown parameter name.
pub fn unknown_param(plant: &dyn Plant, name: &str) -> String {
    let known: Vec<&str> = plant.params().iter().map(|p| p.name).collect();
    format!(
        "the {} plant has no parameter `{name}`; it has {}",
        plant.name(),
        known.join(", ")
    )
}
