//! Reading inputs and writing outputs: the spec and target loaders every command shares, and
//! atomic file writes.

use super::error::{CliError, CliResult};
use qloop::{Plan, Target};
use std::path::Path;

/// A built-in target by name, or a target file (a name ending `.toml` or containing `/`).
pub fn target(name: &str) -> CliResult<Target> {
    if name.ends_with(".toml") || name.contains('/') {
        let text = std::fs::read_to_string(name).map_err(|e| CliError::Unreadable {
            what: "target file ",
            path: name.to_string(),
            source: e,
        })?;
        return qloop::targets::from_toml(&text).map_err(|e| CliError::Input {
            msg: format!("{name}: {e}"),
            help: Some("see targets/*.toml for the format".into()),
        });
    }
    qloop::targets::by_name(name).ok_or_else(|| {
        CliError::input(format!(
            "unknown target `{name}`; built-in targets: {} (or give a target file, `*.toml`)",
            qloop::targets::builtin_names().join(", ")
        ))
    })
}

/// The spec at `path` planned for the target named `target_name`, and the spec's file name
/// as shown in reports.
pub fn load(path: &Path, target_name: &str) -> CliResult<(Plan, String)> {
    let t = target(target_name)?;
    let plan = plan_for(path, &t)?;
    Ok((plan, path.display().to_string()))
}

/// The spec at `path` planned for `t`.
pub fn plan_for(path: &Path, t: &Target) -> CliResult<Plan> {
    let name = path.display().to_string();
    let src = std::fs::read_to_string(path).map_err(|e| CliError::Unreadable {
        what: "",
        path: name.clone(),
        source: e,
    })?;
    qloop::compile_str(&src, t).map_err(|d| CliError::spec(&d, &name, &src))
}

/// Creates `dir` and its parents if missing.
pub fn create_dir(dir: &Path) -> CliResult {
    std::fs::create_dir_all(dir).map_err(|e| CliError::cannot_create(dir, e))
}

/// Writes `text` to `path` atomically: into a temporary file next to it, then renamed over it,
/// so a reader never sees a partial file.
pub fn write_atomic(path: &Path, text: &str) -> CliResult {
    let fail = |e: std::io::Error| CliError::cannot_write(path, e);
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("out"),
        std::process::id()
    ));
    std::fs::write(&tmp, text).map_err(fail)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })
}
