//! Plots of closed-loop runs (plotters): one panel per quantity a control engineer looks at,
//! the compiled fixed-point loop and the f64 reference loop drawn over each other.
//!
//! [`run_figure`] lays out a run: the measured signal with its reference, each controller
//! output (the command), each adapted state in a unit of its own (gains), and the scenario
//! channels that vary (depth of cut, spindle speed, ...). [`write_svg`] and [`write_png`]
//! render it; both write atomically (a temporary file renamed into place).
//!
//! Text is drawn with DejaVu Sans embedded in the binary (the `dejavu` crate), so plots look
//! the same on every machine and need no system fonts.

use crate::controller::Signals;
use crate::scenario::Scenario;
use crate::trace::Trace;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line {
    /// The compiled fixed-point loop: solid blue, thick.
    Fixed,
    /// The f64 reference loop: thin orange, drawn over the fixed-point line.
    Reference,
    /// A set point: thin black.
    Setpoint,
    /// A scenario input (depth, speed): green.
    Channel,
    /// One of several designs compared in one figure: colour `i` of a fixed palette (blue,
    /// red, purple, brown, grey; then around again), solid.
    Design(usize),
}

/// One curve: a label and its samples (at the figure's time base).
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Samples, one per time point.
    pub y: Vec<f64>,
    /// Style.
    pub line: Line,
}

/// One panel: a title (with unit) and its curves.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// Title, e.g. `fc (kN)`.
    pub title: String,
    /// Curves.
    pub series: Vec<Series>,
}

/// A figure: stacked panels sharing the time axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title on top.
    pub title: String,
    /// The shared x axis: time in seconds for a run, or a cycle number.
    pub t: Vec<f64>,
    /// The x axis's label, e.g. `t (s)` (see [`TIME_AXIS`]) or `cycle`.
    pub x_label: String,
    /// Panels, top to bottom.
    pub panels: Vec<Panel>,
}

/// The x label of a figure over time.
pub const TIME_AXIS: &str = "t (s)";

/// Width of a figure in pixels.
pub const WIDTH: u32 = 1000;
/// Height of one panel in pixels.
pub const PANEL_HEIGHT: u32 = 190;

fn title_with_unit(name: &str, unit: &str) -> String {
    if unit.is_empty() {
        name.to_string()
    } else {
        format!("{name} ({unit})")
    }
}

/// The standard figure of a run of [`crate::run`]: the measured input with the plant's
/// reference, the outputs, the states whose unit differs from every output's (the adapted
/// gains), and the scenario channels that vary.
pub fn run_figure(
    title: &str,
    trace: &Trace,
    sig: &Signals,
    reference: &dyn Fn(f64) -> f64,
    sc: &Scenario,
) -> Figure {
    let t = trace.col("t").unwrap_or_default();
    // A controller signal named like a plant column is recorded with the suffix `_ctl`.
    let col = |name: &str, suffix: &str| {
        trace
            .col(&format!("{name}_ctl{suffix}"))
            .or_else(|| trace.col(&format!("{name}{suffix}")))
    };
    let pair = |name: &str| -> Vec<Series> {
        let mut v = Vec::new();
        if let Some(y) = col(name, "") {
            v.push(Series {
                label: format!("{name} fixed-point"),
                y,
                line: Line::Fixed,
            });
        }
        if let Some(y) = col(name, "_ref") {
            v.push(Series {
                label: format!("{name} f64 reference"),
                y,
                line: Line::Reference,
            });
        }
        v
    };
    let mut panels = Vec::new();
    if let Some((name, unit)) = sig.inputs.first() {
        let mut series = pair(name);
        series.push(Series {
            label: "reference".into(),
            y: t.iter().map(|&t| reference(t)).collect(),
            line: Line::Setpoint,
        });
        panels.push(Panel {
            title: title_with_unit(name, unit),
            series,
        });
    }
    for (name, unit) in &sig.outputs {
        panels.push(Panel {
            title: title_with_unit(name, unit),
            series: pair(name),
        });
    }
    for (name, unit) in &sig.states {
        if sig.outputs.iter().all(|o| o.1 != *unit) {
            panels.push(Panel {
                title: title_with_unit(name, unit),
                series: pair(name),
            });
        }
    }
    for ch in sc.channels.keys() {
        let Some(y) = trace.col(ch) else { continue };
        let (lo, hi) = y
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if hi > lo {
            panels.push(Panel {
                title: ch.clone(),
                series: vec![Series {
                    label: format!("{ch} (scenario)"),
                    y,
                    line: Line::Channel,
                }],
            });
        }
    }
    Figure {
        title: title.to_string(),
        t,
        x_label: TIME_AXIS.into(),
        panels,
    }
}

/// Registers the embedded font once.
fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font shipped by the `dejavu` crate; if registration
        // failed anyway, text would be missing from the plot, not wrong.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

fn size(fig: &Figure) -> (u32, u32) {
    (WIDTH, 40 + PANEL_HEIGHT * fig.panels.len().max(1) as u32)
}

/// The colours of [`Line::Design`], distinct from the set point's black and the channels'
/// green.
const PALETTE: [RGBColor; 5] = [
    RGBColor(31, 90, 200),
    RGBColor(210, 40, 40),
    RGBColor(130, 60, 170),
    RGBColor(150, 90, 30),
    RGBColor(110, 110, 110),
];

fn style(line: Line) -> ShapeStyle {
    match line {
        Line::Fixed => RGBColor(31, 90, 200).stroke_width(2),
        Line::Reference => RGBColor(235, 120, 0).stroke_width(1),
        Line::Setpoint => BLACK.stroke_width(1),
        Line::Channel => RGBColor(40, 140, 60).stroke_width(2),
        Line::Design(i) => PALETTE[i % PALETTE.len()].stroke_width(2),
    }
}

fn y_range(p: &Panel) -> (f64, f64) {
    let (lo, hi) = p
        .series
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = if hi > lo {
        0.08 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(fig: &Figure, root: DrawingArea<DB, Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(&fig.title, ("sans-serif", 20)).map_err(err)?;
    let areas = root.split_evenly((fig.panels.len().max(1), 1));
    let t0 = fig.t.first().copied().unwrap_or(0.0);
    let t1 = fig.t.last().copied().unwrap_or(1.0).max(t0 + 1e-9);
    for (i, (p, area)) in fig.panels.iter().zip(&areas).enumerate() {
        let (lo, hi) = y_range(p);
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, ("sans-serif", 15))
            .margin_right(20)
            .x_label_area_size(if i + 1 == fig.panels.len() { 35 } else { 20 })
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, lo..hi)
            .map_err(err)?;
        let mut mesh = chart.configure_mesh();
        mesh.light_line_style(RGBColor(245, 245, 245))
            .label_style(("sans-serif", 12));
        if i + 1 == fig.panels.len() {
            mesh.x_desc(fig.x_label.as_str());
        }
        mesh.draw().map_err(err)?;
        for s in &p.series {
            let st = style(s.line);
            // A non-finite sample (NaN: no data there) breaks the line into segments.
            let points: Vec<(f64, f64)> = fig.t.iter().copied().zip(s.y.iter().copied()).collect();
            let mut segments = points
                .split(|(_, y)| !y.is_finite())
                .filter(|g| !g.is_empty());
            let first = segments.next().unwrap_or(&[]);
            chart
                .draw_series(LineSeries::new(first.iter().copied(), st))
                .map_err(err)?
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], st));
            for g in segments {
                chart
                    .draw_series(LineSeries::new(g.iter().copied(), st))
                    .map_err(err)?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)
}

/// The figure as SVG text.
pub fn to_svg(fig: &Figure) -> Result<String, String> {
    fonts();
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, size(fig)).into_drawing_area();
        draw(fig, root)?;
    }
    Ok(s)
}

/// A temporary path next to `path`, with the same extension (the PNG encoder picks the
/// format from it).
fn temp_next_to(path: &Path) -> PathBuf {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("plot");
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("png");
    dir.join(format!(".{name}.tmp{}.{ext}", std::process::id()))
}

fn rename_into(tmp: &Path, path: &Path) -> Result<(), String> {
    std::fs::rename(tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        format!("cannot write `{}`: {e}", path.display())
    })
}

/// Writes the figure as SVG to `path`, atomically.
pub fn write_svg(fig: &Figure, path: &Path) -> Result<(), String> {
    let text = to_svg(fig)?;
    let tmp = temp_next_to(path);
    std::fs::write(&tmp, text).map_err(|e| format!("cannot write `{}`: {e}", tmp.display()))?;
    rename_into(&tmp, path)
}

/// Writes the figure as PNG to `path`, atomically.
pub fn write_png(fig: &Figure, path: &Path) -> Result<(), String> {
    fonts();
    let tmp = temp_next_to(path);
    {
        let root = BitMapBackend::new(&tmp, size(fig)).into_drawing_area();
        draw(fig, root).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot render `{}`: {e}", path.display())
        })?;
    }
    rename_into(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fig() -> Figure {
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        Figure {
            title: "test".into(),
            x_label: TIME_AXIS.into(),
            panels: vec![Panel {
                title: "x (kN)".into(),
                series: vec![
                    Series {
                        label: "x fixed-point".into(),
                        y: t.iter().map(|t| t.sin()).collect(),
                        line: Line::Fixed,
                    },
                    Series {
                        label: "reference".into(),
                        y: vec![0.5; t.len()],
                        line: Line::Setpoint,
                    },
                ],
            }],
            t,
        }
    }

    /// NaN samples (no data) split a line instead of drawing to a bogus point: the SVG has
    /// two polylines for the series (and the legend's sample, a third) and no NaN.
    #[test]
    fn nan_samples_break_the_line() {
        let mut f = fig();
        f.panels.truncate(1);
        f.panels[0].series.truncate(1);
        f.panels[0].series[0].y[20] = f64::NAN;
        let svg = to_svg(&f).unwrap();
        assert!(!svg.contains("NaN"));
        let blue = svg
            .matches("<polyline fill=\"none\" opacity=\"1\" stroke=\"#1F5AC8\"")
            .count();
        assert_eq!(blue, 3, "{svg}");
    }

    #[test]
    fn svg_has_every_panel_title_and_label() {
        let s = to_svg(&fig()).unwrap();
        assert!(s.starts_with("<svg"), "{}", &s[..40]);
        for text in ["test", "x (kN)", "x fixed-point", "reference"] {
            assert!(s.contains(text), "missing {text}");
        }
    }

    #[test]
    fn png_is_written_atomically_with_its_size() {
        let dir = std::env::temp_dir().join(format!("qloop-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("f.png");
        write_png(&fig(), &p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        // IHDR: width and height, big-endian, at bytes 16..24.
        let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        assert_eq!((w, h), size(&fig()));
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1, "temporary file left behind");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
