//! The nonlinear program's answers against independent ones: the closed-form vertex where
//! both constraints are active, and a second solver (COBYLA, derivative-free, from the
//! `cobyla` crate) on biased models.

use qloop_aco::rcb::optimum;
use qloop_aco::turning::{
    Constants, Settings, BOUNDS, DEPTH_MM, FIRST_CYCLE, LIMITS, NOMINAL, RA_DEPTH_EXP, RA_SPEED_EXP,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Where P = p and Ra = r (both active): P − k6 = k7·d·f^u·v/60 Koren & Masory (1981) gives v = A·f^−u, and
/// then Ra = k9·f^a·v^e·d^0.25 (e = −1.52) gives f^(a + e·(−u)) = r/(k9·d^0.25·A^e).
fn vertex(k: &Constants, p: f64, r: f64) -> Settings {
    let [_, _, _, _, _, p0, ks, u, kr, a] = k.k;
    let big_a = (p - p0) * 60_000.0 / (ks * DEPTH_MM);
    let e = RA_SPEED_EXP;
    let f = (r / (kr * DEPTH_MM.powf(RA_DEPTH_EXP) * big_a.powf(e))).powf(1.0 / (a - e * u));
    Settings {
        v: big_a * f.powf(-u),
        f,
    }
}

/// On the nominal model, the optimum sits at the vertex of both constraints, at the limits
/// and at the ceilings where RCB₂ with c = 0.5 settles (limits/1.2).
#[test]
fn optimum_is_the_closed_form_vertex() {
    for scale in [1.0, 1.2] {
        let ceiling = [LIMITS[0] / scale, LIMITS[1] / scale];
        let o = optimum(&NOMINAL, ceiling, FIRST_CYCLE).unwrap();
        let x = vertex(&NOMINAL, ceiling[0], ceiling[1]);
        println!(
            "ceiling {ceiling:?}: NLP {:?}, vertex {x:?}, {:.3} s",
            o.x, o.value
        );
        assert!((o.x[0] / x.v - 1.0).abs() < 1e-6, "{o:?} {x:?}");
        assert!((o.x[1] / x.f - 1.0).abs() < 1e-6, "{o:?} {x:?}");
    }
}

/// SLSQP against COBYLA on 20 biased models: the same optimal time to 1e-5, relative.
#[test]
fn slsqp_agrees_with_cobyla() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let k = NOMINAL.biased(0.1, &mut rng);
        let s = optimum(&k, LIMITS, FIRST_CYCLE).unwrap();
        let set = |x: &[f64]| Settings { v: x[0], f: x[1] };
        let obj = |x: &[f64], _: &mut ()| k.cycle_time(set(x));
        let c0 = |x: &[f64], _: &mut ()| LIMITS[0] - k.power(set(x));
        let c1 = |x: &[f64], _: &mut ()| LIMITS[1] - k.roughness(set(x));
        let cons: Vec<&dyn cobyla::Func<()>> = vec![&c0, &c1];
        let tol = cobyla::StopTols {
            ftol_rel: 1e-12,
            ..Default::default()
        };
        let ((), x, t) = match cobyla::minimize(
            obj,
            &[FIRST_CYCLE.v, FIRST_CYCLE.f],
            &BOUNDS,
            &cons,
            (),
            5000,
            cobyla::RhoBeg::Set(vec![5.0, 0.02]),
            Some(tol),
        ) {
            Ok((_, x, t)) => ((), x, t),
            // Its last iterate, when the final test fails by rounding; checked below.
            Err((cobyla::FailStatus::RoundoffLimited, x, t)) => ((), x, t),
            Err((status, x, t)) => panic!("COBYLA: {status:?} at {x:?} ({t})"),
        };
        let infeasible =
            k.power(set(&x)) - LIMITS[0] > 1e-6 || k.roughness(set(&x)) - LIMITS[1] > 1e-6;
        assert!(!infeasible, "COBYLA's point is infeasible: {x:?}");
        assert!(
            (s.value / t - 1.0).abs() < 1e-5,
            "SLSQP {} at {:?}, COBYLA {t} at {x:?}",
            s.value,
            s.x
        );
    }
}
