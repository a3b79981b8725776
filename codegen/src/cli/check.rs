//! `qloop check`: every signal's range, Q-format, LSB and one-step error bound.

use super::error::CliResult;
use super::files::load;
use std::path::Path;

/// Prints the check report of `spec` planned for `target`.
pub fn run(spec: &Path, target: &str) -> CliResult {
    let (plan, name) = load(spec, target)?;
    print!("{}", qloop::report::check_report(&plan, &name));
    Ok(())
}
