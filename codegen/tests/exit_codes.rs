//! The exit code and message of every failure class of every command (the rule is in
//! `codegen/src/cli/error.rs` and the book's Install chapter): 0 done and every claim holds; 1 a claim does not
//! hold, or a tool it needs is missing or failed; 2 bad input or usage, including an output
//! path that cannot be written.
//!
//! Each case names the class it covers, the exit code and a distinctive part of the message.
//! Tools are faked where that makes a case deterministic: `bench` runs a fake compiler and a
//! fake `qemu-system-arm` (shell scripts) that print the firmware's protocol lines, `sim`,
//! `sweep` and `demo` get a `$CARGO` that does not exist, and `prove` a `$PATH` without solvers.
//! Only the refuted proof and the `--json` write after a proof need z3 or cvc5; `sim` and
//! `sweep` cases that fail after the controller is compiled need cargo (as `tests/sim.rs`).

use crate::common::{spec, text};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A scratch directory for one test, with a regular file `file` in it: a path under it can
/// be neither created nor written.
fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("exit-codes-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    std::fs::write(d.join("file"), "a regular file\n").expect("regular file");
    d
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn fixture(name: &str) -> String {
    s(&Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name))
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs `qloop args` with extra environment variables.
fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_qloop"));
    c.args(args);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run qloop")
}

/// Asserts the exit code and that standard error contains every `needle`.
#[track_caller]
fn expect(class: &str, o: &Output, code: i32, needles: &[&str]) {
    let err = text(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(code),
        "{class}: exit code\nstderr:\n{err}\nstdout:\n{}",
        text(&o.stdout)
    );
    for n in needles {
        assert!(err.contains(n), "{class}: `{n}` not in stderr:\n{err}");
    }
}

/// Like [`expect`], for a message on standard output (the proof table).
#[track_caller]
fn expect_stdout(class: &str, o: &Output, code: i32, needles: &[&str]) {
    let out = text(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(code),
        "{class}: exit code\nstdout:\n{out}\nstderr:\n{}",
        text(&o.stderr)
    );
    for n in needles {
        assert!(out.contains(n), "{class}: `{n}` not in stdout:\n{out}");
    }
}

fn solvers_installed() -> bool {
    ["z3", "cvc5"].iter().any(|p| {
        Command::new(p)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// A spec with a syntax error (a missing `;` before line 4).
fn syntax_error_spec(dir: &Path) -> String {
    let p = dir.join("syntax.qloop");
    std::fs::write(
        &p,
        "controller x {\n    period 0.1 \"s\";\n    input a: [0.0, 1.0]\n}\n",
    )
    .expect("write spec");
    s(&p)
}

/// A target file with an invalid value.
fn bad_target_file(dir: &Path) -> String {
    let good = std::fs::read_to_string(root().join("targets/atmega328p.toml")).expect("target");
    let p = dir.join("bad.toml");
    std::fs::write(&p, good.replace("int_bits = 16", "int_bits = 24")).expect("write target");
    s(&p)
}

#[test]
fn top_level_usage() {
    expect("no command", &run(&[], &[]), 2, &["Usage: qloop"]);
    expect(
        "unknown command",
        &run(&["frobnicate"], &[]),
        2,
        &["unrecognized subcommand 'frobnicate'"],
    );
    let o = run(&["--help"], &[]);
    assert_eq!(o.status.code(), Some(0), "--help");
    assert!(
        text(&o.stdout).contains("Exit codes: 0 ok; 1"),
        "--help states the rule"
    );
    assert_eq!(run(&["--version"], &[]).status.code(), Some(0), "--version");
    expect(
        "targets: unexpected argument",
        &run(&["targets", "extra"], &[]),
        2,
        &["unexpected argument 'extra'"],
    );
    expect(
        "rules: unknown name",
        &run(&["rules", "nope"], &[]),
        2,
        &["no rules library or rule named `nope`"],
    );
    expect_stdout(
        "rules: one rule",
        &run(&["rules", "fmax"], &[]),
        0,
        &["rule fmax(LIMIT \"@cmd\") on (cmd)"],
    );
}

#[test]
fn aco_failures() {
    let d = scratch("aco");
    let out = s(&d.join("out"));
    expect(
        "aco: confidence outside [0, 1]",
        &run(&["aco", "--c", "1.5", "--out", &out], &[]),
        2,
        &[
            "--c 1.5 is outside [0, 1]",
            "help: c is the confidence level of Ivester & Danai, eq. 13",
        ],
    );
    expect(
        "aco: no cycles",
        &run(&["aco", "--cycles", "0", "--out", &out], &[]),
        2,
        &["--cycles 0 is outside 1..=200"],
    );
    expect(
        "aco: seeds would wrap",
        &run(
            &["aco", "--seed", "18446744073709551615", "--out", &out],
            &[],
        ),
        2,
        &["leaves no room for 100 study runs"],
    );
    expect(
        "aco: output under a regular file",
        &run(
            &["aco", "--runs", "0", "--out", &s(&d.join("file/out"))],
            &[],
        ),
        2,
        &["cannot create"],
    );
    expect_stdout(
        "aco: done",
        &run(
            &["aco", "--runs", "3", "--study-cycles", "4", "--out", &out],
            &[],
        ),
        0,
        &["paper  Tab.2", "3 seeded runs of 4 cycles"],
    );
    for f in ["rcb2.txt", "rcb2-run.csv", "rcb2-run.png", "rcb2-study.svg"] {
        assert!(d.join("out").join(f).is_file(), "{f}");
    }
    expect(
        "aco: unknown study",
        &run(&["aco", "nope", "--out", &out], &[]),
        2,
        &["invalid value 'nope'", "rcb2, bendix, cascade"],
    );
    expect_stdout(
        "aco bendix: done",
        &run(&["aco", "bendix", "--out", &out], &[]),
        0,
        &["torque, temperature"],
    );
    // The cascade compiles its inner loop with cargo, as `sim` does.
    expect(
        "aco cascade: cargo missing",
        &run(
            &["aco", "cascade", "--out", &out],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        1,
        &["cargo, which did not start"],
    );
}

#[test]
fn c2d_failures() {
    let plant = [
        "c2d", "--num", "-3,150", "--den", "1,20,550", "--period", "0.0839",
    ];
    expect_stdout("c2d: done", &run(&plant, &[]), 0, &["order 2 (ZOH)"]);
    expect(
        "c2d: missing flag",
        &run(&["c2d", "--num", "1", "--period", "0.1"], &[]),
        2,
        &["--den <DEN>"],
    );
    expect(
        "c2d: β outside [-1, 1]",
        &run(&[&plant[..], &["--beta", "-0.5,3"]].concat(), &[]),
        2,
        &["β = 3 is outside [−1, 1]"],
    );
    expect(
        "c2d: not a period",
        &run(
            &["c2d", "--num", "1", "--den", "1,1", "--period", "-1"],
            &[],
        ),
        2,
        &["positive number of seconds"],
    );
    expect(
        "c2d: static gain",
        &run(
            &["c2d", "--num", "1,0", "--den", "2", "--period", "0.1"],
            &[],
        ),
        2,
        &["the denominator is a constant"],
    );
}

#[test]
fn check_failures() {
    let d = scratch("check");
    let good = spec("acc_fixed_gain.qloop");
    expect(
        "missing spec file",
        &run(&["check", &s(&d.join("none.qloop"))], &[]),
        2,
        &["error: cannot read `", "none.qloop`"],
    );
    expect(
        "spec with a syntax error",
        &run(&["check", &syntax_error_spec(&d)], &[]),
        2,
        &["syntax.qloop:4:1", "expected `;`"],
    );
    expect(
        "spec the checker rejects",
        &run(&["check", &fixture("division.qloop")], &[]),
        2,
        &["division.qloop:8:19", "division is not allowed", "help:"],
    );
    expect(
        "unknown target",
        &run(&["check", &good, "--target", "z80"], &[]),
        2,
        &["unknown target `z80`; built-in targets: rv32i"],
    );
    expect(
        "unreadable target file",
        &run(&["check", &good, "--target", &s(&d.join("none.toml"))], &[]),
        2,
        &["error: cannot read target file `"],
    );
    expect(
        "invalid target file",
        &run(&["check", &good, "--target", &bad_target_file(&d)], &[]),
        2,
        &["int_bits", "help: see targets/*.toml for the format"],
    );
    expect(
        "unknown flag",
        &run(&["check", &good, "--frobnicate"], &[]),
        2,
        &["unexpected argument '--frobnicate'"],
    );
    expect(
        "missing spec argument",
        &run(&["check"], &[]),
        2,
        &["required arguments were not provided"],
    );
}

#[test]
fn gen_failures() {
    let d = scratch("gen");
    let good = spec("acc_fixed_gain.qloop");
    let under_file = s(&d.join("file/sub"));
    expect(
        "missing spec file",
        &run(&["gen", &s(&d.join("none.qloop"))], &[]),
        2,
        &["cannot read `"],
    );
    expect(
        "spec with a syntax error",
        &run(&["gen", &syntax_error_spec(&d)], &[]),
        2,
        &["syntax.qloop:4:1"],
    );
    expect(
        "bad --lang value",
        &run(&["gen", &good, "--lang", "cobol"], &[]),
        2,
        &["invalid value 'cobol' for '--lang <LANG>'"],
    );
    expect(
        "unknown target",
        &run(&["gen", &good, "--lang", "c", "--target", "z80"], &[]),
        2,
        &["unknown target `z80`"],
    );
    expect(
        "--out with a one-file language",
        &run(&["gen", &good, "--out", &s(&d)], &[]),
        2,
        &["`--out DIR` is for `--lang c` and `--lang linuxcnc`; use `-o FILE`"],
    );
    expect(
        "-o with --lang c",
        &run(
            &["gen", &good, "--lang", "c", "-o", &s(&d.join("x.c"))],
            &[],
        ),
        2,
        &["`--lang c` writes two files; give a directory with `--out DIR`"],
    );
    expect(
        "-o naming the LinuxCNC component wrongly",
        &run(
            &[
                "gen",
                &good,
                "--lang",
                "linuxcnc",
                "-o",
                &s(&d.join("x.comp")),
            ],
            &[],
        ),
        2,
        &["halcompile requires its file to be named `qloop_acc_fixed_gain.comp`"],
    );
    expect(
        "-o and --out together",
        &run(
            &[
                "gen",
                &good,
                "--lang",
                "linuxcnc",
                "--out",
                &s(&d),
                "-o",
                &s(&d.join("qloop_acc_fixed_gain.comp")),
            ],
            &[],
        ),
        2,
        &["give either `--out DIR` or `-o FILE`, not both"],
    );
    let unrep = d.join("t.qloop");
    std::fs::write(
        &unrep,
        "controller t {\n period 0.01 \"s\";\n input x: [0.0, 1.0];\n input steps: [0.0, 1.0];\n \
         output y;\n step { y = x + steps; }\n}\n",
    )
    .expect("write spec");
    expect(
        "spec LinuxCNC cannot represent",
        &run(&["gen", &s(&unrep), "--lang", "linuxcnc"], &[]),
        2,
        &["cannot become a LinuxCNC HAL component"],
    );
    expect(
        "unwritable -o",
        &run(&["gen", &good, "-o", &s(&d.join("file/x.rs"))], &[]),
        2,
        &["error: cannot write `", "file/x.rs`"],
    );
    expect(
        "unwritable --out (c)",
        &run(&["gen", &good, "--lang", "c", "--out", &under_file], &[]),
        2,
        &["error: cannot create `", "file/sub`"],
    );
    expect(
        "unwritable --out (linuxcnc)",
        &run(
            &["gen", &good, "--lang", "linuxcnc", "--out", &under_file],
            &[],
        ),
        2,
        &["error: cannot create `"],
    );
    assert!(!d.join("x.c").exists() && !d.join("x.comp").exists());
}

#[test]
fn prove_failures() {
    let d = scratch("prove");
    let good = spec("acc_fixed_gain.qloop");
    expect(
        "missing spec file",
        &run(&["prove", &s(&d.join("none.qloop"))], &[]),
        2,
        &["cannot read `"],
    );
    expect(
        "spec with a syntax error",
        &run(&["prove", &syntax_error_spec(&d)], &[]),
        2,
        &["syntax.qloop:4:1"],
    );
    expect(
        "unknown target",
        &run(&["prove", &good, "--target", "z80"], &[]),
        2,
        &["unknown target `z80`"],
    );
    expect(
        "bad --solvers value",
        &run(&["prove", &good, "--solvers", "yices"], &[]),
        2,
        &["invalid value 'yices' for '--solvers <SOLVERS>'"],
    );
    expect(
        "bad --timeout value",
        &run(&["prove", &good, "--timeout", "soon"], &[]),
        2,
        &["invalid value 'soon' for '--timeout <TIMEOUT>'"],
    );
    expect(
        "unwritable --smt-dir",
        &run(&["prove", &good, "--smt-dir", &s(&d.join("file/smt"))], &[]),
        2,
        &["error: cannot create `", "file/smt`"],
    );
    // A tool missing: no solver on the PATH.
    expect(
        "no SMT solver",
        &run(&["prove", &good, "--no-cache"], &[("PATH", &s(&d))]),
        1,
        &[
            "warning: z3 is not installed",
            "error: no SMT solver available; install z3 and cvc5",
        ],
    );
    if !solvers_installed() {
        eprintln!("skipping the refuted and --json cases: neither z3 nor cvc5 is installed");
        return;
    }
    // The claim does not hold: a spec of the refutation corpus.
    let refuted = s(&root().join("tests/fixtures/refute/claimed_range_too_narrow.qloop"));
    let o = run(&["prove", &refuted, "--no-cache"], &[]);
    expect_stdout("refuted proof", &o, 1, &["REFUTED: ", "1 refuted"]);
    // An output written after the proof (no obligation selected: nothing to solve).
    expect(
        "unwritable --json",
        &run(
            &[
                "prove",
                &good,
                "--no-cache",
                "--only",
                "no-such-obligation",
                "--json",
                &s(&d.join("file/report.json")),
            ],
            &[],
        ),
        2,
        &["error: cannot write `", "file/report.json`"],
    );
}

#[test]
fn sim_failures() {
    let d = scratch("sim");
    let km = spec("koren_masory_1981.qloop");
    let out = s(&d.join("out"));
    expect(
        "missing spec file",
        &run(&["sim", &s(&d.join("none.qloop")), "--out", &out], &[]),
        2,
        &["cannot read `"],
    );
    expect(
        "spec with a syntax error",
        &run(&["sim", &syntax_error_spec(&d), "--out", &out], &[]),
        2,
        &["syntax.qloop:4:1"],
    );
    expect(
        "unknown target",
        &run(&["sim", &km, "--target", "z80", "--out", &out], &[]),
        2,
        &["unknown target `z80`"],
    );
    expect(
        "bad --substeps value",
        &run(&["sim", &km, "--substeps", "many"], &[]),
        2,
        &["invalid value 'many' for '--substeps <SUBSTEPS>'"],
    );
    expect(
        "unknown plant",
        &run(&["sim", &km, "--plant", "lathe", "--out", &out], &[]),
        2,
        &["unknown plant `lathe`; built-in plants: turning"],
    );
    expect(
        "unknown scenario",
        &run(&["sim", &km, "--scenario", "no-such", "--out", &out], &[]),
        2,
        &["unknown scenario `no-such`", "depth-steps"],
    );
    expect(
        "missing scenario file",
        &run(
            &[
                "sim",
                &km,
                "--scenario",
                &s(&d.join("none.toml")),
                "--out",
                &out,
            ],
            &[],
        ),
        2,
        &["cannot read scenario file `"],
    );
    let bad = d.join("bad.toml");
    std::fs::write(&bad, "name = \"x\"\nduration_s = \"long\"\n").expect("write scenario");
    expect(
        "invalid scenario file",
        &run(&["sim", &km, "--scenario", &s(&bad), "--out", &out], &[]),
        2,
        &["bad.toml", "line 2"],
    );
    // A tool missing: cargo, which compiles the generated controller.
    expect(
        "cargo missing",
        &run(
            &["sim", &km, "--out", &out],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        1,
        &[
            "cargo, which did not start",
            "install Rust with rustup or set $CARGO",
        ],
    );
    expect(
        "unwritable cache",
        &run(
            &["sim", &km, "--out", &out],
            &[("QLOOP_CACHE", &s(&d.join("file/cache")))],
        ),
        2,
        &[
            "error: cannot create `",
            "set $QLOOP_CACHE to a writable directory",
        ],
    );
    // Checked against the plant's contract before the controller is compiled.
    expect(
        "plant whose units do not match the spec",
        &run(
            &[
                "sim",
                &km,
                "--plant",
                "grinding",
                "--scenario",
                "force-step",
                "--out",
                &out,
            ],
            &[],
        ),
        2,
        &[
            "takes its position command in mm (length)",
            "plant `grinding`",
        ],
    );
    expect(
        "unwritable --out",
        &run(&["sim", &km, "--out", &s(&d.join("file/out"))], &[]),
        2,
        &["error: cannot create `", "file/out`"],
    );
    assert!(!d.join("out").exists(), "nothing is written on error");
}

#[test]
fn sweep_failures() {
    let d = scratch("sweep");
    let km = spec("koren_masory_1981.qloop");
    expect(
        "missing spec file",
        &run(&["sweep", &s(&d.join("none.qloop"))], &[]),
        2,
        &["cannot read `"],
    );
    expect(
        "bad --replay seed",
        &run(&["sweep", &km, "--replay", "zz"], &[]),
        2,
        &["`zz` is not a seed (a decimal or 0x-hex 64-bit number)"],
    );
    expect(
        "bad --draws value",
        &run(&["sweep", &km, "--draws", "many"], &[]),
        2,
        &["invalid value 'many' for '--draws <DRAWS>'"],
    );
    expect(
        "unknown plant (before compiling)",
        &run(
            &["sweep", &km, "--plant", "lathe"],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        2,
        &["unknown plant `lathe`"],
    );
    expect(
        "unknown scenario (before compiling)",
        &run(
            &["sweep", &km, "--scenario", "no-such"],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        2,
        &["unknown scenario `no-such`"],
    );
    expect(
        "cargo missing",
        &run(
            &["sweep", &km, "--draws", "2"],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        1,
        &["cargo, which did not start"],
    );
    // After the controller is compiled (cached, as in tests/sim.rs).
    expect(
        "unwritable --report",
        &run(
            &[
                "sweep",
                &km,
                "--draws",
                "2",
                "--jobs",
                "1",
                "--report",
                &s(&d.join("file/report.txt")),
            ],
            &[],
        ),
        2,
        &["error: cannot write `", "file/report.txt`"],
    );
    expect(
        "unwritable --out for --replay",
        &run(
            &[
                "sweep",
                &km,
                "--replay",
                "1",
                "--out",
                &s(&d.join("file/replay")),
            ],
            &[],
        ),
        2,
        &["error: cannot create `", "file/replay`"],
    );
}

#[test]
fn demo_failures() {
    let d = scratch("demo");
    expect(
        "unwritable --out",
        &run(&["demo", "--out", &s(&d.join("file/demo"))], &[]),
        2,
        &["error: cannot create `", "file/demo`"],
    );
    expect(
        "unknown flag",
        &run(&["demo", "--lang", "c"], &[]),
        2,
        &["unexpected argument '--lang'"],
    );
    expect(
        "cargo missing",
        &run(
            &["demo", "--out", &s(&d.join("demo"))],
            &[("CARGO", "/nonexistent/cargo")],
        ),
        1,
        &["cargo, which did not start"],
    );
}

/// Fake tools for `bench` on a Cortex-M target: a compiler that succeeds, writing a link map
/// with 256 KiB of flash and 16 KiB of RAM (or fails with `QB_FAKE=cc-fails`; with
/// `QB_FAKE=overflow` its link fails with ld's region overflow unless `--noinhibit-exec`), its
/// `size` (a firmware of 104 bytes of flash and 44 of RAM; 300004 of flash with
/// `QB_FAKE=overflow`), `nm` (a 12-byte `bench_state`) and `objdump` (no sections), and a `qemu-system-arm` that prints
/// `QB_STEPS` steps of the firmware's protocol, 16 instructions each and all outputs 0
/// (plain_mul's 1 with `QB_FAKE=differ`), or fails with `QB_FAKE=qemu-fails`. Returns the
/// directory to put first on `PATH` and a target file naming the fake compiler.
#[cfg(unix)]
fn fake_bench_tools(d: &Path) -> (PathBuf, PathBuf) {
    use std::os::unix::fs::PermissionsExt;
    let bin = d.join("bin");
    std::fs::create_dir_all(&bin).expect("bin dir");
    let tools = [
        (
            "fake-arm-gcc",
            "#!/bin/sh\n\
             if [ \"$QB_FAKE\" = cc-fails ]; then echo 'fake-arm-gcc: error: bad insn' >&2; exit 1; fi\n\
             map=; keep=\n\
             for a; do case \"$a\" in -Wl,-Map=*) map=${a#-Wl,-Map=};; -Wl,--noinhibit-exec) keep=1;; esac; done\n\
             if [ -n \"$map\" ]; then\n\
             printf 'Memory Configuration\\n\\nName Origin Length Attributes\\nFLASH 0x0 0x40000 xr\\nRAM 0x20000000 0x4000 xrw\\n' > \"$map\"\n\
             if [ \"$QB_FAKE\" = overflow ]; then echo \"ld: region \\`FLASH' overflowed by 37860 bytes\" >&2; [ -n \"$keep\" ] || exit 1; fi\n\
             fi\n\
             exit 0\n",
        ),
        (
            "fake-arm-size",
            "#!/bin/sh\n\
             echo '   text    data     bss     dec     hex filename'\n\
             if [ \"$QB_FAKE\" = overflow ]; then echo ' 300000 4 40 300044 4940c x'; else echo ' 100 4 40 144 90 x'; fi\n",
        ),
        ("fake-arm-nm", "#!/bin/sh\necho 'bench_state b 536870912 12'\n"),
        ("fake-arm-objdump", "#!/bin/sh\nexit 0\n"),
        (
            "qemu-system-arm",
            "#!/bin/sh\n\
             if [ \"$QB_FAKE\" = qemu-fails ]; then echo 'qemu: fatal: fake failure' >&2; exit 1; fi\n\
             for a; do elf=$a; done\n\
             v=0\n\
             case \"$QB_FAKE:$elf\" in differ:*/plain_mul/*) v=1;; esac\n\
             echo 'qb calib 0 0 40'\n\
             i=0\n\
             while [ $i -lt \"${QB_STEPS:-0}\" ]; do echo \"qb step $i 10 $v\"; i=$((i+1)); done\n\
             exit 0\n",
        ),
    ];
    for (name, body) in tools {
        let p = bin.join(name);
        std::fs::write(&p, body).expect("write fake tool");
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    }
    let toml = std::fs::read_to_string(root().join("targets/cortex-m0.toml"))
        .expect("target file")
        .replace(
            "cc = \"arm-none-eabi-gcc\"",
            &format!("cc = \"{}\"", s(&bin.join("fake-arm-gcc"))),
        );
    assert!(toml.contains("fake-arm-gcc"), "cortex-m0.toml names its cc");
    let target = d.join("fake-m0.toml");
    std::fs::write(&target, toml).expect("write target");
    (bin, target)
}

#[cfg(unix)]
#[test]
fn bench_failures() {
    let d = scratch("bench");
    let acc = spec("acc_fixed_gain.qloop");
    let km = spec("koren_masory_1981.qloop");
    expect(
        "missing spec file",
        &run(
            &["bench", &s(&d.join("none.qloop")), "--target", "cortex-m0"],
            &[],
        ),
        2,
        &["cannot read `"],
    );
    expect(
        "unknown target",
        &run(&["bench", &km, "--target", "pdp11"], &[]),
        2,
        &["unknown target `pdp11`"],
    );
    expect(
        "target it cannot run",
        &run(&["bench", &km, "--target", "host"], &[]),
        2,
        &["target `host` names no simulator", "targets it can measure"],
    );
    expect(
        "bad --steps value",
        &run(
            &["bench", &km, "--target", "atmega328p", "--steps", "0"],
            &[],
        ),
        2,
        &["invalid value '0' for '--steps <STEPS>'", "1..=100000"],
    );
    expect(
        "missing --target",
        &run(&["bench", &km], &[]),
        2,
        &["--target <TARGET>"],
    );

    let (bin, target) = fake_bench_tools(&d);
    let target = s(&target);
    let path = format!("{}:{}", s(&bin), std::env::var("PATH").unwrap_or_default());
    let work = s(&d.join("work"));
    let bench = |extra: &[&str], fake: &str| {
        let mut args = vec![
            "bench",
            &acc,
            "--target",
            &target,
            "--steps",
            "5",
            "--work-dir",
            &work,
        ];
        args.extend_from_slice(extra);
        run(
            &args,
            &[("PATH", &path), ("QB_FAKE", fake), ("QB_STEPS", "5")],
        )
    };
    // The fake tools work: the run succeeds, and the float goal is not met (equal counts).
    let o = bench(&[], "ok");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("NOT met"), "{}", text(&o.stdout));

    expect(
        "goal not met with --check-goals",
        &bench(&["--check-goals"], "ok"),
        1,
        &["error: --check-goals: a goal is not met (see above)"],
    );
    expect(
        "outputs that disagree",
        &bench(&[], "differ"),
        1,
        &["error: qloop and plain_mul outputs differ"],
    );
    expect(
        "compiler fails",
        &bench(&[], "cc-fails"),
        1,
        &[
            "error: compiling variant `qloop` with",
            "fake-arm-gcc: error: bad insn",
            "note: build files kept in `",
        ],
    );
    let o = bench(&[], "overflow");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(
        out.contains("not run")
            && out.contains("no: flash 300004 > 262144")
            && out.contains("qloop was not run (does not fit)"),
        "{out}"
    );
    expect(
        "variant that does not fit, with --check-goals",
        &bench(&["--check-goals"], "overflow"),
        1,
        &[
            "does not fit the target's memory",
            "error: --check-goals: a goal is not met",
        ],
    );
    expect(
        "simulator fails",
        &bench(&[], "qemu-fails"),
        1,
        &["error: QEMU run of variant `qloop` failed", "qemu: fatal"],
    );
    expect(
        "unwritable --json",
        &bench(&["--json", &s(&d.join("file/bench.json"))], "ok"),
        2,
        &["error: cannot write `", "file/bench.json`"],
    );
    let o = run(
        &[
            "bench",
            &acc,
            "--target",
            &target,
            "--steps",
            "5",
            "--work-dir",
            &s(&d.join("file/work")),
        ],
        &[("PATH", &path), ("QB_FAKE", "ok"), ("QB_STEPS", "5")],
    );
    expect(
        "unwritable --work-dir",
        &o,
        2,
        &["error: cannot create `", "file/work/qloop`"],
    );
    assert!(
        !text(&o.stderr).contains("build files kept"),
        "no note about a directory that could not be made"
    );
    // Tools missing: the compiler the target names, and QEMU (a PATH without it).
    let nocc = d.join("nocc.toml");
    std::fs::write(
        &nocc,
        std::fs::read_to_string(&target)
            .expect("fake target")
            .replace(&s(&bin.join("fake-arm-gcc")), "qloop-no-such-arm-gcc"),
    )
    .expect("write target");
    expect(
        "compiler missing",
        &run(&["bench", &acc, "--target", &s(&nocc)], &[("PATH", &path)]),
        1,
        &[
            "`qloop-no-such-arm-gcc` cannot be run",
            "apt-get install gcc-arm-none-eabi",
        ],
    );
    let lonely = d.join("lonely");
    std::fs::create_dir_all(&lonely).expect("lonely dir");
    std::fs::copy(bin.join("fake-arm-gcc"), lonely.join("lonely-arm-gcc")).expect("copy cc");
    let nosize = d.join("nosize.toml");
    std::fs::write(
        &nosize,
        std::fs::read_to_string(&target)
            .expect("fake target")
            .replace(
                &s(&bin.join("fake-arm-gcc")),
                &s(&lonely.join("lonely-arm-gcc")),
            ),
    )
    .expect("write target");
    expect(
        "size tool missing",
        &run(
            &["bench", &acc, "--target", &s(&nosize)],
            &[("PATH", &path)],
        ),
        1,
        &["lonely-arm-size` cannot be run", "binutils-arm-none-eabi"],
    );
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).expect("empty dir");
    expect(
        "simulator missing",
        &run(
            &["bench", &acc, "--target", &target],
            &[("PATH", &s(&empty))],
        ),
        1,
        &[
            "`qemu-system-arm` cannot be run",
            "apt-get install qemu-system-arm",
        ],
    );
}

/// Output into a pipe whose reader has gone (`qloop gen SPEC | head -1`): `gen` ends quietly
/// with 0 instead of panicking in `print!` with "failed printing to stdout".
#[cfg(unix)]
#[test]
fn closed_stdout_pipe_ends_quietly() {
    use std::process::Stdio;
    let spec = s(&root().join("verified/specs/koren_masory_1981.qloop"));
    let mut child = Command::new(env!("CARGO_BIN_EXE_qloop"))
        .args(["gen", &spec, "--lang", "rust"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("qloop runs");
    // Close the read end before qloop has compiled the spec and written anything.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("qloop ends");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "qloop panicked:\n{err}");
    assert!(
        out.status.success(),
        "unexpected status {:?}:\n{err}",
        out.status
    );
}
