//! Numbers as qloop prints them, in reports and generated docs: compact, and directed where
//! they are claims (a printed bound is never below the bound, a derived range never inside the
//! range; checked exactly against the decimal).

use crate::ir::SigId;
use crate::lower::Plan;
use std::cmp::Ordering;

/// `v` as [`g`] prints it, rounded down (`up = false`) or up: a printed range end or bound is
/// never inside the true one. Printing rounds to nearest, so this steps one unit of the last
/// printed digit outward where that was not already so.
fn directed(v: f64, up: bool, fmt: impl Fn(f64) -> String, unit: impl Fn(f64) -> f64) -> String {
    let mut s = fmt(v);
    if !v.is_finite() {
        return s;
    }
    for _ in 0..8 {
        let outward = match decimal_cmp(&s, v) {
            Some(o) => o == Ordering::Equal || (o == Ordering::Greater) == up,
            None => false,
        };
        if outward {
            return s;
        }
        let p: f64 = s.parse().unwrap_or(v);
        let u = unit(p);
        s = fmt(if up { p + u } else { p - u });
    }
    s
}

/// Compares the decimal `s` (as printed: `-1.563e-4`, `0.05`) with the exact value of `v`,
/// exactly (a decimal and a binary fraction rarely coincide, and parsing `s` back to f64 would
/// round it). `None` if `s` is not a decimal or `v` is not finite.
///
/// Every finite f64 is a finite decimal of at most 767 significant digits, and Rust's `{:.Ne}`
/// formatting prints the exact digits (not a shortest round trip), so `v` printed with 800
/// digits after the point is its exact value; the two decimals are then compared digit by
/// digit. (`qloop`'s tests check this against big-integer arithmetic.)
pub fn decimal_cmp(s: &str, v: f64) -> Option<Ordering> {
    if !v.is_finite() {
        return None;
    }
    let a = Decimal::parse(s)?;
    // Almost always decided without the exact digits: Rust's parse is correctly rounded, so
    // if `s` rounds to an f64 `w` other than `v`, then `s` is on `w`'s side of `v` (it is
    // within half an ulp of `w`, and `v` is at least a whole ulp away). Only `w == v` (or a
    // parse that fails) needs the digits.
    if let Ok(w) = s.parse::<f64>() {
        if w < v {
            return Some(Ordering::Less);
        }
        if w > v {
            return Some(Ordering::Greater);
        }
    }
    let b = Decimal::parse(&format!("{v:.800e}"))?;
    Some(a.cmp(&b))
}

/// A decimal `±0.d₁d₂…dₙ · 10^exp` with `d₁ ≠ 0` and `dₙ ≠ 0`; zero has no digits.
#[derive(PartialEq, Eq)]
struct Decimal {
    neg: bool,
    digits: Vec<u8>,
    exp: i64,
}

impl Decimal {
    /// Reads `[-+]int[.frac][e[-+]exp]`.
    fn parse(s: &str) -> Option<Decimal> {
        // A byte search: `find(['e', 'E'])` is a char-array searcher, several times slower
        // in the test builds that compare millions of printed bounds.
        let (mant, e) = match s.bytes().position(|b| b == b'e' || b == b'E') {
            Some(i) => (&s[..i], s[i + 1..].parse::<i64>().ok()?),
            None => (s, 0),
        };
        let neg = mant.starts_with('-');
        let mant = mant.strip_prefix(['-', '+']).unwrap_or(mant);
        let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
        if int.is_empty() && frac.is_empty() {
            return None;
        }
        let all: Vec<u8> = int.bytes().chain(frac.bytes()).collect();
        if !all.iter().all(u8::is_ascii_digit) {
            return None;
        }
        // value = 0.(int frac) · 10^(e + len(int)); drop leading zeros (each lowers the
        // exponent) and trailing zeros.
        let lead = all.iter().take_while(|&&d| d == b'0').count();
        let mut digits = all[lead..].to_vec();
        while digits.last() == Some(&b'0') {
            digits.pop();
        }
        let exp = e.checked_add(int.len() as i64)?.checked_sub(lead as i64)?;
        let neg = neg && !digits.is_empty();
        let exp = if digits.is_empty() { 0 } else { exp };
        Some(Decimal { neg, digits, exp })
    }

    /// Compares magnitudes.
    fn cmp_abs(&self, o: &Decimal) -> Ordering {
        match (self.digits.is_empty(), o.digits.is_empty()) {
            (true, true) => Ordering::Equal,
            (true, false) => Ordering::Less,
            (false, true) => Ordering::Greater,
            // Same number of leading zeros stripped: the larger exponent is the larger value;
            // then the digits, where a prefix is the smaller (no trailing zeros).
            _ => self
                .exp
                .cmp(&o.exp)
                .then_with(|| self.digits.cmp(&o.digits)),
        }
    }
}

impl PartialOrd for Decimal {
    fn partial_cmp(&self, o: &Decimal) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Decimal {
    fn cmp(&self, o: &Decimal) -> Ordering {
        match (self.neg, o.neg) {
            (false, true) => Ordering::Greater,
            (true, false) => Ordering::Less,
            (false, false) => self.cmp_abs(o),
            (true, true) => o.cmp_abs(self),
        }
    }
}

/// One unit of the last digit of `{:.Ne}` formatting at `v`'s magnitude.
fn sci_unit(v: f64, digits: i32) -> f64 {
    if v == 0.0 {
        return f64::MIN_POSITIVE;
    }
    10f64.powi(v.abs().log10().floor() as i32 - digits)
}

/// [`g`], rounded down.
pub fn g_down(v: f64) -> String {
    directed(v, false, g, g_unit)
}

/// [`g`], rounded up.
pub fn g_up(v: f64) -> String {
    directed(v, true, g, g_unit)
}

fn g_unit(v: f64) -> f64 {
    if v.abs() >= 1e-3 && v.abs() < 1e6 {
        1e-6
    } else {
        sci_unit(v, 4)
    }
}

/// A range `[lo, hi]` the analysis derived, as printed in reports and generated docs: ends
/// rounded outward.
pub fn range_text(lo: f64, hi: f64) -> String {
    format!("[{}, {}]", g_down(lo), g_up(hi))
}

/// The range of signal `id` as printed: a declared range as the spec wrote it (the shortest
/// decimal that reads back as the same f64) when that has at most 12 significant digits, else
/// (a computed end such as `K / 6`) rounded outward like a derived one.
pub fn signal_range_text(plan: &Plan, id: SigId) -> String {
    let (lo, hi) = plan.summary[id.0].range;
    if plan.prog.sig(id).range.is_some() {
        let end = |v: f64, up: bool| {
            let l = literal(v);
            let mantissa = l.split(['e', 'E']).next().unwrap_or("");
            let digits = mantissa
                .chars()
                .filter(char::is_ascii_digit)
                .skip_while(|c| *c == '0')
                .count();
            if digits <= 12 {
                l
            } else if up {
                g_up(v)
            } else {
                g_down(v)
            }
        };
        format!("[{}, {}]", end(lo, false), end(hi, true))
    } else {
        range_text(lo, hi)
    }
}

/// The shortest decimal that reads back as `v` (`0.27`, `5`, `1e-21`).
fn literal(v: f64) -> String {
    let s = format!("{v:?}");
    s.strip_suffix(".0").map_or(s.clone(), str::to_string)
}

/// An error bound (non-negative) to four significant digits, rounded up: what qloop prints as
/// a bound is never below the bound it computed.
pub fn bound(v: f64) -> String {
    directed(v, true, |x| format!("{x:.3e}"), |x| sci_unit(x, 3))
}

/// A lower bound (non-negative) to four significant digits, rounded down: what qloop prints
/// as "at least" is never above the bound it computed.
pub fn bound_down(v: f64) -> String {
    directed(v, false, |x| format!("{x:.3e}"), |x| sci_unit(x, 3))
}

/// A percentage bound (non-negative) to three significant digits, rounded up.
pub fn percent(v: f64) -> String {
    directed(v, true, |x| format!("{x:.2e}"), |x| sci_unit(x, 2))
}

/// Compact number formatting for tables and generated docs.
pub fn g(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e6 {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.4e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A printed bound is never below the bound, and a printed range never inside the range,
    /// exactly (not only after parsing back to f64).
    #[test]
    fn printed_bounds_round_up_and_ranges_outward() {
        // `{:.3e}` rounds to nearest: 1.56245e-4 printed as 1.562e-4, below the bound.
        assert_eq!(format!("{:.3e}", 1.56245e-4), "1.562e-4");
        assert_eq!(bound(1.56245e-4), "1.563e-4");
        assert_eq!(bound(0.5), "5.000e-1");
        assert_eq!(bound(0.0), "0.000e0");
        // -1.178e-5 as an f64 is a little more than 1.178e-5 in magnitude: the decimal that
        // parses back to the same f64 is below it.
        assert_eq!(decimal_cmp("1.178e-5", 1.178e-5), Some(Ordering::Less));
        assert_eq!(bound(1.178e-5), "1.179e-5");
        // The f64 nearest 0.2083 is a little above it.
        assert_eq!(g_down(0.2083), "0.2083");
        assert_eq!(g_up(0.2083), "0.208301");
        assert_eq!(range_text(0.050048828125, 5.0), "[0.050048, 5]");
        for v in [
            3.0503e-5,
            1e-300,
            123456.789,
            7.0,
            0.1,
            2f64.powi(-40),
            9.999e-1,
        ] {
            assert_ne!(decimal_cmp(&bound(v), v), Some(Ordering::Less), "{v}");
            assert_ne!(
                decimal_cmp(&bound_down(v), v),
                Some(Ordering::Greater),
                "{v}"
            );
            assert_ne!(decimal_cmp(&g_up(v), v), Some(Ordering::Less), "{v}");
            assert_ne!(decimal_cmp(&g_down(v), v), Some(Ordering::Greater), "{v}");
            assert_ne!(decimal_cmp(&g_up(-v), -v), Some(Ordering::Less), "{v}");
        }
    }
}
