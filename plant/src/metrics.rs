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
/// A segment has settled only if the measurement stays in the band for at least this fraction
/// of the segment before it ends (the window of the steady-state error), and at least
/// [`SETTLE_DWELL_MIN_S`]: a last sample that happens to fall in the band is not settling.
pub const SETTLE_DWELL: f64 = 0.2;
/// See [`SETTLE_DWELL`].
pub const SETTLE_DWELL_MIN_S: f64 = 1.0;
/// A segment rings when, later than this after its start, the measurement leaves the band on
/// both sides of the reference (above, then below, or the reverse).
pub const RING_AFTER_S: f64 = 3.0;
/// Rise time: until the measurement first comes within this fraction of the reference.
pub const RISE_BAND: f64 = 0.1;

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
    /// The loop's own overshoot: the largest distance from the reference, as a fraction of
    /// it, after the measurement first reaches the reference (0 if it never does). A
    /// disturbance step (a deeper cut) moves the measurement away in one sample, before any
    /// controller can act; this leaves that jump out and keeps what the loop does after it.
    pub loop_overshoot: f64,
    /// Time from the segment start until the measurement stays within the band to the end of
    /// the segment; `None` ("not settled") if it does not, or if it is in the band for less
    /// than the dwell ([`SETTLE_DWELL`]) before the segment ends.
    pub settling_s: Option<f64>,
    /// Time from the segment start until the measurement first comes within ±[`RISE_BAND`] of
    /// the reference (for a step from zero, the 0 → 90 % rise); `None` if it never does.
    pub rise_s: Option<f64>,
    /// Damping ratio ζ estimated from the first two extrema of the error about the reference
    /// that leave the band, on opposite sides: their ratio is e^{−ζπ/√(1−ζ²)} for a
    /// second-order response. `None` when the error does not swing through the reference
    /// beyond the band (no overshoot to measure: well damped).
    pub damping: Option<f64>,
    /// Largest excursion beyond the reference, as a fraction of it, later than
    /// [`RING_AFTER_S`] after the segment start, if the measurement leaves the band there on
    /// both sides of the reference (ringing); `None` otherwise.
    pub ringing: Option<f64>,
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
    let loop_overshoot = match xs.windows(2).position(|w| (w[0] - r) * (w[1] - r) <= 0.0) {
        Some(k) => xs[k + 1..]
            .iter()
            .map(|v| (v - r).abs() / r.abs())
            .fold(0.0, f64::max),
        None => 0.0,
    };
    let t_end = t[idx[n - 1]];
    let dwell = (SETTLE_DWELL * (t_end - t0)).max(SETTLE_DWELL_MIN_S);
    let settling_s = match xs.iter().rposition(|v| (v - r).abs() > band) {
        None => Some(0.0),
        Some(k) if k + 1 < n && t_end - t[idx[k + 1]] >= dwell => Some(t[idx[k + 1]] - t0),
        Some(_) => None,
    };
    let rise_s = xs
        .iter()
        .position(|v| (v - r).abs() <= RISE_BAND * r.abs())
        .map(|k| t[idx[k]] - t0);
    let damping = damping_ratio(&xs, r, band);
    let ringing = {
        let late: Vec<f64> = idx
            .iter()
            .zip(&xs)
            .filter(|(&i, _)| t[i] - t0 > RING_AFTER_S)
            .map(|(_, v)| v - r)
            .collect();
        let above = late.iter().any(|e| *e > band);
        let below = late.iter().any(|e| *e < -band);
        (above && below).then(|| late.iter().map(|e| e.abs()).fold(0.0, f64::max) / r.abs())
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
        loop_overshoot,
        settling_s,
        rise_s,
        damping,
        ringing,
        osc_amplitude: a4,
        oscillating,
        osc_hz,
    })
}

/// The damping ratio of the error `x − r`: from the first two extrema beyond `band` on
/// opposite sides of the reference (a half cycle apart), whose magnitude ratio `q` is
/// e^{−ζπ/√(1−ζ²)} for a second-order step response, so ζ = δ/√(π² + δ²) with δ = ln(1/q).
/// `None` when the error does not swing through the reference beyond the band.
pub fn damping_ratio(xs: &[f64], r: f64, band: f64) -> Option<f64> {
    // The extreme error of each excursion beyond the band, in order, one per side change.
    let mut peaks: Vec<f64> = Vec::new();
    let mut cur: Option<f64> = None;
    for e in xs.iter().map(|v| v - r) {
        if e.abs() <= band {
            continue;
        }
        match cur {
            Some(p) if p.signum() == e.signum() => {
                if e.abs() > p.abs() {
                    cur = Some(e);
                }
            }
            Some(p) => {
                peaks.push(p);
                if peaks.len() == 2 {
                    break;
                }
                cur = Some(e);
            }
            None => cur = Some(e),
        }
    }
    if peaks.len() < 2 {
        if let (1, Some(p)) = (peaks.len(), cur) {
            peaks.push(p);
        } else {
            return None;
        }
    }
    let q = (peaks[1] / peaks[0]).abs();
    if q >= 1.0 {
        return Some(0.0);
    }
    let d = -q.ln();
    Some(d / (std::f64::consts::PI.powi(2) + d * d).sqrt())
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

    /// The unit step response of a second-order system with damping ζ and natural frequency
    /// ωn, scaled to `r`: the analytic truth for the damping, overshoot and rise metrics.
    fn second_order(ts: &[f64], r: f64, zeta: f64, wn: f64) -> Vec<f64> {
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        ts.iter()
            .map(|&t| {
                let c = (wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin();
                r * (1.0 - (-zeta * wn * t).exp() * c)
            })
            .collect()
    }

    #[test]
    fn damping_overshoot_and_rise_of_a_second_order_step_match_analysis() {
        let ts: Vec<f64> = (0..20_000).map(|k| k as f64 * 1e-3).collect();
        for zeta in [0.1, 0.3, 0.5] {
            let x = second_order(&ts, 1.5, zeta, 4.0);
            let s = segment(&ts, &x, 1.5, 0.0, 20.0).unwrap();
            let d = s.damping.expect("an underdamped response swings");
            assert!((d - zeta).abs() < 2e-3, "ζ = {zeta}: estimated {d}");
            let os = (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
            assert!((s.overshoot - os).abs() < 1e-4, "{} vs {os}", s.overshoot);
            // Rise to 90 %: the first t with x = 0.9 r, found by bisection on the formula.
            let f = |t: f64| second_order(&[t], 1.5, zeta, 4.0)[0] - 1.35;
            let (mut a, mut b) = (
                0.0,
                std::f64::consts::PI / (4.0 * (1.0 - zeta * zeta).sqrt()),
            );
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if f(m) < 0.0 {
                    a = m
                } else {
                    b = m
                }
            }
            assert!(
                (s.rise_s.unwrap() - b).abs() < 2e-3,
                "{:?} vs {b}",
                s.rise_s
            );
        }
        // ζ = 0.8 overshoots 1.5 %, inside the 5 % band: nothing swings beyond it.
        let x = second_order(&ts, 1.5, 0.8, 4.0);
        assert_eq!(segment(&ts, &x, 1.5, 0.0, 20.0).unwrap().damping, None);
    }

    #[test]
    fn a_last_sample_in_the_band_is_not_settling_and_late_swings_ring() {
        let ts = t(150);
        // Rings ±30 % at 0.5 Hz, decaying slowly; the band is entered only near the end.
        let x: Vec<f64> = ts
            .iter()
            .map(|t| 1.5 * (1.0 + 0.3 * (-t / 8.0).exp() * (std::f64::consts::PI * t).cos()))
            .collect();
        let s = segment(&ts, &x, 1.5, 0.0, 15.0).unwrap();
        assert_eq!(s.settling_s, None, "{s:?}");
        let ring = s
            .ringing
            .expect("swings beyond ±5 % on both sides after 3 s");
        // After 3 s the envelope is 0.3·e^{-3/8} = 0.206; the first sample after 3 s sits at a
        // cosine extreme (t = 3.1 s is not one; the next, 4.0 s, gives 0.3·e^{-0.5} = 0.182).
        assert!(ring > 0.18 && ring <= 0.21, "{ring}");
        // The same trace cut off where the band holds for its last 20 %: settled.
        let quiet: Vec<f64> = x
            .iter()
            .zip(&ts)
            .map(|(v, t)| if *t >= 10.0 { 1.5 } else { *v })
            .collect();
        let q = segment(&ts, &quiet, 1.5, 0.0, 15.0).unwrap();
        assert!(q.settling_s.is_some_and(|s| s <= 10.0), "{q:?}");
    }

    #[test]
    fn the_loop_overshoot_leaves_out_a_disturbance_jump() {
        // A jump to 2 r at t = 0, then a second-order return (ζ = 0.3) to r: the peak is the
        // jump (100 %); after the first crossing the error swings to e^{-ζπ/√(1-ζ²)} of the
        // initial error on the other side (37.2 % of r).
        let ts: Vec<f64> = (0..20_000).map(|k| k as f64 * 1e-3).collect();
        let back = second_order(&ts, 1.0, 0.3, 4.0);
        let x: Vec<f64> = back.iter().map(|b| 1.5 * (2.0 - b)).collect();
        let s = segment(&ts, &x, 1.5, 0.0, 20.0).unwrap();
        assert!((s.overshoot - 1.0).abs() < 1e-9, "{}", s.overshoot);
        let os = (-0.3 * std::f64::consts::PI / (1.0f64 - 0.09).sqrt()).exp();
        assert!(
            (s.loop_overshoot - os).abs() < 1e-4,
            "{} vs {os}",
            s.loop_overshoot
        );
    }
}
