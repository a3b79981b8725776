//! Which platform measures a target: simavr, QEMU on Cortex-M or QEMU on RV32, from the
//! target's toolchain.

use crate::cli::error::{CliError, CliResult};
use std::fmt::Write as _;

/// How a target's code is run and measured.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Platform {
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
    pub(super) fn unit(&self) -> &'static str {
        match self {
            Platform::Avr => "cycles",
            Platform::Qemu { .. } | Platform::Riscv { .. } => "instructions",
        }
    }

    /// The link's memory regions that hold the flash and the RAM (the AVR toolchain's
    /// device script names them `text` and `data`, `arm::link_ld` `FLASH` and `RAM`;
    /// on QEMU `virt` one RAM holds everything).
    pub(super) fn regions(&self) -> (&'static str, &'static str) {
        match self {
            Platform::Avr => ("text", "data"),
            Platform::Qemu { .. } => ("FLASH", "RAM"),
            Platform::Riscv { .. } => ("RAM", "RAM"),
        }
    }

    pub(super) fn method(&self) -> String {
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
pub(super) fn platform(t: &qloop::Target) -> CliResult<Platform> {
    let supported =
        "atmega328p (simavr), cortex-m0, cortex-m0-slowmul, cortex-m4, rv32i and rv32imc (QEMU)";
    let Some(cc) = &t.toolchain.cc else {
        return Err(CliError::input(format!(
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
                return Err(CliError::input(format!(
                    "target `{}`: `qloop bench` has no memory map for QEMU machine `{other}` \
                     (known: microbit, mps2-an386; virt for RISC-V)",
                    t.name
                )))
            }
        };
        if !cc.contains("arm") {
            return Err(CliError::input(format!(
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
    Err(CliError::input(format!(
        "target `{}` names no simulator in its toolchain (`simulator = \"simavr\"` or \
         `qemu_machine`), so `qloop bench` cannot run its code; targets it can measure: \
         {supported}",
        t.name
    )))
}

/// The RISC-V platform: machine `virt`, a `riscv*` compiler and an RV32 `-march` in the cflags,
/// whose extensions give QEMU's `-cpu`.
fn riscv_platform(t: &qloop::Target, cc: &str, m: &str) -> CliResult<Platform> {
    if m != "virt" {
        return Err(CliError::input(format!(
            "target `{}`: `qloop bench` runs RISC-V code on QEMU machine `virt` only, the \
             toolchain names `{m}`",
            t.name
        )));
    }
    if !cc.contains("riscv") {
        return Err(CliError::input(format!(
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
        CliError::input(format!(
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
        return Err(CliError::input(format!(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
