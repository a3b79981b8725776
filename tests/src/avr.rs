//! The ATmega328P runs of the C tests: a firmware of a plan's C and scripted raw inputs, built
//! by avr-gcc ([`firmware`]), run in simavr by `targets/avr/cycles.c` and compared bit for bit
//! with qloop's plan interpreter ([`matches_the_interpreter`]). Each function assumes its tool
//! is there: [`Simavr::find`] asks for them.

use crate::c_harness::{field, ids, interpreted, root, write_c, Case};
use crate::{run, tool};
use qloop::ir::SigKind;
use qloop::Plan;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What a simavr run needs: avr-gcc, the host `cc`, and simavr's headers and library.
pub struct Simavr {
    avr_cc: PathBuf,
    cc: PathBuf,
    include: Vec<String>,
}

impl Simavr {
    /// The tools, or `None` (each missing one reported by [`crate::tool`] or
    /// [`crate::skip`]).
    pub fn find() -> Option<Self> {
        let (avr_cc, cc) = (tool("avr-gcc"), tool("cc"));
        let include = libsimavr()?;
        Some(Self {
            avr_cc: avr_cc?,
            cc: cc?,
            include,
        })
    }
}

/// The plan's AVR firmware run in simavr on `cases` (inputs only, in order, from the
/// initial state): every step's raw outputs and states are the interpreter's. Panics on the
/// first step that differs; the number of steps compared.
pub fn matches_the_interpreter(sim: &Simavr, plan: &Plan, cases: &[Case], dir: &Path) -> usize {
    assert!(
        cases.iter().all(|c| c.states.is_none()),
        "a firmware runs from the initial state"
    );
    std::fs::create_dir_all(dir).unwrap();
    let runner = cycles_runner(&sim.cc, &sim.include, dir);
    let want = interpreted(plan, cases);
    let steps: Vec<Vec<i128>> = cases.iter().map(|c| c.inputs.clone()).collect();
    let elf = firmware(plan, &sim.avr_cc, dir, &steps, &[]);
    let out = simulate(plan, &runner, &elf);
    let got: Vec<Vec<i64>> = out
        .lines()
        .filter_map(|l| l.strip_prefix("out "))
        .map(|l| {
            l.split_whitespace()
                .skip(1)
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(got.len(), want.len(), "steps reported:\n{out}");
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(
            g, w,
            "{}: step {k} ({:?}): simavr vs interpreter",
            plan.prog.name, cases[k]
        );
    }
    got.len()
}

/// An AVR firmware (in `dir`; the ATmega328P's or the core the plan's flags name) for the simavr runner `targets/avr/cycles.c`: the raw
/// inputs of every step in flash, then per step the step between markers and its raw outputs
/// and states reported as 8-byte values (`targets/avr/firmware/sim_protocol.h`), then the
/// done marker. Extra `cflags` go to the controller's C only. The ELF's path.
pub fn firmware(
    plan: &Plan,
    cc: &Path,
    dir: &Path,
    steps: &[Vec<i128>],
    cflags: &[&str],
) -> PathBuf {
    let n = &plan.prog.name;
    let c = write_c(plan, dir);
    let inputs = ids(plan, SigKind::Input);
    let mut m = format!(
        "#include <avr/io.h>\n#include <avr/pgmspace.h>\n#include <stdint.h>\n\
         #include \"sim_protocol.h\"\n#include \"{n}.h\"\n\n#define STEPS {}u\n\n",
        steps.len()
    );
    let mut read = String::new();
    for (k, id) in inputs.iter().enumerate() {
        let ty = plan.format(*id).ty;
        let vals: Vec<String> = steps
            .iter()
            .map(|s| qloop::emit::c::c_lit(s[k], ty))
            .collect();
        let _ = writeln!(
            m,
            "static const {} in_{k}[STEPS] PROGMEM = {{\n    {}\n}};",
            qloop::emit::c::c_ty(ty),
            vals.join(", ")
        );
        let rd = match ty.bits {
            8 => "pgm_read_byte",
            16 => "pgm_read_word",
            32 => "pgm_read_dword",
            b => panic!("{b}-bit input"),
        };
        let _ = writeln!(
            read,
            "        in.{} = ({}){rd}(&in_{k}[k]);",
            field(plan, *id),
            qloop::emit::c::c_ty(ty)
        );
    }
    let mut report = String::new();
    for (what, kind) in [("out", SigKind::Output), ("st", SigKind::State)] {
        for id in ids(plan, kind) {
            let _ = writeln!(
                report,
                "        value((int64_t){what}.{});",
                field(plan, id)
            );
        }
    }
    let _ = write!(
        m,
        "\nstatic {n}_state st;\nstatic {n}_inputs in;\nstatic {n}_outputs out;\n\n\
         /* Eight bytes, least significant first, committed as a signed 8-byte value. */\n\
         static void value(int64_t v)\n{{\n    uint64_t u = (uint64_t)v;\n    uint8_t b;\n\
         \x20   for (b = 0; b < 8; b++) {{\n        GPIOR1 = (uint8_t)u;\n        u >>= 8;\n    }}\n\
         \x20   GPIOR2 = 0x88;\n}}\n\n\
         int main(void)\n{{\n    uint16_t k;\n    __asm__ __volatile__(\"cli\" ::: \"memory\");\n\
         \x20   MARK(MARK_CAL_BEGIN);\n    MARK(MARK_CAL_END);\n    {n}_init(&st);\n\
         \x20   for (k = 0; k < STEPS; k++) {{\n{read}\
         \x20       MARK(MARK_STEP_BEGIN);\n        {n}_step(&st, &in, &out);\n        MARK(MARK_STEP_END);\n\
         {report}\x20       MARK(MARK_RECORD_END);\n    }}\n    MARK(MARK_DONE);\n\
         \x20   for (;;)\n        __asm__ __volatile__(\"cli\\n\\tsleep\" ::: \"memory\");\n}}\n"
    );
    std::fs::write(dir.join("main.c"), m).unwrap();
    let obj = dir.join(format!("{n}.o"));
    run(Command::new(cc)
        .args(WARN)
        .args(&plan.target.toolchain.cflags)
        .args(cflags)
        .arg("-c")
        .arg(&c)
        .arg("-o")
        .arg(&obj));
    let elf = dir.join("firmware.elf");
    link(cc, plan, dir, &[&obj], &elf);
    elf
}

/// `dir/main.c` (and `objs`) linked into `elf` with the plan's flags, the firmware protocol's
/// headers and `dir` on the include path, every warning an error.
fn link(cc: &Path, plan: &Plan, dir: &Path, objs: &[&Path], elf: &Path) {
    run(Command::new(cc)
        .args(WARN)
        .args(&plan.target.toolchain.cflags)
        .arg("-I")
        .arg(root().join("targets/avr/firmware"))
        .arg("-I")
        .arg(dir)
        .arg(dir.join("main.c"))
        .args(objs)
        .arg("-o")
        .arg(elf));
}

/// What the simavr runner printed for `elf`, which must have reached its done marker, on the
/// core the plan's `-mmcu=` names (the ATmega328P without one).
fn simulate(plan: &Plan, runner: &Path, elf: &Path) -> String {
    let mcu = plan.target.toolchain.mcu().unwrap_or("atmega328p");
    let out = run(Command::new(runner).arg("--mcu").arg(mcu).arg(elf));
    assert!(out.contains("end done-marker "), "{out}");
    out
}

/// The warning flags of every AVR build here.
const WARN: [&str; 4] = ["-std=c99", "-Wall", "-Wextra", "-Werror"];

/// A firmware of the plan's C and `main` (a C file that includes `NAME.c`, so it can call the
/// controller's helpers), built with the plan's flags and run in simavr; what the runner
/// printed (`targets/avr/cycles.c`: the values each step record reports on its `out` line).
pub fn run_program(sim: &Simavr, plan: &Plan, main: &str, dir: &Path) -> String {
    std::fs::create_dir_all(dir).unwrap();
    write_c(plan, dir);
    std::fs::write(dir.join("main.c"), main).unwrap();
    let elf = dir.join("program.elf");
    link(&sim.avr_cc, plan, dir, &[], &elf);
    simulate(plan, &cycles_runner(&sim.cc, &sim.include, dir), &elf)
}

/// simavr's headers and library, as `targets/avr/Makefile` looks for them.
fn libsimavr() -> Option<Vec<String>> {
    let pc = Command::new("pkg-config")
        .args(["--cflags", "simavr"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let header = Path::new("/usr/include/simavr/sim_avr.h").is_file() || pc.is_some();
    if !header || crate::hidden("simavr") {
        crate::skip("libsimavr is not installed (simavr, libsimavr-dev)");
        return None;
    }
    let inc = pc
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "-I/usr/include/simavr".into());
    Some(inc.split_whitespace().map(String::from).collect())
}

/// The simavr runner `targets/avr/cycles.c`, built in `dir` with the host `cc` (the static
/// libsimavr needs libelf; the shared one brings it).
fn cycles_runner(cc: &Path, include: &[String], dir: &Path) -> PathBuf {
    let exe = dir.join("cycles");
    let mut errors = String::new();
    for libs in [&["-lsimavr", "-lelf"][..], &["-l:libsimavr.so.2"][..]] {
        let o = Command::new(cc)
            .args(["-O2", "-std=c99", "-Wall", "-Wextra", "-Werror"])
            .args(include)
            .arg(root().join("targets/avr/cycles.c"))
            .arg("-o")
            .arg(&exe)
            .args(libs)
            .output()
            .unwrap();
        if o.status.success() {
            return exe;
        }
        errors.push_str(&String::from_utf8_lossy(&o.stderr));
    }
    panic!("cannot build targets/avr/cycles.c:\n{errors}");
}
