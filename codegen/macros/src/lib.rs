//! `controller!`: compiles a qloop spec into a fixed-point controller module at build time.
//!
//! A thin shell over [`qloop_core::expand_macro`] (the compiler core, without the prover); the macro and the `qloop gen` CLI share one
//! parser and one emitter, so the expansion is exactly what `qloop gen --lang rust` writes.
//!
//! ```ignore
//! qloop_macros::controller!("specs/koren_masory_1981.qloop");            // fixed-point
//! qloop_macros::controller!("specs/koren_masory_1981.qloop", reference); // f64 reference
//! qloop_macros::controller! { controller my_loop { period 0.01 "s"; /* .. */ } }
//! ```

use proc_macro::TokenStream;

/// Expands a qloop spec (inline, or a path relative to the crate root) into a module.
#[proc_macro]
pub fn controller(input: TokenStream) -> TokenStream {
    let dir = std::env::var("CARGO_MANIFEST_DIR").ok();
    qloop_core::expand_macro(input.into(), dir.as_deref()).into()
}
