//! The one error type of the command line, its exit code and how it is printed.
//!
//! Every command returns `Result<(), CliError>`; `main` prints the error and exits with
//! [`CliError::exit_code`], and nothing else in the CLI decides an exit code. The rule:
//!
//! | code | meaning | variants |
//! |---|---|---|
//! | 0 | done, and every claim holds | (also `--help` and `--version`) |
//! | 1 | the command ran, but what it checks does not hold, or it could not finish: a proof obligation refuted or unknown, a goal not met, outputs that disagree, an unstable loop; or a tool it needs is missing or failed (no SMT solver, no C compiler or simulator, cargo failed) | [`Failed`](CliError::Failed), [`Tool`](CliError::Tool) |
//! | 2 | the request is wrong and running again will fail the same way until it is fixed: a bad flag or value, an unreadable or invalid spec, target or scenario file (spec errors show `file:line:col` with a caret), an unknown target, plant or scenario, a target or spec the command cannot handle, or a file or directory that cannot be created or written | [`Args`](CliError::Args), [`Spec`](CliError::Spec), [`Unreadable`](CliError::Unreadable), [`Input`](CliError::Input), [`Output`](CliError::Output) |
//!
//! Messages start with `error: ` (spec errors are rendered by miette) and say what to do.

use miette::{LabeledSpan, MietteDiagnostic, NamedSource, Report};
use qloop::Diag;
use std::fmt::Display;
use std::path::Path;

/// Exit code of a successful run.
pub const OK: u8 = 0;
/// Exit code when a claim does not hold, or a tool is missing or failed.
pub const FAILED: u8 = 1;
/// Exit code for bad input or usage.
pub const BAD_INPUT: u8 = 2;

/// Why a command did not succeed. Exit code 2 (bad input or usage): `Args`, `Spec`,
/// `Unreadable`, `Input`, `Output`; exit code 1 (a claim does not hold, or a tool failed):
/// `Failed`, `Tool`. The table in the module docs says which failure is which.
#[derive(Debug)]
pub enum CliError {
    /// The command line did not parse (unknown flag, bad value), or `--help` / `--version`
    /// was asked for: printed by clap; exit 2, or 0 for help and version.
    Args(clap::Error),
    /// A spec that does not compile, already rendered with `file:line:col` and a caret
    /// (rendered when made, so that the error can cross threads); exit 2.
    Spec(String),
    /// A file that cannot be read (`what` says which, e.g. "target file "); exit 2.
    Unreadable {
        /// What kind of file, with a trailing space, or empty.
        what: &'static str,
        /// The path as given.
        path: String,
        /// The reason.
        source: std::io::Error,
    },
    /// Bad input: an unknown target, plant or scenario, an invalid target or scenario file,
    /// options that do not go together, a target or spec the command cannot handle; exit 2.
    Input {
        /// What is wrong and what to do.
        msg: String,
        /// A further hint, printed as `help: ...`.
        help: Option<String>,
    },
    /// A file or directory that cannot be created or written; exit 2.
    Output(String),
    /// What the command checks does not hold (a refuted or unknown obligation, a goal not
    /// met, outputs that disagree, an unstable loop); exit 1. `None` when the command's own
    /// output already says so (the proof table).
    Failed(Option<String>),
    /// A tool the command needs is missing or failed (SMT solver, C compiler, simulator,
    /// cargo), or an internal step failed; exit 1.
    Tool(String),
    /// An error with a note printed after it (e.g. where the build files were kept).
    Noted(Box<CliError>, String),
}

/// The commands' result.
pub type CliResult<T = ()> = Result<T, CliError>;

impl CliError {
    /// Bad input with a message (exit 2).
    pub fn input(msg: impl Display) -> Self {
        CliError::Input {
            msg: msg.to_string(),
            help: None,
        }
    }

    /// A tool failure with a message (exit 1).
    pub fn tool(msg: impl Display) -> Self {
        CliError::Tool(msg.to_string())
    }

    /// A claim that does not hold, with a message (exit 1).
    pub fn failed(msg: impl Display) -> Self {
        CliError::Failed(Some(msg.to_string()))
    }

    /// `cannot create `path`: e` (exit 2).
    pub fn cannot_create(path: &Path, e: impl Display) -> Self {
        CliError::Output(format!("cannot create `{}`: {e}", path.display()))
    }

    /// `cannot write `path`: e` (exit 2).
    pub fn cannot_write(path: &Path, e: impl Display) -> Self {
        CliError::Output(format!("cannot write `{}`: {e}", path.display()))
    }

    /// A spec diagnostic for `file` with text `src` (exit 2).
    pub fn spec(diag: &Diag, file: &str, src: &str) -> Self {
        CliError::Spec(render(diag, file, src))
    }

    /// The same error with `note` printed after it.
    pub fn with_note(self, note: impl Display) -> Self {
        CliError::Noted(Box::new(self), note.to_string())
    }

    /// The process exit code: 1 or 2 by the rule in the module docs (0 for `--help`).
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Args(e) if !e.use_stderr() => OK,
            CliError::Args(_)
            | CliError::Spec(_)
            | CliError::Unreadable { .. }
            | CliError::Input { .. }
            | CliError::Output(_) => BAD_INPUT,
            CliError::Failed(_) | CliError::Tool(_) => FAILED,
            CliError::Noted(e, _) => e.exit_code(),
        }
    }

    /// Prints the error (clap's to its own stream, the rest to standard error).
    pub fn print(&self) {
        match self {
            CliError::Args(e) => {
                let _ = e.print();
            }
            CliError::Spec(rendered) => eprintln!("{rendered}"),
            CliError::Unreadable { what, path, source } => {
                eprintln!("error: cannot read {what}`{path}`: {source}");
            }
            CliError::Input { msg, help } => {
                eprintln!("error: {msg}");
                if let Some(h) = help {
                    eprintln!("help: {h}");
                }
            }
            CliError::Output(msg) | CliError::Tool(msg) | CliError::Failed(Some(msg)) => {
                eprintln!("error: {msg}");
            }
            CliError::Failed(None) => {}
            CliError::Noted(e, note) => {
                e.print();
                eprintln!("note: {note}");
            }
        }
    }
}

impl From<clap::Error> for CliError {
    fn from(e: clap::Error) -> Self {
        CliError::Args(e)
    }
}

/// Renders a diagnostic with `file:line:col` and a caret (miette).
pub fn render(d: &Diag, file: &str, src: &str) -> String {
    // miette prints `file:line:col` in the snippet header.
    let (s, e) = d.byte_range(src);
    let mut m = MietteDiagnostic::new(d.message.clone()).with_label(LabeledSpan::at(
        s..e.max(s + 1).min(src.len().max(s)),
        d.label.clone(),
    ));
    if let Some(h) = &d.help {
        m = m.with_help(h.clone());
    }
    let r = Report::new(m).with_source_code(NamedSource::new(file, src.to_string()));
    format!("{r:?}")
}
