//! Quality of the constant multiplier (`qloop::lower::shift_add`) over every 12-bit constant:
//! exact products, adder counts against CSD and the literature's bound, and optimality
//! against an independent brute-force search.
//!
//! Reference figures: every constant below `2^12` needs at most four adders, 2.90 on average
//! over all 12-bit integers (O. Gustafsson, A. G. Dempster, L. Wanhammar, "Extended results
//! for minimum-adder constant integer multipliers", ISCAS 2002). The brute force below is
//! written from the definition of an adder graph (Dempster & Macleod 1994; the A-operation
//! of Voronenko & Püschel 2007) and shares no code with the planner.

use qloop::lower::shift_add::{best, csd, ShiftAddPlan};

/// Constants tested: odd and below `2^BITS`.
const BITS: u32 = 12;

fn odd_constants() -> impl Iterator<Item = i128> {
    (1..1i128 << BITS).step_by(2)
}

/// Every constant the planner is asked about: the odd ones, their negatives, and even
/// multiples of both (small and large powers of two).
fn all_variants() -> Vec<i128> {
    let mut v = Vec::new();
    for c in odd_constants() {
        for k in [0u32, 1, 2, 5, 16, 40, 100] {
            v.push(c << k);
            v.push(-(c << k));
        }
    }
    v
}

/// Multiplicands: small values, word extremes (where the product fits), and the largest and
/// smallest `x` for which `m * x` still fits an `i128` (and their neighbours inside that
/// range).
fn multiplicands(m: i128) -> Vec<i128> {
    let mut xs = vec![
        0,
        1,
        -1,
        2,
        -3,
        12345,
        -98765,
        i64::MAX as i128,
        i64::MIN as i128,
        i32::MIN as i128,
        u32::MAX as i128,
    ];
    // Truncating division: |m * x| ≤ i128::MAX, resp. m * x ≥ i128::MIN, for these.
    let hi = i128::MAX / m;
    xs.extend([hi, -hi, hi - hi.signum(), hi / 3, -(hi / 7)]);
    // i128::MIN / m exceeds i128::MAX / m in magnitude when m divides 2^127 (m = ±2^k);
    // it does not exist for m = −1.
    xs.extend(i128::MIN.checked_div(m));
    // The fixed values overflow for the largest multiples (|m| up to 2^111): drop those.
    xs.retain(|&x| m.checked_mul(x).is_some());
    xs
}

#[test]
fn best_computes_the_exact_product_for_every_12_bit_constant() {
    let mut checked = 0usize;
    for m in all_variants() {
        let plan = best(m);
        assert_eq!(plan.m, m, "plan for {m} records another constant");
        for x in multiplicands(m) {
            let want = m
                .checked_mul(x)
                .expect("multiplicands() keeps fitting products");
            assert_eq!(plan.eval(x), want, "best({m}).eval({x})");
            checked += 1;
        }
    }
    assert!(checked > 200_000, "only {checked} products checked");
}

/// Number of nonzero digits of the non-adjacent form of `n > 0`, by the textbook recoding
/// (a digit `2 − (n mod 4)` whenever `n` is odd).
fn naf_weight(mut n: i128) -> usize {
    let mut w = 0;
    while n != 0 {
        if n & 1 == 1 {
            n -= 2 - (n & 3);
            w += 1;
        }
        n >>= 1;
    }
    w
}

#[test]
fn best_is_never_worse_than_csd_and_needs_at_most_four_adders() {
    for m in all_variants() {
        let (b, c) = (best(m), csd(m));
        let weight = naf_weight(m.abs());
        assert_eq!(c.adders(), weight - 1, "csd({m}) is not nnz − 1 adders");
        assert_eq!(c.eval(3), 3 * m, "csd({m})");
        assert!(b.adders() <= c.adders(), "best({m}) worse than CSD");
        // `optimal` covers |m| < 2^16 (see the ignored test below for larger even multiples).
        if m.abs() < 1 << 16 {
            assert!(b.adders() <= 4, "best({m}) needs {} adders", b.adders());
        }
    }
}

/// A power of two is a free shift, so `c · 2^k` should cost what `c` costs. Today `optimal`
/// bounds the magnitude `|m| < 2^16` rather than the odd part (its module docs say the odd
/// part), so e.g. `683 · 2^16` falls back to CSD (5 adders instead of 4). The lowering only
/// asks for odd `m`, so generated code is unaffected.
#[test]
fn even_multiples_cost_what_their_odd_part_costs() {
    for c in odd_constants() {
        let k0 = best(c).adders();
        for k in [16u32, 40, 100] {
            assert_eq!(best(c << k).adders(), k0, "best({c} << {k})");
            assert_eq!(best(-(c << k)).adders(), k0, "best(-({c} << {k}))");
        }
    }
}

/// Mean adder count of `planner` over `constants`.
fn mean(constants: impl Iterator<Item = i128>, planner: fn(i128) -> ShiftAddPlan) -> f64 {
    let (mut sum, mut n) = (0usize, 0usize);
    for c in constants {
        sum += planner(c).adders();
        n += 1;
    }
    sum as f64 / n as f64
}

#[test]
fn mean_adder_counts_match_the_literature() {
    // ISCAS 2002's 2.90 is the mean over all 12-bit integers (an even constant costs what its
    // odd part costs); over the odd constants alone it is higher (measured 3.12, and checked
    // exactly against the brute force below), so the ≤ 3.0 bound applies to the full set.
    let all = mean(1..1i128 << BITS, best);
    let odd = mean(odd_constants(), best);
    let csd_odd = mean(odd_constants(), csd);
    println!("best: mean {all:.4} over 1..2^{BITS}, {odd:.4} over odd; CSD over odd {csd_odd:.4}");
    assert!(
        all <= 3.0,
        "mean over all 12-bit integers {all} > 3.0 (literature: 2.90)"
    );
    assert!(
        odd < csd_odd - 0.5,
        "best saves too little over CSD: {odd} vs {csd_odd}"
    );
}

/// Exclusive bound on the fundamentals the brute force visits: `2^(BITS + 2)`, twice the
/// usual `2^(b + 1)` of the minimum-adder-graph literature. Too small a bound could only hide
/// graphs, which would show up below as `best` beating the brute force.
const BRUTE_BOUND: u64 = 1 << (BITS + 2);

/// The odd part of `v > 0`.
fn odd_part(v: u64) -> u64 {
    v >> v.trailing_zeros()
}

/// The general A-operation on odd fundamentals: the odd parts of `(u << i) + (v << j)` and
/// `|(u << i) − (v << j)|` for all shifts (one of `i`, `j` may be taken as zero, the other
/// common power of two is removed by the odd part), below [`BRUTE_BOUND`]. This includes the
/// right-shifted sums the planner excludes, so the brute force is at least as strong.
fn a_op(u: u64, v: u64) -> Vec<u64> {
    let mut out = Vec::new();
    for (a, b) in [(u, v), (v, u)] {
        let mut s = a;
        while s < BRUTE_BOUND + b {
            for w in [s + b, s.abs_diff(b)] {
                if w != 0 {
                    let w = odd_part(w);
                    if w < BRUTE_BOUND {
                        out.push(w);
                    }
                }
            }
            s <<= 1;
        }
    }
    out
}

/// Minimum adder count of every odd `t < 2^BITS` that needs at most three adders, by
/// exhaustive enumeration of every adder graph `1, f₁, f₂` and its last adder; `None` means
/// "four or more".
fn brute_force_costs() -> Vec<Option<u8>> {
    let n = 1usize << BITS;
    let mut cost: Vec<Option<u8>> = vec![None; n];
    let mut mark = |t: u64, k: u8| {
        if let Some(slot) = cost.get_mut(t as usize) {
            match *slot {
                Some(c) if c <= k => {}
                _ => *slot = Some(k),
            }
        }
    };
    mark(1, 0);
    let mut level1 = a_op(1, 1);
    level1.sort_unstable();
    level1.dedup();
    level1.retain(|&f| f != 1);
    for &f1 in &level1 {
        mark(f1, 1);
        let mut level2: Vec<u64> = [(1, 1), (1, f1), (f1, f1)]
            .iter()
            .flat_map(|&(u, v)| a_op(u, v))
            .collect();
        level2.sort_unstable();
        level2.dedup();
        for &f2 in &level2 {
            mark(f2, 2);
            let r = [1, f1, f2];
            for i in 0..3 {
                for j in i..3 {
                    for t in a_op(r[i], r[j]) {
                        mark(t, 3);
                    }
                }
            }
        }
    }
    cost
}

#[test]
fn best_is_optimal_against_an_independent_brute_force() {
    let brute = brute_force_costs();
    let mut four = 0;
    let mut sum = 0usize;
    for c in odd_constants() {
        let got = best(c).adders();
        sum += got;
        match brute[c as usize] {
            // Exhaustive up to three adders: exactly the minimum.
            Some(k) => assert_eq!(got, usize::from(k), "best({c}) vs brute-force minimum"),
            // Not reachable with three adders, so `best`'s valid four-adder plan is optimal.
            None => {
                assert_eq!(got, 4, "best({c}) but no graph with ≤ 3 adders exists");
                four += 1;
            }
        }
        // The brief's smaller sample, stated on its own so a regression there is obvious.
        if c < 1 << 8 {
            assert!(brute[c as usize].is_some(), "8-bit {c} needs four adders?");
        }
    }
    // Sanity of the brute force itself: small known cases (45 = 5·9: two adders, 3 = 2 + 1:
    // one; 4 adders are needed by some 12-bit constants, ISCAS 2002).
    assert_eq!(brute[45], Some(2));
    assert_eq!(brute[3], Some(1));
    assert!(four > 0, "no 12-bit constant needs four adders?");
    println!(
        "brute force: {four} odd constants below 2^{BITS} need 4 adders; optimal mean {:.4}",
        sum as f64 / (1usize << (BITS - 1)) as f64
    );
}
