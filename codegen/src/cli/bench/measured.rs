//! A run's raw results and reading them from the simulator's output lines.

use super::variants::Variant;
use crate::cli::error::{CliError, CliResult};

/// A run's raw results: cost and raw outputs per step.
pub(super) struct Measured {
    pub(super) cost: Vec<u64>,
    pub(super) outs: Vec<Vec<i64>>,
}

impl Measured {
    /// Mean cost per step.
    pub(super) fn mean(&self) -> f64 {
        self.cost.iter().sum::<u64>() as f64 / self.cost.len().max(1) as f64
    }
    /// Least cost of a step.
    pub(super) fn min(&self) -> u64 {
        self.cost.iter().copied().min().unwrap_or(0)
    }
    /// Greatest cost of a step.
    pub(super) fn max(&self) -> u64 {
        self.cost.iter().copied().max().unwrap_or(0)
    }
}

/// A line from the simulator that does not parse (a tool failure).
pub(super) fn malformed(line: &str) -> CliError {
    CliError::tool(format!("malformed line from the simulator: `{line}`"))
}

/// A decimal count on `line`.
pub(super) fn num(s: &str, line: &str) -> CliResult<u64> {
    s.parse().map_err(|_| malformed(line))
}

/// A hexadecimal raw value on `line` (64-bit two's complement).
pub(super) fn hex(s: &str, line: &str) -> CliResult<i64> {
    u64::from_str_radix(s, 16)
        .map(|u| u as i64)
        .map_err(|_| malformed(line))
}

/// Fails unless the run reported `steps` timed steps, each with every output of `v`.
pub(super) fn check_counts(m: &Measured, v: &Variant, steps: usize, out: &str) -> CliResult {
    if m.cost.len() != steps
        || m.outs.len() != steps
        || m.outs.iter().any(|o| o.len() != v.outputs.len())
    {
        let tail: Vec<&str> = out.lines().rev().take(5).collect();
        return Err(CliError::tool(format!(
            "variant `{}`: the simulator reported {} timed steps and {} output records for {} steps \
             of {} outputs; last lines:\n{}",
            v.name,
            m.cost.len(),
            m.outs.len(),
            steps,
            v.outputs.len(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        )));
    }
    Ok(())
}
