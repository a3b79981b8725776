//! `qloop sim`: one closed-loop run of a spec's compiled controller (fixed-point and f64
//! reference) on a built-in plant and scenario; writes the trace, plots and a summary.

use super::bind::{bind, Bound};
use super::error::{CliError, CliResult};
use super::files::{create_dir, load, write_atomic};
use super::jit::{self, Compiled};
use qloop::Plan;
use qloop_plant::metrics::metrics_noisy;
use qloop_plant::metrics::Segment;
use qloop_plant::{catalog, plot, Metrics, Plant, RunConfig, Scenario, Trace};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// What `qloop sim` was asked to do.
pub struct SimArgs<'a> {
    /// The plan of the spec.
    pub plan: &'a Plan,
    /// The plant's name.
    pub plant: &'a str,
    /// A built-in scenario name or a TOML file.
    pub scenario: &'a str,
    /// Output directory.
    pub out: &'a Path,
    /// Plant substeps per controller period.
    pub substeps: usize,
    /// The nominal feed of an override output (`--nominal-feed`), in the plant's command unit.
    pub nominal: Option<f64>,
}

/// The outcome of a run, for the demo and the summary.
pub struct SimResult {
    /// Its metrics.
    pub metrics: Metrics,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// The printed summary.
    pub summary: String,
    /// Whether both loops were stable and every cutting segment of the fixed-point loop
    /// settled (for `sim --check`).
    pub ok: bool,
    /// The trace.
    pub trace: Trace,
}

/// `qloop sim SPEC`: loads the spec for `target`, runs it on `plant` in `scenario`, writes
/// into `out` and prints the summary and the files written.
/// With `check`, a run that is unstable or does not settle is an error (exit status 1).
/// Without a scenario, the plant's first built-in one.
pub fn run(
    spec: &Path,
    target: &str,
    (plant, scenario): (&str, Option<&str>),
    out: &Path,
    (substeps, nominal, check): (usize, Option<f64>, bool),
) -> CliResult {
    let first = catalog::scenarios_of(plant).into_iter().next();
    let scenario = match (scenario, &first) {
        (Some(s), _) => s,
        (None, Some(s)) => s.name.as_str(),
        // An unknown plant: let the catalog name the known ones.
        (None, None) => "",
    };
    let (plan, _) = load(spec, target)?;
    let r = sim(&SimArgs {
        plan: &plan,
        plant,
        scenario,
        out,
        substeps: substeps.max(1),
        nominal,
    })?;
    print_run(&r);
    if check && !r.ok {
        return Err(CliError::Failed(Some(
            "sim --check: a loop is unstable or a cutting segment never settles (see the summary)"
                .into(),
        )));
    }
    Ok(())
}

/// Prints a run's summary and the files it wrote.
pub fn print_run(r: &SimResult) {
    print!("{}", r.summary);
    for f in &r.files {
        println!("wrote {}", f.display());
    }
}

/// Compiles the spec (cached) with a note on standard error.
pub fn compile(plan: &Plan) -> CliResult<Compiled> {
    eprintln!(
        "compiling the generated controller `{}` (rustc, release; cached after the first run) ...",
        plan.prog.name
    );
    jit::compile(plan)
}

/// Runs a loop and computes its metrics.
pub fn simulate(
    compiled: &Compiled,
    plant: &dyn Plant,
    sc: &Scenario,
    substeps: usize,
    bound: &Bound,
) -> Result<(Trace, Metrics), String> {
    let trace = qloop_plant::run(
        plant,
        compiled.fixed(),
        compiled.reference(),
        sc,
        RunConfig {
            substeps,
            binding: Some(bound.binding),
        },
    )?;
    let sig = compiled.signals();
    let measured = sig.inputs[0].0;
    let compared: Vec<&str> = sig.states.iter().chain(&sig.outputs).map(|s| s.0).collect();
    let m = metrics_noisy(
        &trace,
        measured,
        &|t| bound.reference.at(plant, sc, t),
        &sc.breakpoints(),
        sc.duration_s,
        &compared,
        // The sensor noise is in the plant's unit; the metrics see the input's.
        sc.noise_sigma * bound.binding.measured_scale.abs(),
    );
    Ok((trace, m))
}

/// One closed-loop run of `a.plan`: compiles it, runs it and writes the results.
pub fn sim(a: &SimArgs) -> CliResult<SimResult> {
    let plant = catalog::plant_named(a.plant).map_err(CliError::input)?;
    let sc = catalog::scenario(a.plant, a.scenario).map_err(CliError::input)?;
    // The spec against the plant's contract, before the (slow) compile.
    let bound = bind(&a.plan.prog, plant.as_ref(), &sc, a.nominal)?;
    let compiled = compile(a.plan)?;
    let (trace, m) =
        simulate(&compiled, plant.as_ref(), &sc, a.substeps, &bound).map_err(CliError::input)?;
    write_run(a, &compiled, plant.as_ref(), &sc, &bound, trace, m)
}

/// Writes a run's trace (`trace.csv`), figure (SVG and PNG) and summary into `a.out`.
pub fn write_run(
    a: &SimArgs,
    compiled: &Compiled,
    plant: &dyn Plant,
    sc: &Scenario,
    bound: &Bound,
    trace: Trace,
    m: Metrics,
) -> CliResult<SimResult> {
    create_dir(a.out)?;
    let mut files = Vec::new();
    let csv = a.out.join("trace.csv");
    write_atomic(&csv, &trace.to_csv())?;
    files.push(csv);
    let title = format!(
        "{} on the {} plant, scenario {}: fixed-point (compiled) and f64 reference",
        a.plan.prog.name, a.plant, sc.name
    );
    let reference = |t: f64| bound.reference.at(plant, sc, t);
    let fig = plot::run_figure(&title, &trace, compiled.signals(), &reference, sc);
    let stem = format!("{}-{}-{}", a.plan.prog.name, a.plant, sc.name);
    let svg = a.out.join(format!("{stem}.svg"));
    let png = a.out.join(format!("{stem}.png"));
    plot::write_svg(&fig, &svg).map_err(CliError::Output)?;
    plot::write_png(&fig, &png).map_err(CliError::Output)?;
    files.push(svg);
    files.push(png);
    let summary = summary(a, sc, &trace, &m, compiled.signals(), plant, bound);
    let txt = a.out.join("summary.txt");
    write_atomic(&txt, &summary)?;
    files.push(txt);
    let settled = m
        .fixed
        .segments
        .iter()
        .all(|s| !s.cutting || s.settling_s.is_some());
    Ok(SimResult {
        ok: m.fixed.stable() && m.reference.stable() && settled,
        metrics: m,
        files,
        summary,
        trace,
    })
}

/// A loop's verdict: "stable" only with what it hides said next to it (the worst overshoot
/// and settling over cutting segments, segments not settled, ringing, the lowest damping).
pub fn verdict(l: &qloop_plant::metrics::LoopMetrics) -> String {
    if !l.stable() {
        return "UNSTABLE".into();
    }
    let cut: Vec<&Segment> = l.segments.iter().filter(|s| s.cutting).collect();
    if cut.is_empty() {
        return "stable (no cutting segment)".into();
    }
    let os = cut.iter().map(|s| s.overshoot).fold(0.0, f64::max);
    let los = cut.iter().map(|s| s.loop_overshoot).fold(0.0, f64::max);
    let unsettled = cut.iter().filter(|s| s.settling_s.is_none()).count();
    let settle = cut.iter().filter_map(|s| s.settling_s).fold(0.0, f64::max);
    let mut v = format!(
        "stable, peak {:.0}% over the reference, loop overshoot {:.0}%",
        100.0 * os,
        100.0 * los
    );
    if unsettled > 0 {
        v.push_str(&format!(
            ", {unsettled} of {} segments not settled",
            cut.len()
        ));
    } else {
        v.push_str(&format!(", settles within {settle:.1} s"));
    }
    let ringing = cut.iter().filter(|s| s.ringing.is_some()).count();
    if ringing > 0 {
        v.push_str(&format!(
            ", ringing beyond ±5% after {} s in {ringing}",
            qloop_plant::metrics::RING_AFTER_S
        ));
    }
    if let Some(z) = cut.iter().filter_map(|s| s.damping).reduce(f64::min) {
        v.push_str(&format!(", damping ζ ≥ {z:.2}"));
    }
    v
}

fn osc(s: &Segment) -> String {
    if s.oscillating {
        format!("yes, {:.2} Hz", s.osc_hz)
    } else {
        "no".into()
    }
}

/// The summary table: per segment and loop, the measured signal's steady-state error, peak
/// and loop overshoot, rise and settling time, damping, late ringing and oscillation; then max |fixed − f64| per signal.
pub fn summary(
    a: &SimArgs,
    sc: &Scenario,
    trace: &Trace,
    m: &Metrics,
    sig: &qloop_plant::Signals,
    plant: &dyn Plant,
    bound: &Bound,
) -> String {
    let (meas, unit) = sig.inputs[0];
    let mut s = String::new();
    let _ = writeln!(
        s,
        "qloop sim: {} on the {} plant, scenario `{}` ({} s, {} periods, {} plant substeps each)",
        a.plan.prog.name,
        a.plant,
        sc.name,
        sc.duration_s,
        trace.rows.len(),
        a.substeps
    );
    let _ = writeln!(s, "reference: {}", bound.reference.source(plant, sc));
    for n in &bound.notes {
        let _ = writeln!(s, "{n}");
    }
    let _ = writeln!(
        s,
        "\n| segment (s) | loop | cutting | {meas} ss error ({unit}) | peak over ref. | loop overshoot | rise ±10% | settling ±5% | damping ζ | ringing after {ring} s | oscillating |",
        ring = qloop_plant::metrics::RING_AFTER_S
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    for (f, r) in m.fixed.segments.iter().zip(&m.reference.segments) {
        for (name, seg) in [("fixed", f), ("f64", r)] {
            if !seg.cutting {
                let _ = writeln!(
                    s,
                    "| {:.1}–{:.1} | {name} | no (air) | – | – | – | – | – | – | – | – |",
                    seg.span.0,
                    seg.span.1.min(sc.duration_s)
                );
                continue;
            }
            let _ = writeln!(
                s,
                "| {:.1}–{:.1} | {name} | yes | {:+.4} | {:.1}% | {:.1}% | {} | {} | {} | {} | {} |",
                seg.span.0,
                seg.span.1.min(sc.duration_s),
                seg.ss_error,
                100.0 * seg.overshoot,
                100.0 * seg.loop_overshoot,
                seg.rise_s.map_or("never".into(), |t| format!("{t:.2} s")),
                seg.settling_s
                    .map_or("not settled".into(), |t| format!("{t:.2} s")),
                seg.damping.map_or("–".into(), |z| format!("{z:.2}")),
                seg.ringing
                    .map_or("no".into(), |r| format!("yes, ±{:.0}%", 100.0 * r)),
                osc(seg)
            );
        }
    }
    let units: std::collections::BTreeMap<&str, &str> =
        sig.states.iter().chain(&sig.outputs).copied().collect();
    let _ = writeln!(s, "\nmax |fixed − f64| per signal:");
    for (name, d) in &m.max_diff {
        let _ = writeln!(
            s,
            "  {name:<10} {d:.3e} {}",
            units.get(name.as_str()).copied().unwrap_or("")
        );
    }
    let _ = writeln!(
        s,
        "\nverdict: fixed-point loop {}; f64 reference loop {}",
        verdict(&m.fixed),
        verdict(&m.reference)
    );
    if let Some(o) = m.fixed.first_oscillation() {
        let _ = writeln!(
            s,
            "  the fixed-point loop oscillates from the segment starting at {:.1} s at {:.2} Hz (amplitude {:.3} {unit})",
            o.span.0, o.osc_hz, o.osc_amplitude
        );
    }
    // Under a sensor fault or a feed hold the loop metrics above describe a loop that was
    // broken or stopped on purpose: say when.
    for f in &sc.faults {
        let _ = writeln!(
            s,
            "sensor fault: {} from {:.1} s to {:.1} s",
            fault_text(&f.kind),
            f.from_s,
            f.to_s
        );
    }
    for id in a.plan.prog.ids_of(qloop_core::ir::SigKind::Output) {
        let out = a.plan.prog.sig(id);
        if !out.flag {
            continue;
        }
        let first_set = |col: &str| {
            let (t, v) = (trace.col("t")?, trace.col(col)?);
            t.iter().zip(v).find(|(_, v)| *v > 0.5).map(|(t, _)| *t)
        };
        let when =
            |t: Option<f64>| t.map_or("never set".to_string(), |t| format!("set at {t:.2} s"));
        let _ = writeln!(
            s,
            "flag {}: fixed-point {}, f64 reference {}",
            out.name,
            when(first_set(&out.name)),
            when(first_set(&format!("{}_ref", out.name)))
        );
    }
    s
}

/// A sensor fault in words.
fn fault_text(k: &qloop_plant::fault::FaultKind) -> String {
    use qloop_plant::fault::FaultKind::*;
    match k {
        Saturate => "saturated at full scale".into(),
        Stuck => "stuck".into(),
        Dropout => "dropped out to zero".into(),
        Spikes {
            height,
            period_s,
            width_s,
        } => format!("spikes of {height} every {period_s} s, {width_s} s wide"),
        NoiseBurst { sigma } => format!("noise burst, σ = {sigma}"),
    }
}
