//! The reciprocal tracker `recip_track(r, x, G);` (the 1981 division-free loop,
//! 000_b8cbacf29caa8fe2.txt eqs. 12-13 with K = 1): its generated contraction property is
//! proved by both solvers on the generated code; the compiled tracker converges to 1/x as the
//! geometric series of that property says; and the checker refuses a gain that does not
//! contract, a range that does not hold 1/x, and an `x` that changes after the tracker read
//! it, each at its place. (The same gain written out by hand is refuted by the prover:
//! tests/fixtures/refute/recip_tracker_gain_too_large.qloop.)

use fixed::FixedI16;
use qloop::Plan;

qloop_macros::controller!("tests/tracker.qloop");

fn plan() -> Plan {
    qloop::compile_str(include_str!("tracker.qloop"), &qloop::Target::default())
        .expect("tracker.qloop compiles")
}

#[test]
fn the_contraction_property_is_generated_and_proved() {
    let p = plan();
    let t = &p.prog.tracks[0];
    assert_eq!(t.property, "recip_track_kinv");
    // max |1 - G*x| over [0.25, 6] with G = 1/4: at x = 0.25, 1 - 1/16.
    assert_eq!(t.rho, 0.9375);
    assert!(t.claimed_rho > t.rho && t.claimed_rho < 0.94);
    let report = qloop::report::check_report(&p, "tracker.qloop");
    assert!(report.contains("kinv -> 1/km"), "{report}");
    let cfg = qloop_tests::both_solvers(60_000);
    let r = qloop::prove::prove(&p, &cfg, &mut |_| {});
    assert!(r.proved(), "{}", r.table(&p));
    assert!(r
        .outcomes
        .iter()
        .any(|o| o.ob.name.contains("recip_track_kinv")));
}

#[test]
fn the_compiled_tracker_converges_as_its_property_says() {
    let p = plan();
    let t = p.prog.tracks[0].clone();
    let km_q = p.format(p.prog.ids_of(qloop::ir::SigKind::Input).next().unwrap());
    for km in [0.25, 0.5, 1.0, 1.7, 3.0, 4.5, 6.0] {
        let raw = km_q.raw_floor(km) as i16;
        let x = km_q.value(raw.into());
        let mut c = tracker::Controller::new();
        let mut e0 = None;
        for n in 1..=400 {
            let out = c.step(tracker::Inputs {
                km: FixedI16::from_bits(raw),
            });
            let r = out.gain.to_num::<f64>();
            let e = (1.0 - x * r).abs();
            let start = *e0.get_or_insert((1.0 - x * 1.0f64).abs());
            // |e_n| <= rho'^n |e_0| + eps/(1 - rho'): the property, applied n times.
            let bound = t.claimed_rho.powi(n) * start + t.eps / (1.0 - t.claimed_rho);
            assert!(
                e <= bound + 1e-12,
                "km = {km}, step {n}: |1 - x*r| = {e} > {bound}"
            );
        }
        let r = c.states().kinv.to_num::<f64>();
        assert!(
            (1.0 - x * r).abs() <= 2.0 * t.eps / (1.0 - t.claimed_rho),
            "km = {km}: r = {r} after 400 steps, 1/x = {}",
            1.0 / x
        );
    }
}

/// The error message and line:col of compiling `src`.
fn err(src: &str) -> (String, usize, usize) {
    let d = qloop::compile_str(src, &qloop::Target::default())
        .err()
        .unwrap_or_else(|| panic!("accepted:\n{src}"));
    let (l, c) = d.line_col();
    (d.message, l, c)
}

#[test]
fn refusals_name_the_place() {
    let head = "controller t {\n    period 10 \"ms\";\n    input km: [0.25, 6.0];\n    state r: [0.125, 5.0] = 1.0;\n    state s: [0.5, 2.0] = 1.0;\n    output y;\n";
    let cases: &[(&str, &str, usize, usize)] = &[
        (
            "step { recip_track(r, km, 0.5); y = r; }",
            "the tracker does not contract: |1 - G·x| reaches 2",
            7,
            31,
        ),
        (
            "step { recip_track(s, km, 0.25); y = s; }",
            "does not hold 1/x for every x in [0.25, 6]",
            7,
            24,
        ),
        (
            "step { recip_track(r, km, 0.25); km = 1.0; y = r; }",
            "input `km` is read-only",
            7,
            38,
        ),
        (
            "step { let k = km; recip_track(r, k, 0.25); y = r; }",
            "`x` must be an input or a state",
            7,
            39,
        ),
        (
            "step { recip_track(y, km, 0.25); y = r; }",
            "the tracker `r` must be a state",
            7,
            24,
        ),
        (
            "step { recip_track(r, s, 0.25); s = km * 0.25; y = r; }",
            "`s` is assigned after the tracker that reads it",
            7,
            12,
        ),
    ];
    for (step, msg, line, col) in cases {
        let (m, l, c) = err(&format!("{head}    {step}\n}}\n"));
        assert!(m.contains(msg), "{step}: got `{m}`");
        assert_eq!((l, c), (*line, *col), "{step}: {m}");
    }
}
