//! Emits a LinuxCNC HAL realtime component: a `.comp` file for `halcompile` that embeds the
//! controller's C (`qloop gen --lang c`), converts HAL floats to raw inputs and raw outputs
//! back to floats, and runs one controller step per spec period from a HAL thread
//! (`targets/linuxcnc/README.md` documents the component and the halcompile facts it relies
//! on).
//!
//! The component is `qloop_<spec name>` (the file must be `qloop_<spec name>.comp`). Pins and
//! params, HAL names in lower case:
//!
//! * `spindle_load` (in float): the spec's **first** input, in its unit; every further input
//!   keeps its own name. For each input `IN`, `IN_raw` (out s32): the raw input after the
//!   conversion `floor(x · 2^frac)` (`nearest` specs: rounded half up) saturated to the raw
//!   bounds of its declared range, NaN → the upper bound.
//! * For each output `OUT`: `OUT` (out float) = `OUT_raw · 2^-frac` (exact) and `OUT_raw`
//!   (out s32).
//! * `adaptive_feed` (out float): the **first** output times the reciprocal of its range
//!   maximum (declared, or proved for an unranged output), clamped to `[0, 1]`, for
//!   `motion.adaptive-feed`; a first output in `%` or declared dimensionless (`"1"`) is a
//!   feed override and is taken as such (100 % is 1).
//! * `steps` (out u32), controller steps since load; the spec's `param`s as read-only float
//!   params (compiled-in constants); `period_us` (read-only u32), the sample period.
//! * A vector or matrix input or output has one pin per element (and one raw pin), named
//!   after the element's generated name in lower case: `phi_1` (HAL `phi-1`) for `phi[1]`,
//!   `p_1_0` (HAL `p-1-0`) for `P[1][0]`, `p_1_0_raw`, as halcompile names the pins of its own
//!   arrays (`in-#`). Each element counts as one input or output (so the first element of a
//!   first input vector is `spindle_load`), in declaration order, row-major. The checker keeps
//!   the generated names apart from every other signal name; a coincidence in lower case is
//!   refused like any other.
//!
//! Refused, with an [`Unrepresentable`] error rather than a component that does not build or
//! load: a spec with no input or no output, a first output whose range maximum is not
//! positive, a raw input or output range that does not fit a HAL s32, a name that is not a
//! plain ASCII identifier or is reserved (see `names`), or that halcompile would change (a
//! double or trailing underscore), two signals or params with the same HAL name, a HAL name
//! longer than `HAL_NAME_LEN` for instance 0, a sample period outside [1 µs, `u32::MAX` µs]
//! (it is rounded to whole microseconds, as the C header's `NAME_PERIOD_US`).
//!
//! The C section pushes away (`#pragma push_macro`/`#undef`) every macro halcompile makes of
//! a pin, param or variable, `data`, and every identifier the pasted controller takes from the
//! spec, so the controller compiles as it does on its own; the floats are handled outside the
//! controller, by multiplications only (no division anywhere in the file).

mod c_section;
mod decls;
mod names;

use super::c;
use crate::ir::{SigId, SigKind};
use crate::lower::Plan;
use crate::qformat::{QFormat, Rounding};
use crate::text::g;
use std::fmt;

pub use names::HAL_NAME_LEN;

/// Why a spec cannot be represented as a LinuxCNC HAL component.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unrepresentable(pub String);

impl fmt::Display for Unrepresentable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Unrepresentable {}

/// The component's name, `qloop_<spec name>`; halcompile requires the file to be
/// `<component name>.comp`.
pub fn component_name(plan: &Plan) -> String {
    format!("qloop_{}", plan.prog.name)
}

/// The marker lines around the pasted controller and the glue, which
/// `targets/linuxcnc/run.sh` extracts for its host reference build.
pub const MARKERS: [&str; 4] = [
    "/* ==== qloop:controller:begin ==== */",
    "/* ==== qloop:controller:end ==== */",
    "/* ==== qloop:glue:begin ==== */",
    "/* ==== qloop:glue:end ==== */",
];

/// The `.comp` file for `plan` (any target; the CLI plans for `host`).
pub fn component(plan: &Plan) -> Result<String, Unrepresentable> {
    let l = layout(plan)?;
    let mut o = decls::declarations(plan, &l);
    o.push_str(";;\n");
    o.push_str(&c_section::c_section(plan, &l));
    Ok(o)
}

/// One input or output as the component sees it.
struct Port {
    id: SigId,
    /// HAL name (a C identifier, `_` for `-`).
    hal: String,
    /// Field in the controller's C structs: `fc`, or `phi[1]` for a vector's element.
    field: String,
    q: QFormat,
    /// Raw range: the saturation bounds of an input, the proved range of an output.
    raw: (i128, i128),
}

/// What the component exposes, validated.
struct Layout {
    comp: String,
    /// HAL prefix of instance 0: `qloop-NAME.0`.
    inst: String,
    inputs: Vec<Port>,
    outputs: Vec<Port>,
    /// HAL name, value, spec index of each `param`.
    params: Vec<(String, f64, usize)>,
    period_us: u64,
    /// The first output's value that means adaptive feed 1 (its range maximum, or 100 %
    /// for an override), and its reciprocal as the multiplier.
    full_scale: f64,
    override_scale: f64,
    /// Why that value: `the range maximum of feed (5 mm/s)` or `100 %: ovr is a feed
    /// override`.
    scale_why: String,
}

/// Component variables (halcompile `variable`), beside pins and params.
const VARIABLES: [&str; 1] = ["countdown_ns"];

fn err<T>(spec: &str, msg: impl fmt::Display) -> Result<T, Unrepresentable> {
    Err(Unrepresentable(format!(
        "spec `{spec}` cannot become a LinuxCNC HAL component: {msg}"
    )))
}

fn port(plan: &Plan, id: SigId, hal: Option<&str>) -> Result<Port, Unrepresentable> {
    let spec = &plan.prog.name;
    let s = plan.prog.sig(id);
    let kind = super::kind_name(s.kind);
    let hal = match hal {
        Some(h) => h.to_string(),
        None => match names::hal_name(&s.name) {
            Some(h) => h,
            None => {
                return err(
                    spec,
                    format!(
                        "{kind} `{}` is not an ASCII identifier, as HAL names must be",
                        s.label()
                    ),
                )
            }
        },
    };
    let q = plan.format(id);
    let raw = match plan.raw_bounds(id) {
        Some(b) => b,
        None => {
            let (lo, hi) = plan.summary[id.0].range;
            (
                q.raw_floor(lo).max(q.ty.min()),
                q.raw_ceil(hi).min(q.ty.max()),
            )
        }
    };
    if raw.0 < i32::MIN as i128 || raw.1 > i32::MAX as i128 {
        return err(
            spec,
            format!(
                "the raw {kind} `{}` ({}, raw range [{}, {}]) does not fit a HAL s32 pin; \
                 give it fewer fraction bits (`#[q(i32, F)]` or `#[lsb(..)]`)",
                s.label(),
                q,
                raw.0,
                raw.1
            ),
        );
    }
    Ok(Port {
        id,
        hal,
        field: c::field(&plan.prog, id),
        q,
        raw,
    })
}

fn layout(plan: &Plan) -> Result<Layout, Unrepresentable> {
    let p = &plan.prog;
    let spec = &p.name;
    let in_ids: Vec<SigId> = p.ids_of(SigKind::Input).collect();
    let out_ids: Vec<SigId> = p.ids_of(SigKind::Output).collect();
    if in_ids.is_empty() {
        return err(
            spec,
            "it has no input (the first input is the `spindle-load` pin)",
        );
    }
    if out_ids.is_empty() {
        return err(
            spec,
            "it has no output (the first output drives `adaptive-feed`)",
        );
    }
    let inputs = in_ids
        .iter()
        .enumerate()
        .map(|(i, id)| port(plan, *id, (i == 0).then_some("spindle_load")))
        .collect::<Result<Vec<_>, _>>()?;
    let outputs = out_ids
        .iter()
        .map(|id| port(plan, *id, None))
        .collect::<Result<Vec<_>, _>>()?;
    let mut params = Vec::new();
    for (i, c) in p.constants.iter().enumerate().filter(|(_, c)| c.is_param) {
        let Some(h) = names::hal_name(&c.name) else {
            return err(
                spec,
                format!(
                    "param `{}` is not an ASCII identifier, as HAL names must be",
                    c.name
                ),
            );
        };
        if !c.value.is_finite() {
            return err(spec, format!("param `{}` is not finite", c.name));
        }
        params.push((h, c.value, i));
    }
    let period_us = (p.period * 1e6).round();
    if !(1.0..=u32::MAX as f64).contains(&period_us) {
        return err(
            spec,
            format!(
                "its period {} s, rounded to microseconds, is not in [1 us, {} us] (the \
                 `period-us` param is a HAL u32)",
                p.period,
                u32::MAX
            ),
        );
    }
    let first = &outputs[0];
    let fo = p.sig(first.id);
    if fo.flag {
        return err(
            spec,
            format!(
                "its first output `{}` is a `#[flag]`, but the first output drives \
                 `adaptive-feed`; declare the feed output first",
                fo.name
            ),
        );
    }
    let unit = crate::units::parse(fo.unit.as_deref().unwrap_or("")).ok();
    // A dimensionless first output (a fraction, or %) is already an override: 1 (100 %) is
    // adaptive feed 1. Anything else is scaled by its range maximum.
    let (full_scale, scale_why) = match unit {
        Some(u) if u.is_dimensionless() && fo.unit.is_some() => (
            1.0 / u.scale,
            format!(
                "{} {}: `{}` is a feed override (above it LinuxCNC caps adaptive-feed at 1)",
                g(1.0 / u.scale),
                fo.unit.as_deref().unwrap_or(""),
                fo.label()
            ),
        ),
        _ => {
            let m = plan.summary[first.id.0].range.1;
            (
                m,
                format!(
                    "the range maximum of {} ({}{})",
                    fo.label(),
                    g(m),
                    fo.unit
                        .as_deref()
                        .map(|u| format!(" {u}"))
                        .unwrap_or_default()
                ),
            )
        }
    };
    let override_scale = 1.0 / full_scale;
    if !(full_scale > 0.0 && override_scale.is_finite() && override_scale > 0.0) {
        return err(
            spec,
            format!(
                "`adaptive-feed` is the first output `{n}` scaled by its range maximum, which \
                 is {} here; it must be positive (declare or widen `output {n}: [LO, HI]` with \
                 HI > 0)",
                g(full_scale),
                n = p.sig(first.id).label()
            ),
        );
    }
    let comp = component_name(plan);
    let l = Layout {
        inst: format!("{}.0", names::dashed(&comp)),
        comp,
        inputs,
        outputs,
        params,
        period_us: period_us as u64,
        full_scale,
        override_scale,
        scale_why,
    };
    check_names(plan, &l)?;
    Ok(l)
}

/// Every HAL name (pins, then params) and what it comes from, in declaration order.
fn hal_names(plan: &Plan, l: &Layout) -> Vec<(String, String)> {
    let p = &plan.prog;
    let what = |id: SigId| {
        format!(
            "{} `{}`",
            super::kind_name(p.sig(id).kind),
            p.sig(id).label()
        )
    };
    let mut v: Vec<(String, String)> = Vec::new();
    for i in &l.inputs {
        v.push((i.hal.clone(), what(i.id)));
    }
    v.push(("adaptive_feed".into(), "the override pin".into()));
    for o in &l.outputs {
        v.push((o.hal.clone(), what(o.id)));
        v.push((
            format!("{}_raw", o.hal),
            format!("the raw pin of {}", what(o.id)),
        ));
    }
    for i in &l.inputs {
        v.push((
            format!("{}_raw", i.hal),
            format!("the raw pin of {}", what(i.id)),
        ));
    }
    v.push(("steps".into(), "the step counter pin".into()));
    for (h, _, i) in &l.params {
        v.push((h.clone(), format!("param `{}`", p.constants[*i].name)));
    }
    v.push(("period_us".into(), "the period param".into()));
    v
}

fn check_names(plan: &Plan, l: &Layout) -> Result<(), Unrepresentable> {
    let spec = &plan.prog.name;
    let mut taken: Vec<(String, String)> = VARIABLES
        .iter()
        .map(|v| (v.to_string(), format!("the component variable `{v}`")))
        .collect();
    for (name, what) in hal_names(plan, l) {
        if let Some(why) =
            names::reserved(&name, spec).or_else(|| names::changed_by_halcompile(&name))
        {
            return err(spec, format!("{what}: {why}; rename it in the spec"));
        }
        if let Some((_, other)) = taken.iter().find(|(n, _)| *n == name) {
            return err(
                spec,
                format!("{what} and {other} would both be the HAL name `{name}`; rename one"),
            );
        }
        let full = format!("{}.{}", l.inst, names::dashed(&name));
        if full.len() > HAL_NAME_LEN {
            return err(
                spec,
                format!(
                    "the HAL name `{full}` of {what} has {} characters, more than HAL's {} \
                     (shorten the spec's name or the signal's)",
                    full.len(),
                    HAL_NAME_LEN
                ),
            );
        }
        taken.push((name, what));
    }
    let longest = format!("{}.tmax-increased", l.inst);
    if longest.len() > HAL_NAME_LEN {
        return err(
            spec,
            format!(
                "HAL's own param `{longest}` would have {} characters, more than {} \
                 (shorten the spec's name)",
                longest.len(),
                HAL_NAME_LEN
            ),
        );
    }
    Ok(())
}

/// Physical unit of a signal or constant, with a leading space (empty if none).
fn unit(u: &Option<String>) -> String {
    match u.as_deref() {
        Some(u) if !u.is_empty() => format!(" {u}"),
        _ => String::new(),
    }
}

/// `2^12`, `2^-12`.
fn pow2_text(e: i32) -> String {
    format!("2^{e}")
}

/// A power of two as a C99 hexadecimal floating constant: `0x1p12`.
fn pow2_c(e: i32) -> String {
    format!("0x1p{e}")
}

/// A double as a C (and halcompile) literal: Rust's shortest round-trip form, which C's
/// correctly rounded conversion reads back to the same double.
fn double_c(v: f64) -> String {
    format!("{v:?}")
}

/// A spec doc comment as one line of text, followed by a space (empty if there is none).
fn doc_prefix(docs: &[String]) -> String {
    let d = docs.join(" ");
    let d = d.trim();
    if d.is_empty() {
        String::new()
    } else if d.ends_with(['.', '!', '?', ':']) {
        format!("{d} ")
    } else {
        // A doc line without a full stop would run into the next sentence.
        format!("{d}. ")
    }
}

/// The raw conversion of input `i`, as documentation: `floor(spindle-load * 2^12)`.
fn conversion_text(plan: &Plan, i: &Port) -> String {
    let x = format!("{} * {}", names::dashed(&i.hal), pow2_text(i.q.frac));
    match plan.prog.rounding {
        Rounding::Floor => format!("floor({x})"),
        Rounding::Nearest => format!("floor({x} + 1/2)"),
    }
}
