//! Recursive least squares of three parameters (tests/rls3.qloop), division-free, with a
//! covariance whose positive definiteness is proved:
//!
//! * proof: every obligation, the three leading principal minors of P among them (Sylvester's
//!   criterion), is proved by both solvers;
//! * meaning: the compiled fixed-point estimator, fed a persistently exciting regressor and
//!   the output of a known parameter vector, follows the textbook RLS (written here in f64,
//!   with its division) step by step, and both converge to the true parameters;
//! * the mechanism: along the run P stays symmetric with positive leading minors, and the
//!   reset never fires on well-excited data (the clamps and the reset do not distort the
//!   estimator where it is healthy).

use fixed::types::extra::{U27, U30};
use fixed::FixedI32;
use qloop::Plan;
use qloop_tests::rls::{regressors, Rls};

qloop_macros::controller!("tests/rls3.qloop");

fn plan() -> Plan {
    qloop::compile_str(include_str!("rls3.qloop"), &qloop::Target::default())
        .expect("rls3.qloop compiles")
}

/// 1/λ of the spec.
const LAMBDA_INV: f64 = 1.0625;
/// The parameters the data come from.
const THETA: [f64; 3] = [1.5, -0.75, 0.5];

#[test]
fn every_obligation_and_the_positive_definiteness_are_proved_by_both_solvers() {
    let r = qloop_tests::assert_proved(&plan(), 60_000, &[]);
    for inv in [
        "covariance_symmetric",
        "covariance_minor_2",
        "covariance_determinant",
    ] {
        qloop_tests::assert_proved_by_each_solver(&r, &format!("invariant {inv} is inductive"));
    }
}

#[test]
fn the_fixed_point_estimator_follows_textbook_rls_to_the_true_parameters() {
    let mut c = rls3::Controller::new();
    let mut reference = Rls::<3>::new(4.0, LAMBDA_INV);
    let phis = regressors::<3>(0x2545_f491_4f6c_dd1d, 400);
    let mut worst: f64 = 0.0;
    for (n, phi) in phis.iter().enumerate() {
        let q: [FixedI32<U30>; 3] = phi.map(FixedI32::<U30>::from_num);
        let phi_q = q.map(|x| x.to_num::<f64>());
        let y = (0..3).map(|i| THETA[i] * phi_q[i]).sum::<f64>();
        let y_q = FixedI32::<U27>::from_num(y);
        c.step(rls3::Inputs { phi: q, y: y_q });
        reference.step(phi_q, y_q.to_num::<f64>());
        let s = c.states();
        let pm: [[f64; 3]; 3] = s.P.map(|row| row.map(|x| x.to_num::<f64>()));
        // The mechanism: symmetric, leading minors positive, never reset (a reset puts
        // P[0][0] back at 4 with zeros off the diagonal).
        let m2 = pm[0][0] * pm[1][1] - pm[0][1] * pm[1][0];
        let det = pm[0][0] * (pm[1][1] * pm[2][2] - pm[1][2] * pm[2][1])
            - pm[0][1] * (pm[1][0] * pm[2][2] - pm[1][2] * pm[2][0])
            + pm[0][2] * (pm[1][0] * pm[2][1] - pm[1][1] * pm[2][0]);
        assert!(pm[0][1] == pm[1][0] && pm[0][2] == pm[2][0] && pm[1][2] == pm[2][1]);
        assert!(pm[0][0] > 0.0 && m2 > 0.0 && det > 0.0, "step {n}: {pm:?}");
        if n > 0 {
            assert!(
                pm[0][0] < 4.0 || pm[0][1] != 0.0,
                "step {n}: P was reset: {pm:?}"
            );
        }
        for i in 0..3 {
            let th = s.theta[i].to_num::<f64>();
            worst = worst.max((th - reference.theta[i]).abs());
        }
    }
    let th: Vec<f64> = c.states().theta.iter().map(|x| x.to_num::<f64>()).collect();
    // Tolerances: the fixed-point step's per-step error bound (`qloop check`: θ 7.1e-3, a
    // worst case over every state and input) is far above what a healthy run accumulates;
    // 1e-3 against the reference all along, and 1e-4 from the truth at the end, where the
    // noise-free data leave only the rounding of each step (Q(i32, 28) for θ), fail on any
    // wrong sign, index or scale in the generated update.
    assert!(worst < 1e-3, "fixed point and f64 RLS differ by {worst}");
    for i in 0..3 {
        assert!(
            (th[i] - THETA[i]).abs() < 1e-4,
            "theta[{i}] = {} after 400 steps, true {}",
            th[i],
            THETA[i]
        );
        assert!((reference.theta[i] - THETA[i]).abs() < 1e-9);
    }
}
