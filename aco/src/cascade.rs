//! The outer layer sets the inner loop's set point (issue 19, item 6). RCB₂ (Ivester & Danai, eq. 13)
//! chooses the force reference F_r for the next part. The generated Koren–Masory controller,
//! with F_r as an input ([`SETPOINT_SPEC`]), holds it within the part on the turning plant.
//! The part's cycle time is measured in that closed loop, not taken from the static model.
//!
//! **The part** ([`Part`]): a stepped shaft. The depth of cut is set by its geometry along the
//! tool's axial position (2 → 3 → 2.5 mm over 60 mm at 500 rpm, [`Part::example`]). The plant
//! follows it through `TurningParams::depth_profile`. Cycle time = handling + the time the
//! closed loop takes to travel the length.
//!
//! **What RCB₂ measures** after each part, with limits [`LIMITS`]:
//! - the peak force the sensor read over the part (kN, limit 3.0: the insert's rating). At a
//!   depth increase the force jumps with the depth before the loop can cut the feed, a
//!   dynamic effect the static model does not have;
//! - the surface roughness, Ra = f²/(32·r) with the largest feed per revolution over the
//!   part (µm, limit 3.2, nose radius 0.8 mm), read by a gauge with ±10 % noise (Ivester & Danai's noise
//!   model).
//!
//! The noise widths n_R of eq. 7 are each measurement's own: ±3σ of the force sensor (6σ,
//! 0.06 kN at 10 N) and 0.2·m for the gauge.
//!
//! **The static model** for the nonlinear program: the steady feed where the force equals
//! F_r, `f_i = (F_r/(K_s·a_i))^(1/u)` (Koren's survey, eq. 5) in each section, with the nominal K_s. It
//! gives the machining time Σ L_i/(f_i·n/60), a peak force of F_r (no overshoot) and the
//! roughness of the shallowest section. The true plant's K_s is off by up to ±10 % (seeded).
//! RCB₂'s buffers absorb both that bias and the overshoot, since the model is trusted only for
//! the change it predicts (Ivester & Danai, eq. 6).

use crate::nlp::{self, NlpError};
use crate::rcb::{buffers_with, noise_width};
use qloop_plant::controller::Controller;
use qloop_plant::runner::{run_single, RunConfig};
use qloop_plant::scenario::{Scenario, Schedule};
use qloop_plant::turning::{Turning, TurningParams};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The inner loop's spec: the tuned Koren–Masory law with `input fr` (kN), proved for every
/// F_r in [0.5, 3] kN (`tests/tests/cascade.rs` proves it with both solvers).
pub const SETPOINT_SPEC: &str = include_str!("../specs/koren_masory_setpoint.qloop");

/// The limits: peak force (kN) and roughness (µm).
pub const LIMITS: [f64; 2] = [3.0, 3.2];

/// The bounds of F_r the outer layer may choose (kN): the spec's `fr` input range.
pub const FR_BOUNDS: (f64, f64) = (0.5, 3.0);

/// A part: sections of constant depth along the axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// Sections: (length mm, depth mm), in cutting order.
    pub sections: Vec<(f64, f64)>,
    /// Spindle speed (rpm).
    pub spindle_rpm: f64,
    /// Load, unload and approach time per part (s).
    pub handling_s: f64,
    /// Tool nose radius (mm), for the roughness.
    pub nose_radius_mm: f64,
}

impl Part {
    /// The example: 20 mm at 2 mm depth, 20 mm at 3 mm, 20 mm at 2.5 mm; 500 rpm; 30 s of
    /// handling; a 0.8 mm nose radius.
    pub fn example() -> Part {
        Part {
            sections: vec![(20.0, 2.0), (20.0, 3.0), (20.0, 2.5)],
            spindle_rpm: 500.0,
            handling_s: 30.0,
            nose_radius_mm: 0.8,
        }
    }

    /// The part's length (mm).
    pub fn length(&self) -> f64 {
        self.sections.iter().map(|s| s.0).sum()
    }

    /// The depth along the axis as the plant reads it: steps at the section boundaries (two
    /// points at one position; the later wins), then 0 from the end (the tool leaves the
    /// part).
    pub fn profile(&self) -> Schedule {
        let mut points = Vec::new();
        let mut x = 0.0;
        for &(len, depth) in &self.sections {
            points.push([x, depth]);
            x += len;
            points.push([x, depth]);
        }
        points.push([x, 0.0]);
        Schedule(points)
    }

    /// Kinematic roughness Ra = f²/(32·r) (µm) for a feed f (mm/rev).
    pub fn roughness(&self, f_mm_rev: f64) -> f64 {
        1000.0 * f_mm_rev * f_mm_rev / (32.0 * self.nose_radius_mm)
    }
}

/// The static model of a part under ACC at reference F_r (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticModel {
    /// Specific cutting force K_s (kN/(mm·(mm/rev)^u)), nominal.
    pub ks: f64,
    /// Force exponent u (Koren's survey, eq. 5).
    pub u: f64,
}

impl StaticModel {
    /// The turning plant's nominal values.
    pub fn nominal() -> StaticModel {
        let p = TurningParams::default();
        StaticModel { ks: p.ks, u: p.u }
    }

    /// The steady feed (mm/rev) where F = K_s·a·f^u equals `fr`.
    pub fn feed(&self, fr: f64, depth: f64) -> f64 {
        (fr / (self.ks * depth)).powf(1.0 / self.u)
    }

    /// Predicted cycle time (s): handling plus Σ L_i/(f_i·n/60).
    pub fn cycle_time(&self, part: &Part, fr: f64) -> f64 {
        part.handling_s
            + part
                .sections
                .iter()
                .map(|&(len, a)| len / (self.feed(fr, a) * part.spindle_rpm / 60.0))
                .sum::<f64>()
    }

    /// Predicted [peak force, roughness]: F_r, and Ra at the shallowest section's feed.
    pub fn quality(&self, part: &Part, fr: f64) -> [f64; 2] {
        let shallowest = part
            .sections
            .iter()
            .map(|s| s.1)
            .fold(f64::INFINITY, f64::min);
        [fr, part.roughness(self.feed(fr, shallowest))]
    }
}

/// One part of the cascade.
#[derive(Clone, Debug, PartialEq)]
pub struct PartRun {
    /// 1-based part number.
    pub index: usize,
    /// The reference force the outer layer chose (kN).
    pub fr: f64,
    /// Measured [peak force kN, roughness µm].
    pub measured: [f64; 2],
    /// The cycle time of the closed loop (s); the horizon if the part was not finished.
    pub time: f64,
    /// Whether the tool reached the end of the part within the horizon.
    pub finished: bool,
    /// The static model's prediction of the cycle time (s), with the nominal K_s (so it
    /// differs from the closed loop by the bias as well as by the transients).
    pub time_static: f64,
    /// The buffers for the next part (eq. 13).
    pub buffers: [f64; 2],
    /// Set when the next part's program had no solution (the next part then goes back to
    /// the first part's F_r).
    pub nlp_error: Option<String>,
    /// The force the sensor read, one sample per controller period, while cutting (kN).
    pub force: Vec<f64>,
    /// The controller period (s).
    pub period: f64,
}

impl PartRun {
    /// By how much the worse measurement exceeds its limit (≤ 0: none).
    pub fn excess(&self) -> f64 {
        (self.measured[0] - LIMITS[0]).max(self.measured[1] - LIMITS[1])
    }
}

/// The cascade's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Cascade {
    /// The part.
    pub part: Part,
    /// Parts to make.
    pub parts: usize,
    /// The first part's F_r (kN).
    pub first_fr: f64,
    /// RCB₂'s confidence levels (peak force, roughness).
    pub confidence: [f64; 2],
    /// Bias of the true K_s against the static model's (drawn in ±bias).
    pub bias: f64,
    /// Force sensor noise (kN, standard deviation).
    pub sensor_noise_kn: f64,
    /// Half-width of the roughness gauge's multiplicative noise.
    pub gauge_noise: f64,
    /// Seed of the bias, sensor and gauge draws.
    pub seed: u64,
    /// Longest time a part may take to cut before it counts as not finished (s).
    pub horizon_s: f64,
}

impl Cascade {
    /// Ten parts of [`Part::example`] from F_r = 1 kN, c = 0.5, 10 % bias, 10 N of sensor
    /// noise, ±10 % gauge noise, seed 1.
    pub fn example() -> Cascade {
        Cascade {
            part: Part::example(),
            parts: 10,
            first_fr: 1.0,
            confidence: [0.5, 0.5],
            bias: 0.1,
            sensor_noise_kn: 0.01,
            gauge_noise: 0.1,
            seed: 1,
            horizon_s: 120.0,
        }
    }
}

/// The result of a cascade.
#[derive(Clone, Debug, PartialEq)]
pub struct CascadeRun {
    /// The settings.
    pub cascade: Cascade,
    /// The true plant's K_s.
    pub true_ks: f64,
    /// The parts, in order.
    pub parts: Vec<PartRun>,
}

/// What one part's closed-loop run gave.
struct Cut {
    /// Cycle time (s).
    time: f64,
    /// Whether the tool reached the end.
    finished: bool,
    /// Peak measured force (kN).
    peak: f64,
    /// Largest feed per revolution while cutting (mm/rev).
    fmax: f64,
    /// Measured force per period while cutting (kN).
    force: Vec<f64>,
    /// Controller period (s).
    period: f64,
}

/// Cuts one part at reference `fr` in closed loop.
fn cut(
    c: &Cascade,
    plant: &Turning,
    controller: Box<dyn Controller>,
    fr: f64,
    seed: u64,
) -> Result<Cut, String> {
    let mut sc = Scenario::new(
        "cascade part",
        c.horizon_s,
        c.sensor_noise_kn,
        &[
            ("fr", Schedule::constant(fr)),
            ("n_rpm", Schedule::constant(c.part.spindle_rpm)),
        ],
    );
    sc.seed = seed;
    let period = controller.period();
    let trace = run_single(plant, controller, &sc, RunConfig::default())?;
    let col = |n: &str| {
        trace
            .col(n)
            .ok_or_else(|| format!("the closed-loop trace has no column `{n}`"))
    };
    let (t, x, fc, f) = (col("t")?, col("x_mm")?, col("fc")?, col("f_mm_rev")?);
    let length = c.part.length();
    let end = x.iter().position(|&x| x >= length);
    let cutting = end.unwrap_or(t.len());
    let peak = fc[..cutting].iter().copied().fold(0.0, f64::max);
    let fmax = f[..cutting].iter().copied().fold(0.0, f64::max);
    let (time, finished) = match end {
        Some(i) => (t[i], true),
        None => (c.horizon_s, false),
    };
    Ok(Cut {
        time: c.part.handling_s + time,
        finished,
        peak,
        fmax,
        force: fc[..cutting].to_vec(),
        period,
    })
}

/// The next F_r by RCB₂: the static model's fastest F_r with its predicted quality at most
/// the current prediction plus the buffers (Ivester & Danai, eqs. 5–6, 13).
pub fn next_fr(model: &StaticModel, part: &Part, fr: f64, b: [f64; 2]) -> Result<f64, NlpError> {
    let q0 = model.quality(part, fr);
    let diff = |g: &dyn Fn(f64) -> f64, x: &[f64]| {
        let h = 1e-7 * x[0];
        (g(x[0]), vec![(g(x[0] + h) - g(x[0] - h)) / (2.0 * h)])
    };
    let obj = |x: &[f64]| diff(&|r| model.cycle_time(part, r), x);
    let c0 = |x: &[f64]| diff(&|r| model.quality(part, r)[0] - q0[0] - b[0], x);
    let c1 = |x: &[f64]| diff(&|r| model.quality(part, r)[1] - q0[1] - b[1], x);
    let o = nlp::minimise(&obj, &[&c0, &c1], &[fr], &[FR_BOUNDS])?;
    Ok(o.x[0])
}

/// Runs the cascade; `controller` makes a fresh inner-loop controller per part (the compiled
/// [`SETPOINT_SPEC`], or its f64 reference).
pub fn run(
    c: &Cascade,
    controller: &dyn Fn() -> Box<dyn Controller>,
) -> Result<CascadeRun, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(c.seed);
    let model = StaticModel::nominal();
    let true_ks = model.ks * (1.0 + c.bias * rng.random_range(-1.0..=1.0));
    let plant = Turning::new(TurningParams {
        ks: true_ks,
        depth_profile: Some(c.part.profile()),
        ..TurningParams::default()
    });
    let mut fr = c.first_fr;
    let mut parts = Vec::with_capacity(c.parts);
    for index in 1..=c.parts {
        let seed = rng.random::<u64>();
        let cut = cut(c, &plant, controller(), fr, seed)?;
        let w = c.gauge_noise;
        let ra = c.part.roughness(cut.fmax) * rng.random_range(1.0 - w..=1.0 + w);
        let measured = [cut.peak, ra];
        // n_R (Ivester & Danai, eq. 7): the sensor's ±3σ band for the peak force, the gauge's ±10 % for
        // the roughness.
        let n_r = [6.0 * c.sensor_noise_kn, noise_width(ra)];
        let buffers = buffers_with(c.confidence, measured, LIMITS, n_r);
        let mut p = PartRun {
            index,
            fr,
            measured,
            time: cut.time,
            finished: cut.finished,
            time_static: model.cycle_time(&c.part, fr),
            buffers,
            nlp_error: None,
            force: cut.force,
            period: cut.period,
        };
        match next_fr(&model, &c.part, fr, buffers) {
            Ok(next) => fr = next,
            // No F_r meets the modified constraints: back to the first part's conservative
            // reference, not the one that just failed.
            Err(e) => {
                p.nlp_error = Some(e.to_string());
                fr = c.first_fr;
            }
        }
        parts.push(p);
    }
    Ok(CascadeRun {
        cascade: c.clone(),
        true_ks,
        parts,
    })
}
