//! Products by a constant and comparisons whose exact form needs 64 bits, computed in 32 bits
//! where the target's word is narrower (tests/narrow_words.qloop;
//! `lower::const_mul::const_split`, `lower::rounding::const_sum_split`,
//! `lower::compare::coarse_compare`):
//! * on the ATmega328P, the Cortex-M cores and RV32 the plan has no value wider than 32 bits,
//!   and `qloop check` says where a product is rounded in 32 bits;
//! * on every built-in target, for both roundings, the interpreter's outputs are the ones
//!   integer arithmetic written here gives (`round(9·d, 3)`, `2^25 + round(9·d, 3)`,
//!   `round(−17·d, 4)`, `2·a > b` ...), on the range's ends, around every tie of the
//!   comparisons and every rounding's half-way point, and on random inputs;
//! * the C of every built-in target, compiled for the host, and the ATmega328P's in simavr
//!   match the interpreter bit for bit (the SMT encodings' agreement is
//!   smt_differential.rs's);
//! * every obligation is proved by both solvers on the ATmega328P and RV32I.

use qloop::interp::step_fixed;
use qloop::Plan;
use qloop_tests::c_harness::{self, Rng};
use qloop_tests::{avr, scratch, sig, tool};

const SPEC: &str = include_str!("narrow_words.qloop");

fn plan_for(target: &str, floor: bool) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    let src = if floor {
        SPEC.replace("rounding nearest;", "rounding floor;")
    } else {
        SPEC.to_string()
    };
    qloop::compile_str(&src, &t).unwrap_or_else(|e| panic!("narrow_words.qloop for {target}: {e}"))
}

const NARROW: [&str; 4] = ["atmega328p", "cortex-m0", "cortex-m4", "rv32i"];

#[test]
fn no_value_is_wider_than_32_bits_on_narrow_words() {
    for t in NARROW {
        for floor in [false, true] {
            let p = plan_for(t, floor);
            let wide: Vec<usize> = (0..p.vals.len())
                .filter(|&i| !p.vals[i].boolean && p.vals[i].ty.bits > 32)
                .collect();
            assert!(
                wide.is_empty(),
                "{t} (floor {floor}): values {wide:?} wider than 32 bits"
            );
            let report = qloop::report::check_report(&p, "narrow_words.qloop");
            assert!(
                report.contains("where rounded by 3 bit(s), as 1·x + round(1·x / 2^3) in 32 bits")
                    && report.contains("where rounded by 4 bit(s), as -1·x + round(-1·x / 2^4)"),
                "{t}: the report does not say how the products are rounded:\n{report}"
            );
        }
    }
    // On a 64-bit host the wide forms are as cheap, and kept.
    let host = plan_for("host", false);
    assert!(host.vals.iter().any(|v| !v.boolean && v.ty.bits == 64));
}

/// `⌊(y + h)/2^n⌋`: nearest (`h = 2^(n−1)`) or floor.
fn round(y: i128, n: u32, floor: bool) -> i128 {
    let h = if floor { 0 } else { 1 << (n - 1) };
    (y + h).div_euclid(1 << n)
}

/// The inputs tried: (d, a, b) raw.
fn inputs(rng: &mut Rng) -> Vec<(i128, i128, i128)> {
    let dmax = 48i128 << 25;
    let (amax, bmin, bmax) = (8i128 << 27, 1i128 << 27, 4i128 << 28);
    let mut d: Vec<i128> = vec![-dmax, dmax, 0];
    // Every residue around the half-way points of both roundings, and near the ends.
    for base in [0i128, 1 << 20, -(1 << 20), dmax - 40, -dmax + 1] {
        d.extend((0..40).map(|k| base + k));
    }
    // The clamp of `pp` at P_MIN: 9·d/8 around 2^15.
    let t = (32768i128 * 8) / 9;
    d.extend((t - 20)..(t + 20));
    let mut ab: Vec<(i128, i128)> = Vec::new();
    for a in [
        0i128,
        1,
        bmin / 2,
        bmin / 2 + 1,
        12_345_678,
        amax / 2,
        amax - 1,
        amax,
    ] {
        for b in [2 * a - 1, 2 * a, 2 * a + 1, bmin, bmax] {
            ab.push((a, b.clamp(bmin, bmax)));
        }
    }
    let mut out = Vec::new();
    for (i, &dv) in d.iter().enumerate() {
        let (a, b) = ab[i % ab.len()];
        out.push((dv, a, b));
    }
    for &(a, b) in &ab {
        out.push((0, a, b));
    }
    for _ in 0..3000 {
        let a = rng.in_range(0, amax);
        let b = if rng.in_range(0, 1) == 0 {
            (2 * a + rng.in_range(-1, 1)).clamp(bmin, bmax)
        } else {
            rng.in_range(bmin, bmax)
        };
        out.push((rng.in_range(-dmax, dmax), a, b));
    }
    out
}

#[test]
fn outputs_are_exact_integer_arithmetic() {
    let mut rng = Rng(0x5eed_0032_b175);
    let cases = inputs(&mut rng);
    for t in [
        "host",
        "atmega328p",
        "cortex-m0",
        "cortex-m4",
        "rv32i",
        "rv32imc",
    ] {
        for floor in [false, true] {
            let p = plan_for(t, floor);
            let id = |n: &str| sig(&p, n).0;
            let one = 1i128 << p.format(sig(&p, "gt")).frac;
            for &(d, a, b) in &cases {
                let mut v = vec![0i128; p.prog.signals.len()];
                (v[id("d")], v[id("a")], v[id("b")]) = (d, a, b);
                step_fixed(&p, &mut v).unwrap_or_else(|e| panic!("{t}: {e:?}"));
                let r9 = round(9 * d, 3, floor);
                let want = [
                    ("p", r9.clamp(1 << 15, 16 << 25)),
                    ("u", (1 << 25) + r9),
                    ("w", round(-17 * d, 4, floor)),
                    ("gt", one * i128::from(2 * a > b)),
                    ("ge", one * i128::from(2 * a >= b)),
                    ("lt", one * i128::from(b > 2 * a)),
                    ("le", one * i128::from(b >= 2 * a)),
                ];
                for (name, w) in want {
                    assert_eq!(
                        v[id(name)],
                        w,
                        "{t} (floor {floor}): {name} for d = {d}, a = {a}, b = {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn fixed_c_matches_the_interpreter_bit_for_bit() {
    let Some(cc) = tool("cc") else { return };
    for t in qloop::targets::builtin() {
        let plan = plan_for(&t.name, false);
        let dir = scratch(&format!("c-narrow-words-{}", t.name));
        let mut rng = Rng(0x5eed_0032_0000 ^ t.name.len() as u64);
        let cases = c_harness::trajectory_and_states(&plan, &mut rng, 2_000, 0);
        c_harness::fixed_c_matches_interpreter(&plan, &cc, &dir, &cases);
    }
}

#[test]
fn avr_c_in_simavr_matches_the_interpreter() {
    let Some(sim) = avr::Simavr::find() else {
        return;
    };
    let plan = plan_for("atmega328p", false);
    let cases = c_harness::trajectory_and_states(&plan, &mut Rng(0x5eed_0032_0328), 400, 0);
    let dir = scratch("c-narrow-words-simavr");
    assert_eq!(avr::matches_the_interpreter(&sim, &plan, &cases, &dir), 400);
}

#[test]
fn proves_with_both_solvers() {
    use qloop::prove::solver::Solver;
    if !Solver::ALL.iter().all(|s| s.available()) {
        eprintln!("z3 or cvc5 missing: skipped");
        return;
    }
    for target in ["atmega328p", "rv32i"] {
        let r = qloop_tests::assert_proved(&plan_for(target, false), 5_000, &[]);
        for o in &r.outcomes {
            qloop_tests::assert_proved_by_each_solver(&r, &o.ob.name);
        }
    }
}
