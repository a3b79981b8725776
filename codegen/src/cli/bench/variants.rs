//! The benchmarked variants: each one's C sources and API, the scripted inputs as constant
//! tables, and its `main.c`.

use super::DIV_SPEC;
use qloop::emit::{c as cemit, c_float};
use qloop::ir::{SigId, SigKind};
use qloop::qformat::{pow2, IntTy};
use qloop::Plan;
use std::fmt::Write as _;

const DIV_H: &str = include_str!("../../../targets/bench/koren_masory_1981_div.h");
const DIV_FLOAT_C: &str = include_str!("../../../targets/bench/koren_masory_1981_div_float.c");
const DIV_INT32_C: &str = include_str!("../../../targets/bench/koren_masory_1981_div_int32.c");

/// How an output value comes back from the firmware.
#[derive(Clone, Copy, Debug)]
pub(super) enum OutKind {
    /// A raw integer of this type and fraction bits.
    Raw(IntTy, i32),
    /// A `float`, sent as its bits.
    Float,
}

impl OutKind {
    pub(super) fn value(self, raw: i64) -> f64 {
        match self {
            OutKind::Raw(ty, frac) => {
                let r = if !ty.signed && ty.bits == 64 {
                    raw as u64 as f64
                } else {
                    raw as f64
                };
                r * pow2(-frac)
            }
            OutKind::Float => f32::from_bits(raw as u32) as f64,
        }
    }
}

/// One benchmarked routine: its files and API.
pub(super) struct Variant {
    pub(super) name: &'static str,
    /// Files written next to `main.c` (name, text).
    pub(super) files: Vec<(String, String)>,
    /// Which of them to compile.
    pub(super) sources: Vec<String>,
    header: String,
    /// Prefix of the API: `P_state`, `P_inputs`, `P_outputs`, `P_init`, `P_step`.
    prefix: String,
    /// Input fields, declaration order, and each step's C initialisers for them.
    inputs: Vec<String>,
    table: Vec<Vec<String>>,
    /// Output fields and how to read them back.
    pub(super) outputs: Vec<(String, OutKind)>,
}

impl Variant {
    /// The name of its step function (`P_step`).
    pub(super) fn step_fn(&self) -> String {
        format!("{}_step", self.prefix)
    }
}

/// What [`stimulus`] drives, for the bench report.
pub(super) const STIMULUS_TEXT: &str = "inputs: every variant gets the same scripted sequence per \
input, as a fraction of its declared range: 10 % of the steps below, at and just above the \
range's start (an air cut for a force), 50 % at held levels 4, 20, 30, 50, 80, 30 %, 25 % a \
ramp to 110 %, 15 % a ramp back down; input k is shifted by 0.37·k of the script";

/// The scripted physical value of an input with declared range `[lo, hi]` at each step:
/// below the range, its start and just above it (an air cut for a force), then levels held
/// across the range (4 % = just above a force's air-cut threshold, 20, 30, 50, 80, 30 %),
/// a ramp to 110 % and a ramp back down. `phase` shifts the script (one per input).
fn stimulus(lo: f64, hi: f64, steps: usize, phase: f64) -> Vec<f64> {
    let span = if hi > lo { hi - lo } else { 1.0 };
    let pick =
        |levels: &[f64], x: f64| levels[((x * levels.len() as f64) as usize).min(levels.len() - 1)];
    (0..steps)
        .map(|i| {
            let p = (i as f64 / steps as f64 + phase).fract();
            let f = if p < 0.10 {
                pick(&[-0.1, 0.0, 0.02], p / 0.10)
            } else if p < 0.60 {
                pick(&[0.04, 0.2, 0.3, 0.5, 0.8, 0.3], (p - 0.10) / 0.50)
            } else if p < 0.85 {
                1.1 * (p - 0.60) / 0.25
            } else {
                1.0 - (p - 0.85) / 0.15
            };
            lo + f * span
        })
        .collect()
}

/// Each input's physical value per step: `values[step][input]`.
pub(super) fn script(plan: &Plan, steps: usize) -> Vec<Vec<f64>> {
    let ins: Vec<SigId> = plan.prog.ids_of(SigKind::Input).collect();
    let cols: Vec<Vec<f64>> = ins
        .iter()
        .enumerate()
        .map(|(k, id)| {
            let (lo, hi) = plan.prog.sig(*id).range.unwrap_or((0.0, 1.0));
            stimulus(lo, hi, steps, 0.37 * k as f64)
        })
        .collect();
    (0..steps)
        .map(|i| cols.iter().map(|c| c[i]).collect())
        .collect()
}

/// `floor(v · 2^frac)` clamped to the type.
fn raw_of(v: f64, ty: IntTy, frac: i32) -> i128 {
    ((v * pow2(frac)).floor() as i128).clamp(ty.min(), ty.max())
}

/// The fixed-point variant of `plan` (`qloop` or `plain_mul`).
pub(super) fn fixed_variant(name: &'static str, plan: &Plan, values: &[Vec<f64>]) -> Variant {
    let p = &plan.prog;
    let (h, c) = qloop::gen_c(plan);
    let ins: Vec<SigId> = p.ids_of(SigKind::Input).collect();
    let table = values
        .iter()
        .map(|row| {
            ins.iter()
                .zip(row)
                .map(|(id, v)| {
                    let q = plan.format(*id);
                    cemit::c_lit(raw_of(*v, q.ty, q.frac), q.ty)
                })
                .collect()
        })
        .collect();
    Variant {
        name,
        files: vec![(format!("{}.h", p.name), h), (format!("{}.c", p.name), c)],
        sources: vec![format!("{}.c", p.name)],
        header: format!("{}.h", p.name),
        prefix: p.name.clone(),
        inputs: ins
            .iter()
            .map(|id| cemit::ident(&p.sig(*id).name))
            .collect(),
        table,
        outputs: p
            .ids_of(SigKind::Output)
            .map(|id| {
                let q = plan.format(id);
                (cemit::ident(&p.sig(id).name), OutKind::Raw(q.ty, q.frac))
            })
            .collect(),
    }
}

/// The spec's step in C `float`.
pub(super) fn float_variant(plan: &Plan, values: &[Vec<f64>]) -> Variant {
    let p = &plan.prog;
    let (h, c) = c_float::source(p);
    Variant {
        name: "float",
        files: vec![
            (format!("{}_f.h", p.name), h),
            (format!("{}_f.c", p.name), c),
        ],
        sources: vec![format!("{}_f.c", p.name)],
        header: format!("{}_f.h", p.name),
        prefix: format!("{}_f", p.name),
        inputs: p
            .ids_of(SigKind::Input)
            .map(|id| c_float::ident(&p.sig(id).name))
            .collect(),
        table: values
            .iter()
            .map(|row| row.iter().map(|v| c_float::lit(*v)).collect())
            .collect(),
        outputs: p
            .ids_of(SigKind::Output)
            .map(|id| (c_float::ident(&p.sig(id).name), OutKind::Float))
            .collect(),
    }
}

/// Whether the hand-written division baselines implement this spec (same name and signals).
pub(super) fn has_div_baselines(plan: &Plan) -> bool {
    let p = &plan.prog;
    let names = |k| {
        p.ids_of(k)
            .map(|id| p.sig(id).name.clone())
            .collect::<Vec<_>>()
    };
    p.name == DIV_SPEC && names(SigKind::Input) == ["fc"] && names(SigKind::Output) == ["feed"]
}

/// `div_float` and `div_int32` (Q12 `int16_t`, see `koren_masory_1981_div.h`).
pub(super) fn div_variants(values: &[Vec<f64>]) -> [Variant; 2] {
    let hdr = "koren_masory_1981_div.h".to_string();
    let q12 = IntTy {
        signed: true,
        bits: 16,
    };
    let mk = |name, file: &str, text: &str, prefix: &str, table, kind| Variant {
        name,
        files: vec![
            (hdr.clone(), DIV_H.to_string()),
            (file.to_string(), text.to_string()),
        ],
        sources: vec![file.to_string()],
        header: hdr.clone(),
        prefix: prefix.to_string(),
        inputs: vec!["fc".into()],
        table,
        outputs: vec![("feed".into(), kind)],
    };
    [
        mk(
            "div_float",
            "koren_masory_1981_div_float.c",
            DIV_FLOAT_C,
            "koren_masory_1981_divf",
            values.iter().map(|r| vec![c_float::lit(r[0])]).collect(),
            OutKind::Float,
        ),
        mk(
            "div_int32",
            "koren_masory_1981_div_int32.c",
            DIV_INT32_C,
            "koren_masory_1981_divi",
            values
                .iter()
                .map(|r| vec![cemit::c_lit(raw_of(r[0], q12, 12), q12)])
                .collect(),
            OutKind::Raw(q12, 12),
        ),
    ]
}

/// The variant's `main.c`: table, init, then per step load, timed step, report.
pub(super) fn main_c(v: &Variant) -> String {
    let p = &v.prefix;
    let mut o = format!(
        "/* main.c -- qloop bench, variant `{}`: {} steps of {p}_step on a scripted input. */\n\
         #include <stdint.h>\n#include \"bench_io.h\"\n#include \"{}\"\n\n\
         #define BENCH_STEPS {}u\n\n\
         static const {p}_inputs bench_table[BENCH_STEPS] BENCH_ROM = {{\n",
        v.name,
        v.table.len(),
        v.header,
        v.table.len()
    );
    for row in &v.table {
        let fields: Vec<String> = v
            .inputs
            .iter()
            .zip(row)
            .map(|(f, x)| format!(".{f} = {x}"))
            .collect();
        let _ = writeln!(o, "    {{{}}},", fields.join(", "));
    }
    let _ = write!(
        o,
        "}};\n\n\
         static {p}_state bench_state;\nstatic {p}_inputs bench_in;\nstatic {p}_outputs bench_out;\n\n\
         int main(void)\n{{\n    uint32_t i;\n    bench_setup();\n    bench_calibrate();\n    \
         {p}_init(&bench_state);\n    for (i = 0; i < BENCH_STEPS; i++) {{\n        \
         bench_load(&bench_in, &bench_table[i], sizeof bench_in);\n        \
         BENCH_TIMED({p}_step(&bench_state, &bench_in, &bench_out));\n        \
         bench_record_begin(i);\n"
    );
    for (f, k) in &v.outputs {
        match k {
            OutKind::Raw(..) => {
                let _ = writeln!(o, "        bench_value((int64_t)bench_out.{f});");
            }
            OutKind::Float => {
                let _ = writeln!(o, "        bench_value_f(bench_out.{f});");
            }
        }
    }
    o.push_str("        bench_record_end();\n    }\n    bench_done();\n    return 0;\n}\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stimulus_covers_below_inside_and_above_the_range() {
        let v = stimulus(0.0, 5.0, 200, 0.0);
        assert_eq!(v.len(), 200);
        assert!(v[0] < 0.0, "starts below the range: {}", v[0]);
        assert!(
            v.iter().any(|x| *x > 0.15 && *x < 0.3),
            "just above an air cut"
        );
        assert!(v.iter().any(|x| *x > 5.0), "ramps past the range");
        assert!(v.iter().all(|x| x.is_finite() && *x >= -0.5 && *x <= 5.5));
        assert_eq!(stimulus(0.0, 5.0, 1, 0.0).len(), 1);
    }

    #[test]
    fn raw_values_saturate_to_the_storage_type() {
        let u16t = IntTy {
            signed: false,
            bits: 16,
        };
        assert_eq!(raw_of(-1.0, u16t, 4), 0);
        assert_eq!(raw_of(1e9, u16t, 4), 65535);
        let i16t = IntTy {
            signed: true,
            bits: 16,
        };
        assert_eq!(raw_of(-0.5, i16t, 12), -2048);
        assert_eq!(raw_of(1.0 / 4096.0 * 1.5, i16t, 12), 1);
    }

    #[test]
    fn float_outputs_come_back_from_their_bits() {
        let bits = 1.25f32.to_bits() as i64;
        assert_eq!(OutKind::Float.value(bits), 1.25);
        let q = OutKind::Raw(
            IntTy {
                signed: true,
                bits: 16,
            },
            12,
        );
        assert_eq!(q.value(-2048), -0.5);
    }
}
