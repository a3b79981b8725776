//! The `qloop` command: check, generate and demo.
//!
//! Exit codes: 0 ok, 1 refuted or failed, 2 bad input (unreadable file, spec error).

mod cli;

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
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
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
        /// Write into this directory (created if missing): `--lang c` NAME.h and NAME.c,
        /// `--lang linuxcnc` qloop_NAME.comp.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        /// Default: rv32i; host for `--lang linuxcnc`.
        #[arg(long)]
        target: Option<String>,
    },
    /// Prove every obligation (overflow, initial, inductive, properties) with z3 and cvc5.
    ///
    /// Exit 0 only if everything is proved; 1 if anything is refuted or unknown.
    Prove {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// Also write the report as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Time limit for the whole proof, in seconds (default: none). At the limit, running
        /// solvers are stopped and queries not yet started are not run: their obligations are
        /// unknown.
        #[arg(long)]
        timeout: Option<u64>,
        /// Time limit per solver per query, in seconds.
        #[arg(long, default_value_t = 60)]
        query_timeout: u64,
        /// Solver processes at once (default: the number of cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Which solvers to run.
        #[arg(long, value_enum, default_value_t = Solvers::Both)]
        solvers: Solvers,
        /// Verdict cache directory (default: $QLOOP_CACHE, else ~/.cache/qloop).
        #[arg(long)]
        cache: Option<PathBuf>,
        /// Do not read or write the verdict cache.
        #[arg(long)]
        no_cache: bool,
        /// Write each obligation's SMT-LIB 2 script into this directory.
        #[arg(long)]
        smt_dir: Option<PathBuf>,
        /// Prove only the obligations whose name contains this text.
        #[arg(long)]
        only: Option<String>,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
        target: String,
    },
    /// Run the compiled controller (fixed-point and f64 reference) in closed loop on a
    /// reference plant; write DIR/trace.csv, plots (SVG, PNG) and a summary.
    ///
    /// The generated Rust is compiled with cargo into a shared library (cached under
    /// $QLOOP_CACHE or ~/.cache/qloop/sim) and called through its `step`, so the run
    /// exercises the real routine.
    Sim {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// The plant: turning, milling or grinding.
        #[arg(long, default_value = "turning")]
        plant: String,
        /// A built-in scenario of the plant, or a scenario TOML file.
        #[arg(long, default_value = "depth-steps")]
        scenario: String,
        /// Output directory.
        #[arg(long, default_value = "qloop-sim")]
        out: PathBuf,
        /// Plant integration substeps per controller period.
        #[arg(long, default_value_t = 20)]
        substeps: usize,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
        target: String,
    },
    /// Monte-Carlo envelope: closed-loop runs over drawn plant parameters and scenarios, on
    /// every core, reporting the worst case of each metric and the seed that produced it.
    Sweep {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// The plant: turning, milling or grinding.
        #[arg(long, default_value = "turning")]
        plant: String,
        /// Scenarios to draw from (built-in names or TOML files; repeatable). Default: every
        /// built-in scenario of the plant.
        #[arg(long)]
        scenario: Vec<String>,
        /// Number of draws.
        #[arg(long, default_value_t = 1000)]
        draws: u64,
        /// Base seed of the draws.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Worker threads (default: every core).
        #[arg(long)]
        jobs: Option<usize>,
        /// Replay the draw with this seed (as the report prints it) like `qloop sim`, writing
        /// its trace, plots and summary to --out.
        #[arg(long, value_parser = parse_seed)]
        replay: Option<u64>,
        /// Output directory for --replay.
        #[arg(long, default_value = "qloop-sweep")]
        out: PathBuf,
        /// Also write the report to this file.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Plant integration substeps per controller period.
        #[arg(long, default_value_t = 20)]
        substeps: usize,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
        target: String,
    },
    /// Run check, gen, a closed-loop simulation (turning, depth steps: 000 Fig. 5) and prove
    /// on the built-in Koren–Masory (1981) spec; write to ./qloop-demo/.
    ///
    /// The proofs need z3 and/or cvc5 (skipped with a note if neither is installed).
    Demo {
        /// Output directory.
        #[arg(long, default_value = "qloop-demo")]
        out: PathBuf,
    },
    /// Measure cost per controller step on a target: qloop's C against the same spec with
    /// plain multiplies, in `float`, and (koren_masory_1981) the direct-division baselines.
    ///
    /// Compiles each variant with the target's C compiler and runs it in a simulator:
    /// simavr on atmega328p (exact cycles), qemu-system-arm on Cortex-M and
    /// qemu-system-riscv32 on RV32 (instructions executed, -icount). Prints cost per step,
    /// ratios to qloop and the goals.
    Bench {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// Target: atmega328p, cortex-m0, cortex-m0-slowmul, cortex-m4, rv32i, rv32imc (or a
        /// target file).
        #[arg(long)]
        target: String,
        /// Also write the results as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Controller steps per variant.
        #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        steps: u32,
        /// Exit 1 if a goal is not met (default: report only).
        #[arg(long)]
        check_goals: bool,
        /// Build in this directory and keep the files (default: a temporary one, removed).
        #[arg(long)]
        work_dir: Option<PathBuf>,
    },
    /// List the built-in cost-model targets.
    Targets,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Solvers {
    /// z3 and cvc5 in parallel (cross-checked).
    Both,
    /// z3 only.
    Z3,
    /// cvc5 only.
    Cvc5,
}

#[derive(Clone, Copy, ValueEnum)]
enum Lang {
    /// Fixed-point no_std Rust module (`fixed` types at the API, raw integers inside).
    Rust,
    /// The f64 reference controller compiled from the same spec.
    RustRef,
    /// Proof harnesses (`<spec>_proofs`): Kani proofs that also run as bolero property tests.
    /// Place the module next to the fixed-point one; needs `bolero` as a dev-dependency.
    Kani,
    /// C99 `.h`/`.c` pair (stdint types, no UB, ACSL contract; see `--out`).
    C,
    /// LinuxCNC HAL component `qloop_NAME.comp` for halcompile: the C controller, float pins
    /// `spindle-load` (first input) and `adaptive-feed` (first output over its range maximum).
    Linuxcnc,
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
            out,
            target,
        } => {
            let default_target = match lang {
                Lang::Linuxcnc => "host",
                _ => "rv32i",
            };
            let (plan, _) = load(&spec, target.as_deref().unwrap_or(default_target))?;
            let text = match lang {
                Lang::Rust => qloop::gen_rust(&plan),
                Lang::RustRef => qloop::gen_reference(&plan),
                Lang::Kani => qloop::gen_kani(&plan),
                Lang::C => return gen_c(&plan, out.as_deref(), output.as_deref()),
                Lang::Linuxcnc => return gen_linuxcnc(&plan, out.as_deref(), output.as_deref()),
            };
            if out.is_some() {
                eprintln!(
                    "error: `--out DIR` is for `--lang c` and `--lang linuxcnc`; use `-o FILE`"
                );
                return Err(Fail(2));
            }
            match output {
                Some(p) => write_atomic(&p, &text),
                None => {
                    print!("{text}");
                    Ok(())
                }
            }
        }
        Cmd::Prove {
            spec,
            json,
            timeout,
            query_timeout,
            jobs,
            solvers,
            cache,
            no_cache,
            smt_dir,
            only,
            target,
        } => {
            let (plan, _) = load(&spec, &target)?;
            if let Some(dir) = &smt_dir {
                write_smt(&plan, dir)?;
            }
            let mut cfg = solver_config(solvers, query_timeout, jobs, cache, no_cache)?;
            let start = std::time::Instant::now();
            cfg.deadline = timeout.map(|t| start + std::time::Duration::from_secs(t));
            let report = run_prove(&plan, &cfg, only.as_deref());
            print!("{}", report.table(&plan));
            if let Some(j) = json {
                write_atomic(&j, &report.json())?;
            }
            if report.proved() {
                Ok(())
            } else {
                Err(Fail(1))
            }
        }
        Cmd::Sim {
            spec,
            plant,
            scenario,
            out,
            substeps,
            target,
        } => {
            let (plan, _) = load(&spec, &target)?;
            let r = cli::sim::sim(&cli::sim::SimArgs {
                plan: &plan,
                plant: &plant,
                scenario: &scenario,
                out: &out,
                substeps: substeps.max(1),
            })?;
            print!("{}", r.summary);
            for f in &r.files {
                println!("wrote {}", f.display());
            }
            Ok(())
        }
        Cmd::Sweep {
            spec,
            plant,
            scenario,
            draws,
            seed,
            jobs,
            replay,
            out,
            report,
            substeps,
            target,
        } => {
            let (plan, _) = load(&spec, &target)?;
            run_sweep(
                &plan,
                &cli::sweep::SweepArgs {
                    spec: &plan.prog.name,
                    plant: &plant,
                    scenarios: &scenario,
                    draws,
                    seed,
                    substeps: substeps.max(1),
                },
                jobs,
                replay,
                &out,
                report.as_deref(),
            )
        }
        Cmd::Bench {
            spec,
            target: target_name,
            json,
            steps,
            check_goals,
            work_dir,
        } => {
            let (plan, _) = load(&spec, &target_name)?;
            let plain = plan_for(&spec, &plan.target.always_multiply())?;
            cli::bench::bench(&cli::bench::BenchArgs {
                plan: &plan,
                plain: &plain,
                steps: steps as usize,
                json: json.as_deref(),
                check_goals,
                work_dir: work_dir.as_deref(),
            })
        }
        Cmd::Demo { out } => demo(&out),
        Cmd::Targets => {
            print!(
                "{}",
                qloop::report::targets_table(&qloop::targets::builtin())
            );
            Ok(())
        }
    }
}

/// A seed in decimal or `0x` hexadecimal.
fn parse_seed(s: &str) -> Result<u64, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u64::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|e| format!("`{s}` is not a seed (a decimal or 0x-hex 64-bit number): {e}"))
}

fn run_sweep(
    plan: &Plan,
    a: &cli::sweep::SweepArgs,
    jobs: Option<usize>,
    replay: Option<u64>,
    out: &Path,
    report: Option<&Path>,
) -> Result<(), Fail> {
    let compiled = cli::sim::compile(plan)?;
    if let Some(seed) = replay {
        let (d, trace, m) = cli::sweep::replay(a, &compiled, seed)?;
        let args = cli::sim::SimArgs {
            plan,
            plant: a.plant,
            scenario: &d.scenario.name,
            out,
            substeps: a.substeps,
        };
        let params: Vec<String> = d.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
        println!(
            "draw {seed:#018x}: scenario {} (noise seed {}), {}",
            d.scenario.name,
            d.scenario.seed,
            params.join(" ")
        );
        let r = cli::sim::write_run(&args, &compiled, d.plant.as_ref(), &d.scenario, trace, m)?;
        print!("{}", r.summary);
        for f in &r.files {
            println!("wrote {}", f.display());
        }
        return Ok(());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .map_err(|e| {
            eprintln!("error: cannot start worker threads: {e}");
            Fail(1)
        })?;
    let start = std::time::Instant::now();
    let env = pool.install(|| cli::sweep::sweep(a, &compiled))?;
    let secs = start.elapsed().as_secs_f64();
    let nominal = qloop_plant::catalog::plant_named(a.plant).map_err(|e| {
        eprintln!("error: {e}");
        Fail(2)
    })?;
    let scs = cli::sweep::scenarios(a.plant, a.scenarios)?;
    let sig = compiled.signals().clone();
    let units = |name: &str| {
        sig.states
            .iter()
            .chain(&sig.outputs)
            .find(|s| s.0 == name)
            .map_or(String::new(), |s| s.1.to_string())
    };
    let mut text = cli::sweep::report(a, nominal.as_ref(), &scs, &env, sig.inputs[0].1, &units);
    text.push_str(&format!(
        "
{} draws in {secs:.1} s on {} threads ({:.0} draws/s)\n",
        env.draws,
        pool.current_num_threads(),
        env.draws as f64 / secs.max(1e-9)
    ));
    print!("{text}");
    if let Some(p) = report {
        write_atomic(p, &text)?;
    }
    Ok(())
}

/// Writes the C pair into `dir`, or prints it (header, then source) without one.
fn gen_c(plan: &Plan, dir: Option<&Path>, output: Option<&Path>) -> Result<(), Fail> {
    let (h, c) = qloop::gen_c(plan);
    if output.is_some() {
        eprintln!("error: `--lang c` writes two files; give a directory with `--out DIR`");
        return Err(Fail(2));
    }
    let Some(dir) = dir else {
        print!("{h}\n{c}");
        return Ok(());
    };
    std::fs::create_dir_all(dir).map_err(|e| {
        eprintln!("error: cannot create `{}`: {e}", dir.display());
        Fail(2)
    })?;
    let name = &plan.prog.name;
    write_atomic(&dir.join(format!("{name}.h")), &h)?;
    write_atomic(&dir.join(format!("{name}.c")), &c)
}

/// Writes the LinuxCNC component: `DIR/qloop_NAME.comp`, the file `-o` names (which must be
/// `qloop_NAME.comp`: halcompile takes the component name from the file name), or stdout.
fn gen_linuxcnc(plan: &Plan, dir: Option<&Path>, output: Option<&Path>) -> Result<(), Fail> {
    let comp = qloop::emit::linuxcnc::component_name(plan);
    let file = format!("{comp}.comp");
    let path = match (dir, output) {
        (Some(_), Some(_)) => {
            eprintln!("error: give either `--out DIR` or `-o FILE`, not both");
            return Err(Fail(2));
        }
        (Some(d), None) => Some(d.join(&file)),
        (None, Some(p)) => {
            if p.file_name().and_then(|n| n.to_str()) != Some(file.as_str()) {
                eprintln!(
                    "error: `{}`: the component is `{comp}`, and halcompile requires its file \
                     to be named `{file}`",
                    p.display()
                );
                return Err(Fail(2));
            }
            Some(p.to_path_buf())
        }
        (None, None) => None,
    };
    let text = qloop::gen_linuxcnc(plan).map_err(|e| {
        eprintln!("error: {e}");
        Fail(2)
    })?;
    let Some(path) = path else {
        print!("{text}");
        return Ok(());
    };
    if let Some(d) = dir {
        std::fs::create_dir_all(d).map_err(|e| {
            eprintln!("error: cannot create `{}`: {e}", d.display());
            Fail(2)
        })?;
    }
    write_atomic(&path, &text)
}

/// A built-in target by name, or a target file.
fn target(name: &str) -> Result<Target, Fail> {
    if name.ends_with(".toml") || name.contains('/') {
        let text = std::fs::read_to_string(name).map_err(|e| {
            eprintln!("error: cannot read target file `{name}`: {e}");
            Fail(2)
        })?;
        return qloop::targets::from_toml(&text).map_err(|e| {
            eprintln!("error: {name}: {e}");
            eprintln!("help: see targets/*.toml for the format");
            Fail(2)
        });
    }
    qloop::targets::by_name(name).ok_or_else(|| {
        eprintln!(
            "error: unknown target `{name}`; built-in targets: {} (or give a target file, `*.toml`)",
            qloop::targets::builtin_names().join(", ")
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

/// The spec at `path` planned for `t` (for `bench`'s second target).
fn plan_for(path: &Path, t: &Target) -> Result<Plan, Fail> {
    let name = path.display().to_string();
    let src = std::fs::read_to_string(path).map_err(|e| {
        eprintln!("error: cannot read `{name}`: {e}");
        Fail(2)
    })?;
    qloop::compile_str(&src, t).map_err(|d| {
        report(&d, &name, &src);
        Fail(2)
    })
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

fn solver_config(
    which: Solvers,
    timeout: u64,
    jobs: Option<usize>,
    cache: Option<PathBuf>,
    no_cache: bool,
) -> Result<qloop::prove::solver::Config, Fail> {
    use qloop::prove::solver::{Config, Solver};
    let wanted: Vec<Solver> = match which {
        Solvers::Both => Solver::ALL.to_vec(),
        Solvers::Z3 => vec![Solver::Z3],
        Solvers::Cvc5 => vec![Solver::Cvc5],
    };
    let solvers: Vec<Solver> = wanted.iter().copied().filter(|s| s.available()).collect();
    for s in wanted.iter().filter(|s| !s.available()) {
        eprintln!(
            "warning: {} is not installed (on Debian: apt-get install {})",
            s.name(),
            s.name()
        );
    }
    if solvers.is_empty() {
        eprintln!("error: no SMT solver available; install z3 and cvc5 (apt-get install z3 cvc5)");
        return Err(Fail(1));
    }
    let mut cfg = Config {
        solvers,
        timeout_ms: timeout.saturating_mul(1000),
        ..Config::default()
    };
    if let Some(j) = jobs {
        cfg.jobs = j.max(1);
    }
    cfg.cache_dir = if no_cache {
        None
    } else {
        cache
            .or_else(|| std::env::var_os("QLOOP_CACHE").map(PathBuf::from))
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/qloop")))
    };
    Ok(cfg)
}

/// Runs the prover with a progress bar on standard error (hidden when it is not a terminal).
/// Writes every obligation's SMT-LIB script to `dir` (one `.smt2` file each).
fn write_smt(plan: &Plan, dir: &Path) -> Result<(), Fail> {
    std::fs::create_dir_all(dir).map_err(|e| {
        eprintln!("error: cannot create `{}`: {e}", dir.display());
        Fail(1)
    })?;
    for (i, ob) in qloop::prove::obligations::obligations(plan)
        .iter()
        .enumerate()
    {
        let text = format!(
            "; qloop obligation {i}: {} ({})\n(set-option :produce-models true)\n{}(check-sat)\n",
            ob.label(),
            ob.kind.name(),
            ob.query.script
        );
        write_atomic(&dir.join(format!("{i:03}-{}.smt2", ob.kind.name())), &text)?;
    }
    Ok(())
}

fn run_prove(
    plan: &Plan,
    cfg: &qloop::prove::solver::Config,
    only: Option<&str>,
) -> qloop::prove::Report {
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} proving {pos}/{len} solver runs [{elapsed}] {wide_bar}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Without a terminal (CI logs), a plain line every 10 s instead of the bar.
    let quiet = bar.is_hidden();
    let start = std::time::Instant::now();
    let mut last = start;
    let report = qloop::prove::prove_filtered(plan, cfg, only, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        if quiet && (last.elapsed().as_secs() >= 10 || done == total) {
            last = std::time::Instant::now();
            eprintln!(
                "qloop prove: {done}/{total} solver runs done, {:.0} s",
                start.elapsed().as_secs_f64()
            );
        }
    });
    bar.finish_and_clear();
    report
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
    // The closed-loop step: the compiled controller on the turning plant, 000 Fig. 5.
    println!();
    let sim_out = out.join("sim");
    let r = cli::sim::sim(&cli::sim::SimArgs {
        plan: &plan,
        plant: "turning",
        scenario: "depth-steps",
        out: &sim_out,
        substeps: 20,
    })?;
    print!("{}", r.summary);
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    if !r.metrics.fixed.stable() {
        eprintln!("error: the demo's closed loop is unstable");
        return Err(Fail(1));
    }
    // The proof step: every obligation, with the verdict cache (an unchanged spec re-proves
    // instantly).
    println!();
    let missing: Vec<&str> = qloop::prove::solver::Solver::ALL
        .iter()
        .filter(|s| !s.available())
        .map(|s| s.name())
        .collect();
    if missing.len() == qloop::prove::solver::Solver::ALL.len() {
        println!("skipping the proofs: no SMT solver installed (apt-get install z3 cvc5)");
        return Ok(());
    }
    let cfg = solver_config(Solvers::Both, 300, None, None, false)?;
    println!(
        "proving every obligation with {} (first run: a few minutes; then cached) ...",
        cfg.solvers
            .iter()
            .map(|s| s.name())
            .collect::<Vec<_>>()
            .join(" and ")
    );
    let report = run_prove(&plan, &cfg, None);
    let table = report.table(&plan);
    print!("{table}");
    for (f, text) in [("prove.txt", table), ("prove.json", report.json())] {
        let p = out.join(f);
        write_atomic(&p, &text)?;
        println!("wrote {}", p.display());
    }
    if report.proved() {
        Ok(())
    } else {
        Err(Fail(1))
    }
}
