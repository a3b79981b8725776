//! Figures of RCB₂ against the cycle number, drawn with qloop-plant's plot module.

use crate::paper::TABLE2;
use crate::rcb::Run;
use crate::study::Study;
use crate::turning::LIMITS;
use qloop_plant::plot::{Figure, Line, Panel, Series};

fn series(label: &str, y: Vec<f64>, line: Line) -> Series {
    Series {
        label: label.into(),
        y,
        line,
    }
}

/// The paper's column, padded with NaN (not drawn) past Table 2's ten rows.
fn paper(n: usize, col: impl Fn(&crate::paper::Row) -> f64) -> Vec<f64> {
    (0..n)
        .map(|j| TABLE2.get(j).map_or(f64::NAN, &col))
        .collect()
}

/// One run against Ivester & Danai's Table 2: cycle time, power, roughness, v and f per cycle.
pub fn run_figure(run: &Run) -> Figure {
    let n = run.cycles.len();
    let col = |g: &dyn Fn(&crate::rcb::Cycle) -> f64| run.cycles.iter().map(g).collect::<Vec<_>>();
    let mut time = vec![
        series("qloop RCB2 (true model)", col(&|c| c.time), Line::Fixed),
        series(
            "Ivester & Danai, Table 2",
            paper(n, |r| r.time),
            Line::Reference,
        ),
    ];
    if let Ok(o) = run.robust_optimum() {
        time.push(series(
            "optimum (parts in limits under any noise)",
            vec![o.value; n],
            Line::Setpoint,
        ));
    }
    let quality = |i: usize, name: &str, unit: &str, pick: fn(&crate::paper::Row) -> f64| Panel {
        title: format!("{name} ({unit})"),
        series: vec![
            series("measured", col(&|c| c.measured[i]), Line::Fixed),
            series("true (noise-free)", col(&|c| c.truth[i]), Line::Design(2)),
            series("Ivester & Danai, Table 2", paper(n, pick), Line::Reference),
            series("limit", vec![LIMITS[i]; n], Line::Setpoint),
        ],
    };
    Figure {
        title: format!(
            "RCB2 on Ivester & Danai's turning model (reconstructed): {}, seed {}",
            run.scenario.policy.name(),
            run.scenario.seed
        ),
        t: (1..=n).map(|j| j as f64).collect(),
        x_label: "cycle (part)".into(),
        panels: vec![
            Panel {
                title: "cycle time (s)".into(),
                series: time,
            },
            quality(0, "spindle power", "kW", |r| r.power),
            quality(1, "surface roughness Ra", "um", |r| r.roughness),
            Panel {
                title: "cutting speed v (m/min)".into(),
                series: vec![
                    series("qloop", col(&|c| c.settings.v), Line::Fixed),
                    series(
                        "Ivester & Danai, Table 2",
                        paper(n, |r| r.v),
                        Line::Reference,
                    ),
                ],
            },
            Panel {
                title: "feed f (mm/rev)".into(),
                series: vec![
                    series("qloop", col(&|c| c.settings.f), Line::Fixed),
                    series(
                        "Ivester & Danai, Table 2",
                        paper(n, |r| r.f),
                        Line::Reference,
                    ),
                ],
            },
        ],
    }
}

/// Several policies over the same seeded runs: the median cycle time per cycle (Ivester & Danai, Fig. 5)
/// and the parts out of specification per cycle (the concern of Ivester & Danai, Fig. 6).
pub fn study_figure(studies: &[Study]) -> Figure {
    let n = studies.iter().map(|s| s.cycles).max().unwrap_or(0);
    let runs = studies.first().map_or(0, |s| s.runs.len());
    let pad = |mut v: Vec<f64>| {
        v.resize(n, f64::NAN);
        v
    };
    Figure {
        title: format!(
            "RCB2 confidence levels against the nominal optimiser, {runs} seeded runs (10 % bias, ±10 % noise)"
        ),
        t: (1..=n).map(|j| j as f64).collect(),
        x_label: "cycle (part)".into(),
        panels: vec![
            Panel {
                title: "median cycle time over the runs (s)".into(),
                series: studies
                    .iter()
                    .enumerate()
                    .map(|(i, s)| series(&s.policy.name(), pad(s.median_times()), Line::Design(i)))
                    .collect(),
            },
            Panel {
                title: format!("parts out of specification (of {runs})"),
                series: studies
                    .iter()
                    .enumerate()
                    .map(|(i, s)| {
                        series(
                            &s.policy.name(),
                            pad(s.violations_per_cycle().into_iter().map(|v| v as f64).collect()),
                            Line::Design(i),
                        )
                    })
                    .collect(),
            },
        ],
    }
}

/// φ against spindle speed along the torque limit (the tooth load at which the torque is at
/// its limit), for β = 0, 0.5 and 1, with the temperature along the same line: the optimum is
/// where φ stops rising, at the first limit met.
pub fn bendix_figure(m: &crate::bendix::Milling, e: &crate::bendix::Economics) -> Figure {
    let ft = m.torque_limited_tooth_load();
    let steps = 200;
    let n: Vec<f64> = (0..=steps)
        .map(|i| m.speed.0 + (m.speed.1 - m.speed.0) * i as f64 / steps as f64)
        .collect();
    let feasible = |n: f64| {
        let v = ft * m.teeth * n;
        v <= m.feed_max && m.constraints(v, n).iter().all(|g| *g <= 1e-9)
    };
    let phi = |beta: f64| -> Vec<f64> {
        n.iter()
            .map(|&n| {
                if feasible(n) {
                    m.index(e, beta, ft * m.teeth * n, n)
                } else {
                    f64::NAN
                }
            })
            .collect()
    };
    Figure {
        title: format!(
            "Bendix index along the torque limit (tooth load {ft:.4} in): feasible part only"
        ),
        t: n.clone(),
        x_label: "spindle speed N (rpm)".into(),
        panels: vec![
            Panel {
                title: "phi (in^3/$)".into(),
                series: [0.0, 0.5, 1.0]
                    .iter()
                    .enumerate()
                    .map(|(i, &b)| series(&format!("beta = {b}"), phi(b), Line::Design(i)))
                    .collect(),
            },
            Panel {
                title: "tool temperature (F)".into(),
                series: vec![
                    series(
                        "theta",
                        n.iter()
                            .map(|&n| m.temperature(ft * m.teeth * n, n))
                            .collect(),
                        Line::Fixed,
                    ),
                    series("limit", vec![m.temp_max; n.len()], Line::Setpoint),
                ],
            },
            Panel {
                title: "feedrate V (in/min)".into(),
                series: vec![
                    series(
                        "V at the torque limit",
                        n.iter().map(|&n| ft * m.teeth * n).collect(),
                        Line::Fixed,
                    ),
                    series("max feed", vec![m.feed_max; n.len()], Line::Setpoint),
                ],
            },
        ],
    }
}

/// The cascade per part: F_r, the cycle time (closed loop against the static model), and the
/// two measurements against their limits.
pub fn cascade_figure(run: &crate::cascade::CascadeRun) -> Figure {
    use crate::cascade::LIMITS;
    let n = run.parts.len();
    let col =
        |g: &dyn Fn(&crate::cascade::PartRun) -> f64| run.parts.iter().map(g).collect::<Vec<_>>();
    Figure {
        title: "RCB2 sets the force reference of the generated 1981 loop, part by part (turning plant, closed loop)".into(),
        t: (1..=n).map(|j| j as f64).collect(),
        x_label: "part".into(),
        panels: vec![
            Panel {
                title: "force reference F_r chosen by RCB2 (kN)".into(),
                series: vec![series("F_r", col(&|p| p.fr), Line::Fixed)],
            },
            Panel {
                title: "cycle time (s)".into(),
                series: vec![
                    series("closed loop (generated controller)", col(&|p| p.time), Line::Fixed),
                    series("static model (nominal K_s)", col(&|p| p.time_static), Line::Reference),
                ],
            },
            Panel {
                title: "peak force over the part (kN)".into(),
                series: vec![
                    series("measured", col(&|p| p.measured[0]), Line::Fixed),
                    series("limit", vec![LIMITS[0]; n], Line::Setpoint),
                ],
            },
            Panel {
                title: "surface roughness Ra (um)".into(),
                series: vec![
                    series("measured", col(&|p| p.measured[1]), Line::Fixed),
                    series("limit", vec![LIMITS[1]; n], Line::Setpoint),
                ],
            },
        ],
    }
}

/// The force the sensor read within the first, second and last parts, against each part's
/// reference: the inner loop holding the set point the outer layer chose.
pub fn cascade_parts_figure(run: &crate::cascade::CascadeRun) -> Figure {
    let mut picks: Vec<&crate::cascade::PartRun> = run.parts.iter().take(2).collect();
    if let Some(last) = run.parts.last() {
        if run.parts.len() > 2 {
            picks.push(last);
        }
    }
    let n = picks.iter().map(|p| p.force.len()).max().unwrap_or(0);
    let period = picks.first().map_or(0.1, |p| p.period);
    let pad = |v: &[f64]| {
        let mut v = v.to_vec();
        v.resize(n, f64::NAN);
        v
    };
    let mut force = Vec::new();
    for (i, p) in picks.iter().enumerate() {
        force.push(series(
            &format!("part {} (F_r = {:.3} kN)", p.index, p.fr),
            pad(&p.force),
            Line::Design(i),
        ));
    }
    for p in &picks {
        force.push(series(
            &format!("F_r part {}", p.index),
            pad(&vec![p.fr; p.force.len()]),
            Line::Setpoint,
        ));
    }
    Figure {
        title: format!(
            "Within a part: the generated loop holds the chosen F_r (depth {} mm along the part)",
            run.cascade
                .part
                .sections
                .iter()
                .map(|s| s.1.to_string())
                .collect::<Vec<_>>()
                .join(" -> ")
        ),
        t: (0..n).map(|k| k as f64 * period).collect(),
        x_label: "t (s) from the start of the cut".into(),
        panels: vec![Panel {
            title: "measured cutting force (kN)".into(),
            series: force,
        }],
    }
}
