//! Arithmetic on error bounds, rounded up.
//!
//! A bound is an f64, and f64 arithmetic rounds to nearest: summing a bound of 0.371 (just
//! below, as f64) and one of 1.4e-17 gives 0.371 again, below the real sum. Every operation
//! that combines bounds goes through here instead: the exact result is recovered with an
//! error-free transformation (TwoSum for `+`, a fused multiply-add for `·`) and the f64 is
//! stepped up by one unit where it fell below. The results are exact where the f64 operation
//! was, so bounds that were exact stay as they were.

/// `a + b`, rounded up (`a`, `b` finite or +∞).
pub(super) fn add(a: f64, b: f64) -> f64 {
    let s = a + b;
    if !s.is_finite() {
        return s;
    }
    // TwoSum (Knuth): s + t == a + b exactly.
    let bb = s - a;
    let t = (a - (s - bb)) + (b - bb);
    if t > 0.0 {
        s.next_up()
    } else {
        s
    }
}

/// `a · b`, rounded up (`a`, `b` finite or +∞).
pub(super) fn mul(a: f64, b: f64) -> f64 {
    let p = a * b;
    if !p.is_finite() || p == 0.0 {
        return p;
    }
    // a·b − p, exactly (one rounding of an exact value that fits).
    if a.mul_add(b, -p) > 0.0 {
        p.next_up()
    } else {
        p
    }
}

/// `a − b`, rounded up.
pub(super) fn sub(a: f64, b: f64) -> f64 {
    add(a, -b)
}

/// `|a − b|`, rounded up.
pub(super) fn dist(a: f64, b: f64) -> f64 {
    if a >= b {
        sub(a, b)
    } else {
        sub(b, a)
    }
}

/// `v` as the f64s just below and just above it (equal where `v` has at most 53 significant
/// bits).
fn enclose(v: u128) -> (f64, f64) {
    let f = v as f64;
    let back = f as u128;
    (
        if back > v { f.next_down() } else { f },
        if back < v { f.next_up() } else { f },
    )
}

/// `|raw| · 2^-frac` as an f64 no smaller than the exact value (an `i128` magnitude with more
/// than 53 significant bits rounds up, not to nearest).
pub(super) fn magnitude(raw: i128, frac: i32) -> f64 {
    enclose(raw.unsigned_abs()).1 * crate::qformat::pow2(-frac)
}

/// `raw · 2^-frac` rounded down (`up = false`) or up.
pub(super) fn value(raw: i128, frac: i32, up: bool) -> f64 {
    let (down_m, up_m) = enclose(raw.unsigned_abs());
    let scale = crate::qformat::pow2(-frac);
    match (raw < 0, up) {
        (false, true) => up_m * scale,
        (false, false) => down_m * scale,
        (true, true) => -down_m * scale,
        (true, false) => -up_m * scale,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_bigint::BigInt;
    use num_rational::BigRational;

    fn q(v: f64) -> BigRational {
        BigRational::from_float(v).unwrap()
    }

    /// The case that showed the need: 0.371 (as the f64 just below it) plus a bound far below
    /// its last bit stays 0.371 to nearest, and must not.
    #[test]
    fn a_tiny_addend_is_not_lost() {
        let a = 3.0 - 2.629f64; // exact (Sterbenz): 0.37099999999999999645
        let b = 1.4e-17;
        assert_eq!(a + b, a, "round to nearest loses it");
        let s = add(a, b);
        assert!(q(s) >= q(a) + q(b));
        assert_eq!(s, a.next_up());
    }

    /// Against exact rationals, over operands spread across many binades: never below, and at
    /// most one unit above.
    #[test]
    fn add_mul_sub_bound_the_exact_result_from_above_by_at_most_one_unit() {
        let mut s: u64 = 0x243f_6a88_85a3_08d3;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let e = (s % 120) as i32 - 80;
            m * 2f64.powi(e)
        };
        for _ in 0..20_000 {
            let (a, b) = (next(), next());
            for (r, exact) in [
                (add(a, b), q(a) + q(b)),
                (mul(a, b), q(a) * q(b)),
                (sub(a, b), q(a) - q(b)),
                (dist(a, b), if a >= b { q(a) - q(b) } else { q(b) - q(a) }),
            ] {
                assert!(
                    q(r) >= exact,
                    "{r:e} below the exact result of {a:e}, {b:e}"
                );
                assert!(q(r.next_down()) < exact, "{r:e} more than one unit above");
            }
        }
    }

    #[test]
    fn exact_results_stay_exact() {
        assert_eq!(add(0.5, 0.25), 0.75);
        assert_eq!(mul(3.0, 0.125), 0.375);
        assert_eq!(dist(1.0, 3.0), 2.0);
        assert_eq!(add(0.0, 0.0), 0.0);
    }

    #[test]
    fn values_of_wide_raws_round_in_the_asked_direction() {
        let raw: i128 = (1 << 60) + 1; // 61 significant bits
        for raw in [raw, -raw] {
            let exact = BigRational::new(BigInt::from(raw), BigInt::from(1) << 10);
            assert!(q(value(raw, 10, true)) >= exact);
            assert!(q(value(raw, 10, false)) <= exact);
            assert!(
                q(magnitude(raw, 10))
                    >= if raw < 0 {
                        -exact.clone()
                    } else {
                        exact.clone()
                    }
            );
        }
        assert_eq!(value(-3, 1, true), -1.5);
        assert_eq!(value(-3, 1, false), -1.5);
    }
}
