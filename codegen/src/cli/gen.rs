//! `qloop gen`: the fixed-point Rust module, the f64 reference, the Kani harnesses, the C pair
//! or the LinuxCNC component, to standard output, a file (`-o`) or a directory (`--out`).

use super::args::Lang;
use super::error::{CliError, CliResult};
use super::files::{create_dir, load, write_atomic};
use qloop::Plan;
use std::io::Write;
use std::path::Path;

/// What `qloop gen` was asked to do.
pub struct GenArgs<'a> {
    /// The spec file.
    pub spec: &'a Path,
    /// The output language.
    pub lang: Lang,
    /// `-o FILE`.
    pub output: Option<&'a Path>,
    /// `--out DIR`.
    pub out: Option<&'a Path>,
    /// `--target`, if given.
    pub target: Option<&'a str>,
}

/// Generates the code `a` asks for and writes or prints it.
pub fn run(a: &GenArgs) -> CliResult {
    let default_target = match a.lang {
        Lang::Linuxcnc => "host",
        _ => "rv32i",
    };
    let (plan, _) = load(a.spec, a.target.unwrap_or(default_target))?;
    let text = match a.lang {
        Lang::Rust => qloop::gen_rust(&plan),
        Lang::RustRef => qloop::gen_reference(&plan),
        Lang::Kani => qloop::gen_kani(&plan),
        Lang::C => return gen_c(&plan, a.out, a.output),
        Lang::Linuxcnc => return gen_linuxcnc(&plan, a.out, a.output),
    };
    if a.out.is_some() {
        return Err(CliError::input(
            "`--out DIR` is for `--lang c` and `--lang linuxcnc`; use `-o FILE`",
        ));
    }
    match a.output {
        Some(p) => write_atomic(p, &text),
        None => {
            // Not `print!`: it panics when the reader has gone (`qloop gen SPEC | head`). Then
            // there is nothing left to do. (SIGPIPE stays ignored, as Rust sets it: `prove`
            // writes to solvers that may exit first.)
            let mut out = std::io::stdout().lock();
            match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
                Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CliError::failed(
                    format!("cannot write to standard output: {e}"),
                )),
                _ => Ok(()),
            }
        }
    }
}

/// Writes the C pair into `dir`, or prints it (header, then source) without one.
fn gen_c(plan: &Plan, dir: Option<&Path>, output: Option<&Path>) -> CliResult {
    let (h, c) = qloop::gen_c(plan);
    if output.is_some() {
        return Err(CliError::input(
            "`--lang c` writes two files; give a directory with `--out DIR`",
        ));
    }
    let Some(dir) = dir else {
        print!("{h}\n{c}");
        return Ok(());
    };
    create_dir(dir)?;
    let name = &plan.prog.name;
    write_atomic(&dir.join(format!("{name}.h")), &h)?;
    write_atomic(&dir.join(format!("{name}.c")), &c)
}

/// Writes the LinuxCNC component: `DIR/qloop_NAME.comp`, the file `-o` names (which must be
/// `qloop_NAME.comp`: halcompile takes the component name from the file name), or stdout.
fn gen_linuxcnc(plan: &Plan, dir: Option<&Path>, output: Option<&Path>) -> CliResult {
    let comp = qloop::emit::linuxcnc::component_name(plan);
    let file = format!("{comp}.comp");
    let path = match (dir, output) {
        (Some(_), Some(_)) => {
            return Err(CliError::input(
                "give either `--out DIR` or `-o FILE`, not both",
            ));
        }
        (Some(d), None) => Some(d.join(&file)),
        (None, Some(p)) => {
            if p.file_name().and_then(|n| n.to_str()) != Some(file.as_str()) {
                return Err(CliError::input(format!(
                    "`{}`: the component is `{comp}`, and halcompile requires its file to be \
                     named `{file}`",
                    p.display()
                )));
            }
            Some(p.to_path_buf())
        }
        (None, None) => None,
    };
    let text = qloop::gen_linuxcnc(plan).map_err(CliError::input)?;
    let Some(path) = path else {
        print!("{text}");
        return Ok(());
    };
    if let Some(d) = dir {
        create_dir(d)?;
    }
    write_atomic(&path, &text)
}
