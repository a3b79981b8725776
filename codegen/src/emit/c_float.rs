//! Emits a spec's step in C `float` arithmetic: the floating-point baseline `qloop bench`
//! compares the fixed-point C step against.
//!
//! The semantics are those of the f64 reference controller ([`super::reference`]), in single
//! precision: inputs clamped to their declared ranges on entry, states (and ranged outputs)
//! saturated to their declared ranges on every write, each `let` one `const float` (rounded
//! like every other operation, never saturated), constants rounded once to the nearest `float` (the f64 value the checker folded,
//! then `as f32`), and `min`/`max` with the NaN rule of Rust's `f64::min`/`max` (a NaN
//! operand yields the other one). Values are physical (no scaling).
//!
//! API, with `NAME` the spec's controller name (files `NAME_f.h`, `NAME_f.c`):
//!
//! ```c
//! #define NAME_F_PERIOD_US 100000UL   /* uppercase NAME */
//! typedef struct NAME_f_inputs  { float fc; } NAME_f_inputs;     /* declaration order */
//! typedef struct NAME_f_outputs { float feed; } NAME_f_outputs;
//! typedef struct NAME_f_state   { float km; float kc; float u; } NAME_f_state;
//! void NAME_f_init(NAME_f_state *self);
//! void NAME_f_step(NAME_f_state *self, const NAME_f_inputs *in, NAME_f_outputs *out);
//! ```
//!
//! A vector or matrix is an array field (`float theta[2];`, `float P[2][2];`, row-major), read
//! and written element by element (`in->phi[0]`, `self->P[1][0]`); inside `step` each element
//! is a scalar local named as in the IR (`P_1_0`).
//!
//! C99 with no header at all and no library call (min, max and clamp are inline), no
//! `double` anywhere (literals carry the `f` suffix), so it compiles with
//! `gcc -std=c99 -Wall -Wextra -Werror -Wdouble-promotion` and links without libm. On a
//! core without an FPU (AVR, Cortex-M0/M3) every operation is a soft-float library call,
//! which is what the baseline is for. Floating-point contraction (FMA) is the compiler's
//! choice: GCC does not contract in the ISO modes (`-std=c99`), which matches the reference's
//! separate roundings; a `gnu` dialect may fuse `a*b + c` on an FPU that has FMA.

use crate::ir::{Cond, Expr, Program, SigId, SigKind, Stmt};
use std::fmt::Write;

/// Besides C99's keywords ([`super::c::C99_KEYWORDS`]): `<stdbool.h>`'s names, the names
/// `step` uses for its parameters and the inline helpers. A signal name that collides gets a
/// trailing underscore.
const RESERVED: [&str; 10] = [
    "bool",
    "true",
    "false",
    "self",
    "in",
    "out",
    "qloop_minf",
    "qloop_maxf",
    "qloop_clampf",
    "main",
];

/// The header and source of `prog`'s float step: `(NAME_f.h, NAME_f.c)`.
pub fn source(prog: &Program) -> (String, String) {
    (header(prog), body(prog))
}

/// A signal name as a C identifier (reserved names get a trailing underscore).
pub fn ident(name: &str) -> String {
    if super::c::C99_KEYWORDS.contains(&name) || RESERVED.contains(&name) {
        format!("{name}_")
    } else {
        name.to_string()
    }
}

/// A `float` literal: the nearest `float` to `v`, written so that C reads back exactly that
/// `float` (Rust prints the shortest decimal that round-trips), with the `f` suffix. Values
/// beyond the `float` range are clamped to `±FLT_MAX` (a constant that large has no useful
/// single-precision meaning; no seed spec comes near).
pub fn lit(v: f64) -> String {
    let x = (v as f32).clamp(-f32::MAX, f32::MAX);
    if x == 0.0 {
        return "0.0f".to_string();
    }
    let s = format!("{:e}f", x.abs());
    if x < 0.0 {
        format!("(-{s})")
    } else {
        s
    }
}

fn sig_ident(prog: &Program, id: SigId) -> String {
    ident(&prog.sig(id).name)
}

/// A signal as a field of the structs: `fc`, or `theta[0]`, `P[1][0]` for an element of a
/// vector or matrix.
pub fn field(prog: &Program, id: SigId) -> String {
    super::c::field_as(prog, id, ident)
}

fn declarator(prog: &Program, m: &super::Member) -> String {
    super::c::declarator_as(prog, m, ident)
}

fn ids(prog: &Program, k: SigKind) -> Vec<SigId> {
    prog.ids_of(k).collect()
}

/// Text safe inside a `/* */` comment.
fn safe(text: &str) -> String {
    text.replace("*/", "* /")
}

/// A comment block: every line prefixed with ` * `.
fn comment(text: &str) -> String {
    let mut o = String::from("/*\n");
    for l in text.lines() {
        if l.is_empty() {
            o.push_str(" *\n");
        } else {
            let _ = writeln!(o, " * {}", safe(l));
        }
    }
    o.push_str(" */\n");
    o
}

fn range_text(prog: &Program, id: SigId) -> String {
    let s = prog.sig(id);
    let unit = s.unit.as_deref().unwrap_or("");
    match s.range {
        Some((lo, hi)) => format!("[{lo}, {hi}] {unit}"),
        None => format!("unranged {unit}"),
    }
}

fn header(prog: &Program) -> String {
    let n = &prog.name;
    let up = n.to_uppercase();
    let mut doc = String::new();
    for l in &prog.docs {
        doc.push_str(l);
        doc.push('\n');
    }
    let _ = write!(
        doc,
        "\nGenerated by qloop {} from spec `{n}`: the same step in C `float` arithmetic\n\
         (the floating-point baseline of `qloop bench`; semantics of the f64 reference\n\
         controller, `qloop gen --lang rust-ref`, in single precision).\n\
         Physical values, no scaling. Sample period {} s.",
        env!("CARGO_PKG_VERSION"),
        prog.period
    );
    let mut o = comment(&doc);
    let _ = write!(
        o,
        "\n#ifndef QLOOP_{up}_F_H\n#define QLOOP_{up}_F_H\n\n\
         #ifdef __cplusplus\nextern \"C\" {{\n#endif\n\n\
         /* Sample period in microseconds. */\n#define {up}_F_PERIOD_US {}UL\n",
        (prog.period * 1e6).round() as u64
    );
    let strukt = |o: &mut String, kind: SigKind, what: &str, doc: &str| {
        let _ = writeln!(o, "\n/* {doc} */\ntypedef struct {n}_f_{what} {{");
        let fields = super::members(prog, kind);
        for m in &fields {
            // A vector's comment lists each element's range (they may differ).
            let range = match m {
                super::Member::Scalar(id) => range_text(prog, *id),
                super::Member::Group { ids, .. } => {
                    let each: Vec<String> = ids
                        .iter()
                        .map(|e| match prog.sig(*e).range {
                            Some((lo, hi)) => format!("{} [{lo}, {hi}]", prog.sig(*e).label()),
                            None => format!("{} unranged", prog.sig(*e).label()),
                        })
                        .collect();
                    let unit = prog.sig(ids[0]).unit.as_deref().unwrap_or("");
                    format!("{} {unit}", each.join(", "))
                }
            };
            let _ = writeln!(
                o,
                "    float {}; /* {}: {} */",
                declarator(prog, m),
                super::kind_name(kind),
                safe(&range)
            );
        }
        if fields.is_empty() {
            // C99 has no empty structs.
            let _ = writeln!(o, "    char unused_;");
        }
        let _ = writeln!(o, "}} {n}_f_{what};");
    };
    strukt(
        &mut o,
        SigKind::Input,
        "inputs",
        "Inputs of one step; each is clamped to its declared range inside step.",
    );
    strukt(&mut o, SigKind::Output, "outputs", "Outputs of one step.");
    strukt(
        &mut o,
        SigKind::State,
        "state",
        "The controller's states; keep one per controller instance.",
    );
    let _ = write!(
        o,
        "\n/* Sets the declared initial state. */\nvoid {n}_f_init({n}_f_state *self);\n\n\
         /* One control period: reads the inputs, updates the state, writes the outputs. */\n\
         void {n}_f_step({n}_f_state *self, const {n}_f_inputs *in, {n}_f_outputs *out);\n\n\
         #ifdef __cplusplus\n}}\n#endif\n\n#endif /* QLOOP_{up}_F_H */\n"
    );
    o
}

fn body(prog: &Program) -> String {
    let n = &prog.name;
    let (inputs, states, outputs) = (
        ids(prog, SigKind::Input),
        ids(prog, SigKind::State),
        ids(prog, SigKind::Output),
    );
    let mut o = comment(&format!(
        "{n}: float step, generated by qloop {}. Do not edit: change the spec and\n\
         regenerate. No library calls, no double.",
        env!("CARGO_PKG_VERSION")
    ));
    let _ = write!(
        o,
        "\n#include \"{n}_f.h\"\n\n\
         /* min and max as Rust's f32::min/max: a NaN operand yields the other one. */\n\
         static inline float qloop_minf(float a, float b) {{ return (a < b || b != b) ? a : b; }}\n\
         static inline float qloop_maxf(float a, float b) {{ return (a > b || b != b) ? a : b; }}\n\
         /* Saturation to [lo, hi]: max first, then min, as the reference. */\n\
         static inline float qloop_clampf(float x, float lo, float hi)\n\
         {{\n    return qloop_minf(qloop_maxf(x, lo), hi);\n}}\n\n"
    );
    o.push_str(&table_fns(prog));

    let _ = writeln!(o, "void {n}_f_init({n}_f_state *self)\n{{");
    for id in &states {
        let init = prog.sig(*id).init.unwrap_or(0.0);
        let _ = writeln!(o, "    self->{} = {};", field(prog, *id), lit(init));
    }
    if states.is_empty() {
        let _ = writeln!(o, "    self->unused_ = 0;");
    }
    let _ = writeln!(o, "}}\n");

    let _ = writeln!(
        o,
        "void {n}_f_step({n}_f_state *self, const {n}_f_inputs *in, {n}_f_outputs *out)\n{{"
    );
    if states.is_empty() {
        let _ = writeln!(o, "    (void)self;");
    }
    if inputs.is_empty() {
        let _ = writeln!(o, "    (void)in;");
    }
    let mut read = vec![false; prog.signals.len()];
    reads_block(&prog.body, &mut read);
    for id in &inputs {
        let v = sat(prog, *id, format!("in->{}", field(prog, *id)));
        let name = sig_ident(prog, *id);
        let _ = writeln!(
            o,
            "    const float {name} = {v};{}",
            unused(prog, &read, *id)
        );
    }
    for id in &states {
        let (name, path) = (sig_ident(prog, *id), field(prog, *id));
        let _ = writeln!(o, "    float {name} = self->{path};");
    }
    for id in &outputs {
        let _ = writeln!(o, "    float {} = 0.0f;", sig_ident(prog, *id));
    }
    block(prog, &prog.body, &read, 1, &mut o);
    for id in &states {
        let (name, path) = (sig_ident(prog, *id), field(prog, *id));
        let _ = writeln!(o, "    self->{path} = {name};");
    }
    for id in &outputs {
        let (name, path) = (sig_ident(prog, *id), field(prog, *id));
        let _ = writeln!(o, "    out->{path} = {name};");
    }
    if outputs.is_empty() {
        let _ = writeln!(o, "    out->unused_ = 0;");
    }
    let _ = writeln!(o, "}}");
    o
}

/// `e` saturated to the declared range of `id`, if it has one.
fn sat(prog: &Program, id: SigId, e: String) -> String {
    match prog.sig(id).range {
        Some((lo, hi)) => format!("qloop_clampf({e}, {}, {})", lit(lo), lit(hi)),
        None => e,
    }
}

/// ` (void)name;` for a value the body never reads (an input or `let` the spec does not use
/// would otherwise trip `-Wunused-variable`), else nothing.
fn unused(prog: &Program, read: &[bool], id: SigId) -> String {
    if read[id.0] {
        String::new()
    } else {
        format!(" (void){};", sig_ident(prog, id))
    }
}

/// Marks every signal a statement list reads.
fn reads_block(stmts: &[Stmt], read: &mut [bool]) {
    for s in stmts {
        match s {
            Stmt::Assign { value, .. } => reads_expr(value, read),
            Stmt::If { cond, then, els } => {
                reads_cond(cond, read);
                reads_block(then, read);
                reads_block(els, read);
            }
        }
    }
}

fn reads_expr(e: &Expr, read: &mut [bool]) {
    match e {
        Expr::Const { .. } => {}
        Expr::Var(id, _) => read[id.0] = true,
        Expr::Neg(a) => reads_expr(a, read),
        Expr::Add(a, b)
        | Expr::Sub(a, b)
        | Expr::Mul(a, b, _)
        | Expr::Min(a, b)
        | Expr::Max(a, b) => {
            reads_expr(a, read);
            reads_expr(b, read);
        }
        Expr::Table(_, a, _) => reads_expr(a, read),
        Expr::Select(c, a, b) => {
            reads_cond(c, read);
            reads_expr(a, read);
            reads_expr(b, read);
        }
    }
}

fn reads_cond(c: &Cond, read: &mut [bool]) {
    match c {
        Cond::Cmp(_, a, b) => {
            reads_expr(a, read);
            reads_expr(b, read);
        }
        Cond::And(a, b) | Cond::Or(a, b) => {
            reads_cond(a, read);
            reads_cond(b, read);
        }
        Cond::Not(a) => reads_cond(a, read),
    }
}

fn block(prog: &Program, stmts: &[Stmt], read: &[bool], depth: usize, o: &mut String) {
    let pad = "    ".repeat(depth);
    for s in stmts {
        match s {
            Stmt::Assign { target, value, .. } => {
                let sig = prog.sig(*target);
                let name = ident(&sig.name);
                let v = expr(prog, value);
                if sig.kind == SigKind::Local {
                    let _ = writeln!(
                        o,
                        "{pad}const float {name} = {v};{}",
                        unused(prog, read, *target)
                    );
                } else {
                    let _ = writeln!(o, "{pad}{name} = {};", sat(prog, *target, v));
                }
            }
            Stmt::If { cond: c, then, els } => {
                let _ = writeln!(o, "{pad}if ({}) {{", cond(prog, c));
                block(prog, then, read, depth + 1, o);
                if els.is_empty() {
                    let _ = writeln!(o, "{pad}}}");
                } else {
                    let _ = writeln!(o, "{pad}}} else {{");
                    block(prog, els, read, depth + 1, o);
                    let _ = writeln!(o, "{pad}}}");
                }
            }
        }
    }
}

fn expr(prog: &Program, e: &Expr) -> String {
    let x = |e: &Expr| expr(prog, e);
    match e {
        Expr::Const { value, .. } => lit(*value),
        Expr::Var(id, _) => sig_ident(prog, *id),
        Expr::Neg(a) => format!("(-{})", x(a)),
        Expr::Add(a, b) => format!("({} + {})", x(a), x(b)),
        Expr::Sub(a, b) => format!("({} - {})", x(a), x(b)),
        Expr::Mul(a, b, _) => format!("({} * {})", x(a), x(b)),
        Expr::Min(a, b) => format!("qloop_minf({}, {})", x(a), x(b)),
        Expr::Max(a, b) => format!("qloop_maxf({}, {})", x(a), x(b)),
        // Pure operands: evaluating one arm is the same as evaluating both and selecting.
        Expr::Select(c, a, b) => format!("(({}) ? {} : {})", cond(prog, c), x(a), x(b)),
        Expr::Table(t, a, _) => format!("{}_table_{t}({})", prog.name, x(a)),
    }
}

/// Each table as its samples (float) and the interpolation of `ir::Table::eval`.
fn table_fns(prog: &Program) -> String {
    let mut o = String::new();
    for (i, t) in prog.tables.iter().enumerate() {
        let n = &prog.name;
        let vals: Vec<String> = t.samples.iter().map(|v| lit(*v)).collect();
        let _ = write!(
            o,
            "/* Table `{}`: linear interpolation of its samples over [{}, {}], step {}. */\n\
             static const float {n}_samples_{i}[{}] = {{ {} }};\n\
             static inline float {n}_table_{i}(float x)\n{{\n\
             \x20   x = qloop_minf(qloop_maxf(x, {lo}), {hi});\n\
             \x20   float u = (x - {lo}) * {inv};\n\
             \x20   unsigned i = (unsigned)u;\n\
             \x20   if (i > {last}u) i = {last}u;\n\
             \x20   float t = u - (float)i;\n\
             \x20   return {n}_samples_{i}[i] + t * ({n}_samples_{i}[i + 1u] - {n}_samples_{i}[i]);\n}}\n\n",
            safe(&t.name),
            crate::text::g(t.lo),
            crate::text::g(t.hi),
            crate::text::g(t.step),
            t.samples.len(),
            vals.join(", "),
            lo = lit(t.lo),
            hi = lit(t.hi),
            inv = lit(1.0 / t.step),
            last = t.segments() - 1,
        );
    }
    o
}

fn cond(prog: &Program, c: &Cond) -> String {
    match c {
        Cond::Cmp(op, a, b) => format!("{} {} {}", expr(prog, a), op.symbol(), expr(prog, b)),
        Cond::And(a, b) => format!("({}) && ({})", cond(prog, a), cond(prog, b)),
        Cond::Or(a, b) => format!("({}) || ({})", cond(prog, a), cond(prog, b)),
        Cond::Not(a) => format!("!({})", cond(prog, a)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_round_trip_to_the_nearest_float() {
        for v in [
            0.15,
            1.5,
            -0.2083,
            1e-30,
            4.228419205480031e-3,
            1.0,
            100.0,
            -0.0,
        ] {
            let s = lit(v);
            let digits = s.trim_start_matches("(-").trim_end_matches(')');
            let digits = digits.strip_suffix('f').expect("f suffix");
            let back: f32 = digits.parse().expect("a number");
            let back = if s.starts_with("(-") { -back } else { back };
            assert_eq!(back, v as f32, "{v} -> {s}");
        }
        assert_eq!(lit(1e300), format!("{:e}f", f32::MAX));
    }

    #[test]
    fn reserved_names_are_renamed() {
        assert_eq!(ident("in"), "in_");
        assert_eq!(ident("float"), "float_");
        assert_eq!(ident("km"), "km");
    }
}
