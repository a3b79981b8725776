//! The `qloop check` report: per-signal ranges, formats, resolution and error bounds, and
//! how each multiplication was lowered.

use crate::emit::kind_name;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{LStmt, Op};
use crate::lower::target::{MulKind, Target};
use crate::lower::Plan;
use std::cmp::Ordering;
use std::fmt::Write;

/// Counts of emitted operations in `step` (both branches of every `if`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCounts {
    /// Adds, subtracts and negations.
    pub add: usize,
    /// Constant shifts.
    pub shift: usize,
    /// Hardware multiplies.
    pub mul: usize,
    /// Comparisons, min, max, selects.
    pub cmp: usize,
    /// Divisions: always zero, by construction.
    pub div: usize,
}

/// Counts operations in the plan.
pub fn op_counts(plan: &Plan) -> OpCounts {
    fn walk(plan: &Plan, s: &[LStmt], c: &mut OpCounts) {
        for st in s {
            match st {
                LStmt::Def(id) => match plan.val(*id).op {
                    Op::Add(..) | Op::Sub(..) | Op::Neg(..) => c.add += 1,
                    Op::Shl(..) | Op::Shr(..) => c.shift += 1,
                    Op::Mul(..) => c.mul += 1,
                    Op::Min(..) | Op::Max(..) | Op::Select(..) | Op::Cmp(..) => c.cmp += 1,
                    _ => {}
                },
                LStmt::Store(..) => {}
                LStmt::If(_, t, e) => {
                    c.cmp += 1;
                    walk(plan, t, c);
                    walk(plan, e, c);
                }
            }
        }
    }
    let mut c = OpCounts::default();
    walk(plan, &plan.body, &mut c);
    c
}

/// The human-readable check report.
pub fn check_report(plan: &Plan, file: &str) -> String {
    let p = &plan.prog;
    let mut o = String::new();
    let _ = writeln!(o, "controller `{}`  ({file})", p.name);
    let t = &plan.target;
    let _ = writeln!(
        o,
        "period {} s, rounding {}, default word {} bits, target {} ({})",
        p.period, p.rounding, p.word, t.name, t.about
    );
    let _ = writeln!(
        o,
        "target model: {}-bit words, C int {} bits (intermediates start there), multiplier {}, {}{}",
        t.word_bits,
        t.c.int_bits,
        multiplier_text(t),
        shifter_text(t),
        extra_costs_text(t)
    );
    let _ = writeln!(o);
    let rows: Vec<[String; 7]> = p
        .signals
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let sm = &plan.summary[i];
            let err = if s.kind == SigKind::Input && sm.err == 0.0 {
                "exact".to_string()
            } else {
                bound(sm.err)
            };
            let pct = if sm.err == 0.0 || sm.range.1 <= sm.range.0 {
                String::new()
            } else {
                let p = 100.0 * sm.err / (sm.range.1 - sm.range.0);
                format!(
                    "{}%",
                    directed(p, true, |x| format!("{x:.2e}"), |x| sci_unit(x, 2))
                )
            };
            [
                s.name.clone(),
                kind_name(s.kind).to_string(),
                signal_range_text(plan, crate::ir::SigId(i)),
                s.unit.clone().unwrap_or_default(),
                sm.format.to_string(),
                format!("{:.3e}", sm.format.lsb()),
                format!("{err} {pct}"),
            ]
        })
        .collect();
    let head = [
        "signal",
        "kind",
        "range",
        "unit",
        "Q-format",
        "LSB",
        "max |error|, one step (% of range)",
    ];
    let head: Vec<String> = head.iter().map(|h| h.to_string()).collect();
    let rows: Vec<Vec<String>> = rows.into_iter().map(Vec::from).collect();
    o.push_str(&table(&head, &rows));
    let _ = writeln!(o);
    let _ = writeln!(o, "Constant multiplications:");
    if plan.mults.is_empty() {
        let _ = writeln!(o, "  (none)");
    }
    for m in &plan.mults {
        let what = m.name.clone().unwrap_or_else(|| g(m.constant));
        let how = if m.hw_mul {
            format!(
                "multiplier (cost {} < shift-add {} with {} adder(s))",
                m.costs.1, m.costs.0, m.adders
            )
        } else if m.adders == 0 {
            if m.m.abs() == 1 {
                let dir = if m.k > 0 { "right" } else { "left" };
                format!(
                    "power of two: a {dir} shift by {} place(s), folded into the next alignment or rounding shift",
                    m.k.abs()
                )
            } else {
                format!("{} shift(s), no adders", m.shifts)
            }
        } else {
            format!(
                "shift-add, {} adder(s), {} shift(s) (cost {} <= multiplier {})",
                m.adders, m.shifts, m.costs.0, m.costs.1
            )
        };
        let _ = writeln!(o, "  x * {what} = x * {}·2^{}: {how}", m.m, -m.k);
    }
    o.push_str(&comparisons(plan));
    let c = op_counts(plan);
    let _ = writeln!(o);
    let _ = writeln!(o, "Working widths of step's values: {}", width_census(plan));
    let _ = writeln!(
        o,
        "step: {} add/sub, {} shifts, {} multiplies, {} compare/select, {} divisions",
        c.add, c.shift, c.mul, c.cmp, c.div
    );
    let _ = writeln!(
        o,
        "Errors are one-step bounds against real arithmetic from the same state and inputs, \
assuming both take the same branches."
    );
    o
}

/// The comparisons of `step`, each with its band: the fixed-point decision equals real
/// arithmetic's whenever the real operands differ by more than the band ("exact": always).
fn comparisons(plan: &Plan) -> String {
    let rows: Vec<String> = plan
        .vals
        .iter()
        .filter_map(|v| match v.op {
            Op::Cmp(op, ..) => Some(format!(
                "  line {:<4} {:<2}  {}",
                v.line,
                op.symbol(),
                if v.err == 0.0 {
                    "exact".to_string()
                } else {
                    format!("band {}", bound(v.err))
                }
            )),
            _ => None,
        })
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    format!(
        "\nComparisons (a decision can differ from real arithmetic only where the operands are \
         within the band):\n{}\n",
        rows.join("\n")
    )
}

/// How many values of each integer width `step` computes, e.g. `i32 ×14, i64 ×3`.
fn width_census(plan: &Plan) -> String {
    let mut n = std::collections::BTreeMap::new();
    for v in plan.vals.iter().filter(|v| !v.boolean) {
        *n.entry((v.ty.bits, v.ty.signed)).or_insert(0usize) += 1;
    }
    let parts: Vec<String> = n
        .iter()
        .map(|((b, s), k)| format!("{}{b} ×{k}", if *s { "i" } else { "u" }))
        .collect();
    parts.join(", ")
}

fn multiplier_text(t: &Target) -> String {
    match t.multiplier.kind {
        MulKind::None => "none (library loop)".to_string(),
        k => format!("{} in {} cycle(s)", k.as_str(), t.multiplier.cycles),
    }
}

fn shifter_text(t: &Target) -> String {
    if t.shifter.barrel {
        format!("barrel shifter ({} cycle(s))", t.shifter.cycles)
    } else {
        let mut s = format!(
            "no barrel shifter ({} cycle(s) per bit per word",
            t.shifter.cycles
        );
        if t.shifter.loop_cycles > 0 {
            s += &format!(", +{} per bit in a shift loop", t.shifter.loop_cycles);
        }
        s + ")"
    }
}

/// The cost-model knobs that only some targets set: library adds/shifts, saved temporaries.
fn extra_costs_text(t: &Target) -> String {
    let mut s = String::new();
    if t.costs.libcall_bits > 0 {
        s += &format!(
            ", {}-bit adds and shifts are library calls",
            t.costs.libcall_bits
        );
    }
    if t.costs.temp > 0 {
        s += &format!(
            ", each shift-add temporary costs {} cycle(s) per word in saved registers",
            t.costs.temp
        );
    }
    s
}

/// The `qloop targets` table: every target's word, C int, multiplier, shifter and the cost of
/// a 16- and a 32-bit multiply in its model.
pub fn targets_table(targets: &[Target]) -> String {
    let head: Vec<String> = [
        "target",
        "word",
        "C int",
        "multiplier",
        "shifter",
        "mul16",
        "mul32",
        "about",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows: Vec<Vec<String>> = targets
        .iter()
        .map(|t| {
            vec![
                t.name.clone(),
                t.word_bits.to_string(),
                t.c.int_bits.to_string(),
                multiplier_text(t),
                if t.shifter.barrel {
                    "barrel".into()
                } else {
                    "per bit".into()
                },
                t.mul_cost(16).to_string(),
                t.mul_cost(32).to_string(),
                t.about.clone(),
            ]
        })
        .collect();
    let mut o = table(&head, &rows);
    o.push_str(
        "mul16/mul32: modelled cycles of a 16/32-bit multiply. The first target is the default.\n",
    );
    o
}

/// A plain-text table: left-aligned columns two spaces apart, a dashed rule under the head.
pub fn table(head: &[String], rows: &[Vec<String>]) -> String {
    let mut w: Vec<usize> = head.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            if let Some(x) = w.get_mut(i) {
                *x = (*x).max(c.chars().count());
            }
        }
    }
    let line = |cells: &[String]| {
        let mut s = String::new();
        for (c, width) in cells.iter().zip(&w) {
            let pad = width.saturating_sub(c.chars().count());
            let _ = write!(s, "{c}{}  ", " ".repeat(pad));
        }
        s.trim_end().to_string()
    };
    let mut o = String::new();
    let _ = writeln!(o, "{}", line(head));
    let rule: Vec<String> = w.iter().map(|n| "-".repeat(*n)).collect();
    let _ = writeln!(o, "{}", rule.join("  "));
    for r in rows {
        let _ = writeln!(o, "{}", line(r));
    }
    o
}

/// `v` as [`g`] prints it, rounded down (`up = false`) or up: a printed range end or bound is
/// never inside the true one. Printing rounds to nearest, so this steps one unit of the last
/// printed digit outward where that was not already so.
fn directed(v: f64, up: bool, fmt: impl Fn(f64) -> String, unit: impl Fn(f64) -> f64) -> String {
    let mut s = fmt(v);
    if !v.is_finite() {
        return s;
    }
    for _ in 0..8 {
        let outward = match decimal_cmp(&s, v) {
            Some(o) => o == Ordering::Equal || (o == Ordering::Greater) == up,
            None => false,
        };
        if outward {
            return s;
        }
        let p: f64 = s.parse().unwrap_or(v);
        let u = unit(p);
        s = fmt(if up { p + u } else { p - u });
    }
    s
}

/// Compares the decimal `s` (as printed: `-1.563e-4`, `0.05`) with the exact value of `v`,
/// exactly (a decimal and a binary fraction rarely coincide, and parsing `s` back to f64 would
/// round it).
fn decimal_cmp(s: &str, v: f64) -> Option<Ordering> {
    use num_bigint::BigInt;
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let neg = mant.starts_with('-');
    let mant = mant.trim_start_matches(['-', '+']);
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut d: BigInt = format!("{int}{frac}").parse().ok()?;
    if neg {
        d = -d;
    }
    let k = exp - frac.len() as i32; // s = d · 10^k
    let (m, e) = crate::qformat::significand_exponent(v);
    let m = BigInt::from(m);
    let pow = |b: u32, n: i32| BigInt::from(b).pow(n.max(0) as u32);
    // d·10^k ? m·2^e  ⟺  d·10^k⁺·2^e⁻ ? m·2^e⁺·10^k⁻
    let lhs = d * pow(10, k) * pow(2, -e);
    let rhs = m * pow(2, e) * pow(10, -k);
    Some(lhs.cmp(&rhs))
}

/// One unit of the last digit of `{:.Ne}` formatting at `v`'s magnitude.
fn sci_unit(v: f64, digits: i32) -> f64 {
    if v == 0.0 {
        return f64::MIN_POSITIVE;
    }
    10f64.powi(v.abs().log10().floor() as i32 - digits)
}

/// [`g`], rounded down.
pub fn g_down(v: f64) -> String {
    directed(v, false, g, g_unit)
}

/// [`g`], rounded up.
pub fn g_up(v: f64) -> String {
    directed(v, true, g, g_unit)
}

fn g_unit(v: f64) -> f64 {
    if v.abs() >= 1e-3 && v.abs() < 1e6 {
        1e-6
    } else {
        sci_unit(v, 4)
    }
}

/// A range `[lo, hi]` the analysis derived, as printed in reports and generated docs: ends
/// rounded outward.
pub fn range_text(lo: f64, hi: f64) -> String {
    format!("[{}, {}]", g_down(lo), g_up(hi))
}

/// The range of signal `id` as printed: a declared range as the spec wrote it (the shortest
/// decimal that reads back as the same f64), a derived one rounded outward.
pub fn signal_range_text(plan: &Plan, id: SigId) -> String {
    let (lo, hi) = plan.summary[id.0].range;
    if plan.prog.sig(id).range.is_some() {
        format!("[{}, {}]", literal(lo), literal(hi))
    } else {
        range_text(lo, hi)
    }
}

/// The shortest decimal that reads back as `v` (`0.27`, `5`, `1e-21`).
fn literal(v: f64) -> String {
    let s = format!("{v:?}");
    s.strip_suffix(".0").map_or(s.clone(), str::to_string)
}

/// An error bound (non-negative) to four significant digits, rounded up: what qloop prints as
/// a bound is never below the bound it computed.
pub fn bound(v: f64) -> String {
    directed(v, true, |x| format!("{x:.3e}"), |x| sci_unit(x, 3))
}

/// Compact number formatting for tables and generated docs.
pub fn g(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e6 {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.4e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A printed bound is never below the bound, and a printed range never inside the range,
    /// exactly (not only after parsing back to f64).
    #[test]
    fn printed_bounds_round_up_and_ranges_outward() {
        // `{:.3e}` rounds to nearest: 1.56245e-4 printed as 1.562e-4, below the bound.
        assert_eq!(format!("{:.3e}", 1.56245e-4), "1.562e-4");
        assert_eq!(bound(1.56245e-4), "1.563e-4");
        assert_eq!(bound(0.5), "5.000e-1");
        assert_eq!(bound(0.0), "0.000e0");
        // -1.178e-5 as an f64 is a little more than 1.178e-5 in magnitude: the decimal that
        // parses back to the same f64 is below it.
        assert_eq!(decimal_cmp("1.178e-5", 1.178e-5), Some(Ordering::Less));
        assert_eq!(bound(1.178e-5), "1.179e-5");
        // The f64 nearest 0.2083 is a little above it.
        assert_eq!(g_down(0.2083), "0.2083");
        assert_eq!(g_up(0.2083), "0.208301");
        assert_eq!(range_text(0.050048828125, 5.0), "[0.050048, 5]");
        for v in [
            3.0503e-5,
            1e-300,
            123456.789,
            7.0,
            0.1,
            2f64.powi(-40),
            9.999e-1,
        ] {
            assert_ne!(decimal_cmp(&bound(v), v), Some(Ordering::Less), "{v}");
            assert_ne!(decimal_cmp(&g_up(v), v), Some(Ordering::Less), "{v}");
            assert_ne!(decimal_cmp(&g_down(v), v), Some(Ordering::Greater), "{v}");
            assert_ne!(decimal_cmp(&g_up(-v), -v), Some(Ordering::Less), "{v}");
        }
    }
}
