//! The core's exact decimal-versus-f64 comparison (`text::decimal_cmp`, digit strings from
//! Rust's exact float formatting) against big-integer arithmetic, on printed bounds and on
//! arbitrary decimals near arbitrary doubles.

use num_bigint::BigInt;
use proptest::prelude::*;
use qloop::text::decimal_cmp;
use std::cmp::Ordering;

/// `s = d·10^k` against `v = m·2^e`, in integers.
fn reference(s: &str, v: f64) -> Option<Ordering> {
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
    let k = exp - frac.len() as i32;
    let (m, e) = qloop::qformat::significand_exponent(v);
    let m = BigInt::from(m);
    let pow = |b: u32, n: i32| BigInt::from(b).pow(n.max(0) as u32);
    let lhs = d * pow(10, k) * pow(2, -e);
    let rhs = m * pow(2, e) * pow(10, -k);
    Some(lhs.cmp(&rhs))
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<u64>().prop_map(f64::from_bits),
        (-1e6f64..1e6),
        (-60i32..60, -1000i64..1000).prop_map(|(e, m)| m as f64 * 2f64.powi(e)),
    ]
    .prop_filter("finite", |v| v.is_finite())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(4000)))]

    /// Decimals printed from `v` or a neighbour, at every precision the reports use.
    #[test]
    fn agrees_with_big_integers(v in finite(), digits in 0usize..20, nudge in -2i64..=2, sci in any::<bool>()) {
        let w = f64::from_bits((v.to_bits() as i64).wrapping_add(nudge) as u64);
        prop_assume!(w.is_finite());
        let s = if sci { format!("{w:.digits$e}") } else { format!("{w:.digits$}") };
        prop_assert_eq!(decimal_cmp(&s, v), reference(&s, v), "{} vs {:e}", s, v);
        prop_assert_eq!(decimal_cmp(&s, w), reference(&s, w), "{} vs {:e}", s, w);
    }
}

#[test]
fn exact_ties_and_zeros() {
    assert_eq!(decimal_cmp("0.5", 0.5), Some(Ordering::Equal));
    assert_eq!(decimal_cmp("5e-1", 0.5), Some(Ordering::Equal));
    assert_eq!(decimal_cmp("-0", 0.0), Some(Ordering::Equal));
    assert_eq!(decimal_cmp("0.000e0", -0.0), Some(Ordering::Equal));
    assert_eq!(decimal_cmp("0.1", 0.1), Some(Ordering::Less)); // 0.1 as f64 is above 1/10
    assert_eq!(decimal_cmp("-0.1", -0.1), Some(Ordering::Greater));
    assert_eq!(
        decimal_cmp("1e-400", f64::from_bits(1)),
        Some(Ordering::Less)
    );
    assert_eq!(decimal_cmp("x", 1.0), None);
    assert_eq!(decimal_cmp("1", f64::NAN), None);
}
