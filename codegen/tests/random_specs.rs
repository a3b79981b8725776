//! Randomised tests of the compiler itself.
//!
//! * Soundness on random specs: for random controllers (random ranges over five decades,
//!   nested `+ - *`, `min`/`max`/`clamp`, value `if`s, branches, both roundings), every
//!   value the plan computes stays inside the interval the range analysis proved, and every
//!   state and output stays within the reported error bound of real arithmetic.
//! * No panics on bad input: mutated seed specs either compile or give a located error.

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use qloop::interp::{step_fixed, step_real};
use qloop::ir::SigKind;
use qloop::Target;

const LEAVES: [&str; 4] = ["a", "b", "s", "t"];

fn expr(depth: u32) -> BoxedStrategy<String> {
    let leaf = prop_oneof![
        3 => (0..LEAVES.len()).prop_map(|i| LEAVES[i].to_string()),
        1 => (-4.0f64..4.0).prop_map(|c| format!("{c:.3}")),
    ];
    if depth == 0 {
        return leaf.boxed();
    }
    let sub = || expr(depth - 1);
    prop_oneof![
        2 => leaf,
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} + {y})")),
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} - {y})")),
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} * {y})")),
        1 => sub().prop_map(|x| format!("(-{x})")),
        1 => (sub(), sub()).prop_map(|(x, y)| format!("min({x}, {y})")),
        1 => (sub(), sub()).prop_map(|(x, y)| format!("max({x}, {y})")),
        1 => (sub(), 0.0f64..2.0).prop_map(|(x, c)| format!("clamp({x}, {:.3}, {:.3})", -c, c)),
        1 => (sub(), sub(), sub(), sub())
            .prop_map(|(p, q, x, y)| format!("(if {p} < {q} {{ {x} }} else {{ {y} }})")),
    ]
    .boxed()
}

fn range() -> impl Strategy<Value = (f64, f64)> {
    (-3i32..=2, 0.05f64..1.0, prop::bool::ANY).prop_map(|(e, f, neg)| {
        let hi = 10f64.powi(e) * (1.0 + f);
        if neg {
            (-hi, hi * f)
        } else {
            (0.0, hi)
        }
    })
}

#[derive(Debug, Clone)]
struct RandomSpec {
    src: String,
}

fn spec() -> impl Strategy<Value = RandomSpec> {
    (
        (range(), range(), range(), range()),
        (expr(2), expr(2), expr(2), expr(2), expr(1), expr(1)),
        prop::bool::ANY,
        (prop::bool::ANY, prop::bool::ANY),
    )
        .prop_map(
            |((ra, rb, rs, rt), (e0, e1, e2, e3, c0, c1), nearest, (pin, acc))| {
                let mid = |r: (f64, f64)| (r.0 + r.1) * 0.5;
                let src = format!(
                    "controller random {{
    period 0.01 \"s\";
    rounding {rounding};
    input a: [{:?}, {:?}];
    {pin_attr}
    input b: [{:?}, {:?}];
    state s: [{:?}, {:?}] = {:?};
    state t: [{:?}, {:?}] = {:?};
    output y;
    step {{
        let l0 = {e0};
        s {op}= {e1};
        if {c0} > {c1} {{ t = {e2}; }} else {{ t -= l0 * 0.375; }}
        y = {e3} + l0;
    }}
}}",
                    ra.0,
                    ra.1,
                    rb.0,
                    rb.1,
                    rs.0,
                    rs.1,
                    mid(rs),
                    rt.0,
                    rt.1,
                    mid(rt),
                    rounding = if nearest { "nearest" } else { "floor" },
                    pin_attr = if pin { "#[lsb(0.01)]" } else { "" },
                    op = if acc { "+" } else { "" },
                );
                RandomSpec { src }
            },
        )
}

/// A random raw value in `[lo, hi]`.
fn pick(seed: &mut u64, lo: i128, hi: i128) -> i128 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    lo + (*seed as i128).rem_euclid(hi - lo + 1)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_specs_are_sound(sp in spec(), seed in any::<u64>()) {
        let plan = match qloop::compile_str(&sp.src, &Target::default()) {
            Ok(p) => p,
            // Values too wide for the words are a legitimate, located refusal.
            Err(e) => {
                prop_assert!(
                    ["64 bits", "too far apart", "too wide", "narrower than one step"].iter().any(|m| e.message.contains(m)),
                    "unexpected error {e} for\n{}", sp.src);
                return Ok(());
            }
        };
        let mut seed = seed | 1;
        for _ in 0..50 {
            let mut fv = vec![0i128; plan.prog.signals.len()];
            let mut rv = vec![0f64; plan.prog.signals.len()];
            for (i, s) in plan.prog.signals.iter().enumerate() {
                let id = qloop::ir::SigId(i);
                let q = plan.format(id);
                let raw = match s.kind {
                    SigKind::Input => {
                        let (lo, hi) = s.range.unwrap();
                        pick(&mut seed, q.raw_ceil(lo), q.raw_floor(hi))
                    }
                    SigKind::State => {
                        let (lo, hi) = plan.raw_bounds(id).unwrap();
                        pick(&mut seed, lo, hi)
                    }
                    _ => continue,
                };
                fv[i] = raw;
                rv[i] = q.value(raw);
            }
            let fd = step_fixed(&plan, &mut fv)
                .map_err(|v| TestCaseError::fail(format!("{v:?} in\n{}", sp.src)))?;
            let rd = step_real(&plan.prog, &mut rv);
            if !qloop::interp::agree(&fd, &rd) {
                continue; // different branch: the bound does not apply
            }
            for (i, s) in plan.prog.signals.iter().enumerate() {
                if matches!(s.kind, SigKind::State | SigKind::Output) {
                    let got = plan.format(qloop::ir::SigId(i)).value(fv[i]);
                    let want = rv[i];
                    // The f64 reference itself rounds (≈1e-16 relative per operation).
                    let slack = 1e-12 * (want.abs() + 1.0);
                    let bound = plan.summary[i].err;
                    prop_assert!((got - want).abs() <= bound + slack,
                        "{}: fixed {got} vs real {want}: {:e} > bound {bound:e}\n{}",
                        s.name, (got - want).abs(), sp.src);
                }
            }
        }
    }

    #[test]
    fn mutated_specs_never_panic(cut in 0usize..2000, len in 0usize..6, with in prop::sample::select(vec![
        "", "/", "%", "*", "-", "1e300", "-0.0", "(", "}", "[", "let", "if", "state", "#[q(i8, 7)]",
        "#[lsb(1e-30)]", "0.", "\"", "=", ";", "x", "1e-300", "99999999999999999999",
    ])) {
        for src in [qloop::DEMO_SPEC, include_str!("../../verified/specs/acc_fixed_gain.qloop")] {
            let at = cut % src.len();
            let at = (0..=at).rev().find(|&i| src.is_char_boundary(i)).unwrap_or(0);
            let end = (at + len).min(src.len());
            let end = (end..=src.len()).find(|&i| src.is_char_boundary(i)).unwrap_or(src.len());
            let mutated = format!("{}{}{}", &src[..at], with, &src[end..]);
            let r = std::panic::catch_unwind(|| {
                qloop::compile_str(&mutated, &Target::default()).map(|p| qloop::gen_rust(&p))
            });
            prop_assert!(r.is_ok(), "panic on:\n{mutated}");
            if let Ok(Err(d)) = r {
                let (line, col) = d.line_col();
                prop_assert!(line >= 1 && col >= 1, "error without a location: {d}");
                let rendered = d.render("x.qloop", &mutated);
                prop_assert!(rendered.contains("x.qloop:"), "{rendered}");
            }
        }
    }
}
