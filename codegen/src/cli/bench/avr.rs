//! The AVR under simavr: the firmware's `bench_io.h`, the cycle runner
//! (`targets/avr/cycles.c`, built on first use into the cache) and a run of a variant's ELF.

use super::host::{mkdir, need_tool, run_limited, write_file};
use super::measured::{check_counts, malformed, num, Measured};
use super::variants::Variant;
use crate::cli::error::{CliError, CliResult};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

const CYCLES_C: &str = include_str!("../../../targets/avr/cycles.c");
pub(super) const SIM_PROTOCOL_H: &str =
    include_str!("../../../targets/avr/firmware/sim_protocol.h");

/// `bench_io.h` on the AVR: simavr markers and value reports (`sim_protocol.h`).
pub(super) const IO_H: &str = r#"/* bench_io.h -- qloop bench on the AVR in simavr (targets/avr/cycles.c): markers and
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
pub(super) fn runner() -> CliResult<PathBuf> {
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
            .map_err(|e| CliError::tool(format!("cannot run the host `cc`: {e}")))?;
        if out.status.success() {
            let _ = std::fs::remove_file(&src);
            std::fs::rename(&tmp, &exe).map_err(|e| {
                CliError::tool(format!(
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
    Err(CliError::tool(format!(
        "cannot build the simavr cycle runner (targets/avr/cycles.c) with the host `cc`; \
         install simavr and libsimavr-dev (Debian: apt-get install simavr libsimavr-dev libelf-dev):\n{errors}"
    )))
}

/// The simavr core of target `t`: its `-mmcu=` flag's device (`atmega328p` without one).
pub(super) fn mcu(t: &qloop::Target) -> &str {
    t.toolchain.mcu().unwrap_or("atmega328p")
}

/// Runs the ELF in simavr on core `mcu`; exact cycles per step and the reported outputs.
pub(super) fn run(
    runner: &Path,
    mcu: &str,
    elf: &Path,
    v: &Variant,
    steps: usize,
) -> CliResult<Measured> {
    let dir = elf.parent().unwrap_or(Path::new("."));
    let (status, out, err) = run_limited(
        Command::new(runner).arg("--mcu").arg(mcu).arg(elf),
        "the simavr cycle runner",
        &dir.join("simavr.out"),
        &dir.join("simavr.err"),
    )?;
    if !status.success() {
        return Err(CliError::tool(format!(
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
