//! The `qloop` package's integration tests, one test binary (each module was a binary of its
//! own; one link and one process for all of them, and `cargo test` runs them in parallel).
//! See the book's "Tests and their tiers" (docs/book/src/internals/tests.md) for what each tier holds.

mod attrs;
mod bench;
mod cli;
mod common;
mod decimal_cmp;
mod docs;
mod exit_codes;
mod first_day;
mod gen_linuxcnc;
mod interpreted;
mod kani_runner;
mod limits;
mod prove;
mod random_specs;
mod rules;
mod scm_quality;
mod sim;
mod sim_contract;
mod split;
mod tune;
