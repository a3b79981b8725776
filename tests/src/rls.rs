//! Textbook recursive least squares with forgetting, in f64 with division, and a reproducible
//! regressor sequence: the independent reference of the division-free estimators
//! (tests/rls3.qloop, tests/rls4.qloop).

/// RLS of `N` parameters: `e = y − θᵀφ`, `θ ← θ + Pφ·e/(λ + φᵀPφ)`,
/// `P ← (P − PφφᵀP/(λ + φᵀPφ))/λ`.
pub struct Rls<const N: usize> {
    /// The estimate θ.
    pub theta: [f64; N],
    /// The covariance P.
    pub p: [[f64; N]; N],
    /// 1/λ.
    pub lambda_inv: f64,
}

impl<const N: usize> Rls<N> {
    /// θ = 0, P = p0·I.
    pub fn new(p0: f64, lambda_inv: f64) -> Self {
        Rls {
            theta: [0.0; N],
            p: std::array::from_fn(|i| std::array::from_fn(|j| if i == j { p0 } else { 0.0 })),
            lambda_inv,
        }
    }

    /// One update with regressor `phi` and measurement `y`. (Index loops on purpose: they
    /// read as the textbook's sums.)
    #[allow(clippy::needless_range_loop)]
    pub fn step(&mut self, phi: [f64; N], y: f64) {
        let lambda = 1.0 / self.lambda_inv;
        let pphi: Vec<f64> = (0..N)
            .map(|i| (0..N).map(|j| self.p[i][j] * phi[j]).sum())
            .collect();
        let den = lambda + (0..N).map(|i| phi[i] * pphi[i]).sum::<f64>();
        let e = y - (0..N).map(|i| self.theta[i] * phi[i]).sum::<f64>();
        for i in 0..N {
            self.theta[i] += pphi[i] / den * e;
        }
        for i in 0..N {
            for j in 0..N {
                self.p[i][j] = (self.p[i][j] - pphi[i] * pphi[j] / den) / lambda;
            }
        }
    }
}

/// `n` regressors in [-1, 1]^N from a xorshift generator started at `seed`: reproducible and
/// persistently exciting.
pub fn regressors<const N: usize>(seed: u64, n: usize) -> Vec<[f64; N]> {
    let mut s = seed;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..n).map(|_| std::array::from_fn(|_| next())).collect()
}

/// The leading principal minors of an `N × N` matrix, by cofactor expansion (f64): the
/// independent check of Sylvester's test in the estimators and of the `det` built-in.
pub fn minors<const N: usize>(p: &[[f64; N]; N]) -> [f64; N] {
    std::array::from_fn(|k| {
        let m: Vec<Vec<f64>> = p[..=k].iter().map(|r| r[..=k].to_vec()).collect();
        det(&m)
    })
}

/// The determinant of a square matrix by cofactor expansion along the first row.
pub fn det(m: &[Vec<f64>]) -> f64 {
    if m.len() == 1 {
        return m[0][0];
    }
    (0..m.len())
        .map(|c| {
            let sub: Vec<Vec<f64>> = m[1..]
                .iter()
                .map(|r| {
                    r.iter()
                        .enumerate()
                        .filter(|(j, _)| *j != c)
                        .map(|(_, x)| *x)
                        .collect()
                })
                .collect();
            let sign = if c % 2 == 0 { 1.0 } else { -1.0 };
            sign * m[0][c] * det(&sub)
        })
        .sum()
}
