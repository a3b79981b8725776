//! Closed-loop metrics from a trace: per scenario segment (between breakpoints) the
//! steady-state error, overshoot and settling time of the measured signal against its
//! reference, a stability verdict from sustained or growing oscillation (with its frequency),
//! and the largest fixed − f64 difference per controller signal.

use crate::trace::Trace;

/// Settling band: ±5% of the reference.
pub const SETTLE_BAND: f64 = 0.05;
/// A segment oscillates when, in its last quarter, the oscillation amplitude (√2·RMS about
/// the mean: a sinusoid's amplitude) exceeds 20% of the reference without decaying against
/// the quarter before (ratio ≥ 0.8: sustained, e.g. a limit cycle held by saturation), or
/// exceeds 5% and grows by more than 25% (growing), and it swings about its mean at least
/// [`MIN_CYCLES`] times. Neither amplitude is below the settling band (which
/// [`metrics_noisy`] widens to 4σ of the sensor noise), so that noise alone does not count.
pub const OSC_SUSTAINED: f64 = 0.2;
/// See [`OSC_SUSTAINED`].
pub const OSC_GROWING: f64 = 0.05;
/// An oscillation needs at least this many cycles (two mean crossings each) in the second
/// half of its segment.
pub const MIN_CYCLES: usize = 2;

/// Metrics of one loop over one segment.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Start and end time.
    pub span: (f64, f64),
    /// Whether the loop was cutting (mean measurement ≥ 10% of the reference).
    pub cutting: bool,
    /// Mean error (measured − reference) over the last 20% of the segment.
    pub ss_error: f64,
    /// Largest excess over the reference, as a fraction of it.
    pub overshoot: f64,
    /// Time from the segment start until the measurement stays within the band; `None` if it
    /// never does.
    pub settling_s: Option<f64>,
    /// Oscillation amplitude (√2·RMS about the mean) in the last quarter.
    pub osc_amplitude: f64,
    /// Whether the loop oscillates (sustained or growing).
    pub oscillating: bool,
    /// Oscillation frequency in Hz (from mean crossings in the last half).
    pub osc_hz: f64,
}

/// Metrics of one loop.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopMetrics {
    /// Per segment.
    pub segments: Vec<Segment>,
}

impl LoopMetrics {
    /// Stable unless some cutting segment oscillates.
    pub fn stable(&self) -> bool {
        !self.segments.iter().any(|s| s.cutting && s.oscillating)
    }

    /// The first oscillating segment.
    pub fn first_oscillation(&self) -> Option<&Segment> {
        self.segments.iter().find(|s| s.cutting && s.oscillating)
    }
}

/// Metrics of a run: the fixed-point loop, the reference loop, and their differences.
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    /// The fixed-point loop.
    pub fixed: LoopMetrics,
    /// The f64 reference loop.
    pub reference: LoopMetrics,
    /// max |fixed − f64| per controller signal.
    pub max_diff: Vec<(String, f64)>,
}

/// Metrics of the signal `x` (sampled at `t`) against the constant reference `r` over
/// `[t0, t1)`, with the settling band ±5% of `r`.
pub fn segment(t: &[f64], x: &[f64], r: f64, t0: f64, t1: f64) -> Option<Segment> {
    segment_in_band(t, x, r, t0, t1, SETTLE_BAND * r)
}

/// [`segment`] with the settling band ±`band`.
pub fn segment_in_band(
    t: &[f64],
    x: &[f64],
    r: f64,
    t0: f64,
    t1: f64,
    band: f64,
) -> Option<Segment> {
    let idx: Vec<usize> = (0..t.len()).filter(|&i| t[i] >= t0 && t[i] < t1).collect();
    if idx.len() < 8 {
        return None;
    }
    let xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    let n = xs.len();
    let mean_all = xs.iter().sum::<f64>() / n as f64;
    let tail = &xs[n - n / 5..];
    let ss_error = tail.iter().sum::<f64>() / tail.len() as f64 - r;
    let overshoot = xs.iter().map(|v| (v - r) / r).fold(0.0, f64::max);
    let settling_s = match xs.iter().rposition(|v| (v - r).abs() > band) {
        None => Some(0.0),
        Some(k) if k + 1 < n => Some(t[idx[k + 1]] - t0),
        Some(_) => None,
    };
    let (q3, q4) = (&xs[n / 2..3 * n / 4], &xs[3 * n / 4..]);
    let amp = |s: &[f64]| {
        let m = s.iter().sum::<f64>() / s.len() as f64;
        (2.0 * s.iter().map(|v| (v - m).powi(2)).sum::<f64>() / s.len() as f64).sqrt()
    };
    let (a3, a4) = (amp(q3), amp(q4));
    let half = &xs[n / 2..];
    let m = half.iter().sum::<f64>() / half.len() as f64;
    let crossings = half
        .windows(2)
        .filter(|w| (w[0] - m) * (w[1] - m) < 0.0)
        .count();
    // An oscillation swings about its mean: at least MIN_CYCLES cycles in the second half.
    // A one-way drift (a tool wearing out under a finish loop) grows too, but is no
    // oscillation.
    let oscillating = crossings >= 2 * MIN_CYCLES
        && ((a4 > (OSC_SUSTAINED * r).max(band) && a4 >= 0.8 * a3)
            || (a4 > (OSC_GROWING * r).max(band) && a4 > 1.25 * a3));
    let dur = t[idx[n - 1]] - t[idx[n / 2]];
    let osc_hz = if dur > 0.0 {
        crossings as f64 / 2.0 / dur
    } else {
        0.0
    };
    Some(Segment {
        span: (t0, t1),
        cutting: mean_all >= 0.1 * r,
        ss_error,
        overshoot,
        settling_s,
        osc_amplitude: a4,
        oscillating,
        osc_hz,
    })
}

/// Metrics of a trace from [`crate::run`]: `measured` is the controller input that reads the
/// plant, `reference(t)` its set point (taken at each segment's midpoint: reference steps
/// belong at scenario breakpoints), `breakpoints` the scenario's, `signals` the controller
/// signals compared fixed vs f64.
pub fn metrics(
    trace: &Trace,
    measured: &str,
    reference: &dyn Fn(f64) -> f64,
    breakpoints: &[f64],
    duration: f64,
    signals: &[&str],
) -> Metrics {
    metrics_noisy(
        trace,
        measured,
        reference,
        breakpoints,
        duration,
        signals,
        0.0,
    )
}

/// [`metrics`] for a measurement with sensor noise of standard deviation `noise_sigma`: the
/// settling band widens to ±max(5% of the reference, 4σ), so that noise alone (which leaves
/// ±4σ in fewer than 1 sample in 10⁴) does not count as never settling.
pub fn metrics_noisy(
    trace: &Trace,
    measured: &str,
    reference: &dyn Fn(f64) -> f64,
    breakpoints: &[f64],
    duration: f64,
    signals: &[&str],
    noise_sigma: f64,
) -> Metrics {
    let t = trace.col("t").unwrap_or_default();
    let mut edges = vec![0.0];
    edges.extend(breakpoints.iter().copied());
    edges.push(duration + 1e-9);
    let loop_metrics = |col: &str| {
        let x = trace.col(col).unwrap_or_default();
        LoopMetrics {
            segments: edges
                .windows(2)
                .filter_map(|w| {
                    let r = reference(0.5 * (w[0] + w[1]));
                    let band = (SETTLE_BAND * r).max(4.0 * noise_sigma);
                    segment_in_band(&t, &x, r, w[0], w[1], band)
                })
                .collect(),
        }
    };
    let max_diff = signals
        .iter()
        .filter_map(|s| {
            let d = trace.fixed_vs_ref(s)?.into_iter().fold(0.0, f64::max);
            Some((s.to_string(), d))
        })
        .collect();
    Metrics {
        fixed: loop_metrics(measured),
        reference: loop_metrics(&format!("{measured}_ref")),
        max_diff,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(n: usize) -> Vec<f64> {
        (0..n).map(|k| k as f64 * 0.1).collect()
    }

    #[test]
    fn first_order_settling_matches_analysis() {
        // x = r(1 − e^{-t/τ}), τ = 1 s: enters the 5% band at t = τ·ln 20 = 2.996 s.
        let ts = t(200);
        let x: Vec<f64> = ts.iter().map(|t| 1.5 * (1.0 - (-t).exp())).collect();
        let s = segment(&ts, &x, 1.5, 0.0, 20.0).unwrap();
        assert!((s.settling_s.unwrap() - 3.0).abs() < 1e-9, "{s:?}");
        assert_eq!(s.overshoot, 0.0);
        assert!(!s.oscillating && s.cutting);
        assert!(s.ss_error.abs() < 1e-6);
    }

    #[test]
    fn sustained_oscillation_is_unstable_with_its_frequency() {
        let ts = t(400);
        let x: Vec<f64> = ts
            .iter()
            .map(|t| 1.5 + 0.45 * (2.0 * std::f64::consts::PI * 1.7 * t + 0.3).sin())
            .collect();
        let s = segment(&ts, &x, 1.5, 0.0, 40.0).unwrap();
        assert!(s.oscillating, "{s:?}");
        assert!((s.osc_hz - 1.7).abs() < 0.05, "{}", s.osc_hz);
        // A decaying one is not.
        let y: Vec<f64> = ts
            .iter()
            .map(|t| 1.5 + 0.3 * (-t / 3.0).exp() * (2.0 * std::f64::consts::PI * 1.7 * t).sin())
            .collect();
        assert!(!segment(&ts, &y, 1.5, 0.0, 40.0).unwrap().oscillating);
    }
}
