//! `tune NAME in ..;`: the candidate values `qloop tune` may give a `param` or `const`.
//!
//! A `tune` item names a constant declared in the spec and lists its candidates in that
//! constant's unit: explicitly (`{A, B, ..}`), as a grid (`[LO, HI], step H`) or as every power
//! of two in a range (`[LO, HI], pow2`; shift gains, whose products lower to one shift). It
//! does not change the controller: the constant keeps its declared value.

use super::units::{self, ParamUnits};
use super::Checker;
use crate::diag::{Diag, Result};
use crate::ir::Tune;
use crate::lang::ast::{TuneDecl, TuneSet};
use syn::spanned::Spanned;

/// Most candidates one `tune` item may give.
pub const MAX_CANDIDATES: usize = 64;

impl Checker {
    /// Checks the `tune` items (after every constant is declared).
    pub(super) fn tunes(&self, items: &[&TuneDecl]) -> Result<Vec<Tune>> {
        let mut out: Vec<Tune> = Vec::new();
        for t in items {
            let name = t.name.to_string();
            let value_span = match self.const_value_spans.get(&name) {
                Some(s) if self.constants.iter().any(|c| c.name == name) => *s,
                _ => {
                    return Err(Diag::new(
                        t.name.span(),
                        format!("`{name}` is not a `param` or `const` of this spec"),
                    )
                    .label("not a constant")
                    .help("`tune` gives candidates for a declared `param` or `const`"))
                }
            };
            if self.rule_defaults.contains(&name) {
                return Err(Diag::new(
                    t.name.span(),
                    format!("`{name}` takes its value from a rule parameter's default"),
                )
                .label("a rule's default")
                .help(
                    "give the parameter a value in the `apply` item (`PARAM = VALUE`) to tune it",
                ));
            }
            if out.iter().any(|o| o.name == name) {
                return Err(Diag::new(t.name.span(), format!("`{name}` is tuned twice"))
                    .help("give all its candidates in one `tune` item"));
            }
            let unit = self.const_units.get(&name).cloned();
            let check_unit = |e: &syn::Expr| -> Result<f64> {
                let v = self.const_eval(e)?;
                if let Some(u) = &unit {
                    let what = format!("a candidate of `{name}`");
                    units::same(
                        u.clone(),
                        self.unit_of(e, &ParamUnits::new())?,
                        e.span(),
                        &what,
                    )?;
                }
                Ok(v)
            };
            let (mut values, pow2) = match &t.set {
                TuneSet::List(es) => (
                    es.iter().map(check_unit).collect::<Result<Vec<_>>>()?,
                    false,
                ),
                TuneSet::Step(r, h) => {
                    let (lo, hi, step) = (check_unit(&r.lo)?, check_unit(&r.hi)?, check_unit(h)?);
                    if lo > hi || lo.is_nan() || hi.is_nan() {
                        return Err(Diag::new(
                            r.span,
                            "the range is empty: write `[LO, HI]` with LO ≤ HI",
                        ));
                    }
                    if step <= 0.0 || step.is_nan() {
                        return Err(Diag::new(h.span(), "the step must be positive"));
                    }
                    let n = ((hi - lo) / step + 1e-9).floor();
                    if n + 1.0 > MAX_CANDIDATES as f64 {
                        return Err(too_many(t, n + 1.0));
                    }
                    // Each grid point from its index, so that errors do not accumulate.
                    (
                        (0..=n as usize).map(|k| lo + k as f64 * step).collect(),
                        false,
                    )
                }
                TuneSet::Pow2(r) => {
                    let (lo, hi) = (check_unit(&r.lo)?, check_unit(&r.hi)?);
                    if lo <= 0.0 || lo > hi || lo.is_nan() || hi.is_nan() {
                        return Err(Diag::new(
                            r.span,
                            "powers of two need a positive range: write `[LO, HI]` with 0 < LO ≤ HI",
                        ));
                    }
                    let (a, b) = (lo.log2().ceil() as i32, hi.log2().floor() as i32);
                    if a > b {
                        return Err(Diag::new(r.span, "no power of two lies in this range")
                            .help("widen it to include one, e.g. `[0.25, 0.5]`"));
                    }
                    if (b - a + 1) as usize > MAX_CANDIDATES {
                        return Err(too_many(t, (b - a + 1) as f64));
                    }
                    ((a..=b).map(|k| 2f64.powi(k)).collect(), true)
                }
            };
            if values.len() > MAX_CANDIDATES {
                return Err(too_many(t, values.len() as f64));
            }
            values.sort_by(f64::total_cmp);
            values.dedup();
            out.push(Tune {
                name,
                values,
                pow2,
                value_span,
                span: t.span,
            });
        }
        Ok(out)
    }
}

fn too_many(t: &TuneDecl, n: f64) -> Diag {
    Diag::new(
        t.span,
        format!(
            "`tune {}` gives {n} candidates, more than {MAX_CANDIDATES}",
            t.name
        ),
    )
    .help("use a coarser step or a narrower range: the tuner tries every combination")
}
