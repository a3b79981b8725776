//! Building a variant: its files, the platform's firmware files and the target's compiler.
//!
//! The controller's sources are compiled on their own (`-c`, with `-fstack-usage`) so that
//! [`super::size`] can measure them; `main.c` and the platform's startup code are compiled
//! and linked with those objects in one more call, which writes a link map (`link.map`).
//! Splitting the compile changes no instruction: GCC compiles each file of a multi-file
//! command line on its own anyway.

use super::host::{mkdir, write_file};
use super::platform::Platform;
use super::variants::{main_c, Variant};
use super::{arm, avr, riscv, text_io};
use crate::cli::error::{CliError, CliResult};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A built variant: the ELF and what measures its size.
pub(super) struct Build {
    /// The linked firmware.
    pub(super) elf: PathBuf,
    /// The controller's objects (its sources compiled on their own).
    pub(super) objects: Vec<PathBuf>,
    /// Their `-fstack-usage` files.
    pub(super) stack_usage: Vec<PathBuf>,
    /// The link map.
    pub(super) map: PathBuf,
    /// The linker's complaint when the firmware does not fit the memory regions of the link
    /// (the ELF was then linked again with `--noinhibit-exec`, to be measured, not run).
    pub(super) overflow: Option<String>,
}

/// Whether the linker's message says that sections do not fit their memory regions.
fn overflow_lines(err: &str) -> Option<String> {
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("will not fit in region") || l.contains("overflowed by"))
        .map(|l| l.rsplit_once(": ").map_or(l, |(_, m)| m).trim())
        .collect();
    (!lines.is_empty()).then(|| lines.join("; "))
}

/// Runs a compiler command; its standard error on failure.
fn run(cmd: &mut Command, cc: &str) -> CliResult<Result<(), String>> {
    let out = cmd
        .output()
        .map_err(|e| CliError::tool(format!("cannot run `{cc}`: {e}")))?;
    Ok(if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).trim_end().to_string())
    })
}

/// Writes the variant's files into `dir` and compiles its ELF.
pub(super) fn build(v: &Variant, t: &qloop::Target, pf: &Platform, dir: &Path) -> CliResult<Build> {
    mkdir(dir)?;
    let dir = std::path::absolute(dir).map_err(|e| CliError::cannot_create(dir, e))?;
    for (name, text) in &v.files {
        write_file(&dir.join(name), text)?;
    }
    write_file(&dir.join("main.c"), &main_c(v))?;
    let cc = t.toolchain.cc.clone().unwrap_or_default();
    let shown = format!("{cc} {}", t.toolchain.cflags.join(" "));
    let failed = |err: &str, hint: &str| {
        CliError::tool(format!(
            "compiling variant `{}` with `{shown} -std=c99 -Wall -Wextra -Werror` failed \
             (files in `{}`):\n{err}{hint}",
            v.name,
            dir.display(),
        ))
    };
    let compiler = || {
        let mut cmd = Command::new(&cc);
        cmd.current_dir(&dir)
            .args(&t.toolchain.cflags)
            .args(["-std=c99", "-Wall", "-Wextra", "-Werror"])
            .arg("-I.");
        cmd
    };

    let mut objects = Vec::new();
    let mut stack_usage = Vec::new();
    for src in &v.sources {
        let stem = src.strip_suffix(".c").unwrap_or(src);
        let obj = format!("{stem}.o");
        if let Err(err) = run(
            compiler()
                .args(["-fstack-usage", "-c", src, "-o"])
                .arg(&obj),
            &cc,
        )? {
            return Err(failed(&err, ""));
        }
        objects.push(dir.join(obj));
        stack_usage.push(dir.join(format!("{stem}.su")));
    }

    let elf_name = format!("{}.elf", v.name);
    let link = |extra: &[&str]| {
        let mut cmd = compiler();
        cmd.arg("main.c").args(&objects);
        match pf {
            Platform::Avr => {}
            Platform::Qemu { .. } => {
                cmd.args(["startup.c", "-nostartfiles", "-Tlink.ld"]);
            }
            Platform::Riscv { .. } => {
                // No C library (Debian's riscv64-unknown-elf-gcc has none): libgcc brings the
                // soft-float, multiply and divide helpers.
                cmd.args(["startup.c", "-nostdlib", "-Tlink.ld"]);
            }
        }
        cmd.args(["-o", &elf_name, "-Wl,-Map=link.map"]).args(extra);
        if matches!(pf, Platform::Riscv { .. }) {
            cmd.arg("-lgcc");
        }
        cmd
    };
    match pf {
        Platform::Avr => {
            write_file(&dir.join("bench_io.h"), avr::IO_H)?;
            write_file(&dir.join("sim_protocol.h"), avr::SIM_PROTOCOL_H)?;
        }
        Platform::Qemu { flash, ram, .. } => {
            write_file(&dir.join("bench_io.h"), &text_io::io_h(arm::IO_HEAD))?;
            write_file(&dir.join("startup.c"), arm::STARTUP_C)?;
            write_file(&dir.join("link.ld"), &arm::link_ld(flash, ram))?;
        }
        Platform::Riscv { .. } => {
            write_file(&dir.join("bench_io.h"), &text_io::io_h(riscv::IO_HEAD))?;
            write_file(&dir.join("startup.c"), riscv::STARTUP_C)?;
            write_file(&dir.join("link.ld"), riscv::LINK_LD)?;
        }
    }
    let mut overflow = None;
    if let Err(err) = run(&mut link(&[]), &cc)? {
        let Some(o) = overflow_lines(&err) else {
            let hint = if err.contains("is too large") {
                "\nhelp: the input table is larger than the target allows one array to be; \
                 try fewer --steps"
            } else {
                ""
            };
            return Err(failed(&err, hint));
        };
        // Link again, keeping the oversized ELF, only to measure it.
        if let Err(err2) = run(&mut link(&["-Wl,--noinhibit-exec"]), &cc)? {
            return Err(failed(
                &format!("{err}\n(linking again with --noinhibit-exec to measure it:)\n{err2}"),
                "\nhelp: the firmware does not fit the target's memory; fewer --steps shrink \
                 the input table",
            ));
        }
        overflow = Some(o);
    }
    Ok(Build {
        elf: dir.join(elf_name),
        objects,
        stack_usage,
        map: dir.join("link.map"),
        overflow,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overflow_messages_of_ld() {
        let avr = "/usr/lib/gcc/avr/5.4.0/../../../avr/bin/ld: t.elf section `.text' will not \
                   fit in region `text'\n/usr/lib/gcc/avr/5.4.0/../../../avr/bin/ld: region \
                   `text' overflowed by 384636 bytes\ncollect2: error: ld returned 1 exit status";
        assert_eq!(
            overflow_lines(avr).as_deref(),
            Some("t.elf section `.text' will not fit in region `text'; region `text' overflowed by 384636 bytes")
        );
        assert_eq!(overflow_lines("main.c:3: undefined reference to `f'"), None);
    }
}
