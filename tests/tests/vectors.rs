//! Vectors, matrices and loops (`lang::expand`), through the whole pipeline, against
//! independent truths:
//!
//! * meaning: the generated f64 reference of vectors.qloop equals the same algorithm written
//!   here with plain Rust arrays and loops, exactly (the same operations in the same order,
//!   so f64 rounds alike);
//! * bit-exactness: the macro-generated fixed-point `step`, called through its array API and
//!   through `step_bits`, equals qloop's plan interpreter bit for bit;
//! * accuracy: every one-step error bound `qloop check` prints holds against exact rational
//!   arithmetic (`qloop_tests::claims`);
//! * the API: inputs, states and outputs declared as vectors and matrices are arrays.

use fixed::types::extra::{U28, U29, U30};
use fixed::FixedI32;
use proptest::prelude::*;
use qloop::interp::step_fixed;
use qloop::ir::SigKind;
use qloop::Plan;
use qloop_tests::sig;

qloop_macros::controller!("tests/vectors.qloop");
qloop_macros::controller!("tests/vectors.qloop", reference);

thread_local! {
    static PLAN: &'static Plan = Box::leak(Box::new(
        qloop::compile_str(include_str!("vectors.qloop"), &qloop::Target::default())
            .expect("vectors.qloop compiles"),
    ));
}

fn plan() -> &'static Plan {
    PLAN.with(|p| *p)
}

type Q30 = FixedI32<U30>;
type Q29 = FixedI32<U29>;
type Q28 = FixedI32<U28>;

/// The algorithm of vectors.qloop with plain arrays and loops: inputs clamped, every state
/// and ranged output saturated to its declared range on each write. (Index loops on purpose:
/// they mirror the spec's.)
#[allow(clippy::needless_range_loop)]
fn plain(phi: [f64; 2], y: f64, theta: [f64; 2], p: [[f64; 2]; 2]) -> [f64; 9] {
    let phi = phi.map(|x| x.clamp(-1.0, 1.0));
    let y = y.clamp(-4.0, 4.0);
    let dot = |a: [f64; 2], b: [f64; 2]| (a[0] * b[0]) + (a[1] * b[1]);
    let e = y - dot(theta, phi);
    let yhat = dot(theta, phi).clamp(-4.0, 4.0);
    let pphi = [dot(p[0], phi), dot(p[1], phi)];
    let th_range = [(-2.0, 2.0), (-1.0, 1.0)];
    let (mut th, mut dth) = (theta, [0.0; 2]);
    for i in 0..2 {
        let k = 0.125 * e * pphi[i];
        th[i] = (th[i] + k).clamp(th_range[i].0, th_range[i].1);
        dth[i] = k.clamp(-1.0, 1.0);
    }
    let p_range = |i: usize, j: usize| if i == j { (0.0, 2.0) } else { (-1.0, 1.0) };
    let mut q = p;
    for i in 0..2 {
        for j in 0..2 {
            let (lo, hi) = p_range(i, j);
            q[i][j] = (q[i][j] - 0.0625 * q[i][j]).clamp(lo, hi);
        }
    }
    if (q[0][0] + q[0][1]) + (q[1][0] + q[1][1]) < 0.5 {
        q[0][0] = 1.0;
        q[1][1] = 1.0;
    }
    [
        th[0], th[1], q[0][0], q[0][1], q[1][0], q[1][1], yhat, dth[0], dth[1],
    ]
}

#[test]
fn the_api_takes_arrays_and_starts_from_the_declared_values() {
    let c = vectors::Controller::new();
    let s: vectors::States = c.states();
    assert_eq!(s.theta, [Q29::from_num(0.5), Q29::from_num(0.0)]);
    assert_eq!(
        s.P,
        [
            [Q29::from_num(1.0), Q29::from_num(0.0)],
            [Q29::from_num(0.0), Q29::from_num(1.0)]
        ]
    );
    assert_eq!(vectors::INPUTS, ["phi[0]", "phi[1]", "y"]);
    assert_eq!(
        vectors::STATES,
        ["theta[0]", "theta[1]", "P[0][0]", "P[0][1]", "P[1][0]", "P[1][1]"]
    );
    let r = vectors_ref::Reference::new();
    assert_eq!(r.states().P, [[1.0, 0.0], [0.0, 1.0]]);
}

#[test]
fn set_states_saturates_each_element_to_its_own_range() {
    let mut c = vectors::Controller::new();
    c.set_states(vectors::States {
        theta: [Q29::from_num(1.5), Q29::from_num(1.5)],
        P: [[Q29::from_num(-0.5); 2]; 2],
    });
    let s = c.states();
    // theta[0] ∈ [-2, 2] keeps 1.5; theta[1] ∈ [-1, 1] saturates to 1.
    assert_eq!(s.theta, [Q29::from_num(1.5), Q29::from_num(1.0)]);
    // The diagonal is declared [0, 2], the off-diagonal [-1, 1].
    assert_eq!(
        s.P,
        [
            [Q29::from_num(0.0), Q29::from_num(-0.5)],
            [Q29::from_num(-0.5), Q29::from_num(0.0)]
        ]
    );
}

fn state_raw(p: &Plan) -> Vec<(i128, i128)> {
    p.prog
        .ids_of(SigKind::State)
        .map(|id| p.raw_bounds(id).unwrap())
        .collect()
}

fn states_strategy() -> impl Strategy<Value = Vec<i32>> {
    let b = state_raw(plan());
    b.into_iter()
        .map(|(lo, hi)| (lo as i32)..=(hi as i32))
        .collect::<Vec<_>>()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(3000)))]

    #[test]
    fn reference_is_the_algorithm_written_with_loops(
        phi0 in -1.5f64..1.5, phi1 in -1.5f64..1.5, y in -5.0f64..5.0,
        t0 in -2.0f64..2.0, t1 in -1.0f64..1.0,
        p00 in 0.0f64..2.0, p01 in -1.0f64..1.0, p10 in -1.0f64..1.0, p11 in 0.0f64..2.0,
    ) {
        let mut r = vectors_ref::Reference::new();
        r.set_states(vectors_ref::States { theta: [t0, t1], P: [[p00, p01], [p10, p11]] });
        let o = r.step(vectors_ref::Inputs { phi: [phi0, phi1], y });
        let s = r.states();
        let got = [
            s.theta[0], s.theta[1], s.P[0][0], s.P[0][1], s.P[1][0], s.P[1][1],
            o.yhat, o.dtheta[0], o.dtheta[1],
        ];
        let want = plain([phi0, phi1], y, [t0, t1], [[p00, p01], [p10, p11]]);
        prop_assert_eq!(got, want);
    }

    #[test]
    fn generated_matches_interpreter(
        phi0 in any::<i32>(), phi1 in any::<i32>(), y in any::<i32>(), st in states_strategy(),
    ) {
        let p = plan();
        let mut c = vectors::Controller::new();
        c.set_states(vectors::States {
            theta: [Q29::from_bits(st[0]), Q29::from_bits(st[1])],
            P: [
                [Q29::from_bits(st[2]), Q29::from_bits(st[3])],
                [Q29::from_bits(st[4]), Q29::from_bits(st[5])],
            ],
        });
        let mut c2 = c;
        let o = c.step(vectors::Inputs {
            phi: [Q30::from_bits(phi0), Q30::from_bits(phi1)],
            y: Q28::from_bits(y),
        });
        let ob = c2.step_bits([phi0.into(), phi1.into(), y.into()]);
        prop_assert_eq!(c.state_bits(), c2.state_bits());

        let mut v = vec![0i128; p.prog.signals.len()];
        for (k, id) in p.prog.ids_of(SigKind::Input).enumerate() {
            v[id.0] = [phi0, phi1, y][k].into();
        }
        for (k, id) in p.prog.ids_of(SigKind::State).enumerate() {
            v[id.0] = st[k].into();
        }
        let r = step_fixed(p, &mut v);
        prop_assert!(r.is_ok(), "range analysis violated: {:?}", r);
        let states: Vec<i128> = p.prog.ids_of(SigKind::State).map(|id| v[id.0]).collect();
        let got: Vec<i128> = c.state_bits().iter().map(|&x| x.into()).collect();
        prop_assert_eq!(got, states);
        let outs: Vec<i128> = p.prog.ids_of(SigKind::Output).map(|id| v[id.0]).collect();
        prop_assert_eq!(
            vec![i128::from(o.yhat.to_bits()), o.dtheta[0].to_bits().into(), o.dtheta[1].to_bits().into()],
            outs.clone()
        );
        prop_assert_eq!(ob.iter().map(|&x| i128::from(x)).collect::<Vec<_>>(), outs);
        prop_assert_eq!(v[sig(p, "dtheta_1").0], i128::from(o.dtheta[1].to_bits()));
    }

    #[test]
    fn within_bound_of_real_arithmetic(
        phi0 in -1_073_741_824i32..=1_073_741_824, phi1 in -1_073_741_824i32..=1_073_741_824,
        y in any::<i32>(), st in states_strategy(),
    ) {
        let case = qloop_tests::cases::Case {
            inputs: vec![phi0.into(), phi1.into(), y.into()],
            states: st.iter().map(|&x| x.into()).collect(),
        };
        let r = qloop_tests::claims::check(plan(), &case);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }
}
