//! `qloop bench`: cost per controller step on a target, for qloop's code and the baselines
//! compiled the same way.
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
//! `-std=c99 -Wall -Wextra -Werror`.
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

use crate::Fail;
use qloop::emit::{c as cemit, c_float};
use qloop::ir::{SigId, SigKind};
use qloop::qformat::{pow2, IntTy};
use qloop::Plan;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const DIV_H: &str = include_str!("../../../targets/bench/koren_masory_1981_div.h");
const DIV_FLOAT_C: &str = include_str!("../../../targets/bench/koren_masory_1981_div_float.c");
const DIV_INT32_C: &str = include_str!("../../../targets/bench/koren_masory_1981_div_int32.c");
const CYCLES_C: &str = include_str!("../../../targets/avr/cycles.c");
const SIM_PROTOCOL_H: &str = include_str!("../../../targets/avr/firmware/sim_protocol.h");

/// The spec the division baselines implement.
const DIV_SPEC: &str = "koren_masory_1981";

/// Wall-clock limit of one simulator run (a hung firmware is an error, not a hang).
const RUN_LIMIT: Duration = Duration::from_secs(600);

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

fn bad(msg: impl std::fmt::Display) -> Fail {
    eprintln!("error: {msg}");
    Fail(2)
}

fn failed(msg: impl std::fmt::Display) -> Fail {
    eprintln!("error: {msg}");
    Fail(1)
}

/// How a target's code is run and measured.
#[derive(Clone, Debug, PartialEq)]
enum Platform {
    /// simavr, exact cycles.
    Avr,
    /// qemu-system-arm with `-icount`, instructions; the machine and its memory map.
    Qemu {
        machine: String,
        flash: &'static str,
        ram: &'static str,
    },
    /// qemu-system-riscv32 with `-icount`, instructions from `minstret`; the machine and the
    /// `-cpu` model with the extensions of the target's `-march`.
    Riscv { machine: String, cpu: String },
}

impl Platform {
    fn unit(&self) -> &'static str {
        match self {
            Platform::Avr => "cycles",
            Platform::Qemu { .. } | Platform::Riscv { .. } => "instructions",
        }
    }

    fn method(&self) -> String {
        match self {
            Platform::Avr => {
                "cycles per step, exact, simulated by simavr (marker overhead subtracted; \
                 includes argument set-up, CALL and RET)"
                    .into()
            }
            Platform::Qemu { machine, .. } => format!(
                "instructions executed per step under QEMU (-M {machine}, -icount shift=10, \
                 SysTick-timed; includes the call, argument set-up and return; not cycles)"
            ),
            Platform::Riscv { machine, cpu } => format!(
                "instructions executed per step under QEMU (qemu-system-riscv32 -M {machine} \
                 -cpu {cpu}, -icount, minstret-timed; includes the call, argument set-up and \
                 return; not cycles)"
            ),
        }
    }
}

/// Which platform measures `target`, or what its toolchain lacks.
fn platform(t: &qloop::Target) -> Result<Platform, Fail> {
    let supported =
        "atmega328p (simavr), cortex-m0, cortex-m0-slowmul, cortex-m4, rv32i and rv32imc (QEMU)";
    let Some(cc) = &t.toolchain.cc else {
        return Err(bad(format!(
            "target `{}` has no C compiler in its toolchain (`[toolchain] cc` in its target \
             file), so `qloop bench` cannot build its code; targets it can measure: {supported}",
            t.name
        )));
    };
    if t.toolchain.simulator.as_deref() == Some("simavr") {
        return Ok(Platform::Avr);
    }
    if let Some(m) = &t.toolchain.qemu_machine {
        if cc.contains("riscv") || m == "virt" {
            return riscv_platform(t, cc, m);
        }
        let (flash, ram) = match m.as_str() {
            "microbit" => ("256K", "16K"),
            "mps2-an386" => ("4M", "4M"),
            other => {
                return Err(bad(format!(
                    "target `{}`: `qloop bench` has no memory map for QEMU machine `{other}` \
                     (known: microbit, mps2-an386; virt for RISC-V)",
                    t.name
                )))
            }
        };
        if !cc.contains("arm") {
            return Err(bad(format!(
                "target `{}`: QEMU machine `{m}` needs an ARM compiler, the toolchain names `{cc}`",
                t.name
            )));
        }
        return Ok(Platform::Qemu {
            machine: m.clone(),
            flash,
            ram,
        });
    }
    Err(bad(format!(
        "target `{}` names no simulator in its toolchain (`simulator = \"simavr\"` or \
         `qemu_machine`), so `qloop bench` cannot run its code; targets it can measure: \
         {supported}",
        t.name
    )))
}

/// The RISC-V platform: machine `virt`, a `riscv*` compiler and an RV32 `-march` in the cflags,
/// whose extensions give QEMU's `-cpu`.
fn riscv_platform(t: &qloop::Target, cc: &str, m: &str) -> Result<Platform, Fail> {
    if m != "virt" {
        return Err(bad(format!(
            "target `{}`: `qloop bench` runs RISC-V code on QEMU machine `virt` only, the \
             toolchain names `{m}`",
            t.name
        )));
    }
    if !cc.contains("riscv") {
        return Err(bad(format!(
            "target `{}`: QEMU machine `virt` needs a RISC-V compiler, the toolchain names `{cc}`",
            t.name
        )));
    }
    let march = t
        .toolchain
        .cflags
        .iter()
        .find_map(|f| f.strip_prefix("-march="))
        .unwrap_or("");
    let cpu = riscv_cpu(march).ok_or_else(|| {
        bad(format!(
            "target `{}`: `qloop bench` needs an RV32 `-march=rv32...` in `[toolchain] cflags` \
             (it picks QEMU's -cpu from it), found `{}`",
            t.name,
            if march.is_empty() { "none" } else { march }
        ))
    })?;
    if !t
        .toolchain
        .cflags
        .iter()
        .any(|f| f.starts_with("-mabi=ilp32"))
    {
        return Err(bad(format!(
            "target `{}`: `qloop bench` needs `-mabi=ilp32` (or ilp32e/f/d) in `[toolchain] \
             cflags` next to `-march={march}`",
            t.name
        )));
    }
    Ok(Platform::Riscv {
        machine: m.to_string(),
        cpu,
    })
}

/// QEMU's `-cpu` for an RV32 `-march` (`rv32imc` → `rv32,a=false,f=false,d=false`): the
/// base `rv32` model with each single-letter extension the string lacks turned off.
/// `None` unless it starts `rv32i` or `rv32g` (RV32E is not measured).
fn riscv_cpu(march: &str) -> Option<String> {
    let rest = march.strip_prefix("rv32")?;
    // Single-letter extensions end at the first `_` (multi-letter ones, e.g. `_zicsr`).
    let letters = rest.split('_').next().unwrap_or("");
    let letters = letters.replace('g', "imafd");
    let has: Vec<char> = letters.strip_prefix('i')?.chars().collect();
    let mut cpu = "rv32".to_string();
    for ext in ['m', 'a', 'f', 'd', 'c'] {
        if !has.contains(&ext) {
            let _ = write!(cpu, ",{ext}=false");
        }
    }
    Some(cpu)
}

/// Fails with an install hint unless `prog --version` runs.
fn need_tool(prog: &str, hint: &str) -> Result<(), Fail> {
    match Command::new(prog)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(_) => Ok(()),
        Err(e) => Err(failed(format!(
            "`{prog}` cannot be run ({e}); `qloop bench` needs it: {hint}"
        ))),
    }
}

// ---------------------------------------------------------------------------------------
// Variants

/// How an output value comes back from the firmware.
#[derive(Clone, Copy, Debug)]
enum OutKind {
    /// A raw integer of this type and fraction bits.
    Raw(IntTy, i32),
    /// A `float`, sent as its bits.
    Float,
}

impl OutKind {
    fn value(self, raw: i64) -> f64 {
        match self {
            OutKind::Raw(ty, frac) => {
                let r = if !ty.signed && ty.bits == 64 {
                    raw as u64 as f64
                } else {
                    raw as f64
                };
                r * pow2(-frac)
            }
            OutKind::Float => f32::from_bits(raw as u32) as f64,
        }
    }
}

/// One benchmarked routine: its files and API.
struct Variant {
    name: &'static str,
    /// Files written next to `main.c` (name, text).
    files: Vec<(String, String)>,
    /// Which of them to compile.
    sources: Vec<String>,
    header: String,
    /// Prefix of the API: `P_state`, `P_inputs`, `P_outputs`, `P_init`, `P_step`.
    prefix: String,
    /// Input fields, declaration order, and each step's C initialisers for them.
    inputs: Vec<String>,
    table: Vec<Vec<String>>,
    /// Output fields and how to read them back.
    outputs: Vec<(String, OutKind)>,
}

/// The scripted physical value of an input with declared range `[lo, hi]` at each step:
/// below the range, its start and just above it (an air cut for a force), then levels held
/// across the range (4 % = just above a force's air-cut threshold, 20, 30, 50, 80, 30 %),
/// a ramp to 110 % and a ramp back down. `phase` shifts the script (one per input).
pub fn stimulus(lo: f64, hi: f64, steps: usize, phase: f64) -> Vec<f64> {
    let span = if hi > lo { hi - lo } else { 1.0 };
    let pick =
        |levels: &[f64], x: f64| levels[((x * levels.len() as f64) as usize).min(levels.len() - 1)];
    (0..steps)
        .map(|i| {
            let p = (i as f64 / steps as f64 + phase).fract();
            let f = if p < 0.10 {
                pick(&[-0.1, 0.0, 0.02], p / 0.10)
            } else if p < 0.60 {
                pick(&[0.04, 0.2, 0.3, 0.5, 0.8, 0.3], (p - 0.10) / 0.50)
            } else if p < 0.85 {
                1.1 * (p - 0.60) / 0.25
            } else {
                1.0 - (p - 0.85) / 0.15
            };
            lo + f * span
        })
        .collect()
}

/// Each input's physical value per step: `values[step][input]`.
fn script(plan: &Plan, steps: usize) -> Vec<Vec<f64>> {
    let ins: Vec<SigId> = plan.prog.ids_of(SigKind::Input).collect();
    let cols: Vec<Vec<f64>> = ins
        .iter()
        .enumerate()
        .map(|(k, id)| {
            let (lo, hi) = plan.prog.sig(*id).range.unwrap_or((0.0, 1.0));
            stimulus(lo, hi, steps, 0.37 * k as f64)
        })
        .collect();
    (0..steps)
        .map(|i| cols.iter().map(|c| c[i]).collect())
        .collect()
}

/// `floor(v · 2^frac)` clamped to the type.
fn raw_of(v: f64, ty: IntTy, frac: i32) -> i128 {
    ((v * pow2(frac)).floor() as i128).clamp(ty.min(), ty.max())
}

/// The fixed-point variant of `plan` (`qloop` or `plain_mul`).
fn fixed_variant(name: &'static str, plan: &Plan, values: &[Vec<f64>]) -> Variant {
    let p = &plan.prog;
    let (h, c) = qloop::gen_c(plan);
    let ins: Vec<SigId> = p.ids_of(SigKind::Input).collect();
    let table = values
        .iter()
        .map(|row| {
            ins.iter()
                .zip(row)
                .map(|(id, v)| {
                    let q = plan.format(*id);
                    cemit::c_lit(raw_of(*v, q.ty, q.frac), q.ty)
                })
                .collect()
        })
        .collect();
    Variant {
        name,
        files: vec![(format!("{}.h", p.name), h), (format!("{}.c", p.name), c)],
        sources: vec![format!("{}.c", p.name)],
        header: format!("{}.h", p.name),
        prefix: p.name.clone(),
        inputs: ins
            .iter()
            .map(|id| cemit::ident(&p.sig(*id).name))
            .collect(),
        table,
        outputs: p
            .ids_of(SigKind::Output)
            .map(|id| {
                let q = plan.format(id);
                (cemit::ident(&p.sig(id).name), OutKind::Raw(q.ty, q.frac))
            })
            .collect(),
    }
}

/// The spec's step in C `float`.
fn float_variant(plan: &Plan, values: &[Vec<f64>]) -> Variant {
    let p = &plan.prog;
    let (h, c) = c_float::source(p);
    Variant {
        name: "float",
        files: vec![
            (format!("{}_f.h", p.name), h),
            (format!("{}_f.c", p.name), c),
        ],
        sources: vec![format!("{}_f.c", p.name)],
        header: format!("{}_f.h", p.name),
        prefix: format!("{}_f", p.name),
        inputs: p
            .ids_of(SigKind::Input)
            .map(|id| c_float::ident(&p.sig(id).name))
            .collect(),
        table: values
            .iter()
            .map(|row| row.iter().map(|v| c_float::lit(*v)).collect())
            .collect(),
        outputs: p
            .ids_of(SigKind::Output)
            .map(|id| (c_float::ident(&p.sig(id).name), OutKind::Float))
            .collect(),
    }
}

/// Whether the hand-written division baselines implement this spec (same name and signals).
fn has_div_baselines(plan: &Plan) -> bool {
    let p = &plan.prog;
    let names = |k| {
        p.ids_of(k)
            .map(|id| p.sig(id).name.clone())
            .collect::<Vec<_>>()
    };
    p.name == DIV_SPEC && names(SigKind::Input) == ["fc"] && names(SigKind::Output) == ["feed"]
}

/// `div_float` and `div_int32` (Q12 `int16_t`, see `koren_masory_1981_div.h`).
fn div_variants(values: &[Vec<f64>]) -> [Variant; 2] {
    let hdr = "koren_masory_1981_div.h".to_string();
    let q12 = IntTy {
        signed: true,
        bits: 16,
    };
    let mk = |name, file: &str, text: &str, prefix: &str, table, kind| Variant {
        name,
        files: vec![
            (hdr.clone(), DIV_H.to_string()),
            (file.to_string(), text.to_string()),
        ],
        sources: vec![file.to_string()],
        header: hdr.clone(),
        prefix: prefix.to_string(),
        inputs: vec!["fc".into()],
        table,
        outputs: vec![("feed".into(), kind)],
    };
    [
        mk(
            "div_float",
            "koren_masory_1981_div_float.c",
            DIV_FLOAT_C,
            "koren_masory_1981_divf",
            values.iter().map(|r| vec![c_float::lit(r[0])]).collect(),
            OutKind::Float,
        ),
        mk(
            "div_int32",
            "koren_masory_1981_div_int32.c",
            DIV_INT32_C,
            "koren_masory_1981_divi",
            values
                .iter()
                .map(|r| vec![cemit::c_lit(raw_of(r[0], q12, 12), q12)])
                .collect(),
            OutKind::Raw(q12, 12),
        ),
    ]
}

// ---------------------------------------------------------------------------------------
// Firmware text

/// `bench_io.h` on the AVR: simavr markers and value reports (`sim_protocol.h`).
const AVR_IO_H: &str = r#"/* bench_io.h -- qloop bench on the AVR in simavr (targets/avr/cycles.c): markers and
 * value reports through GPIOR0..2, see sim_protocol.h. */
#ifndef QLOOP_BENCH_IO_H
#define QLOOP_BENCH_IO_H
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <stdint.h>
#include "sim_protocol.h"

/* The input table lives in flash. */
#define BENCH_ROM PROGMEM

/* The measured bracket: LDI+OUT markers, interrupts are never enabled. */
#define BENCH_TIMED(call)                                                                      \
    do {                                                                                       \
        MARK(MARK_STEP_BEGIN);                                                                 \
        call;                                                                                  \
        MARK(MARK_STEP_END);                                                                   \
    } while (0)

static inline void bench_setup(void) { __asm__ __volatile__("cli" ::: "memory"); }

/* An empty marker pair: the runner subtracts its cycles from every step. */
static inline void bench_calibrate(void)
{
    MARK(MARK_CAL_BEGIN);
    MARK(MARK_CAL_END);
}

static inline void bench_load(void *dst, const void *src, uint16_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    while (n--)
        *d++ = pgm_read_byte(s++);
}

static inline void bench_record_begin(uint32_t i) { (void)i; }

/* Eight bytes, least significant first, committed as a signed 8-byte value. */
static inline void bench_value(int64_t v)
{
    uint64_t u = (uint64_t)v;
    uint8_t k;
    for (k = 0; k < 8; k++) {
        GPIOR1 = (uint8_t)u;
        u >>= 8;
    }
    GPIOR2 = 0x88;
}

static inline void bench_value_f(float f)
{
    union {
        float f;
        uint32_t u;
    } c;
    c.f = f;
    bench_value((int64_t)c.u);
}

static inline void bench_record_end(void) { MARK(MARK_RECORD_END); }

static inline void bench_done(void)
{
    MARK(MARK_DONE);
    for (;;)
        __asm__ __volatile__("cli\n\tsleep" ::: "memory");
}
#endif
"#;

/// `bench_io.h` on Cortex-M under QEMU: SysTick timing, semihosting text lines.
const ARM_IO_H: &str = r#"/* bench_io.h -- qloop bench on Cortex-M under QEMU -icount: SysTick brackets, results as
 * text lines over semihosting ("qb calib ...", "qb step ...", "qb done"). */
#ifndef QLOOP_BENCH_IO_H
#define QLOOP_BENCH_IO_H
#include <stdint.h>

#define BENCH_ROM

#define BENCH_SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define BENCH_SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define BENCH_SYST_CVR (*(volatile uint32_t *)0xE000E018u)

void bench_write(const char *s); /* startup.c: semihosting SYS_WRITE0 */

static uint32_t bench_ticks;

/* SysTick counts down, 24 bits. Under -icount it advances the same per instruction. */
#define BENCH_TIMED(call)                                                                      \
    do {                                                                                       \
        uint32_t bench_t0_, bench_t1_;                                                         \
        __asm__ __volatile__("" ::: "memory");                                                 \
        bench_t0_ = BENCH_SYST_CVR;                                                            \
        call;                                                                                  \
        bench_t1_ = BENCH_SYST_CVR;                                                            \
        __asm__ __volatile__("" ::: "memory");                                                 \
        bench_ticks = (bench_t0_ - bench_t1_) & 0xFFFFFFu;                                     \
    } while (0)

static char bench_line[512];
static unsigned bench_len;

static inline void bench_flush(void)
{
    bench_line[bench_len] = 0;
    bench_write(bench_line);
    bench_len = 0;
}

static inline void bench_char(char c)
{
    if (bench_len + 2 > sizeof bench_line)
        bench_flush();
    bench_line[bench_len++] = c;
}

static inline void bench_str(const char *s)
{
    while (*s)
        bench_char(*s++);
}

static inline void bench_hex32(uint32_t v)
{
    int k;
    for (k = 28; k >= 0; k -= 4)
        bench_char("0123456789abcdef"[(v >> k) & 15u]);
}

/* " " and 16 hex digits. */
static inline void bench_value(int64_t v)
{
    uint64_t u = (uint64_t)v;
    bench_char(' ');
    bench_hex32((uint32_t)(u >> 32));
    bench_hex32((uint32_t)u);
}

static inline void bench_value_f(float f)
{
    union {
        float f;
        uint32_t u;
    } c;
    c.f = f;
    bench_value((int64_t)c.u);
}

static inline void bench_setup(void)
{
    BENCH_SYST_RVR = 0xFFFFFFu;
    BENCH_SYST_CVR = 0;
    BENCH_SYST_CSR = 5u; /* enable, core clock, no interrupt */
    (void)BENCH_SYST_CVR;
}

__attribute__((noinline)) static void bench_nop0(void) { __asm__ __volatile__(""); }
__attribute__((noinline)) static void bench_nop64(void)
{
    __asm__ __volatile__(".rept 64\n\tnop\n\t.endr");
}

/* Least ticks of 8 runs each: the empty bracket, a call of an empty function and of one
 * with 64 nops (their difference is 64 instructions). */
static inline void bench_calibrate(void)
{
    uint32_t e = 0xFFFFFFFFu, a = 0xFFFFFFFFu, b = 0xFFFFFFFFu;
    int k;
    for (k = 0; k < 8; k++) {
        BENCH_TIMED((void)0);
        if (bench_ticks < e)
            e = bench_ticks;
        BENCH_TIMED(bench_nop0());
        if (bench_ticks < a)
            a = bench_ticks;
        BENCH_TIMED(bench_nop64());
        if (bench_ticks < b)
            b = bench_ticks;
    }
    bench_str("qb calib");
    bench_value((int64_t)e);
    bench_value((int64_t)a);
    bench_value((int64_t)b);
    bench_char('\n');
    bench_flush();
}

static inline void bench_load(void *dst, const void *src, uint32_t n)
{
    /* volatile: keeps GCC from turning the loop into a memcpy call. */
    unsigned char *d = (unsigned char *)dst;
    const volatile unsigned char *s = (const volatile unsigned char *)src;
    while (n--)
        *d++ = *s++;
}

static inline void bench_record_begin(uint32_t i)
{
    bench_str("qb step");
    bench_value((int64_t)i);
    bench_value((int64_t)bench_ticks);
}

static inline void bench_record_end(void)
{
    bench_char('\n');
    bench_flush();
}

static inline void bench_done(void)
{
    bench_str("qb done\n");
    bench_flush();
}
#endif
"#;

/// Reset handler, vector table and semihosting for the QEMU machines.
const ARM_STARTUP_C: &str = r#"/* startup.c -- qloop bench on Cortex-M under QEMU: vector table, reset (copy .data, zero
 * .bss, enable the FPU if the code uses it), semihosting write and exit. */
#include <stdint.h>

extern uint32_t _estack, _sidata, _sdata, _edata, _sbss, _ebss;
int main(void);
void bench_reset(void);
void bench_fault(void);
void bench_write(const char *s);

static void bench_semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ __volatile__("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
}

void bench_write(const char *s) { bench_semihost(0x04u, s); }

/* SYS_EXIT: ADP_Stopped_ApplicationExit (QEMU exits 0) or RunTimeErrorUnknown (exits 1). */
static void bench_exit(int ok)
{
    bench_semihost(0x18u, (const void *)(uintptr_t)(ok ? 0x20026u : 0x20023u));
    for (;;) {
    }
}

void bench_fault(void)
{
    bench_write("qb fault\n");
    bench_exit(0);
}

void bench_reset(void)
{
    uint32_t *s = &_sidata, *d = &_sdata;
    while (d < &_edata)
        *d++ = *s++;
    for (d = &_sbss; d < &_ebss;)
        *d++ = 0;
#if defined(__ARM_FP)
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* CPACR: CP10, CP11 full access */
    __asm__ __volatile__("dsb\n\tisb" ::: "memory");
#endif
    bench_exit(main() == 0);
}

__attribute__((section(".vectors"), used)) const uintptr_t bench_vectors[16] = {
    (uintptr_t)&_estack, (uintptr_t)bench_reset, (uintptr_t)bench_fault,
    (uintptr_t)bench_fault, (uintptr_t)bench_fault, (uintptr_t)bench_fault,
    (uintptr_t)bench_fault, 0, 0, 0, 0, (uintptr_t)bench_fault, (uintptr_t)bench_fault, 0,
    (uintptr_t)bench_fault, (uintptr_t)bench_fault,
};
"#;

fn arm_link_ld(flash: &str, ram: &str) -> String {
    format!(
        "/* qloop bench: QEMU machine memory map */\n\
         MEMORY\n{{\n  FLASH (rx) : ORIGIN = 0x00000000, LENGTH = {flash}\n  \
         RAM (rwx) : ORIGIN = 0x20000000, LENGTH = {ram}\n}}\n\
         ENTRY(bench_reset)\n\
         SECTIONS\n{{\n  \
         .text : {{ KEEP(*(.vectors)) *(.text*) *(.rodata*) . = ALIGN(4); }} > FLASH\n  \
         .ARM.exidx : {{ *(.ARM.exidx*) }} > FLASH\n  \
         .data : {{ _sdata = .; *(.data*) . = ALIGN(4); _edata = .; }} > RAM AT > FLASH\n  \
         _sidata = LOADADDR(.data);\n  \
         .bss (NOLOAD) : {{ _sbss = .; *(.bss*) *(COMMON) . = ALIGN(4); _ebss = .; }} > RAM\n  \
         _estack = ORIGIN(RAM) + LENGTH(RAM);\n}}\n"
    )
}

/// `bench_io.h` on RV32 under QEMU `virt`: `minstret` brackets, text lines on the UART.
const RV_IO_H: &str = r#"/* bench_io.h -- qloop bench on RV32 under QEMU -M virt -icount: minstret brackets,
 * results as text lines on the 16550 UART ("qb calib ...", "qb step ...", "qb done"). */
#ifndef QLOOP_BENCH_IO_H
#define QLOOP_BENCH_IO_H
#include <stdint.h>

#define BENCH_ROM

void bench_putc(char c); /* startup.c: UART */

/* csrr %0, minstret (CSR 0xB02), encoded with .insn: assemblers that want the Zicsr
 * extension named in -march accept it too. Under -icount it counts instructions exactly. */
#define BENCH_INSTRET(v) __asm__ __volatile__(".insn i 0x73, 2, %0, x0, -1278" : "=r"(v) : : "memory")

static uint32_t bench_ticks;

#define BENCH_TIMED(call)                                                                      \
    do {                                                                                       \
        uint32_t bench_t0_, bench_t1_;                                                         \
        BENCH_INSTRET(bench_t0_);                                                              \
        call;                                                                                  \
        BENCH_INSTRET(bench_t1_);                                                              \
        bench_ticks = bench_t1_ - bench_t0_;                                                   \
    } while (0)

static inline void bench_char(char c) { bench_putc(c); }

static inline void bench_str(const char *s)
{
    while (*s)
        bench_char(*s++);
}

static inline void bench_hex32(uint32_t v)
{
    int k;
    for (k = 28; k >= 0; k -= 4)
        bench_char("0123456789abcdef"[(v >> k) & 15u]);
}

/* " " and 16 hex digits. */
static inline void bench_value(int64_t v)
{
    uint64_t u = (uint64_t)v;
    bench_char(' ');
    bench_hex32((uint32_t)(u >> 32));
    bench_hex32((uint32_t)u);
}

static inline void bench_value_f(float f)
{
    union {
        float f;
        uint32_t u;
    } c;
    c.f = f;
    bench_value((int64_t)c.u);
}

static inline void bench_setup(void) {}

__attribute__((noinline)) static void bench_nop0(void) { __asm__ __volatile__(""); }
__attribute__((noinline)) static void bench_nop64(void)
{
    __asm__ __volatile__(".rept 64\n\tnop\n\t.endr");
}

/* Least counts of 8 runs each: the empty bracket, a call of an empty function and of one
 * with 64 nops (their difference is 64 instructions). */
static inline void bench_calibrate(void)
{
    uint32_t e = 0xFFFFFFFFu, a = 0xFFFFFFFFu, b = 0xFFFFFFFFu;
    int k;
    for (k = 0; k < 8; k++) {
        BENCH_TIMED((void)0);
        if (bench_ticks < e)
            e = bench_ticks;
        BENCH_TIMED(bench_nop0());
        if (bench_ticks < a)
            a = bench_ticks;
        BENCH_TIMED(bench_nop64());
        if (bench_ticks < b)
            b = bench_ticks;
    }
    bench_str("qb calib");
    bench_value((int64_t)e);
    bench_value((int64_t)a);
    bench_value((int64_t)b);
    bench_char('\n');
}

static inline void bench_load(void *dst, const void *src, uint32_t n)
{
    /* volatile: keeps GCC from turning the loop into a memcpy call. */
    unsigned char *d = (unsigned char *)dst;
    const volatile unsigned char *s = (const volatile unsigned char *)src;
    while (n--)
        *d++ = *s++;
}

static inline void bench_record_begin(uint32_t i)
{
    bench_str("qb step");
    bench_value((int64_t)i);
    bench_value((int64_t)bench_ticks);
}

static inline void bench_record_end(void) { bench_char('\n'); }

static inline void bench_done(void) { bench_str("qb done\n"); }
#endif
"#;

/// Entry, trap handler, UART, exit and the `mem*` routines GCC may call, for QEMU `virt`.
const RV_STARTUP_C: &str = r#"/* startup.c -- qloop bench on RV32 under QEMU -M virt -bios none: entry at the start of
 * RAM (gp, sp, mtvec), .bss zeroed, UART output, exit through the SiFive test device. */
#include <stddef.h>
#include <stdint.h>

extern uint32_t _sbss, _ebss;
int main(void);
void bench_reset(void);
void bench_fault(void);
void bench_putc(char c);

/* csrw mtvec, t0 (CSR 0x305) as .insn, see bench_io.h. */
__asm__(".section .text.start,\"ax\",@progbits\n"
        ".globl _start\n"
        "_start:\n"
        ".option push\n"
        ".option norelax\n"
        "\tla gp, __global_pointer$\n"
        ".option pop\n"
        "\tla sp, _estack\n"
        "\tla t0, bench_trap\n"
        "\t.insn i 0x73, 1, x0, t0, 0x305\n"
        "\tcall bench_reset\n"
        "1:\tj 1b\n"
        ".text\n"
        ".balign 4\n"
        "bench_trap:\n"
        "\tla sp, _estack\n"
        "\tj bench_fault\n");

#define BENCH_UART ((volatile uint8_t *)0x10000000u)
#define BENCH_TEST (*(volatile uint32_t *)0x00100000u)

void bench_putc(char c)
{
    while (!(BENCH_UART[5] & 0x20u)) /* LSR: transmitter holding register empty */
        ;
    BENCH_UART[0] = (uint8_t)c;
}

/* FINISHER_PASS (QEMU exits 0) or FINISHER_FAIL with code 1. */
static void bench_exit(int ok)
{
    BENCH_TEST = ok ? 0x5555u : 0x13333u;
    for (;;) {
    }
}

void bench_fault(void)
{
    const char *s = "\nqb fault\n";
    while (*s)
        bench_putc(*s++);
    bench_exit(0);
}

void bench_reset(void)
{
    uint32_t *d;
    for (d = &_sbss; d < &_ebss;)
        *d++ = 0;
    bench_exit(main() == 0);
}

/* GCC may call these for struct copies even when freestanding; volatile keeps it from
 * turning the loops back into calls. */
void *memcpy(void *dst, const void *src, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    const unsigned char *s = (const unsigned char *)src;
    while (n--)
        *d++ = *s++;
    return dst;
}

void *memmove(void *dst, const void *src, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    const unsigned char *s = (const unsigned char *)src;
    if (d < s) {
        while (n--)
            *d++ = *s++;
    } else {
        while (n--)
            d[n] = s[n];
    }
    return dst;
}

void *memset(void *dst, int c, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    while (n--)
        *d++ = (unsigned char)c;
    return dst;
}
"#;

/// Everything in the RAM of QEMU `virt` (from 0x80000000, where `-bios none` jumps); QEMU
/// loads the ELF, so `.data` needs no copy.
const RV_LINK_LD: &str = "/* qloop bench: QEMU virt, everything in RAM */\n\
MEMORY\n{\n  RAM (rwx) : ORIGIN = 0x80000000, LENGTH = 64M\n}\n\
ENTRY(_start)\n\
SECTIONS\n{\n  \
.text : { KEEP(*(.text.start)) *(.text*) } > RAM\n  \
.rodata : { *(.rodata*) *(.srodata*) . = ALIGN(4); } > RAM\n  \
.data : { __global_pointer$ = . + 0x800; *(.data*) *(.sdata*) . = ALIGN(4); } > RAM\n  \
.bss (NOLOAD) : { _sbss = .; *(.sbss*) *(.bss*) *(COMMON) . = ALIGN(4); _ebss = .; } > RAM\n  \
_estack = ORIGIN(RAM) + LENGTH(RAM);\n}\n";

/// The variant's `main.c`: table, init, then per step load, timed step, report.
fn main_c(v: &Variant) -> String {
    let p = &v.prefix;
    let mut o = format!(
        "/* main.c -- qloop bench, variant `{}`: {} steps of {p}_step on a scripted input. */\n\
         #include <stdint.h>\n#include \"bench_io.h\"\n#include \"{}\"\n\n\
         #define BENCH_STEPS {}u\n\n\
         static const {p}_inputs bench_table[BENCH_STEPS] BENCH_ROM = {{\n",
        v.name,
        v.table.len(),
        v.header,
        v.table.len()
    );
    for row in &v.table {
        let fields: Vec<String> = v
            .inputs
            .iter()
            .zip(row)
            .map(|(f, x)| format!(".{f} = {x}"))
            .collect();
        let _ = writeln!(o, "    {{{}}},", fields.join(", "));
    }
    let _ = write!(
        o,
        "}};\n\n\
         static {p}_state bench_state;\nstatic {p}_inputs bench_in;\nstatic {p}_outputs bench_out;\n\n\
         int main(void)\n{{\n    uint32_t i;\n    bench_setup();\n    bench_calibrate();\n    \
         {p}_init(&bench_state);\n    for (i = 0; i < BENCH_STEPS; i++) {{\n        \
         bench_load(&bench_in, &bench_table[i], sizeof bench_in);\n        \
         BENCH_TIMED({p}_step(&bench_state, &bench_in, &bench_out));\n        \
         bench_record_begin(i);\n"
    );
    for (f, k) in &v.outputs {
        match k {
            OutKind::Raw(..) => {
                let _ = writeln!(o, "        bench_value((int64_t)bench_out.{f});");
            }
            OutKind::Float => {
                let _ = writeln!(o, "        bench_value_f(bench_out.{f});");
            }
        }
    }
    o.push_str("        bench_record_end();\n    }\n    bench_done();\n    return 0;\n}\n");
    o
}

// ---------------------------------------------------------------------------------------
// Building and running

/// A run's raw results: cost and raw outputs per step.
struct Measured {
    cost: Vec<u64>,
    outs: Vec<Vec<i64>>,
}

impl Measured {
    fn mean(&self) -> f64 {
        self.cost.iter().sum::<u64>() as f64 / self.cost.len().max(1) as f64
    }
    fn min(&self) -> u64 {
        self.cost.iter().copied().min().unwrap_or(0)
    }
    fn max(&self) -> u64 {
        self.cost.iter().copied().max().unwrap_or(0)
    }
}

fn write_file(p: &Path, text: &str) -> Result<(), Fail> {
    crate::write_atomic(p, text)
}

fn mkdir(p: &Path) -> Result<(), Fail> {
    std::fs::create_dir_all(p).map_err(|e| failed(format!("cannot create `{}`: {e}", p.display())))
}

/// The cache directory of `qloop bench` (the simavr runner).
fn cache_dir() -> PathBuf {
    std::env::var_os("QLOOP_CACHE")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/qloop")))
        .unwrap_or_else(|| std::env::temp_dir().join("qloop-cache"))
        .join("bench")
}

fn sha_key(text: &str) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(text.as_bytes())
        .iter()
        .take(8)
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The simavr cycle runner (`targets/avr/cycles.c`), compiled with the host `cc` on first use.
fn avr_runner() -> Result<PathBuf, Fail> {
    let dir = cache_dir();
    let exe = dir.join(format!("simavr-cycles-{}", sha_key(CYCLES_C)));
    if exe.is_file() {
        return Ok(exe);
    }
    need_tool(
        "cc",
        "a host C compiler builds the simavr cycle runner (Debian: apt-get install gcc)",
    )?;
    mkdir(&dir)?;
    let src = dir.join(format!("cycles-{}.c", std::process::id()));
    write_file(&src, CYCLES_C)?;
    let include = Command::new("pkg-config")
        .args(["--cflags", "simavr"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "-I/usr/include/simavr".into());
    let tmp = dir.join(format!(".simavr-cycles.tmp{}", std::process::id()));
    let mut errors = String::new();
    // The static libsimavr.a needs libelf (libelf-dev); the shared one brings it itself.
    for libs in [
        &["-lsimavr", "-lelf"][..],
        &["-l:libsimavr.so.2"][..],
        &["-lsimavr"][..],
    ] {
        let out = Command::new("cc")
            .args(["-O2", "-std=c99", "-Wall", "-Wextra"])
            .args(include.split_whitespace())
            .arg(&src)
            .arg("-o")
            .arg(&tmp)
            .args(libs)
            .output()
            .map_err(|e| failed(format!("cannot run the host `cc`: {e}")))?;
        if out.status.success() {
            let _ = std::fs::remove_file(&src);
            std::fs::rename(&tmp, &exe).map_err(|e| {
                failed(format!(
                    "cannot move the runner to `{}`: {e}",
                    exe.display()
                ))
            })?;
            return Ok(exe);
        }
        let _ = writeln!(
            errors,
            "  with {}: {}",
            libs.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let _ = std::fs::remove_file(&src);
    Err(failed(format!(
        "cannot build the simavr cycle runner (targets/avr/cycles.c) with the host `cc`; \
         install simavr and libsimavr-dev (Debian: apt-get install simavr libsimavr-dev libelf-dev):\n{errors}"
    )))
}

/// Runs `cmd` with its output in files, killing it after [`RUN_LIMIT`].
fn run_limited(
    cmd: &mut Command,
    what: &str,
    out: &Path,
    err: &Path,
) -> Result<(std::process::ExitStatus, String, String), Fail> {
    let open = |p: &Path| {
        std::fs::File::create(p)
            .map_err(|e| failed(format!("cannot create `{}`: {e}", p.display())))
    };
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(open(out)?)
        .stderr(open(err)?)
        .spawn()
        .map_err(|e| failed(format!("cannot start {what}: {e}")))?;
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if start.elapsed() > RUN_LIMIT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(failed(format!(
                    "{what} did not finish within {} s (killed); output in `{}`",
                    RUN_LIMIT.as_secs(),
                    err.display()
                )));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(10)),
            Err(e) => return Err(failed(format!("waiting for {what}: {e}"))),
        }
    };
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    Ok((status, read(out), read(err)))
}

/// Writes the variant's files into `dir` and compiles its ELF.
fn build(v: &Variant, t: &qloop::Target, pf: &Platform, dir: &Path) -> Result<PathBuf, Fail> {
    mkdir(dir)?;
    for (name, text) in &v.files {
        write_file(&dir.join(name), text)?;
    }
    write_file(&dir.join("main.c"), &main_c(v))?;
    let cc = t.toolchain.cc.clone().unwrap_or_default();
    let elf = dir.join(format!("{}.elf", v.name));
    let mut cmd = Command::new(&cc);
    cmd.current_dir(dir)
        .args(&t.toolchain.cflags)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror"])
        .arg("-I.")
        .arg("main.c")
        .args(&v.sources);
    match pf {
        Platform::Avr => {
            write_file(&dir.join("bench_io.h"), AVR_IO_H)?;
            write_file(&dir.join("sim_protocol.h"), SIM_PROTOCOL_H)?;
        }
        Platform::Qemu { flash, ram, .. } => {
            write_file(&dir.join("bench_io.h"), ARM_IO_H)?;
            write_file(&dir.join("startup.c"), ARM_STARTUP_C)?;
            write_file(&dir.join("link.ld"), &arm_link_ld(flash, ram))?;
            cmd.args(["startup.c", "-nostartfiles", "-Tlink.ld"]);
        }
        Platform::Riscv { .. } => {
            write_file(&dir.join("bench_io.h"), RV_IO_H)?;
            write_file(&dir.join("startup.c"), RV_STARTUP_C)?;
            write_file(&dir.join("link.ld"), RV_LINK_LD)?;
            // No C library (Debian's riscv64-unknown-elf-gcc has none): libgcc brings the
            // soft-float, multiply and divide helpers.
            cmd.args(["startup.c", "-nostdlib", "-Tlink.ld"]);
        }
    }
    cmd.arg("-o").arg(&elf);
    if matches!(pf, Platform::Riscv { .. }) {
        cmd.arg("-lgcc");
    }
    let shown = format!("{cc} {}", t.toolchain.cflags.join(" "));
    let out = cmd
        .output()
        .map_err(|e| failed(format!("cannot run `{cc}`: {e}")))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let hint = if err.contains("overflow") {
            "\nhelp: the input table may not fit the target's memory; try fewer --steps"
        } else {
            ""
        };
        return Err(failed(format!(
            "compiling variant `{}` with `{shown} -std=c99 -Wall -Wextra -Werror` failed \
             (files in `{}`):\n{}{hint}",
            v.name,
            dir.display(),
            err.trim_end()
        )));
    }
    Ok(elf)
}

/// Runs the ELF in simavr; exact cycles per step and the reported outputs.
fn run_avr(runner: &Path, elf: &Path, v: &Variant, steps: usize) -> Result<Measured, Fail> {
    let dir = elf.parent().unwrap_or(Path::new("."));
    let (status, out, err) = run_limited(
        Command::new(runner).arg(elf),
        "the simavr cycle runner",
        &dir.join("simavr.out"),
        &dir.join("simavr.err"),
    )?;
    if !status.success() {
        return Err(failed(format!(
            "simavr run of variant `{}` failed ({status}):\n{}",
            v.name,
            err.trim_end()
        )));
    }
    let mut m = Measured {
        cost: Vec::new(),
        outs: Vec::new(),
    };
    for line in out.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["step", _, "cycles", n] => m.cost.push(num(n, line)?),
            ["out", _, vals @ ..] => m.outs.push(
                vals.iter()
                    .map(|s| s.parse::<i64>().map_err(|_| malformed(line)))
                    .collect::<Result<_, _>>()?,
            ),
            _ => {}
        }
    }
    check_counts(&m, v, steps, &out)?;
    Ok(m)
}

fn malformed(line: &str) -> Fail {
    failed(format!("malformed line from the simulator: `{line}`"))
}

fn num(s: &str, line: &str) -> Result<u64, Fail> {
    s.parse().map_err(|_| malformed(line))
}

fn hex(s: &str, line: &str) -> Result<i64, Fail> {
    u64::from_str_radix(s, 16)
        .map(|u| u as i64)
        .map_err(|_| malformed(line))
}

fn check_counts(m: &Measured, v: &Variant, steps: usize, out: &str) -> Result<(), Fail> {
    if m.cost.len() != steps
        || m.outs.len() != steps
        || m.outs.iter().any(|o| o.len() != v.outputs.len())
    {
        let tail: Vec<&str> = out.lines().rev().take(5).collect();
        return Err(failed(format!(
            "variant `{}`: the simulator reported {} timed steps and {} output records for {} steps \
             of {} outputs; last lines:\n{}",
            v.name,
            m.cost.len(),
            m.outs.len(),
            steps,
            v.outputs.len(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        )));
    }
    Ok(())
}

/// Runs the ELF under QEMU with `-icount`; instructions per step and the reported outputs.
fn run_qemu(elf: &Path, pf: &Platform, v: &Variant, steps: usize) -> Result<Measured, Fail> {
    let dir = elf.parent().unwrap_or(Path::new("."));
    let (prog, mut cmd) = match pf {
        Platform::Riscv { machine, cpu } => {
            let prog = "qemu-system-riscv32";
            let mut cmd = Command::new(prog);
            cmd.args(["-M", machine, "-cpu", cpu, "-bios", "none"])
                .args(["-nographic", "-monitor", "none", "-serial", "stdio"])
                .args(["-icount", "shift=0", "-kernel"])
                .arg(elf);
            (prog, cmd)
        }
        Platform::Qemu { machine, .. } => {
            let prog = "qemu-system-arm";
            let mut cmd = Command::new(prog);
            cmd.args([
                "-M",
                machine,
                "-nographic",
                "-monitor",
                "none",
                "-serial",
                "none",
            ])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-icount", "shift=10", "-kernel"])
            .arg(elf);
            (prog, cmd)
        }
        Platform::Avr => return Err(failed("internal: QEMU run of an AVR target")),
    };
    let (status, out, err) =
        run_limited(&mut cmd, prog, &dir.join("qemu.out"), &dir.join("qemu.err"))?;
    // Semihosting console output goes to stderr in QEMU 7; accept either stream.
    let text = format!("{out}\n{err}");
    if !status.success() || text.contains("qb fault") {
        return Err(failed(format!(
            "QEMU run of variant `{}` failed ({status}{}):\n{}",
            v.name,
            if text.contains("qb fault") {
                ", the firmware took a fault"
            } else {
                ""
            },
            text.trim()
        )));
    }
    let mut calib = None;
    let mut ticks = Vec::new();
    let mut m = Measured {
        cost: Vec::new(),
        outs: Vec::new(),
    };
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f.as_slice() {
            ["qb", "calib", e, a, b] => calib = Some((hex(e, line)?, hex(a, line)?, hex(b, line)?)),
            ["qb", "step", _, t, vals @ ..] => {
                ticks.push(hex(t, line)?);
                m.outs.push(
                    vals.iter()
                        .map(|s| hex(s, line))
                        .collect::<Result<_, _>>()?,
                );
            }
            _ => {}
        }
    }
    let Some((empty, nop0, nop64)) = calib else {
        return Err(failed(format!(
            "variant `{}`: no calibration line from the firmware under QEMU:\n{}",
            v.name,
            text.trim()
        )));
    };
    let per = nop64.saturating_sub(nop0) as f64 / 64.0;
    if per < 1.0 {
        return Err(failed(format!(
            "QEMU's {} did not advance with the instruction count (64 nops took {} ticks); \
             cannot count instructions (is -icount supported by this {prog}?)",
            if prog == "qemu-system-arm" {
                "SysTick"
            } else {
                "minstret"
            },
            nop64.saturating_sub(nop0)
        )));
    }
    m.cost = ticks
        .iter()
        .map(|t| (t.saturating_sub(empty) as f64 / per).round().max(0.0) as u64)
        .collect();
    check_counts(&m, v, steps, &text)?;
    Ok(m)
}

// ---------------------------------------------------------------------------------------
// Report

/// One goal line: its text and whether it is met.
struct Goal {
    text: String,
    met: bool,
}

/// How far a variant's outputs are from qloop's after the first tenth of the steps.
struct Deviation {
    /// Largest |difference| as a fraction of the output's range, its absolute value, the
    /// step and the output where it occurs.
    rel: f64,
    abs: f64,
    step: usize,
    output: usize,
    /// Fraction of the compared steps where every output is within `tol` of the range.
    within: f64,
}

fn deviation(
    qv: &[(String, OutKind)],
    q: &Measured,
    v: &Variant,
    m: &Measured,
    spans: &[f64],
    tol: f64,
) -> Deviation {
    let skip = q.outs.len() / 10;
    let mut d = Deviation {
        rel: 0.0,
        abs: 0.0,
        step: skip,
        output: 0,
        within: 1.0,
    };
    let (mut n, mut ok) = (0usize, 0usize);
    for (i, (a, b)) in q.outs.iter().zip(&m.outs).enumerate().skip(skip) {
        let mut step_ok = true;
        for (k, ((_, qk), (_, vk))) in qv.iter().zip(&v.outputs).enumerate() {
            let diff = (qk.value(a[k]) - vk.value(b[k])).abs();
            let rel = if diff.is_nan() {
                f64::INFINITY
            } else {
                diff / spans[k]
            };
            step_ok &= rel <= tol;
            if rel > d.rel {
                (d.rel, d.abs, d.step, d.output) = (rel, diff, i, k);
            }
        }
        n += 1;
        ok += usize::from(step_ok);
    }
    if n > 0 {
        d.within = ok as f64 / n as f64;
    }
    d
}

fn fmt_mean(x: f64) -> String {
    if (x - x.round()).abs() < 1e-9 {
        format!("{}", x.round() as i64)
    } else {
        format!("{x:.2}")
    }
}

/// Prints the table, the output checks and the goals, and writes the JSON; returns whether
/// qloop's and plain_mul's outputs are identical and whether every goal is met.
fn summarize(
    a: &BenchArgs,
    pf: &Platform,
    variants: &[Variant],
    results: &[Measured],
) -> Result<(bool, bool), Fail> {
    let plan = a.plan;
    let t = &plan.target;
    let unit = pf.unit();
    let q_mean = results[0].mean();
    let mut o = format!(
        "qloop bench: spec `{}` on target `{}` ({}), {} steps\nmethod: {}\n\n",
        plan.prog.name,
        t.name,
        t.about,
        a.steps,
        pf.method()
    );
    let _ = writeln!(
        o,
        "{:<10} {:>12} {:>10} {:>10} {:>14}",
        "variant",
        format!("{unit}/step"),
        "min",
        "max",
        "ratio to qloop"
    );
    let order = ["qloop", "plain_mul", "float", "div_float", "div_int32"];
    let find = |name: &str| variants.iter().position(|v| v.name == name);
    for name in order {
        match find(name) {
            Some(i) => {
                let m = &results[i];
                let _ = writeln!(
                    o,
                    "{:<10} {:>12} {:>10} {:>10} {:>13.2}x",
                    name,
                    fmt_mean(m.mean()),
                    m.min(),
                    m.max(),
                    m.mean() / q_mean.max(f64::MIN_POSITIVE)
                );
            }
            None => {
                let _ = writeln!(
                    o,
                    "{:<10} {:>12} {:>10} {:>10} {:>14}",
                    name, "n/a", "", "", ""
                );
            }
        }
    }
    if !variants.iter().any(|v| v.name == "div_float") {
        let _ = writeln!(
            o,
            "(div_float and div_int32 are hand-written for {DIV_SPEC} only: n/a for this spec)"
        );
    }
    if t.name.contains("slowmul") && matches!(pf, Platform::Qemu { .. }) {
        let _ = writeln!(
            o,
            "(QEMU counts instructions: the 32-cycle MULS of this target costs 1 here; \
             compare cycles with its cost model, not with these counts)"
        );
    }
    if let Platform::Qemu { .. } | Platform::Riscv { .. } = pf {
        let _ = writeln!(
            o,
            "(QEMU counts every instruction as 1, whatever its cycles: multiplies, hardware \
             divides and FPU operations too)"
        );
    }
    if let Platform::Riscv { cpu, .. } = pf {
        if cpu.contains("m=false") {
            let _ = writeln!(
                o,
                "(no M extension: every multiply and divide is a libgcc routine, `__mulsi3`, \
                 `__divsi3`, ..., counted instruction by instruction)"
            );
        }
    }

    // Outputs.
    let _ = writeln!(o, "\noutputs:");
    let q = &results[0];
    let qv = &variants[0];
    let out_ids: Vec<SigId> = plan.prog.ids_of(SigKind::Output).collect();
    let spans: Vec<f64> = out_ids
        .iter()
        .map(|id| {
            let (lo, hi) = plan.prog.sig(*id).range.unwrap_or(plan.summary[id.0].range);
            if hi > lo {
                hi - lo
            } else {
                1.0
            }
        })
        .collect();
    let p_idx = find("plain_mul").unwrap_or(1);
    let mism = q
        .outs
        .iter()
        .zip(&results[p_idx].outs)
        .position(|(x, y)| x != y);
    let identical = mism.is_none();
    match mism {
        None => {
            let _ = writeln!(
                o,
                "  plain_mul == qloop: identical raw outputs on all {} steps",
                a.steps
            );
        }
        Some(i) => {
            let _ = writeln!(
                o,
                "  plain_mul != qloop: raw outputs DIFFER from step {i} (qloop {:?}, plain_mul {:?}); \
                 this is a bug: both compute the same exact products",
                q.outs[i], results[p_idx].outs[i]
            );
        }
    }
    let out_units: Vec<String> = out_ids
        .iter()
        .map(|id| plan.prog.sig(*id).unit.clone().unwrap_or_default())
        .collect();
    let out_names: Vec<String> = out_ids
        .iter()
        .map(|id| plan.prog.sig(*id).name.clone())
        .collect();
    let skip = a.steps / 10;
    for (name, tol, expected) in [
        ("float", 0.02, None),
        (
            "div_float",
            0.10,
            Some("a different algorithm (K_c = K/K_p at once instead of integrating), so only held levels agree"),
        ),
        ("div_int32", 0.10, Some("the division algorithm of div_float, in Q12")),
    ] {
        let Some(i) = find(name) else { continue };
        let d = deviation(&qv.outputs, q, &variants[i], &results[i], &spans, tol);
        let verdict = match (d.rel <= tol, expected) {
            (true, _) => "within tolerance".to_string(),
            (false, None) => "DIFFERS".to_string(),
            (false, Some(why)) => format!("differs, as expected: {why}"),
        };
        let _ = writeln!(
            o,
            "  {name:<9} vs qloop after step {skip}: {:.0} % of steps within {:.0} % of the output range; \
             max |{}| difference {} {} ({:.2} %) at step {}: {verdict}",
            d.within * 100.0,
            tol * 100.0,
            out_names.get(d.output).map(String::as_str).unwrap_or("output"),
            qloop::report::g(d.abs),
            out_units.get(d.output).map(String::as_str).unwrap_or(""),
            d.rel * 100.0,
            d.step,
        );
    }

    // Goals.
    let mut goals = Vec::new();
    let ratio = |name: &str| find(name).map(|i| results[i].mean() / q_mean.max(f64::MIN_POSITIVE));
    if let Some(r) = ratio("float") {
        goals.push(Goal {
            text: format!("qloop >= 3x fewer {unit} than float: {r:.2}x"),
            met: r >= 3.0,
        });
    }
    for name in ["div_float", "div_int32"] {
        if let Some(r) = ratio(name) {
            goals.push(Goal {
                text: format!("qloop >= 5x fewer {unit} than {name}: {r:.2}x"),
                met: r >= 5.0,
            });
        }
    }
    if let Some(i) = find("plain_mul") {
        let pm = results[i].mean();
        goals.push(Goal {
            text: format!(
                "qloop <= plain_mul: {} vs {} {unit}",
                fmt_mean(q_mean),
                fmt_mean(pm)
            ),
            met: q_mean <= pm,
        });
    }
    let stated = plan.prog.name == DIV_SPEC && t.name == "atmega328p";
    let _ = writeln!(
        o,
        "\ngoals{}:",
        if stated {
            ""
        } else {
            " (stated for koren_masory_1981 on atmega328p; informational here)"
        }
    );
    for g in &goals {
        let _ = writeln!(
            o,
            "  {:<8} {}",
            if g.met { "met" } else { "NOT met" },
            g.text
        );
    }
    let all_met = goals.iter().all(|g| g.met);
    print!("{o}");

    if let Some(path) = a.json {
        let val = |name: &str, f: &dyn Fn(&Measured) -> serde_json::Value| {
            find(name).map_or(serde_json::Value::Null, |i| f(&results[i]))
        };
        let obj = |f: &dyn Fn(&Measured) -> serde_json::Value| {
            let mut m = serde_json::Map::new();
            for name in order {
                m.insert(name.to_string(), val(name, f));
            }
            serde_json::Value::Object(m)
        };
        let json = serde_json::json!({
            "spec": plan.prog.name,
            "target": t.name,
            "unit": unit,
            "method": pf.method(),
            "steps": a.steps,
            "step": obj(&|m| serde_json::json!((m.mean() * 100.0).round() / 100.0)),
            "min": obj(&|m| serde_json::json!(m.min())),
            "max": obj(&|m| serde_json::json!(m.max())),
            "qloop_equals_plain_mul": identical,
            "goals": goals.iter().map(|g| serde_json::json!({"goal": g.text, "met": g.met})).collect::<Vec<_>>(),
        });
        let text = serde_json::to_string_pretty(&json).unwrap_or_default() + "\n";
        crate::write_atomic(path, &text)?;
        println!("\nwrote {}", path.display());
    }
    Ok((identical, all_met))
}

/// Runs the benchmark and prints its table; see the module docs.
pub fn bench(a: &BenchArgs) -> Result<(), Fail> {
    let start = Instant::now();
    let plan = a.plan;
    let t = &plan.target;
    let pf = platform(t)?;
    if a.steps == 0 {
        return Err(bad("`--steps` must be at least 1"));
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
        Platform::Avr => Some(avr_runner()?),
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
    let mut results: Vec<Measured> = Vec::new();
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
        let r = build(v, t, &pf, &dir).and_then(|elf| {
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
            match (&pf, &runner) {
                (Platform::Qemu { .. } | Platform::Riscv { .. }, _) => {
                    run_qemu(&elf, &pf, v, a.steps)
                }
                (Platform::Avr, Some(r)) => run_avr(r, &elf, v, a.steps),
                (Platform::Avr, None) => Err(failed("internal: no simavr runner")),
            }
        });
        match r {
            Ok(m) => {
                eprintln!(
                    "bench [{}/{n}] {}: done in {:.1} s",
                    i + 1,
                    v.name,
                    t0.elapsed().as_secs_f64()
                );
                results.push(m);
            }
            Err(f) => {
                eprintln!("note: build files kept in `{}`", work.display());
                return Err(f);
            }
        }
    }

    let (identical, all_met) = summarize(a, &pf, &variants, &results)?;
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
        return Err(failed(
            "qloop and plain_mul outputs differ (see above); the cost comparison is void",
        ));
    }
    if a.check_goals && !all_met {
        eprintln!("error: --check-goals: a goal is not met (see above)");
        return Err(Fail(1));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stimulus_covers_below_inside_and_above_the_range() {
        let v = stimulus(0.0, 5.0, 200, 0.0);
        assert_eq!(v.len(), 200);
        assert!(v[0] < 0.0, "starts below the range: {}", v[0]);
        assert!(
            v.iter().any(|x| *x > 0.15 && *x < 0.3),
            "just above an air cut"
        );
        assert!(v.iter().any(|x| *x > 5.0), "ramps past the range");
        assert!(v.iter().all(|x| x.is_finite() && *x >= -0.5 && *x <= 5.5));
        assert_eq!(stimulus(0.0, 5.0, 1, 0.0).len(), 1);
    }

    #[test]
    fn raw_values_saturate_to_the_storage_type() {
        let u16t = IntTy {
            signed: false,
            bits: 16,
        };
        assert_eq!(raw_of(-1.0, u16t, 4), 0);
        assert_eq!(raw_of(1e9, u16t, 4), 65535);
        let i16t = IntTy {
            signed: true,
            bits: 16,
        };
        assert_eq!(raw_of(-0.5, i16t, 12), -2048);
        assert_eq!(raw_of(1.0 / 4096.0 * 1.5, i16t, 12), 1);
    }

    #[test]
    fn riscv_cpu_turns_off_the_extensions_march_lacks() {
        assert_eq!(
            riscv_cpu("rv32i").as_deref(),
            Some("rv32,m=false,a=false,f=false,d=false,c=false")
        );
        assert_eq!(
            riscv_cpu("rv32imc").as_deref(),
            Some("rv32,a=false,f=false,d=false")
        );
        assert_eq!(riscv_cpu("rv32gc").as_deref(), Some("rv32"));
        assert_eq!(
            riscv_cpu("rv32imac_zicsr").as_deref(),
            Some("rv32,f=false,d=false")
        );
        assert_eq!(riscv_cpu("rv64imac"), None);
        assert_eq!(riscv_cpu("rv32e"), None);
        assert_eq!(riscv_cpu(""), None);
    }

    #[test]
    fn float_outputs_come_back_from_their_bits() {
        let bits = 1.25f32.to_bits() as i64;
        assert_eq!(OutKind::Float.value(bits), 1.25);
        let q = OutKind::Raw(
            IntTy {
                signed: true,
                bits: 16,
            },
            12,
        );
        assert_eq!(q.value(-2048), -0.5);
    }
}
