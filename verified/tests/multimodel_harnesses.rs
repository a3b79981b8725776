//! The proof harnesses of the multi-model milling controller (`specs/milling_multimodel.qloop`)
//! as bolero property tests. Its harness module is 27 MB of Rust, so it is a test target of its
//! own with `test = false`: `cargo test --workspace` (the default tier) does not build it, and
//! the acceptance tier runs it (`.ci/run` names it with `--test multimodel_harnesses`;
//! the book's "Tests and their tiers"). Under Kani the same module is part
//! of the library (`src/lib.rs`), where the stubs can reach the step's crate-private products.
#![cfg(not(kani))]

use qloop_verified::milling_multimodel;

qloop_macros::controller!("specs/milling_multimodel.qloop", kani);
