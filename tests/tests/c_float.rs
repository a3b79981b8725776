//! The C baselines of `qloop bench`, compiled with the host `gcc` and run against the f64
//! reference controllers of `qloop-verified`:
//!
//! * `qloop::emit::c_float` (the spec's step in C `float`), for every spec in
//!   `verified/specs/`: one step from the same state against the reference, within a
//!   single-precision error bound derived here from the spec (see [`ErrBound`]), along random
//!   states and inputs and along the reference's own trajectory;
//! * the hand-written direct-division controllers in `targets/bench/`
//!   (Koren & Masory 1981, Koren & Masory (1981), eqs. 2-3), in `float` and in Q12 `int32`:
//!   a different algorithm from the spec's, so only their steady state on a steady cut is
//!   compared with the reference's.
//!
//! Every C file is compiled with `-std=c99 -Wall -Wextra -Werror -Wdouble-promotion
//! -pedantic`, and the controllers' object files must reference no external symbol (no libm,
//! no libc). Without `gcc` on the `PATH` the tests are skipped (see `qloop_tests::tool`).

use qloop::emit::c_float;
use qloop::ir::{Cond, Expr, Program, SigId, SigKind, Stmt, Table};
use qloop::{Plan, Target};
use qloop_tests::c_harness::{self, draw, run_stdin, Stream};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const CFLAGS: &[&str] = &[
    "-std=c99",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-Wdouble-promotion",
    "-pedantic",
    "-O2",
];

/// Whether the host has `gcc`; without it the test is skipped (and listed at the end of
/// `cargo test --workspace`), or fails under QLOOP_REQUIRE_TOOLS.
fn have_gcc() -> bool {
    qloop_tests::tool("gcc").is_some()
}

/// A fresh scratch directory under cargo's per-test temporary directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("c_float")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

fn run_checked(cmd: &mut Command, what: &str) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run: {e}"));
    assert!(
        out.status.success(),
        "{what} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Compiles `src` to an object file with the strict flags and checks that it references no
/// external symbol (no libm, no libc: everything the controller needs is inline).
fn compile_object(dir: &Path, src: &Path, include: &Path) -> PathBuf {
    let obj = dir.join(format!(
        "{}.o",
        src.file_stem().and_then(|s| s.to_str()).unwrap_or("x")
    ));
    run_checked(
        Command::new("gcc")
            .args(CFLAGS)
            .arg("-I")
            .arg(include)
            .arg("-c")
            .arg(src)
            .arg("-o")
            .arg(&obj),
        &format!("gcc -c {}", src.display()),
    );
    if let Ok(out) = Command::new("nm").arg("-u").arg(&obj).output() {
        let undefined = String::from_utf8_lossy(&out.stdout).trim().to_string();
        assert!(
            undefined.is_empty(),
            "{} calls external functions:\n{undefined}",
            src.display()
        );
    }
    obj
}

/// Links a driver (`main`) with controller objects.
fn link(dir: &Path, driver: &str, include: &Path, objs: &[PathBuf]) -> PathBuf {
    let src = dir.join("driver.c");
    std::fs::write(&src, driver).expect("write driver");
    let exe = dir.join("driver");
    run_checked(
        Command::new("gcc")
            .args(CFLAGS)
            .arg("-I")
            .arg(include)
            .arg(&src)
            .args(objs)
            .arg("-o")
            .arg(&exe),
        "gcc driver",
    );
    exe
}

/// Parses a line of `%.9g` floats (9 significant digits round-trip every `float` exactly).
fn floats(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .map(|t| f64::from(t.parse::<f32>().expect("a float")))
        .collect()
}

/// SplitMix64: a small deterministic generator, so every run checks the same cases.
struct Rng(u64);

impl Stream for Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

// ---------------------------------------------------------------------------------------
// The f64 reference controllers of qloop-verified, behind one interface.
// ---------------------------------------------------------------------------------------

/// `(states, inputs) → (outputs, next states)`.
type StepFn = fn(&[f64], &[f64]) -> (Vec<f64>, Vec<f64>);

/// One seed spec's f64 reference controller (`controller!(…, reference)`).
struct Reference {
    inputs: &'static [&'static str],
    states: &'static [&'static str],
    outputs: &'static [&'static str],
    /// The declared initial state.
    init: fn() -> Vec<f64>,
    /// `(states, inputs) → (outputs, next states)`: one step from the given state.
    step: StepFn,
}

/// The state names a reference lists (`STATES`): a scalar `x` as itself, a vector `theta[2]` as
/// `theta[0]`, `theta[1]`, a matrix `P[2][2]` row-major as `P[0][0]`, `P[0][1]`, ...
fn state_labels(fields: &[(&str, &[usize])]) -> Vec<String> {
    let mut out = Vec::new();
    for (name, dims) in fields {
        let mut labels = vec![name.to_string()];
        for d in *dims {
            labels = labels
                .iter()
                .flat_map(|l| (0..*d).map(move |i| format!("{l}[{i}]")))
                .collect();
        }
        out.extend(labels);
    }
    out
}

/// One field of `States` from the flat, row-major state values: a scalar, or an array of
/// the given dimensions (outer first).
macro_rules! take_state {
    ($it:ident) => {
        $it.next().expect("a state value")
    };
    ($it:ident, $n:literal $(, $rest:literal)*) => {
        ::core::array::from_fn::<_, $n, _>(|_| take_state!($it $(, $rest)*))
    };
}

/// `reference!(module { scalar, vector[N], matrix[R][C], .. })`: the reference module's states
/// in declaration order, each with its dimensions (checked against the module's `STATES`).
macro_rules! reference {
    ($m:ident { $($s:ident $([$n:literal])*),* }) => {{
        use qloop_verified::$m as m;
        assert_eq!(
            m::STATES.to_vec(),
            state_labels(&[$((stringify!($s), &[$($n),*])),*]),
            "state list of {}",
            stringify!($m)
        );
        Reference {
            inputs: &m::INPUTS,
            states: &m::STATES,
            outputs: &m::OUTPUTS,
            init: || m::Reference::new().state_values().to_vec(),
            step: |states, inputs| {
                let mut r = m::Reference::new();
                let mut it = states.iter().copied();
                r.set_states(m::States { $($s: take_state!(it $(, $n)*)),* });
                assert!(it.next().is_none(), "more state values than states");
                let o = r.step_values(inputs.try_into().expect("input count"));
                (o.to_vec(), r.state_values().to_vec())
            },
        }
    }};
}

/// The reference controller compiled from spec `name`; every spec in `verified/specs/` must
/// have one here (qloop-verified compiles each of them).
fn reference(name: &str) -> Reference {
    match name {
        "koren_masory_1981" => reference!(koren_masory_1981_ref { km, kc, u }),
        "koren_masory_tuned" => reference!(koren_masory_tuned_ref { km, kc, u }),
        "koren_masory_safe" => reference!(koren_masory_safe_ref {
            km,
            kc,
            u,
            held,
            fault_code,
            overload_count,
            unknown_load_stale,
            unknown_load_last
        }),
        "acc_fixed_gain" => reference!(acc_fixed_gain_ref { u }),
        "milling_acc" => reference!(milling_acc_ref { km, kc, u }),
        "grinding_pi" => reference!(grinding_pi_ref { xi }),
        "grinding_adaptive_pzc" => reference!(grinding_adaptive_pzc_ref {
            b32,
            f2n,
            r,
            swa,
            sw,
            sq32,
            fp,
            wp,
            xp,
            dxp,
            xi
        }),
        "gac_surface_finish" => reference!(gac_surface_finish_ref { f, theta[2], pred, P[2][2] }),
        "milling_multimodel" => reference!(milling_multimodel_ref {
            yh[2],
            uh[3],
            thz[4],
            Pz[4][4],
            lz[3],
            t0z,
            mz[4],
            thf[6][5],
            Pf[6][5][5],
            lf[6][4],
            t0f[6],
            mf[6][5],
            hist[7][8],
            active,
            since
        }),
        other => panic!("spec `{other}` has no reference module here: add it to reference()"),
    }
}

fn spec_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../verified/specs")
}

// ---------------------------------------------------------------------------------------
// Single-precision error bound of one step.
// ---------------------------------------------------------------------------------------

/// Unit roundoff of `float` (round to nearest): every `float` operation and every rounded
/// constant is off by at most this fraction of its exact value.
const U32: f64 = 1.0 / (1u64 << 24) as f64;

/// A bound on a value's magnitude and on its error in `float` against exact arithmetic.
#[derive(Clone, Copy, Debug, Default)]
struct ErrBound {
    mag: f64,
    err: f64,
}

impl ErrBound {
    fn max(self, o: ErrBound) -> ErrBound {
        ErrBound {
            mag: self.mag.max(o.mag),
            err: self.err.max(o.err),
        }
    }
}

/// Standard forward error analysis of one step in `float`, starting from states and inputs
/// that are exact `float`s (the test feeds both sides the same `float` values):
///
/// * a constant `c`: `|c|·u` (rounded once); an input: `u·max|bound|` (its clamp bounds are
///   rounded constants; clamping is 1-Lipschitz);
/// * `a ± b`: `e_a + e_b + u·(|a| + |b| + e_a + e_b)`;
/// * `a·b`: `|a|·e_b + |b|·e_a + e_a·e_b + u·(|a| + e_a)(|b| + e_b)`;
/// * `min`, `max`, select: the larger error (1-Lipschitz, same branch taken);
/// * a table lookup: its samples' largest magnitude, and the error of [`table_bound`];
/// * a `newton_recip` result: also the bound of [`Newton`], which knows the steps contract;
///   the tighter is taken;
/// * a saturated store: `max(e, u·max|bound|)` (clamping with rounded bounds);
/// * an `if`: the larger bound of the two branches for every signal.
///
/// `u` = 2^-24. Magnitudes come from the declared ranges and interval arithmetic. The bound
/// assumes both computations take the same branches; with random `float` inputs a condition
/// within a rounding error of its threshold is a probability-1e-7 event, and the cases are
/// fixed by the seed.
fn step_error_bounds(prog: &Program) -> Vec<ErrBound> {
    step_error_analysis(prog).0
}

/// [`step_error_bounds`], and what it recognised of the `newton_recip`s.
fn step_error_analysis(prog: &Program) -> (Vec<ErrBound>, Newton) {
    let mut env = vec![ErrBound::default(); prog.signals.len()];
    for (i, s) in prog.signals.iter().enumerate() {
        let bound = s.range.map_or(0.0, |(lo, hi)| lo.abs().max(hi.abs()));
        match s.kind {
            SigKind::Input => {
                env[i] = ErrBound {
                    mag: bound,
                    err: U32 * bound,
                }
            }
            SigKind::State => {
                env[i] = ErrBound {
                    mag: bound,
                    err: 0.0,
                }
            }
            SigKind::Output | SigKind::Local => {}
        }
    }
    let mut nt = Newton::default();
    block_bounds(prog, &prog.body, &mut env, &mut nt);
    (env, nt)
}

fn block_bounds(prog: &Program, stmts: &[Stmt], env: &mut [ErrBound], nt: &mut Newton) {
    for s in stmts {
        match s {
            Stmt::Assign { target, value, .. } => {
                let mut v = expr_bound(value, &prog.tables, env);
                // A `newton_recip` result: both bounds hold, take the tighter.
                if let Some(b) = nt.assign(prog, env, *target, value) {
                    v = ErrBound {
                        mag: v.mag.min(b.mag),
                        err: v.err.min(b.err),
                    };
                }
                let sig = prog.sig(*target);
                env[target.0] = match (sig.kind, sig.range) {
                    (SigKind::Local, _) | (_, None) => v,
                    (_, Some((lo, hi))) => {
                        let b = lo.abs().max(hi.abs());
                        ErrBound {
                            mag: b,
                            err: v.err.max(U32 * b),
                        }
                    }
                };
            }
            Stmt::If { then, els, .. } => {
                let mut t = env.to_vec();
                block_bounds(prog, then, &mut t, nt);
                let mut e = env.to_vec();
                block_bounds(prog, els, &mut e, nt);
                for (slot, (a, b)) in env.iter_mut().zip(t.into_iter().zip(e)) {
                    *slot = a.max(b);
                }
            }
        }
    }
}

fn expr_bound(e: &Expr, tables: &[Table], env: &[ErrBound]) -> ErrBound {
    let sum = |a: ErrBound, b: ErrBound| {
        let err = a.err + b.err;
        ErrBound {
            mag: a.mag + b.mag,
            err: err + U32 * (a.mag + b.mag + err),
        }
    };
    let x = |a: &Expr| expr_bound(a, tables, env);
    match e {
        Expr::Const { value, .. } => ErrBound {
            mag: value.abs(),
            err: U32 * value.abs(),
        },
        Expr::Var(id, _) => env[id.0],
        Expr::Neg(a) => x(a),
        Expr::Add(a, b) | Expr::Sub(a, b) => sum(x(a), x(b)),
        Expr::Mul(a, b, _) => {
            let (a, b) = (x(a), x(b));
            ErrBound {
                mag: a.mag * b.mag,
                err: a.mag * b.err
                    + b.mag * a.err
                    + a.err * b.err
                    + U32 * (a.mag + a.err) * (b.mag + b.err),
            }
        }
        Expr::Min(a, b) | Expr::Max(a, b) | Expr::Select(_, a, b) => x(a).max(x(b)),
        Expr::Table(t, a, _) => table_bound(&tables[*t], x(a)),
    }
}

/// The `newton_recip` iterates seen so far by [`block_bounds`], for a bound on the result
/// that knows what the interval analysis of [`expr_bound`] cannot: that a Newton step
/// `r' = r·(2 − d·r)` contracts (`1 − d·r' = (1 − d·r)²`), so an error in `r` is squared
/// away rather than multiplied by the factors' magnitudes.
///
/// In `float`, with `h = |1 − d̂·r̂|` for the float divisor `d̂` and iterate `r̂`, the step
/// `r̂' = fl(r̂·fl(2 − fl(d̂·r̂)))` gives `|1 − d̂·r̂'| ≤ h² + γ(h)`, where
/// `γ(h) = u·(1 + h)²·(1 + u) + (2u + u²)·(1 + h² + u·(1 + h)²)` (`fl(d̂·r̂) = (1 − h)(1 + δ₁)`,
/// `2 − fl(d̂·r̂) = 1 + h − δ₁(1 − h)`, two more roundings); the step's clamp only moves `r̂`
/// toward `1/d̂` when `1/d̂` is inside it, which is checked. The table seed starts at
/// `h₀ = max |1 − d·L(d)| + hi·e_L` (`ir::Recip::seed_error` of the f64 samples, and the
/// float lookup's own error `e_L` at the same argument, [`table_bound`]). The reference's
/// result `r` has `0 ≤ 1 − d·r ≤ ε` (`ir::Recip::real_error`). With `d, d̂ ∈ [lo, hi]` (both
/// clamped there) and `|d̂ − d| ≤ e_d`:
///
/// `|r̂ − r| ≤ |r̂ − 1/d̂| + |1/d̂ − 1/d| + |1/d − r| ≤ h_K/lo + e_d/lo² + ε/lo`, and `r ≤ 1/lo`.
///
/// Only the shapes `newton_recip` expands to are recognised (the divisor clamped to `[lo, hi]`,
/// a table seed of it, `t = 2 − d·r_k`, `r_{k+1} = clamp(r_k·t, a, b)`); anything else keeps
/// the bound of [`expr_bound`].
#[derive(Default)]
struct Newton {
    /// A divisor clamped to constant bounds: `(lo, hi)`.
    clamped: HashMap<SigId, (f64, f64)>,
    /// An iterate (the seed is the 0th): its `newton_recip` and its `h` bound.
    iterates: HashMap<SigId, (usize, f64)>,
    /// A correction factor `t = 2 − d·r_k`: `r_k`.
    corrections: HashMap<SigId, SigId>,
}

/// `(a, b)` for `min(max(x, a), b)`, with `x`.
fn clamp_of(e: &Expr) -> Option<(&Expr, f64, f64)> {
    match e {
        Expr::Min(m, b) => match (&**m, &**b) {
            (Expr::Max(x, a), Expr::Const { value: hi, .. }) => match &**a {
                Expr::Const { value: lo, .. } => Some((x, *lo, *hi)),
                _ => None,
            },
            _ => None,
        },
        _ => None,
    }
}

/// The two signals a product of two signals reads.
fn product_of(e: &Expr) -> Option<(SigId, SigId)> {
    match e {
        Expr::Mul(a, b, _) => match (&**a, &**b) {
            (Expr::Var(a, _), Expr::Var(b, _)) => Some((*a, *b)),
            _ => None,
        },
        _ => None,
    }
}

/// Whether `v` is exact in `float`.
fn is_float(v: f64) -> bool {
    f64::from(v as f32) == v
}

impl Newton {
    /// Records what `target = value` is, if it is a step of a `newton_recip`; the bound of
    /// its result when `target` is one.
    fn assign(
        &mut self,
        prog: &Program,
        env: &[ErrBound],
        target: SigId,
        value: &Expr,
    ) -> Option<ErrBound> {
        let u = U32;
        if let Some((_, lo, hi)) = clamp_of(value) {
            self.clamped.insert(target, (lo, hi));
        }
        let recip = |d: SigId| prog.recips.iter().position(|r| r.d == d);
        // The divisor's range, if the divisor is clamped to exactly it in both arithmetics.
        let divisor = |j: usize| {
            let r = &prog.recips[j];
            (self.clamped.get(&r.d) == Some(&(r.lo, r.hi))
                && is_float(r.lo)
                && is_float(r.hi)
                && r.lo > 0.0)
                .then_some((r.lo, r.hi))
        };
        let mut found = None;
        match value {
            // The table seed `L(d)`.
            Expr::Table(t, a, _) => {
                if let Expr::Var(d, _) = &**a {
                    if let Some(j) = recip(*d) {
                        let r = &prog.recips[j];
                        if let (Some((_, hi)), Some((tt, let_))) = (divisor(j), r.seed_table) {
                            if tt == *t && let_ == target {
                                let e_l = table_bound(&prog.tables[*t], ErrBound::default()).err;
                                found = Some((j, r.seed_error(&prog.tables) + hi * e_l));
                            }
                        }
                    }
                }
            }
            // A correction `2 − d·r_k`.
            Expr::Sub(two, p) => {
                if let (Expr::Const { value: c, .. }, Some((a, b))) = (&**two, product_of(p)) {
                    for (d, rk) in [(a, b), (b, a)] {
                        let same = self
                            .iterates
                            .get(&rk)
                            .is_some_and(|(j, _)| prog.recips[*j].d == d);
                        if *c == 2.0 && same {
                            self.corrections.insert(target, rk);
                        }
                    }
                }
            }
            _ => {}
        }
        // A step `clamp(r_k·t, a, b)`.
        if let Some((x, a, b)) = clamp_of(value) {
            if let Some((p, q)) = product_of(x) {
                for (rk, t) in [(p, q), (q, p)] {
                    if self.corrections.get(&t) != Some(&rk) {
                        continue;
                    }
                    let (j, h) = self.iterates[&rk];
                    // The clamp contains 1/d̂ for every d̂ in range, with its float rounding.
                    if let Some((lo, hi)) = divisor(j) {
                        if a * (1.0 + u) <= 1.0 / hi && b * (1.0 - u) >= 1.0 / lo {
                            let gamma = u * (1.0 + h).powi(2) * (1.0 + u)
                                + (2.0 * u + u * u) * (1.0 + h * h + u * (1.0 + h).powi(2));
                            found = Some((j, h * h + gamma));
                        }
                    }
                }
            }
        }
        let (j, h) = found?;
        self.iterates.insert(target, (j, h));
        let r = &prog.recips[j];
        if r.r != target || h >= 1.0 {
            return None;
        }
        let (lo, _) = divisor(j)?;
        let eps = r.real_error(&prog.tables);
        let e_d = env[r.d.0].err;
        Some(ErrBound {
            mag: (1.0 + eps) / lo,
            err: (h / lo + e_d / (lo * lo) + eps / lo) * (1.0 + 4.0 * u),
        })
    }
}

/// A table lookup `L(x)` in `float` (`c_float`'s `NAME_table_I`: clamp, `u = (x − lo)·(1/H)`,
/// `i = (unsigned)u`, `t = u − i`, `s_i + t·(s_{i+1} − s_i)` over the samples rounded to
/// `float`) against the interpolant of the f64 samples at the exact argument (what the
/// reference computes, up to its own f64 rounding):
///
/// * magnitude: the interpolant lies between its samples, so `max |s_i|`;
/// * the argument: `L` is Lipschitz with `λ = max |s_{i+1} − s_i|/H` (extended linearly past
///   the last sample too), and the point the float code interpolates at is off from the exact
///   clamped argument by at most `e_x` (clamping is 1-Lipschitz), `u·max(|lo|, |hi|)` twice
///   (the clamp bounds and `lo` rounded to `float`) and `u·(hi − lo)` (the rounding of
///   `x − lo`; `1/H` is a power of two, exact, and `t = u − i` is exact by Sterbenz's
///   lemma): `λ·(e_x + u·(2·max(|lo|, |hi|) + hi − lo))`;
/// * the evaluation: the rounded samples (`u·s_max`), their difference (`2u·s_max + u·d_max`),
///   the product by `t ∈ [0, 1]` (`u·d_max`) and the sum (`u·(s_max + d_max)`):
///   `u·(4·s_max + 3·d_max)`, with `d_max = max |s_{i+1} − s_i|`; second-order terms are
///   covered by the factor `1 + 8u`.
fn table_bound(t: &Table, arg: ErrBound) -> ErrBound {
    let smax = t.samples.iter().fold(0f64, |m, s| m.max(s.abs()));
    let dmax = t
        .samples
        .windows(2)
        .fold(0f64, |m, w| m.max((w[1] - w[0]).abs()));
    let lip = dmax / t.step;
    let ends = t.lo.abs().max(t.hi.abs());
    let shift = arg.err + U32 * (2.0 * ends + (t.hi - t.lo));
    ErrBound {
        mag: smax,
        err: (lip * shift + U32 * (4.0 * smax + 3.0 * dmax)) * (1.0 + 8.0 * U32),
    }
}

/// The names of the signals an expression reads, appended to `out`.
fn expr_reads(e: &Expr, prog: &Program, out: &mut Vec<String>) {
    match e {
        Expr::Var(id, _) => out.push(prog.sig(*id).name.clone()),
        Expr::Const { .. } => {}
        Expr::Neg(a) => expr_reads(a, prog, out),
        Expr::Add(a, b)
        | Expr::Sub(a, b)
        | Expr::Mul(a, b, _)
        | Expr::Min(a, b)
        | Expr::Max(a, b) => {
            expr_reads(a, prog, out);
            expr_reads(b, prog, out);
        }
        Expr::Select(c, a, b) => {
            cond_reads(c, prog, out);
            expr_reads(a, prog, out);
            expr_reads(b, prog, out);
        }
        Expr::Table(_, a, _) => expr_reads(a, prog, out),
    }
}

/// The names of the signals a condition reads, appended to `out`.
fn cond_reads(c: &Cond, prog: &Program, out: &mut Vec<String>) {
    match c {
        Cond::Cmp(_, a, b) => {
            expr_reads(a, prog, out);
            expr_reads(b, prog, out);
        }
        Cond::And(a, b) | Cond::Or(a, b) => {
            cond_reads(a, prog, out);
            cond_reads(b, prog, out);
        }
        Cond::Not(a) => cond_reads(a, prog, out),
    }
}

/// What the spec's `if`s branch on (printed, so a reader can see which comparisons the
/// same-branch assumption of [`step_error_bounds`] concerns).
fn branch_signals(prog: &Program, stmts: &[Stmt], out: &mut Vec<String>) {
    for s in stmts {
        if let Stmt::If { cond, then, els } = s {
            cond_reads(cond, prog, out);
            branch_signals(prog, then, out);
            branch_signals(prog, els, out);
        }
    }
}

// ---------------------------------------------------------------------------------------
// The float step of every seed spec.
// ---------------------------------------------------------------------------------------

/// C text without its `/* */` comments (the emitter writes no `//` comments).
fn strip_comments(c: &str) -> String {
    let mut out = String::new();
    let mut rest = c;
    while let Some(i) = rest.find("/*") {
        out.push_str(&rest[..i]);
        rest = rest[i..].split_once("*/").map_or("", |(_, r)| r);
    }
    out.push_str(rest);
    out
}

fn fmt_vals(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!(" {}", *x as f32))
        .collect::<String>()
}

/// Compiles the plan's float step and its driver ([`c_harness::float_driver`]: `I` (init,
/// print states), `S s…` (set states), `X i…` (step, print outputs then states), one line per
/// print); the driver executable.
fn build_float(plan: &Plan) -> PathBuf {
    let prog = &plan.prog;
    let dir = scratch(&prog.name);
    let (h, c) = c_float::source(prog);
    for text in [&h, &c] {
        let code = strip_comments(text);
        assert!(
            !code.contains("double"),
            "double in the float step:\n{code}"
        );
        assert!(!code.contains('/'), "a division in the float step:\n{code}");
    }
    std::fs::write(dir.join(format!("{}_f.h", prog.name)), h).expect("write header");
    let src = dir.join(format!("{}_f.c", prog.name));
    std::fs::write(&src, c).expect("write source");
    let obj = compile_object(&dir, &src, &dir);
    link(&dir, &c_harness::float_driver(plan), &dir, &[obj])
}

/// Checks one step: C's outputs and states against the reference's, within the bound.
#[allow(clippy::too_many_arguments)]
fn check_step(
    spec: &str,
    case: &str,
    prog: &Program,
    bounds: &[ErrBound],
    c_line: &str,
    want_out: &[f64],
    want_st: &[f64],
    worst: &mut f64,
) {
    let got = floats(c_line);
    let ids: Vec<SigId> = prog
        .ids_of(SigKind::Output)
        .chain(prog.ids_of(SigKind::State))
        .collect();
    let want: Vec<f64> = want_out.iter().chain(want_st).copied().collect();
    assert_eq!(got.len(), want.len(), "{spec}: driver printed `{c_line}`");
    for ((id, g), w) in ids.iter().zip(&got).zip(&want) {
        let b = bounds[id.0];
        // The reference's own f64 rounding is the same analysis with u = 2^-53: 2^-29 of it.
        let tol = b.err * (1.0 + 1e-8) + f64::EPSILON * b.mag;
        let d = (g - w).abs();
        *worst = worst.max(d / tol.max(f64::MIN_POSITIVE));
        assert!(
            d <= tol,
            "{spec}, {case}: `{}` is {g} in C float, {w} in the f64 reference (|diff| {d:e} > \
             bound {tol:e})",
            prog.sig(*id).label()
        );
    }
}

/// The float C of the seed spec matches its f64 reference within the float error bound.
fn float_step_matches_the_f64_reference(stem: &str) {
    if !have_gcc() {
        return;
    }
    let file = spec_dir()
        .join(format!("{stem}.qloop"))
        .display()
        .to_string();
    let plan = qloop_tests::plan(stem);
    let prog = &plan.prog;
    let r = reference(&prog.name);
    let names =
        |k: SigKind| -> Vec<String> { prog.ids_of(k).map(|id| prog.sig(id).label()).collect() };
    assert_eq!(names(SigKind::Input), r.inputs, "{file}: inputs");
    assert_eq!(names(SigKind::State), r.states, "{file}: states");
    assert_eq!(names(SigKind::Output), r.outputs, "{file}: outputs");
    let (bounds, newton) = step_error_analysis(prog);
    // Every `newton_recip` is bounded as Newton steps (else its interval bound, sound but
    // far too wide to check anything, would silently stand in).
    for r in &prog.recips {
        assert!(
            newton.iterates.contains_key(&r.r),
            "{file}: `{}` is not recognised as a newton_recip result",
            prog.sig(r.r).label()
        );
    }
    let exe = build_float(&plan);

    // 1. Initial state: each value the nearest float to the reference's.
    let init = run_stdin(&exe, "I\n");
    let want_init = (r.init)();
    assert_eq!(floats(&init), fmt_f32(&want_init), "{file}: init");

    // 2. One step from 400 random states and inputs (inputs partly out of range).
    let mut rng = Rng(0x5EED ^ prog.name.len() as u64);
    let mut script = String::new();
    let mut cases = Vec::new();
    for _ in 0..400 {
        let st = draw(&mut rng, &plan, SigKind::State);
        let inp = draw(&mut rng, &plan, SigKind::Input);
        script.push_str(&format!("S{}\nX{}\n", fmt_vals(&st), fmt_vals(&inp)));
        cases.push((st, inp));
    }
    // 3. Along the reference's own trajectory from the initial state: 300 steps of random
    //    inputs, each step started from the reference's state rounded to float on both
    //    sides (a free-running float loop would compare accumulated drift instead).
    let mut st = want_init.clone();
    for _ in 0..300 {
        let st32 = fmt_f32(&st);
        let inp = draw(&mut rng, &plan, SigKind::Input);
        script.push_str(&format!("S{}\nX{}\n", fmt_vals(&st32), fmt_vals(&inp)));
        st = (r.step)(&st, &inp).1;
        cases.push((st32, inp));
    }
    let out = run_stdin(&exe, &script);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), cases.len(), "{file}: driver output");
    let mut worst = 0.0f64;
    for (k, ((st, inp), line)) in cases.iter().zip(&lines).enumerate() {
        let (o, s) = (r.step)(st, inp);
        let case = format!("case {k}: states {st:?}, inputs {inp:?}");
        check_step(&file, &case, prog, &bounds, line, &o, &s, &mut worst);
    }
    let mut branches = Vec::new();
    branch_signals(prog, &prog.body, &mut branches);
    println!(
        "{}: {} steps within the float bound (worst |diff| = {:.3} of the bound; \
         branches on {:?})",
        prog.name,
        cases.len(),
        worst,
        branches
    );
}
test_tools::spec_tests! {
    float_step_matches_the_f64_reference in "verified/specs";
    default: [
        acc_fixed_gain, grinding_adaptive_pzc, grinding_pi, koren_masory_1981, koren_masory_safe,
        koren_masory_tuned, milling_acc,
    ];
    acceptance: [gac_surface_finish, milling_multimodel];
}

fn fmt_f32(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| f64::from(*x as f32)).collect()
}

// ---------------------------------------------------------------------------------------
// The direct-division baselines of the 1981 controller (targets/bench/).
// ---------------------------------------------------------------------------------------

fn bench_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../targets/bench")
}

/// Steady cut: a static process, F_c(i) = K_p · U(i−1) (the force read at step i is the
/// response to the command of the previous step), which is the steady-state relation of
/// Koren & Masory (1981), eq. 2 without the servo and sensor lags. With both ACC laws the feed settles where
/// F_c = F_r, i.e. U = F_r/K_p, and the gain at K/K_p.
const KP_TRUE: [f64; 6] = [0.4, 0.83, 1.0, 2.4, 3.8, 5.5];
const STEPS: usize = 600;
/// The last steps in which the feed must already sit at its steady state.
const TAIL: usize = 50;

/// Driver for both division baselines: reads `K_p steps`, runs the steady cut from the
/// initial state and prints, for the float and the int version, the feed of the last `TAIL`
/// steps and the final K_p, K_c (physical values; the int version also raw).
const DIV_DRIVER: &str = r#"
#include <stdio.h>
#include "koren_masory_1981_div.h"

int main(void)
{
    double kp;
    int steps;
    while (scanf("%lf %d", &kp, &steps) == 2) {
        koren_masory_1981_divf_state fs;
        koren_masory_1981_divf_inputs fi;
        koren_masory_1981_divf_outputs fo;
        koren_masory_1981_divi_state is;
        koren_masory_1981_divi_inputs ii;
        koren_masory_1981_divi_outputs io;
        float ffeed;
        int ifeed, i;
        koren_masory_1981_divf_init(&fs);
        koren_masory_1981_divi_init(&is);
        ffeed = fs.u;
        ifeed = is.u;
        printf("F");
        for (i = 0; i < steps; i++) {
            fi.fc = (float)(kp * (double)ffeed);
            koren_masory_1981_divf_step(&fs, &fi, &fo);
            ffeed = fo.feed;
            if (i >= steps - TAIL) printf(" %.9g", (double)ffeed);
        }
        printf(" | %.9g %.9g\nI", (double)fs.kp, (double)fs.kc);
        for (i = 0; i < steps; i++) {
            /* The force ADC: Q12, rounded to nearest (non-negative here). */
            ii.fc = (int16_t)(long)(kp * (double)ifeed + 0.5);
            koren_masory_1981_divi_step(&is, &ii, &io);
            ifeed = io.feed;
            if (i >= steps - TAIL) printf(" %d", ifeed);
        }
        printf(" | %d %d %d\n", (int)is.kp, (int)is.kc, (int)ii.fc);
    }
    return 0;
}
"#;

/// The reference (the spec's division-free law, f64) on the same steady cut: final feed,
/// K_m and K_c.
fn reference_steady(kp: f64) -> (f64, f64, f64) {
    use qloop_verified::koren_masory_1981_ref as m;
    let mut r = m::Reference::new();
    let mut feed = r.states().u;
    for _ in 0..STEPS {
        feed = r.step(m::Inputs { fc: kp * feed }).feed;
    }
    let s = r.states();
    (feed, s.km, s.kc)
}

fn build_div(dir: &Path) -> PathBuf {
    let include = bench_dir();
    let objs: Vec<PathBuf> = [
        "koren_masory_1981_div_float.c",
        "koren_masory_1981_div_int32.c",
    ]
    .iter()
    .map(|f| compile_object(dir, &include.join(f), &include))
    .collect();
    let driver = DIV_DRIVER.replace("TAIL", &TAIL.to_string());
    link(dir, &driver, &include, &objs)
}

#[test]
fn division_baselines_settle_where_the_reference_does() {
    if !have_gcc() {
        return;
    }
    let exe = build_div(&scratch("div"));
    let script: String = KP_TRUE.iter().map(|k| format!("{k} {STEPS}\n")).collect();
    let out = run_stdin(&exe, &script);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2 * KP_TRUE.len(), "driver output:\n{out}");
    let (fr, k_loop) = (1.5, 1.25);
    let q = 4096.0;
    for (k, &kp) in KP_TRUE.iter().enumerate() {
        let (ref_feed, ref_km, ref_kc) = reference_steady(kp);
        // The reference itself reaches the analytic steady state (tight: it is f64).
        assert!(
            (ref_feed - fr / kp).abs() < 1e-9,
            "reference feed {ref_feed} at K_p {kp}"
        );
        assert!((ref_km - kp).abs() < 1e-9 && (ref_kc - k_loop / kp).abs() < 1e-9);

        // float: U* = F_r/K_p is a fixed point of the float loop up to a few roundings, and
        // the loop contracts by |1 − K| = 0.25 per step; 2^-17 relative (128 float ulps)
        // bounds that with room, and is far below any algorithmic difference.
        let (tail, gains) = lines[2 * k]
            .strip_prefix('F')
            .and_then(|l| l.split_once('|'))
            .expect("F line");
        let (ffeeds, fgains) = (floats(tail), floats(gains));
        assert_eq!(ffeeds.len(), TAIL);
        let rel = 1.0 / (1u64 << 17) as f64;
        for f in &ffeeds {
            assert!(
                (f - ref_feed).abs() <= rel * ref_feed,
                "float division baseline at K_p {kp}: feed {f}, reference {ref_feed}"
            );
        }
        assert!(
            (fgains[0] - ref_km).abs() <= rel * ref_km,
            "float K_p {}",
            fgains[0]
        );
        assert!(
            (fgains[1] - ref_kc).abs() <= rel * ref_kc,
            "float K_c {}",
            fgains[1]
        );

        // int32 Q12: the feed stops moving once floor(K_c·E·2^-12) = 0 in raw units, i.e.
        // 0 ≤ E_raw < 4096/K_c,raw; with the ADC's rounding (±½ raw) of F_c = K_p·U that puts
        // U_raw within [(6144 − 4096/K_c,raw − ½)/K_p, (6144 + ½)/K_p] (about 2^-12/K mm/s
        // wide). The gains carry the quantisation of F_c, U and the two truncating divisions:
        // relative (½ + 4096/K_c,raw)/F_c,raw + 1/K_p,raw + 1/K_c,raw.
        let (tail, raw) = lines[2 * k + 1]
            .strip_prefix('I')
            .and_then(|l| l.split_once('|'))
            .expect("I line");
        let ifeeds: Vec<f64> = tail
            .split_whitespace()
            .map(|t| t.parse::<f64>().expect("raw feed"))
            .collect();
        let raw: Vec<f64> = raw
            .split_whitespace()
            .map(|t| t.parse::<f64>().expect("raw"))
            .collect();
        let (kp_raw, kc_raw, fc_raw) = (raw[0], raw[1], raw[2]);
        assert_eq!(ifeeds.len(), TAIL);
        let lo = (fr * q - q / kc_raw - 0.5) / kp - 1e-9;
        let hi = (fr * q + 0.5) / kp + 1e-9;
        for &u in &ifeeds {
            assert!(
                (lo..=hi).contains(&u),
                "int32 division baseline at K_p {kp}: raw feed {u} outside [{lo:.2}, {hi:.2}] \
                 (reference {:.2})",
                ref_feed * q
            );
        }
        assert!(
            ifeeds.windows(2).all(|w| w[0] == w[1]),
            "int32 feed still moving at K_p {kp}: {ifeeds:?}"
        );
        let grel = (0.5 + q / kc_raw) / fc_raw + 1.0 / kp_raw + 1.0 / kc_raw;
        assert!(
            (kp_raw / q - ref_km).abs() <= grel * ref_km,
            "int32 K_p {} vs {ref_km}",
            kp_raw / q
        );
        assert!(
            (kc_raw / q - ref_kc).abs() <= grel * ref_kc,
            "int32 K_c {} vs {ref_kc}",
            kc_raw / q
        );
        println!(
            "K_p {kp}: feed ref {ref_feed:.6}, float {:.6}, int32 {:.6} mm/s; K_c ref \
             {ref_kc:.5}, float {:.5}, int32 {:.5}",
            ffeeds[TAIL - 1],
            ifeeds[TAIL - 1] / q,
            fgains[1],
            kc_raw / q
        );
    }
}

/// The hand-written constants of the division baselines are the spec's: formats, raw
/// saturation bounds and initial values from qloop's own plan of the same spec, parameters
/// from its constant table.
#[test]
fn division_baseline_constants_are_the_specs() {
    if !have_gcc() {
        return;
    }
    let src = std::fs::read_to_string(spec_dir().join("koren_masory_1981.qloop")).expect("spec");
    let plan = qloop::compile_str(&src, &Target::default()).expect("compiles");
    let prog = &plan.prog;
    let id = |n: &str| {
        SigId(
            prog.signals
                .iter()
                .position(|s| s.name == n)
                .unwrap_or_else(|| panic!("no signal {n}")),
        )
    };
    let param = |n: &str| {
        prog.constants
            .iter()
            .find(|c| c.name == n)
            .unwrap_or_else(|| panic!("no constant {n}"))
            .value
    };
    // (macro, expected) pairs; the baselines' K_p takes the spec's K_m limits.
    let mut want: Vec<(String, f64)> = Vec::new();
    let p = "KOREN_MASORY_1981_DIVI";
    for (sig, mac) in [("fc", "FC"), ("km", "KP"), ("kc", "KC"), ("u", "U")] {
        let s = id(sig);
        let (lo, hi) = plan.raw_bounds(s).expect("ranged");
        want.push((format!("{p}_{mac}_FRAC"), f64::from(plan.format(s).frac)));
        want.push((format!("{p}_{mac}_MIN"), lo as f64));
        want.push((format!("{p}_{mac}_MAX"), hi as f64));
        if sig != "fc" {
            want.push((format!("{p}_{mac}_INIT"), plan.raw_init(s) as f64));
        }
    }
    want.push((
        format!("{p}_FEED_FRAC"),
        f64::from(plan.format(id("feed")).frac),
    ));
    let q = f64::from(plan.format(id("fc")).frac).exp2();
    want.push((format!("{p}_FR"), (param("FR") * q).round()));
    want.push((format!("{p}_K_LOOP"), (param("K_LOOP") * q).round()));
    // `fc > F_AIR` on raw integers: fc_raw > floor(F_AIR · 2^12).
    want.push((format!("{p}_F_AIR"), (param("F_AIR") * q).floor()));
    let d = "KOREN_MASORY_1981_DIV";
    for (n, v) in [("FR", param("FR")), ("K_LOOP", param("K_LOOP"))] {
        want.push((format!("{d}_{n}"), f64::from(v as f32)));
    }
    want.push((format!("{d}_F_AIR"), f64::from(param("F_AIR") as f32)));
    for (sig, mac) in [("fc", "FC"), ("km", "KP"), ("kc", "KC"), ("u", "U")] {
        let (lo, hi) = prog.sig(id(sig)).range.expect("ranged");
        want.push((format!("{d}_{mac}_LO"), f64::from(lo as f32)));
        want.push((format!("{d}_{mac}_HI"), f64::from(hi as f32)));
        if sig != "fc" {
            let init = prog.sig(id(sig)).init.expect("init");
            want.push((format!("{d}_{mac}_INIT"), f64::from(init as f32)));
        }
    }
    let prints: String = want
        .iter()
        .map(|(m, _)| format!("    printf(\"%.9g\\n\", (double)({m}));\n"))
        .collect();
    let driver = format!(
        "#include <stdio.h>\n#include \"koren_masory_1981_div.h\"\nint main(void)\n{{\n{prints}    return 0;\n}}\n"
    );
    let dir = scratch("div_constants");
    let exe = link(&dir, &driver, &bench_dir(), &[]);
    let out = run_stdin(&exe, "");
    // `%.9g` round-trips floats; the raw integers are far below 2^24, exact as floats too.
    let got = floats(&out);
    assert_eq!(got.len(), want.len());
    for ((m, w), g) in want.iter().zip(&got) {
        assert_eq!(g, w, "{m}");
    }
}

/// Every construct of the language, C reserved words as names (`int`, `float`, `out`), an
/// input and a `let` the body never reads, nested branches, a value `if`, `min`/`max`/`clamp`,
/// negation and an unranged output: the float step against the real-arithmetic interpreter
/// (`qloop::interp::step_real`, which the f64 reference equals exactly by the proptests).
const FEATURES: &str = r#"
controller c_features {
    period 2 "ms";
    input x: [0.0, 10.0] "V";
    input float: [-2.0, 2.0];
    input spare: [0.0, 1.0];
    param G: 0.3 "1/V";
    param NEG: -1.75;
    state int: [-8.0, 8.0] = 0.0;
    state w: [0.0, 0.99] = 0.5;
    output out: [-1.0, 1.0];
    output q;
    step {
        let d = x * G + NEG * float;
        let never = d * 3.0;
        let m = if d > 2.0 { d - 2.0 } else { min(d, 0.5) };
        int = int * 0.875 + clamp(m, -1.0, 1.0);
        if float < 0.0 && !(x > 9.0) {
            w -= 0.0625 * w;
            if x > 5.0 || float < -1.5 {
                let t = max(w, 0.1);
                w = t * 0.9;
            }
        } else {
            w = max(w, 0.25) * 0.5 + 0.125;
        }
        out = int * w - 0.3;
        q = -d;
    }
}
"#;

#[test]
fn float_step_of_every_construct_matches_the_real_interpreter() {
    if !have_gcc() {
        return;
    }
    let plan = qloop::compile_str(FEATURES, &Target::default()).expect("features spec");
    let prog = &plan.prog;
    let (h, _) = c_float::source(prog);
    assert!(h.contains("float float_;") && h.contains("float int_;") && h.contains("float out_;"));
    let bounds = step_error_bounds(prog);
    let exe = build_float(&plan);
    let init: Vec<f64> = prog
        .ids_of(SigKind::State)
        .map(|id| prog.sig(id).init.unwrap_or(0.0))
        .collect();
    assert_eq!(floats(&run_stdin(&exe, "I\n")), fmt_f32(&init), "init");
    let mut rng = Rng(0xFEA7);
    let (mut script, mut want) = (String::new(), Vec::new());
    let mut paths = std::collections::BTreeMap::<Vec<(usize, bool)>, usize>::new();
    for _ in 0..2000 {
        let st = draw(&mut rng, &plan, SigKind::State);
        let inp = draw(&mut rng, &plan, SigKind::Input);
        script.push_str(&format!("S{}\nX{}\n", fmt_vals(&st), fmt_vals(&inp)));
        let mut vars = vec![0.0; prog.signals.len()];
        for (id, v) in prog.ids_of(SigKind::State).zip(&st) {
            vars[id.0] = *v;
        }
        for (id, v) in prog.ids_of(SigKind::Input).zip(&inp) {
            vars[id.0] = *v;
        }
        let decisions = qloop::interp::step_real(prog, &mut vars);
        *paths.entry(decisions).or_default() += 1;
        let pick = |k: SigKind| -> Vec<f64> { prog.ids_of(k).map(|id| vars[id.0]).collect() };
        want.push((st, inp, pick(SigKind::Output), pick(SigKind::State)));
    }
    // Every way through the body was taken: value `if` either way, outer `if` either way
    // (short-circuit or not), inner `if` either way.
    assert!(paths.len() >= 8, "branch coverage {paths:?}");
    let out = run_stdin(&exe, &script);
    let mut worst = 0.0f64;
    for (k, ((st, inp, o, s), line)) in want.iter().zip(out.lines()).enumerate() {
        let case = format!("case {k}: states {st:?}, inputs {inp:?}");
        check_step("c_features", &case, prog, &bounds, line, o, s, &mut worst);
    }
    assert_eq!(out.lines().count(), want.len());
    println!(
        "c_features: {} steps over {} branch paths, worst |diff| = {worst:.3} of the bound",
        want.len(),
        paths.len()
    );
}

/// The float C of every spec of the claim corpus that compiles (on-grid and dead tables,
/// vectors of 33 and 256 elements among them, issue 35) compiles with the strict flags and
/// calls nothing external.
#[test]
fn float_c_of_every_compiling_corpus_spec_compiles_with_the_strict_flags() {
    if !have_gcc() {
        return;
    }
    let mut n = 0;
    for (stem, src) in qloop_tests::claim_corpus() {
        if qloop_tests::corpus_expectation(&src).is_some() {
            continue;
        }
        let prog = qloop::compile_str(&src, &Target::default())
            .unwrap_or_else(|e| panic!("{stem}: {}", e.message))
            .prog;
        let dir = scratch(&format!("corpus-{stem}"));
        let (h, c) = c_float::source(&prog);
        std::fs::write(dir.join(format!("{}_f.h", prog.name)), h).expect("write header");
        let path = dir.join(format!("{}_f.c", prog.name));
        std::fs::write(&path, c).expect("write source");
        compile_object(&dir, &path, &dir);
        n += 1;
    }
    assert!(n >= 10, "only {n} corpus specs compile");
}
