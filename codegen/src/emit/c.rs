//! Emits the fixed-point controller as a C99 `.h`/`.c` pair.
//!
//! The C reads the same plan as the Rust emitter, operation for operation, so the two compute
//! the same raw integers. What C needs beyond Rust:
//!
//! * **No undefined behaviour.** Every intermediate's range is proved to fit its type, so no
//!   signed overflow happens. A left shift of a negative value is undefined in C (C99
//!   6.5.7p4), so `a << k` is emitted as a multiply by the constant `2^k`, which compilers
//!   turn back into a shift (a power-of-two multiply is always a shift in GCC's and LLVM's
//!   expanders); the result passes through `QLOOP_KEEP`, an empty `asm` that hides it from
//!   the optimiser, so GCC cannot fold `x·4 + x` into `x·5`, a general multiply that is a
//!   library call on AVR and slow-multiplier Cortex-M0. A right shift of a negative value is implementation-defined (6.5.7p5); GCC,
//!   Clang and every compiler qloop targets shift arithmetically (GCC manual, "Integers
//!   implementation"), and a file-scope check refuses to compile anywhere else.
//! * **Integer promotion.** Every operation is written on operands of one type and its result
//!   cast back to that type, so an `int16_t` sum on a 32-bit host (computed in `int`) or a
//!   product on AVR (16-bit `int`) gives the value the plan proved.
//! * **Shifts on cores without a barrel shifter** (AVR): GCC shifts a multi-byte value one bit
//!   per loop iteration, so `x >> 14` on an `int32_t` costs about 100 cycles. A shift by
//!   `8q + r` is written as a whole-byte shift (register moves) and an `r`-bit one, or, where
//!   the proved range leaves room, as an `8 − r`-bit shift the other way and `q + 1` bytes
//!   (`(x · 4) >> 16` for `x >> 14`); see `byte_split`. Exact either way.
//! * **Only `<stdint.h>` and `<stdbool.h>`**: no division, no floating point, no libc call.
//!
//! Vectors and matrices (`state theta[2]`, `state P[2][2]`) are arrays in the structs
//! (`int32_t theta[2];`, `int32_t P[2][2];`, row-major), read and written element by element
//! (`self->P[1][0]`); inside `step` every element is a scalar local named as in the plan
//! (`P_1_0`). Macros: one `NAME_THETA_FRAC` per vector whose elements share a format, else a
//! `_FRAC` per element with its indices after `FRAC` (`NAME_THETA_FRAC_0`, `NAME_P_FRAC_1_0`),
//! and `_MIN`/`_MAX` per element, named after the element's generated name (`NAME_THETA_0_MIN`,
//! `NAME_P_1_0_MAX`). An element's `_FRAC` is not named after the element, so a vector `a_0`
//! (`NAME_A_0_FRAC`) and the element `a[0]` (`NAME_A_0_MIN`) do not collide, and the checker
//! refuses a signal named like another's element (`a_0_0` beside `a[2][2]`). As for scalars,
//! names that differ only in case give the same macros. A vector whose elements differ in type
//! is one array of the widest (`int32_t theta[2]` for an `i16` and an `i32` element), each
//! element's raw value in its own format (the book's "Vectors' formats").
//!
//! Frama-C: `step` carries an ACSL contract (valid pointers, each state inside its
//! saturation bounds on entry and on exit). Under `__FRAMAC__` the `.c` file also defines an
//! analysis entry point, `NAME_eva_main`, which calls `step` once on every state in range and
//! every raw input value, so `frama-c -eva -main NAME_eva_main` proves the step free of
//! run-time errors for all of them (with `-eva-split-limit 257` where a table's differences
//! are read from its samples: see `compact_pairs`; the entry's comment says so).

use super::Member;
use crate::ir::{Program, SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use crate::qformat::IntTy;
use qloop_core::emit::repeat::{self, Emit, Param, Repeat, Row, Sync};
use std::collections::HashMap;
use std::fmt::Write;

mod wide;

/// C99's keywords (C99 6.4.1; the `_Bool`-style ones cannot collide with a spec name that
/// does not start with `_`). Every C emitter renames a spec name that is one.
pub const C99_KEYWORDS: [&str; 34] = [
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while",
];

/// Besides the keywords: `<stdbool.h>`'s names and the parameters of `step`. A spec name that
/// collides gets a trailing underscore.
const RESERVED: [&str; 6] = ["bool", "true", "false", "self", "in", "out"];

/// The header and source files of `plan`'s controller: `(NAME.h, NAME.c)`.
pub fn files(plan: &Plan) -> (String, String) {
    (header(plan), source(plan))
}

/// A spec name as a C identifier.
pub fn ident(name: &str) -> String {
    if C99_KEYWORDS.contains(&name) || RESERVED.contains(&name) {
        format!("{name}_")
    } else {
        name.to_string()
    }
}

/// A signal as a field of the generated structs: `fc`, or `theta[0]`, `P[1][0]` for an element
/// of a vector or matrix (the struct holds the whole vector as one array).
pub fn field(prog: &Program, id: SigId) -> String {
    field_as(prog, id, ident)
}

/// [`field`] with the names made C identifiers by `name` (the float C has its own reserved
/// names).
pub fn field_as(prog: &Program, id: SigId, name: fn(&str) -> String) -> String {
    let s = prog.sig(id);
    match &s.elem {
        None => name(&s.name),
        Some(e) => {
            let mut f = name(&e.group);
            for i in &e.index {
                let _ = write!(f, "[{i}]");
            }
            f
        }
    }
}

/// A struct field's declarator: `fc`, `theta[2]`, `P[2][2]`.
pub fn declarator(prog: &Program, m: &Member) -> String {
    declarator_as(prog, m, ident)
}

/// [`declarator`] with the names made C identifiers by `name`.
pub fn declarator_as(prog: &Program, m: &Member, name: fn(&str) -> String) -> String {
    let mut d = name(m.name(prog));
    for n in m.dims() {
        let _ = write!(d, "[{n}]");
    }
    d
}

/// `int16_t`, `uint32_t`, ...
pub fn c_ty(t: IntTy) -> String {
    format!("{}int{}_t", if t.signed { "" } else { "u" }, t.bits)
}

/// A constant of type `ty`: `((int32_t)-123)`, or `INT64_MIN` where the literal itself would
/// not be a valid constant.
pub fn c_lit(v: i128, ty: IntTy) -> String {
    if ty.signed && v == ty.min() {
        return format!("INT{}_MIN", ty.bits);
    }
    let suffix = if ty.signed { "" } else { "u" };
    if v < 0 {
        format!("(({})-{}{suffix})", c_ty(ty), v.unsigned_abs())
    } else {
        format!("(({}){v}{suffix})", c_ty(ty))
    }
}

/// `e`, an expression of signal `id`'s storage type holding a value within its bounds, as the
/// signal's own type (a cast where it is stored in a wider word; exact).
fn from_storage(plan: &Plan, id: SigId, e: &str) -> String {
    let ty = plan.format(id).ty;
    if plan.storage_ty(id) == ty {
        e.to_string()
    } else {
        format!("({}){e}", c_ty(ty))
    }
}

/// `_1_0` for element `P[1][0]`: the indices of element `id`, for its `_FRAC` macro.
fn index_suffix(prog: &Program, id: SigId) -> String {
    prog.sig(id)
        .elem
        .iter()
        .flat_map(|e| e.index.iter())
        .map(|i| format!("_{i}"))
        .collect()
}

fn upper(plan: &Plan) -> String {
    plan.prog.name.to_uppercase()
}

fn ids(plan: &Plan, k: SigKind) -> Vec<SigId> {
    plan.prog.ids_of(k).collect()
}

/// A comment block: every line prefixed with ` * `.
fn comment(text: &str) -> String {
    let mut o = String::from("/*\n");
    for l in text.lines() {
        let l = l.replace("*/", "* /");
        if l.is_empty() {
            o.push_str(" *\n");
        } else {
            let _ = writeln!(o, " * {l}");
        }
    }
    o.push_str(" */\n");
    o
}

fn header(plan: &Plan) -> String {
    let p = &plan.prog;
    let (n, up) = (&p.name, upper(plan));
    let mut o = comment(&super::module_doc(plan, "fixed-point controller, C99"));
    let _ = write!(
        o,
        "\n#ifndef QLOOP_{up}_H\n#define QLOOP_{up}_H\n\n#include <stdint.h>\n\n\
         #ifdef __cplusplus\nextern \"C\" {{\n#endif\n\n"
    );
    let _ = writeln!(o, "/* Sample period in microseconds. */");
    let _ = writeln!(
        o,
        "#define {up}_PERIOD_US {}UL\n",
        (p.period * 1e6).round() as u64
    );
    let _ = writeln!(
        o,
        "/* Fixed-point formats (raw = value * 2^FRAC) and raw saturation bounds. */"
    );
    let kinds = [SigKind::Input, SigKind::State, SigKind::Output];
    let groups: Vec<Member> = kinds
        .iter()
        .flat_map(|k| super::members(p, *k))
        .filter(|m| matches!(m, Member::Group { .. }))
        .collect();
    let mixed = groups.iter().find(|m| !m.uniform(plan));
    if let Some(g) = groups.iter().find(|m| m.uniform(plan)) {
        // The example: the last element of a vector with bounds (an unranged output has none).
        let last = |g: &Member| g.ids()[g.ids().len() - 1];
        let ranged = groups.iter().find(|g| plan.raw_bounds(last(g)).is_some());
        let e = ranged.map(|g| p.sig(last(g)));
        let which = if mixed.is_some() {
            "A vector or matrix whose elements share a format has one FRAC"
        } else {
            "A vector or matrix has one FRAC (its elements share a format)"
        };
        let _ = writeln!(
            o,
            "/* {which} and MIN/MAX per\n\
             \x20* element, named after the element: {up}_{}_FRAC{}. */",
            g.name(p).to_uppercase(),
            e.map(|e| format!(", {up}_{}_MIN for {}", e.name.to_uppercase(), e.label()))
                .unwrap_or_default()
        );
    }
    if let Some(m) = mixed {
        let last = m.ids()[m.ids().len() - 1];
        let idx = index_suffix(p, last);
        let _ = writeln!(
            o,
            "/* A vector whose elements differ in format has a FRAC per element, its indices\n\
             \x20* after FRAC ({up}_{}_FRAC{idx} for {}), MIN/MAX per element, and each element\n\
             \x20* stored in its own format in an array of the widest element's type. */",
            m.name(p).to_uppercase(),
            p.sig(last).label()
        );
    }
    for k in kinds {
        for m in super::members(p, k) {
            let mu = m.name(p).to_uppercase();
            let shared = m.uniform(plan);
            if shared {
                let _ = writeln!(o, "#define {up}_{mu}_FRAC {}", plan.format(m.first()).frac);
            }
            for id in m.ids() {
                let q = plan.format(id);
                if !shared {
                    let idx = index_suffix(p, id);
                    let _ = writeln!(o, "#define {up}_{mu}_FRAC{idx} {}", q.frac);
                }
                if let Some((lo, hi)) = plan.raw_bounds(id) {
                    let su = p.sig(id).name.to_uppercase();
                    let _ = writeln!(o, "#define {up}_{su}_MIN {}", c_lit(lo, q.ty));
                    let _ = writeln!(o, "#define {up}_{su}_MAX {}", c_lit(hi, q.ty));
                }
            }
        }
    }
    let _ = writeln!(
        o,
        "\n/* Compiled-in parameters (physical values; changing one means regenerating). */"
    );
    for c in p.constants.iter().filter(|c| c.is_param) {
        let _ = writeln!(
            o,
            "#define {up}_PARAM_{} {:e} /* {} */",
            c.name.to_uppercase(),
            c.value,
            c.unit.as_deref().unwrap_or("")
        );
    }
    let strukt = |o: &mut String, kind: SigKind, what: &str, doc: &str| {
        let _ = writeln!(o, "\n/* {doc} */\ntypedef struct {n}_{what} {{");
        let fields = super::members(p, kind);
        for m in &fields {
            let id = m.first();
            let s = p.sig(id);
            let sm = &plan.summary[id.0];
            // A vector's comment lists each element's range (they may differ), and each
            // element's format where those differ.
            let shared = m.uniform(plan);
            let range = match m {
                Member::Scalar(_) => crate::text::signal_range_text(plan, id),
                Member::Group { ids, .. } => ids
                    .iter()
                    .map(|e| {
                        let r = crate::text::signal_range_text(plan, *e);
                        let q = if shared {
                            String::new()
                        } else {
                            format!(" {}", plan.format(*e))
                        };
                        format!("{} {r}{q}", p.sig(*e).label())
                    })
                    .collect::<Vec<_>>()
                    .join(", "),
            };
            let fmt = if shared {
                format!(", {}", sm.format)
            } else {
                String::new()
            };
            let _ = writeln!(
                o,
                "    {} {}; /* {}: {} {}{fmt} */",
                c_ty(plan.storage_ty(id)),
                declarator(p, m),
                super::kind_name(kind),
                range,
                s.unit.as_deref().unwrap_or(""),
            );
        }
        if fields.is_empty() {
            // C99 has no empty structs.
            let _ = writeln!(o, "    uint8_t unused_;");
        }
        let _ = writeln!(o, "}} {n}_{what};");
    };
    strukt(
        &mut o,
        SigKind::Input,
        "inputs",
        "Raw inputs of one step; each is clamped to its declared range inside step.",
    );
    strukt(
        &mut o,
        SigKind::Output,
        "outputs",
        "Raw outputs of one step.",
    );
    strukt(
        &mut o,
        SigKind::State,
        "state",
        "The controller's states (raw); keep one per controller instance.",
    );
    let _ = write!(
        o,
        "\n/* Sets the declared initial state. */\nvoid {n}_init({n}_state *self);\n\n\
         /* One control period: reads the inputs, updates the state, writes the outputs.\n\
         \x20* States must lie within their _MIN/_MAX bounds (init and step keep them there). */\n\
         void {n}_step({n}_state *self, const {n}_inputs *in, {n}_outputs *out);\n\n\
         #ifdef __cplusplus\n}}\n#endif\n\n#endif /* QLOOP_{up}_H */\n"
    );
    o
}

fn source(plan: &Plan) -> String {
    format!("{}{}", body(plan, true), eva_entry(plan))
}

/// The controller as one C unit, for pasting into another file (the LinuxCNC component):
/// `NAME.h`, then `NAME.c` without its `#include "NAME.h"` and without the Frama-C entry
/// point (an analysis harness, not part of the controller).
pub fn single_unit(plan: &Plan) -> String {
    format!("{}\n{}", header(plan), body(plan, false))
}

/// `NAME.c` up to the end of `step`; `include`: with its `#include "NAME.h"`.
fn body(plan: &Plan, include: bool) -> String {
    // The step's shared loop bodies, and the plan with their values' hulled intervals: the
    // whole unit is emitted from it (it differs from `plan` only in those intervals).
    let em = repeat::emit(plan);
    let plan = &em.plan;
    let p = &plan.prog;
    let (n, up) = (&p.name, upper(plan));
    let states = ids(plan, SigKind::State);
    let outputs = ids(plan, SigKind::Output);
    let mut o = comment(&format!(
        "{n}: fixed-point step, generated by qloop {} (target `{}`). Do not edit.\n\
         No division, no floating point, no library calls; every intermediate's range is\n\
         proved to fit its type. See the header for formats.",
        env!("CARGO_PKG_VERSION"),
        plan.target.name
    ));
    let inc = if include {
        format!("#include \"{n}.h\"\n")
    } else {
        String::new()
    };
    let _ = write!(
        o,
        "\n{inc}#include <stdbool.h>\n\n\
         /* Right shifts of negative values must be arithmetic (floor); C leaves it to the\n\
         \x20* implementation, GCC and Clang define it so. Refuse to compile otherwise. */\n\
         typedef char qloop_{n}_arithmetic_shift_check[((-8) >> 1) == -4 ? 1 : -1];\n\n\
         /* GCC and Clang fold `(x << 2) + x` back into `x * 5`, which on a core without a fast\n\
         \x20* multiplier is a library call (__mulhisi3, __aeabi_lmul). QLOOP_KEEP hides a\n\
         \x20* shifted term from that folding: an empty asm that claims to modify it. It emits\n\
         \x20* no instruction. Other compilers (and Frama-C) see a no-op. */\n\
         #ifndef QLOOP_KEEP\n\
         #if defined(__GNUC__) && !defined(__FRAMAC__)\n\
         #define QLOOP_KEEP(x) __asm__(\"\" : \"+r\"(x))\n\
         #else\n\
         #define QLOOP_KEEP(x) ((void)(x))\n\
         #endif\n\
         #endif\n\n"
    );
    if wide::used(plan) {
        o.push_str(&wide::HELPERS.replace("qloop_", &format!("qloop_{n}_")));
    }
    if wide::multiplies(plan) {
        o.push_str(&wide::product_helper().replace("qloop_", &format!("qloop_{n}_")));
    }
    if wide::high_products(plan) {
        o.push_str(&wide::high_product_helper().replace("qloop_", &format!("qloop_{n}_")));
    }
    o.push_str(&table_arrays(plan));
    for (k, r) in em.repeats.iter().enumerate() {
        o.push_str(&loop_fn(plan, k, r));
    }
    let _ = writeln!(o, "void {n}_init({n}_state *self)\n{{");
    for id in &states {
        let _ = writeln!(
            o,
            "    self->{} = {};",
            field(p, *id),
            c_lit(plan.raw_init(*id), plan.storage_ty(*id))
        );
    }
    if states.is_empty() {
        let _ = writeln!(o, "    self->unused_ = 0u;");
    }
    let _ = writeln!(o, "}}\n");

    // ACSL contract: pointers valid and apart, states within bounds before and after.
    let mut acsl = String::from(
        "/*@ requires \\valid(self) && \\valid_read(in) && \\valid(out);\n    \
         requires \\separated(self, in, out);\n",
    );
    let mut ens = String::new();
    for id in &states {
        if plan.raw_bounds(*id).is_some() {
            let su = p.sig(*id).name.to_uppercase();
            let f = field(p, *id);
            let _ = writeln!(
                acsl,
                "    requires {up}_{su}_MIN <= self->{f} <= {up}_{su}_MAX;"
            );
            let _ = writeln!(
                ens,
                "    ensures {up}_{su}_MIN <= self->{f} <= {up}_{su}_MAX;"
            );
        }
    }
    for id in &outputs {
        if plan.raw_bounds(*id).is_some() {
            let su = p.sig(*id).name.to_uppercase();
            let f = field(p, *id);
            let _ = writeln!(
                ens,
                "    ensures {up}_{su}_MIN <= out->{f} <= {up}_{su}_MAX;"
            );
        }
    }
    let _ = write!(o, "{acsl}    assigns *self, *out;\n{ens}*/\n");
    let _ = writeln!(
        o,
        "void {n}_step({n}_state *self, const {n}_inputs *in, {n}_outputs *out)\n{{"
    );
    // A controller without states, or whose step reads no input, still takes both pointers
    // (one signature for every controller); say that they are unused on purpose.
    if states.is_empty() {
        let _ = writeln!(o, "    (void)self;");
    }
    if !plan.vals.iter().any(|v| matches!(v.op, Op::Input(_))) {
        let _ = writeln!(o, "    (void)in;");
    }
    let sync = em.sync();
    for id in states.iter().filter(|s| !sync.unnamed.contains(s)) {
        let (f, path) = (ident(&p.sig(*id).name), field(p, *id));
        let v = from_storage(plan, *id, &format!("self->{path}"));
        let _ = writeln!(o, "    {} {f} = {v};", c_ty(plan.format(*id).ty));
    }
    for id in &outputs {
        let f = ident(&p.sig(*id).name);
        let _ = writeln!(o, "    {} {f} = 0;", c_ty(plan.format(*id).ty));
    }
    let mut i = 0;
    while i < plan.body.len() {
        match em.repeats.iter().position(|r| r.start == i) {
            Some(k) => {
                loop_call(&em, &sync, k, &mut o);
                i = em.repeats[k].run().end;
            }
            None => {
                // The statements up to the next loop, as one list.
                let j = em
                    .repeats
                    .iter()
                    .map(|r| r.start)
                    .filter(|&s| s > i)
                    .min()
                    .unwrap_or(plan.body.len());
                block(plan, &plan.body[i..j], 1, &mut o);
                i = j;
            }
        }
    }
    for id in states.iter().filter(|s| !sync.current.contains(s)) {
        let (f, path) = (ident(&p.sig(*id).name), field(p, *id));
        let _ = writeln!(o, "    self->{path} = {f};");
    }
    for id in &outputs {
        let (f, path) = (ident(&p.sig(*id).name), field(p, *id));
        let _ = writeln!(o, "    out->{path} = {f};");
    }
    if outputs.is_empty() {
        let _ = writeln!(o, "    out->unused_ = 0u;");
    }
    let _ = writeln!(o, "}}");
    o
}

/// The Frama-C Eva entry point: `step` from every in-range state and every raw input.
fn eva_entry(plan: &Plan) -> String {
    let p = &plan.prog;
    let n = &p.name;
    let states = ids(plan, SigKind::State);
    let inputs = ids(plan, SigKind::Input);
    let mut o = String::new();
    // A table read compactly splits its index over up to 257 values (`compact_pairs`).
    let split = if super::table_layouts(plan).iter().any(|l| l.saved > 0) {
        " -eva-split-limit 257"
    } else {
        ""
    };
    let _ = write!(
        o,
        "\n#ifdef __FRAMAC__\n#include \"__fc_builtin.h\"\n\n\
         /* Analysis entry for `frama-c -eva{split} -main {n}_eva_main`: one step from every state\n\
         \x20* inside its bounds and every raw input value. */\n\
         void {n}_eva_main(void)\n{{\n    {n}_state s;\n    {n}_inputs i;\n    {n}_outputs o;\n"
    );
    for id in &states {
        let ty = plan.storage_ty(*id);
        let (lo, hi) = plan.bounds(*id);
        let _ = writeln!(
            o,
            "    s.{} = ({}){};",
            field(p, *id),
            c_ty(ty),
            eva_interval(ty, lo, hi)
        );
    }
    if states.is_empty() {
        let _ = writeln!(o, "    s.unused_ = 0u;");
    }
    for id in &inputs {
        let ty = plan.storage_ty(*id);
        let _ = writeln!(
            o,
            "    i.{} = ({}){};",
            field(p, *id),
            c_ty(ty),
            eva_interval(ty, ty.min(), ty.max())
        );
    }
    if inputs.is_empty() {
        let _ = writeln!(o, "    i.unused_ = 0u;");
    }
    let _ = writeln!(o, "    {n}_step(&s, &i, &o);\n}}\n#endif /* __FRAMAC__ */");
    o
}

/// A Frama-C builtin call giving any value in `[lo, hi]` of a `ty` value (through `long long`,
/// which holds every type qloop stores, whatever the width of `int`).
fn eva_interval(ty: IntTy, lo: i128, hi: i128) -> String {
    if !ty.signed && ty.bits == 64 {
        let u = IntTy::unsigned(64);
        return format!(
            "Frama_C_unsigned_long_long_interval({}, {})",
            c_lit(lo, u),
            c_lit(hi, u)
        );
    }
    let w = IntTy::signed(64);
    format!(
        "Frama_C_long_long_interval({}, {})",
        c_lit(lo, w),
        c_lit(hi, w)
    )
}

/// The name of the function of shared loop body `k`.
fn loop_name(plan: &Plan, k: usize) -> String {
    format!("{}_loop_{k}", plan.prog.name)
}

/// A row's parameter: `int32_t thf[5]`, `int32_t P[5][5]`, or `int32_t *t0` for a row that
/// is one element.
fn row_param(plan: &Plan, r: &Row) -> String {
    let ty = c_ty(plan.storage_ty(r.elems[0]));
    let g = ident(&r.group);
    if r.dims.len() == 1 {
        return format!("{ty} *{g}");
    }
    let mut d = format!("{ty} {g}");
    for n in &r.dims[1..] {
        let _ = write!(d, "[{n}]");
    }
    d
}

/// Element `s` (of the first copy) of row `r`, read through the row's parameter.
fn row_elem(plan: &Plan, r: &Row, s: SigId) -> String {
    let g = ident(&r.group);
    let Some(e) = &plan.prog.sig(s).elem else {
        return g;
    };
    if e.index.len() == 1 {
        return format!("(*{g})");
    }
    let mut x = g;
    for i in &e.index[1..] {
        let _ = write!(x, "[{i}]");
    }
    x
}

/// Shared loop body `k` as a `static` function: the first copy's statements on the rows of
/// the state it is called with (see [`repeat`]).
fn loop_fn(plan: &Plan, k: usize, r: &Repeat) -> String {
    let p = &plan.prog;
    let mut params: Vec<String> = Vec::new();
    params.extend(r.rows.iter().map(|row| row_param(plan, row)));
    for q in &r.params {
        params.push(match *q {
            Param::Val(v) => {
                let val = plan.val(v);
                let ty = if val.boolean {
                    "bool".to_string()
                } else {
                    c_ty(val.ty)
                };
                format!("const {ty} {}", name(plan, v))
            }
            Param::Sig(s) => format!(
                "const {} {}",
                c_ty(plan.format(s).ty),
                ident(&p.sig(s).name)
            ),
        });
    }
    if params.is_empty() {
        params.push("void".into());
    }
    let mut o = comment(&format!(
        "Lines {}-{} of the spec, the body of a `for` loop, once for its {} indices: step calls\n\
         it on row l of each state it updates. Its values' intervals are the hull of every\n\
         index's.",
        r.lines.0, r.lines.1, r.count
    ));
    let _ = writeln!(
        o,
        "static void {}({})\n{{",
        loop_name(plan, k),
        params.join(", ")
    );
    for row in &r.rows {
        for s in &row.elems {
            let _ = writeln!(
                o,
                "    {} {} = {};",
                c_ty(plan.format(*s).ty),
                ident(&p.sig(*s).name),
                from_storage(plan, *s, &row_elem(plan, row, *s))
            );
        }
    }
    block(plan, r.body(plan), 1, &mut o);
    for row in &r.rows {
        for s in &row.stored {
            let _ = writeln!(
                o,
                "    {} = {};",
                row_elem(plan, row, *s),
                ident(&p.sig(*s).name)
            );
        }
    }
    o.push_str("}\n\n");
    o
}

/// The call of shared loop body `k` in `step`, between the writes and reads of the step's
/// locals that [`Emit::sync`] asks for.
fn loop_call(em: &Emit, sync: &Sync, k: usize, o: &mut String) {
    let plan = &em.plan;
    let p = &plan.prog;
    let r = &em.repeats[k];
    for e in &sync.before[k] {
        let _ = writeln!(
            o,
            "    self->{} = {};",
            field(p, *e),
            ident(&p.sig(*e).name)
        );
    }
    let mut args: Vec<String> = Vec::new();
    for row in &r.rows {
        let at = if row.lead == 0 {
            "qloop_l".to_string()
        } else {
            format!("qloop_l + {}", row.lead)
        };
        let g = ident(&row.group);
        args.push(if row.dims.len() == 1 {
            format!("&self->{g}[{at}]")
        } else {
            format!("self->{g}[{at}]")
        });
    }
    for q in &r.params {
        args.push(match *q {
            Param::Val(v) => name(plan, v),
            Param::Sig(s) => ident(&p.sig(s).name),
        });
    }
    let _ = writeln!(
        o,
        "    for (int qloop_l = 0; qloop_l < {}; ++qloop_l) {{\n        {}({});\n    }}",
        r.count,
        loop_name(plan, k),
        args.join(", ")
    );
    for e in &sync.after[k] {
        let _ = writeln!(
            o,
            "    {} = {};",
            ident(&p.sig(*e).name),
            from_storage(plan, *e, &format!("self->{}", field(p, *e)))
        );
    }
}

fn indent(depth: usize) -> String {
    "    ".repeat(depth)
}

/// The reads of a table's differences as `T[i + 1] − T[i]` ([`super::table_layouts`]) in one
/// statement list, each with the read of its `T[i]` earlier in the same list (the lowering
/// emits the two together): the difference reuses that value, since on the AVR each read of a
/// table in flash is an `lpm` sequence the compiler cannot merge with another. For Frama-C
/// Eva, which relates no two array reads, the pair is bracketed by `//@ split i;` and
/// `//@ merge i;`: the index is split into its values (at most 257; Eva needs
/// `-eva-split-limit 257` where a table has more than 100 entries) across the two reads
/// alone, so the difference gets the range of `D` instead of `[min T − max T, max T − min T]`.
/// Comments to every compiler.
fn compact_pairs(plan: &Plan, stmts: &[LStmt]) -> HashMap<ValId, ValId> {
    let layouts = super::table_layouts(plan);
    let mut samples: Vec<(usize, ValId, ValId)> = Vec::new();
    let mut pairs = HashMap::new();
    for st in stmts {
        let LStmt::Def(id) = st else { continue };
        match plan.val(*id).op {
            Op::Lookup {
                table,
                delta: false,
                idx,
            } => samples.push((table, idx, *id)),
            Op::Lookup {
                table,
                delta: true,
                idx,
            } if !layouts[table].deltas => {
                if let Some(&(_, _, t)) = samples.iter().rev().find(|s| s.0 == table && s.1 == idx)
                {
                    pairs.insert(*id, t);
                }
            }
            _ => {}
        }
    }
    pairs
}

fn block(plan: &Plan, stmts: &[LStmt], depth: usize, o: &mut String) {
    let ind = indent(depth);
    let pairs = compact_pairs(plan, stmts);
    for s in stmts {
        match s {
            LStmt::Def(id) => {
                let v = plan.val(*id);
                let pair = pairs.get(id).copied();
                if let Op::Lookup { idx, .. } = v.op {
                    if pairs.values().any(|t| t == id) {
                        let _ = writeln!(o, "{ind}//@ split {};", name(plan, idx));
                    }
                }
                let ty = if v.boolean {
                    "bool".to_string()
                } else {
                    c_ty(v.ty)
                };
                let nm = name(plan, *id);
                let tmp = format!("qloop_{}", id.0);
                if let Some(e) = wide::shift(plan, *id).or_else(|| wide::product(plan, *id)) {
                    // A shifted term of a network stays opaque too (see QLOOP_KEEP).
                    let qual = if v.network { "" } else { "const " };
                    let _ = writeln!(o, "{ind}{qual}{ty} {nm} = {e};");
                    if v.network {
                        let _ = writeln!(o, "{ind}QLOOP_KEEP({nm});");
                    }
                } else if let Some((first, second)) = byte_split(plan, *id, &tmp) {
                    // Without a barrel shifter, a constant shift becomes whole-byte moves plus
                    // a short shift; the opaque middle value stops GCC re-joining the two.
                    let _ = writeln!(o, "{ind}{ty} {tmp} = {first};");
                    let _ = writeln!(o, "{ind}QLOOP_KEEP({tmp});");
                    let qual = if v.network { "" } else { "const " };
                    let _ = writeln!(o, "{ind}{qual}{ty} {nm} = {second};");
                    if v.network {
                        let _ = writeln!(o, "{ind}QLOOP_KEEP({nm});");
                    }
                } else if v.network {
                    // Shifted terms stay opaque, so the compiler cannot fold a shift-add
                    // network back into a multiply (see QLOOP_KEEP).
                    let _ = writeln!(o, "{ind}{ty} {nm} = {};", expr(plan, *id, pair));
                    let _ = writeln!(o, "{ind}QLOOP_KEEP({nm});");
                } else {
                    let _ = writeln!(o, "{ind}const {ty} {nm} = {};", expr(plan, *id, pair));
                }
                if let (Some(_), Op::Lookup { idx, .. }) = (pair, &v.op) {
                    let _ = writeln!(o, "{ind}//@ merge {};", name(plan, *idx));
                }
            }
            LStmt::Store(sig, id) => {
                let _ = writeln!(
                    o,
                    "{ind}{} = {};",
                    ident(&plan.prog.sig(*sig).name),
                    name(plan, *id)
                );
            }
            LStmt::If(c, t, e) => {
                let _ = writeln!(o, "{ind}if ({}) {{", name(plan, *c));
                block(plan, t, depth + 1, o);
                if e.is_empty() {
                    let _ = writeln!(o, "{ind}}}");
                } else {
                    let _ = writeln!(o, "{ind}}} else {{");
                    block(plan, e, depth + 1, o);
                    let _ = writeln!(o, "{ind}}}");
                }
            }
        }
    }
}

/// On a target without a barrel shifter (AVR), GCC compiles a constant shift of a multi-byte
/// value as a loop of one-bit shifts over all its bytes: `x >> 14` on an `int32_t` is 14
/// iterations of 7 cycles. Whole-byte shifts are register moves. So a shift by `k = 8q + r`
/// (0 < r < 8) is written as a byte shift and an `r`-bit shift, or, when the operand's proved
/// range leaves room, as an `8 − r`-bit shift the other way and `q + 1` bytes:
///
/// * `a >> k` = `(a >> 8q) >> r`, or `(a · 2^(8−r)) >> 8(q+1)` (exact: floor division by
///   `2^k` either way);
/// * `a · 2^k` = `(a · 2^8q) · 2^r`, or `(a · 2^8(q+1)) >> (8−r)` (exact: the low bits
///   shifted out are zero).
///
/// The up-shifted value must fit the type (checked against the proved interval, so no
/// overflow and no UB). Returns `None` where the plain shift is as cheap: barrel shifters,
/// single-word values, and shifts that are already whole bytes or under one byte with no
/// room to round up.
fn byte_split(plan: &Plan, id: ValId, mid: &str) -> Option<(String, String)> {
    let t = &plan.target;
    let v = plan.val(id);
    let (a, k, left) = match v.op {
        Op::Shr(a, k) => (a, k, false),
        Op::Shl(a, k) => (a, k, true),
        _ => return None,
    };
    let byte = t.word_bits;
    let av = plan.val(a);
    // `a · 2^n` fits the type (a's interval is proved; the shifted value is exact).
    let fits = |n: u32| n + 1 < v.ty.bits && v.ty.holds(av.lo << n, av.hi << n);
    let (q, r) = (k / byte, k % byte);
    let up_room = fits(if left { byte * (q + 1) } else { byte - r });
    let sp = t.split_shift(v.ty.bits, k, up_room)?;
    let tn = c_ty(v.ty);
    let an = name(plan, a);
    let times = |x: &str, n: u32| format!("({tn})({x} * {})", c_lit(1i128 << n, v.ty));
    let shr = |x: &str, n: u32| format!("({tn})({x} >> {n})");
    let moved = byte * sp.words;
    Some(match (sp.up, left) {
        (true, true) => (times(&an, moved), shr(mid, sp.bits)),
        (true, false) => (times(&an, sp.bits), shr(mid, moved)),
        (false, true) if !fits(moved) => return None,
        (false, true) => (times(&an, moved), times(mid, sp.bits)),
        (false, false) => (shr(&an, moved), shr(mid, sp.bits)),
    })
}

/// The C name of table array `i` (samples, or differences).
fn table_array(plan: &Plan, i: usize, delta: bool) -> String {
    let what = if delta { "delta" } else { "table" };
    format!("{}_{what}_{i}", plan.prog.name)
}

/// The table arrays of the step, `static const`, in program memory on AVR (`PROGMEM`, read
/// with `pgm_read_*`: a table in RAM would cost the ATmega328P's scarce 2 KiB), padded to a
/// power of two like the Rust output's.
fn table_arrays(plan: &Plan) -> String {
    let layouts = super::table_layouts(plan);
    if layouts.iter().all(|l| !l.entries && !l.deltas) {
        return String::new();
    }
    let mut o = String::from(
        "/* Table arrays: in flash on AVR (read with pgm_read_*), ordinary constants elsewhere. */\n\
         #if defined(__AVR__) && !defined(__FRAMAC__)\n\
         #include <avr/pgmspace.h>\n\
         #define QLOOP_PROGMEM PROGMEM\n\
         #define QLOOP_READ_8(a, i) ((int8_t)pgm_read_byte(&(a)[i]))\n\
         #define QLOOP_READ_16(a, i) ((int16_t)pgm_read_word(&(a)[i]))\n\
         #define QLOOP_READ_32(a, i) ((int32_t)pgm_read_dword(&(a)[i]))\n\
         #define QLOOP_READ_64(a, i) ((int64_t)((uint64_t)pgm_read_dword(&(a)[i]) | \\\n\
         \x20   ((uint64_t)pgm_read_dword((const char *)&(a)[i] + 4) << 32)))\n\
         #else\n\
         #define QLOOP_PROGMEM\n\
         #define QLOOP_READ_8(a, i) ((a)[i])\n\
         #define QLOOP_READ_16(a, i) ((a)[i])\n\
         #define QLOOP_READ_32(a, i) ((a)[i])\n\
         #define QLOOP_READ_64(a, i) ((a)[i])\n\
         #endif\n\n",
    );
    for (i, t) in plan.tables.iter().enumerate() {
        let layout = layouts[i];
        if !layout.entries && !layout.deltas {
            continue;
        }
        let len = layout.len;
        let _ = writeln!(o, "/*{} */", super::table_doc(plan, i));
        for delta in [false, true] {
            if !(if delta { layout.deltas } else { layout.entries }) {
                continue;
            }
            let (ty, src) = if delta {
                (t.delta_ty, &t.deltas)
            } else {
                (t.format.ty, &t.entries)
            };
            let vals: Vec<String> = super::padded(src, len)
                .into_iter()
                .map(|v| c_lit(v, ty))
                .collect();
            let _ = writeln!(
                o,
                "static const {} {}[{len}] QLOOP_PROGMEM = {{\n    {}\n}};",
                c_ty(ty),
                table_array(plan, i, delta),
                vals.join(", ")
            );
        }
        o.push('\n');
    }
    o
}

/// The C name of a value: the user's `let` name, or `_N`.
fn name(plan: &Plan, id: ValId) -> String {
    match &plan.val(id).name {
        Some(n) => ident(n),
        None => format!("_{}", id.0),
    }
}

/// The expression defining value `id`; the result always has the value's own type.
/// `pair`: the read of `T[i]` that a difference read as `T[i + 1] − T[i]` reuses
/// ([`compact_pairs`]).
fn expr(plan: &Plan, id: ValId, pair: Option<ValId>) -> String {
    let v = plan.val(id);
    let t = c_ty(v.ty);
    let n = |x: &ValId| name(plan, *x);
    match &v.op {
        Op::Input(s) => {
            let x = format!("in->{}", field(&plan.prog, *s));
            let st = plan.storage_ty(*s);
            if st == v.ty {
                x
            } else {
                // Stored in its vector's wider word: saturated to its own type first.
                let (lo, hi) = (c_lit(v.ty.min(), st), c_lit(v.ty.max(), st));
                format!("({t})({x} < {lo} ? {lo} : ({x} > {hi} ? {hi} : {x}))")
            }
        }
        Op::Low(a, k) => format!("({t})({} & {})", n(a), c_lit((1i128 << k) - 1, v.ty)),
        Op::MulHi(a, b) => format!("qloop_{}_mulhi({}, {})", plan.prog.name, n(a), n(b)),
        Op::Lookup { table, delta, idx }
            if *delta && !super::table_layouts(plan)[*table].deltas =>
        {
            // `D[i]` as `T[i + 1] − T[i]` (`table_layouts`): the same type, and the difference
            // fits it, so the subtraction is exact (in `int` for a narrower type).
            let bits = plan.tables[*table].format.ty.bits;
            let (arr, i) = (table_array(plan, *table, false), n(idx));
            let ti = pair.map_or_else(
                || format!("QLOOP_READ_{bits}({arr}, {i})"),
                |v| name(plan, v),
            );
            format!("({t})(QLOOP_READ_{bits}({arr}, {i} + 1) - {ti})")
        }
        Op::Lookup { table, delta, idx } => {
            let bits = if *delta {
                plan.tables[*table].delta_ty.bits
            } else {
                plan.tables[*table].format.ty.bits
            };
            format!(
                "({t})QLOOP_READ_{bits}({}, {})",
                table_array(plan, *table, *delta),
                n(idx)
            )
        }
        Op::Load(s) => ident(&plan.prog.sig(*s).name),
        Op::Const(c) => c_lit(*c, v.ty),
        Op::Cast(a) => format!("({t}){}", n(a)),
        Op::Add(a, b) => format!("({t})({} + {})", n(a), n(b)),
        Op::Sub(a, b) => format!("({t})({} - {})", n(a), n(b)),
        Op::Neg(a) => format!("({t})(-{})", n(a)),
        Op::Shl(a, k) => {
            // a · 2^k: no left shift of a possibly negative value (UB in C). Compilers emit a
            // power-of-two multiply as a shift; QLOOP_KEEP on the result stops them from
            // folding it into a neighbouring add as a general multiply.
            let scale = 1i128 << k;
            if v.ty.holds(scale, scale) {
                format!("({t})({} * {})", n(a), c_lit(scale, v.ty))
            } else {
                // 2^k does not fit the type: only a = 0, or a = -1 with the result at the
                // type's minimum, is in range; compute one size up.
                let w = IntTy::signed(64);
                format!("({t})(({}){} * {})", c_ty(w), n(a), c_lit(scale, w))
            }
        }
        Op::Shr(a, k) => format!("({t})({} >> {k})", n(a)),
        Op::Mul(a, b) => format!("({t})({} * {})", n(a), n(b)),
        Op::Min(a, b) => {
            let (a, b) = (n(a), n(b));
            format!("(({a} < {b}) ? {a} : {b})")
        }
        Op::Max(a, b) => {
            let (a, b) = (n(a), n(b));
            format!("(({a} > {b}) ? {a} : {b})")
        }
        Op::Select(c, a, b) => format!("({} ? {} : {})", n(c), n(a), n(b)),
        Op::Cmp(op, a, b) => format!("({} {} {})", n(a), op.symbol(), n(b)),
        Op::And(a, b) => format!("({} && {})", n(a), n(b)),
        Op::Or(a, b) => format!("({} || {})", n(a), n(b)),
        Op::Not(a) => format!("(!{})", n(a)),
    }
}
