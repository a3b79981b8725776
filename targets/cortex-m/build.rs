//! Picks the memory map from the target triple and passes cortex-m-rt's linker script.
//!
//! One QEMU machine per triple: `thumbv6m-none-eabi` is `-M microbit` (nRF51, Cortex-M0) and
//! `thumbv7em-none-eabihf` is `-M mps2-an386` (Cortex-M4F). `memory/<machine>.x` is copied to
//! `$OUT_DIR/memory.x`, where cortex-m-rt's `link.x` finds it. Host builds (the reference run)
//! need neither.

use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory");
    let target = env::var("TARGET").expect("cargo sets TARGET");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let machine = match target.as_str() {
        "thumbv6m-none-eabi" => "microbit",
        "thumbv7em-none-eabihf" => "mps2-an386",
        other => panic!(
            "no memory map for {other}: add one to memory/ and to build.rs \
             (supported: thumbv6m-none-eabi, thumbv7em-none-eabihf)"
        ),
    };
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy(format!("memory/{machine}.x"), out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
