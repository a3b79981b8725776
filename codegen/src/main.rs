//! The `qloop` command: parses the command line, runs the command and maps its error to the
//! exit code. The commands live in `cli/`, one module each; the exit-code rule is in
//! `cli/error.rs`: 0 ok, 1 a claim does not hold or a tool failed, 2 bad input or usage.

mod cli;

use clap::Parser;
use cli::args::{Cli, Cmd};
use cli::error::CliResult;
use std::process::ExitCode;

fn main() -> ExitCode {
    match Cli::try_parse().map_err(Into::into).and_then(run) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            e.print();
            ExitCode::from(e.exit_code())
        }
    }
}

/// Runs one command.
fn run(cli: Cli) -> CliResult {
    match cli.cmd {
        Cmd::Check { spec, target } => cli::check::run(&spec, &target),
        Cmd::Gen {
            spec,
            lang,
            output,
            out,
            target,
        } => cli::gen::run(&cli::gen::GenArgs {
            spec: &spec,
            lang,
            output: output.as_deref(),
            out: out.as_deref(),
            target: target.as_deref(),
        }),
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
            verbose,
        } => cli::prove::run(cli::prove::ProveArgs {
            verbose,
            spec: &spec,
            json: json.as_deref(),
            timeout,
            query_timeout,
            jobs,
            solvers,
            cache,
            no_cache,
            smt_dir: smt_dir.as_deref(),
            only: only.as_deref(),
            target: &target,
        }),
        Cmd::Sim {
            spec,
            plant,
            scenario,
            out,
            substeps,
            target,
            nominal_feed,
            check,
        } => cli::sim::run(
            &spec,
            &target,
            (&plant, scenario.as_deref()),
            &out,
            (substeps, nominal_feed, check),
        ),
        Cmd::Tune {
            spec,
            plant,
            scenario,
            draws,
            seed,
            jobs,
            substeps,
            max_overshoot,
            max_settling,
            max_proofs,
            solvers,
            out,
            name,
            report,
            target,
        } => cli::tune::run(&cli::tune::TuneCommand {
            spec: &spec,
            target: &target,
            plant: &plant,
            scenarios: &scenario,
            draws,
            seed,
            jobs,
            substeps,
            goals: cli::tune::pareto::Goals {
                overshoot: max_overshoot / 100.0,
                settling_s: max_settling,
            },
            max_proofs,
            solvers,
            out: out.as_deref(),
            name: name.as_deref(),
            report: report.as_deref(),
        }),
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
        } => cli::sweep::run(&cli::sweep::SweepCommand {
            spec: &spec,
            target: &target,
            plant: &plant,
            scenarios: &scenario,
            draws,
            seed,
            jobs,
            replay,
            out: &out,
            report: report.as_deref(),
            substeps,
        }),
        Cmd::Bench {
            spec,
            target,
            json,
            steps,
            check_goals,
            work_dir,
        } => cli::bench::run(
            &spec,
            &target,
            json.as_deref(),
            steps,
            check_goals,
            work_dir.as_deref(),
        ),
        Cmd::Demo { out } => cli::demo::run(&out),
        Cmd::Kani {
            package,
            timeout,
            only,
            solver,
            json,
            cargo,
            grace_secs,
        } => cli::kani::run(&cli::kani::KaniArgs {
            package: &package,
            timeout,
            only: &only,
            solver: solver.as_deref(),
            json: json.as_deref(),
            cargo: &cargo,
            grace: grace_secs,
        }),
        Cmd::C2d {
            num,
            den,
            period,
            beta,
            name,
        } => cli::c2d::run(&num, &den, period, &beta, &name),
        Cmd::Aco(args) => cli::aco::run(&args),
        Cmd::Targets => cli::targets::run(),
        Cmd::Rules { name } => cli::rules::run(name.as_deref()),
        Cmd::Plants { plant } => cli::plants::run(plant.as_deref()),
    }
}
