//! Dead-value elimination: the plan keeps only values that reach a store or a branch.
//!
//! Lowering can compute values nobody reads: the other factor of a product by `0.0`, an
//! input or a `let` the step never uses, a condition whose branches store nothing. Emitted,
//! they are unused variables (`-Werror=unused-variable` in C, `unused_variables` in Rust)
//! and dead proof obligations. Every operation of the plan is pure, so dropping them changes
//! nothing the step computes. The pass renumbers the surviving values in their original order,
//! so that every value of [`Plan::vals`](super::Plan::vals) is defined in the body and used.

use super::lir::{LStmt, Val, ValId};

/// Removes every value that no store or branch uses, directly or through other values, and
/// every `if` left with two empty branches; renumbers what remains.
pub fn eliminate(vals: Vec<Val>, mut body: Vec<LStmt>) -> (Vec<Val>, Vec<LStmt>) {
    loop {
        let mut live = vec![false; vals.len()];
        mark(&vals, &body, &mut live);
        let before = count(&body);
        body = prune(body, &live);
        if count(&body) == before {
            return renumber(vals, body, &live);
        }
    }
}

/// Which values a store or a branch uses, directly or through other values (before
/// [`eliminate`] renumbers them).
pub fn live(vals: &[Val], body: &[LStmt]) -> Vec<bool> {
    let mut live = vec![false; vals.len()];
    mark(vals, body, &mut live);
    live
}

/// Marks what the statements use, walking backwards (a value is defined before its uses).
fn mark(vals: &[Val], body: &[LStmt], live: &mut [bool]) {
    for s in body.iter().rev() {
        match s {
            LStmt::Store(_, v) => live[v.0] = true,
            LStmt::If(c, t, e) => {
                mark(vals, e, live);
                mark(vals, t, live);
                live[c.0] = true;
            }
            LStmt::Def(id) => {
                if live[id.0] {
                    for a in vals[id.0].op.operands() {
                        live[a.0] = true;
                    }
                }
            }
        }
    }
}

/// The body without dead definitions and without `if`s whose branches are both empty.
fn prune(body: Vec<LStmt>, live: &[bool]) -> Vec<LStmt> {
    body.into_iter()
        .filter_map(|s| match s {
            LStmt::Def(id) => live[id.0].then_some(LStmt::Def(id)),
            LStmt::Store(..) => Some(s),
            LStmt::If(c, t, e) => {
                let (t, e) = (prune(t, live), prune(e, live));
                (!(t.is_empty() && e.is_empty())).then_some(LStmt::If(c, t, e))
            }
        })
        .collect()
}

fn count(body: &[LStmt]) -> usize {
    body.iter()
        .map(|s| match s {
            LStmt::If(_, t, e) => 1 + count(t) + count(e),
            _ => 1,
        })
        .sum()
}

fn renumber(vals: Vec<Val>, body: Vec<LStmt>, live: &[bool]) -> (Vec<Val>, Vec<LStmt>) {
    let mut map = vec![ValId(usize::MAX); vals.len()];
    let mut kept = Vec::new();
    for (i, v) in vals.into_iter().enumerate() {
        if live[i] {
            map[i] = ValId(kept.len());
            kept.push(v);
        }
    }
    for v in &mut kept {
        v.op = v.op.map_operands(|a| map[a.0]);
    }
    (kept, rewrite(body, &map))
}

fn rewrite(body: Vec<LStmt>, map: &[ValId]) -> Vec<LStmt> {
    body.into_iter()
        .map(|s| match s {
            LStmt::Def(id) => LStmt::Def(map[id.0]),
            LStmt::Store(sig, v) => LStmt::Store(sig, map[v.0]),
            LStmt::If(c, t, e) => LStmt::If(map[c.0], rewrite(t, map), rewrite(e, map)),
        })
        .collect()
}
