//! The C99 output (`qloop gen --lang c`) of every seed spec:
//! * compiles without a warning (`-std=c99 -pedantic -Wall -Wextra -Werror`, and
//!   `-Wconversion` on the host) for every built-in target, with the compiler and flags of
//!   its `targets/*.toml`: the host cc, avr-gcc (atmega328p), arm-none-eabi-gcc (Cortex-M0,
//!   its slow-multiplier variant, M4) and riscv64-unknown-elf-gcc (RV32I and RV32IMC);
//! * computes bit for bit what the Rust output computes: the C generated for each target,
//!   built by the host gcc with UBSan (any signed overflow, bad shift or bad conversion
//!   aborts), against the `controller!` modules of `qloop-verified` over long random
//!   trajectories, and against qloop's plan interpreter from random and corner states;
//! * is free of run-time errors for every state in range and every raw input: Frama-C Eva
//!   reports 0 alarms and proves the ACSL contract, with the host's 32-bit `int`
//!   (machdep x86_64) and with AVR's 16-bit `int` (machdep x86_16).
//!
//! Tools that are not installed skip their part, which is listed at the end of `cargo test
//! --workspace` (`qloop_tests::tool`); `QLOOP_REQUIRE_TOOLS` (set by `.ci/run`) turns a missing
//! tool into a failure.

use qloop::interp::step_fixed;
use qloop::ir::{SigId, SigKind};
use qloop::Plan;
use qloop_tests::{plan_for, run, scratch, spec_stems, tool};
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Every built-in target with a C compiler (`targets/*.toml`: its compiler and flags, the same
/// the object-code checks and `qloop bench` use), as (name, compiler, flags). The host's C
/// is also built with `-Wconversion`.
fn targets() -> Vec<(String, String, Vec<String>)> {
    qloop::targets::builtin()
        .into_iter()
        .filter_map(|t| {
            let cc = t.toolchain.cc.clone()?;
            let mut flags = t.toolchain.cflags.clone();
            if t.name == "host" {
                flags.push("-Wconversion".into());
            }
            Some((t.name, cc, flags))
        })
        .collect()
}

const WARN: [&str; 6] = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c"];

/// Writes `NAME.h`/`NAME.c` for `plan` into `dir`; returns the `.c` path.
fn write_c(plan: &Plan, dir: &Path) -> PathBuf {
    let (h, c) = qloop::gen_c(plan);
    let n = &plan.prog.name;
    std::fs::write(dir.join(format!("{n}.h")), h).unwrap();
    let p = dir.join(format!("{n}.c"));
    std::fs::write(&p, c).unwrap();
    p
}

#[test]
fn c_compiles_without_warnings_for_every_target() {
    for (target, cc, flags) in targets() {
        let Some(cc) = tool(&cc) else { continue };
        for stem in spec_stems() {
            let plan = plan_for(&stem, &target);
            let dir = scratch(&format!("c-warn-{target}-{stem}"));
            let c = write_c(&plan, &dir);
            run(Command::new(&cc)
                .args(WARN)
                .args(&flags)
                .arg(&c)
                .arg("-o")
                .arg(dir.join("step.o")));
        }
    }
}

fn ids(plan: &Plan, k: SigKind) -> Vec<SigId> {
    plan.prog.ids_of(k).collect()
}

/// A driver reading commands from stdin: `S v..` sets the raw states, `I v..` runs one step
/// on raw inputs and prints the raw outputs, then the raw states.
fn driver(plan: &Plan) -> String {
    let n = &plan.prog.name;
    let field = |id: &SigId| qloop::emit::c::ident(&plan.prog.sig(*id).name);
    let ty = |id: &SigId| qloop::emit::c::c_ty(plan.format(*id).ty);
    let mut d = format!(
        "#include \"{n}.h\"\n#include <stdio.h>\nint main(void) {{\n    {n}_state s;\n    \
         {n}_inputs in;\n    {n}_outputs out;\n    long long v;\n    char op;\n    \
         {n}_init(&s);\n    while (scanf(\" %c\", &op) == 1) {{\n        if (op == 'S') {{\n"
    );
    for id in ids(plan, SigKind::State) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            s.{} = ({})v;",
            field(&id),
            ty(&id)
        );
    }
    d.push_str("        } else {\n");
    for id in ids(plan, SigKind::Input) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            in.{} = ({})v;",
            field(&id),
            ty(&id)
        );
    }
    let _ = writeln!(d, "            {n}_step(&s, &in, &out);");
    for id in ids(plan, SigKind::Output) {
        let _ = writeln!(
            d,
            "            printf(\"%lld \", (long long)out.{});",
            field(&id)
        );
    }
    for id in ids(plan, SigKind::State) {
        let _ = writeln!(
            d,
            "            printf(\"%lld \", (long long)s.{});",
            field(&id)
        );
    }
    d.push_str("            printf(\"\\n\");\n        }\n    }\n    return 0;\n}\n");
    d
}

/// Builds the driver with the host gcc and UBSan; runs it on `script`; returns its lines.
fn run_c(plan: &Plan, dir: &Path, gcc: &Path, script: &str) -> Vec<Vec<i64>> {
    let c = write_c(plan, dir);
    std::fs::write(dir.join("driver.c"), driver(plan)).unwrap();
    let exe = dir.join("driver");
    run(Command::new(gcc)
        .args(["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror"])
        .args(["-fsanitize=undefined", "-fno-sanitize-recover=all"])
        .arg(&c)
        .arg(dir.join("driver.c"))
        .arg("-o")
        .arg(&exe));
    let mut child = Command::new(&exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let script = script.to_string();
    let feeder = std::thread::spawn(move || {
        use std::io::Write as _;
        stdin.write_all(script.as_bytes()).unwrap();
    });
    let o = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    assert!(
        o.status.success(),
        "C driver failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// xorshift64: a fixed, dependency-free stream of test values.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn in_range(&mut self, lo: i128, hi: i128) -> i128 {
        lo + (self.next() as i128).rem_euclid(hi - lo + 1)
    }
}

/// Raw input values: mostly inside the declared range, sometimes anywhere in the storage type
/// (step clamps them), sometimes at the edges.
fn input(plan: &Plan, id: SigId, rng: &mut Rng) -> i128 {
    let q = plan.format(id);
    let (lo, hi) = plan.bounds(id);
    match rng.next() % 16 {
        0 => q.ty.min(),
        1 => q.ty.max(),
        2 => lo,
        3 => hi,
        4 | 5 => rng.in_range(q.ty.min(), q.ty.max()),
        _ => rng.in_range(lo, hi),
    }
}

/// The `qloop-verified` module of a seed spec, run from its initial state on raw inputs:
/// every step's raw outputs, then raw states.
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
        "acc_fixed_gain" => run!(acc_fixed_gain),
        "milling_acc" => run!(milling_acc),
        "grinding_pi" => run!(grinding_pi),
        other => panic!("seed spec {other} is not in qloop-verified"),
    }
}

#[test]
fn c_matches_the_rust_output_bit_for_bit() {
    let Some(gcc) = tool("gcc") else { return };
    for stem in spec_stems() {
        // Plans differ per target only in how they multiply; every target's C must compute
        // the same function as the Rust compiled for the default target.
        for (target, ..) in targets() {
            let plan = plan_for(&stem, &target);
            let dir = scratch(&format!("c-diff-{target}-{stem}"));
            let mut rng = Rng(0x2545_f491_4f6c_dd1d ^ stem.len() as u64);
            let inputs: Vec<Vec<i64>> = (0..20_000)
                .map(|_| {
                    ids(&plan, SigKind::Input)
                        .iter()
                        .map(|id| input(&plan, *id, &mut rng) as i64)
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
            let c = run_c(&plan, &dir, &gcc, &script);
            let rust = rust_trajectory(&stem, &inputs);
            assert_eq!(c.len(), rust.len(), "{stem}/{target}: step count");
            for (k, (a, b)) in c.iter().zip(&rust).enumerate() {
                assert_eq!(
                    a, b,
                    "{stem}/{target}: step {k}, inputs {:?}: C {a:?} vs Rust {b:?}",
                    inputs[k]
                );
            }
        }
    }
}

#[test]
fn c_matches_the_interpreter_from_any_state() {
    let Some(gcc) = tool("gcc") else { return };
    for stem in spec_stems() {
        for (target, ..) in targets() {
            let plan = plan_for(&stem, &target);
            let dir = scratch(&format!("c-interp-{target}-{stem}"));
            let (states, inputs) = (ids(&plan, SigKind::State), ids(&plan, SigKind::Input));
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
                    vars[id.0] = input(&plan, *id, &mut rng);
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
                step_fixed(&plan, &mut vars).unwrap_or_else(|e| panic!("{stem}: {e:?}"));
                let row: Vec<i64> = ids(&plan, SigKind::Output)
                    .iter()
                    .chain(&states)
                    .map(|id| vars[id.0] as i64)
                    .collect();
                want.push(row);
            }
            let got = run_c(&plan, &dir, &gcc, &script);
            assert_eq!(got, want, "{stem}/{target}");
        }
    }
}

/// Frama-C Eva on one C file: the summary must report 0 alarms and every contract property
/// valid.
fn eva(c: &Path, main: &str, machdep: &str) -> String {
    let frama = tool("frama-c").expect("checked by the caller");
    let out = run(Command::new(frama)
        .args(["-machdep", machdep])
        .args(["-warn-signed-downcast", "-warn-unsigned-downcast"])
        .args(["-eva", "-main", main])
        .arg(c)
        .args(["-then", "-report"]));
    assert!(
        out.contains("0 alarms generated by the analysis"),
        "{}: Eva raised alarms:\n{out}",
        c.display()
    );
    // Summary rows: `Preconditions  9 valid  0 unknown  0 invalid  9 total`.
    for l in out
        .lines()
        .filter(|l| l.contains(" valid ") && l.contains(" unknown "))
    {
        let w: Vec<&str> = l.split_whitespace().collect();
        let count = |what: &str| {
            w.iter()
                .position(|x| *x == what)
                .and_then(|i| w[i - 1].parse::<u32>().ok())
        };
        assert_eq!(count("unknown"), Some(0), "{}: {l}\n{out}", c.display());
        assert_eq!(count("invalid"), Some(0), "{}: {l}\n{out}", c.display());
    }
    assert!(!out.contains("Invalid"), "{}:\n{out}", c.display());
    out
}

#[test]
fn c_is_free_of_runtime_errors_by_frama_c_eva() {
    if tool("frama-c").is_none() {
        return;
    }
    for stem in spec_stems() {
        for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
            let plan = plan_for(&stem, target);
            let dir = scratch(&format!("c-eva-{target}-{stem}"));
            let c = write_c(&plan, &dir);
            let out = eva(&c, &format!("{stem}_eva_main"), machdep);
            // Every state's bounds are a postcondition of step, proved by the analysis.
            let n_states = ids(&plan, SigKind::State).len();
            let posts = out
                .lines()
                .filter(|l| l.starts_with("[  Valid  ] Post-condition (file"))
                .count();
            assert!(
                posts >= n_states,
                "{stem}/{target}: {posts} postconditions proved, want ≥ {n_states}:\n{out}"
            );
        }
    }
}
