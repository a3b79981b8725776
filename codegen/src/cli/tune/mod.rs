//! `qloop tune`: picks the values of a spec's `tune` constants.
//!
//! 1. Every combination of the candidates ([`space`]) becomes a spec text, compiled by the
//!    same pipeline; a combination that does not compile (an overflow the range analysis
//!    cannot rule out, say) is dropped with its reason.
//! 2. Each is scored in closed loop ([`score`]): the same draws of plant parameters and
//!    scenarios for all, on every core, with a progress bar, reproducibly from `--seed`.
//! 3. The candidates meeting the goals (every draw stable, worst overshoot and 5 % settling
//!    within `--max-overshoot` and `--max-settling`) are tried fastest first; if none meets
//!    them, the Pareto front by how far it misses ([`pareto`]).
//! 4. A candidate is taken only if every obligation of its spec proves (overflow, initial,
//!    inductive and every `prove` property, with the chosen solvers). One that does not is
//!    reported as refuted and the next is tried.
//! 5. The chosen values are written back into the spec text (`--out`), and the Pareto front
//!    is printed with the reason for the choice.

pub mod pareto;
pub mod score;
pub mod space;

use super::args::Solvers;
use super::error::{CliError, CliResult};
use super::files::{target, write_atomic};
use super::prove::solver_config;
use super::sweep::scenarios;
use pareto::{front, preference, Goals};
use qloop::Diag;
use qloop_plant::catalog;
use rayon::prelude::*;
use score::{Bench, Score};
use std::fmt::Write;
use std::path::Path;
use std::rc::Rc;
use std::time::Instant;

/// `qloop tune` as given on the command line.
pub struct TuneCommand<'a> {
    /// The spec file.
    pub spec: &'a Path,
    /// `--target`.
    pub target: &'a str,
    /// `--plant`.
    pub plant: &'a str,
    /// `--scenario`s (empty: every built-in scenario of the plant).
    pub scenarios: &'a [String],
    /// `--draws` per candidate.
    pub draws: u64,
    /// `--seed`.
    pub seed: u64,
    /// `--jobs`.
    pub jobs: Option<usize>,
    /// `--substeps`.
    pub substeps: usize,
    /// The goals.
    pub goals: Goals,
    /// `--max-proofs`: candidates tried by the prover at most.
    pub max_proofs: usize,
    /// `--solvers`.
    pub solvers: Solvers,
    /// `--out FILE`: the tuned spec.
    pub out: Option<&'a Path>,
    /// `--name`: the tuned controller's name.
    pub name: Option<&'a str>,
    /// `--report FILE`.
    pub report: Option<&'a Path>,
}

/// One candidate: its values and what became of it.
struct Candidate {
    point: Vec<f64>,
    /// The closed-loop score, or why the candidate was dropped.
    score: Result<Score, String>,
    /// `Some(Ok(()))` proved, `Some(Err(why))` not proved (the obligations that failed),
    /// `None` not tried.
    proof: Option<Result<(), String>>,
}

/// Runs the tuner.
pub fn run(c: &TuneCommand) -> CliResult {
    let file = c.spec.display().to_string();
    let src = std::fs::read_to_string(c.spec).map_err(|e| CliError::Unreadable {
        what: "",
        path: file.clone(),
        source: e,
    })?;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(c.goals.overshoot) || !positive(c.goals.settling_s) {
        return Err(CliError::input(
            "--max-overshoot and --max-settling must be positive numbers (percent, seconds)",
        ));
    }
    let t = target(c.target)?;
    let ast = qloop::lang::parse::parse_str(&src).map_err(|d| CliError::spec(&d, &file, &src))?;
    let plan = qloop::compile_str(&src, &t).map_err(|d| CliError::spec(&d, &file, &src))?;
    let tunes = plan.prog.tunes.clone();
    if tunes.is_empty() {
        let d = Diag::new(ast.name.span(), "this spec has no `tune` items: nothing to tune")
            .label("no `tune` item in here")
            .help("mark the constants to tune inside the controller, e.g. `tune C1 in [0.015625, 0.5], pow2;` or `tune K in [0.3, 1.3], step 0.1;`");
        return Err(CliError::spec(&d, &file, &src));
    }
    let n = space::count(&tunes);
    if n > space::MAX_COMBINATIONS {
        let d = Diag::new(
            tunes[0].span,
            format!(
                "the `tune` items give {n} combinations, more than {}",
                space::MAX_COMBINATIONS
            ),
        )
        .help("use coarser steps or fewer candidates: every combination is simulated");
        return Err(CliError::spec(&d, &file, &src));
    }
    let nominal = catalog::plant_named(c.plant).map_err(CliError::input)?;
    let scs = scenarios(c.plant, c.scenarios)?;
    for sc in &scs {
        super::bind::bind(&plan.prog, nominal.as_ref(), sc, None)?;
    }
    let bench = Bench {
        scenarios: &scs,
        draws: c.draws.max(1),
        seed: c.seed,
        substeps: c.substeps.max(1),
    };
    let rename = match c.name {
        Some(name) => {
            let ok = name
                .chars()
                .next()
                .is_some_and(|ch| ch.is_ascii_lowercase())
                && name
                    .chars()
                    .all(|ch| ch.is_ascii_lowercase() || ch.is_ascii_digit() || ch == '_');
            if !ok {
                return Err(CliError::input(format!(
                    "--name `{name}`: a controller name is snake_case (lowercase letters, digits, `_`)"
                )));
            }
            Some((Diag::new(ast.name.span(), "").byte_range(&src), name))
        }
        None => None,
    };

    // 1-2: compile and score every combination.
    let ranges = space::value_ranges(&src, &tunes);
    let points = space::points(&tunes);
    let start = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(c.jobs.unwrap_or(0))
        .build()
        .map_err(|e| CliError::tool(format!("cannot start worker threads: {e}")))?;
    let bar = indicatif::ProgressBar::new(points.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} tune {pos}/{len} candidates [{elapsed} < {eta}] {wide_bar}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    eprintln!(
        "qloop tune: {} candidates × {} draws on the {} plant ({} threads)",
        points.len(),
        bench.draws,
        c.plant,
        pool.current_num_threads()
    );
    let scored: Vec<CliResult<Result<Score, String>>> = pool.install(|| {
        points
            .par_iter()
            .map_init(
                || catalog::plant_named(c.plant).expect("checked above"),
                |plant, p| {
                    let text = space::substitute(&src, &ranges, p, None);
                    let r = match qloop::compile_str(&text, &t) {
                        Err(d) => Ok(Err(d.message.clone())),
                        Ok(plan) => match score::score(Rc::new(plan), &bench, plant.as_ref()) {
                            Ok(s) => Ok(Ok(s)),
                            Err(CliError::Tool(m)) => Err(CliError::Tool(m)),
                            Err(e) => Ok(Err(format!("{e:?}"))),
                        },
                    };
                    bar.inc(1);
                    r
                },
            )
            .collect()
    });
    bar.finish_and_clear();
    let sim_secs = start.elapsed().as_secs_f64();
    let mut cands: Vec<Candidate> = points
        .into_iter()
        .zip(scored)
        .map(|(point, s)| {
            Ok(Candidate {
                point,
                score: s?,
                proof: None,
            })
        })
        .collect::<CliResult<_>>()?;

    // The spec as written, on the same draws: what the tuning is measured against.
    let as_written = score::score(Rc::new(plan.clone()), &bench, nominal.as_ref())?;
    let base: Vec<f64> = tunes
        .iter()
        .map(|t| {
            plan.prog
                .constants
                .iter()
                .find(|k| k.name == t.name)
                .map_or(f64::NAN, |k| k.value)
        })
        .collect();

    // 3-4: prove in order of preference.
    let scores: Vec<Option<&Score>> = cands.iter().map(|c| c.score.as_ref().ok()).collect();
    let changes: Vec<usize> = cands
        .iter()
        .map(|k| {
            k.point
                .iter()
                .zip(&base)
                .filter(|(v, b)| space::written(**v) != **b)
                .count()
        })
        .collect();
    let order = preference(&scores, &c.goals, &changes);
    let mut fr = front(&scores);
    let cfg = solver_config(c.solvers, 300, c.jobs, None, false)?;
    let prove_start = Instant::now();
    let mut chosen = None;
    for &i in order.iter().take(c.max_proofs) {
        let text = space::substitute(&src, &ranges, &cands[i].point, None);
        let plan = qloop::compile_str(&text, &t).map_err(|d| {
            CliError::tool(format!(
                "internal: a scored candidate no longer compiles: {}",
                d.message
            ))
        })?;
        eprintln!(
            "qloop tune: proving candidate {} ...",
            describe(&tunes, &cands[i].point)
        );
        let report = qloop::prove::prove_filtered(&plan, &cfg, None, &mut |_| {});
        cands[i].proof = Some(if report.proved() {
            Ok(())
        } else {
            Err(failures(&report))
        });
        if report.proved() {
            chosen = Some(i);
            break;
        }
    }
    let prove_secs = prove_start.elapsed().as_secs_f64();
    if let Some(i) = chosen {
        if !fr.contains(&i) {
            fr.push(i);
        }
    }

    // 5: the report and the tuned spec.
    let mut text = String::new();
    let _ = writeln!(
        text,
        "qloop tune: {} on the {} plant, scenarios {}; {} candidates × {} draws (seed {}); goals: every draw stable, worst loop overshoot ≤ {:.0}% (after the force first reaches the reference: a depth step's own jump is the plant's), worst 5% settling ≤ {} s",
        plan.prog.name,
        c.plant,
        scs.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", "),
        cands.len(),
        bench.draws,
        c.seed,
        100.0 * c.goals.overshoot,
        c.goals.settling_s
    );
    let dropped = cands.iter().filter(|c| c.score.is_err()).count();
    if dropped > 0 {
        let why = cands
            .iter()
            .find_map(|c| c.score.as_ref().err())
            .cloned()
            .unwrap_or_default();
        let _ = writeln!(
            text,
            "{dropped} candidates do not compile or run (first: {})",
            why.lines().next().unwrap_or("")
        );
    }
    let met = cands
        .iter()
        .filter(|k| k.score.as_ref().is_ok_and(|s| c.goals.met(s)))
        .count();
    let _ = writeln!(text, "{met} candidates meet the goals in closed loop\n");
    table(&mut text, &tunes, &cands, &fr, &base, chosen);
    let written = Candidate {
        point: base.clone(),
        score: Ok(as_written),
        proof: None,
    };
    let _ = writeln!(text, "\nthe spec as written, on the same draws:\n");
    header(&mut text, &tunes);
    row(&mut text, &written, &base, "as written");
    let _ = writeln!(
        text,
        "\nsimulation {sim_secs:.1} s, proofs {prove_secs:.1} s ({} candidates tried)",
        cands.iter().filter(|c| c.proof.is_some()).count()
    );
    let outcome = match chosen {
        None => {
            let _ = writeln!(
                text,
                "\nno candidate proved among the {} tried: nothing written",
                order.len().min(c.max_proofs)
            );
            Err(CliError::failed(
                "qloop tune: no candidate both simulated well and proved",
            ))
        }
        Some(i) => {
            let s = cands[i].score.as_ref().expect("scored");
            let why = if c.goals.met(s) {
                format!(
                    "the fastest (worst rise {:.2} s) of the {met} candidates meeting the goals whose spec proves",
                    s.rise()
                )
            } else {
                format!(
                    "no candidate meets the goals; this one misses them least ({:.2} × the goal) and proves",
                    c.goals.excess(s)
                )
            };
            let _ = writeln!(
                text,
                "\nchosen: {} — {why}",
                describe(&tunes, &cands[i].point)
            );
            for (k, tn) in tunes.iter().enumerate() {
                let (old, new) = (base[k], space::written(cands[i].point[k]));
                if old != new {
                    let _ = writeln!(
                        text,
                        "  {}: {} → {}",
                        tn.name,
                        space::literal(old),
                        space::literal(new)
                    );
                }
            }
            if let Some(out) = c.out {
                let body = space::substitute(&src, &ranges, &cands[i].point, rename);
                let scen: String = c
                    .scenarios
                    .iter()
                    .map(|n| format!(" --scenario {n}"))
                    .collect();
                let header = format!(
                    "// Written by `qloop tune {file} --plant {}{scen} --draws {} --seed {} --max-overshoot {} --max-settling {}`:\n// {}, {why}.\n",
                    c.plant,
                    bench.draws,
                    c.seed,
                    100.0 * c.goals.overshoot,
                    c.goals.settling_s,
                    describe(&tunes, &cands[i].point)
                );
                write_atomic(out, &format!("{header}{body}"))?;
                let _ = writeln!(text, "wrote {}", out.display());
            }
            if c.goals.met(s) {
                Ok(())
            } else {
                Err(CliError::failed(
                    "qloop tune: no candidate meets the goals (see the table)",
                ))
            }
        }
    };
    print!("{text}");
    if let Some(p) = c.report {
        write_atomic(p, &text)?;
    }
    outcome
}

/// `C1 = 0.125, K_LOOP = 0.6`.
fn describe(tunes: &[qloop::ir::Tune], p: &[f64]) -> String {
    tunes
        .iter()
        .zip(p)
        .map(|(t, v)| format!("{} = {}", t.name, space::literal(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The obligations a report does not prove, with their verdicts.
fn failures(report: &qloop::prove::Report) -> String {
    let bad: Vec<String> = report
        .outcomes
        .iter()
        .filter(|o| o.verdict != qloop::prove::Verdict::Proved)
        .map(|o| format!("{} {}", o.ob.label(), o.verdict.name()))
        .collect();
    bad.join("; ")
}

fn fmt_s(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "not settled".into()
    }
}

/// The Pareto front as a Markdown table, fastest rise first; the chosen row marked.
fn table(
    out: &mut String,
    tunes: &[qloop::ir::Tune],
    cands: &[Candidate],
    fr: &[usize],
    base: &[f64],
    chosen: Option<usize>,
) {
    let _ = writeln!(
        out,
        "Pareto front ({} of {} candidates; worst case over the draws):\n",
        fr.len(),
        cands.len()
    );
    header(out, tunes);
    let mut rows: Vec<usize> = fr.to_vec();
    rows.sort_by(|a, b| {
        let r = |i: &usize| cands[*i].score.as_ref().map_or(f64::INFINITY, |s| s.rise());
        r(a).total_cmp(&r(b)).then(a.cmp(b))
    });
    for i in rows {
        let k = &cands[i];
        let proof = match &k.proof {
            None => "not tried".to_string(),
            Some(Ok(())) if Some(i) == chosen => "**proved, chosen**".to_string(),
            Some(Ok(())) => "proved".to_string(),
            Some(Err(e)) => format!("not proved: {e}"),
        };
        row(out, k, base, &proof);
    }
}

/// The table's header for these `tune` items.
fn header(out: &mut String, tunes: &[qloop::ir::Tune]) {
    let names: Vec<&str> = tunes.iter().map(|t| t.name.as_str()).collect();
    let _ = writeln!(
        out,
        "| {} | stable | loop overshoot | peak | settling ±5% (s) | rise ±10% (s) | ss error | damping ζ | proof |",
        names.join(" | ")
    );
    let _ = writeln!(
        out,
        "|{}---|---|---|---|---|---|---|---|",
        "---|".repeat(names.len())
    );
}

/// One candidate's row; values equal to the spec's marked `(spec)`.
fn row(out: &mut String, k: &Candidate, base: &[f64], proof: &str) {
    let Ok(s) = &k.score else { return };
    let vals: Vec<String> = k
        .point
        .iter()
        .zip(base)
        .map(|(v, b)| {
            let w = space::literal(*v);
            if space::written(*v) == *b {
                format!("{w} (spec)")
            } else {
                w
            }
        })
        .collect();
    let _ = writeln!(
        out,
        "| {} | {}/{} | {:.1}% | {:.0}% | {} | {} | {:.4} | {:.2} | {proof} |",
        vals.join(" | "),
        s.env.draws - s.env.unstable,
        s.env.draws,
        100.0 * s.overshoot(),
        100.0 * s.peak(),
        fmt_s(s.settling()),
        fmt_s(s.rise()),
        s.ss_error(),
        s.damping()
    );
}
