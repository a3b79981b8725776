//! `qloop demo`: check, gen, a closed-loop simulation and prove on the built-in Koren–Masory
//! (1981) spec, and the same controller as `qloop tune` tuned it, run on the same scenario
//! and drawn in one figure; everything written into one directory.

use super::args::Solvers;
use super::error::{render, CliError, CliResult};
use super::files::{create_dir, write_atomic};
use super::prove::{prove_with_progress, solver_config};
use super::sim::{print_run, sim, verdict, SimArgs, SimResult};
use qloop::prove::solver::Solver;
use qloop::{Plan, Target};
use qloop_plant::plot::{self, Figure, Line, Panel, Series};
use std::fmt::Write;
use std::path::Path;

/// The demo spec's file name.
const NAME: &str = "koren_masory_1981.qloop";
/// The tuned spec's file name.
const TUNED: &str = "koren_masory_tuned.qloop";

/// A built-in spec's plan; it always compiles, so a failure is qloop's bug.
pub(crate) fn builtin(src: &str, name: &str) -> CliResult<Plan> {
    qloop::compile_str(src, &Target::default()).map_err(|d| {
        CliError::tool(format!(
            "internal: the built-in spec {name} does not compile:\n{}",
            render(&d, name, src)
        ))
    })
}

/// Runs the demo into `out`; fails if a loop is unstable or an obligation is not proved.
pub fn run(out: &Path) -> CliResult {
    let plan = builtin(qloop::DEMO_SPEC, NAME)?;
    let tuned = builtin(qloop::DEMO_TUNED_SPEC, TUNED)?;
    create_dir(out)?;
    let check = qloop::report::check_report(&plan, NAME);
    print!("{check}");
    let files = [
        (NAME, qloop::DEMO_SPEC.to_string()),
        ("check.txt", check),
        ("koren_masory_1981.rs", qloop::gen_rust(&plan)),
        ("koren_masory_1981_ref.rs", qloop::gen_reference(&plan)),
        (TUNED, qloop::DEMO_TUNED_SPEC.to_string()),
        ("koren_masory_tuned.rs", qloop::gen_rust(&tuned)),
    ];
    println!();
    for (f, text) in &files {
        let p = out.join(f);
        write_atomic(&p, text)?;
        println!("wrote {}", p.display());
    }
    // The closed-loop step: the compiled controller on the turning plant, Koren & Masory (1981), Fig. 5, with
    // the paper's gains and with the tuned ones.
    println!();
    let run = |plan: &Plan, dir: &str| {
        sim(&SimArgs {
            plan,
            plant: "turning",
            scenario: "depth-steps",
            out: &out.join(dir),
            substeps: 20,
            nominal: None,
        })
    };
    let r = run(&plan, "sim")?;
    print_run(&r);
    println!();
    let t = run(&tuned, "sim-tuned")?;
    print_run(&t);
    println!();
    let (fig, text) = comparison(&r, &t);
    plot::write_svg(&fig, &out.join("paper-vs-tuned.svg")).map_err(CliError::Output)?;
    plot::write_png(&fig, &out.join("paper-vs-tuned.png")).map_err(CliError::Output)?;
    let p = out.join("paper-vs-tuned.txt");
    write_atomic(&p, &text)?;
    print!("{text}");
    println!(
        "wrote {}, {} and {}",
        out.join("paper-vs-tuned.svg").display(),
        out.join("paper-vs-tuned.png").display(),
        p.display()
    );
    if !r.metrics.fixed.stable() || !t.metrics.fixed.stable() {
        return Err(CliError::failed("a closed loop of the demo is unstable"));
    }
    // The proof step: every obligation of both specs, with the verdict cache (an unchanged
    // spec re-proves instantly).
    println!();
    if !Solver::ALL.iter().any(|s| s.available()) {
        println!("skipping the proofs: no SMT solver installed (apt-get install z3 cvc5)");
        return Ok(());
    }
    let cfg = solver_config(Solvers::Both, 300, None, None, false)?;
    let mut proved = true;
    for (p, stem) in [(&plan, "prove"), (&tuned, "prove-tuned")] {
        println!(
            "proving every obligation of `{}` with {} (first run: a few minutes; then cached) ...",
            p.prog.name,
            cfg.solvers
                .iter()
                .map(|s| s.name())
                .collect::<Vec<_>>()
                .join(" and ")
        );
        let report = prove_with_progress(p, &cfg, None);
        let table = report.table(p);
        print!("{table}");
        for (f, text) in [
            (format!("{stem}.txt"), table),
            (format!("{stem}.json"), report.json()),
        ] {
            let path = out.join(f);
            write_atomic(&path, &text)?;
            println!("wrote {}", path.display());
        }
        proved &= report.proved();
    }
    if proved {
        Ok(())
    } else {
        Err(CliError::Failed(None))
    }
}

/// The paper's tuning against the tuned one on the same run: force, feed and depth in one
/// figure (fixed-point loops), and a table of each segment's peak, loop overshoot, rise and
/// settling time.
pub fn comparison(paper: &SimResult, tuned: &SimResult) -> (Figure, String) {
    let col = |r: &SimResult, c: &str| r.trace.col(c).unwrap_or_default();
    let t = col(paper, "t");
    let design = |r: &SimResult, c: &str, label: &str, i: usize| Series {
        label: label.to_string(),
        y: col(r, c),
        line: Line::Design(i),
    };
    let fr: Vec<f64> = t.iter().map(|_| 1.5).collect();
    let fig = Figure {
        title: "Koren–Masory (1981) on the turning plant, depth steps: paper tuning (K = 1.25) against qloop tune (K = 0.2)".into(),
        t,
        x_label: plot::TIME_AXIS.into(),
        panels: vec![
            Panel {
                title: "fc (kN)".into(),
                series: vec![
                    design(paper, "fc", "paper tuning", 0),
                    design(tuned, "fc", "tuned", 1),
                    Series {
                        label: "reference F_r".into(),
                        y: fr,
                        line: Line::Setpoint,
                    },
                ],
            },
            Panel {
                title: "feed (mm/s)".into(),
                series: vec![
                    design(paper, "feed", "paper tuning", 0),
                    design(tuned, "feed", "tuned", 1),
                ],
            },
            Panel {
                title: "a_mm".into(),
                series: vec![Series {
                    label: "depth of cut (scenario)".into(),
                    y: col(paper, "a_mm"),
                    line: Line::Channel,
                }],
            },
        ],
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "paper tuning against tuned, turning plant, depth steps (fixed-point loops):\n\n| segment (s) | design | peak over ref. | loop overshoot | rise ±10% | settling ±5% | ringing after 3 s |\n|---|---|---|---|---|---|---|"
    );
    for (p, q) in paper
        .metrics
        .fixed
        .segments
        .iter()
        .zip(&tuned.metrics.fixed.segments)
    {
        if !p.cutting {
            continue;
        }
        for (name, seg) in [("paper", p), ("tuned", q)] {
            let _ = writeln!(
                s,
                "| {:.0}–{:.0} | {name} | {:.0}% | {:.1}% | {} | {} | {} |",
                seg.span.0,
                seg.span.1,
                100.0 * seg.overshoot,
                100.0 * seg.loop_overshoot,
                seg.rise_s.map_or("never".into(), |t| format!("{t:.2} s")),
                seg.settling_s
                    .map_or("not settled".into(), |t| format!("{t:.2} s")),
                seg.ringing
                    .map_or("no".into(), |r| format!("yes, ±{:.0}%", 100.0 * r)),
            );
        }
    }
    let _ = writeln!(
        s,
        "\npaper: {}\ntuned: {}",
        verdict(&paper.metrics.fixed),
        verdict(&tuned.metrics.fixed)
    );
    (fig, s)
}
