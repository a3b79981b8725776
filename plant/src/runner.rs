//! The closed-loop runner: the compiled fixed-point controller and the f64 reference, each in
//! its own copy of the same plant and scenario (same sensor noise stream), sampled every
//! controller period, the plant integrated at `substeps` per period with the command held.
//!
//! The controller's first input reads the plant through its sensor; every further input
//! (a reference, a limit) is read from the scenario channel of the same name, in that
//! input's unit, so reference changes are scenario data too.

use crate::contract::Binding;
use crate::controller::Controller;
use crate::plant::Plant;
use crate::scenario::Scenario;
use crate::sensor::Sensor;
use crate::trace::Trace;

/// Runner settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunConfig {
    /// Plant integration substeps per controller period.
    pub substeps: usize,
    /// Unit conversions between controller and plant, checked by the caller against the
    /// plant's [`Contract`](crate::Contract) (`qloop sim` does, with parsed units). `None`:
    /// the units must be spelled as the plant spells them ([`check_binding`]).
    pub binding: Option<Binding>,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            substeps: 20,
            binding: None,
        }
    }
}

/// Checks that the controller's first input and output match the plant's measured signal
/// and command in unit.
pub fn check_binding(plant: &dyn Plant, c: &dyn Controller) -> Result<(), String> {
    let s = c.signals();
    let (Some(i), Some(o)) = (s.inputs.first(), s.outputs.first()) else {
        return Err("the controller needs at least one input (the measurement) and one output (the command)".into());
    };
    let (m, cmd) = (plant.measured(), plant.command());
    if i.1 != m.1 {
        return Err(format!(
            "the {} plant measures {} in {}, but the controller's first input `{}` is in `{}`; declare it in {}",
            plant.name(), m.0, m.1, i.0, i.1, m.1
        ));
    }
    if o.1 != cmd.1 {
        return Err(format!(
            "the {} plant takes its {} command in {}, but the controller's first output `{}` is in `{}`; declare it in {}",
            plant.name(), cmd.0, cmd.1, o.0, o.1, cmd.1
        ));
    }
    Ok(())
}

/// Checks that every controller input after the first has a channel to read: one of the
/// scenario's, or one of the plant's (at its default where the scenario does not set it).
pub fn check_channels(plant: &dyn Plant, sc: &Scenario, c: &dyn Controller) -> Result<(), String> {
    let offered = plant.channels();
    for (name, _) in c.signals().inputs.iter().skip(1) {
        if !sc.channels.contains_key(*name) && !offered.iter().any(|ch| ch.name == *name) {
            let names: Vec<&str> = offered.iter().map(|ch| ch.name).collect();
            return Err(format!(
                "the controller input `{name}` is not the plant's measurement, and neither scenario `{}` nor the {} plant has a channel `{name}` (its schedule would feed the input); the plant's channels: {}",
                sc.name,
                plant.name(),
                names.join(", ")
            ));
        }
    }
    Ok(())
}

/// One loop's state during a run.
struct Loop {
    plant: Box<dyn Plant>,
    sensor: Sensor,
    ctl: Box<dyn Controller>,
    x: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
    /// Names of the inputs after the first, read from scenario channels, with the value
    /// where the scenario does not set the channel (the plant's default).
    extra: Vec<(&'static str, f64)>,
    /// Unit conversions.
    binding: Binding,
    /// The fractional-order hold, when the controller has an output [`HOLD_BETA`]: its index.
    hold: Option<usize>,
    /// The command of this period and of the last, in plant units (for the hold).
    cmd: (f64, f64),
}

/// The controller output that selects a β fractional-order hold between controller and
/// plant (Rubio & De la Sen, eqs. 4-5; `crate::froh`): over each period the plant is
/// driven with `u_k + β·(u_k − u_{k−1})·(t − kT)/T` instead of `u_k` held. β is clamped to
/// [−1, 1], where Rubio & De la Sen defines the hold.
pub const HOLD_BETA: &str = "hold_beta";

impl Loop {
    fn new(plant: &dyn Plant, ctl: Box<dyn Controller>, sc: &Scenario, binding: Binding) -> Loop {
        let sig = ctl.signals();
        let mut sensor_p = plant.sensor();
        sensor_p.noise_sigma = sc.noise_sigma;
        Loop {
            plant: plant.fresh(),
            sensor: Sensor::new(sensor_p, sc.seed).with_faults(&sc.faults, sc.seed),
            x: vec![0.0; sig.inputs.len()],
            y: vec![0.0; sig.outputs.len()],
            s: vec![0.0; sig.states.len()],
            extra: sig
                .inputs
                .iter()
                .skip(1)
                .map(|n| {
                    let offered = plant.channels();
                    let default = offered.iter().find(|c| c.name == n.0);
                    (n.0, default.map_or(0.0, |c| c.default))
                })
                .collect(),
            hold: sig.outputs.iter().position(|o| o.0 == HOLD_BETA),
            cmd: (0.0, 0.0),
            ctl,
            binding,
        }
    }

    /// Before substep `j` of `n` of the period starting at `t`: with a hold, the command
    /// on the hold's line at the substep's midpoint (a staircase of `n` steps).
    fn hold_substep(&mut self, t: f64, j: usize, n: usize, h: f64) {
        if let Some(i) = self.hold {
            let beta = self.y[i].clamp(-1.0, 1.0);
            let (u, prev) = self.cmd;
            let frac = (j as f64 + 0.5) / n as f64;
            self.plant
                .command_at(t + j as f64 * h, u + beta * (u - prev) * frac);
        }
    }

    /// Sample, compute, issue the command.
    fn sample(&mut self, sc: &Scenario, t: f64) {
        self.x[0] = self.sensor.read_at(t, self.plant.output(sc, t)) * self.binding.measured_scale;
        for (x, (name, default)) in self.x[1..].iter_mut().zip(&self.extra) {
            *x = sc.value(name, t, *default);
        }
        self.ctl.step(&self.x, &mut self.y);
        self.ctl.states(&mut self.s);
        let u = self.y[0] * self.binding.command_scale;
        self.cmd = (u, self.cmd.0);
        self.plant.command_at(t, u);
    }

    fn record(&self, sc: &Scenario, t: f64, row: &mut Vec<f64>) {
        self.plant.record(sc, t, row);
        row.extend(&self.x);
        row.extend(&self.s);
        row.extend(&self.y);
    }
}

/// Checks a controller against the plant and scenario; returns its period.
fn checked_period(
    plant: &dyn Plant,
    c: &dyn Controller,
    sc: &Scenario,
    cfg: RunConfig,
) -> Result<f64, String> {
    if cfg.binding.is_none() {
        check_binding(plant, c)?;
    }
    check_channels(plant, sc, c)?;
    let period = c.period();
    if period.is_nan() || period <= 0.0 {
        return Err("the controller's period must be positive".into());
    }
    Ok(period)
}

/// The trace columns of one loop: plant columns, then the controller's inputs, states and
/// outputs by spec name, each with `suffix`.
///
/// A controller signal named like a plant column (an input `n_rpm` reading the channel the
/// plant also records) gets the suffix `_ctl`, so that every column name is unique.
fn loop_columns(plant: &dyn Plant, c: &dyn Controller, suffix: &str) -> Vec<String> {
    let sig = c.signals();
    let names = sig.inputs.iter().chain(&sig.states).chain(&sig.outputs);
    let plant_cols = plant.columns();
    let ctl = names.map(|n| {
        if plant_cols.contains(&n.0) {
            format!("{}_ctl", n.0)
        } else {
            n.0.to_string()
        }
    });
    plant_cols
        .iter()
        .map(|c| c.to_string())
        .chain(ctl)
        .map(|c| format!("{c}{suffix}"))
        .collect()
}

/// Drives `loops` in lock step through `sc`: sample every period, then integrate each plant
/// over the period in `substeps` steps with the command held (or, for a controller with a
/// [`HOLD_BETA`] output, on the fractional-order hold's line, one value per substep).
fn drive(
    loops: &mut [Loop],
    sc: &Scenario,
    period: f64,
    cfg: RunConfig,
    columns: Vec<String>,
) -> Trace {
    let n = (sc.duration_s / period).round() as usize;
    let substeps = cfg.substeps.max(1);
    let h = period / substeps as f64;
    let mut trace = Trace {
        rows: Vec::with_capacity(n + 1),
        columns,
    };
    for k in 0..=n {
        let t = k as f64 * period;
        let mut row = Vec::with_capacity(trace.columns.len());
        row.push(t);
        for l in loops.iter_mut() {
            l.sample(sc, t);
        }
        for l in loops.iter() {
            l.record(sc, t, &mut row);
        }
        trace.rows.push(row);
        for j in 0..substeps {
            for l in loops.iter_mut() {
                l.hold_substep(t, j, substeps, h);
                l.plant.advance(sc, t + j as f64 * h, h);
            }
        }
    }
    trace
}

/// Runs `fixed` and `reference` (the same spec) on copies of `plant` through `sc`. Columns:
/// `t`, then the fixed-point loop's (see [`run_single`]), then the reference loop's with the
/// suffix `_ref`.
pub fn run(
    plant: &dyn Plant,
    fixed: Box<dyn Controller>,
    reference: Box<dyn Controller>,
    sc: &Scenario,
    cfg: RunConfig,
) -> Result<Trace, String> {
    let period = checked_period(plant, fixed.as_ref(), sc, cfg)?;
    checked_period(plant, reference.as_ref(), sc, cfg)?;
    if fixed.signals() != reference.signals()
        || (fixed.period() - reference.period()).abs() > 1e-9 * period
    {
        return Err("the fixed-point and reference controllers come from different specs".into());
    }
    let mut columns = vec!["t".to_string()];
    columns.extend(loop_columns(plant, fixed.as_ref(), ""));
    columns.extend(loop_columns(plant, reference.as_ref(), "_ref"));
    let b = cfg.binding.unwrap_or_default();
    let mut loops = [
        Loop::new(plant, fixed, sc, b),
        Loop::new(plant, reference, sc, b),
    ];
    Ok(drive(&mut loops, sc, period, cfg, columns))
}

/// Runs one controller on a copy of `plant` through `sc`. Columns: `t`, the plant's columns,
/// then the controller's inputs, states and outputs by spec name.
pub fn run_single(
    plant: &dyn Plant,
    ctl: Box<dyn Controller>,
    sc: &Scenario,
    cfg: RunConfig,
) -> Result<Trace, String> {
    let period = checked_period(plant, ctl.as_ref(), sc, cfg)?;
    let mut columns = vec!["t".to_string()];
    columns.extend(loop_columns(plant, ctl.as_ref(), ""));
    let mut loops = [Loop::new(plant, ctl, sc, cfg.binding.unwrap_or_default())];
    Ok(drive(&mut loops, sc, period, cfg, columns))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::turning::{scenario_named, Turning, TurningParams};
    use crate::{fixed_controller, reference_controller};

    #[test]
    fn a_single_loop_is_the_fixed_half_of_a_paired_run() {
        let plant = Turning::new(TurningParams::default());
        let sc = scenario_named("noise").unwrap();
        let paired = run(
            &plant,
            fixed_controller!(qloop_verified::koren_masory_1981),
            reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
            &sc,
            RunConfig::default(),
        )
        .unwrap();
        let single = run_single(
            &plant,
            fixed_controller!(qloop_verified::koren_masory_1981),
            &sc,
            RunConfig::default(),
        )
        .unwrap();
        assert_eq!(single.columns, paired.columns[..single.columns.len()]);
        assert_eq!(single.rows.len(), paired.rows.len());
        for (s, p) in single.rows.iter().zip(&paired.rows) {
            assert_eq!(s[..], p[..s.len()]);
        }
        // The reference half differs (a different controller), so the check can fail.
        let fc = paired.col("fc").unwrap();
        assert_ne!(fc, paired.col("fc_ref").unwrap());
    }

    /// A plant that only logs the commands it is given.
    #[derive(Clone)]
    struct Log(std::sync::Arc<std::sync::Mutex<Vec<(f64, f64)>>>);

    impl Plant for Log {
        fn name(&self) -> &'static str {
            "log"
        }
        fn measured(&self) -> crate::controller::Named {
            ("f", "kN")
        }
        fn command(&self) -> crate::controller::Named {
            ("u", "mm/s")
        }
        fn describe(&self) -> (&'static str, &'static str) {
            ("nothing", "logged")
        }
        fn channels(&self) -> Vec<crate::contract::Channel> {
            Vec::new()
        }
        fn sensor(&self) -> crate::sensor::SensorParams {
            crate::sensor::SensorParams {
                gain: 1.0,
                noise_sigma: 0.0,
                range: (-1e9, 1e9),
                bits: 32,
            }
        }
        fn reference(&self, _: &Scenario, _: f64) -> f64 {
            0.0
        }
        fn command_at(&mut self, t: f64, cmd: f64) {
            self.0.lock().unwrap().push((t, cmd));
        }
        fn advance(&mut self, _: &Scenario, _: f64, _: f64) {}
        fn output(&self, _: &Scenario, _: f64) -> f64 {
            0.0
        }
        fn columns(&self) -> Vec<&'static str> {
            Vec::new()
        }
        fn record(&self, _: &Scenario, _: f64, _: &mut Vec<f64>) {}
        fn fresh(&self) -> Box<dyn Plant> {
            Box::new(self.clone())
        }
        fn params(&self) -> Vec<crate::plant::Param> {
            Vec::new()
        }
        fn set_param(&mut self, name: &str, _: f64) -> Result<(), String> {
            Err(name.into())
        }
    }

    /// Commands 1, 2, 3, .. with the hold's β as a second output.
    struct Ramp(usize, f64);

    impl Controller for Ramp {
        fn signals(&self) -> crate::Signals {
            crate::Signals {
                inputs: vec![("f", "kN")],
                states: vec![],
                outputs: vec![("u", "mm/s"), (HOLD_BETA, "")],
            }
        }
        fn period(&self) -> f64 {
            0.1
        }
        fn step(&mut self, _: &[f64], out: &mut [f64]) {
            self.0 += 1;
            out[0] = self.0 as f64;
            out[1] = self.1;
        }
        fn states(&self, _: &mut [f64]) {}
    }

    #[test]
    fn a_hold_beta_output_drives_the_plant_on_the_holds_line() {
        let sc = Scenario {
            name: "log".into(),
            duration_s: 0.3,
            noise_sigma: 0.0,
            seed: 1,
            channels: Default::default(),
            faults: Vec::new(),
        };
        for beta in [0.0, 0.5, -0.3, 1.0] {
            let log = Log(Default::default());
            let cfg = RunConfig {
                substeps: 4,
                binding: None,
            };
            run_single(&log, Box::new(Ramp(0, beta)), &sc, cfg).expect("runs");
            let got = log.0.lock().unwrap().clone();
            // Per period k: the sample's command u_k = k + 1, then the four substeps at
            // u_k + β·(u_k − u_{k−1})·(j + 1/2)/4, with u_{−1} = 0 (the plant at rest).
            let mut want = Vec::new();
            for k in 0..4 {
                let (u, prev) = ((k + 1) as f64, k as f64);
                want.push((k as f64 * 0.1, u));
                for j in 0..4 {
                    let t = k as f64 * 0.1 + j as f64 * 0.025;
                    want.push((t, u + beta * (u - prev) * (j as f64 + 0.5) / 4.0));
                }
            }
            assert_eq!(got.len(), want.len(), "β = {beta}");
            for ((t, c), (wt, wc)) in got.iter().zip(&want) {
                assert!(
                    (t - wt).abs() < 1e-12 && (c - wc).abs() < 1e-12,
                    "β = {beta}: {got:?}"
                );
            }
        }
    }
}
