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
/// round it).
fn decimal_cmp(s: &str, v: f64) -> Option<Ordering> {
    use num_bigint::BigInt;
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let neg = mant.starts_with('-');
    let mant = mant.trim_start_matches(['-', '+']);
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut d: BigInt = format!("{int}{frac}").parse().ok()?;
    if neg {
        d = -d;
    }
    let k = exp - frac.len() as i32; // s = d · 10^k
    let (m, e) = crate::qformat::significand_exponent(v);
    let m = BigInt::from(m);
    let pow = |b: u32, n: i32| BigInt::from(b).pow(n.max(0) as u32);
    // d·10^k ? m·2^e  ⟺  d·10^k⁺·2^e⁻ ? m·2^e⁺·10^k⁻
    let lhs = d * pow(10, k) * pow(2, -e);
    let rhs = m * pow(2, e) * pow(10, -k);
    Some(lhs.cmp(&rhs))
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
/// decimal that reads back as the same f64), a derived one rounded outward.
pub fn signal_range_text(plan: &Plan, id: SigId) -> String {
    let (lo, hi) = plan.summary[id.0].range;
    if plan.prog.sig(id).range.is_some() {
        format!("[{}, {}]", literal(lo), literal(hi))
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
            assert_ne!(decimal_cmp(&g_up(v), v), Some(Ordering::Less), "{v}");
            assert_ne!(decimal_cmp(&g_down(v), v), Some(Ordering::Greater), "{v}");
            assert_ne!(decimal_cmp(&g_up(-v), -v), Some(Ordering::Less), "{v}");
        }
    }
}
