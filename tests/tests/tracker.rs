//! The reciprocal tracker `recip_track(r, x, G);` (the 1981 division-free loop,
//! Koren & Masory (1981), eqs. 12-13 with K = 1): its generated contraction property is
//! proved by both solvers on the generated code; the compiled tracker converges to 1/x as the
//! geometric series of that property says; and the checker refuses a gain that does not
//! contract, a range that does not hold 1/x, an `x` assigned both before and after the
//! tracker, and a branch condition its property cannot state, each at its place. A tracker
//! that reads its `x` before the step assigns it, after, or inside an `if` is proved too. (The same gain written out by hand is refuted by the prover:
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
            "step { s = km * 0.25; recip_track(r, s, 0.25); s = km * 0.5; y = r; }",
            "`s` is assigned both before and after the tracker that reads it",
            7,
            27,
        ),
        (
            "step { let big = km * 0.5; if big > 1.0 { recip_track(r, km, 0.25); } y = r; }",
            "cannot state the condition of the `if` around it (line 7): `big` is a `let` inside `step`",
            7,
            47,
        ),
        (
            "step { s = km * 0.25; if s > 1.0 { recip_track(r, km, 0.25); } y = r; }",
            "(line 7): it reads `s` after the step has assigned it",
            7,
            40,
        ),
    ];
    for (step, msg, line, col) in cases {
        let (m, l, c) = err(&format!("{head}    {step}\n}}\n"));
        assert!(m.contains(msg), "{step}: got `{m}`");
        assert_eq!((l, c), (*line, *col), "{step}: {m}");
    }
}

/// A tracker of an estimate `theta` that the step updates (least-mean-squares on y = θ·u):
/// `recip_track` before the update or after it, inside `branch` (an `if` header) if given.
fn estimator(track_first: bool, branch: Option<&str>) -> String {
    let update = "theta += 0.125 * u * (y - theta * u);".to_string();
    let mut track = "recip_track(kinv, theta, 0.25);".to_string();
    if let Some(b) = branch {
        track = format!("{b} {{ {track} }}");
    }
    let (a, b) = if track_first {
        (track, update)
    } else {
        (update, track)
    };
    format!(
        "controller est {{
    period 10 \"ms\";
    word 16;
    input u: [0.1, 1.0];
    input y: [0.0, 4.0];
    input on: [0.0, 1.0];
    state theta: [0.5, 4.0] = 1.0;
    state kinv: [0.25, 2.0] = 1.0;
    output g;
    step {{
        {a}
        {b}
        g = kinv;
    }}
}}
"
    )
}

/// Proves `src` with both solvers (15 s a query) and returns the tracker property's row of
/// the table.
fn proved_tracker(src: &str) -> String {
    let p = qloop::compile_str(src, &qloop::Target::default())
        .unwrap_or_else(|d| panic!("{}\n{src}", d.message));
    let table = qloop_tests::assert_proved(&p, 15_000, &["recip_track_kinv"]).table(&p);
    table
        .lines()
        .find(|l| l.contains("recip_track_kinv"))
        .unwrap_or_else(|| panic!("no row for the tracker's property:\n{table}"))
        .to_string()
}

#[test]
fn a_tracker_before_or_after_the_update_of_its_value_is_proved() {
    // Before: it reads theta before the step, and its property says `theta`.
    proved_tracker(&estimator(true, None));
    // After: its property says `next(theta)`, proved over theta's range whatever the
    // estimator's products computed (cvc5 timed out on the whole step's encodings).
    let row = proved_tracker(&estimator(false, None));
    assert!(row.contains("cut at the tracked value"), "{row}");
}

#[test]
fn a_tracker_inside_an_if_assumes_its_branch() {
    for branch in ["if on > 0.5", "if !(on > 0.5 && u < 0.5)"] {
        let src = estimator(false, Some(branch));
        let p = qloop::compile_str(&src, &qloop::Target::default()).expect("compiles");
        let prop = p
            .prog
            .properties
            .iter()
            .find(|q| q.name == "recip_track_kinv")
            .expect("the tracker's property");
        assert_eq!(prop.assumes.len(), 1, "{branch}: {:?}", prop.assumes);
        proved_tracker(&src);
    }
    // In `else`, the negation; a boolean `let` stands for its condition.
    let src = estimator(false, Some("let off = on <= 0.5; if off { } else"));
    proved_tracker(&src);
    // Without its assumption the property is false (the branch not taken leaves kinv as it
    // was, which contracts nothing): the prover refutes it.
    let mut p = qloop::compile_str(
        &estimator(false, Some("if on > 0.5")),
        &qloop::Target::default(),
    )
    .expect("compiles");
    for q in &mut p.prog.properties {
        q.assumes.clear();
    }
    let r = qloop::prove::prove_filtered(
        &p,
        &qloop_tests::both_solvers(15_000),
        Some("recip_track_kinv"),
        &mut |_| {},
    );
    assert!(!r.proved(), "{}", r.table(&p));
}
