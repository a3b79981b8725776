//! Trust in the SMT encoding: the bit-precise QF_BV model of each seed controller, evaluated
//! by z3 on concrete inputs and states, agrees bit for bit with the plan interpreter (which
//! shares no code with the encoder) on every value the step computes, for random and boundary
//! cases, including input bits outside the declared ranges.

use qloop::interp::step_fixed_trace;
use qloop::ir::{SigId, SigKind};
use qloop::prove::smt::{encode_step, input_var, lit, pre_var, vname};
use qloop::prove::solver::{run_all, Answer, Config, Query, Solver};
use qloop::Plan;
use qloop_tests::plan;
use std::fmt::Write;

/// Raw test cases: for each input and state, boundary and random values.
fn cases(p: &Plan, n_random: usize) -> Vec<Vec<i128>> {
    let ids: Vec<SigId> = (0..p.prog.signals.len())
        .map(SigId)
        .filter(|id| matches!(p.prog.sig(*id).kind, SigKind::Input | SigKind::State))
        .collect();
    let span = |id: SigId| -> (i128, i128) {
        let q = p.format(id);
        match p.prog.sig(id).kind {
            SigKind::State => p.raw_bounds(id).unwrap_or((q.ty.min(), q.ty.max())),
            _ => (q.ty.min(), q.ty.max()), // any input bits: step clamps them
        }
    };
    let mut out = Vec::new();
    for corner in 0..4 {
        let mut v = vec![0i128; p.prog.signals.len()];
        for (k, id) in ids.iter().enumerate() {
            let (lo, hi) = span(*id);
            v[id.0] = if (corner >> (k % 2)) & 1 == 0 { lo } else { hi };
        }
        out.push(v);
    }
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..n_random {
        let mut v = vec![0i128; p.prog.signals.len()];
        for id in &ids {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let (lo, hi) = span(*id);
            v[id.0] = lo + (seed as i128).rem_euclid(hi - lo + 1);
        }
        out.push(v);
    }
    out
}

fn differential(stem: &str) {
    assert!(Solver::Z3.available(), "z3 must be installed");
    let p = plan(stem);
    let enc = encode_step(&p);
    let bv: Vec<usize> = (0..p.vals.len()).filter(|i| !p.vals[*i].boolean).collect();
    let cases = cases(&p, 24);
    let queries: Vec<Query> = cases
        .iter()
        .map(|v| {
            let mut script = format!("(set-logic QF_BV)\n{}", enc.text);
            for (i, s) in p.prog.signals.iter().enumerate() {
                let id = SigId(i);
                let w = p.format(id).ty.bits;
                let var = match s.kind {
                    SigKind::Input => input_var(&p.prog, id),
                    SigKind::State => pre_var(&p.prog, id),
                    _ => continue,
                };
                let _ = writeln!(script, "(assert (= {var} {}))", lit(v[i], w));
            }
            Query {
                script,
                want: bv
                    .iter()
                    .map(|i| vname(qloop::lower::lir::ValId(*i)))
                    .collect(),
            }
        })
        .collect();
    let cfg = Config {
        solvers: vec![Solver::Z3],
        timeout_ms: 30_000,
        cache_dir: None,
        jobs: 2,
    };
    let runs = run_all(&queries, &cfg, &mut |_, _| {});
    for (case, run) in cases.iter().zip(runs) {
        let Answer::Sat(model) = &run[0].answer else {
            panic!(
                "{stem}: z3 did not evaluate the encoding: {:?}",
                run[0].answer
            );
        };
        let mut vars = case.clone();
        let trace =
            step_fixed_trace(&p, &mut vars).expect("in-range states never violate the analysis");
        let mut compared = 0;
        for (name, bits, width) in model {
            let i: usize = name[1..].parse().unwrap();
            let Some(want) = trace[i] else { continue }; // branch not taken
            let ty = p.vals[i].ty;
            let got = if ty.signed && (bits >> (width - 1)) & 1 == 1 {
                *bits as i128 - (1i128 << width)
            } else {
                *bits as i128
            };
            assert_eq!(
                got, want,
                "{stem}: value {name} ({:?}) differs on case {case:?}",
                p.vals[i].op
            );
            compared += 1;
        }
        assert!(compared > 10, "{stem}: too few values compared");
    }
}

#[test]
fn koren_masory_1981_encoding_matches_interpreter() {
    differential("koren_masory_1981");
}

#[test]
fn acc_fixed_gain_encoding_matches_interpreter() {
    differential("acc_fixed_gain");
}

#[test]
fn acc_fixed_gain_proves() {
    let p = plan("acc_fixed_gain");
    let cfg = Config {
        solvers: Solver::ALL.to_vec(),
        timeout_ms: 60_000,
        cache_dir: None,
        jobs: 2,
    };
    let report = qloop::prove::prove(&p, &cfg, &mut |_, _| {});
    assert!(report.proved(), "{}", report.table(&p));
    // Both solvers agree on every obligation.
    for o in &report.outcomes {
        assert!(
            o.runs.iter().all(|r| r.answer == Answer::Unsat),
            "{}: {:?}",
            o.ob.name,
            o.runs
        );
    }
}
