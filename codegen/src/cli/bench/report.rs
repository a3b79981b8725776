//! The report: the cost table with ratios to qloop, the size table ([`super::size_table`]),
//! the output checks against qloop, the goals and the JSON summary. A variant that does not
//! fit the target's memory was not run: its cost and outputs are absent.

use super::measured::Measured;
use super::platform::Platform;
use super::size::Footprint;
use super::variants::{OutKind, Variant};
use super::{BenchArgs, DIV_SPEC};
use crate::cli::error::CliResult;
use qloop::ir::{SigId, SigKind};
use std::fmt::Write as _;

/// One goal line: its text and whether it is met.
struct Goal {
    text: String,
    met: bool,
}

/// How far a variant's outputs are from qloop's after the first tenth of the steps.
struct Deviation {
    /// Largest |difference| as a fraction of the output's range, its absolute value, the
    /// step and the output where it occurs.
    rel: f64,
    abs: f64,
    step: usize,
    output: usize,
    /// Fraction of the compared steps where every output is within `tol` of the range.
    within: f64,
}

fn deviation(
    qv: &[(String, OutKind)],
    q: &Measured,
    v: &Variant,
    m: &Measured,
    spans: &[f64],
    tol: f64,
) -> Deviation {
    let skip = q.outs.len() / 10;
    let mut d = Deviation {
        rel: 0.0,
        abs: 0.0,
        step: skip,
        output: 0,
        within: 1.0,
    };
    let (mut n, mut ok) = (0usize, 0usize);
    for (i, (a, b)) in q.outs.iter().zip(&m.outs).enumerate().skip(skip) {
        let mut step_ok = true;
        for (k, ((_, qk), (_, vk))) in qv.iter().zip(&v.outputs).enumerate() {
            let diff = (qk.value(a[k]) - vk.value(b[k])).abs();
            let rel = if diff.is_nan() {
                f64::INFINITY
            } else {
                diff / spans[k]
            };
            step_ok &= rel <= tol;
            if rel > d.rel {
                (d.rel, d.abs, d.step, d.output) = (rel, diff, i, k);
            }
        }
        n += 1;
        ok += usize::from(step_ok);
    }
    if n > 0 {
        d.within = ok as f64 / n as f64;
    }
    d
}

fn fmt_mean(x: f64) -> String {
    if (x - x.round()).abs() < 1e-9 {
        format!("{}", x.round() as i64)
    } else {
        format!("{x:.2}")
    }
}

/// One bench run's data: the arguments, the platform, the variants, what each measured (`None`:
/// not run) and its sizes (`variants[0]`/`results[0]` are qloop's).
pub(super) struct Run<'a> {
    pub(super) a: &'a BenchArgs<'a>,
    pub(super) pf: &'a Platform,
    pub(super) variants: &'a [Variant],
    pub(super) results: &'a [Option<Measured>],
    pub(super) sizes: &'a [Footprint],
}

/// The variants in the order the table and the JSON list them.
pub(super) const ORDER: [&str; 5] = ["qloop", "plain_mul", "float", "div_float", "div_int32"];

impl Run<'_> {
    /// The index of a variant, if it was built.
    pub(super) fn find(&self, name: &str) -> Option<usize> {
        self.variants.iter().position(|v| v.name == name)
    }

    /// A variant's measurements, if it was built and run.
    fn measured(&self, name: &str) -> Option<&Measured> {
        self.find(name).and_then(|i| self.results[i].as_ref())
    }

    /// qloop's mean per step, if it ran.
    fn q_mean(&self) -> Option<f64> {
        self.results[0].as_ref().map(Measured::mean)
    }
}

/// Prints the table, the output checks and the goals, and writes the JSON; returns whether
/// qloop's and plain_mul's outputs are identical and whether every goal is met.
pub(super) fn summarize(
    a: &BenchArgs,
    pf: &Platform,
    variants: &[Variant],
    results: &[Option<Measured>],
    sizes: &[Footprint],
) -> CliResult<(bool, bool)> {
    let r = Run {
        a,
        pf,
        variants,
        results,
        sizes,
    };
    let plan = a.plan;
    let t = &plan.target;
    let mut o = format!(
        "qloop bench: spec `{}` on target `{}` ({}), {} steps\nmethod: {}\n{}\n\n",
        plan.prog.name,
        t.name,
        t.about,
        a.steps,
        pf.method(),
        super::variants::STIMULUS_TEXT
    );
    table(&r, &mut o);
    super::size_table::table(&r, &mut o);
    let identical = outputs(&r, &mut o);
    let goals = goals(&r, &mut o);
    let all_met = goals.iter().all(|g| g.met);
    print!("{o}");
    if let Some(path) = a.json {
        write_json(&r, path, identical, &goals)?;
    }
    Ok((identical, all_met))
}

/// The cost table: per variant, mean, min and max per step and the ratio to qloop, with
/// notes on what the counts mean on this platform.
fn table(r: &Run, o: &mut String) {
    let (a, pf, variants) = (r.a, r.pf, r.variants);
    let t = &a.plan.target;
    let unit = pf.unit();
    let q_mean = r.q_mean();
    let _ = writeln!(
        o,
        "{:<10} {:>12} {:>10} {:>10} {:>14}",
        "variant",
        format!("{unit}/step"),
        "min",
        "max",
        "ratio to qloop"
    );
    for name in ORDER {
        match (r.find(name), r.measured(name)) {
            (Some(_), Some(m)) => {
                let ratio = q_mean.map_or("n/a".to_string(), |q| {
                    format!("{:.2}x", m.mean() / q.max(f64::MIN_POSITIVE))
                });
                let _ = writeln!(
                    o,
                    "{:<10} {:>12} {:>10} {:>10} {:>14}",
                    name,
                    fmt_mean(m.mean()),
                    m.min(),
                    m.max(),
                    ratio
                );
            }
            (Some(_), None) => {
                let _ = writeln!(
                    o,
                    "{:<10} {:>12}   (does not fit the target's memory: not run; see sizes)",
                    name, "not run"
                );
            }
            (None, _) => {
                let _ = writeln!(
                    o,
                    "{:<10} {:>12} {:>10} {:>10} {:>14}",
                    name, "n/a", "", "", ""
                );
            }
        }
    }
    if !variants.iter().any(|v| v.name == "div_float") {
        let _ = writeln!(
            o,
            "(div_float and div_int32 are hand-written for {DIV_SPEC} only: n/a for this spec)"
        );
    }
    if t.name.contains("slowmul") && matches!(pf, Platform::Qemu { .. }) {
        let _ = writeln!(
            o,
            "(QEMU counts instructions: the 32-cycle MULS of this target costs 1 here; \
             compare cycles with its cost model, not with these counts)"
        );
    }
    if let Platform::Qemu { .. } | Platform::Riscv { .. } = pf {
        let _ = writeln!(
            o,
            "(QEMU counts every instruction as 1, whatever its cycles: multiplies, hardware \
             divides and FPU operations too)"
        );
    }
    if let Platform::Riscv { cpu, .. } = pf {
        if cpu.contains("m=false") {
            let _ = writeln!(
                o,
                "(no M extension: every multiply and divide is a libgcc routine, `__mulsi3`, \
                 `__divsi3`, ..., counted instruction by instruction)"
            );
        }
    }
}

/// The output checks: plain_mul must equal qloop bit for bit; float and the division
/// baselines agree within their tolerances. Returns whether plain_mul equals qloop.
fn outputs(r: &Run, o: &mut String) -> bool {
    let (a, variants) = (r.a, r.variants);
    let plan = a.plan;
    let find = |name: &str| r.find(name);
    let _ = writeln!(o, "\noutputs:");
    let Some(q) = r.results[0].as_ref() else {
        let _ = writeln!(o, "  qloop was not run (does not fit): nothing to compare");
        return true;
    };
    let qv = &variants[0];
    let out_ids: Vec<SigId> = plan.prog.ids_of(SigKind::Output).collect();
    let spans: Vec<f64> = out_ids
        .iter()
        .map(|id| {
            let (lo, hi) = plan.prog.sig(*id).range.unwrap_or(plan.summary[id.0].range);
            if hi > lo {
                hi - lo
            } else {
                1.0
            }
        })
        .collect();
    let Some(p) = r.measured("plain_mul") else {
        let _ = writeln!(o, "  plain_mul was not run (does not fit): not compared");
        return true;
    };
    let mism = q.outs.iter().zip(&p.outs).position(|(x, y)| x != y);
    let identical = mism.is_none();
    match mism {
        None => {
            let _ = writeln!(
                o,
                "  plain_mul == qloop: identical raw outputs on all {} steps",
                a.steps
            );
        }
        Some(i) => {
            let _ = writeln!(
                o,
                "  plain_mul != qloop: raw outputs DIFFER from step {i} (qloop {:?}, plain_mul {:?}); \
                 this is a bug: both compute the same exact products",
                q.outs[i], p.outs[i]
            );
        }
    }
    let out_units: Vec<String> = out_ids
        .iter()
        .map(|id| plan.prog.sig(*id).unit.clone().unwrap_or_default())
        .collect();
    let out_names: Vec<String> = out_ids
        .iter()
        .map(|id| plan.prog.sig(*id).name.clone())
        .collect();
    let skip = a.steps / 10;
    for (name, tol, expected) in [
        ("float", 0.02, None),
        (
            "div_float",
            0.10,
            Some("a different algorithm (K_c = K/K_p at once instead of integrating), so only held levels agree"),
        ),
        ("div_int32", 0.10, Some("the division algorithm of div_float, in Q12")),
    ] {
        let Some(i) = find(name) else { continue };
        let Some(m) = r.measured(name) else {
            let _ = writeln!(o, "  {name:<9} was not run (does not fit): not compared");
            continue;
        };
        let d = deviation(&qv.outputs, q, &variants[i], m, &spans, tol);
        let verdict = match (d.rel <= tol, expected) {
            (true, _) => "within tolerance".to_string(),
            (false, None) => "DIFFERS".to_string(),
            (false, Some(why)) => format!("differs, as expected: {why}"),
        };
        let _ = writeln!(
            o,
            "  {name:<9} vs qloop after step {skip}: {:.0} % of steps within {:.0} % of the output range; \
             max |{}| difference {} {} ({:.2} %) at step {}: {verdict}",
            d.within * 100.0,
            tol * 100.0,
            out_names.get(d.output).map(String::as_str).unwrap_or("output"),
            qloop::report::g(d.abs),
            out_units.get(d.output).map(String::as_str).unwrap_or(""),
            d.rel * 100.0,
            d.step,
        );
    }
    identical
}

/// The goals (issue 5), printed; returns them for the JSON.
fn goals(r: &Run, o: &mut String) -> Vec<Goal> {
    let (plan, unit) = (r.a.plan, r.pf.unit());
    let mut goals = Vec::new();
    // A variant that was not run meets no goal it is part of.
    let not_run = |name: &str, what: String| Goal {
        text: format!("{what}: not measured, {name} does not fit"),
        met: false,
    };
    let q_mean = match r.q_mean() {
        Some(q) => q,
        None => {
            goals.push(not_run("qloop", "the goals".to_string()));
            print_goals(plan, &goals, o);
            return goals;
        }
    };
    let ratio = |name: &str| {
        r.find(name).map(|_| {
            r.measured(name)
                .map(|m| m.mean() / q_mean.max(f64::MIN_POSITIVE))
        })
    };
    for (name, times) in [("float", 3.0), ("div_float", 5.0), ("div_int32", 5.0)] {
        let what = format!("qloop >= {times}x fewer {unit} than {name}");
        match ratio(name) {
            Some(Some(r)) => goals.push(Goal {
                text: format!("{what}: {r:.2}x"),
                met: r >= times,
            }),
            Some(None) => goals.push(not_run(name, what)),
            None => {}
        }
    }
    if let Some(p) = r.measured("plain_mul") {
        let pm = p.mean();
        goals.push(Goal {
            text: format!(
                "qloop <= plain_mul: {} vs {} {unit}",
                fmt_mean(q_mean),
                fmt_mean(pm)
            ),
            met: q_mean <= pm,
        });
    } else if r.find("plain_mul").is_some() {
        goals.push(not_run("plain_mul", "qloop <= plain_mul".to_string()));
    }
    print_goals(plan, &goals, o);
    goals
}

/// Prints the goals under their heading.
fn print_goals(plan: &qloop::Plan, goals: &[Goal], o: &mut String) {
    let t = &plan.target;
    let stated = plan.prog.name == DIV_SPEC && t.name == "atmega328p";
    let _ = writeln!(
        o,
        "\ngoals{}:",
        if stated {
            ""
        } else {
            " (stated for koren_masory_1981 on atmega328p; informational here)"
        }
    );
    for g in goals {
        let _ = writeln!(
            o,
            "  {:<8} {}",
            if g.met { "met" } else { "NOT met" },
            g.text
        );
    }
}

/// Writes the JSON report atomically.
fn write_json(r: &Run, path: &std::path::Path, identical: bool, goals: &[Goal]) -> CliResult {
    let (a, pf) = (r.a, r.pf);
    let (plan, unit) = (a.plan, pf.unit());
    let t = &plan.target;
    let val = |name: &str, f: &dyn Fn(&Measured) -> serde_json::Value| {
        r.measured(name).map_or(serde_json::Value::Null, f)
    };
    let obj = |f: &dyn Fn(&Measured) -> serde_json::Value| {
        let mut m = serde_json::Map::new();
        for name in ORDER {
            m.insert(name.to_string(), val(name, f));
        }
        serde_json::Value::Object(m)
    };
    let json = serde_json::json!({
        "spec": plan.prog.name,
        "target": t.name,
        "unit": unit,
        "method": pf.method(),
        "steps": a.steps,
        "step": obj(&|m| serde_json::json!((m.mean() * 100.0).round() / 100.0)),
        "min": obj(&|m| serde_json::json!(m.min())),
        "max": obj(&|m| serde_json::json!(m.max())),
        "qloop_equals_plain_mul": identical,
        "not_run": ORDER
            .iter()
            .filter(|n| r.find(n).is_some() && r.measured(n).is_none())
            .collect::<Vec<_>>(),
        "goals": goals.iter().map(|g| serde_json::json!({"goal": g.text, "met": g.met})).collect::<Vec<_>>(),
    });
    let mut json = json;
    if let Some(m) = json.as_object_mut() {
        m.extend(super::size_table::json(r));
    }
    let text = serde_json::to_string_pretty(&json).unwrap_or_default() + "\n";
    crate::cli::files::write_atomic(path, &text)?;
    println!("\nwrote {}", path.display());
    Ok(())
}
