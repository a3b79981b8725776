//! Text and CSV reports of RCB₂ runs and studies.

use crate::paper::TABLE2;
use crate::rcb::Run;
use crate::study::{Study, CONVERGED};
use crate::turning::LIMITS;
use std::fmt::Write;

/// One run as Ivester & Danai's Table 2, with the paper's rows beside it (where it has one).
pub fn run_table(run: &Run) -> String {
    let sc = &run.scenario;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "RCB2 on the reconstructed turning model of Ivester & Danai: {}, seed {}, bias ±{:.0} %, noise [{}, {}]",
        sc.policy.name(),
        sc.seed,
        100.0 * sc.bias,
        1.0 - sc.noise,
        1.0 + sc.noise
    );
    let _ = writeln!(
        s,
        "measured = true model x noise; limits: power {} kW, roughness {} um",
        LIMITS[0], LIMITS[1]
    );
    let _ = writeln!(
        s,
        "{:>5} | {:>7} {:>6} {:>6} {:>6} {:>7} {:>6} {:>6} | {:>7} {:>6} {:>5} {:>5} {:>6}",
        "", "qloop", "", "P", "Ra", "t", "b1", "b2", "paper", "Tab.2", "g_m1", "g_m2", "t"
    );
    let _ = writeln!(
        s,
        "{:>5} | {:>7} {:>6} {:>6} {:>6} {:>7} {:>6} {:>6} | {:>7} {:>6} {:>5} {:>5} {:>6}",
        "cycle", "v", "f", "kW", "um", "s", "", "", "v", "f", "", "", "s"
    );
    for c in &run.cycles {
        let b = c
            .buffers
            .map(|b| format!("{:>6.2} {:>6.2}", b[0], b[1]))
            .unwrap_or_else(|| format!("{:>6} {:>6}", "-", "-"));
        let flag = if c.excess() > 0.0 { "!" } else { " " };
        let _ = write!(
            s,
            "{:>5} | {:>7.2} {:>6.3} {:>6.2} {:>6.2} {:>7.1} {b} |",
            c.index, c.settings.v, c.settings.f, c.measured[0], c.measured[1], c.time
        );
        match TABLE2.get(c.index - 1) {
            Some(p) => {
                let _ = writeln!(
                    s,
                    " {:>7.2} {:>6.3} {:>5.2} {:>5.2} {:>6.1}{flag}",
                    p.v, p.f, p.power, p.roughness, p.time
                );
            }
            None => {
                let _ = writeln!(s, "{:>34}{flag}", "");
            }
        }
    }
    match (run.robust_optimum(), run.optimum()) {
        (Ok(r), Ok(o)) => {
            let _ = writeln!(
                s,
                "true model's optimum: {:.1} s at v = {:.2}, f = {:.3} with every part in its limits for any noise draw; {:.1} s at v = {:.2}, f = {:.3} without noise",
                r.value, r.x[0], r.x[1], o.value, o.x[0], o.x[1]
            );
        }
        _ => {
            let _ = writeln!(s, "true model's optimum: no solution");
        }
    }
    outcomes(
        &mut s,
        "cycle",
        "the next cycle went back to the first settings",
        run.cycles
            .iter()
            .map(|c| (c.index, c.excess(), c.nlp_error.as_deref())),
    );
    s
}

/// The closing lines of a run's table: which parts were out of specification and by how much,
/// and which re-optimisations had no solution. `items` are (number, excess, NLP error).
fn outcomes<'a>(
    s: &mut String,
    noun: &str,
    fallback: &str,
    items: impl Iterator<Item = (usize, f64, Option<&'a str>)> + Clone,
) {
    let bad: Vec<String> = items
        .clone()
        .filter(|(_, e, _)| *e > 0.0)
        .map(|(i, e, _)| format!("{noun} {i} by {e:.3}"))
        .collect();
    if bad.is_empty() {
        let _ = writeln!(s, "no part out of specification");
    } else {
        let _ = writeln!(s, "out of specification (!): {}", bad.join(", "));
    }
    for (i, _, err) in items {
        if let Some(err) = err {
            let _ = writeln!(s, "{noun} {i}: no solution, {fallback}: {err}");
        }
    }
}

/// One run as CSV, one line per cycle, with Ivester & Danai's Table 2 columns where it has the row.
pub fn run_csv(run: &Run) -> String {
    let mut s = String::from(
        "cycle,v_m_per_min,f_mm_per_rev,power_kw,roughness_um,power_true_kw,roughness_true_um,time_s,buffer_power,buffer_roughness,paper_v,paper_f,paper_g_m1,paper_g_m2,paper_time_s\n",
    );
    for c in &run.cycles {
        let (b0, b1) = c
            .buffers
            .map(|b| (format!("{:.6}", b[0]), format!("{:.6}", b[1])))
            .unwrap_or_default();
        let paper = TABLE2
            .get(c.index - 1)
            .map(|p| format!("{},{},{},{},{}", p.v, p.f, p.power, p.roughness, p.time))
            .unwrap_or_else(|| ",,,,".into());
        let _ = writeln!(
            s,
            "{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{b0},{b1},{paper}",
            c.index,
            c.settings.v,
            c.settings.f,
            c.measured[0],
            c.measured[1],
            c.truth[0],
            c.truth[1],
            c.time
        );
    }
    s
}

/// The studies side by side: convergence against violations (Ivester & Danai, Figs. 5 and 6).
pub fn study_table(studies: &[Study]) -> String {
    let mut s = String::new();
    let (runs, cycles) = studies
        .first()
        .map_or((0, 0), |st| (st.runs.len(), st.cycles));
    let _ = writeln!(
        s,
        "{runs} seeded runs of {cycles} cycles each (same seeds, so the same true model per seed, for every policy)"
    );
    let _ = writeln!(
        s,
        "within {:.0} %: a cycle's time within {:.0} % of the true model's optimum with every part in its limits for any noise draw\n(a policy that puts parts out of specification can get there, or below, by violating)",
        100.0 * CONVERGED,
        100.0 * CONVERGED
    );
    let _ = writeln!(
        s,
        "{:<22} {:>9} {:>13} {:>7} {:>10} {:>9} {:>9} {:>12}",
        "policy",
        &format!("within {:.0}%", 100.0 * CONVERGED),
        "median cycles",
        "out of",
        "runs with",
        "worst",
        "gap (last",
        "conservative"
    );
    let _ = writeln!(
        s,
        "{:<22} {:>9} {:>13} {:>7} {:>10} {:>9} {:>9} {:>12}",
        "", "(runs)", "to get there", "spec", "violation", "excess", "3 cycles)", "runs"
    );
    for st in studies {
        let median = st.median_cycles();
        let median = if median > st.cycles as f64 {
            format!("> {}", st.cycles)
        } else {
            format!("{median:.1}")
        };
        let _ = writeln!(
            s,
            "{:<22} {:>9} {:>13} {:>7} {:>10} {:>9.3} {:>8.1}% {:>12}",
            st.policy.name(),
            st.converged_runs(),
            median,
            st.violations(),
            st.violating_runs(),
            st.worst_excess(),
            100.0 * st.median_gap_robust(),
            st.conservative_runs()
        );
    }
    let failures: usize = studies.iter().map(|s| s.nlp_failures()).sum();
    if failures > 0 {
        let _ = writeln!(
            s,
            "{failures} cycles had no solution for the next program and went back to the first settings"
        );
    }
    s
}

/// Every run of every study as CSV, one line per run.
pub fn study_csv(studies: &[Study]) -> String {
    let mut s = String::from(
        "policy,seed,violations,worst_excess,converged_at,gap_robust,gap_optimum,nlp_failures\n",
    );
    for st in studies {
        for r in &st.summaries {
            let _ = writeln!(
                s,
                "\"{}\",{},{},{:.6},{},{:.6},{:.6},{}",
                st.policy.name(),
                r.seed,
                r.violations,
                r.worst_excess,
                r.converged_at.map(|c| c.to_string()).unwrap_or_default(),
                r.gap_robust,
                r.gap_optimum,
                r.nlp_failures
            );
        }
    }
    s
}

/// The Bendix optimiser's answers for β = 0, 0.5 and 1 on a milling model (Koren's survey, eqs. 1–3).
pub fn bendix_table(m: &crate::bendix::Milling, e: &crate::bendix::Economics) -> String {
    use crate::bendix::{mrr, optimise};
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Bendix ACO (Koren's survey, eqs. 1-3): phi = MRR / [C1 + (C1 t1 + C2 beta) TWR/W0], TWR = K1 MRR + K2 theta (steady torque)"
    );
    let _ = writeln!(
        s,
        "cut {} in x {} in, {} teeth; limits: torque {} lbf*in, temperature {} F, vibration {} in, speed {}-{} rpm, feed <= {} in/min",
        m.width, m.depth, m.teeth, m.torque_max, m.temp_max, m.vib_max, m.speed.0, m.speed.1, m.feed_max
    );
    let _ = writeln!(
        s,
        "C1 = {} $/min, C2 = {} $, t1 = {} min, W0 = {} in, K1 = {:e} in/in^3, K2 = {:e} in/min/F",
        e.c1, e.c2, e.t1, e.w0, e.k1, e.k2
    );
    let _ = writeln!(
        s,
        "{:>5} {:>10} {:>9} {:>10} {:>9} {:>8} {:>9} {:>10}  active",
        "beta", "V in/min", "N rpm", "MRR in3/m", "T lbf*in", "theta F", "life min", "phi"
    );
    for beta in [0.0, 0.5, 1.0] {
        match optimise(m, e, beta) {
            Ok(o) => {
                let r = mrr(m.width, m.depth, o.feed);
                let theta = m.temperature(o.feed, o.speed);
                let life = e.w0 / crate::bendix::twr(e, r, theta, 0.0);
                let _ = writeln!(
                    s,
                    "{beta:>5} {:>10.2} {:>9.1} {r:>10.2} {:>9.1} {theta:>8.0} {life:>9.1} {:>10.4}  {}",
                    o.feed,
                    o.speed,
                    m.torque(o.feed, o.speed),
                    o.index,
                    o.active.join(", ")
                );
            }
            Err(err) => {
                let _ = writeln!(s, "{beta:>5} no optimum: {err}");
            }
        }
    }
    s
}

/// The cascade's parts: F_r chosen by RCB₂, what the closed loop measured, and its time
/// beside the static model's.
pub fn cascade_table(run: &crate::cascade::CascadeRun) -> String {
    use crate::cascade::LIMITS;
    let c = &run.cascade;
    let mut s = String::new();
    let sections: Vec<String> = c
        .part
        .sections
        .iter()
        .map(|(l, a)| format!("{l} mm at {a} mm"))
        .collect();
    let _ = writeln!(
        s,
        "RCB2 (c = {} for the peak force, {} for the roughness) sets the force reference F_r of the generated Koren-Masory loop per part; each part is cut in closed loop on the turning plant",
        c.confidence[0], c.confidence[1]
    );
    let _ = writeln!(
        s,
        "part: {}, {} rpm, {} s handling; plant K_s {:.4} (static model {:.4}); seed {}",
        sections.join(", "),
        c.part.spindle_rpm,
        c.part.handling_s,
        run.true_ks,
        crate::cascade::StaticModel::nominal().ks,
        c.seed
    );
    let _ = writeln!(
        s,
        "limits: peak force {} kN, roughness {} um; cycle time from the closed loop, beside the static model's prediction",
        LIMITS[0], LIMITS[1]
    );
    let _ = writeln!(
        s,
        "{:>5} {:>8} {:>10} {:>9} {:>11} {:>11} {:>7} {:>7}",
        "part", "F_r kN", "peak kN", "Ra um", "t loop s", "t static s", "b1", "b2"
    );
    for p in &run.parts {
        let flag = if p.excess() > 0.0 { " !" } else { "" };
        let unfinished = if p.finished { "" } else { " (not finished)" };
        let _ = writeln!(
            s,
            "{:>5} {:>8.3} {:>10.3} {:>9.2} {:>11.1} {:>11.1} {:>7.3} {:>7.3}{flag}{unfinished}",
            p.index,
            p.fr,
            p.measured[0],
            p.measured[1],
            p.time,
            p.time_static,
            p.buffers[0],
            p.buffers[1]
        );
    }
    outcomes(
        &mut s,
        "part",
        "the next part went back to the first F_r",
        run.parts
            .iter()
            .map(|p| (p.index, p.excess(), p.nlp_error.as_deref())),
    );
    s
}

/// The cascade as CSV, one line per part.
pub fn cascade_csv(run: &crate::cascade::CascadeRun) -> String {
    let mut s = String::from(
        "part,fr_kn,peak_force_kn,roughness_um,cycle_time_s,finished,static_time_s,buffer_force,buffer_roughness\n",
    );
    for p in &run.parts {
        let _ = writeln!(
            s,
            "{},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6},{:.6}",
            p.index,
            p.fr,
            p.measured[0],
            p.measured[1],
            p.time,
            p.finished,
            p.time_static,
            p.buffers[0],
            p.buffers[1]
        );
    }
    s
}
