//! Ivester & Danai's findings (Ivester & Danai), reproduced on the reconstructed turning model over 100
//! seeded runs with 10 % model bias and noise in [0.9, 1.1] (Ivester & Danai's simulation section).
//!
//! Each test prints what it measured (`cargo test -p qloop-aco --test integration paper_rcb2:: --
//! --nocapture`); `qloop aco` prints the same study.

use qloop_aco::paper::TABLE2;
use qloop_aco::rcb::Policy;
use qloop_aco::study::{study, Study};

const RUNS: usize = 100;
const FIRST_SEED: u64 = 1;

fn report(s: &Study) {
    println!(
        "{:<22} converged {:>3}/{} median cycles {:>4.1}, parts out of spec {:>4} in {:>3} runs (worst {:.3}), median gap {:.1} % (robust) {:.1} % (noise-free), conservative {}",
        s.policy.name(),
        s.converged_runs(),
        s.runs.len(),
        s.median_cycles(),
        s.violations(),
        s.violating_runs(),
        s.worst_excess(),
        100.0 * s.median_gap_robust(),
        100.0 * s.median_gap_optimum(),
        s.conservative_runs()
    );
}

/// Ivester & Danai: with c = 0.5 "the control variables move towards the optimal point from cycle to cycle
/// without violating the constraints", and Table 2 reaches its final time at cycle 6. Over 100
/// runs of ten cycles: no part out of specification; a median of at most six cycles before a
/// cycle first comes within 5 % of the true model's noise-robust optimum; and a median gap of
/// the last three cycles within 5 % ("a few per cent").
///
/// Not every run gets there or stays there. As measured: 97 runs first come within 5 % by
/// cycle 6 and 99 by cycle 10 (the test asks for 95); 15 runs end more than 5 % above, seed 76
/// never comes within it (7.9 % above over its last three cycles). RCB₂ settles with the true
/// value about 17 % under each limit where the noise needs 10 % (`rcb.rs`, "Where it
/// settles"), and on a true model with a large no-load power that margin costs more than 5 %.
#[test]
fn c_half_converges_in_about_six_cycles_without_violation() {
    let s = study(Policy::rcb2(0.5), RUNS, FIRST_SEED, 10);
    report(&s);
    assert_eq!(s.violations(), 0, "parts out of specification");
    assert!(s.converged_runs() >= 95, "{}", s.converged_runs());
    assert!(s.median_gap_robust() <= 0.05, "{}", s.median_gap_robust());
    assert!(s.median_cycles() <= 6.0, "{}", s.median_cycles());
    assert_eq!(s.nlp_failures(), 0);
}

/// Table 2's cycle time, relative to its first cycle, against the median over the runs: the
/// paper's one run falls to 0.79, 0.74, 0.71, 0.70, 0.69 of the first cycle's time by
/// cycles 2–6. The reconstructed model is fitted to the first cycle and to the point where
/// RCB₂ settles, not to the path between; this checks the path, within 5 percentage points.
#[test]
fn time_falls_like_table_2() {
    let s = study(Policy::rcb2(0.5), RUNS, FIRST_SEED, 10);
    let median = s.median_times();
    let first = median[0];
    for (j, p) in TABLE2.iter().enumerate() {
        let ours = median[j] / first;
        let paper = p.time / TABLE2[0].time;
        println!(
            "cycle {:>2}: median {:.1} s ({ours:.3} of cycle 1), Ivester & Danai {:.1} s ({paper:.3})",
            j + 1,
            median[j],
            p.time
        );
        assert!(
            (ours - paper).abs() <= 0.05,
            "cycle {}: {ours} vs {paper}",
            j + 1
        );
    }
}

/// Ivester & Danai, Figs. 5 and 6: a higher confidence level converges faster but risks violations; "the
/// differences in cycle times were practically insignificant after the first few cycles".
/// Over the same 100 runs of 20 cycles: the median cycles to converge fall from c = 0.1 to 0.5
/// to 0.9; c = 0.9 puts parts out of specification where c = 0.1 and 0.5 put none; the median
/// last-cycle gaps of 0.5 and 0.9 differ by less than one percentage point.
#[test]
fn confidence_trades_convergence_for_violations() {
    let [low, mid, high] = [0.1, 0.5, 0.9].map(|c| study(Policy::rcb2(c), RUNS, FIRST_SEED, 20));
    for s in [&low, &mid, &high] {
        report(s);
    }
    assert!(low.median_cycles() > mid.median_cycles());
    assert!(mid.median_cycles() > high.median_cycles());
    assert_eq!(low.violations(), 0);
    assert_eq!(mid.violations(), 0);
    assert!(high.violations() > 0);
    assert!((mid.median_gap_robust() - high.median_gap_robust()).abs() < 0.01);
}

/// The baseline without buffers. Aimed at the limits, the nominal optimum puts parts out of
/// specification in nearly every run (bias and noise). With a 10 % margin under each limit
/// for the noise, the bias alone still does in a large share of runs (60 of 100 as measured).
/// RCB₂ with c = 0.5 on the same seeds, so on the same true models, puts none out.
///
/// Where the margined nominal optimum does stay in specification (40 runs), it is mostly
/// *faster* than RCB₂ (checked: in more than half of those runs): the bias happened to favour
/// it, and RCB₂'s margin is wider than the noise needs. The baseline does not stay
/// conservative here: it violates.
#[test]
fn nominal_optimiser_violates_under_bias() {
    let at_limits = study(Policy::Nominal { margin: 0.0 }, RUNS, FIRST_SEED, 10);
    let margin = study(Policy::Nominal { margin: 0.1 }, RUNS, FIRST_SEED, 10);
    report(&at_limits);
    report(&margin);
    assert!(
        at_limits.violating_runs() >= 90,
        "{}",
        at_limits.violating_runs()
    );
    assert!(margin.violating_runs() >= 25, "{}", margin.violating_runs());
    let rcb = study(Policy::rcb2(0.5), RUNS, FIRST_SEED, 10);
    let safe: Vec<_> = margin
        .summaries
        .iter()
        .zip(&rcb.summaries)
        .filter(|(n, _)| n.violations == 0)
        .collect();
    let slower = safe
        .iter()
        .filter(|(n, r)| n.gap_robust > r.gap_robust)
        .count();
    println!(
        "margined nominal optimum in specification in {} runs; slower than RCB2 in {slower} of them",
        safe.len()
    );
    assert!(2 * slower < safe.len(), "{slower} of {}", safe.len());
    assert_eq!(rcb.violations(), 0);
}
