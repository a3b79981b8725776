//! Semantics of the generated code, against independent truths:
//!
//! * bit-exactness: the macro-generated fixed-point `step` equals qloop's plan interpreter
//!   bit for bit, for any input bits (in range or not) and any in-range state, and no
//!   intermediate leaves the interval the range analysis proved for it;
//! * the generated f64 reference equals the real-arithmetic IR interpreter exactly;
//! * accuracy: one fixed-point step agrees with the f64 reference within the error bound
//!   `qloop check` reports, and that bound is not vacuous (< 1% of the signal's range).

use fixed::types::extra::*;
use fixed::{FixedI16, FixedI64};
use proptest::prelude::*;
use qloop::interp::{step_fixed, step_real};
use qloop::ir::{SigId, SigKind};
use qloop::Plan;
use qloop_tests::{plan, sig};
use qloop_verified::{acc_fixed_gain as acc, acc_fixed_gain_ref as acc_ref};
use qloop_verified::{koren_masory_1981 as km81, koren_masory_1981_ref as km81_ref};

// Plans hold proc-macro2 spans, which are not `Sync`: keep one per test thread.
thread_local! {
    static KM81: &'static Plan = Box::leak(Box::new(plan("koren_masory_1981")));
    static ACC: &'static Plan = Box::leak(Box::new(plan("acc_fixed_gain")));
}

fn km81_plan() -> &'static Plan {
    KM81.with(|p| *p)
}

fn acc_plan() -> &'static Plan {
    ACC.with(|p| *p)
}

/// Raw saturation bounds of a state.
fn bounds(p: &Plan, name: &str) -> (i128, i128) {
    p.raw_bounds(sig(p, name)).unwrap()
}

fn in_bounds(p: &Plan, name: &str) -> impl Strategy<Value = i16> {
    let (lo, hi) = bounds(p, name);
    (lo as i16)..=(hi as i16)
}

fn phys(p: &Plan, name: &str, raw: i128) -> f64 {
    p.format(sig(p, name)).value(raw)
}

/// The reported one-step error bound of a signal.
fn bound(p: &Plan, name: &str) -> f64 {
    p.summary[sig(p, name).0].err
}

fn vars_fixed(p: &Plan, vals: &[(&str, i128)]) -> Vec<i128> {
    let mut v = vec![0i128; p.prog.signals.len()];
    for (n, x) in vals {
        v[sig(p, n).0] = *x;
    }
    v
}

fn vars_real(p: &Plan, vals: &[(&str, f64)]) -> Vec<f64> {
    let mut v = vec![0f64; p.prog.signals.len()];
    for (n, x) in vals {
        v[sig(p, n).0] = *x;
    }
    v
}

#[test]
fn error_bounds_are_not_vacuous() {
    for p in [km81_plan(), acc_plan()] {
        for (i, s) in p.prog.signals.iter().enumerate() {
            if matches!(s.kind, SigKind::State | SigKind::Output) {
                let sm = &p.summary[i];
                let span = sm.range.1 - sm.range.0;
                assert!(
                    sm.err > 0.0,
                    "{}: a zero bound for a rounded signal is wrong",
                    s.name
                );
                assert!(
                    sm.err < 0.01 * span,
                    "{}: bound {} ≥ 1% of range {}",
                    s.name,
                    sm.err,
                    span
                );
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(4000)))]

    #[test]
    fn km81_generated_matches_interpreter(fc in any::<i16>(), km in in_bounds(km81_plan(), "km"),
                                          kc in in_bounds(km81_plan(), "kc"), u in in_bounds(km81_plan(), "u")) {
        let p = km81_plan();
        let mut c = km81::Controller::new();
        c.set_states(km81::States { km: FixedI16::from_bits(km), kc: FixedI16::from_bits(kc), u: FixedI16::from_bits(u) });
        let out = c.step(km81::Inputs { fc: FixedI16::from_bits(fc) });
        let mut v = vars_fixed(p, &[("fc", fc.into()), ("km", km.into()), ("kc", kc.into()), ("u", u.into())]);
        let r = step_fixed(p, &mut v);
        prop_assert!(r.is_ok(), "range analysis violated: {:?}", r);
        let s = c.states();
        prop_assert_eq!(i128::from(s.km.to_bits()), v[sig(p, "km").0]);
        prop_assert_eq!(i128::from(s.kc.to_bits()), v[sig(p, "kc").0]);
        prop_assert_eq!(i128::from(s.u.to_bits()), v[sig(p, "u").0]);
        prop_assert_eq!(i128::from(out.feed.to_bits()), v[sig(p, "feed").0]);
    }

    #[test]
    fn km81_fixed_within_reported_bound(fc in in_bounds_input(km81_plan(), "fc"), km in in_bounds(km81_plan(), "km"),
                                         kc in in_bounds(km81_plan(), "kc"), u in in_bounds(km81_plan(), "u")) {
        let p = km81_plan();
        // The same start, exactly, in the generated f64 reference.
        let (fcx, kmx, kcx, ux) = (phys(p, "fc", fc.into()), phys(p, "km", km.into()), phys(p, "kc", kc.into()), phys(p, "u", u.into()));
        let mut r = km81_ref::Reference::new();
        r.set_states(km81_ref::States { km: kmx, kc: kcx, u: ux });
        let rout = r.step(km81_ref::Inputs { fc: fcx });
        // The reference module is the real interpreter, exactly.
        let mut rv = vars_real(p, &[("fc", fcx), ("km", kmx), ("kc", kcx), ("u", ux)]);
        step_real(&p.prog, &mut rv);
        prop_assert_eq!(rout.feed, rv[sig(p, "feed").0]);
        prop_assert_eq!(r.states().km, rv[sig(p, "km").0]);
        // Every printed bound holds against exact rational arithmetic where both take the
        // same branches, and a differing decision is within its band (the f64 reference is
        // not exact: at a tight bound its own rounding could show as an excess). The generated
        // code equals the plan interpreter that this checks (`km81_generated_matches_interpreter`).
        let case = qloop_tests::cases::Case {
            inputs: vec![fc.into()],
            states: vec![km.into(), kc.into(), u.into()],
        };
        let checked = qloop_tests::claims::check(p, &case);
        prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }

    #[test]
    fn acc_generated_matches_interpreter(fc in any::<i16>(), u in in_bounds(acc_plan(), "u")) {
        let p = acc_plan();
        let mut c = acc::Controller::new();
        c.set_states(acc::States { u: FixedI16::from_bits(u) });
        let out = c.step(acc::Inputs { fc: FixedI16::from_bits(fc) });
        let mut v = vars_fixed(p, &[("fc", fc.into()), ("u", u.into())]);
        prop_assert!(step_fixed(p, &mut v).is_ok());
        prop_assert_eq!(i128::from(c.states().u.to_bits()), v[sig(p, "u").0]);
        prop_assert_eq!(i128::from(out.vf.to_bits()), v[sig(p, "vf").0]);
    }

    #[test]
    fn acc_fixed_within_reported_bound(fc in in_bounds_input(acc_plan(), "fc"), u in in_bounds(acc_plan(), "u")) {
        // The generated f64 reference is the real interpreter, exactly.
        let p = acc_plan();
        let (fcx, ux) = (phys(p, "fc", fc.into()), phys(p, "u", u.into()));
        let mut r = acc_ref::Reference::new();
        r.set_states(acc_ref::States { u: ux });
        let rout = r.step(acc_ref::Inputs { fc: fcx });
        let mut rv = vars_real(p, &[("fc", fcx), ("u", ux)]);
        step_real(&p.prog, &mut rv);
        prop_assert_eq!(rout.vf, rv[sig(p, "vf").0]);
        prop_assert_eq!(r.states().u, rv[sig(p, "u").0]);
        // As `km81_fixed_within_reported_bound`, against exact arithmetic.
        let case = qloop_tests::cases::Case { inputs: vec![fc.into()], states: vec![u.into()] };
        let checked = qloop_tests::claims::check(acc_plan(), &case);
        prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }
}

/// Raw values of an input inside its declared range.
fn in_bounds_input(p: &Plan, name: &str) -> impl Strategy<Value = i16> {
    let q = p.format(sig(p, name));
    let (lo, hi) = p.prog.sig(sig(p, name)).range.unwrap();
    (q.raw_ceil(lo) as i16)..=(q.raw_floor(hi) as i16)
}

/// The reported bound is tight enough to mean something: over many steps, the largest
/// observed error reaches a sizeable fraction of it (a bound 1000× too loose would pass the
/// proptest above but fail here).
#[test]
fn km81_bound_is_reasonably_tight() {
    let p = km81_plan();
    let mut worst: f64 = 0.0;
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut next = |lo: i128, hi: i128| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        lo + (rng as i128).rem_euclid(hi - lo + 1)
    };
    let fcq = p.format(sig(p, "fc"));
    let (fl, fh) = (fcq.raw_ceil(0.0), fcq.raw_floor(5.0));
    for _ in 0..20000 {
        let fc = next(fl, fh) as i16;
        let [km, kc, u] = ["km", "kc", "u"].map(|n| {
            let (lo, hi) = bounds(p, n);
            next(lo, hi) as i16
        });
        let mut c = km81::Controller::new();
        c.set_states(km81::States {
            km: FixedI16::from_bits(km),
            kc: FixedI16::from_bits(kc),
            u: FixedI16::from_bits(u),
        });
        let _ = c.step(km81::Inputs {
            fc: FixedI16::from_bits(fc),
        });
        let mut r = km81_ref::Reference::new();
        r.set_states(km81_ref::States {
            km: phys(p, "km", km.into()),
            kc: phys(p, "kc", kc.into()),
            u: phys(p, "u", u.into()),
        });
        r.step(km81_ref::Inputs {
            fc: phys(p, "fc", fc.into()),
        });
        worst = worst.max((c.states().u.to_num::<f64>() - r.states().u).abs() / bound(p, "u"));
    }
    assert!(worst <= 1.0);
    assert!(
        worst > 0.1,
        "observed/bound = {worst}: bound is loose by more than 10x"
    );
}

#[allow(dead_code)]
fn _types(_: FixedI64<U0>, _: SigId) {}
