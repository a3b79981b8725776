//! Seeded studies: one policy over many runs, as Ivester & Danai's Figs. 5 and 6 discuss (speed of
//! convergence against constraint violations).
//!
//! For each run (seed `first_seed + i`):
//! - **violations**: parts whose measured power or roughness exceeds its limit, and by how
//!   much (the part is out of specification as simulated);
//! - **cycles to converge**: the first cycle whose time is within [`CONVERGED`] of the run's
//!   reference optimum. The reference is the true model's optimum with every part inside its
//!   limits for any noise draw ([`Run::robust_optimum`]): with ±10 % noise on the part, a
//!   setting whose noise-free quality sits at the limit puts half its parts out of
//!   specification, so that is not a goal a policy should reach;
//! - **gap**: the mean time of the last three cycles over that reference, and over the
//!   noise-free optimum ([`Run::optimum`]), both reported.

use crate::rcb::{self, Policy, Run, Scenario};

/// "Within a few per cent": a cycle within 5 % of the reference optimum's time has converged.
pub const CONVERGED: f64 = 0.05;

/// What one run gave.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    /// The seed.
    pub seed: u64,
    /// Parts out of specification.
    pub violations: usize,
    /// The largest excess over a limit (kW or µm), 0 when none.
    pub worst_excess: f64,
    /// First cycle within [`CONVERGED`] of the reference, if any.
    pub converged_at: Option<usize>,
    /// Mean time of the last three cycles over the reference optimum, minus 1.
    pub gap_robust: f64,
    /// The same over the noise-free optimum.
    pub gap_optimum: f64,
    /// Cycles whose next program had no solution.
    pub nlp_failures: usize,
}

/// A policy over many runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    /// The policy.
    pub policy: Policy,
    /// Cycles per run.
    pub cycles: usize,
    /// The runs.
    pub runs: Vec<Run>,
    /// One summary per run.
    pub summaries: Vec<RunSummary>,
}

/// Summarises one run. The reference optima are solved on the run's true model; a run whose
/// reference has no solution is reported with NaN gaps and no convergence.
pub fn summarise(run: &Run) -> RunSummary {
    let robust = run.robust_optimum().map(|o| o.value).unwrap_or(f64::NAN);
    let optimum = run.optimum().map(|o| o.value).unwrap_or(f64::NAN);
    let tail: Vec<f64> = run.cycles.iter().rev().take(3).map(|c| c.time).collect();
    let tail_mean = tail.iter().sum::<f64>() / tail.len().max(1) as f64;
    let excesses: Vec<f64> = run
        .cycles
        .iter()
        .map(|c| c.excess())
        .filter(|&e| e > 0.0)
        .collect();
    RunSummary {
        seed: run.scenario.seed,
        violations: excesses.len(),
        worst_excess: excesses.iter().copied().fold(0.0, f64::max),
        converged_at: run
            .cycles
            .iter()
            .find(|c| c.time <= robust * (1.0 + CONVERGED))
            .map(|c| c.index),
        gap_robust: tail_mean / robust - 1.0,
        gap_optimum: tail_mean / optimum - 1.0,
        nlp_failures: run.cycles.iter().filter(|c| c.nlp_error.is_some()).count(),
    }
}

/// Runs `runs` seeded scenarios (seeds `first_seed`, `first_seed + 1`, ..., wrapping at
/// `u64::MAX`) of `cycles` cycles.
pub fn study(policy: Policy, runs: usize, first_seed: u64, cycles: usize) -> Study {
    let runs: Vec<Run> = (0..runs as u64)
        .map(|i| {
            let mut sc = Scenario::paper(policy, first_seed.wrapping_add(i));
            sc.cycles = cycles;
            rcb::run(&sc)
        })
        .collect();
    let summaries = runs.iter().map(summarise).collect();
    Study {
        policy,
        cycles,
        runs,
        summaries,
    }
}

/// The median of some values (NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl Study {
    /// Parts out of specification over all runs.
    pub fn violations(&self) -> usize {
        self.summaries.iter().map(|r| r.violations).sum()
    }

    /// Runs with at least one part out of specification.
    pub fn violating_runs(&self) -> usize {
        self.summaries.iter().filter(|r| r.violations > 0).count()
    }

    /// The largest excess over any run.
    pub fn worst_excess(&self) -> f64 {
        self.summaries
            .iter()
            .map(|r| r.worst_excess)
            .fold(0.0, f64::max)
    }

    /// Runs that came within [`CONVERGED`] of their reference.
    pub fn converged_runs(&self) -> usize {
        self.summaries
            .iter()
            .filter(|r| r.converged_at.is_some())
            .count()
    }

    /// Median cycles to converge, counting a run that never did as one cycle past the end.
    pub fn median_cycles(&self) -> f64 {
        median(
            self.summaries
                .iter()
                .map(|r| r.converged_at.unwrap_or(self.cycles + 1) as f64)
                .collect(),
        )
    }

    /// Runs with no part out of specification whose last cycles are more than [`CONVERGED`]
    /// slower than the reference: safe but conservative.
    pub fn conservative_runs(&self) -> usize {
        self.summaries
            .iter()
            .filter(|r| r.violations == 0 && r.gap_robust > CONVERGED)
            .count()
    }

    /// The median over runs of each cycle's time (s), cycle by cycle.
    pub fn median_times(&self) -> Vec<f64> {
        (0..self.cycles)
            .map(|j| median(self.runs.iter().map(|r| r.cycles[j].time).collect()))
            .collect()
    }

    /// Parts out of specification at each cycle, over all runs.
    pub fn violations_per_cycle(&self) -> Vec<usize> {
        (0..self.cycles)
            .map(|j| {
                self.runs
                    .iter()
                    .filter(|r| r.cycles[j].excess() > 0.0)
                    .count()
            })
            .collect()
    }

    /// Median gap over the robust reference.
    pub fn median_gap_robust(&self) -> f64 {
        median(self.summaries.iter().map(|r| r.gap_robust).collect())
    }

    /// Median gap over the noise-free optimum.
    pub fn median_gap_optimum(&self) -> f64 {
        median(self.summaries.iter().map(|r| r.gap_optimum).collect())
    }

    /// Cycles whose next program had no solution.
    pub fn nlp_failures(&self) -> usize {
        self.summaries.iter().map(|r| r.nlp_failures).sum()
    }
}
