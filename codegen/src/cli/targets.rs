//! `qloop targets`: the built-in cost-model targets.

use super::error::CliResult;

/// Prints the table of built-in targets.
pub fn run() -> CliResult {
    print!(
        "{}",
        qloop::report::targets_table(&qloop::targets::builtin())
    );
    Ok(())
}
