//! Per-element formats (issue 37, item 1), on tests/elements.qloop: vectors.qloop's estimator
//! with each element of φ, θ, P and dθ pinned to a format of its own, in 16- and 32-bit words.
//!
//! * the plan gives each element its own format, the structs store a vector in its widest
//!   element's word, and the Rust API carries it in one format holding every element exactly;
//! * the generated Rust (`controller!`), through its `fixed` API and through `step_bits`,
//!   computes bit for bit what the plan interpreter computes, from random states in bounds and
//!   random raw inputs; `states` and `set_states` convert exactly, and `set_states` drops the
//!   fraction bits an element does not have (toward −∞) and saturates to its range;
//! * the C of every built-in target compiles without a warning and matches the interpreter
//!   bit for bit; its header has a `_FRAC` per element; Frama-C Eva finds no alarm;
//! * the LinuxCNC component's controller and glue match the interpreter;
//! * every obligation is proved on host and the ATmega328P, each by both solvers but the
//!   property `zero_error_keeps_theta`, which cvc5 does not prove in time (the SMT encoding's
//!   agreement with the interpreter is smt_differential.rs's).

use fixed::types::extra::{U13, U14, U29, U30};
use fixed::{FixedI16, FixedI32};
use proptest::prelude::*;
use qloop::interp::step_fixed;
use qloop::ir::SigKind;
use qloop::Plan;
use qloop_tests::c_harness::{self, Rng};
use qloop_tests::{scratch, sig, tool};

qloop_macros::controller!("tests/elements.qloop");

const SPEC: &str = include_str!("elements.qloop");

fn plan_for(target: &str) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    qloop::compile_str(SPEC, &t).unwrap_or_else(|e| panic!("elements.qloop for {target}: {e}"))
}

thread_local! {
    static PLAN: &'static Plan = Box::leak(Box::new(
        qloop::compile_str(SPEC, &qloop::Target::default()).expect("elements.qloop compiles"),
    ));
}

fn plan() -> &'static Plan {
    PLAN.with(|p| *p)
}

#[test]
fn each_element_keeps_its_own_format() {
    let p = plan();
    let f = |n: &str| p.format(sig(p, n)).to_string();
    for (n, want) in [
        ("phi_0", "Q(i16, 14)"),
        ("phi_1", "Q(i32, 30)"),
        ("theta_0", "Q(i16, 13)"),
        ("theta_1", "Q(i32, 29)"),
        ("P_0_0", "Q(i32, 29)"),
        ("P_0_1", "Q(i16, 14)"),
        ("P_1_0", "Q(i16, 14)"),
        ("P_1_1", "Q(i32, 29)"),
        ("dtheta_0", "Q(i16, 14)"),
        ("dtheta_1", "Q(i32, 30)"),
    ] {
        assert_eq!(f(n), want, "{n}");
    }
    let theta = p.group_of(sig(p, "theta_0"));
    assert_eq!(p.group_storage(&theta).to_string(), "i32");
    assert_eq!(
        p.group_api_format(&theta).map(|q| q.to_string()).as_deref(),
        Some("Q(i32, 29)")
    );
}

#[test]
fn the_api_carries_each_element_exactly() {
    let mut c = elements::Controller::new();
    let s = c.states();
    // θ = [0.5, 0]: θ[0] is Q(i16, 13), carried as Q(i32, 29).
    let _: [FixedI32<U29>; 2] = s.theta;
    let _: [[FixedI32<U29>; 2]; 2] = s.P;
    assert_eq!(
        s.theta,
        [FixedI32::<U29>::from_num(0.5), FixedI32::from_num(0)]
    );
    // Every value an element holds crosses the API unchanged.
    let th0 = FixedI16::<U13>::from_bits(-12_345);
    let p01 = FixedI16::<U14>::from_bits(9_999);
    let mut want = s;
    want.theta = [FixedI32::from_num(th0), FixedI32::from_bits(-123_456_789)];
    want.P[0][1] = FixedI32::from_num(p01);
    c.set_states(want);
    assert_eq!(c.states(), want);
    let bits = c.state_bits();
    assert_eq!(bits[0], -12_345, "θ[0] as its own raw bits");
    assert_eq!(bits[1], -123_456_789, "θ[1] as its own raw bits");
    assert_eq!(bits[3], 9_999, "P[0][1] as its own raw bits");
}

#[test]
fn set_states_floors_to_an_element_s_own_lsb_and_saturates_to_its_range() {
    let mut c = elements::Controller::new();
    let mut s = c.states();
    // θ[0] has 13 fraction bits: 2^-29 below 0.25 floors to 0.25 − 2^-13, and 2^-29 above
    // it to 0.25. θ[1] ∈ [−1, 1] saturates 1.5 to 1.
    let lsb = FixedI32::<U29>::from_bits(1);
    let q = FixedI32::<U29>::from_num(0.25);
    s.theta = [q - lsb, FixedI32::from_num(1.5)];
    c.set_states(s);
    let t = c.states().theta;
    assert_eq!(
        t[0],
        q - FixedI32::<U29>::from_num(FixedI16::<U13>::from_bits(1))
    );
    assert_eq!(t[1], FixedI32::<U29>::from_num(1));
    s.theta[0] = q + lsb;
    // P[0][1] ∈ [−1, 1]: −3.5 saturates to −1.
    s.P[0][1] = FixedI32::from_num(-3.5);
    c.set_states(s);
    assert_eq!(c.states().theta[0], q);
    assert_eq!(c.states().P[0][1], FixedI32::<U29>::from_num(-1));
}

fn states_strategy() -> impl Strategy<Value = Vec<i64>> {
    let p = plan();
    p.prog
        .ids_of(SigKind::State)
        .map(|id| {
            let (lo, hi) = p.raw_bounds(id).expect("ranged");
            (lo as i64)..=(hi as i64)
        })
        .collect::<Vec<_>>()
}

fn inputs_strategy() -> impl Strategy<Value = Vec<i64>> {
    let p = plan();
    p.prog
        .ids_of(SigKind::Input)
        .map(|id| {
            let t = p.format(id).ty;
            (t.min() as i64)..=(t.max() as i64)
        })
        .collect::<Vec<_>>()
}

/// Raw bits of one element into its API value (exact: the API format holds it).
fn api32<const F: u32>(raw: i64, frac: i32) -> i64 {
    raw << (F as i32 - frac)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(3000)))]

    #[test]
    fn generated_matches_interpreter(st in states_strategy(), inp in inputs_strategy()) {
        let p = plan();
        let mut c = elements::Controller::new();
        let f = |n: &str| p.format(sig(p, n)).frac;
        c.set_states(elements::States {
            theta: [
                FixedI32::from_bits(api32::<29>(st[0], f("theta_0")) as i32),
                FixedI32::from_bits(api32::<29>(st[1], f("theta_1")) as i32),
            ],
            P: [
                [
                    FixedI32::from_bits(api32::<29>(st[2], f("P_0_0")) as i32),
                    FixedI32::from_bits(api32::<29>(st[3], f("P_0_1")) as i32),
                ],
                [
                    FixedI32::from_bits(api32::<29>(st[4], f("P_1_0")) as i32),
                    FixedI32::from_bits(api32::<29>(st[5], f("P_1_1")) as i32),
                ],
            ],
        });
        prop_assert_eq!(c.state_bits().to_vec(), st.clone());
        let mut c2 = c;
        let o = c.step(elements::Inputs {
            phi: [
                FixedI32::<U30>::from_bits(api32::<30>(inp[0], f("phi_0")) as i32),
                FixedI32::<U30>::from_bits(api32::<30>(inp[1], f("phi_1")) as i32),
            ],
            y: FixedI32::from_bits(inp[2] as i32),
        });
        let ob = c2.step_bits([inp[0], inp[1], inp[2]]);
        prop_assert_eq!(c.state_bits(), c2.state_bits());

        let mut v = vec![0i128; p.prog.signals.len()];
        for (k, id) in p.prog.ids_of(SigKind::Input).enumerate() {
            v[id.0] = inp[k].into();
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
        prop_assert_eq!(ob.iter().map(|&x| i128::from(x)).collect::<Vec<_>>(), outs.clone());
        // The API's outputs: dθ[0] (Q(i16, 14)) carried as Q(i32, 30).
        prop_assert_eq!(
            i128::from(o.dtheta[0].to_bits()),
            outs[1] << (30 - f("dtheta_0"))
        );
        prop_assert_eq!(i128::from(o.dtheta[1].to_bits()), outs[2]);
        prop_assert_eq!(i128::from(o.yhat.to_bits()), outs[0]);
    }
}

#[test]
fn fixed_c_stores_wide_words_and_a_frac_per_element() {
    let (h, c) = qloop::gen_c(&plan_for("host"));
    for want in [
        "    int32_t theta[2]; /* state: theta[0] [-2, 2] Q(i16, 13), theta[1] [-1, 1] Q(i32, 29) ",
        "#define ELEMENTS_THETA_FRAC_0 13\n",
        "#define ELEMENTS_THETA_FRAC_1 29\n",
        "#define ELEMENTS_P_FRAC_0_1 14\n",
        "#define ELEMENTS_Y_FRAC 28\n",
        "#define ELEMENTS_THETA_0_MIN ((int16_t)-16384)\n",
    ] {
        assert!(h.contains(want), "no `{want}` in the header:\n{h}");
    }
    assert!(
        !h.contains("ELEMENTS_THETA_FRAC "),
        "one FRAC for elements of two formats"
    );
    for want in [
        "    int16_t theta_0 = (int16_t)self->theta[0];\n",
        "    int32_t theta_1 = self->theta[1];\n",
        "    self->theta[0] = theta_0;\n",
        "in->phi[0] < ((int32_t)-32768) ? ((int32_t)-32768) : (in->phi[0] > ((int32_t)32767)",
    ] {
        assert!(c.contains(want), "no `{want}` in the source:\n{c}");
    }
}

#[test]
fn fixed_c_compiles_without_warnings_for_every_target() {
    for t in qloop::targets::builtin() {
        let Some(cc) = t.toolchain.cc.as_deref().and_then(tool) else {
            continue;
        };
        let dir = scratch(&format!("c-elements-warn-{}", t.name));
        c_harness::warning_free(&plan_for(&t.name), &cc, &dir);
    }
}

#[test]
fn fixed_c_matches_the_interpreter_bit_for_bit() {
    let Some(cc) = tool("cc") else { return };
    for t in qloop::targets::builtin() {
        let plan = plan_for(&t.name);
        let dir = scratch(&format!("c-elements-interp-{}", t.name));
        let mut rng = Rng(0x5eed_e1e3_0000_0037 ^ t.name.len() as u64);
        let cases = c_harness::trajectory_and_states(&plan, &mut rng, 300, 2_000);
        c_harness::fixed_c_matches_interpreter(&plan, &cc, &dir, &cases);
    }
}

#[test]
fn fixed_c_is_free_of_runtime_errors_by_frama_c_eva() {
    let Some(frama) = tool("frama-c") else { return };
    for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
        let dir = scratch(&format!("c-elements-eva-{target}"));
        c_harness::eva(&plan_for(target), &frama, machdep, &dir);
    }
}

/// Every obligation is proved, each by both solvers but the property `zero_error_keeps_theta`,
/// which z3 proves with exact integers and cvc5 does not within the time (its abstractions'
/// counterexamples are spurious, the CLI's replay finds; it times out on the exact terms).
#[test]
fn proves_with_both_solvers() {
    use qloop::prove::solver::{Answer, Solver};
    if !Solver::ALL.iter().all(|s| s.available()) {
        eprintln!("z3 or cvc5 missing: skipped");
        return;
    }
    for target in ["host", "atmega328p"] {
        let report = qloop_tests::assert_proved(&plan_for(target), 5_000, &[]);
        for o in &report.outcomes {
            let by = |s: Solver| {
                o.runs
                    .iter()
                    .any(|r| r.solver == s && r.answer == Answer::Unsat)
            };
            assert!(by(Solver::Z3), "{target}: {}: {:?}", o.ob.name, o.runs);
            if !o.ob.name.contains("zero_error_keeps_theta") {
                assert!(by(Solver::Cvc5), "{target}: {}: {:?}", o.ob.name, o.runs);
            }
        }
    }
}

/// A small spec around one declaration of `theta[2]`.
fn theta_spec(attr: &str) -> String {
    format!(
        "controller e {{\n    period 10 \"ms\";\n    input y: [-4.0, 4.0];\n    {attr}\n    \
         state theta[2]: [[-2.0, 2.0], [-1.0, 1.0]] = [0.5, 0.0];\n    output o: [-4.0, 4.0];\n    \
         step {{\n        theta[0] = y;\n        theta[1] = y;\n        o = theta[0] + theta[1];\n    }}\n}}\n"
    )
}

#[test]
fn per_element_lsb_requests_are_each_met() {
    let p = qloop::compile_str(
        &theta_spec("#[lsb([1e-3, 1e-7])]"),
        &qloop::Target::default(),
    )
    .expect("compiles");
    for (n, lsb) in [("theta_0", 1e-3), ("theta_1", 1e-7)] {
        assert!(
            p.format(sig(&p, n)).lsb() <= lsb,
            "{n}: {}",
            p.format(sig(&p, n))
        );
    }
    assert_eq!(p.format(sig(&p, "theta_0")).ty.bits, 16);
    assert_eq!(p.format(sig(&p, "theta_1")).ty.bits, 32);
}

#[test]
fn a_count_of_formats_other_than_the_elements_is_refused_at_the_attribute() {
    let e = qloop::compile_str(&theta_spec("#[q([i16, 13])]"), &qloop::Target::default())
        .expect_err("one format for two elements");
    let text = e.message.clone();
    assert!(
        text.contains("1 formats for the 2 elements of `theta`"),
        "{text}"
    );
    assert_eq!(e.line_col().0, 4, "{text}");
}

#[test]
fn elements_no_one_api_type_carries_are_refused_at_the_vector() {
    let e = qloop::compile_str(
        &theta_spec("#[q([i8, 0], [i64, 62])]"),
        &qloop::Target::default(),
    )
    .expect_err("no 64-bit word holds i8 integers and 62 fraction bits");
    let text = e.message.clone();
    assert!(
        text.contains("no `fixed` type of at most 64 bits carries"),
        "{text}"
    );
    assert_eq!(e.line_col().0, 5, "{text}");
}

/// Unpinned, the elements of vectors.qloop's θ (ranges [−2, 2] and [−1, 1]: 29 and 30
/// fraction bits alone) take one format, the cheaper plan on every built-in target by the cost
/// model (its dot products need no alignment shifts then).
#[test]
fn an_unpinned_vector_takes_one_format_where_that_is_cheaper() {
    for t in qloop::targets::builtin() {
        let p = qloop::compile_str(include_str!("vectors.qloop"), &t).expect("compiles");
        let (a, b) = (p.format(sig(&p, "theta_0")), p.format(sig(&p, "theta_1")));
        assert_eq!(a, b, "{}", t.name);
    }
}

/// The LinuxCNC component's controller and glue (as `run.sh` extracts them), compiled for the
/// host with `targets/linuxcnc/test/host_ref.c`: every step's raw outputs are the
/// interpreter's, each element's pin scaled by its own format.
#[test]
fn linuxcnc_glue_and_controller_match_the_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let dir = scratch("c-elements-linuxcnc-ref");
    let mut rng = Rng(0x0e1e_3e47_0000_0037);
    c_harness::linuxcnc_matches_interpreter(&plan_for("host"), &cc, &dir, &mut rng, 2_000);
}
