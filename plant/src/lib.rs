//! Floating-point reference plants for qloop controllers, scenarios as data, and the
//! closed-loop runner that drives the *compiled* fixed-point controller and its f64
//! reference side by side.
//!
//! * [`turning`]: CNC lathe under ACC (Koren & Masory 1981, Koren's survey).
//! * [`milling`]: CNC lag and milling process under force control (Rubio & De la Sen,
//!   eqs. 1-3), the work-piece profile of its Fig. 1.
//! * [`grinding`]: plunge grinding under force control (Jenkins & Kurfess).
//! * [`finishing`]: finish turning under geometric adaptive control, roughness per part with a
//!   wearing tool (Koren's survey, eq. 29, Figs. 10-11).
//! * [`discrete`]: exact ZOH discretisation of first-order parts (Jenkins & Kurfess, eqs. 6-7).
//! * [`sensor`]: gain, seeded noise, saturation, ADC quantisation.
//! * [`scenario`]: piecewise-linear channel schedules, in code or TOML.
//! * [`plot`]: the figure of a run (SVG, PNG).
//! * [`runner`]: ZOH, substep integration, both loops in lock step; [`metrics`](mod@metrics): settling,
//!   overshoot, steady-state error, oscillation verdict and frequency, fixed − f64.

pub mod catalog;
pub mod contract;
pub mod controller;
pub mod discrete;
pub mod fault;
pub mod finishing;
pub mod froh;
pub mod grinding;
pub mod metrics;
pub mod milling;
pub mod multimodel;
pub mod plant;
pub mod plot;
pub mod runner;
pub mod scenario;
pub mod sensor;
pub mod sweep;
pub mod trace;
pub mod turning;

pub use contract::{Binding, Channel, Contract, Reference};
pub use controller::{Controller, Named, Signals};
pub use metrics::{metrics, LoopMetrics, Metrics};
pub use plant::{Param, Plant};
pub use runner::{run, run_single, RunConfig};
pub use scenario::{Scenario, Schedule};
pub use trace::Trace;
