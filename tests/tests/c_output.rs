//! The C99 output (`qloop gen --lang c`) of every seed spec:
//! * compiles without a warning (`-std=c99 -pedantic -Wall -Wextra -Werror -Wconversion`) on
//!   the host, with the compiler and flags of `targets/host.toml`; for the other built-in
//!   targets (avr-gcc for atmega328p, arm-none-eabi-gcc for Cortex-M0, its slow-multiplier
//!   variant and M4, riscv64-unknown-elf-gcc for RV32I and RV32IMC) the warning check is the
//!   object-code test's compile (`object_code.rs`), which disassembles that object;
//! * computes bit for bit what the Rust output computes: the C generated for each target,
//!   built by the host gcc with UBSan (any signed overflow, bad shift or bad conversion
//!   aborts), against the `controller!` modules of `qloop-verified` over long random
//!   trajectories, and against qloop's plan interpreter from random and corner states;
//! * built by avr-gcc and run in simavr, computes on the ATmega328P what the interpreter
//!   computes, where that C reads its 64-bit shifts from their bytes (`qloop_NAME_sar64`);
//! * is free of run-time errors for every state in range and every raw input: Frama-C Eva
//!   reports 0 alarms and proves the ACSL contract, with the host's 32-bit `int`
//!   (machdep x86_64) and with AVR's 16-bit `int` (machdep x86_16).
//!
//! Tools that are not installed skip their part, which is listed at the end of `cargo test
//! --workspace` (`qloop_tests::tool`); `QLOOP_REQUIRE_TOOLS` (set by `.ci/run`) turns a missing
//! tool into a failure.

use qloop::interp::step_fixed;
use qloop::ir::SigKind;
use qloop_tests::avr;
use qloop_tests::c_harness::trajectory_and_states;
use qloop_tests::c_harness::{self, fixed_driver_exe, ids, raw_input, run_lines, Rng};
use qloop_tests::{plan_for, scratch, tool};
use std::fmt::Write;

/// Every built-in target with a C compiler (`targets/*.toml`: its compiler and flags, the same
/// the object-code checks and `qloop bench` use), as (name, compiler).
fn targets() -> Vec<(String, String)> {
    qloop::targets::builtin()
        .into_iter()
        .filter_map(|t| Some((t.name, t.toolchain.cc?)))
        .collect()
}

/// The seed spec's C compiles without a warning on the host, with `-Wconversion` besides
/// ([`c_harness::warning_free`], the compiler and flags of `targets/host.toml`). Every other
/// built-in target's compile is the object-code test's (`object_code.rs`, which checks that it
/// covers them all).
fn c_compiles_without_warnings_on_the_host(stem: &str) {
    let host = qloop::targets::by_name("host").unwrap();
    let Some(cc) = host.toolchain.cc.as_deref().and_then(tool) else {
        return;
    };
    let plan = plan_for(stem, "host");
    let dir = scratch(&format!("c-warn-host-{stem}"));
    c_harness::warning_free(&plan, &cc, &dir);
}

/// The `qloop-verified` module of a seed spec, run from its initial state on raw inputs:
/// every step's raw outputs, then raw states (a vector's elements row-major).
fn rust_trajectory(stem: &str, inputs: &[Vec<i64>]) -> Vec<Vec<i64>> {
    macro_rules! run {
        ($m:ident) => {{
            let mut c = qloop_verified::$m::Controller::new();
            inputs
                .iter()
                .map(|i| {
                    let o = c.step_bits(i.as_slice().try_into().unwrap());
                    o.iter().copied().chain(c.state_bits()).collect()
                })
                .collect()
        }};
    }
    match stem {
        "koren_masory_1981" => run!(koren_masory_1981),
        "koren_masory_tuned" => run!(koren_masory_tuned),
        "koren_masory_safe" => run!(koren_masory_safe),
        "acc_fixed_gain" => run!(acc_fixed_gain),
        "milling_acc" => run!(milling_acc),
        "grinding_pi" => run!(grinding_pi),
        "grinding_adaptive_pzc" => run!(grinding_adaptive_pzc),
        // Vector and matrix states: `step_bits`/`state_bits` flatten them row-major, the
        // order of the C driver's fields (`theta[0]`, `theta[1]`, `P[0][0]`, ..).
        "gac_surface_finish" => run!(gac_surface_finish),
        "milling_multimodel" => run!(milling_multimodel),
        other => panic!("seed spec {other} is not in qloop-verified"),
    }
}

/// Every target's C (built once per target by [`fixed_driver_exe`], host gcc + UBSan) computes
/// what the Rust output computes over a 20,000-step trajectory, and what the interpreter
/// computes from 5,000 random and corner states.
fn c_matches_the_rust_output_and_the_interpreter_bit_for_bit(stem: &str) {
    let Some(gcc) = tool("gcc") else { return };
    let trajectory = RustTrajectory::new(stem);
    for (target, ..) in targets() {
        let plan = plan_for(stem, &target);
        let dir = scratch(&format!("c-diff-{target}-{stem}"));
        let exe = fixed_driver_exe(&plan, &gcc, &dir);
        // A target with high products computes another function (products rounded to 32 bits
        // drop their low x low piece); its C is held to its own plan's interpreter below, and
        // its Rust by random_compile.rs.
        if !plan.target.multiplier.high_product {
            trajectory.check(&plan, &target, &exe);
        }
        c_matches_the_interpreter_from_any_state(stem, &target, &plan, &exe);
    }
}

/// The Rust output's trajectory over 20,000 random raw inputs from the initial state.
struct RustTrajectory {
    stem: String,
    /// The default plan's input formats.
    formats: Vec<String>,
    inputs: Vec<Vec<i64>>,
    /// The driver's script for them.
    script: String,
    rust: Vec<Vec<i64>>,
}

/// The inputs' formats of a plan, which must not depend on the target.
fn input_formats(plan: &qloop::Plan) -> Vec<String> {
    ids(plan, SigKind::Input)
        .iter()
        .map(|id| format!("{:?}", plan.format(*id)))
        .collect()
}

impl RustTrajectory {
    fn new(stem: &str) -> Self {
        // Plans differ per target only in how they multiply; every target's C must compute
        // the same function as the Rust compiled for the default target, on the same 20,000
        // random inputs (drawn once: the inputs' formats do not depend on the target).
        let default = qloop_tests::plan(stem);
        let mut rng = Rng(0x2545_f491_4f6c_dd1d ^ stem.len() as u64);
        let inputs: Vec<Vec<i64>> = (0..20_000)
            .map(|_| {
                ids(&default, SigKind::Input)
                    .iter()
                    .map(|id| raw_input(&default, *id, &mut rng) as i64)
                    .collect()
            })
            .collect();
        let mut script = String::new();
        for i in &inputs {
            script.push('I');
            for v in i {
                let _ = write!(script, " {v}");
            }
            script.push('\n');
        }
        let rust = rust_trajectory(stem, &inputs);
        RustTrajectory {
            stem: stem.to_string(),
            formats: input_formats(&default),
            inputs,
            script,
            rust,
        }
    }

    /// The driver `exe` of `plan` (for `target`) steps through the same trajectory.
    fn check(&self, plan: &qloop::Plan, target: &str, exe: &std::path::Path) {
        let stem = &self.stem;
        assert_eq!(
            input_formats(plan),
            self.formats,
            "{stem}/{target}: the inputs' formats depend on the target"
        );
        let c: Vec<Vec<i64>> = run_lines(exe, &self.script);
        assert_eq!(c.len(), self.rust.len(), "{stem}/{target}: step count");
        for (k, (a, b)) in c.iter().zip(&self.rust).enumerate() {
            assert_eq!(
                a, b,
                "{stem}/{target}: step {k}, inputs {:?}: C {a:?} vs Rust {b:?}",
                self.inputs[k]
            );
        }
    }
}

/// The driver `exe` of `plan` (for `target`), from 5,000 random and corner states with random
/// raw inputs, steps to the interpreter's outputs and states.
fn c_matches_the_interpreter_from_any_state(
    stem: &str,
    target: &str,
    plan: &qloop::Plan,
    exe: &std::path::Path,
) {
    let (states, inputs) = (ids(plan, SigKind::State), ids(plan, SigKind::Input));
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut script = String::new();
    let mut want = Vec::new();
    for case in 0..5_000 {
        let mut vars = vec![0i128; plan.prog.signals.len()];
        for (k, id) in states.iter().enumerate() {
            let (lo, hi) = plan.raw_bounds(*id).unwrap();
            vars[id.0] = match case {
                0..4 if (case >> (k % 2)) & 1 == 0 => lo,
                0..4 => hi,
                _ => rng.in_range(lo, hi),
            };
        }
        for id in &inputs {
            vars[id.0] = raw_input(plan, *id, &mut rng);
        }
        script.push('S');
        for id in &states {
            let _ = write!(script, " {}", vars[id.0]);
        }
        script.push_str("\nI");
        for id in &inputs {
            let _ = write!(script, " {}", vars[id.0]);
        }
        script.push('\n');
        step_fixed(plan, &mut vars).unwrap_or_else(|e| panic!("{stem}: {e:?}"));
        let row: Vec<i64> = ids(plan, SigKind::Output)
            .iter()
            .chain(&states)
            .map(|id| vars[id.0] as i64)
            .collect();
        want.push(row);
    }
    let got: Vec<Vec<i64>> = run_lines(exe, &script);
    assert_eq!(got, want, "{stem}/{target}");
}

/// On the ATmega328P, where avr-gcc makes an `int64_t` shift a bit-at-a-time libgcc call, the C
/// reads a right shift of a 64-bit value with a 32-bit result from its bytes
/// (`qloop_NAME_sar64`). Two seeds and the ZOH-only multi-model design, whose AVR C has such
/// shifts by numbers of bits below 32 that are not multiples of 8 (the helper's two-word path)
/// and, in the last, of 32 and more (its high-word path), run 400 steps of random raw inputs
/// from the initial state in simavr: every step's outputs and states are the interpreter's.
/// (The host runs above build the same C with the host gcc, little-endian too, from any
/// state.)
/// The multi-model seed on the ATmega2560 (`targets/atmega2560.toml`: 256 KiB of flash, where
/// its estimators kept as one loop fit), 200 steps of random raw inputs from the initial state
/// in simavr: every step's outputs and states are the interpreter's.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn the_multi_model_controller_on_the_atmega2560_in_simavr_matches_the_interpreter() {
    let Some(sim) = avr::Simavr::find() else {
        return;
    };
    let mega = qloop::targets::from_toml(include_str!("../../targets/atmega2560.toml")).unwrap();
    let plan = qloop::compile_str(
        include_str!("../../verified/specs/milling_multimodel.qloop"),
        &mega,
    )
    .unwrap();
    assert!(qloop::gen_c(&plan).1.contains("milling_multimodel_loop_0("));
    let cases = trajectory_and_states(&plan, &mut Rng(0x2560), 200, 0);
    let dir = scratch("c-avr-simavr-mega-multimodel");
    assert_eq!(avr::matches_the_interpreter(&sim, &plan, &cases, &dir), 200);
}

#[test]
fn avr_c_in_simavr_matches_the_interpreter() {
    let Some(sim) = avr::Simavr::find() else {
        return;
    };
    let avr = qloop::targets::by_name("atmega328p").unwrap();
    let zoh = qloop::compile_str(include_str!("milling_zoh.qloop"), &avr).unwrap();
    let plans = [
        plan_for("grinding_pi", "atmega328p"),
        plan_for("gac_surface_finish", "atmega328p"),
        zoh,
    ];
    let mut paths = [false; 2];
    for plan in &plans {
        let stem = &plan.prog.name;
        let c = qloop::gen_c(plan).1;
        let shifts: Vec<u32> = c
            .split(&format!("qloop_{stem}_sar64("))
            .skip(2)
            .filter_map(|call| call.split(", ").nth(1)?.split('u').next()?.parse().ok())
            .collect();
        paths[0] |= shifts.iter().any(|k| *k < 32 && k % 8 != 0);
        paths[1] |= shifts.iter().any(|k| *k > 32 && k % 8 != 0);
        let cases = trajectory_and_states(plan, &mut Rng(0x5a64_0000_0000_0400), 400, 0);
        let dir = scratch(&format!("c-avr-simavr-{stem}"));
        let n = avr::matches_the_interpreter(&sim, plan, &cases, &dir);
        println!("{stem}: {n} steps in simavr equal to the interpreter");
    }
    assert_eq!(
        paths, [true; 2],
        "the helper's paths (k < 32, k > 32) are run: some plan must read an unaligned shift by each"
    );
}

/// The AVR product helper `qloop_NAME_mul64` (`codegen/src/emit/c/wide.rs`: sixteen byte
/// products summed by column, then the sign correction), as the AVR C of GAC has it, equals
/// Runs, in simavr, a check of one AVR `asm` helper of GAC's ATmega328P C against a reference
/// computed by avr-gcc in `int64_t`: every pair of 27 edge factors (0, ±1, the extremes, each
/// byte's and half's boundary), then 6,000 random pairs of random widths and their squares
/// (the helper's operands may share registers). `helper` is the helper's name after
/// `qloop_NAME_`; `reference` is C code defining `static int64_t reference(int32_t a, int32_t
/// b)`. Asserts that every pair was checked and returns `(pairs that differ, the first such pair)`;
/// `None` where simavr is missing.
fn avr_helper_against_its_reference(helper: &str, reference: &str) -> Option<(i64, i64, i64)> {
    let sim = avr::Simavr::find()?;
    let plan = plan_for("gac_surface_finish", "atmega328p");
    let n = &plan.prog.name;
    assert!(
        qloop::gen_c(&plan)
            .1
            .contains(&format!("qloop_{n}_{helper}(")),
        "{n}: the AVR C has no call of its {helper} helper"
    );
    let main = format!(
        "#include \"{n}.c\"\n#include \"sim_protocol.h\"\n\n\
         static const int32_t edge[] = {{0, 1, -1, 2, -2, 127, -128, 128, -129, 255, -255, 256,\n\
         \x20   -256, 0x7fff, -0x8000, 0x8000, -0x8001, 0xffff, -0xffff, 0x10000, -0x10000,\n\
         \x20   0x00ff00ff, -0x00ff00ff, 0x7ffffffe, 0x7fffffff, -0x7fffffff, -0x7fffffff - 1}};\n\
         static uint32_t s = 0x2545f491u;\n\
         static uint32_t rnd(void) {{ s ^= s << 13; s ^= s >> 17; s ^= s << 5; return s; }}\n\
         static uint32_t n, bad;\n\
         static int32_t bad_a, bad_b;\n\
         {reference}\n\
         static void check(int32_t a, int32_t b)\n\
         {{\n\
         \x20   n++;\n\
         \x20   if ((int64_t)qloop_{n}_{helper}(a, b) != reference(a, b)) {{\n\
         \x20       if (!bad++) {{ bad_a = a; bad_b = b; }}\n\
         \x20   }}\n\
         }}\n\
         int main(void)\n\
         {{\n\
         \x20   uint16_t i, j;\n\
         \x20   const uint16_t ne = sizeof edge / sizeof edge[0];\n\
         \x20   __asm__ __volatile__(\"cli\" ::: \"memory\");\n\
         \x20   for (i = 0; i < ne; i++)\n\
         \x20       for (j = 0; j < ne; j++)\n\
         \x20           check(edge[i], edge[j]);\n\
         \x20   for (i = 0; i < 6000u; i++) {{\n\
         \x20       const uint8_t w = (uint8_t)rnd();\n\
         \x20       const int32_t a = (int32_t)rnd() >> (w & 31u), b = (int32_t)rnd() >> ((w >> 3) & 31u);\n\
         \x20       check(a, b);\n\
         \x20       check(a, a);\n\
         \x20   }}\n\
         \x20   MARK(MARK_CAL_BEGIN);\n\
         \x20   MARK(MARK_CAL_END);\n\
         \x20   MARK(MARK_STEP_BEGIN);\n\
         \x20   MARK(MARK_STEP_END);\n\
         \x20   emit((int32_t)n);\n\
         \x20   emit((int32_t)bad);\n\
         \x20   emit(bad_a);\n\
         \x20   emit(bad_b);\n\
         \x20   MARK(MARK_RECORD_END);\n\
         \x20   MARK(MARK_DONE);\n\
         \x20   for (;;)\n\
         \x20       __asm__ __volatile__(\"cli\\n\\tsleep\" ::: \"memory\");\n\
         }}\n"
    );
    let out = avr::run_program(&sim, &plan, &main, &scratch(&format!("c-avr-{helper}")));
    let got: Vec<i64> = out
        .lines()
        .find_map(|l| l.strip_prefix("out 0 "))
        .unwrap_or_else(|| panic!("no report:\n{out}"))
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(got[0], 27 * 27 + 12_000, "pairs checked");
    Some((got[1], got[2], got[3]))
}

/// The AVR product helper `qloop_NAME_mul64` (`codegen/src/emit/c/wide.rs`), as the AVR C of
/// GAC has it, equals avr-gcc's own `int64_t` product in simavr on every pair
/// [`avr_helper_against_its_reference`] tries.
#[test]
fn avr_product_helper_equals_the_compilers_product_in_simavr() {
    let reference = "static int64_t reference(int32_t a, int32_t b) { return (int64_t)a * b; }";
    let Some((bad, a, b)) = avr_helper_against_its_reference("mul64", reference) else {
        return;
    };
    assert_eq!(
        bad, 0,
        "products that differ from avr-gcc's (the first: {a} * {b})"
    );
}

/// The AVR high-product helper `qloop_NAME_mulhi` (`codegen/src/emit/c/wide.rs`: three
/// 16 x 16 products of four byte products each, corrected for the halves' signs), as the AVR C
/// of GAC has it, equals the formula of `lower::lir::mul_hi` computed by avr-gcc in `int64_t`
/// in simavr on every pair [`avr_helper_against_its_reference`] tries. (`lower::lir`'s unit
/// tests bound the formula against the exact product.)
#[test]
fn avr_high_product_helper_equals_its_formula_in_simavr() {
    let reference = "static int64_t reference(int32_t a, int32_t b)\n\
                     {\n\
                     \x20   const int64_t ha = a >> 16, hb = b >> 16, la = a & 0xffff, lb = b & 0xffff;\n\
                     \x20   return ha * hb + ((ha * lb) >> 16) + ((la * hb) >> 16);\n\
                     }";
    let Some((bad, a, b)) = avr_helper_against_its_reference("mulhi", reference) else {
        return;
    };
    assert_eq!(
        bad, 0,
        "high products that differ from the formula (the first: {a} * {b})"
    );
}

fn c_is_free_of_runtime_errors_by_frama_c_eva(stem: &str) {
    let Some(frama) = tool("frama-c") else { return };
    for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
        let dir = scratch(&format!("c-eva-{target}-{stem}"));
        // 0 alarms, every contract property valid, and every state's bounds a
        // postcondition of step, proved by the analysis.
        c_harness::eva(&plan_for(stem, target), &frama, machdep, &dir);
    }
}
test_tools::spec_tests! {
    c_compiles_without_warnings_on_the_host,
    c_matches_the_rust_output_and_the_interpreter_bit_for_bit,
    c_is_free_of_runtime_errors_by_frama_c_eva in "verified/specs";
    default: [grinding_pi, koren_masory_1981];
    acceptance: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, koren_masory_safe,
        koren_masory_tuned, milling_acc, milling_multimodel,
    ];
}
