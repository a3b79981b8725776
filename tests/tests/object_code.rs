//! Object-code checks: the plan survives the compiler. For every seed spec and target, the
//! generated routine is compiled by the target's real compiler and disassembled:
//!
//! * the C compiles without a warning (`-std=c99 -pedantic -Wall -Wextra -Werror` and the
//!   target's flags, [`c_harness::warning_free`]): the object disassembled below is that
//!   compile's, so the warning check of every cross target is this test's (the host's, with
//!   `-Wconversion`, is `c_output.rs`'s);
//! * no division instruction or call (`__divmodsi4`, `__udivmodhi4`, `__aeabi_idiv`,
//!   `__divsi3`, `__modsi3`, `sdiv`, `udiv`, RISC-V `div`/`rem`, ...);
//! * no multiply where the plan chose shift-add. The C is built a second time with every
//!   multiply the plan *did* choose replaced by a call to an opaque external function; the
//!   object must then contain no multiply instruction and no multiply helper call at all, so
//!   any multiply left would be a shift-add network the compiler folded back (a multiply by
//!   a power of two loaded just before is a left shift, see [`by_power_of_two`]). The number
//!   of opaque calls equals the plan's multiply count, which checks the replacement itself.
//!   Functions are found by their exact symbol (`NAME_step`, `…::Controller::step`).
//! * Rust (`qloop-verified`, built by rustc for thumbv6m, thumbv7em, riscv32i and
//!   riscv32imc): each `step` has no division, and on ARMv6-M and RV32I (where a re-formed
//!   multiply is a library call) exactly as many multiply instructions or calls as the plan
//!   has multiplies. On thumbv7em and riscv32imc LLVM may re-form a network into a 1-2 cycle
//!   `mul`; the cost model accepts that (see the book, "Targets, C output and object code").

use qloop::report::op_counts;
use qloop::Plan;
use qloop_tests::c_harness;
use qloop_tests::{hidden, plan_for, run, rust_target, scratch, skip, spec_stems, tool};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Division helpers and instructions of every target.
const DIV: [&str; 16] = [
    "__divmodsi4",
    "__udivmodsi4",
    "__divmodhi4",
    "__udivmodhi4",
    "__aeabi_idiv",
    "__aeabi_uidiv",
    "__aeabi_ldivmod",
    "__divsi3",
    "__udivsi3",
    "__divdi3",
    "__moddi3",
    "__umoddi3",
    "__modsi3",
    "__umodsi3",
    "__udivdi3",
    "__divmoddi4",
];

/// Is this disassembly line a division (instruction or call)?
fn is_div(line: &str) -> bool {
    let m = mnemonic(line);
    DIV.iter().any(|d| line.contains(d))
        || matches!(
            m.as_str(),
            "sdiv" | "udiv" | "div" | "divu" | "rem" | "remu" | "idiv"
        )
}

/// Is this disassembly line a multiply (instruction or helper call)?
fn is_mul(line: &str) -> bool {
    let m = mnemonic(line);
    let call = line.contains("__mul")
        || line.contains("__umul")
        || line.contains("__usmul")
        || line.contains("__aeabi_lmul");
    call || m.starts_with("mul")
        || matches!(
            m.as_str(),
            "smull" | "umull" | "smlal" | "umlal" | "mla" | "mls" | "fmul" | "fmuls" | "fmulsu"
        )
}

/// Whether the multiply instruction at `asm[i]` multiplies by a power of two: one of its
/// factors' registers was set to a power-of-two immediate by one of the 8 instructions before
/// it, and no instruction in between writes that register (as its first operand). The C writes a left
/// shift of a signed value as `x * 2^k` (C99 leaves `x << k` undefined for negative `x`);
/// GCC for Cortex-M4 may fold that multiply and the add after it into one `smlal`. That is a
/// shift, not a shift-add network folded back; so does avr-gcc's `mul` by an `ldi` power of
/// two, its 2-cycle way of shifting a byte left. Helper calls never count as one.
fn by_power_of_two(asm: &[String], i: usize) -> bool {
    // `  8e:\tmov.w\tr3, #536870912\t@ 0x20000000` → `["r3", "#536870912"]`.
    let operands = |l: &str| -> Vec<String> {
        l.split('\t')
            .nth(2)
            .map(|o| o.split(',').map(|r| r.trim().to_string()).collect())
            .unwrap_or_default()
    };
    let power_of_two = |v: &str| {
        // `#4` (ARM) or `0x10` (AVR's `ldi`).
        let v = v.strip_prefix('#').unwrap_or(v);
        match v.strip_prefix("0x") {
            Some(h) => u64::from_str_radix(h, 16).ok(),
            None => v.parse::<u64>().ok(),
        }
        .filter(|v| v.is_power_of_two())
    };
    let line = &asm[i];
    if line.contains("__") || line.contains('<') {
        return false;
    }
    // The factors: `smlal lo, hi, a, b`, `mla d, a, b, acc`, `mul d, a, b`, `muls d, a`.
    let ops = operands(line);
    let factors: &[String] = match (mnemonic(line).as_str(), ops.len()) {
        ("smull" | "umull" | "smlal" | "umlal", 4) => &ops[2..],
        ("mla" | "mls", 4) | (_, 3) => &ops[1..3],
        (_, 2) => &ops[..],
        _ => return false,
    };
    let before = &asm[i.saturating_sub(8)..i];
    factors.iter().any(|r| {
        // The latest write to `r` before the multiply.
        let set = before.iter().rev().find(|l| operands(l).first() == Some(r));
        set.is_some_and(|l| {
            let ops = operands(l);
            matches!(
                mnemonic(l).as_str(),
                "mov" | "mov.w" | "movs" | "movw" | "ldi"
            ) && ops.len() == 2
                && power_of_two(&ops[1]).is_some()
        })
    })
}

/// The mnemonic of an objdump line without raw bytes (`  1c:\tmuls\tr3, r1` → `muls`).
fn mnemonic(line: &str) -> String {
    line.split('\t')
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or("")
        .to_lowercase()
}

/// The whole object's disassembly, with relocations and demangled names.
fn disassemble(objdump: &Path, obj: &Path) -> String {
    run(Command::new(objdump)
        .args(["-dr", "--demangle", "--no-show-raw-insn"])
        .arg(obj))
}

/// The lines of the function called exactly `symbol` in a disassembly.
fn function_in(out: &str, symbol: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut inside = false;
    for l in out.lines() {
        if l.ends_with(">:") {
            // GNU objdump for RISC-V lists the local labels of a function (`<.L3>:`) as
            // symbols of their own: they stay part of the function.
            let local = l
                .rsplit_once('<')
                .is_some_and(|(_, name)| name.starts_with(".L"));
            if !local {
                inside = symbol_name(l) == Some(symbol);
            }
            continue;
        }
        if inside && !l.trim().is_empty() {
            lines.push(l.to_string());
        }
    }
    lines
}

/// The symbol of an objdump function header (`00000000 <a::b::step::h0123…>:` → `a::b::step`).
fn symbol_name(header: &str) -> Option<&str> {
    let name = header.rsplit_once('<')?.1.strip_suffix(">:")?;
    Some(match name.rsplit_once("::h") {
        Some((base, hash)) if hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()) => {
            base
        }
        _ => name,
    })
}

/// Replaces each multiply the plan chose, `(T)(a * b)` with two value operands, by a call
/// to an opaque function of its own (`qloop_opaque_mul_K`, K counting the multiplies); returns
/// the new source and the number of replacements.
fn opaque_multiplies(src: &str) -> (String, usize) {
    let mut out = String::new();
    let mut n = 0;
    let mut helper = false;
    for line in src.lines() {
        // `const int32_t _11 = (int32_t)(_9 * _10);` — both operands are names, never a
        // literal (power-of-two scalings are `* ((int32_t)4096)`).
        let replaced = line.split_once(" = (").and_then(|(lhs, rhs)| {
            // `const int64_t _16 = (int64_t)qloop_NAME_mul64((int32_t)_14, (int32_t)_15);`:
            // the AVR product helper (`codegen/src/emit/c/wide.rs`).
            if let Some((ty, call)) = rhs.split_once(')') {
                if let Some((_, args)) = call.split_once("_mul64((int32_t)") {
                    let (a, b) = args.strip_suffix(");")?.split_once(", (int32_t)")?;
                    helper = true;
                    return Some(format!(
                        "{lhs} = ({ty})qloop_opaque_mul_{n}((int64_t){a}, (int64_t){b});"
                    ));
                }
            }
            let (ty, rest) = rhs.split_once(")(")?;
            let inner = rest.strip_suffix(");")?;
            let (a, b) = inner.split_once(" * ")?;
            let ident = |s: &str| s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            (ident(a) && ident(b))
                .then(|| format!("{lhs} = ({ty})qloop_opaque_mul_{n}((int64_t){a}, (int64_t){b});"))
        });
        match replaced {
            Some(r) => {
                n += 1;
                out.push_str(&r);
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    // One opaque function per planned multiply, so that the object code shows each survived
    // (a compiler may call one twice, on two paths it duplicated, and still multiply nothing).
    let mut decl = "#include <stdbool.h>\n".to_string();
    for k in 0..n {
        let _ = writeln!(
            decl,
            "extern int64_t qloop_opaque_mul_{k}(int64_t a, int64_t b);"
        );
    }
    if helper {
        // The helper, now called nowhere, is still used (no -Wunused-function).
        let name = src.find("_mul64(int32_t a, int32_t b)").and_then(|end| {
            let start = src[..end].rfind("qloop_")?;
            Some(format!("{}_mul64", &src[start..end]))
        });
        if let Some(name) = name {
            let _ = writeln!(
                out,
                "typedef int64_t (*qloop_opaque_fn)(int32_t, int32_t);\n\
                 qloop_opaque_fn qloop_opaque_keep(void);\n\
                 qloop_opaque_fn qloop_opaque_keep(void) {{ return &{name}; }}"
            );
        }
    }
    (out.replacen("#include <stdbool.h>\n", &decl, 1), n)
}

fn compile_c(cc: &Path, flags: &[String], c: &Path, o: &Path) {
    run(Command::new(cc)
        .args(["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c"])
        .args(flags)
        .arg(c)
        .arg("-o")
        .arg(o));
}

/// The C targets whose compiler and objdump are checked, each by its `targets/*.toml`.
const C_TARGETS: [&str; 6] = [
    "atmega328p",
    "cortex-m0",
    "cortex-m0-slowmul",
    "cortex-m4",
    "rv32i",
    "rv32imc",
];

/// The object-code check compiles the C of every built-in target but the host, whose warning
/// check is `c_output.rs`'s: the cross targets' warning check is only here.
#[test]
fn every_built_in_c_target_but_the_host_is_checked() {
    let mut with_cc: Vec<String> = qloop::targets::builtin()
        .into_iter()
        .filter(|t| t.toolchain.cc.is_some() && t.name != "host")
        .map(|t| t.name)
        .collect();
    with_cc.sort();
    let mut checked: Vec<String> = C_TARGETS.iter().map(|t| t.to_string()).collect();
    checked.sort();
    assert_eq!(checked, with_cc);
}

/// The seed spec's C, compiled for `target` by its real compiler without a warning and
/// disassembled: no division in `step`, and with the planned multiplies made opaque, no
/// multiply left. (One compile serves both checks: the spec's C is the largest file the
/// tests compile, 0.8 MB for the multi-model spec.)
fn check_c(stem: &str, target: &str) {
    let t = qloop::targets::by_name(target).unwrap();
    let Some(cc) = t.toolchain.cc.as_deref().and_then(tool) else {
        return;
    };
    let plan: Plan = plan_for(stem, target);
    let dir = scratch(&format!("obj-c-{target}-{stem}"));
    // As emitted: warning-free, and no division anywhere in step.
    let obj = c_harness::warning_free(&plan, &cc, &dir);
    let Some(od) = t.toolchain.objdump.as_deref().and_then(tool) else {
        return;
    };
    // `warning_free` wrote the C under the controller's name.
    let c = std::fs::read_to_string(dir.join(format!("{}.c", plan.prog.name))).unwrap();
    let step = format!("{stem}_step");
    // The step and the loop bodies it calls (a body GCC inlined into the step has no symbol).
    let em = qloop::emit::repeat::emit(&plan);
    let loops: Vec<String> = (0..em.repeats.len())
        .map(|k| format!("{stem}_loop_{k}"))
        .collect();
    let code = |obj: &Path| {
        let d = disassemble(&od, obj);
        let mut lines = function_in(&d, &step);
        for f in &loops {
            lines.extend(function_in(&d, f));
        }
        lines
    };
    let asm = code(&obj);
    assert!(!asm.is_empty(), "{stem}/{target}: no {step} in the object");
    let divs: Vec<&String> = asm.iter().filter(|l| is_div(l)).collect();
    assert!(
        divs.is_empty(),
        "{stem}/{target}: division in step: {divs:?}"
    );

    // Planned multiplies made opaque: nothing may multiply.
    let (opaque, n) = opaque_multiplies(&c);
    assert_eq!(
        n,
        emitted_muls(&em),
        "{stem}/{target}: replaced multiplies vs the plan's count"
    );
    let src2 = dir.join(format!("{stem}_opaque.c"));
    std::fs::write(&src2, opaque).unwrap();
    let obj2 = dir.join("step_opaque.o");
    compile_c(&cc, &t.toolchain.cflags, &src2, &obj2);
    let asm2 = code(&obj2);
    let muls: Vec<&String> = asm2
        .iter()
        .enumerate()
        .filter(|(i, l)| is_mul(l) && !by_power_of_two(&asm2, *i))
        .map(|(_, l)| l)
        .collect();
    assert!(
        muls.is_empty(),
        "{stem}/{target}: the compiler turned a shift-add network into a multiply: {muls:?}"
    );
    // One relocation per call (the call instruction itself names the target on some
    // architectures and not on others): every planned multiply is called, on some path.
    let called: std::collections::BTreeSet<usize> = asm2
        .iter()
        .filter(|l| l.contains("R_"))
        .filter_map(|l| {
            let k = l.split("qloop_opaque_mul_").nth(1)?;
            k.split(|c: char| !c.is_ascii_digit()).next()?.parse().ok()
        })
        .collect();
    let missing: Vec<usize> = (0..n).filter(|k| !called.contains(k)).collect();
    assert!(
        missing.is_empty() && called.len() == n,
        "{stem}/{target}: the plan's multiplies not called in the object code: {missing:?} of {n}"
    );
}

/// The multiplies of the plan's statements the C writes: each shared loop body once.
fn emitted_muls(em: &qloop::emit::repeat::Emit) -> usize {
    use qloop::lower::lir::{LStmt, Op};
    let mut n = 0;
    let mut stack: Vec<&LStmt> = em.emitted();
    while let Some(s) = stack.pop() {
        match s {
            LStmt::Def(v) => n += usize::from(matches!(em.plan.val(*v).op, Op::Mul(..))),
            LStmt::Store(..) => {}
            LStmt::If(_, t, e) => stack.extend(t.iter().chain(e)),
        }
    }
    n
}

/// The seed spec's C compiles without a warning, and has no division and no unplanned
/// multiply, on any target whose tools are installed (riscv64-unknown-elf-gcc for RV32I, where multiplies are `__mulsi3`/`__muldi3`
/// calls, and RV32IMC, with `mul`/`mulh*`, where `div`/`rem` exist and must not appear).
fn c_has_no_division_and_no_unplanned_multiply(stem: &str) {
    for target in C_TARGETS {
        check_c(stem, target);
    }
}
test_tools::spec_tests! {
    c_has_no_division_and_no_unplanned_multiply in "verified/specs";
    default: [acc_fixed_gain, grinding_pi, koren_masory_1981];
    acceptance: [
        gac_surface_finish, grinding_adaptive_pzc, koren_masory_safe, koren_masory_tuned,
        milling_acc, milling_multimodel,
    ];
}

/// `llvm-objdump` of the rustup toolchain (component llvm-tools).
fn llvm_objdump() -> Option<PathBuf> {
    let sysroot = run(Command::new("rustc").args(["--print", "sysroot"]));
    let host = run(Command::new("rustc").args(["--print", "host-tuple"]));
    let p = PathBuf::from(sysroot.trim())
        .join("lib/rustlib")
        .join(host.trim())
        .join("bin/llvm-objdump");
    if p.is_file() && !hidden("llvm-objdump") {
        return Some(p);
    }
    skip("llvm-objdump is not installed (rustup component add llvm-tools)");
    None
}

/// The default tier's guard of what the test below checks by building for bare metal: the
/// crate root declares `#![no_std]` unconditionally (not behind a `cfg_attr`), so a host
/// build that links `std` cannot hide a firmware build that would fail.
#[test]
fn qloop_verified_declares_no_std() {
    let lib = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../verified/src/lib.rs");
    let src = std::fs::read_to_string(&lib).unwrap_or_else(|e| panic!("{}: {e}", lib.display()));
    let attrs: Vec<&str> = src
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("#!["))
        .collect();
    assert!(
        attrs.contains(&"#![no_std]"),
        "{}: the crate root must declare `#![no_std]` (its inner attributes: {attrs:?})",
        lib.display()
    );
}

/// Builds `qloop-verified` in release for four bare-metal targets (every seed in one crate, so
/// one build per target): the acceptance tier's.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn rust_step_has_no_division_and_no_unplanned_library_multiply() {
    let Some(od) = llvm_objdump() else { return };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    // (triple, whether a re-formed multiply would be a library call or slow instruction)
    for (triple, strict) in [
        ("thumbv6m-none-eabi", true),
        ("riscv32i-unknown-none-elf", true),
        ("thumbv7em-none-eabihf", false),
        ("riscv32imc-unknown-none-elf", false),
    ] {
        if !rust_target(triple) {
            continue;
        }
        let tdir = root.join("target/qloop-tests/rust-objects");
        run(Command::new(env!("CARGO"))
            .current_dir(&root)
            .args([
                "build",
                "-q",
                "-p",
                "qloop-verified",
                "--release",
                "--target",
                triple,
            ])
            .arg("--target-dir")
            .arg(&tdir));
        let rlib = tdir.join(triple).join("release/libqloop_verified.rlib");
        // Once per target: the rlib holds every seed.
        let listing = disassemble(&od, &rlib);
        for stem in spec_stems() {
            // `step` is inlined into `step_bits`, its only caller in the crate, so it has no
            // symbol of its own; `step_bits` adds only the inputs' saturation (compares).
            let step = format!("qloop_verified::{stem}::Controller::step");
            let mut asm = function_in(&listing, &step);
            if asm.is_empty() {
                asm = function_in(&listing, &format!("{step}_bits"));
            }
            assert!(
                !asm.is_empty(),
                "{stem}/{triple}: neither step nor step_bits found"
            );
            let divs: Vec<&String> = asm.iter().filter(|l| is_div(l)).collect();
            assert!(divs.is_empty(), "{stem}/{triple}: division: {divs:?}");
            if strict {
                // At most the plan's multiplies: a shift-add network LLVM turned back into a
                // multiply would add one. Not exactly as many: LLVM may remove or merge
                // products. The multi-model controller keeps 1,615 of its 3,055 on
                // thumbv6m; every other seed keeps all of its own. (The C check above is
                // exact: it makes each planned multiply an opaque call and then finds none.)
                let muls = asm.iter().filter(|l| is_mul(l)).count();
                let planned = op_counts(&qloop_tests::plan(&stem)).mul;
                assert!(
                    muls <= planned,
                    "{stem}/{triple}: {muls} multiplies in the object, {planned} in the plan"
                );
                if stem != "milling_multimodel" {
                    assert_eq!(
                        muls, planned,
                        "{stem}/{triple}: {muls} multiplies in the object, {planned} in the plan"
                    );
                }
            }
        }
    }
}

/// The power-of-two exception of the multiply check covers only a factor loaded with a
/// power of two right before, and nothing else.
#[test]
fn only_a_multiply_by_a_power_of_two_is_a_shift() {
    let asm = |lines: &[&str]| -> Vec<String> { lines.iter().map(|l| l.to_string()).collect() };
    let shift = asm(&[
        "  8e:\tmov.w\tr3, #536870912\t@ 0x20000000",
        "  92:\tsmlal\tr0, r1, r2, r3",
    ]);
    assert!(by_power_of_two(&shift, 1));
    // avr-gcc shifts a byte left by 4 as a multiply by 16.
    let avr = asm(&["  136:\tldi\tr20, 0x10\t; 16", "  138:\tmul\tr23, r20"]);
    assert!(by_power_of_two(&avr, 1));
    for bad in [
        asm(&["  136:\tldi\tr20, 0x05\t; 5", "  138:\tmul\tr23, r20"]),
        // Not a power of two: a constant multiply re-formed.
        asm(&["  8e:\tmov.w\tr3, #5", "  92:\tsmlal\tr0, r1, r2, r3"]),
        // The power of two is overwritten before the multiply.
        asm(&[
            "  8a:\tmovs\tr3, #4",
            "  8c:\tadds\tr3, r3, r4",
            "  92:\tmuls\tr2, r3",
        ]),
        // The power of two is in an accumulator, not a factor.
        asm(&["  8e:\tmov.w\tr0, #4", "  92:\tsmlal\tr0, r1, r2, r3"]),
        // A helper call.
        asm(&["  8e:\tmovs\tr2, #4", "  92:\tbl\t0 <__aeabi_lmul>"]),
    ] {
        let last = bad.len() - 1;
        assert!(!by_power_of_two(&bad, last), "{bad:?}");
    }
}
