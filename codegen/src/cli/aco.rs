//! `qloop aco`: RCB₂ (Ivester & Danai) above the loops, on the host. See the crate `qloop-aco`.

use super::args::{AcoArgs, AcoStudy};
use super::demo::builtin;
use super::error::{CliError, CliResult};
use super::files::{create_dir, write_atomic};
use qloop_aco::rcb::{self, Policy, Scenario};
use qloop_aco::{bendix, cascade, figures, report, study};
use qloop_plant::plot;

/// Most cycles or runs accepted: the default study (5 policies × 100 runs × 20 cycles) takes
/// 0.2 s; at these bounds (5 × 1,000 × 200, all kept for the plots) 21 s and 118 MB
/// (measured, 2 cores), so a typo cannot run for hours.
const MAX_CYCLES: usize = 200;
const MAX_RUNS: usize = 1000;

fn check(o: &AcoArgs) -> CliResult {
    if !(0.0..=1.0).contains(&o.c) {
        return Err(CliError::Input {
            msg: format!("--c {} is outside [0, 1]", o.c),
            help: Some("c is the confidence level of Ivester & Danai, eq. 13: 0 never tightens, 1 removes the whole estimated slack in one cycle".into()),
        });
    }
    for (name, v, max) in [
        ("--cycles", o.cycles, MAX_CYCLES),
        ("--study-cycles", o.study_cycles, MAX_CYCLES),
    ] {
        if v == 0 || v > max {
            return Err(CliError::Input {
                msg: format!("{name} {v} is outside 1..={max}"),
                help: None,
            });
        }
    }
    if o.runs > MAX_RUNS {
        return Err(CliError::Input {
            msg: format!("--runs {} is more than {MAX_RUNS}", o.runs),
            help: Some("0 skips the study".into()),
        });
    }
    if o.seed.checked_add(o.runs as u64).is_none() {
        return Err(CliError::Input {
            msg: format!(
                "--seed {} leaves no room for {} study runs (seeds seed, seed+1, ...)",
                o.seed, o.runs
            ),
            help: Some(format!(
                "use a seed of at most {}",
                u64::MAX - o.runs as u64
            )),
        });
    }
    Ok(())
}

fn write_figure(fig: &plot::Figure, out: &std::path::Path, stem: &str) -> CliResult {
    plot::write_svg(fig, &out.join(format!("{stem}.svg"))).map_err(CliError::Output)?;
    plot::write_png(fig, &out.join(format!("{stem}.png"))).map_err(CliError::Output)
}

/// Runs `qloop aco`.
pub fn run(o: &AcoArgs) -> CliResult {
    check(o)?;
    create_dir(&o.out)?;
    match o.study {
        AcoStudy::Bendix => return run_bendix(o),
        AcoStudy::Cascade => return run_cascade(o),
        AcoStudy::Rcb2 => {}
    }
    let mut sc = Scenario::paper(Policy::rcb2(o.c), o.seed);
    sc.cycles = o.cycles;
    let run = rcb::run(&sc);
    let mut text = report::run_table(&run);
    write_atomic(&o.out.join("rcb2-run.csv"), &report::run_csv(&run))?;
    write_figure(&figures::run_figure(&run), &o.out, "rcb2-run")?;
    if o.runs > 0 {
        let policies = [
            Policy::rcb2(0.1),
            Policy::rcb2(0.5),
            Policy::rcb2(0.9),
            Policy::Nominal { margin: 0.0 },
            Policy::Nominal { margin: 0.1 },
        ];
        let studies: Vec<_> = policies
            .iter()
            .map(|&p| study::study(p, o.runs, o.seed, o.study_cycles))
            .collect();
        text.push('\n');
        text.push_str(&report::study_table(&studies));
        write_atomic(&o.out.join("rcb2-study.csv"), &report::study_csv(&studies))?;
        write_figure(&figures::study_figure(&studies), &o.out, "rcb2-study")?;
    }
    write_atomic(&o.out.join("rcb2.txt"), &text)?;
    print!("{text}");
    println!(
        "wrote {}/rcb2.txt, rcb2-run.{{csv,png,svg}}{}",
        o.out.display(),
        if o.runs > 0 {
            ", rcb2-study.{csv,png,svg}"
        } else {
            ""
        }
    );
    Ok(())
}

/// `qloop aco bendix`: the optimum of the survey's index for three β on the example cut.
fn run_bendix(o: &AcoArgs) -> CliResult {
    let (m, e) = (bendix::EXAMPLE, bendix::EXAMPLE_ECONOMICS);
    let text = report::bendix_table(&m, &e);
    write_atomic(&o.out.join("bendix.txt"), &text)?;
    write_figure(&figures::bendix_figure(&m, &e), &o.out, "bendix")?;
    print!("{text}");
    println!("wrote {}/bendix.{{txt,png,svg}}", o.out.display());
    Ok(())
}

/// `qloop aco cascade`: RCB₂ sets the inner loop's force reference per part; the built-in
/// setpoint spec (the tuned 1981 law with `input fr`) is compiled as `sim` compiles a spec and
/// cuts each part in closed loop.
fn run_cascade(o: &AcoArgs) -> CliResult {
    let name = "koren_masory_setpoint.qloop";
    let plan = builtin(cascade::SETPOINT_SPEC, name)?;
    let compiled = super::jit::compile(&plan)?;
    let mut c = cascade::Cascade::example();
    c.parts = o.cycles;
    c.confidence = [o.c, o.c];
    c.seed = o.seed;
    let make = || compiled.fixed() as Box<dyn qloop_plant::Controller>;
    let run = cascade::run(&c, &make).map_err(CliError::tool)?;
    let text = report::cascade_table(&run);
    write_atomic(&o.out.join(name), cascade::SETPOINT_SPEC)?;
    write_atomic(&o.out.join("cascade.txt"), &text)?;
    write_atomic(&o.out.join("cascade.csv"), &report::cascade_csv(&run))?;
    write_figure(&figures::cascade_figure(&run), &o.out, "cascade")?;
    write_figure(
        &figures::cascade_parts_figure(&run),
        &o.out,
        "cascade-parts",
    )?;
    print!("{text}");
    println!(
        "wrote {}/cascade.{{txt,csv,png,svg}}, cascade-parts.{{png,svg}} and the inner loop's spec {name}",
        o.out.display()
    );
    Ok(())
}
