//! Random controller specs for the property tests of the compiler: what an adversary would
//! write, within the language.
//!
//! Each spec has two inputs (`a`, `b`), zero to two states (`s`, `t`), an unranged output `y`
//! and sometimes a ranged output `z`, both roundings, words of 16, 32 or 64 bits, and in its
//! step `let`s, accumulating and plain stores, value `if`s, statement `if`s, `min`/`max`/
//! `clamp`, and comparisons of expressions with each other and with constant thresholds.
//! Generators aimed at past bugs (issue 12):
//! * constants from 1e-15 to 1e15, and decimals that no binary grid holds (`0.1`, `0.333333`);
//! * thresholds inside the compared signal's range, both on and off its grid;
//! * range bounds off the grid (`[0, 0.99]`) as well as on it;
//! * unsigned and signed `#[q(..)]` pins and `#[lsb(..)]` requests on inputs and states;
//! * specs with no state;
//! * (issue 35) a table of `(v + C)·(v + C) − C·C` with `C` up to 1e8, which cancels in f64,
//!   called on `a`; and an input vector `v` of 1 or 33 elements (past the standard
//!   library's 32 for `Default` on arrays), its first and last elements summed into `y`.
//! * (issue 37) a bank: a state `w[N][2]` (N from 2 to 4) updated by a `for j in 0..N` loop
//!   whose body reads the inputs, the states and its own row, so that the emitters may keep it
//!   as one function (`qloop_core::emit::repeat`), its first row read after the loop.

use proptest::prelude::*;

/// A generated spec. Its controller is named `random`; [`RandomSpec::named`] renames it.
#[derive(Clone, Debug)]
pub struct RandomSpec {
    /// The spec's text.
    pub src: String,
}

impl RandomSpec {
    /// The text with the controller renamed to `name` (for many specs in one crate).
    pub fn named(&self, name: &str) -> String {
        self.src
            .replacen("controller random {", &format!("controller {name} {{"), 1)
    }
}

/// A declared signal: name, range, and an optional attribute line.
#[derive(Clone, Debug)]
struct Decl {
    name: &'static str,
    range: (f64, f64),
    attr: String,
}

/// A number as a spec literal, parenthesised if negative.
fn lit(v: f64) -> String {
    let s = if v == v.trunc() && v.abs() < 1e15 {
        format!("{v:.1}")
    } else {
        format!("{v:?}")
    };
    if v < 0.0 {
        format!("({s})")
    } else {
        s
    }
}

/// Constants: ordinary decimals, magnitudes from 1e-15 to 1e15, exact binary fractions, and
/// decimals off every binary grid.
fn constant() -> BoxedStrategy<String> {
    prop_oneof![
        4 => (-4.0f64..4.0).prop_map(|c| lit((c * 1000.0).round() / 1000.0)),
        1 => (-15i32..=15, 1.0f64..10.0, any::<bool>()).prop_map(|(e, m, neg)| {
            let s = format!("{m:.3}e{e}");
            if neg { format!("(-{s})") } else { s }
        }),
        1 => (-64i64..=64, 0i32..=20).prop_map(|(k, n)| lit(k as f64 / 2f64.powi(n))),
        1 => prop::sample::select(vec!["0.1", "0.3", "0.2", "0.7", "1e-3", "0.333333", "(-0.1)"])
            .prop_map(str::to_string),
    ]
    .boxed()
}

/// A threshold for a signal with range `r`: inside the range, on or off a binary grid, or a
/// bound itself.
fn threshold(r: (f64, f64)) -> BoxedStrategy<String> {
    let (lo, hi) = r;
    prop_oneof![
        2 => (0.0f64..1.0).prop_map(move |u| {
            let v = lo + u * (hi - lo);
            // 4 significant digits: almost never on the grid.
            lit(format!("{v:.3e}").parse().unwrap_or(v))
        }),
        1 => (0.0f64..1.0, 4i32..=14).prop_map(move |(u, n)| {
            // A grid point of 2^-n scaled to the range.
            let g = 2f64.powi(-n) * (hi - lo).abs().max(1e-300).log2().floor().exp2();
            let v = lo + ((u * (hi - lo)) / g).round() * g;
            lit(v)
        }),
        1 => prop::bool::ANY.prop_map(move |up| lit(if up { hi } else { lo })),
    ]
    .boxed()
}

/// Declared ranges over six decades: symmetric-ish, non-negative, on or off the grid.
fn range() -> BoxedStrategy<(f64, f64)> {
    prop_oneof![
        3 => (-4i32..=2, 0.05f64..1.0, any::<bool>()).prop_map(|(e, f, neg)| {
            let hi = 10f64.powi(e) * (1.0 + f);
            let hi: f64 = format!("{hi:.3e}").parse().unwrap_or(hi);
            if neg {
                let lo: f64 = format!("{:.3e}", -hi * f).parse().unwrap_or(-hi * f);
                (lo.min(-1e-6), hi)
            } else {
                (0.0, hi)
            }
        }),
        1 => prop::sample::select(vec![(0.0, 1.0), (-1.0, 1.0), (0.0, 0.99), (-2.0, 2.0), (0.0, 5.0)]),
    ]
    .boxed()
}

/// An attribute for a declaration with range `r`: none, `#[lsb(..)]`, or a `#[q(..)]` pin
/// (unsigned where the range allows) with as many fraction bits as fit.
fn attr(r: (f64, f64)) -> BoxedStrategy<String> {
    let pin = move |signed: bool, bits: u32| -> String {
        let (min, max) = if signed {
            (
                -(2f64.powi(bits as i32 - 1)),
                2f64.powi(bits as i32 - 1) - 1.0,
            )
        } else {
            (0.0, 2f64.powi(bits as i32) - 1.0)
        };
        let f = (0..=bits as i32)
            .rev()
            .find(|&f| (r.1 * 2f64.powi(f)).ceil() <= max && (r.0 * 2f64.powi(f)).floor() >= min);
        match f {
            // Only pins that resolve the range into many steps.
            Some(f) if (r.1 - r.0) * 2f64.powi(f) >= 64.0 => {
                format!("#[q({}{bits}, {f})]", if signed { 'i' } else { 'u' })
            }
            _ => String::new(),
        }
    };
    prop_oneof![
        6 => Just(String::new()),
        // A resolution of about a thousandth of the range.
        1 => Just(format!("#[lsb({:.1e})]", (r.1 - r.0) / 1000.0)),
        2 => (prop::sample::select(vec![8u32, 16, 32]), any::<bool>())
            .prop_map(move |(bits, signed)| pin(signed || r.0 < 0.0, bits)),
    ]
    .boxed()
}

fn decl(name: &'static str) -> BoxedStrategy<Decl> {
    range()
        .prop_flat_map(move |r| {
            attr(r).prop_map(move |attr| Decl {
                name,
                range: r,
                attr,
            })
        })
        .boxed()
}

/// An arithmetic expression over `leaves`.
fn expr(leaves: Vec<&'static str>, depth: u32) -> BoxedStrategy<String> {
    let l = leaves.clone();
    let leaf = prop_oneof![
        3 => prop::sample::select(l).prop_map(str::to_string),
        1 => constant(),
    ];
    if depth == 0 {
        return leaf.boxed();
    }
    // One strategy per depth, shared by every operand (a `BoxedStrategy` clone is a reference
    // count): building a fresh one per operand made the strategy tree exponential in `depth`,
    // and building and dropping it was a fifth of drawing a spec.
    let shared = expr(leaves, depth - 1);
    let sub = move || shared.clone();
    prop_oneof![
        2 => leaf,
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} + {y})")),
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} - {y})")),
        2 => (sub(), sub()).prop_map(|(x, y)| format!("({x} * {y})")),
        1 => sub().prop_map(|x| format!("(-{x})")),
        1 => (sub(), sub()).prop_map(|(x, y)| format!("min({x}, {y})")),
        1 => (sub(), sub()).prop_map(|(x, y)| format!("max({x}, {y})")),
        1 => (sub(), 0.0f64..2.0).prop_map(|(x, c)| {
            let c = (c * 1000.0).round() / 1000.0;
            format!("clamp({x}, {}, {})", lit(-c), lit(c))
        }),
        1 => (cond_of(sub(), sub()), sub(), sub())
            .prop_map(|(c, x, y)| format!("(if {c} {{ {x} }} else {{ {y} }})")),
    ]
    .boxed()
}

const OPS: [&str; 6] = ["<", "<=", ">", ">=", "==", "!="];

/// A comparison of two expressions.
fn cond_of(a: BoxedStrategy<String>, b: BoxedStrategy<String>) -> BoxedStrategy<String> {
    (a, prop::sample::select(OPS.to_vec()), b)
        .prop_map(|(a, op, b)| format!("{a} {op} {b}"))
        .boxed()
}

/// A condition: a comparison of expressions, or of a declared signal with a threshold (either
/// side), or a conjunction, disjunction or negation of two of those.
fn cond(leaves: Vec<&'static str>, decls: Vec<Decl>) -> BoxedStrategy<String> {
    let thresholded = prop::sample::select(decls)
        .prop_flat_map(|d| {
            (
                Just(d.name),
                prop::sample::select(OPS.to_vec()),
                threshold(d.range),
                any::<bool>(),
            )
        })
        .prop_map(|(n, op, t, flip)| {
            if flip {
                format!("{t} {op} {n}")
            } else {
                format!("{n} {op} {t}")
            }
        })
        .boxed();
    let shallow = expr(leaves, 1);
    let plain = cond_of(shallow.clone(), shallow);
    let one = prop_oneof![2 => thresholded, 1 => plain].boxed();
    prop_oneof![
        4 => one.clone(),
        1 => (one.clone(), one.clone()).prop_map(|(x, y)| format!("{x} && {y}")),
        1 => (one.clone(), one.clone()).prop_map(|(x, y)| format!("{x} || {y}")),
        1 => one.prop_map(|x| format!("!({x})")),
    ]
    .boxed()
}

/// The signals' declarations and the spec-level settings.
#[derive(Clone, Debug)]
struct Shape {
    inputs: Vec<Decl>,
    states: Vec<Decl>,
    z: Option<(f64, f64)>,
    nearest: bool,
    word: u32,
    /// The table's `C = 10^j` and grid step `2^-k`, if the spec has one.
    table: Option<(u32, u32)>,
    /// The input vector's length, if the spec has one.
    vector: Option<usize>,
    /// The bank's rows, if the spec has one.
    bank: Option<usize>,
}

fn shape() -> BoxedStrategy<Shape> {
    (
        (decl("a"), decl("b")),
        (decl("s"), decl("t"), 0usize..=2),
        prop::option::weighted(0.4, range()),
        any::<bool>(),
        prop::sample::select(vec![16u32, 32, 32, 32, 64]),
        prop::option::weighted(0.2, (0u32..=8, 2u32..=5)),
        prop::option::weighted(0.2, prop::sample::select(vec![1usize, 33])),
        prop::option::weighted(0.25, 2usize..=4),
    )
        .prop_map(
            |((a, b), (s, t, n), z, nearest, word, table, vector, bank)| Shape {
                inputs: vec![a, b],
                states: [s, t].into_iter().take(n).collect(),
                z,
                nearest,
                word,
                table,
                vector,
                bank,
            },
        )
        .boxed()
}

/// Random specs (see the module doc).
pub fn spec() -> impl Strategy<Value = RandomSpec> {
    shape().prop_flat_map(|sh| {
        let mut leaves: Vec<&'static str> = sh.inputs.iter().map(|d| d.name).collect();
        leaves.extend(sh.states.iter().map(|d| d.name));
        let decls: Vec<Decl> = sh.inputs.iter().chain(&sh.states).cloned().collect();
        let (deep, shallow) = (expr(leaves.clone(), 2), expr(leaves.clone(), 1));
        let mut row = leaves.clone();
        row.extend(["w[j][0]", "w[j][1]"]);
        let in_row = expr(row, 2);
        (
            (deep.clone(), deep.clone(), deep.clone()),
            (deep, shallow.clone(), shallow),
            (cond(leaves.clone(), decls.clone()), cond(leaves, decls)),
            (any::<bool>(), constant()),
            (in_row.clone(), in_row.clone(), in_row.clone(), in_row),
        )
            .prop_map(move |((e0, e1, e2), (e3, e4, e5), (c0, c1), (acc, k), (r0, r1, r2, r3))| {
                let decl = |kw: &str, d: &Decl| {
                    let init = if kw == "state" {
                        format!(" = {}", lit((d.range.0 + d.range.1) * 0.5))
                    } else {
                        String::new()
                    };
                    format!(
                        "    {}\n    {kw} {}: [{}, {}]{init};\n",
                        d.attr,
                        d.name,
                        lit(d.range.0),
                        lit(d.range.1)
                    )
                };
                let mut src = format!(
                    "controller random {{\n    period 0.01 \"s\";\n    rounding {};\n    word {};\n",
                    if sh.nearest { "nearest" } else { "floor" },
                    sh.word
                );
                for d in &sh.inputs {
                    src += &decl("input", d);
                }
                for d in &sh.states {
                    src += &decl("state", d);
                }
                if let Some(n) = sh.vector {
                    src += &format!("    input v[{n}]: [-1.0, 1.0];\n");
                }
                if let Some((j, k)) = sh.table {
                    let c = lit(10f64.powi(j as i32));
                    src += &format!(
                        "    table f(w: [-4.0, 4.0]) = (w + {c}) * (w + {c}) - {c} * {c}, step {};\n",
                        lit(2f64.powi(-(k as i32)))
                    );
                }
                if let Some(n) = sh.bank {
                    src += &format!("    state w[{n}][2]: [-4.0, 4.0] = 0.0;\n");
                }
                src += "    output y;\n";
                if let Some(r) = sh.z {
                    src += &format!("    output z: [{}, {}];\n", lit(r.0), lit(r.1));
                }
                src += &format!("    step {{\n        let l0 = {e0};\n");
                match sh.states.len() {
                    0 => {}
                    1 => src += &format!("        s {}= {e1};\n", if acc { "+" } else { "" }),
                    _ => {
                        src += &format!("        s {}= {e1};\n", if acc { "+" } else { "" });
                        src += &format!(
                            "        if {c0} {{ t = {e2}; }} else {{ t -= l0 * {k}; }}\n"
                        );
                    }
                }
                if let Some(n) = sh.bank {
                    src += &format!(
                        "        for j in 0..{n} {{\n            let u = {r0};\n            \
                         w[j][0] = clamp({r1}, -4.0, 4.0);\n            \
                         w[j][1] = clamp(u * 0.5 + {r2}, -4.0, 4.0);\n            \
                         w[j][0] = clamp(w[j][0] - {r3}, -4.0, 4.0);\n        }}\n"
                    );
                }
                let mut y = format!("{e3} + l0");
                if sh.bank.is_some() {
                    y += " + w[0][0]";
                }
                if let Some(n) = sh.vector {
                    y += &format!(" + v[0] + v[{}]", n - 1);
                }
                if sh.table.is_some() {
                    y += " + f(a)";
                }
                src += &format!("        y = {y};\n");
                if sh.z.is_some() {
                    src += &format!("        if {c1} {{ z = {e4}; }} else {{ z = {e5}; }}\n");
                }
                src += "    }\n}\n";
                RandomSpec { src }
            })
    })
}

/// Whether a compile error is a legitimate, documented refusal of a random spec (values too
/// wide or too narrow for the words, constants that vanish or overflow), rather than a bug.
pub fn legitimate_refusal(message: &str) -> bool {
    [
        "64 bits",
        "64-bit",
        "too far apart",
        "too wide",
        "narrower than one step",
        "vanishes in this product",
        "vanishes here",
        "overflows",
        "does not fit",
        "could not find a format",
    ]
    .iter()
    .any(|m| message.contains(m))
}

/// `count` specs drawn from [`spec`] with a deterministic RNG seeded by `seed`.
pub fn sample(seed: u64, count: usize) -> Vec<RandomSpec> {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &bytes);
    let mut runner = TestRunner::new_with_rng(Config::default(), rng);
    let strat = spec();
    (0..count)
        .map(|_| {
            strat
                .new_tree(&mut runner)
                .expect("the strategy never rejects")
                .current()
        })
        .collect()
}

/// The seed of a randomised test run: `$QLOOP_SEED` if set (to replay a failure), else fresh;
/// printed so that a failing run can be replayed.
pub fn run_seed(test: &str) -> u64 {
    let seed = std::env::var("QLOOP_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(1, |d| d.as_nanos() as u64)
        });
    eprintln!("{test}: seed {seed} (replay with QLOOP_SEED={seed})");
    seed
}
