//! The `qloop` command line: one module per command, the clap definition ([`args`]), the one
//! error type and its exit codes ([`error`]), and the shared loading and writing ([`files`]).
//!
//! | command | module |
//! |---|---|
//! | `check` | [`check`] |
//! | `gen` | [`gen`] |
//! | `prove` | [`prove`] |
//! | `sim` | [`sim`] (compiling the generated Rust for it: [`jit`]) |
//! | `sweep` | [`sweep`], its report [`sweep_report`] |
//! | `demo` | [`demo`] |
//! | `bench` | [`bench`] |
//! | `kani` | [`kani`] (runs the Kani harnesses of a crate) |
//! | `c2d` | [`c2d`] (β-FROH discretisation for a spec's constants) |
//! | `tune` | [`tune`] (picks the `tune` constants: closed-loop scores, proofs, Pareto front) |
//! | `targets` | [`targets`] |
//! | `plants` | [`plants`] (the plant contracts; `sim` binds a spec to one: [`bind`]) |

pub mod aco;
pub mod args;
pub mod bench;
pub mod bind;
pub mod c2d;
pub mod check;
pub mod demo;
pub mod error;
pub mod files;
pub mod gen;
pub mod jit;
pub mod kani;
pub mod plants;
pub mod prove;
pub mod rules;
pub mod sim;
pub mod sweep;
pub mod sweep_report;
pub mod targets;
pub mod tune;
