//! Milling under force control: the plant of Rubio & De la Sen
//! (Sec. II.A and Sec. V).
//!
//! **Model.** The feed-rate command `f_c` (mm/s, the control signal) goes to the CNC unit,
//! whose drives are tuned over-damped and modelled as a first-order lag (Rubio & De la Sen, eq. 1):
//!
//! ```text
//!     f_a(s)/f_c(s) = 1/(τ_m·s + 1),        τ_m = 0.1 ms (Rubio & De la Sen, Sec. II.A and Sec. V)
//! ```
//!
//! and the chatter-free cutting process as a first-order lag with the process gain
//! `K_p = K_c·a·b/(N·n)` (Rubio & De la Sen, eq. 2; eq. 3 is the product of the two):
//!
//! ```text
//!     F(s)/f_a(s) = K_c·a(φ_st, φ_ex, N)·b/(N·n) · 1/(τ_c·s + 1)
//! ```
//!
//! with `K_c` = 1200 N/mm² (aluminium, Rubio & De la Sen, Sec. II.A and V), `N` = 4 teeth, `n` = 715 rpm
//! (11.92 rev/s), `b` the axial depth of cut (mm) and `a` the non-dimensional immersion
//! function (0 to N). Units: `K_c·b` in N/mm times the feed per tooth `f_a/(N·n)` in mm gives
//! newtons, so `K_p` is in N·s/mm.
//!
//! **Numbers the OCR damaged, and how they were derived.**
//! * `τ_c`: the text reads "τ_c = %\M"; in the same sentence "T = %" is the sampling time
//!   "inversely proportional to the spindle speed", and T = 0.0839 s = 60/715 s is exactly
//!   one revolution, so `%` renders `1/n` and **τ_c = 1/n** (one spindle revolution: the
//!   chip load settles over a revolution). Kept as a parameter in revolutions,
//!   [`MillingParams::tau_c_rev`], and swept from a tooth period to two revolutions.
//! * `a`: not given numerically; the paper mills "full-immersed" with a 4-fluted cutter.
//!   For a slot (φ_st = 0, φ_ex = π) with N = 4, two teeth 90° apart are always in cut,
//!   with chip thicknesses `c·sin φ` and `c·cos φ` (c the feed per tooth) and perpendicular
//!   tangential forces `K_c·b·c·sin φ` and `K_c·b·c·cos φ`, so the resultant is
//!   `K_c·b·c·√(sin²φ + cos²φ) = K_c·b·c` at every angle: **a = 1**, and the peak force
//!   equals the mean (derived; a radial component `K_r` would scale it by √(1 + K_r²)).
//! * `K_c` prints as "1zoo": 1200 N/mm² (Rubio & De la Sen, Sec. V prints "1200").
//!
//! **Realisation.** Between depth changes the process is eq. 2; across a sudden change of
//! `b` (Rubio & De la Sen: "piecewise constant, while admitting sudden changes in the cutting parameters
//! at certain time instants") the lag is placed on the feed (the chip load builds up over a
//! revolution) and the gain multiplies its output: `F = K_p(b(t))·f_h` with
//! `τ_c·ḟ_h = f_a − f_h`. A depth step therefore changes the force at once by `b₂/b₁`, the
//! "peaks ... when the axial depth of cut ... is suddenly altered" of Rubio & De la Sen, Sec. V. Both lags
//! are advanced exactly under the held command (the cascade's closed form, not RK4): the
//! controller output is held (ZOH) and applied at the sample instant, with no transport
//! delay (Rubio & De la Sen, eq. 3 has none, and "the CNC unit has its own digital position law executed
//! at small time intervals in comparison with the sampled time", Rubio & De la Sen, Sec. II.A).
//!
//! **The closed loop and what sets stability.** Sampled at `T = 1/n` (Rubio & De la Sen, Sec. V), `τ_m`
//! is negligible (`e^{−T/τ_m}` ≈ 10⁻³⁶⁴) and the process is `K_p(1 − α)/(z − α)` with
//! `α = e^{−T/τ_c}` = e^{−1} = 0.368. With the integral law `U(i) = U(i−1) + K_c·E(i)`
//! (Koren's survey, eq. 8) and `K = K_c·K_p` the characteristic polynomial is
//! `z² − (1 + α − K(1 − α))z + α`: stable iff `0 < K < 2(1 + α)/(1 − α)` = **4.33**
//! (2 if τ_c were zero, the worst reading of the damaged τ_c). The poles are complex for
//! `K > (1 − √α)/(1 + √α)` = 0.245 and then lie on `|z| = √α` = 0.607 whatever `K`: `K`
//! only sets their angle, the decay per period is fixed by the process lag. Because the
//! force is linear in the feed, the secant gain `F/U` that the Koren–Masory estimator
//! tracks (Koren & Masory 1981, eqs. 8-9) *is* `K_p`, and holding `K_c·K_m` constant holds the true loop
//! gain: with the spec `milling_acc` (K = 1/2) the gain margin is 8.7 at every depth. The
//! process gain spans 0.050 → 0.126 kN/(mm/s) over Fig. 1's 2 → 5 mm, so a fixed gain
//! tuned at 2 mm would still be stable at 5 mm (K ×2.5): unlike turning, milling at these
//! numbers needs the adaptation for constant *dynamics* (settling, overshoot), not for
//! stability.

use crate::contract::Channel;
use crate::controller::Named;
use crate::discrete::exp_diff;
use crate::plant::{unknown_param, Param, Plant};
use crate::scenario::{Scenario, Schedule};
use crate::sensor::SensorParams;

/// Milling-plant parameters (Rubio & De la Sen, Sec. II.A and Sec. V).
#[derive(Clone, Debug, PartialEq)]
pub struct MillingParams {
    /// Specific cutting pressure K_c in N/mm² (Rubio & De la Sen, eq. 2; Sec. V: 1200 N/mm², aluminium).
    pub kc_n_mm2: f64,
    /// Number of teeth N (Rubio & De la Sen, Sec. II.A: "a 4-fluted carbide mill tool"; Sec. V: N = 4).
    pub teeth: f64,
    /// Immersion function a (Rubio & De la Sen, eq. 2): 1, derived for full immersion with 4 teeth (module
    /// docs). A scenario channel `immersion` overrides it.
    pub immersion: f64,
    /// Spindle speed n in rpm (Rubio & De la Sen, Sec. V: 715 rpm, constant). A scenario channel `n_rpm`
    /// overrides it.
    pub n_rpm: f64,
    /// CNC time constant τ_m in s (Rubio & De la Sen, eq. 1 and Sec. V: 0.1 ms).
    pub tau_m_s: f64,
    /// Cutting-process time constant τ_c in spindle revolutions: τ_c = `tau_c_rev`/n
    /// (Rubio & De la Sen, eq. 2 and Sec. V; the OCR-damaged "τ_c = %" read as 1/n, see the module docs).
    pub tau_c_rev: f64,
    /// Reference force F_r in kN (Rubio & De la Sen, Sec. V: 1.2 kN), for metrics.
    pub fr_kn: f64,
    /// Force sensor. Chosen as for turning: 12-bit ADC over 0-5 kN (1.22 N LSB), gain 1; Rubio & De la Sen
    /// does not model the sensor.
    pub sensor: SensorParams,
}

impl Default for MillingParams {
    fn default() -> Self {
        MillingParams {
            kc_n_mm2: 1200.0,
            teeth: 4.0,
            immersion: 1.0,
            n_rpm: 715.0,
            tau_m_s: 1e-4,
            tau_c_rev: 1.0,
            fr_kn: 1.2,
            sensor: SensorParams {
                gain: 1.0,
                noise_sigma: 0.0,
                range: (0.0, 5.0),
                bits: 12,
            },
        }
    }
}

impl MillingParams {
    /// The process gain K_p = K_c·a·b/(N·n) of Rubio & De la Sen, eq. 3, in kN/(mm/s) (= kN·s/mm), at
    /// axial depth `b_mm`, immersion `a` and spindle speed `n_rpm`.
    pub fn process_gain(&self, b_mm: f64, a: f64, n_rpm: f64) -> f64 {
        self.kc_n_mm2 * a * b_mm / (self.teeth * n_rpm / 60.0) / 1000.0
    }
}

/// The milling plant: CNC lag and cutting process of Rubio & De la Sen, eqs. 1-2.
#[derive(Clone, Debug)]
pub struct Milling {
    /// Parameters.
    pub p: MillingParams,
    /// Table feed f_a (mm/s), the CNC lag's output (Rubio & De la Sen, eq. 1).
    fa: f64,
    /// Feed seen by the cut f_h (mm/s): f_a through the process lag τ_c (Rubio & De la Sen, eq. 2).
    fh: f64,
    /// The held feed-rate command f_c (mm/s).
    cmd: f64,
    /// `(h, n_rpm, e^{-h/τ_c}, e^{-h/τ_m}, (1/τ_c)·exp_diff)` for the last substep length and
    /// speed.
    decay: (f64, f64, f64, f64, f64),
}

impl Milling {
    /// A milling plant at rest (no feed, no force).
    pub fn new(p: MillingParams) -> Milling {
        Milling {
            p,
            fa: 0.0,
            fh: 0.0,
            cmd: 0.0,
            decay: (f64::NAN, f64::NAN, 1.0, 1.0, 0.0),
        }
    }

    /// Axial depth of cut b (mm), channel `b_mm`; 3 mm (Fig. 1's first step) if unset.
    fn depth(sc: &Scenario, t: f64) -> f64 {
        sc.value("b_mm", t, 3.0).max(0.0)
    }

    fn immersion(&self, sc: &Scenario, t: f64) -> f64 {
        sc.value("immersion", t, self.p.immersion).max(0.0)
    }

    fn speed(&self, sc: &Scenario, t: f64) -> f64 {
        sc.value("n_rpm", t, self.p.n_rpm).max(1e-9)
    }

    /// The process gain K_p (kN/(mm/s)) now (Rubio & De la Sen, eq. 3).
    pub fn process_gain(&self, sc: &Scenario, t: f64) -> f64 {
        self.p
            .process_gain(Self::depth(sc, t), self.immersion(sc, t), self.speed(sc, t))
    }

    /// Feed per tooth of the cut, f_h/(N·n) (mm/tooth).
    fn feed_per_tooth(&self, sc: &Scenario, t: f64) -> f64 {
        self.fh.max(0.0) / (self.p.teeth * self.speed(sc, t) / 60.0)
    }

    /// The table feed f_a (mm/s).
    pub fn table_feed(&self) -> f64 {
        self.fa
    }

    /// Peak cutting force F = K_p·f_h in kN (Rubio & De la Sen, eq. 2 at the lagged feed).
    pub fn force_kn(&self, sc: &Scenario, t: f64) -> f64 {
        self.process_gain(sc, t) * self.fh.max(0.0)
    }
}

impl Plant for Milling {
    fn name(&self) -> &'static str {
        "milling"
    }
    fn measured(&self) -> Named {
        ("force", "kN")
    }
    fn command(&self) -> Named {
        ("feed", "mm/s")
    }
    fn describe(&self) -> (&'static str, &'static str) {
        (
            "resultant cutting force (Rubio & De la Sen, eq. 3)",
            "table feedrate to the CNC lag (Rubio & De la Sen, eqs. 1-2)",
        )
    }
    fn channels(&self) -> Vec<Channel> {
        vec![
            Channel {
                name: "b_mm",
                unit: "mm",
                default: 3.0,
                what: "axial depth of cut (work-piece profile, Rubio & De la Sen, Fig. 1)",
            },
            Channel {
                name: "immersion",
                unit: "1",
                default: self.p.immersion,
                what: "radial immersion factor",
            },
            Channel {
                name: "n_rpm",
                unit: "rpm",
                default: self.p.n_rpm,
                what: "spindle speed",
            },
            Channel {
                name: "fr",
                unit: "kN",
                default: self.p.fr_kn,
                what: "reference force (for metrics; an input `fr` reads it)",
            },
        ]
    }
    fn sensor(&self) -> SensorParams {
        self.p.sensor.clone()
    }
    fn reference(&self, sc: &Scenario, t: f64) -> f64 {
        sc.value("fr", t, self.p.fr_kn)
    }
    fn command_at(&mut self, _: f64, cmd: f64) {
        self.cmd = cmd;
    }
    fn advance(&mut self, sc: &Scenario, t: f64, h: f64) {
        let n = self.speed(sc, t);
        if self.decay.0 != h || self.decay.1 != n {
            let (pm, pc) = (1.0 / self.p.tau_m_s, n / 60.0 / self.p.tau_c_rev);
            self.decay = (
                h,
                n,
                (-h * pc).exp(),
                (-h * pm).exp(),
                pc * exp_diff(pm, pc, h),
            );
        }
        let (_, _, ec, em, cross) = self.decay;
        // Exact solution of τ_m·ḟ_a = u − f_a, τ_c·ḟ_h = f_a − f_h under the held u over h:
        // f_h(h) = u + (f_h − u)·e^{−h/τ_c} + (f_a − u)·(1/τ_c)·(e^{−h/τ_m} − e^{−h/τ_c})/(1/τ_c − 1/τ_m).
        let u = self.cmd;
        let d = self.fa - u;
        self.fh = u + (self.fh - u) * ec + d * cross;
        self.fa = u + d * em;
    }
    fn output(&self, sc: &Scenario, t: f64) -> f64 {
        self.force_kn(sc, t)
    }
    fn columns(&self) -> Vec<&'static str> {
        vec![
            "b_mm",
            "n_rpm",
            "feed_cmd_mm_s",
            "feed_mm_s",
            "fz_mm_tooth",
            "kp_kn_s_mm",
            "force_n",
        ]
    }
    fn record(&self, sc: &Scenario, t: f64, out: &mut Vec<f64>) {
        out.extend([
            Self::depth(sc, t),
            self.speed(sc, t),
            self.cmd,
            self.fa,
            self.feed_per_tooth(sc, t),
            self.process_gain(sc, t),
            self.force_kn(sc, t) * 1000.0,
        ]);
    }
    fn fresh(&self) -> Box<dyn Plant> {
        Box::new(Milling::new(self.p.clone()))
    }
    fn params(&self) -> Vec<Param> {
        let p = &self.p;
        vec![
            Param {
                name: "kc_n_mm2",
                value: p.kc_n_mm2,
                range: (0.7 * p.kc_n_mm2, 1.3 * p.kc_n_mm2),
                why: "chosen: ±30% about Rubio & De la Sen's 1200 N/mm² (eq. 2): aluminium alloys and tool wear",
            },
            Param {
                name: "tau_c_rev",
                value: p.tau_c_rev,
                range: (0.25, 2.0),
                why: "the τ_c of Rubio & De la Sen, eq. 2, is OCR-damaged (read as 1/n): from one tooth period 1/(N·n) to two revolutions",
            },
            Param {
                name: "tau_m_s",
                value: p.tau_m_s,
                range: (1e-4, 0.03),
                why: "Rubio & De la Sen, eq. 1: 0.1 ms; chosen upper end 30 ms, a slow CNC velocity loop (turning uses 10-40 ms)",
            },
            Param {
                name: "sensor_gain",
                value: p.sensor.gain,
                range: (0.95, 1.05),
                why: "chosen: ±5% dynamometer calibration error",
            },
        ]
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), String> {
        match name {
            "kc_n_mm2" => self.p.kc_n_mm2 = value,
            "tau_c_rev" => self.p.tau_c_rev = value,
            "tau_m_s" => self.p.tau_m_s = value,
            "sensor_gain" => self.p.sensor.gain = value,
            _ => return Err(unknown_param(self, name)),
        }
        *self = Milling::new(self.p.clone());
        Ok(())
    }
}

/// The work-piece of Rubio & De la Sen, Fig. 1 as (axial depth b in mm, segment duration in s).
///
/// The figure is lost in the text extraction; its labels survive as "3mm 5mm 3mm / 2mm" and
/// "5.87mm 5.87mm 7.55mm / 5.87mm" ("5mm" printed "Smm"). Assumed: four segments, the first
/// row the axial depths b = 3, 5, 3, 2 mm (every neighbour differs, as "changes in the axial
/// depth of cut" require; the second row has two equal neighbours) and the second row their
/// lengths 5.87, 5.87, 7.55, 5.87 mm, paired in order. The paper switches the transfer
/// function "at certain time instants" (Rubio & De la Sen, Sec. II.A), and its time axes (Fig. 5) run
/// 0-25 s, the total 25.16 of the lengths, so each segment is taken to last its length read
/// in seconds (1 mm of the drawing = 1 s), with the cut starting at t = 0 from rest.
pub const FIG1_PROFILE: [(f64, f64); 4] = [(3.0, 5.87), (5.0, 5.87), (3.0, 7.55), (2.0, 5.87)];

/// The `b_mm` schedule of [`FIG1_PROFILE`], starting at `t0`.
fn fig1_schedule(t0: f64) -> (Schedule, f64) {
    let mut pts = Vec::new();
    let mut t = t0;
    for (b, len) in FIG1_PROFILE {
        pts.push([t, b]);
        t += len;
        pts.push([t, b]);
    }
    pts.pop();
    (Schedule(pts), t)
}

/// The milling scenarios: the depth profile of Rubio & De la Sen, Fig. 1, at 715 rpm, the same with sensor noise,
/// and an air gap.
pub fn scenarios() -> Vec<Scenario> {
    let n715 = Schedule::constant(715.0);
    let (profile, end) = fig1_schedule(0.0);
    vec![
        // Rubio & De la Sen, Fig. 1: b = 3 → 5 → 3 → 2 mm (see FIG1_PROFILE).
        Scenario::new(
            "depth-profile",
            end,
            0.0,
            &[("b_mm", profile.clone()), ("n_rpm", n715.clone())],
        ),
        // The same with 40 N (1σ, 3.3% of F_r) force-sensor noise.
        Scenario::new(
            "noise",
            end,
            0.04,
            &[("b_mm", profile), ("n_rpm", n715.clone())],
        ),
        // The tool approaches in air for 1 s, cuts 3 mm, leaves the work (b = 0) for 2 s and
        // re-enters: the feed runs to its limit in air, so the re-entry overloads the tool.
        Scenario::new(
            "air-gap",
            20.0,
            0.0,
            &[
                (
                    "b_mm",
                    Schedule::from_points(&[
                        (1.0, 0.0),
                        (1.0, 3.0),
                        (10.0, 3.0),
                        (10.0, 0.0),
                        (12.0, 0.0),
                        (12.0, 3.0),
                    ]),
                ),
                ("n_rpm", n715),
            ],
        ),
    ]
}

/// The scenario named `name`.
pub fn scenario_named(name: &str) -> Option<Scenario> {
    scenarios().into_iter().find(|s| s.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile() -> Scenario {
        scenario_named("depth-profile").unwrap()
    }

    /// Runs `p` with the command `cmd` held from t = 0 for `steps` substeps of `h`.
    fn hold(p: &mut Milling, sc: &Scenario, cmd: f64, h: f64, steps: usize) -> f64 {
        p.command_at(0.0, cmd);
        let mut t = 0.0;
        for _ in 0..steps {
            p.advance(sc, t, h);
            t += h;
        }
        t
    }

    #[test]
    fn steady_state_force_is_kc_a_b_feed_over_n_n() {
        // Rubio & De la Sen, eq. 3 at DC, by hand: K_c·a·b·f/(N·n) = 1200·1·3·10/(4·715/60) N = 755.24 N.
        let expect_n: f64 = 1200.0 * 3.0 * 10.0 / (4.0 * 715.0 / 60.0);
        assert!((expect_n - 755.2448).abs() < 1e-4);
        let mut p = Milling::new(MillingParams::default());
        let sc = profile();
        hold(&mut p, &sc, 10.0, 0.0839 / 20.0, 20 * 60); // 60 periods ≈ 60 τ_c
        let f = p.force_kn(&sc, 1.0) * 1000.0;
        assert!((f - expect_n).abs() < 1e-9 * expect_n, "{f} vs {expect_n}");
        // And the gain at 1.2 kN: the feed that holds F_r at each Fig. 1 depth.
        for (b, feed) in [(2.0, 23.8333), (3.0, 15.8889), (5.0, 9.5333)] {
            let kp = p.p.process_gain(b, 1.0, 715.0);
            assert!((1.2 / kp - feed).abs() < 1e-4, "b = {b}: {}", 1.2 / kp);
        }
    }

    #[test]
    fn lags_follow_the_exact_two_lag_step_response() {
        // Unit step through 1/(τ_m s + 1)·1/(τ_c s + 1): the closed form
        // 1 − (τ_c e^{−t/τ_c} − τ_m e^{−t/τ_m})/(τ_c − τ_m), here with a slow CNC
        // (τ_m = 30 ms) so both lags show, and for the paper's τ_m = 0.1 ms, where it is
        // 1 − e^{−t/τ_c} to 10⁻³.
        for tau_m in [0.03, 1e-4] {
            let mut p = Milling::new(MillingParams {
                tau_m_s: tau_m,
                ..MillingParams::default()
            });
            let sc = profile();
            let tau_c = 60.0 / 715.0;
            let h = 0.0839 / 20.0;
            let mut t = 0.0;
            p.command_at(0.0, 1.0);
            for k in 1..=200 {
                p.advance(&sc, t, h);
                t = k as f64 * h;
                let exact = 1.0
                    - (tau_c * (-t / tau_c).exp() - tau_m * (-t / tau_m).exp()) / (tau_c - tau_m);
                assert!((p.fh - exact).abs() < 1e-12, "t = {t}: {} vs {exact}", p.fh);
                assert!((p.fa - (1.0 - (-t / tau_m).exp())).abs() < 1e-12);
                if tau_m < 1e-3 {
                    assert!((p.fh - (1.0 - (-t / tau_c).exp())).abs() < 1.2e-3);
                }
            }
            // After one period τ_c = T: 1 − e^{−1} (fast CNC) to 10⁻³.
            if tau_m < 1e-3 {
                let mut q = Milling::new(MillingParams::default());
                hold(&mut q, &sc, 1.0, h, 20);
                assert!((q.fh - (1.0 - (-1f64).exp())).abs() < 1.2e-3, "{}", q.fh);
            }
        }
    }

    #[test]
    fn equal_time_constants_use_the_limit() {
        // τ_m = τ_c = τ: f_h = 1 − (1 + t/τ)e^{−t/τ}.
        let tau = 60.0 / 715.0;
        let mut p = Milling::new(MillingParams {
            tau_m_s: tau,
            ..MillingParams::default()
        });
        let t = hold(&mut p, &profile(), 1.0, tau / 20.0, 40);
        let exact = 1.0 - (1.0 + t / tau) * (-t / tau).exp();
        assert!((p.fh - exact).abs() < 1e-12, "{} vs {exact}", p.fh);
    }

    #[test]
    fn a_depth_step_scales_the_force_at_once() {
        // Steady 3 mm cut at 15.89 mm/s (F = F_r), then Fig. 1's step to 5 mm at 5.87 s: the
        // force jumps to F_r·5/3 = 2 kN with no lag (Rubio & De la Sen, Sec. V's "peaks").
        let mut p = Milling::new(MillingParams::default());
        let sc = profile();
        let feed = 1.2 / p.p.process_gain(3.0, 1.0, 715.0);
        hold(&mut p, &sc, feed, 0.0839 / 20.0, 20 * 60);
        assert!((p.force_kn(&sc, 5.86) - 1.2).abs() < 1e-9);
        assert!((p.force_kn(&sc, 5.87) - 2.0).abs() < 1e-9);
        assert!((p.force_kn(&sc, 12.0) - 1.2).abs() < 1e-9);
        assert!((p.force_kn(&sc, 20.0) - 0.8).abs() < 1e-9);
    }

    #[test]
    fn profile_is_fig1() {
        let sc = profile();
        assert_eq!(sc.breakpoints(), vec![5.87, 11.74, 19.29]);
        assert!((sc.duration_s - 25.16).abs() < 1e-12);
        for (t, b) in [(0.0, 3.0), (5.0, 3.0), (6.0, 5.0), (12.0, 3.0), (19.3, 2.0)] {
            assert_eq!(sc.value("b_mm", t, -1.0), b, "t = {t}");
        }
        for s in scenarios() {
            s.validate().unwrap();
            assert_eq!(scenario_named(&s.name).unwrap(), s);
        }
    }

    #[test]
    fn params_cover_their_nominal_values_and_reset_the_plant() {
        let mut p = Milling::new(MillingParams::default());
        for q in p.params() {
            assert!(q.range.0 <= q.value && q.value <= q.range.1, "{q:?}");
        }
        p.command_at(0.0, 5.0);
        p.advance(&profile(), 0.0, 0.01);
        p.set_param("tau_c_rev", 0.5).unwrap();
        assert_eq!((p.fa, p.fh, p.p.tau_c_rev), (0.0, 0.0, 0.5));
        let e = p.set_param("ks", 1.0).unwrap_err();
        assert!(e.contains("kc_n_mm2") && e.contains("tau_c_rev"), "{e}");
    }
}
