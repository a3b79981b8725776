//! Plunge grinding under normal-force control (Jenkins & Kurfess, "Adaptive Pole-Zero
//! Cancellation in Grinding Force Control, Part II", Jenkins & Kurfess).
//!
//! **Model.** The force controller commands the X-axis position `x_d` (mm) every
//! T = 2.214 ms (5 PMAC servo cycles, text above eq. 6), held between samples. Positions are
//! measured from the point of first contact (an identified incremental model, see below).
//!
//! ```text
//! position loop (eq. 1):      dx/dt = −224·x + 203·x_d                    (x: axis position, mm)
//! grinding process (eq. 11):  F_N = K_s·δ,   δ = x − w,                   (K_s = 233 N/mm)
//!                             dw/dt = η·δ   while in contact (δ > 0)     (w: depth ground, mm)
//!                             F_N = 0, dw/dt = 0 out of contact
//! ```
//!
//! In contact, `δ(s) = s/(s + η)·x(s)`, so `F_N(s)/x(s) = K_s·s/(s + η)` (eq. 11) and
//! `F_N/x_d = 203·K_s·s/((s + η)(s + 224))` (eq. 12). The state form is the physical reading of
//! eq. 11 with η = K_p·K_s·V/A (text below eq. 11): the wheel removes material at a rate
//! proportional to the normal force (`dw/dt = (η/K_s)·F_N = K_p·V/A·F_N`), so at a fixed
//! axis position the force relaxes with time constant 1/η, and holding a force needs a
//! steady infeed `η·F_N/K_s`. With η = 0 the process is the spring `K_s` of the fixed-gain
//! design (eq. 2). The force cannot pull: when the wheel leaves the surface (δ ≤ 0) the force
//! is zero and nothing is removed (the paper's Fig. 7 run starts in air and "eventually"
//! makes contact).
//!
//! The identified position loop has DC gain 203/224 = 0.906: it was fitted "with the grinding
//! wheel in contact with the workpiece ... at the anticipated force levels" (text above
//! eq. 1), so it describes increments about the contact point, which is why positions here
//! are measured from first contact. Under the held command both linear stages are advanced
//! exactly ([`crate::discrete`]): `x` by the ZOH first-order update, `δ` by the closed-form
//! response of `s/(s + η)` to the exponentially relaxing `x`. At the sample rate the path is
//! `F_N/x_d = f2(η)·(z − 1)/((z − f1(η))(z − C_o))` with `f1 = e^{−ηT}`, `C_o = e^{−224T}`,
//! `f2 = 203·K_s/(224 − η)·(f1 − C_o)` (eqs. 16-18), and for η = 0 `0.3543·K_s/(z − 0.6091)`
//! (eq. 7; 0.6090 at exactly 2.214 ms, see [`crate::discrete`]). The contact switch is
//! resolved to the integration substep (T/20 = 0.11 ms by default).
//!
//! Sensor: the in-line strain-gauge force sensor "is approximately unity over the frequency
//! range of interest (0-20 Hz)" (text above eq. 1): gain 1, no dynamics; chosen: a 12-bit ADC
//! over 0-100 N (0.024 N per step, below the 0.46 N force resolution the 2 µm encoder sets,
//! text on Fig. 7), and seeded Gaussian noise from the scenario.
//!
//! **Closed loop with the fixed-gain PI** (`verified/specs/grinding_pi.qloop`): eq. 8,
//! `x_d = K_PROP·(1 + α_d·z/(z − 1))·E` with `K_PROP = 200/(203·233)` mm/N and
//! `α_d = K_I·T/K_PROP = 100·T = 0.2214`. The `z − 1` of the process (eq. 18) cancels the
//! PI's integrator, so the loop is type 0 once η > 0, with characteristic polynomial
//!
//! ```text
//!     (z − f1)(z − C_o) + G·((1 + α_d)·z − 1),    G = K_PROP·f2(η)   (G = 0.349 at η = 0)
//! ```
//!
//! * roots at z = 0.891 and 0.292 for η = 0 (s = −52 and −556 1/s), 0.889 and 0.290 for
//!   η = 2: real and positive, so the step response has no overshoot; 95% rise time 20
//!   periods = 0.044 s at η = 0 (19 periods to 95% of its own final value at η = 2; the
//!   paper's target is under 0.25 s, and it measured 0.124-0.164 s, Table 1);
//! * Jury: stable iff `G < (1 + f1)(1 + C_o)/(2 + α_d)`, i.e. the design gain `K_F` of eq. 5
//!   below 830 1/s for every η in [0, 10] (the paper's Fig. 6: "less than 800"); both roots stay
//!   on the positive real axis for K_F < 349 (paper: 380); the design uses 200, so the fixed
//!   gain tolerates K_s up to 4× its nominal value;
//! * steady state: holding F_N needs the infeed `η·F_N/K_s`, which the integrator can only
//!   supply from a standing error: `E = F_r·224η/(α·K_F + 224η)` (α = 100 1/s, K_F = 200),
//!   2.2% at η = 2 1/s (24.45 N at F_r = 25 N) and 8.2% at η = 8 1/s. This is the
//!   performance loss from process variation that the paper's adaptive controller addresses
//!   (text after eq. 12); the fixed-gain design of eq. 2 ignores the process ("ignoring the
//!   process dynamics", text on Fig. 7).

use crate::contract::Channel;
use crate::controller::Named;
use crate::discrete::{exp_diff, zoh_first_order};
use crate::plant::{unknown_param, Param, Plant};
use crate::scenario::{Scenario, Schedule};
use crate::sensor::SensorParams;

/// The paper's encoder resolution, 2 µm (text on Fig. 7: "the resolution of the encoder
/// position is 2 μm which when multiplied by the spring constant yields a force resolution of
/// 0.46 N"), for [`GrindingParams::encoder_mm`].
pub const PAPER_ENCODER_MM: f64 = 0.002;

/// The force-loop period the paper's eq. 7 coefficients correspond to: 5 servo cycles of the
/// measured 442.7 µs (text above eq. 6), which the paper rounds to 2.214 ms.
pub const PAPER_PERIOD_S: f64 = 5.0 * 442.7e-6;

/// Grinding-plant parameters. Defaults are the paper's values, except where marked chosen.
#[derive(Clone, Debug, PartialEq)]
pub struct GrindingParams {
    /// Position-loop gain, 203 1/s (Jenkins & Kurfess, eq. 1, `203/(s + 224)`).
    pub pos_gain_1_s: f64,
    /// Position-loop pole, 224 1/s (Jenkins & Kurfess, eq. 1).
    pub pos_pole_1_s: f64,
    /// Effective stiffness K_s of the axis and in-line strain-gauge sensor, 233 N/mm (Jenkins & Kurfess, text
    /// on Table 1; eqs. 2, 11).
    pub ks_n_mm: f64,
    /// Nominal process parameter η = K_p·K_s·V/A in 1/s (Jenkins & Kurfess, eq. 11). The paper reports only
    /// η ≪ 224 (text below eq. 12; the values are in its Part I). Chosen: 2 1/s, which puts
    /// the fixed-gain loop's standing force error at 2.2% (24.45 N at 25 N), within the spread
    /// of Table 1's fixed-gain mean forces (24.34-26.06 N at 25 N). Scenarios scale it with the
    /// channel `eta_factor`.
    pub eta_1_s: f64,
    /// Encoder resolution in mm: the held command is rounded to it (chosen model of the 2 µm
    /// encoder: the servo can hold only whole counts). 0 (default) is the linear position
    /// loop of eq. 1 that the paper's design analysis uses; [`PAPER_ENCODER_MM`] is the
    /// paper's axis.
    pub encoder_mm: f64,
    /// Reference force in N for metrics when a scenario has no `fr` channel (the Table 1
    /// experiments' 25 N).
    pub fr_n: f64,
    /// Force sensor and ADC (see the module docs).
    pub sensor: SensorParams,
}

impl Default for GrindingParams {
    fn default() -> Self {
        GrindingParams {
            pos_gain_1_s: 203.0,
            pos_pole_1_s: 224.0,
            ks_n_mm: 233.0,
            eta_1_s: 2.0,
            encoder_mm: 0.0,
            fr_n: 25.0,
            sensor: SensorParams {
                gain: 1.0,
                noise_sigma: 0.0,
                range: (0.0, 100.0),
                bits: 12,
            },
        }
    }
}

/// The grinding plant: PMAC position loop and grinding process (Jenkins & Kurfess, eqs. 1, 11).
#[derive(Clone, Debug)]
pub struct Grinding {
    /// Parameters.
    pub p: GrindingParams,
    /// Axis position x (mm from first contact).
    x: f64,
    /// Depth ground w (mm): the workpiece surface, from its position at first contact.
    w: f64,
    /// Held command x_d (mm), after the encoder rounding.
    cmd: f64,
    /// `(h, e^{−224·h})` of the last substep length.
    decay: (f64, f64),
}

impl Grinding {
    /// A grinding plant at first contact: wheel touching the surface, no force, no motion.
    pub fn new(p: GrindingParams) -> Grinding {
        Grinding {
            p,
            x: 0.0,
            w: 0.0,
            cmd: 0.0,
            decay: (0.0, 1.0),
        }
    }

    /// η at time `t`: the nominal value times the scenario's `eta_factor` (default 1).
    pub fn eta(&self, sc: &Scenario, t: f64) -> f64 {
        (self.p.eta_1_s * sc.value("eta_factor", t, 1.0)).max(0.0)
    }

    /// Normal force F_N = K_s·max(δ, 0) in N (Jenkins & Kurfess, eq. 11).
    pub fn force_n(&self) -> f64 {
        self.p.ks_n_mm * (self.x - self.w).max(0.0)
    }

    /// Axis position x in mm.
    pub fn position_mm(&self) -> f64 {
        self.x
    }

    /// Depth ground w in mm.
    pub fn removed_mm(&self) -> f64 {
        self.w
    }
}

impl Plant for Grinding {
    fn name(&self) -> &'static str {
        "grinding"
    }
    fn measured(&self) -> Named {
        ("force", "N")
    }
    fn command(&self) -> Named {
        ("position", "mm")
    }
    fn describe(&self) -> (&'static str, &'static str) {
        (
            "normal grinding force (Jenkins & Kurfess, eqs. 1-5)",
            "infeed slide position command (Jenkins & Kurfess, eq. 9)",
        )
    }
    fn channels(&self) -> Vec<Channel> {
        vec![
            Channel {
                name: "eta_factor",
                unit: "1",
                default: 1.0,
                what: "factor on the process pole eta (wheel dulling)",
            },
            Channel {
                name: "fr",
                unit: "N",
                default: self.p.fr_n,
                what: "reference force (an input `fr` reads it)",
            },
        ]
    }
    fn sensor(&self) -> SensorParams {
        self.p.sensor.clone()
    }
    fn reference(&self, sc: &Scenario, t: f64) -> f64 {
        sc.value("fr", t, self.p.fr_n)
    }
    fn command_at(&mut self, _t: f64, cmd: f64) {
        // Applied at once: eq. 9 has no computation delay.
        let q = self.p.encoder_mm;
        self.cmd = if q > 0.0 { (cmd / q).round() * q } else { cmd };
    }
    fn advance(&mut self, sc: &Scenario, t: f64, h: f64) {
        let (g, p) = (self.p.pos_gain_1_s, self.p.pos_pole_1_s);
        let eta = self.eta(sc, t);
        if self.decay.0 != h {
            self.decay = (h, zoh_first_order(g, p, h).a1);
        }
        // Position loop (eq. 1), exact under the held command: x → x_ss + (x − x_ss)·e^{−p·h}.
        let x_ss = g / p * self.cmd;
        let c = self.x - x_ss;
        let x1 = x_ss + c * self.decay.1;
        // Process (eq. 11): in contact, dδ/dt = dx/dt − η·δ with dx/dt = −p·c·e^{−p·t}, so
        // δ(h) = δ(0)·e^{−η·h} − p·c·(e^{−η·h} − e^{−p·h})/(p − η).
        let d0 = self.x - self.w;
        if d0 > 0.0 {
            let d1 = d0 * (-eta * h).exp() - p * c * exp_diff(eta, p, h);
            if d1 > 0.0 {
                self.w = x1 - d1;
            }
            // Else the wheel left the surface within the substep; the removal before that
            // (less than η·δ(0)·h, with δ(0) near zero) is neglected.
        }
        self.x = x1;
    }
    fn output(&self, _: &Scenario, _: f64) -> f64 {
        self.force_n()
    }
    fn columns(&self) -> Vec<&'static str> {
        vec!["xd_cmd_mm", "x_mm", "removed_mm", "eta_1_s", "force_n"]
    }
    fn record(&self, sc: &Scenario, t: f64, out: &mut Vec<f64>) {
        out.extend([self.cmd, self.x, self.w, self.eta(sc, t), self.force_n()]);
    }
    fn fresh(&self) -> Box<dyn Plant> {
        Box::new(Grinding::new(self.p.clone()))
    }
    fn params(&self) -> Vec<Param> {
        let p = &self.p;
        vec![
            Param {
                name: "eta_1_s",
                value: p.eta_1_s,
                range: (0.5, 10.0),
                why: "chosen: η = K_p·K_s·V/A ≪ 224 (Jenkins & Kurfess, eq. 11 and text below eq. 12), varying with wheel, material and contact area",
            },
            Param {
                name: "ks_n_mm",
                value: p.ks_n_mm,
                range: (163.0, 303.0),
                why: "chosen: ±30% on the 233 N/mm axis + sensor stiffness (Jenkins & Kurfess, text on Table 1) for wheel and workpiece contact compliance",
            },
            Param {
                name: "pos_pole_1_s",
                value: p.pos_pole_1_s,
                range: (200.0, 250.0),
                why: "Jenkins & Kurfess identify the pole at 224 (eq. 1) and also refers to it as s = -250 (text above Fig. 3); chosen down to 200 for other force levels",
            },
            Param {
                name: "pos_gain_1_s",
                value: p.pos_gain_1_s,
                range: (183.0, 223.0),
                why: "chosen: ±10% on the ARX-identified 203 (Jenkins & Kurfess, eq. 1), fitted at one force level",
            },
            Param {
                name: "sensor_gain",
                value: p.sensor.gain,
                range: (0.95, 1.05),
                why: "chosen: ±5% strain-gauge calibration error (Jenkins & Kurfess: response 'approximately unity')",
            },
        ]
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), String> {
        match name {
            "eta_1_s" => self.p.eta_1_s = value,
            "ks_n_mm" => self.p.ks_n_mm = value,
            "pos_pole_1_s" => self.p.pos_pole_1_s = value,
            "pos_gain_1_s" => self.p.pos_gain_1_s = value,
            "sensor_gain" => self.p.sensor.gain = value,
            _ => return Err(unknown_param(self, name)),
        }
        *self = Grinding::new(self.p.clone());
        Ok(())
    }
}

/// Time of the 20 → 25 N force step in the Table 1 scenarios (s).
pub const STEP_AT_S: f64 = 1.0;

/// The grinding scenarios. Every one starts at first contact (no force) with the commanded
/// force in the channel `fr` (N), which the controller's second input reads.
///
/// * `force-step`: the plunge-grinding benchmark of Table 1: "the force command input is
///   20 N with a step change to 25 N". The paper reaches the 20 N operating point with the
///   force loop itself (text on Fig. 7: the axis "is servoed downward from the force error ...
///   increasing the applied force to the desired set point"), so the loop is started at
///   20 N and given 1 s (about 50 time constants of the slow closed-loop mode, 19 ms) to
///   settle; the step follows, then the paper's 4.5 s record ("1,000 data points (4.5 s)").
/// * `step-25`: Fig. 7, the fixed-gain controller's response to a 25 N step command. The
///   initial air gap is not given; the run starts at contact, which makes it the loop's own
///   step response.
/// * `eta-varying`: `force-step` while η = K_p·K_s·V/A (eq. 11) changes over the pass: it
///   rises 4× (8 1/s) over 1.5 s (sharper grits, a softer zone: K_p up, or a shrinking
///   contact area A as high spots are ground away), drops at once to a quarter (0.5 1/s: a
///   harder zone, "harder materials with low material removal rates", text on Table 2), holds
///   there for 1.5 s and recovers over 1.5 s. Chosen: the paper gives no η history, only that "the grinding
///   process has been ... shown to be a continuously, time-varying system".
/// * `noise`: `force-step` with 0.5 N (1σ) sensor noise (chosen: about the 0.46 N force
///   resolution of the text on Fig. 7).
pub fn scenarios() -> Vec<Scenario> {
    let step = || Schedule::from_points(&[(0.0, 20.0), (STEP_AT_S, 20.0), (STEP_AT_S, 25.0)]);
    vec![
        Scenario::new("force-step", STEP_AT_S + 4.5, 0.0, &[("fr", step())]),
        Scenario::new("step-25", 1.0, 0.0, &[("fr", Schedule::constant(25.0))]),
        Scenario::new(
            "eta-varying",
            6.5,
            0.0,
            &[
                ("fr", step()),
                (
                    "eta_factor",
                    Schedule::from_points(&[
                        (1.5, 1.0),
                        (3.0, 4.0),
                        (3.0, 0.25),
                        (4.5, 0.25),
                        (6.0, 1.0),
                    ]),
                ),
            ],
        ),
        Scenario::new("noise", STEP_AT_S + 4.5, 0.5, &[("fr", step())]),
    ]
}

/// The scenario named `name`.
pub fn scenario_named(name: &str) -> Option<Scenario> {
    scenarios().into_iter().find(|s| s.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(p: &mut Grinding, sc: &Scenario, cmd: f64, t0: f64, dur: f64, h: f64) -> f64 {
        p.command_at(t0, cmd);
        let n = (dur / h).round() as usize;
        for k in 0..n {
            p.advance(sc, t0 + k as f64 * h, h);
        }
        t0 + n as f64 * h
    }

    /// η = 0: the process is the spring of eq. 2, and sampling the force every T under a
    /// held command reproduces 0.3543·K_s/(z − 0.6091) (eq. 7) at the paper's period,
    /// whatever the substep.
    #[test]
    fn spring_process_sampled_is_eq_7() {
        let sc = Scenario::new("x", 1.0, 0.0, &[("eta_factor", Schedule::constant(0.0))]);
        let t = PAPER_PERIOD_S;
        let d = zoh_first_order(203.0, 224.0, t);
        let mut p = Grinding::new(GrindingParams::default());
        let (mut f, mut tt) = (0.0, 0.0);
        for k in 0..30 {
            let u = 0.01 * (1.0 + (k % 7) as f64); // an arbitrary held command sequence
            tt = held(&mut p, &sc, u, tt, t, t / 20.0);
            f = d.a1 * f + d.b1 * 233.0 * u;
            assert!(
                (p.force_n() - f).abs() < 1e-9,
                "k = {k}: {} vs {f}",
                p.force_n()
            );
        }
    }

    /// η > 0: at a held position the force relaxes as e^{−η·t} once the position loop has
    /// settled (s/(s + η), eq. 11), and the removal keeps F_N = (K_s/η)·dw/dt.
    #[test]
    fn process_relaxes_at_eta() {
        let sc = Scenario::new("x", 1.0, 0.0, &[]);
        let mut p = Grinding::new(GrindingParams::default());
        let t = held(&mut p, &sc, 0.1, 0.0, 0.1, 1e-4);
        let (f0, w0) = (p.force_n(), p.removed_mm());
        let t1 = held(&mut p, &sc, 0.1, t, 0.25, 1e-3);
        let ratio = p.force_n() / f0;
        // x has settled to within e^{−224·0.1} of its target: the relaxation is e^{−2·0.25}.
        assert!((ratio - (-0.5f64).exp()).abs() < 1e-6, "{ratio}");
        // dw/dt = η·δ integrated: w1 − w0 = δ0·(1 − e^{−η·Δt}).
        let dw = p.removed_mm() - w0;
        assert!(
            (dw - f0 / 233.0 * (1.0 - (-0.5f64).exp())).abs() < 1e-7,
            "{dw}"
        );
        assert!(t1 > t);
    }

    /// Retracting above the surface gives no force and no removal; the encoder rounding
    /// holds the command on the 2 µm grid.
    #[test]
    fn contact_is_one_sided_and_encoder_rounds() {
        let sc = Scenario::new("x", 1.0, 0.0, &[]);
        let mut p = Grinding::new(GrindingParams {
            encoder_mm: PAPER_ENCODER_MM,
            ..GrindingParams::default()
        });
        held(&mut p, &sc, -0.05, 0.0, 0.2, 1e-4);
        assert_eq!(p.force_n(), 0.0);
        assert_eq!(p.removed_mm(), 0.0);
        p.command_at(0.2, 0.0123);
        assert!((p.cmd - 0.012).abs() < 1e-15, "{}", p.cmd);
    }

    #[test]
    fn params_round_trip_and_scenarios_validate() {
        let mut p = Grinding::new(GrindingParams::default());
        for q in p.params() {
            assert!(q.range.0 <= q.value && q.value <= q.range.1, "{q:?}");
            p.set_param(q.name, q.range.1).unwrap();
        }
        assert_eq!(p.p.eta_1_s, 10.0);
        assert!(p.set_param("depth", 1.0).unwrap_err().contains("eta_1_s"));
        for s in scenarios() {
            s.validate().unwrap();
            assert!(s.channels.contains_key("fr"), "{}", s.name);
            assert_eq!(scenario_named(&s.name).as_ref(), Some(&s));
        }
    }
}
