//! Exact zero-order-hold (ZOH) discretisation of first-order linear systems, for plants whose
//! linear parts are advanced in closed form under a held input instead of by RK4.
//!
//! For `G(s) = b/(s + a)` driven through a ZOH of period `T` (input held constant over each
//! period), `G(z) = (1 − z^-1)·Z{L^-1[G(s)/s]}` (Jenkins & Kurfess, eq. 6) is
//!
//! ```text
//!     G(z) = b1/(z − a1),   a1 = e^{−aT},   b1 = (b/a)·(1 − a1)
//! ```
//!
//! i.e. `y(k+1) = a1·y(k) + b1·u(k)`, exact at the sample instants for any `T` (not an
//! approximation in `T`): between samples the state relaxes exponentially toward `(b/a)·u`.
//! For `a → 0` (an integrator `b/s`) `b1 → b·T`; [`zoh_first_order`] evaluates
//! `(1 − e^{−aT})/a` through `exp_m1`, so it stays accurate there. At T = 2.214 ms the PMAC
//! position loop 203/(s + 224) (Jenkins & Kurfess, eq. 1) becomes 0.3543/(z − 0.6090); at the paper's
//! unrounded 5 × 442.7 µs = 2.2135 ms it is the 0.3543/(z − 0.6091) of Jenkins & Kurfess, eq. 7.

/// A discrete first-order system `b1/(z − a1)`: `y(k+1) = a1·y(k) + b1·u(k)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstOrder {
    /// Numerator `b1` (Jenkins & Kurfess, eq. 7: 0.3543 per unit of `K_s`).
    pub b1: f64,
    /// Pole `a1 = e^{−aT}` (Jenkins & Kurfess, eq. 7: 0.6091).
    pub a1: f64,
}

impl FirstOrder {
    /// One period: the next output from the output `y` and the held input `u`.
    pub fn step(&self, y: f64, u: f64) -> f64 {
        self.a1 * y + self.b1 * u
    }

    /// The DC gain `b1/(1 − a1)` (equal to the continuous `b/a`).
    pub fn dc_gain(&self) -> f64 {
        self.b1 / (1.0 - self.a1)
    }
}

/// `(1 − e^{−x})/x`, continuous at 0 (where it is 1).
fn phi(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0 - 0.5 * x
    } else {
        -(-x).exp_m1() / x
    }
}

/// The exact ZOH equivalent of `b/(s + a)` at period `t` (Jenkins & Kurfess, eq. 6 applied to a first-order
/// system): `a1 = e^{−a·t}`, `b1 = (b/a)·(1 − a1)` (= `b·t` for `a = 0`).
pub fn zoh_first_order(b: f64, a: f64, t: f64) -> FirstOrder {
    FirstOrder {
        a1: (-a * t).exp(),
        b1: b * t * phi(a * t),
    }
}

/// `(e^{−p·t} − e^{−q·t})/(q − p)`, continuous at `p = q` (where it is `t·e^{−p·t}`): the
/// response at `t` of the cascade `1/(s + p) · 1/(s + q)` to a unit impulse. The grinding
/// plant uses it to advance the process stage `s/(s + η)` behind the position lag `1/(s + 224)`
/// exactly (Jenkins & Kurfess, eq. 12).
pub fn exp_diff(p: f64, q: f64, t: f64) -> f64 {
    // (e^{−pt} − e^{−qt})/(q − p) = e^{−pt}·(1 − e^{−(q−p)t})/(q − p) = e^{−pt}·t·φ((q−p)t).
    (-p * t).exp() * t * phi((q - p) * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jenkins & Kurfess, eq. 7: the ZOH equivalent of 203/(s + 224) at the force-loop period is
    /// 0.3543/(z − 0.6091). The paper's period is 5 servo cycles of the measured 442.7 µs
    /// (text above eq. 6) = 2.2135 ms, which it rounds to "2.214-ms"; at 2.2135 ms both
    /// coefficients round to the paper's 4 digits. At exactly 2.214 ms the pole is 0.60900:
    /// 0.6090, one unit in the 4th digit off, which shows the paper used the unrounded period.
    #[test]
    fn position_loop_at_the_force_period_is_eq_7() {
        let g = zoh_first_order(203.0, 224.0, 5.0 * 442.7e-6);
        assert_eq!(format!("{:.4}", g.b1), "0.3543", "b1 = {}", g.b1);
        assert_eq!(format!("{:.4}", g.a1), "0.6091", "a1 = {}", g.a1);
        let g = zoh_first_order(203.0, 224.0, 2.214e-3);
        assert_eq!(format!("{:.4}", g.b1), "0.3543", "b1 = {}", g.b1);
        assert_eq!(format!("{:.4}", g.a1), "0.6090", "a1 = {}", g.a1);
        // The DC gain is preserved: 203/224.
        assert!((g.dc_gain() - 203.0 / 224.0).abs() < 1e-15);
    }

    /// The difference equation reproduces the continuous step response at the samples.
    #[test]
    fn step_response_is_exact_at_the_samples() {
        let (b, a, t) = (3.0, 7.0, 0.05);
        let g = zoh_first_order(b, a, t);
        let mut y = 0.0;
        for k in 1..=40 {
            y = g.step(y, 1.0);
            let exact = b / a * (1.0 - (-a * t * k as f64).exp());
            assert!((y - exact).abs() < 1e-14, "k = {k}: {y} vs {exact}");
        }
    }

    /// a → 0 is the integrator b/s: b1 = b·T, a1 = 1, smoothly.
    #[test]
    fn integrator_limit() {
        let g = zoh_first_order(2.0, 0.0, 0.1);
        assert_eq!((g.a1, g.b1), (1.0, 0.2));
        let g = zoh_first_order(2.0, 1e-9, 0.1);
        assert!((g.b1 - 0.2).abs() < 1e-10);
    }

    /// exp_diff against its closed form away from and at p = q.
    #[test]
    fn exp_diff_closed_form() {
        let (p, q, t): (f64, f64, f64) = (224.0, 2.0, 0.003);
        let direct = ((-p * t).exp() - (-q * t).exp()) / (q - p);
        assert!((exp_diff(p, q, t) - direct).abs() < 1e-15);
        assert!((exp_diff(5.0, 5.0, 0.2) - 0.2 * (-1f64).exp()).abs() < 1e-15);
        assert!((exp_diff(5.0, 5.0 + 1e-10, 0.2) - 0.2 * (-1f64).exp()).abs() < 1e-10);
    }
}
