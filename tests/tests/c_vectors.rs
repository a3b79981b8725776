//! The C outputs of a spec with vectors and matrices (tests/vectors.qloop: `input phi[2]`,
//! `state theta[2]`, `state P[2][2]`, `output dtheta[2]`), where the structs hold arrays and
//! `step` works on one scalar local per element:
//!
//! * the fixed-point C (`qloop gen --lang c`) of every built-in target's plan compiles without
//!   a warning with that target's compiler, and, built for the host with UBSan, computes bit
//!   for bit what qloop's plan interpreter computes, from the initial state and from random
//!   and corner states inside the bounds, on random raw inputs (also beyond the ranges);
//! * Frama-C Eva proves it free of run-time errors, with its ACSL contract, for every state
//!   in bounds and every raw input (host and 16-bit `int`);
//! * its macros: one `_FRAC` per vector, `_MIN`/`_MAX` per element, no name twice;
//! * the float C (`qloop::emit::c_float`) agrees with qloop's real-arithmetic interpreter
//!   (`step_real`, which the f64 reference equals: vectors.rs) within single precision;
//! * the LinuxCNC component has one pin per element with distinct names, is built by
//!   `halcompile --compile` (no install, no root), and its controller and glue, compiled for
//!   the host with `targets/linuxcnc/test/host_ref.c` as `run.sh` does, match the interpreter;
//!   an element whose pin name another pin has is refused.
//!
//! Tools that are not installed skip their part (`qloop_tests::tool`).

use qloop::emit::c_float;
use qloop::ir::SigKind;
use qloop::Plan;
use qloop_tests::c_harness::{self, ids, Rng};
use qloop_tests::{scratch, tool};

const SPEC: &str = include_str!("vectors.qloop");

fn plan_for(target: &str) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    qloop::compile_str(SPEC, &t).unwrap_or_else(|e| panic!("vectors.qloop for {target}: {e}"))
}

#[test]
fn fixed_c_holds_arrays_and_one_frac_per_vector() {
    let plan = plan_for("host");
    let (h, c) = qloop::gen_c(&plan);
    for want in [
        "    int32_t phi[2]; /* input: phi[0] [-1, 1], phi[1] [-1, 1] ",
        "    int32_t y; /* input: [-4, 4] ",
        "    int32_t theta[2]; /* state: theta[0] [-2, 2], theta[1] [-1, 1] ",
        "    int32_t P[2][2]; /* state: P[0][0] [0, 2], P[0][1] [-1, 1], P[1][0] [-1, 1], P[1][1] [0, 2] ",
        "    int32_t dtheta[2]; /* output: ",
        "#define VECTORS_P_FRAC 29\n#define VECTORS_P_0_0_MIN ((int32_t)0)\n",
        "#define VECTORS_P_1_0_MAX ((int32_t)536870912)\n",
        "#define VECTORS_THETA_1_MIN ((int32_t)-536870912)\n",
    ] {
        assert!(h.contains(want), "no `{want}` in the header:\n{h}");
    }
    for want in [
        "    self->P[1][1] = ((int32_t)536870912);\n",
        "    int32_t P_1_0 = self->P[1][0];\n",
        "    self->P[1][0] = P_1_0;\n",
        "    out->dtheta[1] = dtheta_1;\n",
        " = in->phi[1];\n",
        "    requires VECTORS_P_1_0_MIN <= self->P[1][0] <= VECTORS_P_1_0_MAX;\n",
        "    s.P[0][1] = (int32_t)Frama_C_long_long_interval(",
    ] {
        assert!(c.contains(want), "no `{want}` in the source:\n{c}");
    }
    // One FRAC per vector, bounds per element; no macro twice.
    let defines: Vec<&str> = h
        .lines()
        .filter_map(|l| l.strip_prefix("#define "))
        .map(|l| l.split(' ').next().unwrap())
        .collect();
    let mut seen = std::collections::HashSet::new();
    for d in &defines {
        assert!(seen.insert(*d), "`{d}` defined twice");
    }
    let fracs: Vec<&str> = defines
        .iter()
        .copied()
        .filter(|d| d.ends_with("_FRAC"))
        .collect();
    assert_eq!(
        fracs,
        [
            "VECTORS_PHI_FRAC",
            "VECTORS_Y_FRAC",
            "VECTORS_THETA_FRAC",
            "VECTORS_P_FRAC",
            "VECTORS_YHAT_FRAC",
            "VECTORS_DTHETA_FRAC"
        ]
    );
    let n_bounded = [SigKind::Input, SigKind::State, SigKind::Output]
        .iter()
        .flat_map(|k| ids(&plan, *k))
        .filter(|id| plan.raw_bounds(*id).is_some())
        .count();
    assert_eq!(
        defines.iter().filter(|d| d.ends_with("_MIN")).count(),
        n_bounded
    );
}

#[test]
fn fixed_c_compiles_without_warnings_for_every_target() {
    for t in qloop::targets::builtin() {
        let Some(cc) = t.toolchain.cc.as_deref().and_then(tool) else {
            continue;
        };
        let dir = scratch(&format!("c-vectors-warn-{}", t.name));
        c_harness::warning_free(&plan_for(&t.name), &cc, &dir);
    }
}

#[test]
fn fixed_c_matches_the_interpreter_bit_for_bit() {
    let Some(cc) = tool("cc") else { return };
    for t in qloop::targets::builtin() {
        // Plans differ per target in how they multiply; each one's C must compute its plan.
        let plan = plan_for(&t.name);
        let dir = scratch(&format!("c-vectors-interp-{}", t.name));
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ t.name.len() as u64);
        // 500 steps along the trajectory from the initial state, then 4000 steps each from a
        // state of its own: the corners first, then random.
        let cases = c_harness::trajectory_and_states(&plan, &mut rng, 500, 4_000);
        c_harness::fixed_c_matches_interpreter(&plan, &cc, &dir, &cases);
    }
}

/// Frama-C Eva on the fixed-point C: 0 alarms, every contract property valid, every
/// element's bounds a proved postcondition.
#[test]
fn fixed_c_is_free_of_runtime_errors_by_frama_c_eva() {
    let Some(frama) = tool("frama-c") else { return };
    for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
        let dir = scratch(&format!("c-vectors-eva-{target}"));
        c_harness::eva(&plan_for(target), &frama, machdep, &dir);
    }
}

/// The float step against `step_real` from the same (`float`) states and inputs. The bound:
/// every value of vectors.qloop stays within 8 in magnitude and takes at most a dozen
/// roundings of 2^-24 relative in one step, so 2^-16 absolute (about 3× the worst case);
/// an element read or written at another index is off by far more.
#[test]
fn float_c_matches_the_real_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let plan = plan_for("host");
    let prog = &plan.prog;
    let (h, c) = c_float::source(prog);
    for want in [
        "    float phi[2]; /* input: phi[0] [-1, 1], phi[1] [-1, 1]  */",
        "    float P[2][2]; /* state: ",
        "    float dtheta[2]; /* output: ",
    ] {
        assert!(h.contains(want), "no `{want}` in:\n{h}");
    }
    for want in [
        "qloop_clampf(in->phi[1], ",
        "    float P_1_0 = self->P[1][0];\n",
        "    self->P[1][0] = P_1_0;\n",
        "    out->dtheta[0] = dtheta_0;\n",
        "    self->theta[0] = 5e-1f;\n",
    ] {
        assert!(c.contains(want), "no `{want}` in:\n{c}");
    }
    let dir = scratch("c-vectors-float");
    let n = ids(&plan, SigKind::Output).len() + ids(&plan, SigKind::State).len();
    let mut rng = Rng(0x5eed_f10a_7000_0001);
    let run = c_harness::float_c_matches_real(
        &plan,
        &cc,
        &dir,
        &mut rng,
        3_000,
        &vec![2f64.powi(-16); n],
    );
    // Both ways through the reset `if`.
    assert!(run.paths.len() >= 2, "branch coverage {:?}", run.paths);
    let worst = run.worst.iter().copied().fold(0.0, f64::max);
    println!("float C: {} steps, worst |diff| {worst:e}", run.steps);
}

/// `pin DIR TYPE NAME` / `param DIR TYPE NAME` declarations: (kind, type, name).
fn declared(comp: &str) -> Vec<(String, String, String)> {
    comp.lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            match w.first().copied() {
                Some("pin") | Some("param") => Some((
                    format!("{} {}", w[0], w[1]),
                    w[2].to_string(),
                    w[3].trim_end_matches(';').to_string(),
                )),
                _ => None,
            }
        })
        .collect()
}

#[test]
fn linuxcnc_component_has_one_pin_per_element() {
    let plan = plan_for("host");
    let comp = c_harness::component(&plan);
    let decl = declared(&comp);
    let pins = |kind: &str, ty: &str| -> Vec<String> {
        decl.iter()
            .filter(|(k, t, _)| k == kind && t == ty)
            .map(|(.., n)| n.clone())
            .collect()
    };
    // The first input, phi[0], is the spindle-load pin; every other element a pin of its own.
    assert_eq!(pins("pin in", "float"), ["spindle_load", "phi_1", "y"]);
    assert_eq!(
        pins("pin out", "float"),
        ["adaptive_feed", "yhat", "dtheta_0", "dtheta_1"]
    );
    assert_eq!(
        pins("pin out", "s32"),
        [
            "yhat_raw",
            "dtheta_0_raw",
            "dtheta_1_raw",
            "spindle_load_raw",
            "phi_1_raw",
            "y_raw"
        ]
    );
    assert!(comp.contains("pin in float phi_1 \"Regressor φ. The spec's input phi[1], "));
    // Every pin and param name distinct, in C (halcompile's macros) and in HAL.
    let mut c_names = std::collections::HashSet::new();
    let mut hal_names = std::collections::HashSet::new();
    for (.., n) in &decl {
        assert!(c_names.insert(n.clone()), "`{n}` declared twice");
        assert!(
            hal_names.insert(n.replace('_', "-")),
            "HAL name of `{n}` twice"
        );
    }
    // halcompile's macros of the pins, and the spec's names the controller uses (the vectors'
    // names too: they are struct fields), are pushed away around the controller.
    let pushes: Vec<&str> = comp
        .lines()
        .filter_map(|l| l.strip_prefix("#pragma push_macro(\""))
        .filter_map(|l| l.strip_suffix("\")"))
        .collect();
    for n in decl
        .iter()
        .map(|(.., n)| n.as_str())
        .chain(["phi", "theta", "P", "dtheta", "data"])
    {
        assert!(pushes.contains(&n), "`{n}` is not pushed away");
    }
    // The glue passes the raw values through the structs' arrays.
    for want in [
        "    in.phi[0] = (int32_t)in_raw[0];",
        "    in.phi[1] = (int32_t)in_raw[1];",
        "    out_raw[2] = (int32_t)out.dtheta[1];",
        "/* phi[0], phi[1], y */",
    ] {
        assert!(comp.contains(want), "no `{want}`");
    }
}

#[test]
fn linuxcnc_component_builds_with_halcompile() {
    let Some(halcompile) = tool("halcompile") else {
        return;
    };
    let dir = scratch("c-vectors-halcompile");
    c_harness::halcompile_builds(&plan_for("host"), &halcompile, &dir);
}

/// The component's controller and glue (as `run.sh` extracts them), compiled for the host with
/// `targets/linuxcnc/test/host_ref.c`, run from the initial state on raw inputs inside the
/// glue's saturation bounds: every step's raw outputs are the interpreter's.
#[test]
fn linuxcnc_glue_and_controller_match_the_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let dir = scratch("c-vectors-linuxcnc-ref");
    let mut rng = Rng(0x0c0f_fee0_1981_2024);
    c_harness::linuxcnc_matches_interpreter(&plan_for("host"), &cc, &dir, &mut rng, 3_000);
}

/// A pin name that two signals would share is refused, whichever of them is a vector's
/// element; so is an element name halcompile would change (`v__0`).
#[test]
fn colliding_element_pins_are_refused() {
    let host = qloop::targets::by_name("host").unwrap();
    let spec = |decls: &str, body: &str| {
        format!(
            "controller t {{\n period 0.01 \"s\";\n input x: [0.0, 1.0];\n {decls}\n \
             output y;\n step {{ y = x + {body}; }}\n}}\n"
        )
    };
    for (src, want) in [
        (
            spec(
                "input P[2][2]: [0.0, 1.0];\n input p_1_0: [0.0, 1.0];",
                "P[1][0] + p_1_0",
            ),
            "input `p_1_0` and input `P[1][0]` would both be the HAL name `p_1_0`",
        ),
        (
            spec("input v_[2]: [0.0, 1.0];", "v_[1]"),
            "input `v_[0]`: halcompile would rename `v__0`",
        ),
    ] {
        let plan = qloop::compile_str(&src, &host).unwrap_or_else(|e| panic!("{e}\n{src}"));
        let msg = qloop::gen_linuxcnc(&plan).expect_err(&src).to_string();
        assert!(msg.contains(want), "expected `{want}` in: {msg}");
    }
}
