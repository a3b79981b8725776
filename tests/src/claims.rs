//! Checks what `qloop check` prints against a concrete step: every printed error bound holds
//! against exact rational arithmetic, and where a branch decision differs from the exact one,
//! the operands really were within the comparison's printed band.

use crate::cases::Case;
use crate::exact::{self, Q};
use qloop::interp::step_fixed_trace;
use qloop::ir::{SigId, SigKind};
use qloop::lower::lir::{LStmt, Op, ValId};
use qloop::report::bound;
use qloop::Plan;

/// A bound as qloop prints it, as an exact rational.
pub fn printed(err: f64) -> Q {
    exact::of_decimal(&bound(err)).expect("a printed bound parses")
}

/// The comparisons `step` executed, in order, with their outcomes.
fn executed_cmps(plan: &Plan, trace: &[Option<i128>]) -> Vec<(ValId, bool)> {
    fn walk(plan: &Plan, s: &[LStmt], trace: &[Option<i128>], out: &mut Vec<(ValId, bool)>) {
        for st in s {
            match st {
                LStmt::Def(id) => {
                    if let (Op::Cmp(..), Some(v)) = (&plan.val(*id).op, trace[id.0]) {
                        out.push((*id, v != 0));
                    }
                }
                LStmt::Store(..) => {}
                LStmt::If(_, t, e) => {
                    walk(plan, t, trace, out);
                    walk(plan, e, trace, out);
                }
            }
        }
    }
    let mut out = Vec::new();
    walk(plan, &plan.body, trace, &mut out);
    out
}

/// The value holding signal `id` after the step, if the step computed it: a `let`'s binding,
/// an input's clamped value.
fn named_val(plan: &Plan, id: SigId) -> Option<ValId> {
    let name = &plan.prog.sig(id).name;
    plan.vals
        .iter()
        .enumerate()
        .rev()
        .find(|(_, v)| v.name.as_deref() == Some(name.as_str()) && !matches!(v.op, Op::Input(_)))
        .map(|(i, _)| ValId(i))
}

/// What one case showed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Checked {
    /// Signals whose error was compared with their bound.
    pub bounds: usize,
    /// Whether a decision differed from the exact one (and was within its band).
    pub branch_differed: bool,
}

/// Runs `case` through the plan interpreter and the exact reference; checks every printed
/// claim that applies. `Err` says which claim failed, with the numbers.
pub fn check(plan: &Plan, case: &Case) -> Result<Checked, String> {
    let prog = &plan.prog;
    let n = prog.signals.len();
    let mut fv = vec![0i128; n];
    let mut ev: Vec<Option<Q>> = vec![None; n];
    for (k, id) in prog.ids_of(SigKind::Input).enumerate() {
        fv[id.0] = case.inputs[k];
        ev[id.0] = Some(exact::of_raw(case.inputs[k], plan.format(id).frac));
    }
    for (k, id) in prog.ids_of(SigKind::State).enumerate() {
        fv[id.0] = case.states[k];
        ev[id.0] = Some(exact::of_raw(case.states[k], plan.format(id).frac));
    }
    let trace = step_fixed_trace(plan, &mut fv)
        .map_err(|v| format!("a value left its proved interval: {v:?}"))?;
    let decisions = exact::step(prog, &mut ev);
    // The first decision (in the fixed step's order) that differs from the exact one: the
    // paths agree up to it, so the exact step made it too.
    for (cmp, taken) in executed_cmps(plan, &trace) {
        let k = plan
            .val(cmp)
            .decision
            .ok_or("a comparison without its number")?;
        let m = decisions
            .iter()
            .find(|d| d.number == k)
            .ok_or_else(|| format!("the exact step did not make decision {k}"))?;
        if m.taken == taken {
            continue;
        }
        let band = printed(plan.val(cmp).err);
        if exact::dist(&m.margin, &Q::from_integer(0.into())) > band {
            return Err(format!(
                "decision {k} (value _{}, spec line {}) differs from real arithmetic with the \
                 operands {} apart, outside its printed band {}",
                cmp.0,
                plan.val(cmp).line,
                fmt(&m.margin),
                bound(plan.val(cmp).err)
            ));
        }
        return Ok(Checked {
            bounds: 0,
            branch_differed: true,
        });
    }
    let mut checked = 0;
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let got = match s.kind {
            SigKind::State | SigKind::Output => Some(exact::of_raw(fv[i], plan.format(id).frac)),
            SigKind::Input | SigKind::Local => named_val(plan, id).and_then(|v| {
                let val = plan.val(v);
                trace[v.0].map(|r| exact::of_raw(r, val.frac))
            }),
        };
        let (Some(got), Some(want)) = (got, ev[i].as_ref()) else {
            continue;
        };
        let b = printed(plan.summary[i].err);
        let d = exact::dist(&got, want);
        if d > b {
            return Err(format!(
                "`{}`: fixed {} vs exact {}: |error| {} > printed bound {}",
                s.name,
                fmt(&got),
                fmt(want),
                fmt(&d),
                bound(plan.summary[i].err)
            ));
        }
        checked += 1;
    }
    Ok(Checked {
        bounds: checked,
        branch_differed: false,
    })
}

/// Every shift of the plan is narrower than its operand's type (`x << 64` on an `i32` does not
/// compile; `x >> 32` on an `i32` is undefined in C).
pub fn shifts_within_width(plan: &Plan) -> Result<(), String> {
    for (i, v) in plan.vals.iter().enumerate() {
        if let Op::Shl(a, k) | Op::Shr(a, k) = v.op {
            let w = plan.val(a).ty.bits.min(v.ty.bits);
            if k >= w {
                return Err(format!("_{i}: shift by {k} of a {}-bit value", w));
            }
        }
    }
    Ok(())
}

/// A rational for messages, as an f64 (enough to read).
fn fmt(q: &Q) -> String {
    use num_traits::ToPrimitive;
    format!("{:e}", q.to_f64().unwrap_or(f64::NAN))
}
