//! The command line's definition (clap): the commands, their flags and their documentation.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "qloop",
    version,
    about = "Compile adaptive machine-tool controllers to division-free fixed-point code",
    long_about = "qloop compiles a declarative controller spec (*.qloop) into a Q-format \
fixed-point update routine that uses only adds, subtracts, shifts, compares and, where the \
target's cost model says it pays, a widening multiply. It never emits division or floating \
point.\n\nExit codes: 0 ok; 1 a claim does not hold (an obligation refuted or unknown, a goal \
not met) or a tool it needs is missing or failed; 2 bad input or usage (flags, spec, target, \
plant or scenario, an output path that cannot be written)."
)]
/// The parsed command line.
pub struct Cli {
    // The command (no doc comment: clap would take it as help text).
    #[command(subcommand)]
    pub cmd: Cmd,
}

/// The commands; each runs in its own module of `cli`.
#[derive(Subcommand)]
pub enum Cmd {
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
        /// Print every obligation's row (each solver's answer and time) and what the
        /// verdicts mean, not only the summary.
        #[arg(long, short)]
        verbose: bool,
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
        /// The plant: turning, milling, grinding or finishing.
        #[arg(long, default_value = "turning")]
        plant: String,
        /// A built-in scenario of the plant, or a scenario TOML file. Default: the plant's
        /// first built-in scenario (turning: depth-steps).
        #[arg(long)]
        scenario: Option<String>,
        /// Output directory.
        #[arg(long, default_value = "qloop-sim")]
        out: PathBuf,
        /// Plant integration substeps per controller period.
        #[arg(long, default_value_t = 20)]
        substeps: usize,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
        target: String,
        /// The nominal feed, in the plant's command unit, that a dimensionless (override)
        /// output scales: 100 % = this feed. Overrides a `#[nominal]` param.
        #[arg(long)]
        nominal_feed: Option<f64>,
        /// Exit with status 1 if a loop is unstable or a cutting segment never settles.
        #[arg(long)]
        check: bool,
    },
    /// Monte-Carlo envelope: closed-loop runs over drawn plant parameters and scenarios, on
    /// every core, reporting the worst case of each metric and the seed that produced it.
    Sweep {
        /// The spec file (*.qloop).
        spec: PathBuf,
        /// The plant: turning, milling, grinding or finishing.
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
    /// Pick the values of the spec's `tune` constants: every combination is simulated in
    /// closed loop over drawn plant variants (the same draws for all), the ones meeting the
    /// goals are proved fastest first, and the first whose every obligation proves is written
    /// back into the spec (--out), with the Pareto front and the reason for the choice.
    ///
    /// Exit status 1 when no candidate proves or none meets the goals (the closest that
    /// proves is still written, and the table says by how much it misses).
    Tune {
        /// The spec file (*.qloop) with `tune` items.
        spec: PathBuf,
        /// The plant: turning, milling, grinding or finishing.
        #[arg(long, default_value = "turning")]
        plant: String,
        /// Scenarios to draw from (built-in names or TOML files; repeatable). Default: every
        /// built-in scenario of the plant.
        #[arg(long)]
        scenario: Vec<String>,
        /// Draws per candidate.
        #[arg(long, default_value_t = 48)]
        draws: u64,
        /// Base seed of the draws.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Worker threads (default: every core).
        #[arg(long)]
        jobs: Option<usize>,
        /// Plant integration substeps per controller period.
        #[arg(long, default_value_t = 20)]
        substeps: usize,
        /// Goal: largest worst-case overshoot over the reference, in percent.
        #[arg(long, default_value_t = 20.0)]
        max_overshoot: f64,
        /// Goal: largest worst-case 5% settling time, in seconds.
        #[arg(long, default_value_t = 3.0)]
        max_settling: f64,
        /// Candidates the prover tries at most, in order of preference.
        #[arg(long, default_value_t = 16)]
        max_proofs: usize,
        /// SMT solvers for the proofs.
        #[arg(long, value_enum, default_value_t = Solvers::Both)]
        solvers: Solvers,
        /// Write the tuned spec here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// The tuned controller's name (default: the spec's).
        #[arg(long)]
        name: Option<String>,
        /// Also write the report to this file.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Target: a built-in name (see `qloop targets`) or a target file (`*.toml`).
        #[arg(long, default_value = "rv32i")]
        target: String,
    },
    /// Run check, gen, a closed-loop simulation (turning, depth steps: Koren & Masory (1981), Fig. 5) and prove
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
    /// ratios to qloop, flash and RAM (the controller's own and the whole firmware's, with
    /// the toolchain's size, nm and objdump), whether the firmware fits the target's memory
    /// (a variant that does not fit is reported, not run) and the goals.
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
    /// Run every Kani harness of a crate one at a time, each with a time limit, and print a
    /// table: harness, verdict, checks, seconds.
    ///
    /// Needs `cargo kani` (the book's "Kani harnesses", `docs/book/src/reference/kani.md`, says how
    /// to build it where `cargo kani setup` cannot download). Run it in the workspace. Exit 0 only if every harness is
    /// SUCCESSFUL; 1 if one fails, times out or does not compile.
    Kani {
        /// The package whose test harnesses to run.
        #[arg(long, default_value = "qloop-verified")]
        package: String,
        /// Time limit per harness, in seconds (Kani's `--harness-timeout`).
        #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u64).range(1..))]
        timeout: u64,
        /// Run only the harnesses whose name contains this text (repeatable).
        #[arg(long)]
        only: Vec<String>,
        /// SAT solver for every harness: cadical, kissat, minisat, ... (overrides the
        /// harnesses' `kani::solver` attributes).
        #[arg(long)]
        solver: Option<String>,
        /// Also write the table as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// The cargo to run (for tests).
        #[arg(long, default_value = "cargo", hide = true)]
        cargo: String,
        /// Seconds after the time limit at which a run's process group is killed.
        #[arg(long, default_value_t = 300, hide = true)]
        grace_secs: u64,
    },
    /// Discretise a continuous transfer function under a β fractional-order hold (Rubio & De la Sen, eqs.
    /// 4-5; β = 0 is the ZOH, β = 1 the causal FOH), and print the discrete coefficients as
    /// a difference equation and as `const` lines to paste into a spec.
    #[command(allow_negative_numbers = true)]
    C2d {
        /// Numerator coefficients, highest power of s first, comma-separated (e.g. `-3,150`).
        #[arg(
            long,
            value_delimiter = ',',
            required = true,
            allow_hyphen_values = true
        )]
        num: Vec<f64>,
        /// Denominator coefficients, highest power of s first (e.g. `1,20,550`).
        #[arg(
            long,
            value_delimiter = ',',
            required = true,
            allow_hyphen_values = true
        )]
        den: Vec<f64>,
        /// Sampling period in seconds.
        #[arg(long)]
        period: f64,
        /// Correcting gains β in [-1, 1], comma-separated; `paper` for Rubio & De la Sen's set
        /// {-0.5, -0.3, 0, 0.3, 0.5, 0.8, 1}.
        #[arg(long, default_value = "0", allow_hyphen_values = true)]
        beta: String,
        /// Prefix of the `const` names printed for a spec.
        #[arg(long, default_value = "H")]
        name: String,
    },
    /// Optimisation above the loops, on the host in f64: RCB2, the cycle-to-cycle constraint
    /// bounding of Ivester & Danai, on its turning model (reconstructed).
    ///
    /// Runs one scenario (10 % model bias, noise in [0.9, 1.1]) and prints it beside Ivester & Danai's
    /// Table 2, then runs a seeded study of confidence levels 0.1, 0.5 and 0.9 against the
    /// nominal optimiser without buffers (Ivester & Danai, Figs. 5 and 6). Writes the table, CSV files and
    /// plots to the output directory.
    Aco(AcoArgs),
    /// List the built-in cost-model targets.
    Targets,
    /// qloop's safety-rule libraries (`use feed_safety;` in a spec): every rule with its
    /// parameters, ports and proved properties.
    Rules {
        /// One library (default: all), or one rule of a library.
        name: Option<String>,
    },
    /// The plants' contracts: what each measures and is commanded (with units), its scenario
    /// channels, its default reference and its built-in scenarios.
    Plants {
        /// One plant (default: all).
        plant: Option<String>,
    },
}

/// The options of `qloop aco`.
#[derive(Args)]
pub struct AcoArgs {
    /// `rcb2`: Ivester & Danai's RCB2 (the default); `bendix`: the survey's Bendix ACO index (eqs. 1-3)
    /// maximised over feedrate and spindle speed for beta = 0, 0.5 and 1 on an example
    /// milling cut; `cascade`: RCB2 sets the force reference of the generated
    /// Koren-Masory loop for each of `--cycles` parts, each part cut in closed loop on
    /// the turning plant (needs cargo, like `sim`; uses `--c` and `--seed`).
    #[arg(value_enum, default_value = "rcb2")]
    pub study: AcoStudy,
    /// Confidence level c of Ivester & Danai, eq. 13 for both constraints, in [0, 1], of the printed
    /// run and the cascade (the study always compares 0.1, 0.5 and 0.9).
    #[arg(long, default_value_t = 0.5)]
    pub c: f64,
    /// Seed of the printed run; the study's runs use seeds seed, seed+1, ...
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Cycles (parts) of the printed run.
    #[arg(long, default_value_t = 10)]
    pub cycles: usize,
    /// Seeded runs per policy in the study (0 skips the study).
    #[arg(long, default_value_t = 100)]
    pub runs: usize,
    /// Cycles per run in the study.
    #[arg(long, default_value_t = 20)]
    pub study_cycles: usize,
    /// Output directory.
    #[arg(long, default_value = "qloop-aco")]
    pub out: PathBuf,
}

/// `qloop aco STUDY`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AcoStudy {
    /// RCB2 (Ivester & Danai).
    Rcb2,
    /// The Bendix ACO index (Koren's survey, eqs. 1-3).
    Bendix,
    /// RCB2 choosing the force reference of the generated 1981 loop per part (issue 19).
    Cascade,
}

/// `qloop prove --solvers`.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Solvers {
    /// z3 and cvc5 in parallel (cross-checked).
    Both,
    /// z3 only.
    Z3,
    /// cvc5 only.
    Cvc5,
}

/// `qloop gen --lang`.
#[derive(Clone, Copy, ValueEnum)]
pub enum Lang {
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

/// A seed in decimal or `0x` hexadecimal.
pub fn parse_seed(s: &str) -> Result<u64, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u64::from_str_radix(h, 16),
        None => s.parse(),
    };
    r.map_err(|e| format!("`{s}` is not a seed (a decimal or 0x-hex 64-bit number): {e}"))
}
