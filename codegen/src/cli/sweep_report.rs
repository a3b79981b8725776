//! The text of the `qloop sweep` report: the drawn parameters, the stability counts and the
//! worst case of each metric with the seed that reproduces it.

use super::sweep::SweepArgs;
use qloop_plant::sweep::{Envelope, Outcome, Worst};
use qloop_plant::{Plant, Scenario};
use std::fmt::Write;

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
        row(&mut s, "peak over the reference", w, &|v| {
            format!("{:.1}%", 100.0 * v)
        });
    }
    if let Some(w) = &e.loop_overshoot {
        row(
            &mut s,
            "loop overshoot (after first reaching it)",
            w,
            &|v| format!("{:.1}%", 100.0 * v),
        );
    }
    if let Some(w) = &e.settling_s {
        row(&mut s, "settling ±5% (s)", w, &|v| {
            if v.is_finite() {
                format!("{v:.2}")
            } else {
                "not settled".into()
            }
        });
    }
    if let Some(w) = &e.rise_s {
        row(&mut s, "rise to ±10% (s)", w, &|v| {
            if v.is_finite() {
                format!("{v:.2}")
            } else {
                "never".into()
            }
        });
    }
    if let Some(w) = &e.underdamping {
        row(&mut s, "damping ratio ζ, lowest", w, &|v| {
            if v > 0.0 {
                format!("{:.2}", 1.0 - v)
            } else {
                "no swing beyond ±5%".into()
            }
        });
    }
    if let Some(w) = &e.ringing_worst {
        let label = format!(
            "ringing beyond ±5% after {} s ({} draws)",
            qloop_plant::metrics::RING_AFTER_S,
            e.ringing
        );
        row(&mut s, &label, w, &|v| format!("±{:.1}%", 100.0 * v));
    }
    for (name, w) in &e.max_diff {
        let u = units(name);
        // A dimensionless signal (a covariance) has no unit to show.
        let u = if u.is_empty() { u } else { format!(" ({u})") };
        row(
            &mut s,
            &format!("fixed − f64 {name}, max abs{u}"),
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
