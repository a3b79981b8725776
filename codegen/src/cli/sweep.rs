//! `qloop sweep`: a Monte-Carlo envelope of closed-loop runs over plant parameters and
//! scenarios, on every core (rayon), with a progress bar; reports the worst case of each
//! metric and the seed that reproduces it (`qloop sweep ... --replay SEED`).

use super::jit::Compiled;
use super::sim;
use crate::Fail;
use qloop_plant::sweep::{draw, draw_seed, Envelope, Outcome, Worst};
use qloop_plant::{catalog, Plant, Scenario};
use rayon::prelude::*;
use std::fmt::Write;

/// What `qloop sweep` was asked to do.
pub struct SweepArgs<'a> {
    /// Spec name (for the report).
    pub spec: &'a str,
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

fn fail(msg: impl std::fmt::Display) -> Fail {
    eprintln!("error: {msg}");
    Fail(2)
}

/// The scenarios a sweep draws from.
pub fn scenarios(plant: &str, names: &[String]) -> Result<Vec<Scenario>, Fail> {
    if names.is_empty() {
        return Ok(catalog::scenarios_of(plant));
    }
    names
        .iter()
        .map(|n| catalog::scenario(plant, n).map_err(fail))
        .collect()
}

/// Runs one draw.
fn one(
    compiled: &Compiled,
    nominal: &dyn Plant,
    scs: &[Scenario],
    seed: u64,
    substeps: usize,
) -> Result<Outcome, String> {
    let d = draw(nominal, scs, seed)?;
    let (_, m) = sim::simulate(compiled, d.plant.as_ref(), &d.scenario, substeps)?;
    Ok(Outcome::new(&d, &m))
}

/// Runs the sweep and returns its envelope.
pub fn sweep(a: &SweepArgs, compiled: &Compiled) -> Result<Envelope, Fail> {
    let nominal = catalog::plant_named(a.plant).map_err(fail)?;
    let scs = scenarios(a.plant, a.scenarios)?;
    qloop_plant::runner::check_binding(nominal.as_ref(), compiled.fixed().as_ref())
        .map_err(fail)?;
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
                let r = one(
                    compiled,
                    plant.as_ref(),
                    &scs,
                    draw_seed(a.seed, i),
                    a.substeps,
                );
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
    env.map_err(fail)
}

fn params(o: &Outcome) -> String {
    o.params
        .iter()
        .map(|(n, v)| format!("{n}={v:.4}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn row(s: &mut String, metric: &str, w: &Worst, fmt: &dyn Fn(f64) -> String) {
    let _ = writeln!(
        s,
        "| {metric} | {} | {:#018x} | {} | {} |",
        fmt(w.value),
        w.outcome.seed,
        w.outcome.scenario,
        params(&w.outcome)
    );
}

/// The sweep report.
pub fn report(
    a: &SweepArgs,
    nominal: &dyn Plant,
    scs: &[Scenario],
    e: &Envelope,
    unit: &str,
    units: &dyn Fn(&str) -> String,
) -> String {
    let mut s = String::new();
    let names: Vec<&str> = scs.iter().map(|s| s.name.as_str()).collect();
    let _ = writeln!(
        s,
        "qloop sweep: {} on the {} plant, {} draws (seed {}) over scenarios {}",
        a.spec,
        a.plant,
        e.draws,
        a.seed,
        names.join(", ")
    );
    let _ = writeln!(s, "parameters, drawn uniformly:");
    for p in nominal.params() {
        let _ = writeln!(
            s,
            "  {:<12} [{:.4}, {:.4}] (nominal {:.4}): {}",
            p.name, p.range.0, p.range.1, p.value, p.why
        );
    }
    let _ = writeln!(
        s,
        "\nstable: fixed-point {}/{}, f64 reference {}/{}; the two loops disagree on {} draws",
        e.draws - e.unstable,
        e.draws,
        e.draws - e.unstable_ref,
        e.draws,
        e.disagree
    );
    if let Some(u) = &e.first_unstable {
        let _ = writeln!(
            s,
            "first unstable draw: seed {:#018x}, {} at {:.2} Hz, {}",
            u.seed,
            u.scenario,
            u.osc_hz.unwrap_or(0.0),
            params(u)
        );
    }
    let _ = writeln!(
        s,
        "\nworst cases over the stable draws (fixed-point loop):\n\n| metric | worst | draw seed | scenario | parameters |\n|---|---|---|---|---|"
    );
    if let Some(w) = &e.ss_error {
        row(
            &mut s,
            &format!("steady-state error, abs ({unit})"),
            w,
            &|v| format!("{v:.4}"),
        );
    }
    if let Some(w) = &e.overshoot {
        row(&mut s, "overshoot", w, &|v| format!("{:.1}%", 100.0 * v));
    }
    if let Some(w) = &e.settling_s {
        row(&mut s, "settling ±5% (s)", w, &|v| {
            if v.is_finite() {
                format!("{v:.2}")
            } else {
                "never".into()
            }
        });
    }
    for (name, w) in &e.max_diff {
        let u = units(name);
        row(
            &mut s,
            &format!("fixed − f64 {name}, max abs ({u})"),
            w,
            &|v| format!("{v:.3e}"),
        );
    }
    let _ = writeln!(
        s,
        "\nreplay a draw: qloop sweep SPEC --plant {} --replay SEED --out DIR",
        a.plant
    );
    s
}

/// Replays one draw as `qloop sim` would (trace, plots, summary in `out`).
pub fn replay(
    a: &SweepArgs,
    compiled: &Compiled,
    seed: u64,
) -> Result<
    (
        qloop_plant::sweep::Draw,
        qloop_plant::Trace,
        qloop_plant::Metrics,
    ),
    Fail,
> {
    let nominal = catalog::plant_named(a.plant).map_err(fail)?;
    let scs = scenarios(a.plant, a.scenarios)?;
    let d = draw(nominal.as_ref(), &scs, seed).map_err(fail)?;
    let (trace, m) =
        sim::simulate(compiled, d.plant.as_ref(), &d.scenario, a.substeps).map_err(fail)?;
    Ok((d, trace, m))
}
