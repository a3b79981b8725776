//! `qloop sweep`: a Monte-Carlo envelope of closed-loop runs over plant parameters and
//! scenarios, on every core (rayon), with a progress bar; reports the worst case of each
//! metric and the seed that reproduces it (`qloop sweep ... --replay SEED`).

use super::bind::{bind, Bound};
use super::error::{CliError, CliResult};
use super::files::{load, write_atomic};
use super::jit::Compiled;
use super::sim::{self, print_run, SimArgs};
use super::sweep_report::report;
use qloop::Plan;
use qloop_plant::sweep::{draw, draw_seed, Draw, Envelope, Outcome};
use qloop_plant::{catalog, Metrics, Plant, Scenario, Trace};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// `qloop sweep` as given on the command line.
pub struct SweepCommand<'a> {
    /// The spec file.
    pub spec: &'a Path,
    /// `--target`.
    pub target: &'a str,
    /// `--plant`.
    pub plant: &'a str,
    /// `--scenario`s (empty: every built-in scenario of the plant).
    pub scenarios: &'a [String],
    /// `--draws`.
    pub draws: u64,
    /// `--seed`.
    pub seed: u64,
    /// `--jobs` (default: every core).
    pub jobs: Option<usize>,
    /// `--replay SEED`.
    pub replay: Option<u64>,
    /// `--out DIR` for `--replay`.
    pub out: &'a Path,
    /// `--report FILE`.
    pub report: Option<&'a Path>,
    /// `--substeps`.
    pub substeps: usize,
}

/// Runs the sweep and prints its report, or with `--replay` one draw as `qloop sim` would.
pub fn run(c: &SweepCommand) -> CliResult {
    let (plan, _) = load(c.spec, c.target)?;
    // Bad plant or scenario names, and a spec the plant cannot run, fail before the
    // controller is compiled.
    let nominal = catalog::plant_named(c.plant).map_err(CliError::input)?;
    let bounds = scenarios(c.plant, c.scenarios)?
        .iter()
        .map(|sc| {
            Ok((
                sc.name.clone(),
                bind(&plan.prog, nominal.as_ref(), sc, None)?,
            ))
        })
        .collect::<CliResult<Vec<_>>>()?;
    let a = SweepArgs {
        spec: &plan.prog.name,
        bounds: &bounds,
        plant: c.plant,
        scenarios: c.scenarios,
        draws: c.draws,
        seed: c.seed,
        substeps: c.substeps.max(1),
    };
    let compiled = sim::compile(&plan)?;
    match c.replay {
        Some(seed) => run_replay(&plan, &a, &compiled, seed, c.out),
        None => run_sweep(&a, &compiled, c.jobs, c.report),
    }
}

/// `--replay SEED`: the draw's parameters, then its run as `qloop sim` prints it.
fn run_replay(plan: &Plan, a: &SweepArgs, compiled: &Compiled, seed: u64, out: &Path) -> CliResult {
    let (d, trace, m) = replay(a, compiled, seed)?;
    let args = SimArgs {
        plan,
        plant: a.plant,
        scenario: &d.scenario.name,
        out,
        substeps: a.substeps,
        nominal: None,
    };
    let bound = bound_for(a, &d.scenario)?;
    let params: Vec<String> = d.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
    println!(
        "draw {seed:#018x}: scenario {} (noise seed {}), {}",
        d.scenario.name,
        d.scenario.seed,
        params.join(" ")
    );
    let r = sim::write_run(
        &args,
        compiled,
        d.plant.as_ref(),
        &d.scenario,
        bound,
        trace,
        m,
    )?;
    print_run(&r);
    Ok(())
}

/// The sweep on `jobs` threads: prints the report (and writes it to `report_file`).
fn run_sweep(
    a: &SweepArgs,
    compiled: &Compiled,
    jobs: Option<usize>,
    report_file: Option<&Path>,
) -> CliResult {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .map_err(|e| CliError::tool(format!("cannot start worker threads: {e}")))?;
    let start = Instant::now();
    let env = pool.install(|| sweep(a, compiled))?;
    let secs = start.elapsed().as_secs_f64();
    let nominal = catalog::plant_named(a.plant).map_err(CliError::input)?;
    let scs = scenarios(a.plant, a.scenarios)?;
    let sig = compiled.signals().clone();
    let units = |name: &str| {
        sig.states
            .iter()
            .chain(&sig.outputs)
            .find(|s| s.0 == name)
            .map_or(String::new(), |s| s.1.to_string())
    };
    let mut text = report(a, nominal.as_ref(), &scs, &env, sig.inputs[0].1, &units);
    text.push_str(&format!(
        "\n{} draws in {secs:.1} s on {} threads ({:.0} draws/s)\n",
        env.draws,
        pool.current_num_threads(),
        env.draws as f64 / secs.max(1e-9)
    ));
    print!("{text}");
    if let Some(p) = report_file {
        write_atomic(p, &text)?;
    }
    Ok(())
}

/// What `qloop sweep` was asked to do.
pub struct SweepArgs<'a> {
    /// Spec name (for the report).
    pub spec: &'a str,
    /// The spec bound to the plant for each scenario, by scenario name ([`bind`]).
    pub bounds: &'a [(String, Bound)],
    /// Plant name.
    pub plant: &'a str,
    /// Scenarios to draw from (built-in names or TOML files); empty = all built-in.
    pub scenarios: &'a [String],
    /// Number of draws.
    pub draws: u64,
    /// Base seed.
    pub seed: u64,
    /// Plant substeps per period.
    pub substeps: usize,
}

/// The binding of the spec for scenario `sc` (made in [`run`] for every scenario).
fn bound_for<'a>(a: &'a SweepArgs, sc: &Scenario) -> CliResult<&'a Bound> {
    a.bounds
        .iter()
        .find(|(n, _)| *n == sc.name)
        .map(|(_, b)| b)
        .ok_or_else(|| {
            CliError::input(format!("scenario `{}` was not bound to the plant", sc.name))
        })
}

/// The scenarios a sweep draws from.
pub fn scenarios(plant: &str, names: &[String]) -> CliResult<Vec<Scenario>> {
    if names.is_empty() {
        return Ok(catalog::scenarios_of(plant));
    }
    names
        .iter()
        .map(|n| catalog::scenario(plant, n).map_err(CliError::input))
        .collect()
}

/// Runs one draw.
fn one(
    a: &SweepArgs,
    compiled: &Compiled,
    nominal: &dyn Plant,
    scs: &[Scenario],
    seed: u64,
) -> Result<Outcome, String> {
    let d = draw(nominal, scs, seed)?;
    let bound = bound_for(a, &d.scenario).map_err(|_| "scenario not bound".to_string())?;
    let (_, m) = sim::simulate(compiled, d.plant.as_ref(), &d.scenario, a.substeps, bound)?;
    Ok(Outcome::new(&d, &m))
}

/// Runs the sweep and returns its envelope.
pub fn sweep(a: &SweepArgs, compiled: &Compiled) -> CliResult<Envelope> {
    catalog::plant_named(a.plant).map_err(CliError::input)?;
    let scs = scenarios(a.plant, a.scenarios)?;
    let bar = indicatif::ProgressBar::new(a.draws);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} sweep {pos}/{len} draws [{elapsed} < {eta}] {wide_bar}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let env = (0..a.draws)
        .into_par_iter()
        .map_init(
            || catalog::plant_named(a.plant).expect("checked above"),
            |plant, i| {
                let r = one(a, compiled, plant.as_ref(), &scs, draw_seed(a.seed, i));
                bar.inc(1);
                r
            },
        )
        .try_fold(Envelope::default, |mut e, o| {
            e.add(&o?);
            Ok::<_, String>(e)
        })
        .try_reduce(Envelope::default, |x, y| Ok(x.merge(y)));
    bar.finish_and_clear();
    env.map_err(CliError::input)
}

/// Replays one draw as `qloop sim` would (trace, plots, summary in `out`).
pub fn replay(a: &SweepArgs, compiled: &Compiled, seed: u64) -> CliResult<(Draw, Trace, Metrics)> {
    let nominal = catalog::plant_named(a.plant).map_err(CliError::input)?;
    let scs = scenarios(a.plant, a.scenarios)?;
    let d = draw(nominal.as_ref(), &scs, seed).map_err(CliError::input)?;
    let bound = bound_for(a, &d.scenario)?;
    let (trace, m) = sim::simulate(compiled, d.plant.as_ref(), &d.scenario, a.substeps, bound)
        .map_err(CliError::input)?;
    Ok((d, trace, m))
}
