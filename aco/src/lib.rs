//! Optimisation above the loops, on the host in `f64`: adaptive control with optimisation
//! (ACO), which picks each next part's machining variables or the inner loop's set point.
//!
//! - [`turning`]: the turning model of Ivester & Danai, reconstructed (its eqs. 16–20 and
//!   Table 1 are lost in the extraction).
//! - [`rcb`]: RCB₂, recursive constraint bounding (Ivester & Danai, eqs. 5–14).
//! - [`bendix`]: the Bendix ACO index (Koren's survey, eqs. 1–3) and its optimiser over feedrate and
//!   spindle speed.
//! - [`cascade`]: the outer layer choosing the inner loop's force reference per part, the
//!   part's time measured in closed loop with the generated controller.
//! - [`nlp`]: the nonlinear program, solved by the `slsqp` crate.
//! - [`study`]: seeded studies of a policy (convergence against violations).
//! - [`paper`]: Ivester & Danai's Table 2; [`report`] and [`figures`]: tables, CSV and plots.
//!
//! This is not firmware: it runs between parts on the PC next to the machine controller.

pub mod bendix;
pub mod cascade;
pub mod figures;
pub mod nlp;
pub mod paper;
pub mod rcb;
pub mod report;
pub mod study;
pub mod turning;
