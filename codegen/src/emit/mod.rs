//! Emitters: the compiler core's (fixed-point Rust, the f64 reference controller, proof
//! harnesses, shared doc text; see [`qloop_core::emit`]) and this crate's C99, C f64-reference
//! and LinuxCNC HAL component emitters.

pub use qloop_core::emit::*;

pub mod c;
pub mod c_float;
pub mod linuxcnc;
