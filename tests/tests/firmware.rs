//! The generated controllers as firmware, run in simulators and checked against the host:
//!
//! * AVR: the C `qloop gen --lang c --target atmega328p` writes for the 1981 controller, built
//!   into the ATmega328P firmware of `targets/avr/` and run in simavr on a scripted ADC
//!   sequence by `targets/avr/run.sh`, which first checks its cycle-counting method against
//!   the datasheet, then diffs the firmware's raw values against the same C built for the host
//!   with UBSan (needs avr-gcc, avr-libc, simavr with libsimavr-dev, a host cc and make);
//! * Cortex-M: the `qloop-verified` controllers in the `no_std` firmware of
//!   `targets/cortex-m/`, built for Cortex-M0 and Cortex-M4F and run in QEMU by
//!   `targets/cortex-m/run.sh`, print byte for byte what the same program prints on the host
//!   (needs qemu-system-arm and the Rust targets thumbv6m-none-eabi and thumbv7em-none-eabihf).
//!
//! Without their tools the tests are skipped, and listed at the end of `cargo test
//! --workspace`, unless QLOOP_REQUIRE_TOOLS is set.

use qloop_tests::{plan_for, run, rust_target, scratch, skip, tool};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// simavr's headers and library, as `targets/avr/Makefile` looks for them.
fn libsimavr() -> bool {
    let header = Path::new("/usr/include/simavr/sim_avr.h").is_file()
        || Command::new("pkg-config")
            .args(["--exists", "simavr"])
            .status()
            .is_ok_and(|s| s.success());
    if !header || qloop_tests::hidden("simavr") {
        skip("libsimavr is not installed (simavr, libsimavr-dev)");
        return false;
    }
    true
}

#[test]
fn avr_firmware_in_simavr_matches_the_host_build() {
    let have = ["avr-gcc", "avr-objdump", "avr-size", "cc", "make"]
        .iter()
        .all(|t| tool(t).is_some());
    if !have || !libsimavr() {
        return;
    }
    let dir = scratch("avr-firmware");
    let stem = "koren_masory_1981";
    let (h, c) = qloop::gen_c(&plan_for(stem, "atmega328p"));
    let gen = dir.join("gen");
    std::fs::create_dir_all(&gen).unwrap();
    std::fs::write(gen.join(format!("{stem}.h")), h).unwrap();
    std::fs::write(gen.join(format!("{stem}.c")), c).unwrap();
    let out = run(Command::new("bash")
        .arg(root().join("targets/avr/run.sh"))
        .env("GEN", &gen)
        .env("BUILD", dir.join("build")));
    let pass = out.lines().find(|l| l.starts_with("PASS: "));
    assert!(pass.is_some(), "no PASS line:\n{out}");
    eprintln!("{}", pass.unwrap_or_default());
}

/// Three release builds of `qloop-verified` with LTO (host, thumbv6m, thumbv7em), each with
/// the six seeds the script runs (not the multi-model controller: `default-features = false`):
/// the acceptance tier's.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn cortex_m_firmware_in_qemu_matches_the_host_run() {
    let have = tool("qemu-system-arm").is_some()
        && rust_target("thumbv6m-none-eabi")
        && rust_target("thumbv7em-none-eabihf");
    if !have {
        return;
    }
    // Its own target directory (a separate package with its own Cargo.lock), kept between runs
    // so that only the first build is slow; --locked, as CI builds it.
    let out = run(Command::new("bash")
        .arg(root().join("targets/cortex-m/run.sh"))
        .env("CARGO_FLAGS", "--locked")
        .env("CARGO_TARGET_DIR", root().join("target/cortex-m")));
    for machine in ["microbit", "mps2-an386"] {
        assert!(
            out.lines()
                .any(|l| l.starts_with(&format!("PASS {machine} "))),
            "{machine}: no PASS line:\n{out}"
        );
    }
}
