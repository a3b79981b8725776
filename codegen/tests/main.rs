//! The `qloop` package's integration tests, one test binary (each module was a binary of its
//! own; one link and one process for all of them, and `cargo test` runs them in parallel).
//! See the README's "Tests" for what each tier holds.

mod bench;
mod cli;
mod common;
mod decimal_cmp;
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
