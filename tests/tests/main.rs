//! The workspace's integration, snapshot and paper-reproduction tests, one test binary (each
//! module was a binary of its own; one link and one process for all of them, so that a large
//! generated text is generated once per run and `cargo test` runs every module in parallel).
//! See the book's "Tests and their tiers" (docs/book/src/internals/tests.md) for what each tier holds.

mod budget;
mod c_float;
mod c_output;
mod c_tables;
mod c_vectors;
mod cascade;
mod claims;
mod elements;
mod equations_doc;
mod exact_bounds;
mod faults;
mod features;
mod firmware;
mod kani_snapshots;
mod linuxcnc;
mod loops;
mod macro_dependencies;
mod macro_matches_cli;
mod multimodel;
mod narrow_words;
mod object_code;
mod paper_gac;
mod paper_grinding;
mod paper_grinding_adaptive;
mod paper_milling;
mod paper_multimodel;
mod paper_turning;
mod pole_placement;
mod random_compile;
mod reciprocal;
mod refute;
mod rls3;
mod rls4;
mod rls5;
mod semantics;
mod smt_differential;
mod snapshots;
mod supervisor;
mod tables;
mod tracker;
mod tuned;
mod units;
mod vectors;
