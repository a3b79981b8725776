//! Discretisation of a continuous transfer function under a fractional-order hold (β-FROH),
//! Rubio & De la Sen, eqs. 4–5.
//!
//! **The hold.** Between the sample instants `kT` and `(k+1)T` a β-FROH drives the plant with
//! the last sample extrapolated along the last difference, scaled by the correcting gain β:
//!
//! ```text
//!     u(t) = u_k + β·(u_k − u_{k−1})·(t − kT)/T,        kT ≤ t < (k+1)T
//! ```
//!
//! β = 0 is the zero-order hold (ZOH), β = 1 the causal, extrapolating first-order hold
//! (FOH) that Rubio & De la Sen, Sec. II.B means. Its impulse response is `1 + βt/T` on `[0, T)` and
//! `−β(t − T)/T` on `[T, 2T)`, so its transfer function is
//!
//! ```text
//!     g_β(s) = (1 − β·e^{−Ts})·(1 − e^{−Ts})/s + β·(1 − e^{−Ts})²/(T·s²)
//! ```
//!
//! which is what the damaged eq. 4 of Rubio & De la Sen reads as (`g(s) = [1 − β e^{−Ts} + β(1 − e^{−Ts})/(Ts)]
//! (1 − e^{−Ts})/s`; the extraction kept only fragments of it: derived from the hold above).
//! The z-transform of `g_β(s)·G(s)` is then a combination of two ZOH discretisations,
//! Rubio & De la Sen, eq. 5 (also damaged; derived the same way):
//!
//! ```text
//!     H_β(z) = ((z − β)/z)·Z[h₀(s)G(s)] + β(z − 1)/(T·z)·Z[h₀(s)G(s)/s],   h₀(s) = (1 − e^{−Ts})/s
//! ```
//!
//! For β ≠ 0 it has one pole more than the ZOH model, at the origin ("a fractional order hold
//! with β ≠ 0 always adds a pole at the origin", Rubio & De la Sen after eq. 5); at β = 0 the pole cancels
//! and `H_0` is the ZOH model.
//!
//! **How it is computed here.** Not from eq. 5's polynomials, but from the hold itself, in
//! state space, which needs no polynomial division and no pole at z = 1: with `G` in
//! controllable canonical form `(A, B, C, D)`, the state at the next sample is
//!
//! ```text
//!     x_{k+1} = Φ·x_k + Γ₀·u_k + β·Γ₁·(u_k − u_{k−1}),
//!     Φ = e^{AT},  Γ₀ = ∫₀ᵀ e^{Aσ} dσ·B,  Γ₁ = ∫₀ᵀ e^{A(T−t)}·B·t/T dt
//! ```
//!
//! and all three are blocks of one matrix exponential (Van Loan's method):
//! `exp([[A·T, B·T, 0], [0, 0, 1], [0, 0, 0]]) = [[Φ, Γ₀, Γ₁], [0, 1, 1], [0, 0, 1]]`.
//! With `u_{k−1}` as one more state this is a discrete state-space model of order n + 1
//! (order n for β = 0), whose transfer function is read off its characteristic polynomial
//! (Faddeev–LeVerrier) and its Markov parameters `D, CΓ, CΦΓ, …`.
//!
//! **Against scipy.** `scipy.signal.cont2discrete(..., method="foh")` is the *triangle* hold
//! (non-causal, impulse response `1 − |t|/T` on `[−T, T]`), not Rubio & De la Sen's FOH. The two are
//! related exactly: the β-FROH's impulse response is the ZOH pulse, plus β times the
//! triangle delayed one period, minus β times the pulse delayed one period, so
//! `H_β(z) = (1 − βz⁻¹)·H_zoh(z) + β·z⁻¹·H_tri(z)`. The test `froh_matches_scipy` checks
//! every β of the paper's set against that identity evaluated by scipy
//! (`plant/tests/oracle/froh_scipy.py`).

use nalgebra::DMatrix;
use std::fmt;

/// The seven correcting gains of Rubio & De la Sen, Sec. V: β ∈ {−0.5, −0.3, 0, 0.3, 0.5, 0.8, 1}.
pub const PAPER_BETAS: [f64; 7] = [-0.5, -0.3, 0.0, 0.3, 0.5, 0.8, 1.0];

/// A continuous transfer function `num(s)/den(s)`, coefficients in descending powers of s.
#[derive(Clone, Debug, PartialEq)]
pub struct ContinuousTf {
    /// Numerator coefficients, highest power first.
    pub num: Vec<f64>,
    /// Denominator coefficients, highest power first.
    pub den: Vec<f64>,
}

impl ContinuousTf {
    /// `num(s)/den(s)`.
    pub fn new(num: &[f64], den: &[f64]) -> ContinuousTf {
        ContinuousTf {
            num: num.to_vec(),
            den: den.to_vec(),
        }
    }

    /// The initial estimated model of Rubio & De la Sen, Sec. V: `(−3s + 150)/(s² + 20s + 550)`.
    pub fn paper_initial_model() -> ContinuousTf {
        ContinuousTf::new(&[-3.0, 150.0], &[1.0, 20.0, 550.0])
    }

    /// The reference model of Rubio & De la Sen, Sec. V: `98.62/(s² + 15.89s + 98.62)` (ζ = 0.75,
    /// ω_n = 9.93 rad/s; Rubio & De la Sen, Sec. II.C).
    pub fn paper_reference_model() -> ContinuousTf {
        ContinuousTf::new(&[98.62], &[1.0, 15.89, 98.62])
    }
}

/// A discrete transfer function `num(z)/den(z)` with a monic denominator; both lists have
/// the model's order + 1 coefficients, highest power of z first. Read in powers of `z⁻¹`,
/// the same lists are `(b₀ + b₁z⁻¹ + … + b_m z⁻ᵐ)/(1 + a₁z⁻¹ + … + a_m z⁻ᵐ)`, i.e. the
/// difference equation `y_k = −a₁y_{k−1} − … − a_m y_{k−m} + b₀u_k + … + b_m u_{k−m}`.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscreteTf {
    /// Numerator `b₀ … b_m`.
    pub num: Vec<f64>,
    /// Denominator `1, a₁ … a_m`.
    pub den: Vec<f64>,
    /// Sampling period T in seconds.
    pub period: f64,
}

impl DiscreteTf {
    /// The model order m.
    pub fn order(&self) -> usize {
        self.den.len() - 1
    }

    /// The first `len` samples of the impulse response (`h_0 = b₀`).
    pub fn impulse(&self, len: usize) -> Vec<f64> {
        let m = self.order();
        let mut h = Vec::with_capacity(len);
        for k in 0..len {
            let mut v = if k <= m { self.num[k] } else { 0.0 };
            for i in 1..=m.min(k) {
                v -= self.den[i] * h[k - i];
            }
            h.push(v);
        }
        h
    }

    /// The DC gain `num(1)/den(1)`.
    pub fn dc_gain(&self) -> f64 {
        self.num.iter().sum::<f64>() / self.den.iter().sum::<f64>()
    }
}

/// Why a transfer function could not be discretised.
#[derive(Clone, Debug, PartialEq)]
pub enum C2dError {
    /// The denominator is empty, zero, or of degree 0.
    Denominator(String),
    /// More zeros than poles: no hold makes an improper system causal.
    Improper {
        /// Degree of the numerator.
        num: usize,
        /// Degree of the denominator.
        den: usize,
    },
    /// A coefficient, the period or β is not finite, or the period is not positive.
    Value(String),
    /// β outside [−1, 1], where Rubio & De la Sen, Sec. II.B defines the FROH.
    Beta(f64),
}

impl fmt::Display for C2dError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            C2dError::Denominator(why) => write!(
                f,
                "the denominator {why}: give its coefficients highest power first, e.g. \
                 `--den 1,20,550` for s² + 20s + 550"
            ),
            C2dError::Improper { num, den } => write!(
                f,
                "the numerator has degree {num} but the denominator only {den}: the transfer \
                 function is improper (more zeros than poles) and has no discrete equivalent"
            ),
            C2dError::Value(why) => write!(f, "{why}"),
            C2dError::Beta(b) => write!(
                f,
                "β = {b} is outside [−1, 1], where Rubio & De la Sen, Sec. II.B defines the fractional-order \
                 hold (and Rubio & De la Sen, Sec. V: β < −0.6 already gives an unstable discrete pole)"
            ),
        }
    }
}

impl std::error::Error for C2dError {}

/// The zero-order-hold equivalent of `g` at period `period` (β-FROH with β = 0).
pub fn zoh(g: &ContinuousTf, period: f64) -> Result<DiscreteTf, C2dError> {
    froh(g, period, 0.0)
}

/// The β-FROH equivalent of `g` at period `period` (Rubio & De la Sen, eqs. 4–5; module docs): order n for
/// β = 0 (the ZOH model), n + 1 otherwise (the hold's pole at the origin).
pub fn froh(g: &ContinuousTf, period: f64, beta: f64) -> Result<DiscreteTf, C2dError> {
    if !beta.is_finite() {
        return Err(C2dError::Value(format!("β must be a number, not {beta}")));
    }
    if !(-1.0..=1.0).contains(&beta) {
        return Err(C2dError::Beta(beta));
    }
    let hm = hold_matrices(g, period)?;
    let n = hm.phi.nrows();
    let (c, d) = (hm.c.clone(), hm.d);
    // The discrete model: state x (n), plus u_{k−1} when β ≠ 0.
    let dim = if beta == 0.0 { n } else { n + 1 };
    let mut phi = DMatrix::<f64>::zeros(dim, dim);
    let mut gam = vec![0.0; dim];
    for i in 0..n {
        for j in 0..n {
            phi[(i, j)] = hm.phi[(i, j)];
        }
        gam[i] = hm.gamma0[i] + beta * hm.gamma1[i];
        if dim > n {
            phi[(i, n)] = -beta * hm.gamma1[i];
        }
    }
    if dim > n {
        gam[n] = 1.0;
    }
    let mut cd = c.clone();
    cd.resize(dim, 0.0);
    // det(zI − Φ_β) = z·det(zI − Φ) for β ≠ 0 (the u_{k−1} row is zero): the hold's pole
    // at the origin is put in exactly, not left to rounding.
    let mut den = charpoly(&phi.view((0, 0), (n, n)).into_owned());
    den.resize(dim + 1, 0.0);
    // Markov parameters h_0 = D, h_k = C Φ^{k−1} Γ.
    let mut h = vec![d];
    let mut v = DMatrix::from_column_slice(dim, 1, &gam);
    for _ in 0..dim {
        h.push((0..dim).map(|i| cd[i] * v[(i, 0)]).sum());
        v = &phi * v;
    }
    let num = (0..=dim)
        .map(|j| (0..=j).map(|i| den[i] * h[j - i]).sum())
        .collect();
    let tf = DiscreteTf { num, den, period };
    if tf.num.iter().chain(&tf.den).all(|x| x.is_finite()) {
        Ok(tf)
    } else {
        Err(C2dError::Value(format!(
            "the discrete model overflows at T = {period} s: the plant's poles times T are too \
             large for f64; choose a shorter period"
        )))
    }
}

/// The exact sampled model of `g` under a β-FROH, for any β (module docs): with `G` in
/// controllable canonical form `(A, B, C, D)`,
/// `x_{k+1} = Φ·x_k + Γ₀·u_k + β·Γ₁·(u_k − u_{k−1})` and `y_k = C·x_k + D·u_k`.
#[derive(Clone, Debug)]
pub struct HoldMatrices {
    /// `Φ = e^{AT}`.
    pub phi: DMatrix<f64>,
    /// `Γ₀ = ∫₀ᵀ e^{Aσ} dσ·B`.
    pub gamma0: Vec<f64>,
    /// `Γ₁ = ∫₀ᵀ e^{A(T−t)}·B·t/T dt`.
    pub gamma1: Vec<f64>,
    /// `C`.
    pub c: Vec<f64>,
    /// `D`.
    pub d: f64,
}

impl HoldMatrices {
    /// The next state from `x` under the hold of `u` (this sample) after `u_prev`.
    pub fn step(&self, x: &[f64], u: f64, u_prev: f64, beta: f64) -> Vec<f64> {
        let n = x.len();
        (0..n)
            .map(|i| {
                (0..n).map(|j| self.phi[(i, j)] * x[j]).sum::<f64>()
                    + self.gamma0[i] * u
                    + beta * self.gamma1[i] * (u - u_prev)
            })
            .collect()
    }

    /// The output at a sample instant, `C·x + D·u`.
    pub fn output(&self, x: &[f64], u: f64) -> f64 {
        self.c.iter().zip(x).map(|(c, x)| c * x).sum::<f64>() + self.d * u
    }
}

/// Φ, Γ₀ and Γ₁ of `g` at `period`, from one matrix exponential (Van Loan; module docs).
pub fn hold_matrices(g: &ContinuousTf, period: f64) -> Result<HoldMatrices, C2dError> {
    if !(period.is_finite() && period > 0.0) {
        return Err(C2dError::Value(format!(
            "the period must be a positive number of seconds, not {period}"
        )));
    }
    let (a, b, c, d) = canonical(g)?;
    let n = a.len();
    let mut m = DMatrix::<f64>::zeros(n + 2, n + 2);
    for i in 0..n {
        for j in 0..n {
            m[(i, j)] = a[i][j] * period;
        }
        m[(i, n)] = b[i] * period;
    }
    m[(n, n + 1)] = 1.0;
    let e = m.exp();
    Ok(HoldMatrices {
        phi: e.view((0, 0), (n, n)).into_owned(),
        gamma0: (0..n).map(|i| e[(i, n)]).collect(),
        gamma1: (0..n).map(|i| e[(i, n + 1)]).collect(),
        c,
        d,
    })
}

/// Controllable canonical form `(A, B, C, D)` of `g`, with the denominator made monic.
#[allow(clippy::type_complexity)]
fn canonical(g: &ContinuousTf) -> Result<(Vec<Vec<f64>>, Vec<f64>, Vec<f64>, f64), C2dError> {
    if g.num.iter().chain(&g.den).any(|x| !x.is_finite()) {
        return Err(C2dError::Value(
            "every coefficient must be a finite number".into(),
        ));
    }
    let den: Vec<f64> = g.den.iter().copied().skip_while(|&x| x == 0.0).collect();
    let num: Vec<f64> = g.num.iter().copied().skip_while(|&x| x == 0.0).collect();
    if den.is_empty() {
        return Err(C2dError::Denominator("is zero".into()));
    }
    let n = den.len() - 1;
    if n == 0 {
        return Err(C2dError::Denominator(
            "is a constant: a static gain needs no discretisation".into(),
        ));
    }
    if num.len() > den.len() {
        return Err(C2dError::Improper {
            num: num.len() - 1,
            den: n,
        });
    }
    let lead = den[0];
    let a_s: Vec<f64> = den.iter().map(|x| x / lead).collect();
    let mut b_s = vec![0.0; den.len() - num.len()];
    b_s.extend(num.iter().map(|x| x / lead));
    let d = b_s[0];
    let c: Vec<f64> = (1..=n).map(|i| b_s[i] - d * a_s[i]).collect();
    let mut a = vec![vec![0.0; n]; n];
    for j in 0..n {
        a[0][j] = -a_s[j + 1];
    }
    for i in 1..n {
        a[i][i - 1] = 1.0;
    }
    let mut b = vec![0.0; n];
    b[0] = 1.0;
    Ok((a, b, c, d))
}

/// The characteristic polynomial `det(zI − M)`, highest power first (Faddeev–LeVerrier).
fn charpoly(m: &DMatrix<f64>) -> Vec<f64> {
    let n = m.nrows();
    let mut coef = vec![1.0];
    let mut mk = DMatrix::<f64>::zeros(n, n);
    for k in 1..=n {
        mk = m * &mk + DMatrix::identity(n, n) * coef[k - 1];
        let c = -(m * &mk).trace() / k as f64;
        coef.push(c);
    }
    coef
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discrete::zoh_first_order;

    #[test]
    fn zoh_of_a_first_order_lag_is_its_closed_form() {
        let t = 0.0839;
        let g = ContinuousTf::new(&[3.0], &[2.0, 5.0]); // 1.5/(s + 2.5)
        let h = zoh(&g, t).expect("discretises");
        let f = zoh_first_order(1.5, 2.5, t);
        assert_eq!(h.order(), 1);
        assert!((h.den[1] + f.a1).abs() < 1e-15, "{h:?} {f:?}");
        assert!((h.num[1] - f.b1).abs() < 1e-15, "{h:?} {f:?}");
        assert_eq!(h.num[0], 0.0);
    }

    #[test]
    fn the_hold_adds_a_pole_at_the_origin_and_keeps_the_dc_gain() {
        let g = ContinuousTf::paper_initial_model();
        let t = 0.0839;
        let z0 = zoh(&g, t).expect("zoh");
        for beta in PAPER_BETAS {
            let h = froh(&g, t, beta).expect("froh");
            assert_eq!(h.order(), if beta == 0.0 { 2 } else { 3 });
            if beta != 0.0 {
                assert_eq!(h.den[3], 0.0, "pole at 0: {h:?}");
                // The other poles are the ZOH model's: e^{pT}.
                for (x, y) in h.den[..3].iter().zip(&z0.den) {
                    assert!((x - y).abs() < 1e-12, "β = {beta}: {h:?} vs {z0:?}");
                }
            }
            // The hold passes a constant unchanged: DC gain 150/550.
            assert!((h.dc_gain() - 150.0 / 550.0).abs() < 1e-12, "β = {beta}");
        }
    }

    #[test]
    fn bad_input_is_refused_with_a_reason() {
        let g = ContinuousTf::paper_initial_model();
        assert!(matches!(froh(&g, 0.0, 0.0), Err(C2dError::Value(_))));
        assert!(matches!(froh(&g, 0.1, 1.5), Err(C2dError::Beta(_))));
        assert!(matches!(froh(&g, 0.1, f64::NAN), Err(C2dError::Value(_))));
        let improper = ContinuousTf::new(&[1.0, 0.0, 0.0], &[1.0, 1.0]);
        assert!(matches!(
            zoh(&improper, 0.1),
            Err(C2dError::Improper { num: 2, den: 1 })
        ));
        let flat = ContinuousTf::new(&[1.0], &[0.0, 2.0]);
        assert!(matches!(zoh(&flat, 0.1), Err(C2dError::Denominator(_))));
        let text = froh(&g, 0.1, -2.0).unwrap_err().to_string();
        assert!(text.contains("outside [−1, 1]"), "{text}");
    }
}
