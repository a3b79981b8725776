//! A spec exercising what the seed specs do not: round-to-nearest, pinned and
//! resolution-requested formats (16-bit, unsigned), value `if`, `clamp`, `min`/`max`,
//! non-power-of-two and negative constant gains, and a ranged (saturating) output. It is
//! compiled inline by the macro, and checked bit for bit against the interpreter and
//! against real arithmetic within the reported bound.

use fixed::types::extra::*;
use fixed::{FixedI16, FixedI32, FixedU16};
use proptest::prelude::*;
use qloop::interp::step_fixed;
use qloop::qformat::{IntTy, QFormat};
use qloop::Plan;
use qloop_tests::sig;

const SPEC: &str = include_str!("features.qloop");

qloop_macros::controller! {
    /// Feature coverage (see features.qloop: the same text).
    controller features {
        period 2 "ms";
        rounding nearest;
        #[lsb(0.001)]
        input x: [0.0, 10.0] "V";
        input y: [-2.0, 2.0];
        param G: 0.3 "1/V";
        param NEG: -1.75;
        #[q(i16, 10)]
        state s: [-8.0, 8.0] = 0.0;
        #[q(u16, 16)]
        state w: [0.0, 0.99] = 0.5;
        output z: [-1.0, 1.0];
        output q;
        step {
            let d = x * G + NEG * y;
            let m = if d > 2.0 { d - 2.0 } else { min(d, 0.5) };
            s = s * 0.875 + clamp(m, -1.0, 1.0);
            if y < 0.0 && !(x > 9.0) {
                w -= 0.0625 * w;
            } else {
                w = max(w, 0.25) * 0.5 + 0.125;
            }
            z = s * w - 0.3;
            q = -d;
        }
    }
}

thread_local! {
    static PLAN: &'static Plan = Box::leak(Box::new(
        qloop::compile_str(SPEC, &qloop::Target::default()).expect("features.qloop compiles"),
    ));
}

fn plan() -> &'static Plan {
    PLAN.with(|p| *p)
}

#[test]
fn formats_follow_pins_and_lsb_requests() {
    let p = plan();
    // #[lsb(0.001)] over [0, 10]: 10 fraction bits give 9.8e-4; i16 holds 10·2^10, and is
    // the narrowest word that does.
    assert_eq!(
        p.format(sig(p, "x")),
        QFormat {
            ty: IntTy::signed(16),
            frac: 11
        }
    );
    assert_eq!(
        p.format(sig(p, "s")),
        QFormat {
            ty: IntTy::signed(16),
            frac: 10
        }
    );
    assert_eq!(
        p.format(sig(p, "w")),
        QFormat {
            ty: IntTy::unsigned(16),
            frac: 16
        }
    );
    // The default word for unpinned signals is 32 bits.
    assert_eq!(p.format(sig(p, "y")).ty, IntTy::signed(32));
    let report = qloop::report::check_report(p, "features.qloop");
    assert!(
        report.contains("adder"),
        "0.3 and -1.75 need adders:\n{report}"
    );
}

#[test]
fn the_macro_spec_is_the_file_spec() {
    // The inline spec above and features.qloop must be the same text, token for token.
    let file: proc_macro2::TokenStream = SPEC.parse().unwrap();
    let this = include_str!("features.rs");
    let start = this.find("    /// Feature coverage").unwrap();
    let end = this.find("\n}\n\nthread_local!").unwrap();
    let inline: proc_macro2::TokenStream = this[start..end].parse().unwrap();
    assert_eq!(file.to_string(), inline.to_string());
}

fn fixed_vars(x: i16, y: i32, s: i16, w: u16) -> Vec<i128> {
    let p = plan();
    let mut v = vec![0i128; p.prog.signals.len()];
    v[sig(p, "x").0] = x.into();
    v[sig(p, "y").0] = y.into();
    v[sig(p, "s").0] = s.into();
    v[sig(p, "w").0] = w.into();
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(4000)))]

    #[test]
    fn generated_matches_interpreter(x in any::<i16>(), y in any::<i32>(), s in -8192i16..=8192, w in 0u16..=64880) {
        let p = plan();
        let mut c = features::Controller::new();
        c.set_states(features::States { s: FixedI16::from_bits(s), w: FixedU16::from_bits(w) });
        let out = c.step(features::Inputs { x: FixedI16::from_bits(x), y: FixedI32::from_bits(y) });
        let mut v = fixed_vars(x, y, s, w);
        let r = step_fixed(p, &mut v);
        prop_assert!(r.is_ok(), "range analysis violated: {:?}", r);
        prop_assert_eq!(i128::from(c.states().s.to_bits()), v[sig(p, "s").0]);
        prop_assert_eq!(i128::from(c.states().w.to_bits()), v[sig(p, "w").0]);
        prop_assert_eq!(i128::from(out.z.to_bits()), v[sig(p, "z").0]);
        prop_assert_eq!(i128::from(out.q.to_bits()), v[sig(p, "q").0]);
    }

    /// Every error bound `check` prints holds against exact rational arithmetic (the f64
    /// reference is not exact: at a bound that is tight, as `q`'s is at `x = 20480`, its own
    /// rounding showed as a 2e-16 excess), where both take the same branches, and every
    /// differing decision is within its band (`qloop_tests::claims::check`).
    #[test]
    fn within_bound_of_real_arithmetic(x in 0i16..=20480, y in any::<i32>(), s in -8192i16..=8192, w in 0u16..=64880) {
        let case = qloop_tests::cases::Case {
            inputs: vec![x.into(), y.into()],
            states: vec![s.into(), w.into()],
        };
        let r = qloop_tests::claims::check(plan(), &case);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }
}

#[allow(dead_code)]
fn _unused(_: FixedI32<U0>) {}

/// The case where the f64 reference's rounding made `q`'s tight bound look exceeded by 2e-16:
/// against exact arithmetic the bound holds.
#[test]
fn tight_bound_holds_exactly_at_the_range_end() {
    let case = qloop_tests::cases::Case {
        inputs: vec![20480, 296009044],
        states: vec![0, 0],
    };
    let r = qloop_tests::claims::check(plan(), &case);
    assert!(r.is_ok(), "{}", r.unwrap_err());
    assert!(r.unwrap().bounds > 0);
}
