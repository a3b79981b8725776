//! The Bendix ACO system (Koren's survey, eqs. 1–3): a performance index of metal removal
//! rate against tool wear, maximised over milling feedrate and spindle speed under the
//! system's constraints (Koren's survey: "maximum and minimum spindle speed, maximum torque, maximum
//! feed, maximum temperature, and maximum vibration amplitude").
//!
//! **The index, in a form correct in its units.** The extraction prints eq. 3 as
//! `φ = MMR/C1 + (C1·t1 + C2·β)(TWR)/W0`. As printed, it adds in³/$ to $/min. The intended form
//! puts the whole cost rate in the denominator:
//!
//! `φ = MRR / [C1 + (C1·t1 + C2·β)·TWR/W0]`   (in³ per $)
//!
//! TWR/W0 is the rate of tool changes (1/min), since the tool is worn out when its flank wear
//! reaches W0. Each change costs the machine and operator's time C1·t1 plus, weighted by β, the
//! tool C2. The denominator is therefore a cost per minute, and φ is volume per cost. With
//! β = 1 it is the reciprocal of the cost per unit volume. With β = 0 it is
//! `MRR/(1 + t1·TWR/W0)/C1`, the production rate including tool changes, divided by a
//! constant. Those are the two limits Koren's survey states for β. The extraction is ambiguous in where
//! the fraction bar ends, and "MMR" is a typo for MRR (eq. 1).
//!
//! **The milling model** is ours, because Koren's survey gives no numbers. It uses the survey's inch
//! units. MRR = w·a·V (eq. 1). Tooth load f_t = V/(z·N). Specific cutting energy
//! u = U0·(f_t/F0)^−m, the size effect of F = K_s·a·f^u (Koren's survey, eq. 5) with m = 1 − u. The
//! torque is then `T = u·MRR/(2π·N)`, which at a fixed cut depends on the tooth load only.
//! Tool temperature is `θ = Θ0·(N/N0)^p·(f_t/F0)^q`. Vibration amplitude is taken as
//! proportional to the cutting force (a forced response away from resonance), so its
//! constraint is parallel to the torque's and only the tighter of the two can bind. Wear rate
//! is eq. 2 at steady torque (dT/dt = 0).
//!
//! **Where the optimum lies.** Write k = (C1·t1 + C2·β)/W0, so φ = MRR/(C1 + k·K1·MRR +
//! k·K2·θ).
//! - At a fixed speed, the derivative of φ in the feed has the sign of `C1 + k·K2·θ·(1 − q)`.
//!   For q < 1, φ rises with the feed.
//! - At a fixed tooth load (MRR ∝ N, θ = Θ′·N^p), it has the sign of `C1 + k·K2·θ·(1 − p)`.
//!   For p < 1 (measured temperatures grow slower than speed), φ rises with N.
//! - Along the temperature limit, the tooth load falls as N^(−p/q), so MRR ∝ N^(1 − p/q) while
//!   θ stays fixed. For q < p, φ falls with N along it.
//!
//! With q < p < 1 (here 0.2 < 0.5) the optimum is therefore the vertex of the torque limit (the
//! tooth load) and the temperature limit, whatever β, unless the top speed or feed comes first.
//! That is the survey's strategy, to keep φ "at the highest possible value without causing any
//! constraint violations". With q > p it would be the temperature limit at top speed. Only where
//! θ grows faster than N (p > 1) is there a speed inside the limits,
//! `N* = [C1/(k·K2·Θ′·(p − 1))]^(1/p)`. There a larger β, which weighs the tool's cost, gives a
//! lower speed. Both cases are tested against these hand-derived points.

use crate::nlp::{self, NlpError};
use std::f64::consts::PI;

/// The cost and wear constants of eqs. 2–3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Economics {
    /// C1: machine and operator cost per unit time ($/min).
    pub c1: f64,
    /// C2: tool and regrind cost per change ($).
    pub c2: f64,
    /// t1: tool changing time (min).
    pub t1: f64,
    /// W0: terminal allowable flank-wear width (in).
    pub w0: f64,
    /// K1: wear per volume removed (in/in³), eq. 2.
    pub k1: f64,
    /// K2: wear rate per degree of tool temperature (in/min/°F), eq. 2.
    pub k2: f64,
    /// K3: wear per unit of torque change (in/(lbf·in)), eq. 2.
    pub k3: f64,
}

/// Metal removal rate MRR = w·a·V (Koren's survey, eq. 1): width (in) × depth (in) × feedrate (in/min),
/// in in³/min.
pub fn mrr(width: f64, depth: f64, feedrate: f64) -> f64 {
    width * depth * feedrate
}

/// Tool wear rate TWR = K1·MRR + K2·θ + K3·dT/dt (Koren's survey, eq. 2), in in/min.
pub fn twr(e: &Economics, mrr: f64, temperature: f64, torque_rate: f64) -> f64 {
    e.k1 * mrr + e.k2 * temperature + e.k3 * torque_rate
}

/// The performance index φ = MRR/[C1 + (C1·t1 + C2·β)·TWR/W0] (Koren's survey, eq. 3, read as the module
/// docs say), in in³/$.
pub fn index(e: &Economics, mrr: f64, twr: f64, beta: f64) -> f64 {
    mrr / (e.c1 + (e.c1 * e.t1 + e.c2 * beta) * twr / e.w0)
}

/// The milling model and its constraints (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Milling {
    /// Width of cut w (in).
    pub width: f64,
    /// Depth of cut a (in).
    pub depth: f64,
    /// Teeth z.
    pub teeth: f64,
    /// Specific cutting energy U0 at tooth load F0 (lbf·in/in³).
    pub u0: f64,
    /// Reference tooth load F0 (in).
    pub f0: f64,
    /// Size-effect exponent m.
    pub m: f64,
    /// Temperature Θ0 (°F) at N0 and F0.
    pub theta0: f64,
    /// Reference speed N0 (rpm).
    pub n0: f64,
    /// Temperature's speed exponent p.
    pub p: f64,
    /// Temperature's tooth-load exponent q.
    pub q: f64,
    /// Vibration amplitude per unit torque (in/(lbf·in)).
    pub vib_per_torque: f64,
    /// Spindle speed range (rpm).
    pub speed: (f64, f64),
    /// Maximum feedrate (in/min).
    pub feed_max: f64,
    /// Maximum torque (lbf·in).
    pub torque_max: f64,
    /// Maximum tool temperature (°F).
    pub temp_max: f64,
    /// Maximum vibration amplitude (in).
    pub vib_max: f64,
    /// Lowest feedrate the optimiser considers (in/min).
    pub feed_min: f64,
}

/// The constraints by name, in the order [`Milling::constraints`] returns them.
pub const CONSTRAINT_NAMES: [&str; 3] = ["torque", "temperature", "vibration"];

impl Milling {
    /// Tooth load f_t = V/(z·N) (in).
    pub fn tooth_load(&self, v: f64, n: f64) -> f64 {
        v / (self.teeth * n)
    }

    /// Spindle torque T = u·MRR/(2π·N) (lbf·in), u = U0·(f_t/F0)^−m.
    pub fn torque(&self, v: f64, n: f64) -> f64 {
        let u = self.u0 * (self.tooth_load(v, n) / self.f0).powf(-self.m);
        u * mrr(self.width, self.depth, v) / (2.0 * PI * n)
    }

    /// Tool temperature θ = Θ0·(N/N0)^p·(f_t/F0)^q (°F).
    pub fn temperature(&self, v: f64, n: f64) -> f64 {
        self.theta0 * (n / self.n0).powf(self.p) * (self.tooth_load(v, n) / self.f0).powf(self.q)
    }

    /// The tooth load at which the torque is at its limit: T = U0·F0^m·w·a·z·f_t^(1−m)/(2π)
    /// solved for f_t (the torque depends on the tooth load only).
    pub fn torque_limited_tooth_load(&self) -> f64 {
        let c = self.u0 * self.f0.powf(self.m) * self.width * self.depth * self.teeth / (2.0 * PI);
        (self.torque_max / c).powf(1.0 / (1.0 - self.m))
    }

    /// Vibration amplitude (in), proportional to the torque.
    pub fn vibration(&self, v: f64, n: f64) -> f64 {
        self.vib_per_torque * self.torque(v, n)
    }

    /// The constraint values, each ≤ 0 when met, relative to its limit: T/T_max − 1,
    /// θ/θ_max − 1, A/A_max − 1. Speed and feed limits are the optimiser's bounds.
    pub fn constraints(&self, v: f64, n: f64) -> [f64; 3] {
        [
            self.torque(v, n) / self.torque_max - 1.0,
            self.temperature(v, n) / self.temp_max - 1.0,
            self.vibration(v, n) / self.vib_max - 1.0,
        ]
    }

    /// φ at steady cutting (dT/dt = 0).
    pub fn index(&self, e: &Economics, beta: f64, v: f64, n: f64) -> f64 {
        let r = mrr(self.width, self.depth, v);
        index(e, r, twr(e, r, self.temperature(v, n), 0.0), beta)
    }
}

/// An example shop: a 1 in, four-flute end mill taking a 0.5 in × 0.2 in cut in steel
/// (1 hp·min/in³ at 0.005 in/tooth), with limits that let both the torque and the
/// temperature bind (at about 0.0064 in/tooth and 2,200 rpm). The numbers are ours (Koren's survey gives
/// none).
pub const EXAMPLE: Milling = Milling {
    width: 0.5,
    depth: 0.2,
    teeth: 4.0,
    u0: 396_000.0,
    f0: 0.005,
    m: 0.3,
    theta0: 900.0,
    n0: 1000.0,
    p: 0.5,
    q: 0.2,
    vib_per_torque: 1e-5,
    speed: (200.0, 3000.0),
    feed_max: 120.0,
    torque_max: 150.0,
    temp_max: 1400.0,
    vib_max: 3e-3,
    feed_min: 0.5,
};

/// The example's economics: $1/min for machine and operator, $20 a tool, 2 min to change it,
/// 0.015 in of flank wear allowed.
pub const EXAMPLE_ECONOMICS: Economics = Economics {
    c1: 1.0,
    c2: 20.0,
    t1: 2.0,
    w0: 0.015,
    k1: 2e-5,
    k2: 2e-7,
    k3: 0.0,
};

/// The optimum of φ.
#[derive(Clone, Debug, PartialEq)]
pub struct Optimum {
    /// Feedrate V (in/min).
    pub feed: f64,
    /// Spindle speed N (rpm).
    pub speed: f64,
    /// φ there (in³/$).
    pub index: f64,
    /// The constraints and bounds within 1e-6 (relative) of their limits: "torque",
    /// "temperature", "vibration", "max speed", "min speed", "max feed".
    pub active: Vec<&'static str>,
}

/// Maximises φ over (V, N) within the speed and feed bounds and the three constraints,
/// starting from a light feed (a tenth of the feed bounds' sum) at mid speed. The gradients
/// are central differences of the closed forms (the model is smooth and every term is
/// positive on the box).
pub fn optimise(m: &Milling, e: &Economics, beta: f64) -> Result<Optimum, NlpError> {
    let bounds = [(m.feed_min, m.feed_max), m.speed];
    let diff = |g: &dyn Fn(f64, f64) -> f64, x: &[f64]| -> (f64, Vec<f64>) {
        let h = [1e-6 * x[0], 1e-6 * x[1]];
        (
            g(x[0], x[1]),
            vec![
                (g(x[0] + h[0], x[1]) - g(x[0] - h[0], x[1])) / (2.0 * h[0]),
                (g(x[0], x[1] + h[1]) - g(x[0], x[1] - h[1])) / (2.0 * h[1]),
            ],
        )
    };
    // SLSQP minimises: −φ, scaled by 100 so that its changes stay well above the solver's
    // tolerances (φ is of order 1 to 10 in³/$).
    let obj = |x: &[f64]| diff(&|v, n| -100.0 * m.index(e, beta, v, n), x);
    let c0 = |x: &[f64]| diff(&|v, n| m.constraints(v, n)[0], x);
    let c1 = |x: &[f64]| diff(&|v, n| m.constraints(v, n)[1], x);
    let c2 = |x: &[f64]| diff(&|v, n| m.constraints(v, n)[2], x);
    let start = [
        0.1 * (bounds[0].0 + bounds[0].1),
        0.5 * (bounds[1].0 + bounds[1].1),
    ];
    let o = nlp::minimise(&obj, &[&c0, &c1, &c2], &start, &bounds)?;
    let (v, n) = (o.x[0], o.x[1]);
    let g = m.constraints(v, n);
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
    let mut active = Vec::new();
    for (i, name) in CONSTRAINT_NAMES.iter().enumerate() {
        if g[i].abs() <= 1e-6 {
            active.push(*name);
        }
    }
    if near(n, m.speed.1) {
        active.push("max speed");
    }
    if near(n, m.speed.0) {
        active.push("min speed");
    }
    if near(v, m.feed_max) {
        active.push("max feed");
    }
    Ok(Optimum {
        feed: v,
        speed: n,
        index: m.index(e, beta, v, n),
        active,
    })
}
