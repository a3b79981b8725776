//! Building a variant: its files, the platform's firmware files and the target's compiler.

use super::host::{mkdir, write_file};
use super::platform::Platform;
use super::variants::{main_c, Variant};
use super::{arm, avr, riscv, text_io};
use crate::cli::error::{CliError, CliResult};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Writes the variant's files into `dir` and compiles its ELF.
pub(super) fn build(
    v: &Variant,
    t: &qloop::Target,
    pf: &Platform,
    dir: &Path,
) -> CliResult<PathBuf> {
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
            write_file(&dir.join("bench_io.h"), avr::IO_H)?;
            write_file(&dir.join("sim_protocol.h"), avr::SIM_PROTOCOL_H)?;
        }
        Platform::Qemu { flash, ram, .. } => {
            write_file(&dir.join("bench_io.h"), &text_io::io_h(arm::IO_HEAD))?;
            write_file(&dir.join("startup.c"), arm::STARTUP_C)?;
            write_file(&dir.join("link.ld"), &arm::link_ld(flash, ram))?;
            cmd.args(["startup.c", "-nostartfiles", "-Tlink.ld"]);
        }
        Platform::Riscv { .. } => {
            write_file(&dir.join("bench_io.h"), &text_io::io_h(riscv::IO_HEAD))?;
            write_file(&dir.join("startup.c"), riscv::STARTUP_C)?;
            write_file(&dir.join("link.ld"), riscv::LINK_LD)?;
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
        .map_err(|e| CliError::tool(format!("cannot run `{cc}`: {e}")))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let hint = if err.contains("overflow") {
            "\nhelp: the input table may not fit the target's memory; try fewer --steps"
        } else {
            ""
        };
        return Err(CliError::tool(format!(
            "compiling variant `{}` with `{shown} -std=c99 -Wall -Wextra -Werror` failed \
             (files in `{}`):\n{}{hint}",
            v.name,
            dir.display(),
            err.trim_end()
        )));
    }
    Ok(elf)
}
