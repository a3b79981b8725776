//! Scoring a candidate spec in closed loop: the same draws of plant parameters and scenarios
//! for every candidate (common random numbers, so that candidates differ only by their
//! constants), each run by the plan interpreter beside the real-arithmetic reference
//! ([`qloop::interpreted`]), reduced to a sweep [`Envelope`].

use super::super::bind::{bind, Bound};
use super::super::error::{CliError, CliResult};
use qloop::interpreted::{Interpreted, RealInterpreted};
use qloop::Plan;
use qloop_plant::metrics::metrics_noisy;
use qloop_plant::sweep::{draw, draw_seed, Envelope, Outcome};
use qloop_plant::{Plant, RunConfig, Scenario};
use std::rc::Rc;

/// What every candidate is run against.
pub struct Bench<'a> {
    /// The scenarios the draws pick from.
    pub scenarios: &'a [Scenario],
    /// Draws per candidate.
    pub draws: u64,
    /// Base seed of the draws.
    pub seed: u64,
    /// Plant substeps per period.
    pub substeps: usize,
}

/// A candidate's closed-loop record.
#[derive(Clone, Debug)]
pub struct Score {
    /// The sweep envelope of its draws.
    pub env: Envelope,
}

impl Score {
    /// Fraction of the draws whose fixed-point loop stayed stable.
    pub fn stable_frac(&self) -> f64 {
        (self.env.draws - self.env.unstable) as f64 / self.env.draws.max(1) as f64
    }

    /// Whether every draw of both loops stayed stable.
    pub fn all_stable(&self) -> bool {
        self.env.unstable == 0 && self.env.unstable_ref == 0
    }

    fn worst(w: &Option<qloop_plant::sweep::Worst>, none: f64) -> f64 {
        w.as_ref().map_or(none, |w| w.value)
    }

    /// Worst loop overshoot (fraction of the reference, after the measurement first reaches
    /// the reference) over the stable draws.
    pub fn overshoot(&self) -> f64 {
        Self::worst(&self.env.loop_overshoot, f64::INFINITY)
    }

    /// Worst peak over the reference (the disturbance's own jump included).
    pub fn peak(&self) -> f64 {
        Self::worst(&self.env.overshoot, f64::INFINITY)
    }

    /// Worst settling time (∞: some segment did not settle).
    pub fn settling(&self) -> f64 {
        Self::worst(&self.env.settling_s, f64::INFINITY)
    }

    /// Worst rise time.
    pub fn rise(&self) -> f64 {
        Self::worst(&self.env.rise_s, f64::INFINITY)
    }

    /// Worst |steady-state error|.
    pub fn ss_error(&self) -> f64 {
        Self::worst(&self.env.ss_error, f64::INFINITY)
    }

    /// Lowest damping ratio (1 when nothing swings beyond the band).
    pub fn damping(&self) -> f64 {
        1.0 - Self::worst(&self.env.underdamping, 1.0)
    }
}

/// Runs the draws of `bench` with the candidate `plan`. An error is the candidate's own (its
/// spec does not bind to the plant) or qloop's (a value left its proved interval).
pub fn score(plan: Rc<Plan>, bench: &Bench, nominal: &dyn Plant) -> CliResult<Score> {
    let bounds: Vec<(String, Bound)> = bench
        .scenarios
        .iter()
        .map(|sc| Ok((sc.name.clone(), bind(&plan.prog, nominal, sc, None)?)))
        .collect::<CliResult<_>>()?;
    let sig = Interpreted::new(plan.clone());
    let signals = qloop_plant::Controller::signals(&sig);
    let measured = signals.inputs[0].0;
    let compared: Vec<&str> = signals
        .states
        .iter()
        .chain(&signals.outputs)
        .map(|s| s.0)
        .collect();
    let mut env = Envelope::default();
    for i in 0..bench.draws {
        let d =
            draw(nominal, bench.scenarios, draw_seed(bench.seed, i)).map_err(CliError::input)?;
        let bound = &bounds
            .iter()
            .find(|(n, _)| *n == d.scenario.name)
            .ok_or_else(|| CliError::tool("a drawn scenario was not bound"))?
            .1;
        let fixed = Interpreted::new(plan.clone());
        let violations = fixed.violations();
        let trace = qloop_plant::run(
            d.plant.as_ref(),
            Box::new(fixed),
            Box::new(RealInterpreted::new(plan.clone())),
            &d.scenario,
            RunConfig {
                substeps: bench.substeps,
                binding: Some(bound.binding),
            },
        )
        .map_err(CliError::input)?;
        if let Some(v) = violations.first() {
            return Err(CliError::tool(format!(
                "internal: `{}`: value {:?} computed {} outside its proved interval {:?} (a qloop bug; please report it with the spec)",
                plan.prog.name, v.val, v.got, v.range
            )));
        }
        let m = metrics_noisy(
            &trace,
            measured,
            &|t| bound.reference.at(d.plant.as_ref(), &d.scenario, t),
            &d.scenario.breakpoints(),
            d.scenario.duration_s,
            &compared,
            d.scenario.noise_sigma * bound.binding.measured_scale.abs(),
        );
        env.add(&Outcome::new(&d, &m));
    }
    Ok(Score { env })
}
