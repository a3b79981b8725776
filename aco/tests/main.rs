//! `qloop-aco`'s integration tests, one test binary: the optimisation layer against its papers
//! and against independent solutions.

mod bendix;
mod nlp_crosscheck;
mod paper_rcb2;
