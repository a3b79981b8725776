//! `qloop bench`: cost per controller step on a target, and flash and RAM, for qloop's code
//! and the baselines compiled the same way.
//!
//! Variants, each an `init`/`step` pair in C with the same stimulus:
//!
//! | variant | code |
//! |---|---|
//! | `qloop` | the spec's fixed-point C for the target ([`qloop::gen_c`]) |
//! | `plain_mul` | the same for [`qloop::Target::always_multiply`]: every non-power-of-two constant on the multiplier |
//! | `float` | the spec's step in C `float` ([`qloop::emit::c_float`]) |
//! | `div_float`, `div_int32` | Koren & Masory (1981) in the direct-division form (`targets/bench/`); that spec only |
//!
//! Each variant gets a small `main.c`: the inputs of every step sit in a constant table (a
//! scripted physical sequence per input, converted to raw integers or `float` here), the
//! step call is bracketed by timing markers, and the outputs of every step are reported
//! back. Everything is compiled with the target's `cc` and `cflags` plus
//! `-std=c99 -Wall -Wextra -Werror`: the variant's own sources on their own (`-c
//! -fstack-usage`), then `main.c` and the platform's startup code, linked with them and
//! writing a link map.
//!
//! Sizes, in bytes, with the toolchain's `size`, `nm` and `objdump` (named after `cc`:
//! `avr-gcc` → `avr-size`), flash = text + data and RAM = data + bss as `size` counts them
//! (Berkeley format):
//!
//! * whole ELF: `size` of the firmware: the controller, and the harness with it (`main.c`,
//!   the input table, which on the AVR sits in flash, startup code, result reporting);
//! * controller flash: what the variant's own objects (`P_step`, `P_init`, static helpers,
//!   tables) and the library archive members they need (`__muldi3`, soft float, ...; found
//!   from their undefined symbols to a fixed point) put into the firmware, by the link map's
//!   input sections, each counted in the class of the output section it landed in;
//! * controller RAM: the state object (`bench_state`, the size `nm` gives) plus the static
//!   data of those objects and members (on the AVR a `const` array outside `PROGMEM` lands in
//!   `.data`: RAM); the inputs and outputs (`bench_in`, `bench_out`) are not counted;
//! * step fn: the size of `P_step` in the ELF; step frame: its own stack frame
//!   (`-fstack-usage`), without that of the library routines it calls.
//!
//! The fit: the ELF's flash against the length of the link's flash region and its RAM plus
//! the step frame against the RAM region (avr-gcc's device script for the ATmega328P: 32768
//! and 2048; `arm::link_ld` for the QEMU machines: the micro:bit's nRF51 256 KiB and
//! 16 KiB, MPS2-AN386 4 MiB and 4 MiB; RV32 on `virt`: one 64 MiB RAM). A firmware the linker
//! rejects as too big is linked again with `--noinhibit-exec`, measured and reported as not
//! fitting, and not run (its cost, outputs and goals are "not run"/"not measured"); other
//! variants still run.
//!
//! * AVR (`simulator = "simavr"`): the ELF runs in `targets/avr/cycles.c`, a libsimavr host
//!   program compiled on first use into the cache; markers are `LDI`+`OUT GPIOR0` pairs
//!   (`targets/avr/firmware/sim_protocol.h`), the counts are exact simavr cycles with the
//!   marker overhead subtracted (they include the argument set-up, `CALL` and `RET`).
//! * Cortex-M (`qemu_machine`): the ELF runs under `qemu-system-arm -icount shift=10`, where
//!   every instruction advances the virtual clock by the same time; SysTick, read before and
//!   after the call, then counts instructions (calibrated on a 64-`nop` function; the empty
//!   bracket is subtracted). These are instructions executed, not cycles: QEMU models no
//!   pipeline, wait states or multiplier latency.
//! * RISC-V (`qemu_machine = "virt"`, a `riscv*` compiler): the ELF runs under
//!   `qemu-system-riscv32 -M virt -bios none -icount shift=0` on a CPU with exactly the
//!   extensions of the target's `-march` (`-cpu rv32,m=false,c=false,...` for RV32I, so a stray
//!   `mul` traps); `minstret`, read before and after the call, counts instructions retired
//!   (exact under `-icount`; calibrated on the same 64-`nop` function, the empty bracket
//!   subtracted). Results are text lines on the 16550 UART, exit through the SiFive test
//!   device. Multiplies and divides on RV32I are libgcc calls (`__mulsi3`, `__divsi3`), counted
//!   instruction by instruction; again instructions, not cycles.
//!
//! Modules, one job each:
//!
//! * `platform`: which platform measures the target (simavr, QEMU on Cortex-M or RV32);
//! * `variants`: each variant's sources, its input table and its `main.c`;
//! * `avr`, `arm`, `riscv`: each platform's firmware text (and on the AVR the simavr runner
//!   and its run); `text_io`: the text protocol the two QEMU platforms share;
//! * `compile`: a variant's ELF, built with the target's compiler, and its link map;
//! * `size`: flash and RAM of the ELF and of the controller, the fit; `linkmap`: reading
//!   GNU ld's map; `size_table`: the size table and its JSON;
//! * `qemu`: a run under QEMU with `-icount`;
//! * `measured`: a run's results, read from the simulator's lines;
//! * `report`: the table, the output checks, the goals and the JSON;
//! * `host`: the host's tools, time-limited runs and file writing.

mod arm;
mod avr;
mod compile;
mod host;
mod linkmap;
mod measured;
mod platform;
mod qemu;
mod report;
mod riscv;
mod size;
mod size_table;
mod text_io;
mod variants;

use super::error::{CliError, CliResult};
use super::files::{load, plan_for};
use host::need_tool;
use measured::Measured;
use platform::{platform, Platform};
use qloop::Plan;
use size::Footprint;
use std::path::Path;
use std::time::Instant;
use variants::{div_variants, fixed_variant, float_variant, has_div_baselines, script};

/// The spec the division baselines implement.
const DIV_SPEC: &str = "koren_masory_1981";

/// What `qloop bench` was asked to do.
pub struct BenchArgs<'a> {
    /// The spec's plan for the target.
    pub plan: &'a Plan,
    /// The same spec planned for `target.always_multiply()`.
    pub plain: &'a Plan,
    /// Controller steps per variant.
    pub steps: usize,
    /// Write the JSON summary here.
    pub json: Option<&'a Path>,
    /// Exit 1 if a goal is not met.
    pub check_goals: bool,
    /// Build here and keep the files (default: a temporary directory, removed on success).
    pub work_dir: Option<&'a Path>,
}

/// `qloop bench SPEC --target T`: plans the spec for the target and for its always-multiply
/// variant, then runs [`bench`].
pub fn run(
    spec: &Path,
    target: &str,
    json: Option<&Path>,
    steps: u32,
    check_goals: bool,
    work_dir: Option<&Path>,
) -> CliResult {
    let (plan, _) = load(spec, target)?;
    let plain = plan_for(spec, &plan.target.always_multiply())?;
    bench(&BenchArgs {
        plan: &plan,
        plain: &plain,
        steps: steps as usize,
        json,
        check_goals,
        work_dir,
    })
}

/// Runs the benchmark and prints its table; see the module docs.
pub fn bench(a: &BenchArgs) -> CliResult {
    let start = Instant::now();
    let plan = a.plan;
    let t = &plan.target;
    let pf = platform(t)?;
    if a.steps == 0 {
        return Err(CliError::input("`--steps` must be at least 1"));
    }
    let cc = t.toolchain.cc.clone().unwrap_or_default();
    match &pf {
        Platform::Avr => {
            need_tool(
                &cc,
                "the AVR toolchain (Debian: apt-get install gcc-avr avr-libc)",
            )?;
        }
        Platform::Qemu { .. } => {
            need_tool(
                &cc,
                "the ARM toolchain (Debian: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi)",
            )?;
            need_tool(
                "qemu-system-arm",
                "it runs the Cortex-M code (Debian: apt-get install qemu-system-arm)",
            )?;
        }
        Platform::Riscv { .. } => {
            need_tool(
                &cc,
                "the RISC-V toolchain with its rv32 libgcc (Debian: apt-get install gcc-riscv64-unknown-elf)",
            )?;
            need_tool(
                "qemu-system-riscv32",
                "it runs the RISC-V code (Debian: apt-get install qemu-system-misc)",
            )?;
        }
    }
    let runner = match pf {
        Platform::Avr => Some(avr::runner()?),
        Platform::Qemu { .. } | Platform::Riscv { .. } => None,
    };

    let values = script(plan, a.steps);
    let mut variants = vec![
        fixed_variant("qloop", plan, &values),
        fixed_variant("plain_mul", a.plain, &values),
        float_variant(plan, &values),
    ];
    let div = has_div_baselines(plan);
    if div {
        variants.extend(div_variants(&values));
    }

    let (work, temporary) = match a.work_dir {
        Some(d) => (d.to_path_buf(), false),
        None => (
            std::env::temp_dir().join(format!(
                "qloop-bench-{}-{}",
                std::process::id(),
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos())
            )),
            true,
        ),
    };
    let tools = size::tools(t, &pf)?;
    let mut results: Vec<Option<Measured>> = Vec::new();
    let mut sizes: Vec<Footprint> = Vec::new();
    let n = variants.len();
    for (i, v) in variants.iter().enumerate() {
        let t0 = Instant::now();
        eprintln!(
            "bench [{}/{n}] {}: compiling with {cc} {} ...",
            i + 1,
            v.name,
            t.toolchain.cflags.join(" ")
        );
        let dir = work.join(v.name);
        let r = compile::build(v, t, &pf, &dir).and_then(|b| {
            let fp = size::footprint(&tools, &b, &pf, &v.step_fn())?;
            if let Some(o) = &b.overflow {
                eprintln!(
                    "bench [{}/{n}] {}: does not fit the target's memory ({o}); not run",
                    i + 1,
                    v.name
                );
                return Ok((None, fp));
            }
            eprintln!(
                "bench [{}/{n}] {}: simulating {} steps ({}) ...",
                i + 1,
                v.name,
                a.steps,
                match &pf {
                    Platform::Avr => "simavr".to_string(),
                    Platform::Qemu { machine, .. } => format!("qemu-system-arm -M {machine}"),
                    Platform::Riscv { machine, cpu } =>
                        format!("qemu-system-riscv32 -M {machine} -cpu {cpu}"),
                }
            );
            let m = match (&pf, &runner) {
                (Platform::Qemu { .. } | Platform::Riscv { .. }, _) => {
                    qemu::run(&b.elf, &pf, v, a.steps)
                }
                (Platform::Avr, Some(r)) => avr::run(r, avr::mcu(t), &b.elf, v, a.steps),
                (Platform::Avr, None) => Err(CliError::tool("internal: no simavr runner")),
            }?;
            Ok((Some(m), fp))
        });
        match r {
            Ok((m, fp)) => {
                eprintln!(
                    "bench [{}/{n}] {}: done in {:.1} s",
                    i + 1,
                    v.name,
                    t0.elapsed().as_secs_f64()
                );
                results.push(m);
                sizes.push(fp);
            }
            Err(e) if work.is_dir() => {
                return Err(e.with_note(format!("build files kept in `{}`", work.display())));
            }
            Err(e) => return Err(e),
        }
    }

    let (identical, all_met) = report::summarize(a, &pf, &variants, &results, &sizes)?;
    if temporary {
        let _ = std::fs::remove_dir_all(&work);
    } else {
        println!("build files in {}", work.display());
    }
    eprintln!(
        "bench: {} variants in {:.1} s",
        n,
        start.elapsed().as_secs_f64()
    );
    if !identical {
        return Err(CliError::failed(
            "qloop and plain_mul outputs differ (see above); the cost comparison is void",
        ));
    }
    if a.check_goals && !all_met {
        return Err(CliError::failed(
            "--check-goals: a goal is not met (see above)",
        ));
    }
    Ok(())
}
