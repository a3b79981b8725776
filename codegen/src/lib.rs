//! qloop: compiles declarative adaptive-controller specs into division-free Q-format
//! fixed-point update routines, with an f64 reference controller from the same spec, proves
//! them, and emits C and LinuxCNC firmware.
//!
//! The compiler itself is the [`qloop_core`] crate, shared with the `controller!` proc-macro
//! and re-exported here under the same module names: [`lang`] (the spec language: scan,
//! parse) → [`check`] (names, constants → [`ir`]) → [`lower`] (range analysis, Q-formats,
//! shift-add, cost model → integer plan) → [`emit`] (Rust, reference, Kani; plus this crate's
//! C and LinuxCNC emitters) and [`interp`]. This crate adds the prover ([`prove`]), the
//! reports ([`report`]), the built-in target files ([`targets`]) and the command line.

#![deny(missing_docs)]

pub mod emit;
#[cfg(feature = "cli")]
pub mod interpreted;
pub mod prove;
pub mod report;
pub mod targets;

pub use qloop_core::{check, diag, interp, ir, lang, lower, prop_eval, qformat, text, units};
pub use qloop_core::{
    compile_str, compile_tokens, expand_macro, gen_kani, gen_reference, gen_rust, kani_tokens,
    reference_tokens, rust_tokens, Diag, Plan, Target, GEN_HEADER,
};

/// The built-in Koren–Masory (1981) spec, used by `qloop demo` (`codegen/specs/demo.qloop`, a
/// link to `verified/specs/koren_masory_1981.qloop`, so that the packaged crate carries it).
pub const DEMO_SPEC: &str = include_str!("../specs/demo.qloop");

/// The same controller tuned by `qloop tune` on the turning plant, shown by `qloop demo`
/// beside the paper's tuning (`codegen/specs/demo_tuned.qloop`, a link to
/// `verified/specs/koren_masory_tuned.qloop`).
pub const DEMO_TUNED_SPEC: &str = include_str!("../specs/demo_tuned.qloop");

/// The C99 controller of a compiled plan: `(NAME.h, NAME.c)`.
pub fn gen_c(plan: &Plan) -> (String, String) {
    emit::c::files(plan)
}

/// `qloop gen --lang linuxcnc` output: the LinuxCNC HAL component `qloop_NAME.comp` (for
/// `halcompile`) that embeds [`gen_c`]'s controller; an error names what the spec has that a
/// component cannot represent (see [`emit::linuxcnc`]).
pub fn gen_linuxcnc(plan: &Plan) -> Result<String, emit::linuxcnc::Unrepresentable> {
    emit::linuxcnc::component(plan)
}
