//! `#[flag]` outputs hold 0 or 1 (the LinuxCNC component makes them `bit` pins, TRUE above
//! 1/2): every value stored to one must be 0 or 1. A value is 0/1 when it is the constant 0
//! or 1, or a signal whose every store is 0/1 (and, for a state, whose initial value is): the
//! largest such set of signals, found by removing offenders until none is left. A flag that
//! receives anything else (`0.4`, `-1`, `2.0`, a continuous value) is refused at that store.

use crate::diag::{Diag, Result};
use crate::ir::{Expr, SigId, SigKind, Signal, Stmt};
use proc_macro2::Span;

/// Every store of `body`, in order: (target, value, site).
fn stores<'a>(body: &'a [Stmt], out: &mut Vec<(SigId, &'a Expr, Span)>) {
    for s in body {
        match s {
            Stmt::Assign {
                target,
                value,
                span,
            } => out.push((*target, value, *span)),
            Stmt::If { then, els, .. } => {
                stores(then, out);
                stores(els, out);
            }
        }
    }
}

/// Whether `e` is 0/1 given the signals currently taken as 0/1.
fn binary(e: &Expr, ok: &[bool]) -> bool {
    match e {
        Expr::Const { value, .. } => *value == 0.0 || *value == 1.0,
        Expr::Var(id, _) => ok[id.0],
        _ => false,
    }
}

/// Refuses a `#[flag]` output that may receive a value other than 0 or 1 (module docs).
pub(super) fn check(signals: &[Signal], body: &[Stmt]) -> Result<()> {
    if !signals.iter().any(|s| s.flag) {
        return Ok(());
    }
    let mut all = Vec::new();
    stores(body, &mut all);
    // Start from every stored signal whose initial value (if any) is 0 or 1.
    let mut ok: Vec<bool> = signals
        .iter()
        .enumerate()
        .map(|(i, s)| {
            s.kind != SigKind::Input
                && all.iter().any(|(t, ..)| t.0 == i)
                && s.init.is_none_or(|v| v == 0.0 || v == 1.0)
        })
        .collect();
    loop {
        let mut changed = false;
        for (t, v, _) in &all {
            if ok[t.0] && !binary(v, &ok) {
                ok[t.0] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    for (t, v, span) in &all {
        let s = &signals[t.0];
        if s.flag && !binary(v, &ok) {
            let what = match v {
                Expr::Const { value, .. } => format!("the constant {}", crate::text::g(*value)),
                Expr::Var(id, _) => format!(
                    "`{}`, which is not 0 or 1 on every path",
                    signals[id.0].name
                ),
                _ => "a computed value".to_string(),
            };
            return Err(Diag::new(
                *span,
                format!("`#[flag]` output `{}` is 0 or 1; this stores {what}", s.name),
            )
            .label("not 0 or 1")
            .help("store 0.0 or 1.0 (in an `if` on the condition), or a state that only ever holds 0.0 or 1.0; or drop `#[flag]` for a continuous output"));
        }
    }
    Ok(())
}
