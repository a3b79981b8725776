//! Bounds that hold, tested independently: the compiled plans of random specs, the seed specs
//! and the claim corpus run against exact rational arithmetic (`qloop_tests::exact`, written
//! apart from the compiler), on inputs aimed at the entry clamp, the range bounds, the
//! saturation bounds and every constant threshold (`qloop_tests::cases`). For every signal:
//! observed |fixed − exact| ≤ the bound as `qloop check` prints it; where a branch decision
//! differs, the operands were within the comparison's printed band. Every shift is narrower
//! than its operand.
//!
//! The plan interpreter stands in for the emitted code here; `random_compile.rs` ties the two
//! together bit for bit.

use qloop::Target;
use qloop_tests::cases::cases;
use qloop_tests::claims::{check, shifts_within_width};
use qloop_tests::random_spec::{legitimate_refusal, run_seed, sample};

/// Compiled random specs in the default run: a few hundred, seconds in a debug build.
const SPECS: usize = 200;
/// Compiled random specs in the acceptance tier.
const ACCEPTANCE_SPECS: usize = 10_000;
/// Random cases per spec, on top of one case per candidate value of each signal.
const RANDOM_CASES: usize = 4;

/// Compiles specs drawn with `seed` until `want` compile; checks each. Returns (compiled,
/// refused, cases, bound comparisons, branch differences, plans with a high product, plans
/// with a short product) or the first failure.
fn run(seed: u64, want: usize, target: &Target) -> Result<[usize; 7], String> {
    let mut n = [0usize; 7];
    let mut batch = 0u64;
    while n[0] < want {
        for sp in sample(seed.wrapping_add(batch), 500) {
            if n[0] == want {
                break;
            }
            let plan = match qloop::compile_str(&sp.src, target) {
                Ok(p) => p,
                Err(e) if legitimate_refusal(&e.message) => {
                    n[1] += 1;
                    continue;
                }
                Err(e) => return Err(format!("unexpected refusal `{}` of\n{}", e.message, sp.src)),
            };
            n[0] += 1;
            n[5] += usize::from(
                plan.vals
                    .iter()
                    .any(|v| matches!(v.op, qloop::lower::lir::Op::MulHi(..))),
            );
            n[6] += usize::from(has_short_product(&plan));
            shifts_within_width(&plan).map_err(|e| format!("{e} in\n{}", sp.src))?;
            let mut s = seed ^ (n[0] as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
            for case in cases(&plan, &mut s, RANDOM_CASES) {
                let c = check(&plan, &case)
                    .map_err(|e| format!("{e}\ncase {case:?}\nspec:\n{}", sp.src))?;
                n[2] += 1;
                n[3] += c.bounds;
                n[4] += usize::from(c.branch_differed);
            }
        }
        batch += 1;
    }
    Ok(n)
}

/// Compiles `specs` random specs drawn from `seed`, on every core, and checks each.
fn random_specs(seed: u64, specs: usize, target: &Target) -> (usize, usize) {
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 8);
    let per = specs.div_ceil(threads);
    let results: Vec<Result<[usize; 7], String>> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..threads as u64)
            .map(|t| s.spawn(move || run(seed.wrapping_add(t << 32), per, target)))
            .collect();
        hs.into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err("a worker panicked".into())))
            .collect()
    });
    let mut total = [0usize; 7];
    for r in results {
        let n = r.unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        for (t, x) in total.iter_mut().zip(n) {
            *t += x;
        }
    }
    eprintln!(
        "{} specs compiled ({} refused with a located, documented error), {} cases, {} \
         bounds compared, {} decisions within their band",
        total[0], total[1], total[2], total[3], total[4]
    );
    assert!(total[0] >= specs, "only {} specs compiled", total[0]);
    // The corners must be reached: many cases, and some decided inside a band.
    assert!(total[2] >= 10 * specs, "only {} cases", total[2]);
    (total[5], total[6])
}

/// Whether the plan has a short product (`lower/rounding.rs`, `short_product`): `⌊a·b/2^16⌋`
/// as `a·h(b) + ⌊a·l(b)/2^16⌋`, seen as a 16-bit shift of a product by the low half of a
/// value (`Low(b, 16)` under its casts).
fn has_short_product(plan: &qloop::Plan) -> bool {
    use qloop::lower::lir::Op;
    let under_casts = |mut id| {
        while let Op::Cast(s) = plan.val(id).op {
            id = s;
        }
        id
    };
    plan.vals.iter().any(|v| match v.op {
        Op::Shr(p, 16) => match plan.val(p).op {
            Op::Mul(a, b) => [a, b]
                .iter()
                .any(|&f| matches!(plan.val(under_casts(f)).op, Op::Low(_, 16))),
            _ => false,
        },
        _ => false,
    })
}

#[test]
fn printed_bounds_hold_against_exact_arithmetic_on_random_specs() {
    let seed = run_seed("printed_bounds_hold_against_exact_arithmetic_on_random_specs");
    random_specs(seed, SPECS, &Target::default());
}

/// The same on the ATmega328P, whose plan computes a product rounded to 32 bits as its high
/// word from three 16 x 16 pieces (`Op::MulHi`), a product with a factor within `i16` rounded
/// by 16 bits or more from two such pieces (a short product), its sums term by term in 32 bits,
/// and a clamped product on the high word (`lower/rounding.rs`): the printed bounds, which add
/// the truncation, hold against exact arithmetic.
#[test]
fn printed_bounds_hold_against_exact_arithmetic_on_random_specs_for_the_avr() {
    let seed = run_seed("printed_bounds_hold_against_exact_arithmetic_on_random_specs_for_the_avr");
    let avr = qloop::targets::by_name("atmega328p").expect("built-in target");
    // About 1 plan in 40 has a high product (a variable product rounded to 32 bits): three
    // times the specs, and at least five of them.
    let (high, short) = random_specs(seed, 3 * SPECS, &avr);
    eprintln!("{high} plans with a high product, {short} with a short product");
    assert!(
        high >= 5,
        "only {high} of {} AVR plans have a high product",
        3 * SPECS
    );
    // About 1 plan in 50 has one; `printed_bounds_hold_for_short_products_on_the_avr` always
    // does.
    assert!(
        short >= 1,
        "none of {} AVR plans has a short product",
        3 * SPECS
    );
}

/// A dot product of a covariance-like row (`Q(i32, 12)` within ±2, so within `i16`) with a
/// regressor in `Q(i32, 30)`, rounded by 16 bits: on the ATmega328P each product is a short
/// product (two 16 x 16 pieces, summed in 32 bits), and the printed bounds hold against exact
/// arithmetic on 2,000 cases and every corner.
#[test]
fn printed_bounds_hold_for_short_products_on_the_avr() {
    let src = "controller short_product {
    period 0.01;
    rounding floor;
    #[q(i32, 30)]
    input phi: [-1.0, 1.0];
    #[q(i32, 30)]
    input w: [-1.0, 1.0];
    #[q(i32, 12)]
    state p[2]: [-2.0, 2.0] = [0.5, -0.25];
    output y: [-8.0, 8.0];
    step {
        #[q(i32, 26)]
        let q = p[0] * phi + p[1] * w;
        y = q;
        p[0] = clamp(p[0] + 0.001 * q, -2.0, 2.0);
    }
}";
    let avr = qloop::targets::by_name("atmega328p").expect("built-in target");
    let plan = qloop::compile_str(src, &avr).unwrap_or_else(|e| panic!("{}", e.message));
    assert!(has_short_product(&plan), "no short product in the AVR plan");
    printed_bounds_hold_for("short_product", src, &avr);
}

/// A random spec (acceptance seed 1796322904772293782) where a constant product rounded in 32
/// bits (`lower::const_mul::const_split`) would take `1449·x` through the network term
/// `23·x << 6`, which leaves `i32` although `1449·x` does not: the split is refused there, and
/// every value stays inside its proved interval.
#[test]
fn printed_bounds_hold_where_a_split_network_term_would_leave_32_bits() {
    let src = r#"controller split_network {
    period 0.01 "s";
    rounding floor;
    word 16;
    
    input a: [(-140.4), 178.6];
    
    input b: [(-2.0), 2.0];
    
    state s: [(-9.557), 15.98] = 3.2115;
    
    state t: [(-106.1), 164.5] = 29.200000000000003;
    state w[3][2]: [-4.0, 4.0] = 0.0;
    output y;
    step {
        let l0 = (0.708 * (a + b));
        s = ((t - b) + s);
        if ((-5.309e-7) + 3.62396240234375e-5) == min(b, (-0.1)) && 72.97 == t { t = a; } else { t -= l0 * (-3.476); }
        for j in 0..3 {
            let u = ((b - a) - (b + w[j][0]));
            w[j][0] = clamp(min((a * b), (s * w[j][1])), -4.0, 4.0);
            w[j][1] = clamp(u * 0.5 + t, -4.0, 4.0);
            w[j][0] = clamp(w[j][0] - ((0.343 * s) + (w[j][1] + a)), -4.0, 4.0);
        }
        y = (if max(t, a) > (if a > s { a } else { s }) { ((-3.315) * s) } else { b }) + l0 + w[0][0];
    }
}"#;
    printed_bounds_hold_for("split_network", src, &Target::default());
}

#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn printed_bounds_hold_against_exact_arithmetic_on_10000_random_specs() {
    let seed = run_seed("printed_bounds_hold_against_exact_arithmetic_on_10000_random_specs");
    random_specs(seed, ACCEPTANCE_SPECS, &Target::default());
}

/// Checks the compiled plan of `src` on 2,000 random cases and every corner case (packed into
/// rounds where there are many signals: `qloop_tests::cases`); for a step of more than 5,000
/// values (the multi-model controller: 13,565 values, whose exact evaluation takes about 2 s a
/// case in a debug build; 7 rounds of corner cases) 10 random cases. A spec the compiler refuses is skipped: the corpus
/// specs that must be refused are tested in claims.rs.
fn printed_bounds_hold_on(name: &str, src: &str) {
    printed_bounds_hold_for(name, src, &Target::default());
}

/// [`printed_bounds_hold_on`] for the plan of `target`.
fn printed_bounds_hold_for(name: &str, src: &str, target: &Target) {
    let t0 = std::time::Instant::now();
    let Ok(plan) = qloop::compile_str(src, target) else {
        return;
    };
    shifts_within_width(&plan).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut seed = 0x5eed;
    let mut n = 0;
    let large = plan.vals.len() > 5_000;
    let all = cases(&plan, &mut seed, if large { 10 } else { 2000 });
    let count = all.len();
    for case in all {
        let c = check(&plan, &case).unwrap_or_else(|e| panic!("{name}: {e}\n{case:?}"));
        n += c.bounds;
    }
    assert!(n > 0, "{name}: no bound was compared");
    eprintln!(
        "{name}: {n} bounds compared on {count} cases in {:.1?}",
        t0.elapsed()
    );
}

/// The printed bounds of a seed spec hold against exact arithmetic.
fn printed_bounds_hold_on_the_seed_spec(stem: &str) {
    let src = std::fs::read_to_string(qloop_tests::specs_dir().join(format!("{stem}.qloop")))
        .expect("seed spec");
    printed_bounds_hold_on(stem, &src);
}
test_tools::spec_tests! {
    printed_bounds_hold_on_the_seed_spec in "verified/specs";
    default: [acc_fixed_gain, grinding_pi, koren_masory_1981];
    acceptance: [
        gac_surface_finish, grinding_adaptive_pzc, koren_masory_safe, koren_masory_tuned,
        milling_acc, milling_multimodel,
    ];
}

/// The printed bounds of the estimating seeds' ATmega328P plans (high products, sums in 32
/// bits, clamps on the high word), and of GAC's with formats chosen against error budgets,
/// hold against exact arithmetic.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn printed_bounds_hold_on_the_avr_plans_of_the_estimating_seeds() {
    let avr = qloop::targets::by_name("atmega328p").expect("built-in target");
    for stem in [
        "gac_surface_finish",
        "grinding_adaptive_pzc",
        "koren_masory_safe",
    ] {
        let src = std::fs::read_to_string(qloop_tests::specs_dir().join(format!("{stem}.qloop")))
            .expect("seed spec");
        printed_bounds_hold_for(stem, &src, &avr);
    }
    printed_bounds_hold_for("milling_zoh", include_str!("milling_zoh.qloop"), &avr);
    // Its formats searched against error budgets instead of pinned (`budget.rs`).
    printed_bounds_hold_for("gac_budgeted", &qloop_tests::gac_with_budgets(), &avr);
}

/// The printed bounds of a claim corpus spec that compiles hold against exact arithmetic.
fn printed_bounds_hold_on_the_claim_corpus(stem: &str) {
    let path = test_tools::workspace_root().join(format!("tests/fixtures/claims/{stem}.qloop"));
    let src = std::fs::read_to_string(&path).expect("corpus spec");
    printed_bounds_hold_on(stem, &src);
}
test_tools::spec_tests! {
    printed_bounds_hold_on_the_claim_corpus in "tests/fixtures/claims";
    default: [
        budget_narrows, budget_on_input, budget_on_let, budget_on_port, budget_pinned,
        budget_unmeetable,
        clamp_gap, division_method, flag_continuous, flag_not_binary, infinite_const, infinite_product, newton_recip_range_spans_zero, newton_steps,
        no_input, no_state,
        pinned_let_type, recip_method, s21_zero_const, threshold_ge, thresholds_all_ops,
        table_cancellation, table_dead_and_constant, table_error_after_clamp, table_on_grid,
        tiny_factor_chain,
        tiny_period, tiny_range, truncated, u64_input, unbalanced, underflow_exp,
        underflow_literal, vanishing_addend, vector_33,
    ];
    // 21 s in a debug build: 2,007 cases of 3,079 values each (256 inputs and states).
    acceptance: [vector_256];
}

/// A random spec (seed 1795571380726870180) on which the printed bound of `y` was 1 unit of its
/// last bit too small: `-2.629` rounds to `-3` next to the integer `a`, an error of 0.371 that
/// is just below 0.371 as an f64, and the round-to-nearest sum with the 1e-17 errors of `b`'s
/// terms stayed there. Error bounds are now summed rounding up (`lower/err_bound.rs`).
#[test]
fn a_bound_exact_at_its_printed_digits_still_covers_the_tiny_errors_added_to_it() {
    let src = "controller random {
        period 0.01 \"s\";
        rounding nearest;
        word 64;
        #[q(u8, 0)]
        input a: [0.0, 148.0];
        input b: [0.0, 0.0001366];
        output y;
        output z: [(-16.24), 18.69];
        step {
            let l0 = max((if b >= a { b } else { b }), (if b >= b { 3.369 } else { (-4.1961669921875e-5) }));
            y = ((b - (-6.537e-6)) - ((-2.629) + a)) + l0;
            if 6.5625 > a || (a * b) >= (0.805 * b) { z = (-b); } else { z = (b + b); }
        }
    }";
    let plan = qloop::compile_str(src, &Target::default()).expect("compiles");
    let case = qloop_tests::cases::Case {
        inputs: vec![6, 106_090_008_610_664],
        states: vec![],
    };
    let c = check(&plan, &case).unwrap_or_else(|e| panic!("{e}"));
    assert!(c.bounds > 0, "no bound was compared");
}
