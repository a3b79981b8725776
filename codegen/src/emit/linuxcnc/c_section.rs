//! The C section of the component: the pasted controller and the glue between push/pop of
//! the colliding macros, the float conversion, `EXTRA_SETUP` and the HAL function.

use super::{c, double_c, hal_names, pow2_c, Layout, Port, MARKERS, VARIABLES};
use crate::ir::SigKind;
use crate::lower::Plan;
use crate::qformat::Rounding;
use crate::text::g;
use std::fmt::Write;

/// The names pushed away around the controller and glue: every HAL name and variable of the
/// component, `data`, and every identifier the controller takes from the spec (the signals'
/// names, and the names of the vectors its structs hold as arrays).
fn pushed(plan: &Plan, l: &Layout) -> Vec<String> {
    let mut v: Vec<String> = hal_names(plan, l).into_iter().map(|(n, _)| n).collect();
    v.extend(VARIABLES.iter().map(|s| s.to_string()));
    v.push("data".into());
    v.extend(plan.prog.signals.iter().map(|s| c::ident(&s.name)));
    v.extend(plan.prog.signals.iter().filter_map(|s| match &s.elem {
        Some(e) if s.kind != SigKind::Local => Some(c::ident(&e.group)),
        _ => None,
    }));
    let mut seen = std::collections::HashSet::new();
    v.retain(|n| seen.insert(n.clone()));
    v
}

/// A C initialiser list of one entry per port, with the spec names as a comment.
fn c_array(ports: &[Port], plan: &Plan, f: impl Fn(&Port) -> String) -> String {
    let vals: Vec<String> = ports.iter().map(f).collect();
    let names: Vec<String> = ports.iter().map(|p| plan.prog.sig(p.id).label()).collect();
    format!("{{ {} }}; /* {} */", vals.join(", "), names.join(", "))
}

/// Everything after the `;;` line.
pub(super) fn c_section(plan: &Plan, l: &Layout) -> String {
    let p = &plan.prog;
    let n = &p.name;
    let pushed = pushed(plan, l);
    let mut o = String::from(
        "\n/* Every pin, param and variable of this component, and `data`, is a macro of its \
         bare name\n * here (halcompile's convenience defines), and GCC and the RTAPI headers \
         predefine a few\n * more (`linux`, `unix`, `realtime`). The controller and the glue \
         are compiled with these\n * names and every identifier the controller takes from the \
         spec pushed away. */\n",
    );
    for m in &pushed {
        let _ = writeln!(o, "#pragma push_macro(\"{m}\")");
    }
    for m in &pushed {
        let _ = writeln!(o, "#undef {m}");
    }

    let _ = writeln!(
        o,
        "\n{}\n/* The controller as `qloop gen --lang c --target {}` writes it: {n}.h, then \
         {n}.c\n * without its #include of the header and without its Frama-C entry point. */",
        MARKERS[0], plan.target.name
    );
    o.push_str(&c::single_unit(plan));
    let _ = writeln!(o, "{}\n\n{}", MARKERS[1], MARKERS[2]);
    let _ = writeln!(
        o,
        "/* Glue between the HAL function and the controller, generic over inputs and outputs \
         (raw\n * integers in declaration order), and the only code that touches the \
         controller's struct\n * fields. targets/linuxcnc/run.sh also compiles it, with the \
         controller, on the host for its\n * reference run. */"
    );
    let _ = writeln!(
        o,
        "#define QLOOP_N_IN {}\n#define QLOOP_N_OUT {}\n#define QLOOP_PERIOD_US {}UL\n\
         #define QLOOP_ROUND_NEAREST {} /* the input conversion: 0 floor, 1 nearest (ties up) */\n\
         typedef {n}_state qloop_state;\n#define qloop_init {n}_init",
        l.inputs.len(),
        l.outputs.len(),
        l.period_us,
        u8::from(p.rounding == Rounding::Nearest)
    );
    let _ = writeln!(
        o,
        "/* input i: raw = floor(value * qloop_in_scale[i]{}) saturated to [qloop_in_min[i], \
         qloop_in_max[i]] */",
        if p.rounding == Rounding::Nearest {
            " + 1/2"
        } else {
            ""
        }
    );
    let _ = writeln!(
        o,
        "static const double qloop_in_scale[QLOOP_N_IN] = {}",
        c_array(&l.inputs, plan, |i| pow2_c(i.q.frac))
    );
    let _ = writeln!(
        o,
        "static const int32_t qloop_in_min[QLOOP_N_IN] = {}",
        c_array(&l.inputs, plan, |i| i.raw.0.to_string())
    );
    let _ = writeln!(
        o,
        "static const int32_t qloop_in_max[QLOOP_N_IN] = {}",
        c_array(&l.inputs, plan, |i| i.raw.1.to_string())
    );
    let _ = writeln!(
        o,
        "/* output j: value = raw * qloop_out_scale[j] (exact); the adaptive feed is output \
         0's value\n * times qloop_override_scale (see below) */"
    );
    let _ = writeln!(
        o,
        "static const double qloop_out_scale[QLOOP_N_OUT] = {}",
        c_array(&l.outputs, plan, |o| pow2_c(-o.q.frac))
    );
    let _ = writeln!(
        o,
        "static const double qloop_override_scale = {}; /* 1 / {}: {} */\n",
        double_c(l.override_scale),
        g(l.full_scale),
        l.scale_why
    );
    let _ = writeln!(
        o,
        "static void qloop_step_raw(qloop_state *s, const int32_t *in_raw, int32_t *out_raw)\n{{\n    \
         {n}_inputs in;\n    {n}_outputs out;"
    );
    for (k, i) in l.inputs.iter().enumerate() {
        let _ = writeln!(
            o,
            "    in.{} = ({})in_raw[{k}]; /* in [{}, {}]: saturated by the caller */",
            i.field,
            c::c_ty(i.q.ty),
            i.raw.0,
            i.raw.1
        );
    }
    let _ = writeln!(o, "    {n}_step(s, &in, &out);");
    for (k, out) in l.outputs.iter().enumerate() {
        let _ = writeln!(o, "    out_raw[{k}] = (int32_t)out.{};", out.field);
    }
    let _ = writeln!(o, "}}\n{}\n", MARKERS[3]);

    // float -> raw, with the spec's rounding.
    let nearest = if p.rounding == Rounding::Nearest {
        "    if (y - (double)t >= 0.5) t += 1;   /* nearest, ties up: y - t is exact */\n"
    } else {
        ""
    };
    let _ = writeln!(
        o,
        "/* {} saturated to [lo, hi]; scale is a power of two, so the\n * \
         product is exact. NaN maps to hi. No libm. */\n\
         static int32_t qloop_float_to_raw(double x, double scale, int32_t lo, int32_t hi)\n{{\n    \
         double y = x * scale;\n    int32_t t;\n    if (y != y) return hi;              /* NaN */\n    \
         if (y <= (double)lo) return lo;\n    if (y >= (double)hi) return hi;\n    \
         t = (int32_t)y;                     /* truncation toward zero; lo < y < hi fits */\n    \
         if ((double)t > y) t -= 1;          /* floor of a negative non-integer */\n{nearest}    \
         return t;\n}}\n",
        match p.rounding {
            Rounding::Floor => "floor(x * scale)",
            Rounding::Nearest => "floor(x * scale + 1/2), i.e. x * scale rounded to nearest with ties up,",
        }
    );
    for m in &pushed {
        let _ = writeln!(o, "#pragma pop_macro(\"{m}\")");
    }

    // The HAL side: setup and the function.
    let _ = writeln!(
        o,
        "\n#define QLOOP_PERIOD_NS ((rtapi_s64)QLOOP_PERIOD_US * 1000)\n\n\
         EXTRA_SETUP()\n{{\n    (void)prefix;\n    (void)extra_arg;\n    qloop_init(&data);\n    \
         {} = 0;\n    return 0;\n}}\n",
        VARIABLES[0]
    );
    let _ = writeln!(
        o,
        "FUNCTION(_)\n{{\n    int32_t qloop_in[QLOOP_N_IN], qloop_out[QLOOP_N_OUT];\n    \
         double qloop_v;\n"
    );
    for (k, i) in l.inputs.iter().enumerate() {
        let _ = writeln!(
            o,
            "    qloop_in[{k}] = qloop_float_to_raw({}, qloop_in_scale[{k}], qloop_in_min[{k}], \
             qloop_in_max[{k}]);\n    {}_raw = qloop_in[{k}];",
            i.hal, i.hal
        );
    }
    let _ = writeln!(
        o,
        "\n    /* One controller step every QLOOP_PERIOD_NS of thread time; the first in the \
         first period. */\n    if ({c} > 0) {{\n        {c} -= period;\n        \
         return;                         /* between controller steps the outputs hold */\n    \
         }}\n    {c} += QLOOP_PERIOD_NS - period;\n    \
         if ({c} < 0) {c} = 0; /* thread period > controller period: every period */\n\n    \
         qloop_step_raw(&data, qloop_in, qloop_out);\n    steps++;\n",
        c = VARIABLES[0]
    );
    for (k, out) in l.outputs.iter().enumerate() {
        let _ = writeln!(
            o,
            "    {h}_raw = qloop_out[{k}];\n    qloop_v = (double)qloop_out[{k}] * \
             qloop_out_scale[{k}];\n    {h} = {v};",
            h = out.hal,
            v = if plan.prog.sig(out.id).flag {
                "qloop_v > 0.5 /* #[flag]: a bit pin */"
            } else {
                "qloop_v"
            }
        );
        if k == 0 {
            let _ = writeln!(
                o,
                "    qloop_v = qloop_v * qloop_override_scale;\n    \
                 adaptive_feed = qloop_v < 0.0 ? 0.0 : (qloop_v > 1.0 ? 1.0 : qloop_v);"
            );
        }
    }
    o.push_str("}\n");
    o
}
