//! A run under QEMU with `-icount` (Cortex-M and RV32): the command line, the calibration
//! and the instructions per step from the firmware's text lines.

use super::host::run_limited;
use super::measured::{check_counts, hex, Measured};
use super::platform::Platform;
use super::variants::Variant;
use crate::cli::error::{CliError, CliResult};
use std::path::Path;
use std::process::Command;

/// Runs the ELF under QEMU with `-icount`; instructions per step and the reported outputs.
pub(super) fn run(elf: &Path, pf: &Platform, v: &Variant, steps: usize) -> CliResult<Measured> {
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
        Platform::Avr => return Err(CliError::tool("internal: QEMU run of an AVR target")),
    };
    let (status, out, err) =
        run_limited(&mut cmd, prog, &dir.join("qemu.out"), &dir.join("qemu.err"))?;
    // Semihosting console output goes to stderr in QEMU 7; accept either stream.
    let text = format!("{out}\n{err}");
    if !status.success() || text.contains("qb fault") {
        return Err(CliError::tool(format!(
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
        return Err(CliError::tool(format!(
            "variant `{}`: no calibration line from the firmware under QEMU:\n{}",
            v.name,
            text.trim()
        )));
    };
    let per = nop64.saturating_sub(nop0) as f64 / 64.0;
    if per < 1.0 {
        return Err(CliError::tool(format!(
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
