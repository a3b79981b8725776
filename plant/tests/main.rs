//! `qloop-plant`'s integration tests, one test binary.

mod froh;
mod multimodel_study;
