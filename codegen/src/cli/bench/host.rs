//! The host side: checking and running tools (with a time limit) and writing files.

use crate::cli::error::{CliError, CliResult};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Wall-clock limit of one simulator run (a hung firmware is an error, not a hang).
const RUN_LIMIT: Duration = Duration::from_secs(600);

/// Fails with an install hint unless `prog --version` runs.
pub(super) fn need_tool(prog: &str, hint: &str) -> CliResult {
    match Command::new(prog)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(_) => Ok(()),
        Err(e) => Err(CliError::tool(format!(
            "`{prog}` cannot be run ({e}); `qloop bench` needs it: {hint}"
        ))),
    }
}

/// Writes a build file (atomically).
pub(super) fn write_file(p: &Path, text: &str) -> CliResult {
    crate::cli::files::write_atomic(p, text)
}

/// Creates a build directory.
pub(super) fn mkdir(p: &Path) -> CliResult {
    crate::cli::files::create_dir(p)
}

/// Runs `cmd` with its output in files, killing it after [`RUN_LIMIT`].
pub(super) fn run_limited(
    cmd: &mut Command,
    what: &str,
    out: &Path,
    err: &Path,
) -> CliResult<(std::process::ExitStatus, String, String)> {
    let open = |p: &Path| std::fs::File::create(p).map_err(|e| CliError::cannot_create(p, e));
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(open(out)?)
        .stderr(open(err)?)
        .spawn()
        .map_err(|e| CliError::tool(format!("cannot start {what}: {e}")))?;
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if start.elapsed() > RUN_LIMIT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(CliError::tool(format!(
                    "{what} did not finish within {} s (killed); output in `{}`",
                    RUN_LIMIT.as_secs(),
                    err.display()
                )));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(10)),
            Err(e) => return Err(CliError::tool(format!("waiting for {what}: {e}"))),
        }
    };
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    Ok((status, read(out), read(err)))
}
