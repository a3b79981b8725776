//! `qloop demo`: check, gen, a closed-loop simulation and prove on the built-in Koren–Masory
//! (1981) spec, everything written into one directory.

use super::args::Solvers;
use super::error::{render, CliError, CliResult};
use super::files::{create_dir, write_atomic};
use super::prove::{prove_with_progress, solver_config};
use super::sim::{print_run, sim, SimArgs};
use qloop::prove::solver::Solver;
use qloop::Target;
use std::path::Path;

/// The demo spec's file name.
const NAME: &str = "koren_masory_1981.qloop";

/// Runs the demo into `out`; fails if its loop is unstable or an obligation is not proved.
pub fn run(out: &Path) -> CliResult {
    let plan = qloop::compile_str(qloop::DEMO_SPEC, &Target::default()).map_err(|d| {
        // The built-in spec always compiles; if not, that is qloop's bug, not the user's.
        CliError::tool(format!(
            "internal: the built-in demo spec does not compile:\n{}",
            render(&d, NAME, qloop::DEMO_SPEC)
        ))
    })?;
    create_dir(out)?;
    let check = qloop::report::check_report(&plan, NAME);
    print!("{check}");
    let files = [
        (NAME, qloop::DEMO_SPEC.to_string()),
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
    let r = sim(&SimArgs {
        plan: &plan,
        plant: "turning",
        scenario: "depth-steps",
        out: &out.join("sim"),
        substeps: 20,
        nominal: None,
    })?;
    print_run(&r);
    if !r.metrics.fixed.stable() {
        return Err(CliError::failed("the demo's closed loop is unstable"));
    }
    // The proof step: every obligation, with the verdict cache (an unchanged spec re-proves
    // instantly).
    println!();
    if !Solver::ALL.iter().any(|s| s.available()) {
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
    let report = prove_with_progress(&plan, &cfg, None);
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
        Err(CliError::Failed(None))
    }
}
