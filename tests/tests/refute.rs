//! The refutation corpus: every spec in `tests/fixtures/refute/` must be refuted on the
//! obligation its first line names (`// expect-refuted: ...`), and the counterexample must
//! replay in the *compiled* generated code, not only in qloop's interpreter.
//! Needs z3 and cvc5 (`.ci/run` installs them).

use fixed::{FixedI16, FixedI32};
use qloop::prove::{Outcome, Verdict};
use qloop::Plan;
use std::path::PathBuf;

qloop_macros::controller!("fixtures/refute/claimed_range_too_narrow.qloop");
qloop_macros::controller!("fixtures/refute/missing_saturation.qloop");
qloop_macros::controller!("fixtures/refute/c2_too_large.qloop");
qloop_macros::controller!("fixtures/refute/csd_partial_sum.qloop");
qloop_macros::controller!("fixtures/refute/property_sign_error.qloop");
qloop_macros::controller!("fixtures/refute/recip_tracker_gain_too_large.qloop");
qloop_macros::controller!("fixtures/refute/rls_unbounded_covariance.qloop");
qloop_macros::controller!("fixtures/refute/table_claim_too_small.qloop");
qloop_macros::controller!("fixtures/refute/table_claim_cancellation.qloop");
qloop_macros::controller!("fixtures/refute/determinant_bound_too_high.qloop");
qloop_macros::controller!("fixtures/refute/supervisor_switches_early.qloop");
qloop_macros::controller!("fixtures/refute/pole_placement_sign_error.qloop");
qloop_macros::controller!("fixtures/refute/law_check_looser_than_invariant.qloop");
qloop_macros::controller!("fixtures/refute/rule_counter_off_by_one.qloop");
qloop_macros::controller!("fixtures/refute/backoff_factor_at_range_edge.qloop");

fn fixture(name: &str) -> (String, PathBuf) {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/refute")
        .join(format!("{name}.qloop"));
    (std::fs::read_to_string(&p).expect("fixture"), p)
}

/// Proves the fixture and returns its plan and the outcome it must refute.
fn refuted(name: &str) -> (Plan, Outcome) {
    let (src, _) = fixture(name);
    let expect = src
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("// expect-refuted: "))
        .expect("first line names the refuted obligation")
        .to_string();
    let plan = qloop::compile_str(&src, &qloop::Target::default()).expect("fixture compiles");
    let cfg = qloop_tests::both_solvers(20_000);
    let report = qloop::prove::prove(&plan, &cfg, &mut |_| {});
    let table = report.table(&plan);
    let o = report
        .outcomes
        .iter()
        .find(|o| o.ob.name.contains(&expect))
        .unwrap_or_else(|| panic!("{name}: no obligation matching `{expect}`:\n{table}"))
        .clone();
    assert_eq!(
        o.verdict,
        Verdict::Refuted,
        "{name}: `{}`:\n{table}",
        o.ob.name
    );
    assert!(o.cex.is_some(), "{name}: refuted without a counterexample");
    assert!(!report.proved());
    (plan, o)
}

/// The counterexample's raw value of SMT variable `var`.
fn cex(o: &Outcome, var: &str) -> i128 {
    o.cex
        .as_ref()
        .and_then(|c| c.values.iter().find(|(n, ..)| n == var).map(|(_, v, _)| *v))
        .unwrap_or_else(|| panic!("no `{var}` in the counterexample"))
}

/// [`cex`], or `default` when the model does not name `var` (the query left it out).
fn cex_or(o: &Outcome, var: &str, default: i128) -> i128 {
    o.cex
        .as_ref()
        .and_then(|c| c.values.iter().find(|(n, ..)| n == var).map(|(_, v, _)| *v))
        .unwrap_or(default)
}

fn slot(plan: &Plan, name: &str) -> usize {
    plan.prog
        .signals
        .iter()
        .position(|s| s.name == name)
        .expect("signal")
}

#[test]
fn claimed_range_too_narrow_wraps_in_compiled_code() {
    let (_, o) = refuted("claimed_range_too_narrow");
    let (x, y) = (cex(&o, "in_x"), cex(&o, "in_y"));
    let out = claimed_range_too_narrow::Controller::new().step(claimed_range_too_narrow::Inputs {
        x: FixedI16::from_bits(x as i16),
        y: FixedI16::from_bits(y as i16),
    });
    // What the spec means: x - y with both clamped to [-2, 2].
    let clamp = |v: i128| (v.clamp(-16384, 16384)) as f64 / 8192.0;
    let want = clamp(x) - clamp(y);
    let got = out.y_out.to_num::<f64>();
    assert!(
        (got - want).abs() > 1.0,
        "no wrap observed: got {got}, want {want}"
    );
}

#[test]
fn missing_saturation_leaves_its_range_in_compiled_code() {
    let (_, o) = refuted("missing_saturation");
    let mut c = missing_saturation::Controller::new();
    c.set_states(missing_saturation::States {
        s: FixedI16::from_bits(cex(&o, "pre_s") as i16),
    });
    c.step(missing_saturation::Inputs {
        x: FixedI16::from_bits(cex(&o, "in_x") as i16),
    });
    let s = c.states().s.to_num::<f64>();
    assert!(!(-1.0..=1.0).contains(&s), "state stayed in range: {s}");
}

#[test]
fn c2_too_large_breaks_contraction_in_compiled_code() {
    let (plan, o) = refuted("c2_too_large");
    let (km, kc) = (cex(&o, "in_km"), cex(&o, "pre_kc"));
    let mut c = c2_too_large::Controller::new();
    c.set_states(c2_too_large::States {
        kc: FixedI16::from_bits(kc as i16),
    });
    c.step(c2_too_large::Inputs {
        km: FixedI16::from_bits(km as i16),
    });
    let mut pre = vec![0i128; plan.prog.signals.len()];
    pre[slot(&plan, "km")] = km;
    pre[slot(&plan, "kc")] = kc;
    let mut post = pre.clone();
    post[slot(&plan, "kc")] = c.states().kc.to_bits().into();
    assert_eq!(
        qloop::prove::replay::property_holds(&plan, 0, &pre, &post, &[]),
        Some(false)
    );
}

#[test]
fn csd_partial_sum_overflows_in_compiled_code() {
    let (_, o) = refuted("csd_partial_sum");
    let x = cex(&o, "in_x");
    let run = std::panic::catch_unwind(|| {
        csd_partial_sum::Controller::new().step(csd_partial_sum::Inputs {
            x: FixedI32::from_bits(x as i32),
        })
    });
    if cfg!(debug_assertions) {
        // Debug builds check integer overflow: the partial sum 8x overflows i32.
        assert!(run.is_err(), "the partial-sum overflow did not trap");
    }
}

#[test]
fn property_sign_error_is_false_in_compiled_code() {
    let (plan, o) = refuted("property_sign_error");
    let (fc, u) = (cex(&o, "in_fc"), cex(&o, "pre_u"));
    let mut c = property_sign_error::Controller::new();
    c.set_states(property_sign_error::States {
        u: FixedI16::from_bits(u as i16),
    });
    let out = c.step(property_sign_error::Inputs {
        fc: FixedI16::from_bits(fc as i16),
    });
    let mut pre = vec![0i128; plan.prog.signals.len()];
    pre[slot(&plan, "fc")] = fc;
    pre[slot(&plan, "u")] = u;
    let mut post = pre.clone();
    post[slot(&plan, "u")] = c.states().u.to_bits().into();
    post[slot(&plan, "vf")] = out.vf.to_bits().into();
    assert_eq!(
        qloop::prove::replay::property_holds(&plan, 0, &pre, &post, &[]),
        Some(false)
    );
}

#[test]
fn recip_tracker_gain_too_large_diverges_in_compiled_code() {
    let (plan, o) = refuted("recip_tracker_gain_too_large");
    let (x, r) = (cex(&o, "in_x"), cex(&o, "pre_r"));
    let mut c = recip_tracker_gain_too_large::Controller::new();
    c.set_states(recip_tracker_gain_too_large::States {
        r: FixedI16::from_bits(r as i16),
    });
    c.step(recip_tracker_gain_too_large::Inputs {
        x: FixedI16::from_bits(x as i16),
    });
    let mut pre = vec![0i128; plan.prog.signals.len()];
    pre[slot(&plan, "x")] = x;
    pre[slot(&plan, "r")] = r;
    let mut post = pre.clone();
    post[slot(&plan, "r")] = c.states().r.to_bits().into();
    assert_eq!(
        qloop::prove::replay::property_holds(&plan, 0, &pre, &post, &[]),
        Some(false)
    );
}

#[test]
fn rls_unbounded_covariance_leaves_its_range_in_compiled_code() {
    let (_, o) = refuted("rls_unbounded_covariance");
    let mut c = rls_unbounded_covariance::Controller::new();
    // θ does not bear on P's update, so the query leaves it out and the model does not name
    // it: the replay (and this run) takes its initial value.
    let theta = cex_or(&o, "pre_theta", c.states().theta.to_bits().into()) as i16;
    c.set_states(rls_unbounded_covariance::States {
        theta: FixedI16::from_bits(theta),
        p: FixedI16::from_bits(cex(&o, "pre_p") as i16),
    });
    c.step(rls_unbounded_covariance::Inputs {
        phi: FixedI16::from_bits(cex(&o, "in_phi") as i16),
        // y does not bear on P either: the replay's value for an absent input, 0 (in range).
        y: FixedI16::from_bits(cex_or(&o, "in_y", 0) as i16),
    });
    let p = c.states().p.to_num::<f64>();
    assert!(
        !(0.0..=16.0).contains(&p),
        "the covariance stayed in range: {p}"
    );
}

#[test]
fn table_claim_too_small_is_exceeded_by_compiled_code() {
    let (plan, o) = refuted("table_claim_too_small");
    // The counterexample is the table's argument, in units of 2^-40.
    let x = cex(&o, "x") as f64 * 2f64.powi(-40);
    let q = plan.format(plan.prog.ids_of(qloop::ir::SigKind::Input).next().unwrap());
    let raw = q.raw_nearest(x);
    let out = table_claim_too_small::Controller::new().step_bits([raw as i64]);
    let (d, r) = (q.value(raw), out[0] as f64 * 2f64.powi(-30));
    assert!(
        (r - 1.0 / d).abs() > 0.002,
        "|{r} - 1/{d}| within the claim"
    );
}

/// The compiled table of `(v + 1e8)² − 1e16` misses the expression, computed here in exact
/// rationals, by more than the claimed 1e-4 at the counterexample (a segment's midpoint).
#[test]
fn table_claim_cancellation_is_exceeded_by_compiled_code() {
    use num_traits::Signed;
    use qloop_tests::exact::{of_f64, of_raw, Q};
    let (plan, o) = refuted("table_claim_cancellation");
    let x = cex(&o, "x") as f64 * 2f64.powi(-40);
    let ids = |k| plan.prog.ids_of(k).next().unwrap();
    let (qx, qy) = (
        plan.format(ids(qloop::ir::SigKind::Input)),
        plan.format(ids(qloop::ir::SigKind::Output)),
    );
    let raw = qx.raw_nearest(x);
    let out = table_claim_cancellation::Controller::new().step_bits([raw as i64]);
    let v = of_raw(raw, qx.frac);
    let c = Q::from_integer(100_000_000.into());
    let exact = (&v + &c) * (&v + &c) - Q::from_integer(10_000_000_000_000_000i64.into());
    let err = (of_raw(out[0].into(), qy.frac) - exact).abs();
    assert!(err > of_f64(1e-4), "|y - f({x})| = {err} within the claim");
}

/// The reset test accepts a product of at least 1 and the invariant claims 1.0625: from a
/// pre-state inside the invariant, the compiled step stores a pair whose product is below it.
/// (The emitter bug this guards against, two products under one name in the linear
/// envelope, had this invariant "proved".)
#[test]
fn determinant_bound_too_high_is_broken_by_compiled_code() {
    let (_, o) = refuted("determinant_bound_too_high");
    let (a, b) = (cex(&o, "pre_a") as i16, cex(&o, "pre_b") as i16);
    let q12 = |raw: i16| f64::from(raw) / 4096.0;
    assert!(
        q12(a) * q12(b) >= 1.0625,
        "the pre-state is outside the invariant: a = {}, b = {}",
        q12(a),
        q12(b)
    );
    let mut c = determinant_bound_too_high::Controller::new();
    c.set_states(determinant_bound_too_high::States {
        a: FixedI16::from_bits(a),
        b: FixedI16::from_bits(b),
    });
    c.step(determinant_bound_too_high::Inputs {
        x: FixedI16::from_bits(cex(&o, "in_x") as i16),
        // y does not bear on P either: the replay's value for an absent input, 0 (in range).
        y: FixedI16::from_bits(cex_or(&o, "in_y", 0) as i16),
    });
    let s = c.states();
    let (na, nb) = (s.a.to_num::<f64>(), s.b.to_num::<f64>());
    assert!(
        na * nb < 1.0625,
        "the invariant holds after the step: {na} * {nb}"
    );
}

#[test]
fn corpus_is_complete() {
    // Every fixture in the folder has a replay test above.
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/refute");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path().file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "backoff_factor_at_range_edge",
            "c2_too_large",
            "claimed_range_too_narrow",
            "csd_partial_sum",
            "determinant_bound_too_high",
            "law_check_looser_than_invariant",
            "missing_saturation",
            "pole_placement_sign_error",
            "property_sign_error",
            "recip_tracker_gain_too_large",
            "rls_unbounded_covariance",
            "rule_counter_off_by_one",
            "supervisor_switches_early",
            "table_claim_cancellation",
            "table_claim_too_small"
        ]
    );
}

/// A rule's counter with an off-by-one (issue 18, item 6): from the refuting pre-state (the
/// count at N − 1 or more, the load above the limit), the compiled step does not set the hold.
#[test]
fn rule_counter_off_by_one_does_not_trip_in_compiled_code() {
    let (_, o) = refuted("rule_counter_off_by_one");
    let mut c = rule_counter_off_by_one::Controller::new();
    let init = c.states();
    let count = cex_or(&o, "pre_late_count", init.late_count.to_bits().into());
    let held = cex_or(&o, "pre_held", init.held.to_bits().into());
    c.set_states(rule_counter_off_by_one::States {
        u: FixedI16::from_bits(cex_or(&o, "pre_u", init.u.to_bits().into()) as i16),
        held: FixedI16::from_bits(held as i16),
        late_count: FixedI16::from_bits(count as i16),
    });
    let fc = FixedI16::from_bits(cex(&o, "in_fc") as i16);
    c.step(rule_counter_off_by_one::Inputs { fc });
    let s = c.states();
    assert!(fc.to_num::<f64>() > 3.5 && s.late_count.to_num::<f64>() >= 4.0);
    assert!(s.held.to_num::<f64>() < 1.0, "the hold was set");
}

/// A back-off claimed at the range edge (issue 18, item 6): from the refuting pre-state the
/// compiled step falls by less than K · UP = 1/4 mm/s, because the command is within 1/4 of
/// its floor.
#[test]
fn backoff_factor_at_range_edge_falls_short_in_compiled_code() {
    let (_, o) = refuted("backoff_factor_at_range_edge");
    let mut c = backoff_factor_at_range_edge::Controller::new();
    let u0 = cex(&o, "pre_u");
    c.set_states(backoff_factor_at_range_edge::States {
        u: FixedI16::from_bits(u0 as i16),
    });
    let fc = FixedI16::from_bits(cex(&o, "in_fc") as i16);
    c.step(backoff_factor_at_range_edge::Inputs { fc });
    let (before, after) = (
        FixedI16::<fixed::types::extra::U12>::from_bits(u0 as i16).to_num::<f64>(),
        c.states().u.to_num::<f64>(),
    );
    assert!(fc.to_num::<f64>() > 2.0);
    assert!(
        after > before - 0.25,
        "fell {} from {before}",
        before - after
    );
    assert!(before < 0.05 + 0.25, "not at the edge: {before}");
}

/// The supervisor with an off-by-one in its residence test (issue 17): from the refuting
/// pre-state, the compiled step switches with fewer than N_R = 2 periods since the last
/// switch.
#[test]
fn supervisor_switching_early_switches_early_in_compiled_code() {
    use fixed::types::extra::{U0, U24};
    use fixed::FixedU8;
    let (_, o) = refuted("supervisor_switches_early");
    let mut c = supervisor_switches_early::Controller::new();
    let init = c.states();
    let hist: [[FixedI32<U24>; 8]; 7] = std::array::from_fn(|l| {
        std::array::from_fn(|j| {
            let v = cex_or(
                &o,
                &format!("pre_hist_{l}_{j}"),
                init.hist[l][j].to_bits().into(),
            );
            FixedI32::<U24>::from_bits(v as i32)
        })
    });
    let active = cex_or(&o, "pre_active", init.active.to_bits().into()) as u8;
    let since = cex_or(&o, "pre_since", init.since.to_bits().into()) as u8;
    c.set_states(supervisor_switches_early::States {
        hist,
        active: FixedU8::<U0>::from_bits(active),
        since: FixedU8::<U0>::from_bits(since),
    });
    let e2: [FixedI32<U24>; 7] = std::array::from_fn(|l| {
        FixedI32::<U24>::from_bits(cex_or(&o, &format!("in_e2_{l}"), 0) as i32)
    });
    c.step(supervisor_switches_early::Inputs { e2 });
    let after = c.states().active.to_bits();
    assert!(
        after != active && since < 2,
        "no early switch: active {active} -> {after}, since {since}"
    );
}

/// A pole placement with a sign error in its equation (issue 17; `− b1·s0` in the check and
/// the claim): the compiled controller's initial law places the poles (the correct equation
/// holds within TOL) and so breaks the claim, which the prover refutes on the initial state.
#[test]
fn pole_placement_sign_error_is_broken_by_the_compiled_initial_law() {
    let (_, o) = refuted("pole_placement_sign_error");
    assert!(o.ob.name.contains("holds initially"), "{}", o.ob.name);
    let s = pole_placement_sign_error::Controller::new().states();
    let f = |x: FixedI32<fixed::types::extra::U28>| x.to_num::<f64>();
    let g = |x: FixedI32<fixed::types::extra::U24>| x.to_num::<f64>();
    let (la1, lb1, r1, s0) = (f(s.la1), f(s.lb1), g(s.r1), g(s.s0));
    const M1: f64 = -0.9012686441554565;
    const TOL: f64 = 0.0009765625;
    assert!((r1 + la1 + lb1 * s0 - M1).abs() <= TOL, "the law is wrong");
    assert!(
        (r1 + la1 - lb1 * s0 - M1).abs() > TOL,
        "the sign error holds"
    );
}

/// A law stored under a check twice as loose as its invariant (issue 17's split encoding must
/// not prove it): from the refuting pre-state (inside the invariant) the compiled step stores
/// a law whose residual |law + model − TARGET| exceeds TOL.
#[test]
fn a_law_check_looser_than_its_invariant_stores_a_law_outside_it() {
    use fixed::types::extra::{U24, U28};
    let (_, o) = refuted("law_check_looser_than_invariant");
    let mut c = law_check_looser_than_invariant::Controller::new();
    let init = c.states();
    let law = cex_or(&o, "pre_law", init.law.to_bits().into()) as i32;
    let model = cex_or(&o, "pre_model", init.model.to_bits().into()) as i32;
    c.set_states(law_check_looser_than_invariant::States {
        law: FixedI32::<U24>::from_bits(law),
        model: FixedI32::<U28>::from_bits(model),
    });
    c.step(law_check_looser_than_invariant::Inputs {
        a1: FixedI32::<U28>::from_bits(cex_or(&o, "in_a1", 0) as i32),
        n1: FixedI32::<U24>::from_bits(cex_or(&o, "in_n1", 0) as i32),
    });
    let s = c.states();
    let residual = (s.law.to_num::<f64>() + s.model.to_num::<f64>() + 0.90625).abs();
    assert!(
        residual > 0.0009765625,
        "the invariant holds after the step: residual {residual}"
    );
}
