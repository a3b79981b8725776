//! Binding a spec to a plant's contract ([`qloop_plant::Contract`]) before anything is
//! compiled: units by dimension (with the conversion factors the runner applies), a feed
//! override through a nominal feed, further inputs to scenario channels, and the reference
//! the run is measured against. Errors say what the plant offers.

use super::error::{CliError, CliResult};
use qloop::ir::{Constant, Program, SigKind};
use qloop::units::{self, Unit};
use qloop_plant::{Binding, Contract, Plant, Reference, Scenario};

/// A spec bound to a plant.
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    /// Unit conversions for the runner.
    pub binding: Binding,
    /// The reference the run is measured against.
    pub reference: Reference,
    /// What the binding did, for the summary (`feed override in %: 100 % = 2 mm/s`).
    pub notes: Vec<String>,
}

/// A unit string of the spec or the plant, parsed (the spec's were checked by the compiler;
/// the plant's are the plant's own).
fn unit(text: Option<&str>) -> Unit {
    units::parse(text.unwrap_or("")).unwrap_or(Unit::ONE)
}

fn dim(u: &Unit) -> String {
    u.dimension_name()
        .map_or_else(|| u.dimension_text(), str::to_string)
}

/// The value of param `k` (marked `mark`) in unit `to`, or why not (`why`: what needs it).
fn param_in(k: &Constant, mark: &str, to: &Unit, why: &str) -> Result<f64, String> {
    let ku = unit(k.unit.as_deref());
    ku.factor_to(to).map(|f| k.value * f).ok_or_else(|| {
        format!(
            "the `{mark}` param `{}` is in \"{}\" ({}), but {why}",
            k.name,
            k.unit.as_deref().unwrap_or(""),
            dim(&ku)
        )
    })
}

/// Binds `prog` to `plant` for `sc`. `nominal` is the nominal feed from the command line, in
/// the plant's command unit (it overrides a `#[nominal]` param).
pub fn bind(
    prog: &Program,
    plant: &dyn Plant,
    sc: &Scenario,
    nominal: Option<f64>,
) -> CliResult<Bound> {
    let c = Contract::of(plant);
    let offer = || format!("\n\n{}(see `qloop plants`)", c.describe());
    let fail = |msg: String| CliError::input(format!("{msg}{}", offer()));
    let inputs: Vec<_> = prog.ids_of(SigKind::Input).map(|id| prog.sig(id)).collect();
    let outputs: Vec<_> = prog
        .ids_of(SigKind::Output)
        .map(|id| prog.sig(id))
        .collect();
    let (Some(first_in), Some(first_out)) = (inputs.first(), outputs.first()) else {
        return Err(fail(format!(
            "`{}` needs an input (the measurement) and an output (the command) to run on the {} plant",
            prog.name, c.plant
        )));
    };
    for (s, what) in [
        (first_in, "first input (the measurement)"),
        (first_out, "first output (the command)"),
    ] {
        if s.elem.is_some() {
            return Err(fail(format!(
                "the spec's {what} `{}` is an element of a vector: the plant exchanges one \
                 measurement and one command per step; declare a scalar first",
                s.label()
            )));
        }
    }
    let mut notes = Vec::new();

    // The measurement.
    let (m_unit, in_unit) = (unit(Some(c.measured.1)), unit(first_in.unit.as_deref()));
    let measured_scale = m_unit.factor_to(&in_unit).ok_or_else(|| {
        fail(format!(
            "the {} plant measures {} in {} ({}), but the spec's first input `{}` is in \"{}\" ({})",
            c.plant,
            c.measured.0,
            c.measured.1,
            dim(&m_unit),
            first_in.name,
            first_in.unit.as_deref().unwrap_or(""),
            dim(&in_unit)
        ))
    })?;
    if !m_unit.same(&in_unit) {
        notes.push(format!(
            "measurement: the plant's {} is converted to the spec's {} (×{})",
            c.measured.1,
            first_in.unit.as_deref().unwrap_or(""),
            qloop::text::g(measured_scale)
        ));
    }

    // The command: the same dimension converts; a dimensionless output is an override.
    let (c_unit, out_unit) = (unit(Some(c.command.1)), unit(first_out.unit.as_deref()));
    let out_text = first_out.unit.as_deref().unwrap_or("");
    let command_scale = match out_unit.factor_to(&c_unit) {
        Some(f) => {
            if !out_unit.same(&c_unit) {
                notes.push(format!(
                    "command: the spec's {out_text} is converted to the plant's {} (×{})",
                    c.command.1,
                    qloop::text::g(f)
                ));
            }
            f
        }
        None if out_unit.is_dimensionless() && c_unit.dimension_name() == Some("velocity") => {
            let spec_nominal = prog.constants.iter().find(|k| k.nominal);
            let (value, source) = match (nominal, spec_nominal) {
                (Some(v), _) => (v, "--nominal-feed".to_string()),
                (None, Some(k)) => {
                    let why = format!("the {} plant's command is in {}", c.plant, c.command.1);
                    let v = param_in(k, "#[nominal]", &c_unit, &why).map_err(fail)?;
                    (v, format!("param {}", k.name))
                }
                (None, None) => {
                    return Err(fail(format!(
                        "the spec's first output `{}` is dimensionless (\"{out_text}\"): a feed \
                         override. Give the nominal feed it scales, in {}: mark a param \
                         `#[nominal] param FNOM: 2.0 \"{}\";` or pass `--nominal-feed 2.0`",
                        first_out.name, c.command.1, c.command.1
                    )))
                }
            };
            if !(value.is_finite() && value > 0.0) {
                return Err(fail(format!(
                    "the nominal feed ({source}) must be positive, not {value}"
                )));
            }
            notes.push(format!(
                "command: `{}` is a feed override; 1 (= {}) is the nominal feed {} {} ({source})",
                first_out.name,
                if out_text.trim() == "%" {
                    "100 %".to_string()
                } else {
                    "1".to_string()
                },
                qloop::text::g(value),
                c.command.1
            ));
            out_unit.scale * value
        }
        None => {
            return Err(fail(format!(
                "the {} plant takes its {} command in {} ({}), but the spec's first output `{}` is in \"{out_text}\" ({})",
                c.plant,
                c.command.0,
                c.command.1,
                dim(&c_unit),
                first_out.name,
                dim(&out_unit)
            )))
        }
    };

    // Further inputs read scenario channels of their names, in the channel's unit.
    for s in inputs.iter().skip(1) {
        let from_plant = c.channel(&s.name);
        if from_plant.is_none() && !sc.channels.contains_key(&s.name) {
            let names: Vec<&str> = c.channels.iter().map(|c| c.name).collect();
            return Err(fail(format!(
                "the spec's input `{}` is not the plant's measurement, so it reads the scenario \
                 channel of its name, and neither the {} plant nor scenario `{}` has a channel \
                 `{}`. The plant's channels: {}; rename the input, or add a `{}` channel to a \
                 scenario TOML file",
                s.label(),
                c.plant,
                sc.name,
                s.name,
                names.join(", "),
                s.name
            )));
        }
        if let Some(ch) = from_plant {
            let (cu, su) = (unit(Some(ch.unit)), unit(s.unit.as_deref()));
            if !cu.same(&su) {
                return Err(fail(format!(
                    "the spec's input `{}` is in \"{}\", but the channel `{}` is in {}: declare the input in {}",
                    s.name,
                    s.unit.as_deref().unwrap_or(""),
                    ch.name,
                    ch.unit,
                    ch.unit
                )));
            }
        }
    }

    // The reference: a `#[reference]` param, else a param named FR in the measured
    // dimension; else the plant's (its default, or the scenario's `fr` channel, which an
    // input `fr` reads too).
    let marked = prog.constants.iter().find(|k| k.reference);
    let by_name = prog
        .constants
        .iter()
        .find(|k| k.is_param && k.name == "FR" && unit(k.unit.as_deref()).same_dimension(&m_unit));
    let reference = match marked.or(by_name) {
        Some(k) => {
            let ku = unit(k.unit.as_deref());
            // In the unit of the controller's input: the trace column the metrics compare.
            let why = format!(
                "the {} plant measures {} in {}",
                c.plant, c.measured.0, c.measured.1
            );
            let value = param_in(k, "#[reference]", &in_unit, &why).map_err(fail)?;
            if sc.channels.contains_key("fr") && !inputs.iter().any(|s| s.name == "fr") {
                notes.push(format!(
                    "the scenario's `fr` channel is not used: the controller holds its param {}",
                    k.name
                ));
            }
            let converted = if ku.same(&in_unit) {
                String::new()
            } else {
                format!(
                    " = {} {}",
                    qloop::text::g(value),
                    first_in.unit.as_deref().unwrap_or("")
                )
            };
            Reference::Constant {
                value,
                source: format!(
                    "the spec's {}param {} = {} {}{converted}",
                    if k.reference { "#[reference] " } else { "" },
                    k.name,
                    qloop::text::g(k.value),
                    k.unit.as_deref().unwrap_or("")
                ),
            }
        }
        None => Reference::Plant {
            scale: measured_scale,
        },
    };
    Ok(Bound {
        binding: Binding {
            measured_scale,
            command_scale,
        },
        reference,
        notes,
    })
}
