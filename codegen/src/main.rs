//! The `qloop` command: check, generate and demo.
//!
//! Exit codes: 0 ok, 1 refuted or failed, 2 bad input (unreadable file, spec error).

use clap::{Parser, Subcommand, ValueEnum};
use miette::{LabeledSpan, MietteDiagnostic, NamedSource, Report};
use qloop::{Diag, Plan, Target};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "qloop",
    version,
    about = "Compile adaptive machine-tool controllers to division-free fixed-point code",
    long_about = "qloop compiles a declarative controller spec (*.qloop) into a Q-format \
fixed-point update routine that uses only adds, subtracts, shifts, compares and, where the \
target's cost model says it pays, a widening multiply. It never emits division or floating \
point.\n\nExit codes: 0 ok, 1 refuted or failed, 2 bad input."
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Analyse a spec: print every signal's range, Q-format, LSB and one-step error bound.
    Check {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// Cost-model target (see `qloop targets`).
        #[arg(long, default_value = "generic32")]
        target: String,
    },
    /// Generate code from a spec.
    Gen {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// Output language.
        #[arg(long, value_enum, default_value_t = Lang::Rust)]
        lang: Lang,
        /// Write to this file (atomically) instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Cost-model target (see `qloop targets`).
        #[arg(long, default_value = "generic32")]
        target: String,
    },
    /// Run check and gen on the built-in Koren–Masory (1981) spec; write to ./qloop-demo/.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "qloop-demo")]
        out: PathBuf,
    },
    /// List the built-in cost-model targets.
    Targets,
}

#[derive(Clone, Copy, ValueEnum)]
enum Lang {
    /// Fixed-point no_std Rust module (`fixed` types at the API, raw integers inside).
    Rust,
    /// The f64 reference controller compiled from the same spec.
    RustRef,
}

/// A failure with its exit code.
struct Fail(u8);

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Fail(code)) => ExitCode::from(code),
    }
}

fn run(cli: Cli) -> Result<(), Fail> {
    match cli.cmd {
        Cmd::Check { spec, target } => {
            let (plan, name) = load(&spec, &target)?;
            print!("{}", qloop::report::check_report(&plan, &name));
            Ok(())
        }
        Cmd::Gen {
            spec,
            lang,
            output,
            target,
        } => {
            let (plan, _) = load(&spec, &target)?;
            let text = match lang {
                Lang::Rust => qloop::gen_rust(&plan),
                Lang::RustRef => qloop::gen_reference(&plan),
            };
            match output {
                Some(p) => write_atomic(&p, &text),
                None => {
                    print!("{text}");
                    Ok(())
                }
            }
        }
        Cmd::Demo { out } => demo(&out),
        Cmd::Targets => {
            for t in Target::ALL {
                println!("{:<10} {}", t.name, t.about);
            }
            Ok(())
        }
    }
}

fn target(name: &str) -> Result<Target, Fail> {
    Target::by_name(name).ok_or_else(|| {
        let names: Vec<_> = Target::ALL.iter().map(|t| t.name).collect();
        eprintln!(
            "error: unknown target `{name}`; known targets: {}",
            names.join(", ")
        );
        Fail(2)
    })
}

fn load(path: &Path, target_name: &str) -> Result<(Plan, String), Fail> {
    let t = target(target_name)?;
    let name = path.display().to_string();
    let src = std::fs::read_to_string(path).map_err(|e| {
        eprintln!("error: cannot read `{name}`: {e}");
        Fail(2)
    })?;
    let plan = qloop::compile_str(&src, &t).map_err(|d| {
        report(&d, &name, &src);
        Fail(2)
    })?;
    Ok((plan, name))
}

/// Renders a diagnostic with file:line:col and a caret (miette).
fn report(d: &Diag, file: &str, src: &str) {
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
    eprintln!("{r:?}");
}

fn write_atomic(path: &Path, text: &str) -> Result<(), Fail> {
    let fail = |e: std::io::Error| {
        eprintln!("error: cannot write `{}`: {e}", path.display());
        Fail(1)
    };
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

fn demo(out: &Path) -> Result<(), Fail> {
    let t = Target::default();
    let name = "koren_masory_1981.qloop";
    let plan = qloop::compile_str(qloop::DEMO_SPEC, &t).map_err(|d| {
        report(&d, name, qloop::DEMO_SPEC);
        Fail(1)
    })?;
    std::fs::create_dir_all(out).map_err(|e| {
        eprintln!("error: cannot create `{}`: {e}", out.display());
        Fail(1)
    })?;
    let check = qloop::report::check_report(&plan, name);
    print!("{check}");
    let files = [
        ("koren_masory_1981.qloop", qloop::DEMO_SPEC.to_string()),
        ("check.txt", check),
        ("koren_masory_1981.rs", qloop::gen_rust(&plan)),
        ("koren_masory_1981_ref.rs", qloop::gen_reference(&plan)),
    ];
    println!();
    for (f, text) in &files {
        let p = out.join(f);
        write_atomic(&p, text)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
