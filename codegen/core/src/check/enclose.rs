//! Rigorous enclosures of a constant expression's real value, in exact rational arithmetic:
//! what a table's samples and the check of its `error` claim rest on.
//!
//! `const_eval` computes in f64, which is what every other constant needs (each use quantises
//! it). A table is different: its claim speaks of the expression itself, and an f64 evaluation
//! can lose all of a difference to cancellation (`(x + 1e8)·(x + 1e8) − 1e16` at `x = 1` is
//! 200000001; in f64 it is 200000000). Here `+ − × ÷` are exact on big rationals; a decimal
//! literal is its exact decimal value; `exp`, `ln`, `sqrt` and `powf` are evaluated in f64 at
//! the ends of their argument's enclosure and widened outward by four ulps (within an ulp or
//! two for the platform's libm; correctly rounded for `sqrt`), so the exact value lies inside.
//! A name (`param`, `const`, `period`) is the f64 value the compiler uses for it everywhere,
//! and `convert`'s unit factor is widened by four ulps like a library function.

use super::{path_ident, Checker};
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, ToPrimitive, Zero};
use syn::{BinOp, Expr as SExpr, Lit, UnOp};

/// A closed interval `[lo, hi]` of rationals holding the exact value.
#[derive(Clone, Debug, PartialEq)]
pub struct Enc {
    /// Lower end.
    pub lo: BigRational,
    /// Upper end.
    pub hi: BigRational,
}

/// The exact rational value of a finite f64.
pub fn rat(v: f64) -> BigRational {
    BigRational::from_float(v).expect("a finite f64")
}

/// The exact value of `v`, if it is finite.
fn rat_finite(v: f64) -> Option<BigRational> {
    BigRational::from_float(v)
}

/// The f64 nearest `r` (rounding of the conversion is not relied on: every use measures the
/// distance to the exact value).
pub fn to_f64(r: &BigRational) -> f64 {
    r.to_f64().unwrap_or(f64::NAN)
}

/// The least f64 at or above `r`.
pub fn f64_up(r: &BigRational) -> f64 {
    let v = to_f64(r);
    if v.is_finite() && rat(v) < *r {
        v.next_up()
    } else {
        v
    }
}

/// The greatest f64 at or below `r`.
pub fn f64_down(r: &BigRational) -> f64 {
    let v = to_f64(r);
    if v.is_finite() && rat(v) > *r {
        v.next_down()
    } else {
        v
    }
}

fn widen(v: f64, ulps: u32, up: bool) -> f64 {
    (0..ulps).fold(v, |x, _| if up { x.next_up() } else { x.next_down() })
}

impl Enc {
    /// `v` widened outward by four ulps: the allowance for a value computed in f64 by a few
    /// operations or a library function; `None` past the f64 range.
    pub fn around(v: f64) -> Option<Enc> {
        Some(Enc {
            lo: rat_finite(widen(v, 4, false))?,
            hi: rat_finite(widen(v, 4, true))?,
        })
    }

    /// The point `r`.
    pub fn point(r: BigRational) -> Enc {
        Enc {
            lo: r.clone(),
            hi: r,
        }
    }

    /// The midpoint.
    pub fn mid(&self) -> BigRational {
        (&self.lo + &self.hi) / BigRational::from_integer(BigInt::from(2))
    }

    /// `max(|v − lo|, |hi − v|)`: how far `v` may be from the exact value.
    pub fn dist_max(&self, v: &BigRational) -> BigRational {
        let a = (v - &self.lo).abs();
        let b = (&self.hi - v).abs();
        if a > b {
            a
        } else {
            b
        }
    }

    /// The least distance from `v` to a point of the interval (0 inside it): a lower bound
    /// on `|v − exact|`.
    pub fn dist_min(&self, v: &BigRational) -> BigRational {
        if *v < self.lo {
            &self.lo - v
        } else if *v > self.hi {
            v - &self.hi
        } else {
            BigRational::zero()
        }
    }

    fn hull(c: [BigRational; 4]) -> Enc {
        let [a, b, x, y] = c;
        let lo = a.clone().min(b.clone()).min(x.clone()).min(y.clone());
        let hi = a.max(b).max(x).max(y);
        Enc { lo, hi }
    }

    fn neg(self) -> Enc {
        Enc {
            lo: -self.hi,
            hi: -self.lo,
        }
    }

    fn is_point(&self) -> bool {
        self.lo == self.hi
    }

    fn add(self, o: Enc) -> Enc {
        // A table's expression at a grid point is mostly points (literals, the variable): one
        // rational operation instead of two, or of four products in `mul`.
        if self.is_point() && o.is_point() {
            return Enc::point(self.lo + o.lo);
        }
        Enc {
            lo: self.lo + o.lo,
            hi: self.hi + o.hi,
        }
    }

    fn mul(self, o: Enc) -> Enc {
        if self.is_point() && o.is_point() {
            return Enc::point(self.lo * o.lo);
        }
        Enc::hull([
            &self.lo * &o.lo,
            &self.lo * &o.hi,
            &self.hi * &o.lo,
            &self.hi * &o.hi,
        ])
    }

    fn div(self, o: Enc) -> Option<Enc> {
        if !o.lo.is_positive() && !o.hi.is_negative() {
            return None;
        }
        let r = Enc {
            lo: o.hi.recip(),
            hi: o.lo.recip(),
        };
        Some(self.mul(r))
    }

    /// A monotone f64 function of the ends, widened by four ulps: increasing if `up`.
    fn monotone(&self, f: impl Fn(f64) -> f64, increasing: bool) -> Option<Enc> {
        let (a, b) = (f(f64_down(&self.lo)), f(f64_up(&self.hi)));
        let (lo, hi) = if increasing { (a, b) } else { (b, a) };
        let (lo, hi) = (widen(lo, 4, false), widen(hi, 4, true));
        Some(Enc {
            lo: rat_finite(lo)?,
            hi: rat_finite(hi)?,
        })
    }
}

impl Checker {
    /// The enclosure of `e`'s exact value with `var` (if any) at the point `x`, or `None`
    /// where an operation is not defined on the whole enclosure (the f64 evaluation,
    /// `const_eval`, reports those with their place).
    pub(super) fn enclose(&self, e: &SExpr, var: Option<(&str, &BigRational)>) -> Option<Enc> {
        Some(match e {
            SExpr::Lit(l) => Enc::point(lit_rational(&l.lit)?),
            SExpr::Paren(p) => self.enclose(&p.expr, var)?,
            SExpr::Group(g) => self.enclose(&g.expr, var)?,
            SExpr::Path(_) => {
                let n = path_ident(e)?.to_string();
                match var {
                    Some((v, x)) if v == n => Enc::point(x.clone()),
                    _ => Enc::point(rat_finite(self.const_eval(e).ok()?)?),
                }
            }
            SExpr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => self.enclose(&u.expr, var)?.neg(),
            SExpr::Binary(b) => {
                let (l, r) = (self.enclose(&b.left, var)?, self.enclose(&b.right, var)?);
                match b.op {
                    BinOp::Add(_) => l.add(r),
                    BinOp::Sub(_) => l.add(r.neg()),
                    BinOp::Mul(_) => l.mul(r),
                    BinOp::Div(_) => l.div(r)?,
                    _ => return None,
                }
            }
            SExpr::Call(c) => {
                let f = path_ident(&c.func)?.to_string();
                let args: Vec<&SExpr> = c.args.iter().collect();
                self.enclose_call(&f, &args, var)?
            }
            SExpr::MethodCall(m) => {
                let mut args: Vec<&SExpr> = vec![&m.receiver];
                args.extend(m.args.iter());
                self.enclose_call(&m.method.to_string(), &args, var)?
            }
            _ => return None,
        })
    }

    fn enclose_call(
        &self,
        f: &str,
        args: &[&SExpr],
        var: Option<(&str, &BigRational)>,
    ) -> Option<Enc> {
        if f == "convert" {
            let k = Enc::around(self.convert_factor(args).ok()?)?;
            return Some(self.enclose(args.first()?, var)?.mul(k));
        }
        let a: Vec<Enc> = args
            .iter()
            .map(|x| self.enclose(x, var))
            .collect::<Option<_>>()?;
        let zero = BigRational::zero();
        match (f, a.as_slice()) {
            ("exp", [x]) => x.monotone(f64::exp, true).map(|mut r| {
                if r.lo.is_negative() {
                    r.lo = zero;
                }
                r
            }),
            ("ln", [x]) if x.lo.is_positive() => x.monotone(f64::ln, true),
            ("sqrt", [x]) if !x.lo.is_negative() => x.monotone(f64::sqrt, true).map(|mut r| {
                if r.lo.is_negative() {
                    r.lo = zero;
                }
                r
            }),
            // A positive base: `b^c` is monotone in each of `b` and `c`, so its extremes over
            // the box are at the corners.
            ("powf", [x, c]) if x.lo.is_positive() => {
                let bs = [f64_down(&x.lo), f64_up(&x.hi)];
                let cs = [f64_down(&c.lo), f64_up(&c.hi)];
                let v: Vec<f64> = bs
                    .iter()
                    .flat_map(|b| cs.iter().map(move |c| b.powf(*c)))
                    .collect();
                let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                Some(Enc {
                    lo: rat_finite(widen(lo, 4, false))?.max(zero),
                    hi: rat_finite(widen(hi, 4, true))?,
                })
            }
            ("abs", [x]) => Some(if !x.lo.is_negative() {
                x.clone()
            } else if !x.hi.is_positive() {
                x.clone().neg()
            } else {
                Enc {
                    lo: zero,
                    hi: (-x.lo.clone()).max(x.hi.clone()),
                }
            }),
            ("min", [x, y]) => Some(Enc {
                lo: x.lo.clone().min(y.lo.clone()),
                hi: x.hi.clone().min(y.hi.clone()),
            }),
            ("max", [x, y]) => Some(Enc {
                lo: x.lo.clone().max(y.lo.clone()),
                hi: x.hi.clone().max(y.hi.clone()),
            }),
            ("clamp", [x, l, h]) => Some(Enc {
                lo: x.lo.clone().max(l.lo.clone()).min(h.lo.clone()),
                hi: x.hi.clone().max(l.hi.clone()).min(h.hi.clone()),
            }),
            _ => None,
        }
    }
}

/// A literal's exact decimal value.
pub(super) fn lit_rational(l: &Lit) -> Option<BigRational> {
    let digits = match l {
        Lit::Float(f) => f.base10_digits().to_string(),
        Lit::Int(i) => i.base10_digits().to_string(),
        _ => return None,
    };
    decimal(&digits)
}

/// `[-]D[.D][e[+-]D]` as an exact rational.
pub fn decimal(s: &str) -> Option<BigRational> {
    let (mant, exp) = match s.bytes().position(|b| b == b'e' || b == b'E') {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let (neg, mant) = match mant.strip_prefix('-') {
        Some(m) => (true, m),
        None => (false, mant.strip_prefix('+').unwrap_or(mant)),
    };
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let digits = format!("{int}{frac}");
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let m: BigInt = digits.parse().ok()?;
    let e = exp.checked_sub(i32::try_from(frac.len()).ok()?)?;
    // Far beyond the f64 range (and a bound on the work a hostile literal can ask for).
    if e.unsigned_abs() > 1000 {
        return None;
    }
    let ten = BigInt::from(10);
    let p = ten.pow(e.unsigned_abs());
    let r = if e >= 0 {
        BigRational::from_integer(m * p)
    } else {
        BigRational::new(m, p)
    };
    Some(if neg { -r } else { r })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_are_exact() {
        let r = |n: i64, d: i64| BigRational::new(BigInt::from(n), BigInt::from(d));
        assert_eq!(decimal("0.1"), Some(r(1, 10)));
        assert_eq!(decimal("1e-3"), Some(r(1, 1000)));
        assert_eq!(decimal("-2.50e2"), Some(r(-250, 1)));
        assert_eq!(decimal("100000000.0"), Some(r(100_000_000, 1)));
        assert_eq!(decimal("1e400").map(|x| x > rat(f64::MAX)), Some(true));
        assert_eq!(decimal("x"), None);
    }

    #[test]
    fn rounding_to_f64_is_directed() {
        let third = BigRational::new(BigInt::from(1), BigInt::from(3));
        assert!(rat(f64_down(&third)) <= third);
        assert!(rat(f64_up(&third)) >= third);
        assert!(f64_up(&third) > f64_down(&third));
        let half = BigRational::new(BigInt::from(1), BigInt::from(2));
        assert_eq!((f64_down(&half), f64_up(&half)), (0.5, 0.5));
    }
}
