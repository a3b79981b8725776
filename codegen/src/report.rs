//! The `qloop check` report: per-signal ranges, formats, resolution and error bounds, and
//! how each multiplication was lowered.

use crate::emit::kind_name;
use crate::ir::SigKind;
use crate::lower::lir::{LStmt, Op};
use crate::lower::target::{MulKind, Target};
use crate::lower::Plan;
use std::fmt::Write;

/// The fixed-step reciprocals: what real arithmetic guarantees, and with the fixed-point
/// error of the result (the `let`'s column: |r − r_real| ≤ err), |1 − d·r| ≤ E + HI·err.
fn recips(plan: &Plan) -> String {
    let p = &plan.prog;
    if p.recips.is_empty() {
        return String::new();
    }
    let mut o =
        String::from("\nFixed-step reciprocals (`newton_recip`, of d clamped to its range):\n");
    for r in &p.recips {
        let e = r.real_error(&p.tables);
        let total = match crate::lower::newton::recip_bound(plan, r) {
            Some(b) => format!(
                "with the rounding of each step (lower::newton): |1 - d*r| <= {}",
                bound(b)
            ),
            None => {
                let err = plan.summary[r.r.0].err;
                format!(
                    "with r's fixed-point error (<= {}): |1 - d*r| <= {}",
                    bound(err),
                    bound((e + r.hi * err) * (1.0 + 1e-12))
                )
            }
        };
        let _ = writeln!(
            o,
            "  line {}: r = 1/d for d in [{}, {}], seed {}, {} Newton step(s): 0 <= 1 - d*r <= {} in real arithmetic; {total}",
            r.span.start().line,
            g(r.lo),
            g(r.hi),
            match r.seed_table {
                Some((t, _)) => format!("table `{}`", p.tables[t].name),
                None => g(r.seed),
            },
            r.steps,
            bound(e),
        );
    }
    o
}

/// The reciprocal trackers: the contraction real arithmetic gives, and the property that
/// `qloop prove` discharges on the generated code.
fn tracks(plan: &Plan) -> String {
    let p = &plan.prog;
    if p.tracks.is_empty() {
        return String::new();
    }
    let mut o = String::from("\nReciprocal trackers (`recip_track`):\n");
    for t in &p.tracks {
        let (r, x) = (p.sig(t.r), p.sig(t.x));
        let (xl, xh) = x.range.unwrap_or((0.0, 0.0));
        let _ = writeln!(
            o,
            "  line {}: {} -> 1/{} for {} in [{}, {}], gain {}: 1 - x*r shrinks by {} per step in real arithmetic; property `{}`: |1 - x*r'| <= {}*|1 - x*r| + {} (`qloop prove`)",
            t.span.start().line,
            r.label(),
            x.label(),
            x.label(),
            g(xl),
            g(xh),
            g(t.gain),
            g(t.rho),
            t.property,
            g(t.claimed_rho),
            g(t.eps)
        );
    }
    o
}

/// The tables: grid, the proved interpolation error, and the verdict on a claimed one.
fn tables(plan: &Plan) -> String {
    let p = &plan.prog;
    if p.tables.is_empty() {
        return String::new();
    }
    let mut o = String::from(
        "\nTables (linear interpolation; the error column adds the interpolation error):\n",
    );
    let layouts = qloop_core::emit::table_layouts(plan);
    for t in &p.tables {
        let arrays: Vec<String> = plan
            .tables
            .iter()
            .enumerate()
            .filter(|(_, l)| p.tables[l.table].name == t.name)
            .map(|(i, l)| {
                let n = l.entries.len();
                if layouts[i].saved > 0 {
                    format!(
                        "{n} x {}, its differences read as T[i+1] - T[i], not stored ({} B of \
                         flash saved for a subtraction a read: the target's flash_per_cycle)",
                        l.format, layouts[i].saved
                    )
                } else {
                    format!("{n} x {}", l.format)
                }
            })
            .collect();
        let claim = match t.claim_verdict() {
            None => String::new(),
            Some(qloop_core::ir::TableClaim::Proved) => format!("; claimed error {}: proved", g(t.claim.unwrap_or(0.0))),
            Some(qloop_core::ir::TableClaim::Refuted { x, err }) => format!(
                "; claimed error {}: REFUTED at x = {} (|L(x) - f(x)| >= {}, exact)",
                g(t.claim.unwrap_or(0.0)),
                g(x),
                qloop_core::text::bound_down(err)
            ),
            Some(qloop_core::ir::TableClaim::Unknown) => format!(
                "; claimed error {}: UNKNOWN (the bound is larger; no sampled point exceeds the claim)",
                g(t.claim.unwrap_or(0.0))
            ),
        };
        let _ = writeln!(
            o,
            "  line {}: {} over [{}, {}], step {} ({} segments; arrays {}): |L(x) - f(x)| <= {} (curvature and samples), at least {} (sampled, exact){claim}",
            t.span.start().line,
            t.name,
            g(t.lo),
            g(t.hi),
            g(t.step),
            t.segments(),
            if arrays.is_empty() { "none: unused".to_string() } else { arrays.join(", ") },
            bound(t.interp_err),
            qloop_core::text::bound_down(t.witness.1),
        );
    }
    o
}

/// The signal table's rows, with the rows of a vector's or matrix's elements merged into one
/// (`theta[0..3]`) where every column but the name agrees.
fn merge_vector_rows(p: &crate::ir::Program, rows: Vec<[String; 7]>) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = Vec::new();
    let mut i = 0;
    while i < rows.len() {
        let Some(e) = &p.signals[i].elem else {
            out.push(Vec::from(rows[i].clone()));
            i += 1;
            continue;
        };
        let n = p.signals[i..]
            .iter()
            .take_while(|s| {
                s.kind == p.signals[i].kind && s.elem.as_ref().is_some_and(|f| f.group == e.group)
            })
            .count();
        let same = n == e.len() && rows[i..i + n].iter().all(|r| r[1..] == rows[i][1..]);
        if same && n > 1 {
            let mut r = Vec::from(rows[i].clone());
            r[0] = e.group.clone()
                + &e.dims
                    .iter()
                    .map(|d| format!("[0..{d}]"))
                    .collect::<String>();
            out.push(r);
        } else {
            out.extend(rows[i..i + n].iter().cloned().map(Vec::from));
        }
        i += n;
    }
    out
}

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
                    Op::Mul(..) | Op::MulHi(..) => c.mul += 1,
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

/// Relative quantisation error of a constant above which `qloop check` warns: the bound the
/// lowering keeps every constant within (`CONST_REL`), so a warning means it did not.
pub const QUANTISATION_WARN: f64 = qloop_core::lower::CONST_REL;

/// How the applied constant `m·2^-k` differs from the written one: `exact`, or the relative
/// difference in percent. `m·2^-k` is an f64 exactly only below 2^53; above, a difference
/// the f64 cannot show is said as a bound, never as `exact`.
fn quantisation(written: f64, m: i128, k: i32) -> String {
    let applied = m as f64 * 2f64.powi(-k);
    let representable = m.unsigned_abs() < 1 << 53;
    match (applied == written, representable) {
        (true, true) => "exact".into(),
        (true, false) => "< 1e-13 %".into(),
        _ => format!("{:+.2e} %", 100.0 * (applied - written) / written),
    }
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
                format!("{}%", crate::text::percent(p))
            };
            [
                s.label(),
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
    let rows = merge_vector_rows(p, rows);
    o.push_str(&table(&head, &rows));
    let _ = writeln!(o);
    let _ = writeln!(o, "Constant multiplications:");
    if plan.mults.is_empty() {
        let _ = writeln!(o, "  (none)");
    }
    // One line per distinct multiplication, counted: an unrolled loop repeats each.
    let mut lines: Vec<(String, usize)> = Vec::new();
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
        // A product rounded into 32 bits by `const_split`: what the code computes.
        let split = match m.split {
            Some((q, c, n)) => format!(
                "; where rounded by {n} bit(s), as {q}·x + round({c}·x / 2^{n}) in 32 bits (exact)"
            ),
            None => String::new(),
        };
        let line = format!(
            "  x * {what} = x * {}·2^{} ({}): {how}{split}",
            m.m,
            -m.k,
            quantisation(m.constant, m.m, m.k)
        );
        match lines.iter_mut().find(|(l, _)| *l == line) {
            Some((_, n)) => *n += 1,
            None => lines.push((line, 1)),
        }
    }
    for (line, n) in lines {
        let times = if n > 1 {
            format!(" (×{n})")
        } else {
            String::new()
        };
        let _ = writeln!(o, "{line}{times}");
    }
    let mut warned = Vec::new();
    for m in &plan.mults {
        let applied = m.m as f64 * 2f64.powi(-m.k);
        let rel = (applied - m.constant) / m.constant;
        if rel.abs() > QUANTISATION_WARN && !warned.contains(&(m.m, m.k, m.constant.to_bits())) {
            // Not expected: the lowering applies every constant within `CONST_REL`.
            warned.push((m.m, m.k, m.constant.to_bits()));
            let what = m.name.clone().unwrap_or_else(|| g(m.constant));
            let _ = writeln!(
                o,
                "warning: {what} = {} is applied as {} ({:+.2} %, above {} %): qloop quantises a \
                 constant to within half an LSB of the value it multiplies, over that value's \
                 range, and within 2^-10 of itself; give that value more fraction bits \
                 (`#[lsb(..)]` or `#[q(..)]` on the input, state or `let`) to apply the constant \
                 more exactly",
                g(m.constant),
                g(applied),
                100.0 * rel,
                g(100.0 * QUANTISATION_WARN)
            );
        }
    }
    o.push_str(&quantised_params(plan));
    o.push_str(&budget_report(plan));
    o.push_str(&recips(plan));
    o.push_str(&tracks(plan));
    o.push_str(&tables(plan));
    o.push_str(&comparisons(plan));
    let c = op_counts(plan);
    let _ = writeln!(o);
    let _ = writeln!(o, "Working widths of step's values: {}", width_census(plan));
    o.push_str(&wide_values(plan));
    o.push_str(&loose_bounds(plan));
    let _ = writeln!(
        o,
        "step: {} add/sub, {} shifts, {} multiplies, {} compare/select, {} divisions",
        c.add, c.shift, c.mul, c.cmp, c.div
    );
    for r in qloop_core::emit::repeat::find(plan) {
        let rows: Vec<String> = r
            .rows
            .iter()
            .map(|row| match row.lead {
                0 => format!("{}[l]", row.group),
                k => format!("{}[l + {k}]", row.group),
            })
            .collect();
        let _ = writeln!(
            o,
            "loop kept as a loop: lines {}-{}, {} indices l: one function in the Rust and the C \
             (its {} plan statements emitted once, not {} times), on rows {}",
            r.lines.0,
            r.lines.1,
            r.count,
            r.len,
            r.count,
            rows.join(", ")
        );
    }
    let _ = writeln!(
        o,
        "Errors are one-step bounds against real arithmetic from the same state and inputs, \
assuming both take the same branches."
    );
    o
}

/// The formats chosen against the spec's `#[error]` budgets (nothing without budgets): each
/// narrowed choice, each budget with its use, and the cost model's estimate against the
/// default formats.
fn budget_report(plan: &Plan) -> String {
    let Some(t) = &plan.tuning else {
        return String::new();
    };
    let p = &plan.prog;
    let mut o = String::new();
    let _ = writeln!(o);
    let _ = writeln!(
        o,
        "Formats chosen against the error budgets (for {}; {} plans lowered):",
        plan.target.name, t.plans
    );
    if t.choices.is_empty() {
        let _ = writeln!(o, "  (none narrower than the default formats)");
    }
    for c in &t.choices {
        let s = p.sig(c.ids[0]);
        let name = match (&s.elem, c.ids.len()) {
            (Some(e), n) if n > 1 => format!("{}[..] ({n} elements)", e.group),
            _ => s.label(),
        };
        let _ = writeln!(
            o,
            "  {name:<24} {:<6}  {} -> {}",
            kind_name(s.kind),
            c.default,
            c.chosen
        );
    }
    let rows: Vec<Vec<String>> = t
        .budgets
        .iter()
        .map(|b| {
            vec![
                p.sig(b.id).label(),
                format!("{:.3e}", b.budget),
                bound(b.default_err),
                bound(b.err),
                format!("{:.0}%", (100.0 * b.err / b.budget).ceil()),
                if b.binds { "binds" } else { "" }.to_string(),
            ]
        })
        .collect();
    let head: Vec<String> = [
        "budget on",
        "bound",
        "default error",
        "chosen error",
        "used",
        "",
    ]
    .iter()
    .map(|h| h.to_string())
    .collect();
    let _ = writeln!(o);
    o.push_str(&table(&head, &rows));
    if !t.kept.is_empty() {
        let names: Vec<String> = t
            .kept
            .iter()
            .map(|id| format!("`{}`", p.sig(*id).label()))
            .collect();
        let _ = writeln!(
            o,
            "  kept as accurate as the default (no budget of their own), which refused a narrower choice: {}",
            names.join(", ")
        );
    }
    let pct = |a: u64, b: u64| {
        if b == 0 {
            String::new()
        } else {
            format!(" ({:+.1} %)", 100.0 * (a as f64 - b as f64) / b as f64)
        }
    };
    let (d, c) = (t.default_cost, t.chosen_cost);
    let _ = writeln!(
        o,
        "  cost model: {} cycles a step, size {} against the default formats' {} and {}: \
         cycles{}, size{} (an estimate to rank formats; `qloop bench` measures)",
        c.cycles,
        c.size,
        d.cycles,
        d.size,
        pct(c.cycles, d.cycles),
        pct(c.size, d.size)
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
/// Whether 64-bit arithmetic is costly on the target: a word under 32 bits (every i64 add is
/// eight AVR instructions), or no 32×32→64 multiply (an i64 product is a library call).
pub fn i64_is_costly(t: &Target) -> bool {
    t.word_bits < 64
        && (t.word_bits < 32
            || !matches!(t.multiplier.kind, MulKind::M32x32To64 | MulKind::M64x64To64))
}

/// The rule parameters `check` moved onto their port's grid (`ir::Quantised`), each with the
/// value the spec wrote and the one the code and the rule's properties use.
fn quantised_params(plan: &Plan) -> String {
    let mut o = String::new();
    for c in &plan.prog.constants {
        let Some(q) = &c.quantised else { continue };
        if o.is_empty() {
            o.push_str(
                "\nRule parameters on their port's grid (the rule's code and its properties use \
                 the value on the right):\n",
            );
        }
        let _ = writeln!(
            o,
            "  {} = {} is used as {}, the multiple of `{}`'s LSB 2^-{} at or {} it",
            c.name,
            g(q.written),
            exact_decimal(c.value, q.frac),
            q.signal,
            q.frac,
            if q.up { "above" } else { "below" }
        );
    }
    o
}

/// The exact decimal of `v`, a multiple of `2^-frac`: `frac` digits after the point hold
/// every digit of it (Rust prints the exact digits at a given precision).
fn exact_decimal(v: f64, frac: i32) -> String {
    let s = format!("{v:.prec$}", prec = frac.max(0) as usize);
    if !s.contains('.') {
        return s;
    }
    let s = s.trim_end_matches('0');
    s.strip_suffix('.').unwrap_or(s).to_string()
}

/// Share of a state's or output's range above which `qloop check` warns of its one-step
/// error bound (the book's "What the emitted code guarantees", docs/book/src/reference/guarantees.md).
pub const BOUND_WARN: f64 = 0.01;

/// A warning for each state or output whose one-step error bound exceeds [`BOUND_WARN`] of
/// its range, naming where the bound grows: the first value the step computes for it (in the
/// order the step computes them, a `let` where it has a name) whose own bound exceeds that
/// share of its own range, with what to change there.
fn loose_bounds(plan: &Plan) -> String {
    use crate::ir::SigId;
    use crate::lower::lir::Val;
    // What each value is computed from, through loads of values stored earlier in the step
    // (the branch tests are not where a bound grows).
    let deps = crate::prove::obligations::cone::Cone::of(plan, false);
    // The physical width of a value's proved interval, and its bound as a share of it.
    let width_of = |v: &Val| (v.hi - v.lo) as f64 * 2f64.powi(-v.frac);
    let share = |v: &Val| -> Option<f64> {
        let width = width_of(v);
        (!v.boolean && width > 0.0).then(|| v.err / width)
    };
    let p = &plan.prog;
    // One warning per vector and place where its bounds grow (an unrolled loop repeats it):
    // (group, the origin's line) -> (the largest share, its element's text, how many elements).
    let mut warnings: Vec<((String, usize), f64, String, usize)> = Vec::new();
    for (i, s) in p.signals.iter().enumerate() {
        if !matches!(s.kind, SigKind::State | SigKind::Output) {
            continue;
        }
        let sm = &plan.summary[i];
        let width = sm.range.1 - sm.range.0;
        // Not where the bound is within one LSB of the signal's own format: that is the
        // precision the spec pinned (a model index in `#[q(u8, 0)]` cannot be closer than 1).
        if !(width > 0.0 && sm.err > BOUND_WARN * width && sm.err > sm.format.lsb()) {
            continue;
        }
        // The values its post-step value is computed from. A copy whose bound is below its
        // operand's was bounded by an analysis of its own (a Newton iterate, `lower::newton`):
        // its operands' bounds do not reach the signal through it.
        let cone = deps.closure_until(deps.post_roots(SigId(i)), |v| match plan.val(v).op {
            Op::Cast(a) => plan.val(v).err >= plan.val(a).err,
            _ => true,
        });
        let loose = |named: bool| {
            cone.iter().copied().find(|id| {
                let v = plan.val(*id);
                (!named || v.name.is_some()) && share(v).is_some_and(|x| x > BOUND_WARN)
            })
        };
        let Some(origin) = loose(true).or_else(|| loose(false)) else {
            continue;
        };
        let v = plan.val(origin);
        let newton = p
            .recips
            .iter()
            .find(|r| r.span.start().line == v.line && v.line != 0);
        // qloop's own `let`s (`qloop_recip1_r0`, ..) are named by what wrote them.
        let what = match &v.name {
            Some(n) if !n.starts_with("qloop_") => format!("`{n}`"),
            _ if newton.is_some() => "the `newton_recip`".to_string(),
            _ => "a value".to_string(),
        };
        let at = if v.line == 0 {
            String::new()
        } else {
            format!(" (line {})", v.line)
        };
        // Of a `newton_recip`, what d's own bound becomes through 1/d: up to d_err/LO².
        let d_part = newton.and_then(|r| {
            let d = &p.sig(r.d).name;
            let dv = plan
                .vals
                .iter()
                .rev()
                .find(|x| x.name.as_deref() == Some(d))?;
            Some((dv.err, dv.err / (r.lo * r.lo), r.lo))
        });
        let fix = match d_part {
            Some((d_err, through, lo)) if through >= 0.5 * v.err => format!(
                "it is a `newton_recip`, and 1/d turns the bound {} of its d into up to {} \
                 (d_err/LO², LO = {}): compute d more exactly, or raise LO",
                bound(d_err),
                bound(through),
                g(lo)
            ),
            Some(_) => "it is a `newton_recip`, whose bound adds each step's rounding: give \
                        its `let` more fraction bits (`#[q(..)]`), seed it closer to 1/d (a \
                        table), or narrow d's range"
                .to_string(),
            None => "give the values it is computed from more fraction bits (`#[lsb(..)]` or \
                     `#[q(..)]`), or narrow their ranges (`#[range(..)]`)"
                .to_string(),
        };
        let unit = s
            .unit
            .as_deref()
            .map(|u| format!(" {u}"))
            .unwrap_or_default();
        let text = format!(
            "warning: `{}` may be off by up to {}{unit} after one step, {}% of its range [{}, {}]{unit} \
             (above {} %); the bound first exceeds {} % of a value's range at {what}{at}, {} on a \
             range {} wide: {fix}",
            s.label(),
            bound(sm.err),
            crate::text::percent(100.0 * sm.err / width),
            g(sm.range.0),
            g(sm.range.1),
            100.0 * BOUND_WARN,
            100.0 * BOUND_WARN,
            bound(v.err),
            g(width_of(v)),
        );
        let key = (
            s.elem.as_ref().map_or(s.name.clone(), |e| e.group.clone()),
            v.line,
        );
        let share = sm.err / width;
        match warnings.iter_mut().find(|w| w.0 == key) {
            Some(w) => {
                w.3 += 1;
                if share > w.1 {
                    (w.1, w.2) = (share, text);
                }
            }
            None => warnings.push((key, share, text, 1)),
        }
    }
    let mut o = String::new();
    for ((group, _), _, text, n) in warnings {
        let more = if n > 1 {
            format!(" (the worst of {n} elements of `{group}` whose bounds first exceed it there)")
        } else {
            String::new()
        };
        let _ = writeln!(o, "{text}{more}");
    }
    o
}

/// A warning for each spec line whose values need 64-bit words on a target where they are
/// costly ([`i64_is_costly`]), naming the `let`s and formats, with what to do.
fn wide_values(plan: &Plan) -> String {
    if !i64_is_costly(&plan.target) {
        return String::new();
    }
    let mut lines: std::collections::BTreeMap<usize, (usize, Vec<String>)> = Default::default();
    for v in plan.vals.iter().filter(|v| !v.boolean && v.ty.bits > 32) {
        let e = lines.entry(v.line).or_default();
        e.0 += 1;
        if let Some(n) = &v.name {
            let f = format!("`{n}` Q({}, {})", v.ty, v.frac);
            if !e.1.contains(&f) {
                e.1.push(f);
            }
        }
    }
    let mut o = String::new();
    for (line, (n, names)) in &lines {
        let at = if *line == 0 {
            "a value".to_string()
        } else {
            format!("line {line}")
        };
        let _ = writeln!(
            o,
            "warning: {at} needs 64-bit arithmetic ({n} value(s){}), costly on {}: pin a \
             narrower format on its `let` (`#[q(i32, F)]` or a coarser `#[lsb(..)]`), claim a \
             tighter range (`#[range(LO, HI)]`), or apply a small constant factor first so that \
             the product keeps fewer fraction bits",
            if names.is_empty() {
                String::new()
            } else {
                format!(": {}", names.join(", "))
            },
            plan.target.name
        );
    }
    o
}

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

pub use crate::text::{bound, g, range_text, signal_range_text};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Target;

    /// A state computed from a `let` pinned to 4 fraction bits is off by up to an LSB of the
    /// `let` (1/16 = 6.25 % of the state's range): `check` warns, with the bound of the table
    /// and the `let` where it first exceeds 1 % of a range; with 24 fraction bits it does not.
    #[test]
    fn a_bound_above_one_percent_of_the_range_is_warned_with_where_it_grows() {
        let spec = |q: &str| {
            format!(
                "controller loose {{\n period 0.1 \"s\";\n input x: [0.0, 1.0];\n \
                 state s: [0.0, 1.0] = 0.0;\n output y: [0.0, 1.0];\n step {{\n #[q({q})]\n \
                 let c = x * 0.3;\n s = c;\n y = s;\n }}\n}}\n"
            )
        };
        let plan = crate::compile_str(&spec("i16, 4"), &Target::default()).unwrap();
        let r = check_report(&plan, "loose.qloop");
        let s = plan
            .prog
            .signals
            .iter()
            .position(|s| s.name == "s")
            .unwrap();
        let err = plan.summary[s].err;
        // 1/16 from the `let`'s floor, and the constant's quantisation on top.
        assert!(err > 0.0625 && err < 0.0625 + 1e-6, "{r}");
        let w = r
            .lines()
            .find(|l| l.starts_with("warning: `s` may be off by up to"))
            .unwrap_or_else(|| panic!("{r}"));
        assert!(
            w.contains(&format!("up to {} after one step", bound(err))),
            "{w}"
        );
        // The `let` statement starts at its attribute, line 7.
        assert!(w.contains("at `c` (line 7)"), "{w}");
        // `y` reads `s` after its store: the warning follows the load to `c`.
        let w = r
            .lines()
            .find(|l| l.starts_with("warning: `y` may be off by up to"))
            .unwrap_or_else(|| panic!("{r}"));
        assert!(w.contains("at `c` (line 7)"), "{w}");
        let r = check_report(
            &crate::compile_str(&spec("i32, 24"), &Target::default()).unwrap(),
            "loose.qloop",
        );
        assert!(!r.contains("may be off by"), "{r}");
    }

    /// A user's constant 6.25e-5 on a 16-bit input with LSB 1/32: half an LSB of the input
    /// alone let it be applied as 2^-14 (-2.34 %); it is now applied within 2^-10 of itself
    /// (checked here on the exact `m·2^-k` the step multiplies by), and the report prints that
    /// error and no warning. With a finer input it is applied finer still.
    #[test]
    fn a_small_constant_on_a_coarse_value_is_applied_within_a_tenth_of_a_percent() {
        for attr in ["", "#[lsb(1e-3)]"] {
            let src = format!(
                "controller kn {{\n period 0.1 \"s\";\n word 16;\n {attr} input n: [0.0, 1000.0];\n \
                 param KN: 6.25e-5;\n output y;\n step {{ y = n * KN; }}\n}}\n"
            );
            let plan = crate::compile_str(&src, &Target::default()).unwrap();
            let m = plan.mults.iter().find(|m| m.constant == 6.25e-5).unwrap();
            // m·2^-k - c, exactly: both are dyadic rationals of a few bits (6.25e-5 is not, so
            // compare c's f64, the value the spec's literal rounds to, scaled by 2^k).
            let scaled = 6.25e-5 * 2f64.powi(m.k);
            let rel = (m.m as f64 - scaled) / scaled;
            assert!(
                rel.abs() <= 1.0 / 1024.0,
                "{attr}: {}·2^-{} is {rel:e} off",
                m.m,
                m.k
            );
            let r = check_report(&plan, "kn.qloop");
            assert!(
                r.contains(&format!(
                    "x * KN = x * {}·2^-{} ({:+.2e} %)",
                    m.m,
                    m.k,
                    100.0 * rel
                )),
                "{r}"
            );
            assert!(!r.contains("warning: KN"), "{r}");
        }
        // The first user's case: a power in W (LSB 1/16 W) converted to kW was 0.71 % high.
        let src =
            "controller kw {\n period 0.01 \"s\";\n word 16;\n input p: [0.0, 2000.0] \"W\";\n \
                   output lim \"kW\";\n step { lim = convert(p, \"kW\"); }\n}\n";
        let plan = crate::compile_str(src, &Target::default()).unwrap();
        let m = plan.mults.iter().find(|m| m.constant == 1e-3).unwrap();
        let scaled = 1e-3 * 2f64.powi(m.k);
        assert!(
            ((m.m as f64 - scaled) / scaled).abs() <= 1.0 / 1024.0,
            "{}·2^-{}",
            m.m,
            m.k
        );
    }
}
