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

/// One run against 001's Table 2: cycle time, power, roughness, v and f per cycle.
pub fn run_figure(run: &Run) -> Figure {
    let n = run.cycles.len();
    let col = |g: &dyn Fn(&crate::rcb::Cycle) -> f64| run.cycles.iter().map(g).collect::<Vec<_>>();
    let mut time = vec![
        series("qloop RCB2 (true model)", col(&|c| c.time), Line::Fixed),
        series("001 Table 2", paper(n, |r| r.time), Line::Reference),
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
            series("001 Table 2", paper(n, pick), Line::Reference),
            series("limit", vec![LIMITS[i]; n], Line::Setpoint),
        ],
    };
    Figure {
        title: format!(
            "RCB2 on 001's turning model (reconstructed): {}, seed {}",
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
                    series("001 Table 2", paper(n, |r| r.v), Line::Reference),
                ],
            },
            Panel {
                title: "feed f (mm/rev)".into(),
                series: vec![
                    series("qloop", col(&|c| c.settings.f), Line::Fixed),
                    series("001 Table 2", paper(n, |r| r.f), Line::Reference),
                ],
            },
        ],
    }
}

/// Several policies over the same seeded runs: the median cycle time per cycle (001 Fig. 5)
/// and the parts out of specification per cycle (001 Fig. 6's concern).
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
