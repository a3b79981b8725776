//! Rigorous bounds on a compile-time function and its first two derivatives over an interval:
//! second-order forward differentiation in interval arithmetic with outward rounding.
//!
//! A table (`issue 16`, item 3) replaces `f` by its linear interpolant on a grid of step `h`;
//! on a segment the interpolation error is at most `h²/8 · max |f''|` (the remainder of
//! linear interpolation, `f(x) − L(x) = f''(ξ)/2 · (x − x₀)(x − x₁)`). This module bounds
//! `max |f''|` over each segment by evaluating the generator expression on dual numbers whose
//! parts are intervals: value, first and second derivative. Every interval operation rounds
//! its ends outward by one ulp (`next_down`/`next_up`), which covers the rounding of the f64
//! operation (correctly rounded for `+ − × ÷ sqrt`, within an ulp or two for the platform's
//! `exp`, `ln`, `powf`: the ends of those are widened by four ulps), so the true values lie in
//! the intervals.

/// A closed interval of reals, `lo ≤ hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct I {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

/// Why an expression could not be bounded over the interval.
#[derive(Clone, Debug, PartialEq)]
pub enum Trouble {
    /// A division by an interval containing 0, `ln`/`powf` of a non-positive or `sqrt` of a
    /// negative interval: the function is not smooth (or not defined) there.
    Domain(&'static str),
    /// A result is not finite.
    Overflow,
}

fn down(v: f64, ulps: u32) -> f64 {
    (0..ulps).fold(v, |x, _| x.next_down())
}

fn up(v: f64, ulps: u32) -> f64 {
    (0..ulps).fold(v, |x, _| x.next_up())
}

impl I {
    /// The point `v`.
    pub fn point(v: f64) -> I {
        I { lo: v, hi: v }
    }

    /// `[lo, hi]`.
    pub fn new(lo: f64, hi: f64) -> I {
        I { lo, hi }
    }

    /// The hull of candidate ends, rounded outward by `ulps`.
    fn hull(c: &[f64], ulps: u32) -> Result<I, Trouble> {
        let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(Trouble::Overflow);
        }
        Ok(I {
            lo: down(lo, ulps),
            hi: up(hi, ulps),
        })
    }

    /// The largest absolute value in the interval.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    fn add(self, o: I) -> Result<I, Trouble> {
        I::hull(&[self.lo + o.lo, self.hi + o.hi], 1)
    }

    fn neg(self) -> I {
        I {
            lo: -self.hi,
            hi: -self.lo,
        }
    }

    fn sub(self, o: I) -> Result<I, Trouble> {
        self.add(o.neg())
    }

    fn mul(self, o: I) -> Result<I, Trouble> {
        I::hull(
            &[
                self.lo * o.lo,
                self.lo * o.hi,
                self.hi * o.lo,
                self.hi * o.hi,
            ],
            1,
        )
    }

    fn recip(self) -> Result<I, Trouble> {
        if self.lo <= 0.0 && self.hi >= 0.0 {
            return Err(Trouble::Domain("a division by an interval containing 0"));
        }
        I::hull(&[1.0 / self.lo, 1.0 / self.hi], 1)
    }

    fn sqr(self) -> Result<I, Trouble> {
        if self.lo >= 0.0 || self.hi <= 0.0 {
            let (a, b) = (self.lo * self.lo, self.hi * self.hi);
            I::hull(&[a, b], 1)
        } else {
            I::hull(&[0.0, self.lo * self.lo, self.hi * self.hi], 1)
        }
    }

    fn exp(self) -> Result<I, Trouble> {
        I::hull(&[self.lo.exp(), self.hi.exp()], 4).map(|i| I {
            lo: i.lo.max(0.0),
            hi: i.hi,
        })
    }

    fn ln(self) -> Result<I, Trouble> {
        if self.lo <= 0.0 {
            return Err(Trouble::Domain("`ln` of an interval reaching 0 or below"));
        }
        I::hull(&[self.lo.ln(), self.hi.ln()], 4)
    }

    fn sqrt(self) -> Result<I, Trouble> {
        if self.lo < 0.0 {
            return Err(Trouble::Domain("`sqrt` of an interval reaching below 0"));
        }
        I::hull(&[self.lo.sqrt(), self.hi.sqrt()], 1).map(|i| I {
            lo: i.lo.max(0.0),
            hi: i.hi,
        })
    }

    /// `x^c` for a constant `c` over `x > 0` (monotone in `x`).
    fn powc(self, c: f64) -> Result<I, Trouble> {
        if self.lo <= 0.0 {
            return Err(Trouble::Domain("`powf` of an interval reaching 0 or below"));
        }
        I::hull(&[self.lo.powf(c), self.hi.powf(c)], 4)
    }

    fn scale(self, c: f64) -> Result<I, Trouble> {
        self.mul(I::point(c))
    }
}

/// A value with its first and second derivatives with respect to the table's variable, each
/// an interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual {
    /// The value.
    pub v: I,
    /// The first derivative.
    pub d1: I,
    /// The second derivative.
    pub d2: I,
}

const ZERO: I = I { lo: 0.0, hi: 0.0 };

impl Dual {
    /// A constant.
    pub fn constant(c: f64) -> Dual {
        Dual {
            v: I::point(c),
            d1: ZERO,
            d2: ZERO,
        }
    }

    /// The variable over `x`.
    pub fn variable(x: I) -> Dual {
        Dual {
            v: x,
            d1: I::point(1.0),
            d2: ZERO,
        }
    }

    /// `a + b`.
    pub fn add(self, b: Dual) -> Result<Dual, Trouble> {
        Ok(Dual {
            v: self.v.add(b.v)?,
            d1: self.d1.add(b.d1)?,
            d2: self.d2.add(b.d2)?,
        })
    }

    /// `-a`.
    pub fn neg(self) -> Dual {
        Dual {
            v: self.v.neg(),
            d1: self.d1.neg(),
            d2: self.d2.neg(),
        }
    }

    /// `a − b`.
    pub fn sub(self, b: Dual) -> Result<Dual, Trouble> {
        self.add(b.neg())
    }

    /// `a·b`: `(uv)'' = u''v + 2u'v' + uv''`.
    pub fn mul(self, b: Dual) -> Result<Dual, Trouble> {
        let (u, v) = (self, b);
        Ok(Dual {
            v: u.v.mul(v.v)?,
            d1: u.d1.mul(v.v)?.add(u.v.mul(v.d1)?)?,
            d2: u
                .d2
                .mul(v.v)?
                .add(u.d1.mul(v.d1)?.scale(2.0)?)?
                .add(u.v.mul(v.d2)?)?,
        })
    }

    /// `1/a`: `w = 1/u`, `w' = −u'/u²`, `w'' = (2u'² − u·u'')/u³`.
    pub fn recip(self) -> Result<Dual, Trouble> {
        let u = self;
        let w = u.v.recip()?;
        let w2 = w.sqr()?;
        Ok(Dual {
            v: w,
            d1: u.d1.mul(w2)?.neg(),
            d2: u
                .d1
                .sqr()?
                .scale(2.0)?
                .mul(w2.mul(w)?)?
                .sub(u.d2.mul(w2)?)?,
        })
    }

    /// `a/b`.
    pub fn div(self, b: Dual) -> Result<Dual, Trouble> {
        self.mul(b.recip()?)
    }

    /// `exp(a)`: `e' = e·u'`, `e'' = e·(u'' + u'²)`.
    pub fn exp(self) -> Result<Dual, Trouble> {
        let e = self.v.exp()?;
        Ok(Dual {
            v: e,
            d1: e.mul(self.d1)?,
            d2: e.mul(self.d2.add(self.d1.sqr()?)?)?,
        })
    }

    /// `ln(a)`: `l' = u'/u`, `l'' = u''/u − (u'/u)²`.
    pub fn ln(self) -> Result<Dual, Trouble> {
        let r = self.v.recip()?;
        let q = self.d1.mul(r)?;
        Ok(Dual {
            v: self.v.ln()?,
            d1: q,
            d2: self.d2.mul(r)?.sub(q.sqr()?)?,
        })
    }

    /// `sqrt(a)`: `s' = u'/(2s)`, `s'' = u''/(2s) − u'²/(4s³)`.
    pub fn sqrt(self) -> Result<Dual, Trouble> {
        let s = self.v.sqrt()?;
        if s.lo <= 0.0 {
            return Err(Trouble::Domain(
                "`sqrt` of an interval reaching 0 (not smooth there)",
            ));
        }
        let half_r = s.recip()?.scale(0.5)?;
        Ok(Dual {
            v: s,
            d1: self.d1.mul(half_r)?,
            d2: self.d2.mul(half_r)?.sub(
                self.d1
                    .sqr()?
                    .mul(half_r.mul(s.recip()?.sqr()?)?)?
                    .scale(0.5)?,
            )?,
        })
    }

    /// `a^c` for a constant `c`: `p' = c·u^(c−1)·u'`, `p'' = c(c−1)·u^(c−2)·u'² + c·u^(c−1)·u''`.
    pub fn powc(self, c: f64) -> Result<Dual, Trouble> {
        let p1 = self.v.powc(c - 1.0)?;
        let p2 = self.v.powc(c - 2.0)?;
        Ok(Dual {
            v: self.v.powc(c)?,
            d1: p1.mul(self.d1)?.scale(c)?,
            d2: p2
                .mul(self.d1.sqr()?)?
                .scale(c * (c - 1.0))?
                .add(p1.mul(self.d2)?.scale(c)?)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `f''` over `[a, b]` contains the exact second derivative at many points, and its
    /// magnitude (what the interpolation bound uses) is within `slack` (relative) of the
    /// largest exact `|f''|` there.
    fn check(
        f: impl Fn(Dual) -> Result<Dual, Trouble>,
        exact: impl Fn(f64) -> f64,
        a: f64,
        b: f64,
        slack: f64,
    ) {
        let d = f(Dual::variable(I::new(a, b))).expect("bounded");
        let mut max = 0f64;
        for k in 0..=1000 {
            let x = a + (b - a) * k as f64 / 1000.0;
            let v = exact(x);
            assert!(
                d.d2.lo <= v && v <= d.d2.hi,
                "f''({x}) = {v} outside {:?}",
                d.d2
            );
            max = max.max(v.abs());
        }
        assert!(
            d.d2.mag() <= (1.0 + slack) * max,
            "{:?} loose against max |f''| = {max}",
            d.d2
        );
    }

    #[test]
    fn second_derivatives_enclose_the_exact_ones() {
        // On narrow segments (as tables use them) the enclosure is tight.
        let seg = |a: f64| (a, a + 1.0 / 64.0);
        for a in [0.25, 1.0, 3.0] {
            let (a, b) = seg(a);
            check(
                |x| Dual::constant(1.0).div(x),
                |x| 2.0 / x.powi(3),
                a,
                b,
                0.1,
            );
            check(|x| x.neg().exp(), |x| (-x).exp(), a, b, 0.1);
            check(|x| x.ln(), |x| -1.0 / (x * x), a, b, 0.1);
            check(|x| x.sqrt(), |x| -0.25 * x.powf(-1.5), a, b, 0.1);
            check(|x| x.powc(1.5), |x| 0.75 * x.powf(-0.5), a, b, 0.1);
            // A composite: 203·Ks/(224 − η)·(e^(−ηT) − C0) of Jenkins & Kurfess, eq. 17 as a function of η.
            let (t, c0) = (2.214e-3, (-224.0f64 * 2.214e-3).exp());
            let f2 = |x: Dual| {
                let num = x.scale_const(-t)?.exp()?.sub(Dual::constant(c0))?;
                Dual::constant(203.0 * 233.0)
                    .div(Dual::constant(224.0).sub(x)?)?
                    .mul(num)
            };
            let exact = |e: f64| {
                let g = 203.0 * 233.0;
                let (u, du, ddu) = (
                    1.0 / (224.0 - e),
                    1.0 / (224.0 - e).powi(2),
                    2.0 / (224.0 - e).powi(3),
                );
                let (v, dv, ddv) = (
                    (-e * t).exp() - c0,
                    -t * (-e * t).exp(),
                    t * t * (-e * t).exp(),
                );
                g * (ddu * v + 2.0 * du * dv + u * ddv)
            };
            check(f2, exact, a, b, 0.1);
        }
    }

    #[test]
    fn singular_points_are_refused() {
        let x = Dual::variable(I::new(-1.0, 1.0));
        assert!(matches!(
            Dual::constant(1.0).div(x),
            Err(Trouble::Domain(_))
        ));
        assert!(matches!(x.ln(), Err(Trouble::Domain(_))));
        assert!(matches!(x.sqrt(), Err(Trouble::Domain(_))));
        let y = Dual::variable(I::new(0.0, 1.0));
        assert!(matches!(y.sqrt(), Err(Trouble::Domain(_))));
    }

    impl Dual {
        fn scale_const(self, c: f64) -> Result<Dual, Trouble> {
            self.mul(Dual::constant(c))
        }
    }
}
