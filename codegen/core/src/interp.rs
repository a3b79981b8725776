//! Interpreters: the fixed-point plan, bit for bit, and the IR in real (f64) arithmetic.
//!
//! The fixed interpreter is the executable definition of the generated code's semantics: the
//! emitted Rust (and later C and SMT) must agree with it bit for bit. It also checks every
//! intermediate against the interval the range analysis proved, so a wrong proof shows up as
//! [`RangeViolation`] in tests instead of as silent wrap-around.
//!
//! The real interpreter is the f64 reference: same body, real arithmetic, exact constants,
//! inputs clamped and states saturated to their declared (unquantised) ranges.

use crate::ir::{comparisons_in, Cond, Expr, Program, SigKind, Stmt};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;

/// A value left the interval the analysis proved for it: a bug in qloop.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RangeViolation {
    /// The value.
    pub val: ValId,
    /// What it computed.
    pub got: i128,
    /// The proved interval.
    pub range: (i128, i128),
}

/// Runs one step of the plan. `vars` holds raw input bits and raw state values, indexed by
/// signal id; it is updated in place (states and outputs). Returns the comparisons it made,
/// in execution order, as (the comparison's index in the reference's evaluation order,
/// outcome); see [`agree`].
pub fn step_fixed(plan: &Plan, vars: &mut [i128]) -> Result<Vec<(usize, bool)>, RangeViolation> {
    let mut m = Machine {
        plan,
        vals: vec![0; plan.vals.len()],
        decisions: Vec::new(),
    };
    m.block(&plan.body, vars)?;
    Ok(m.decisions)
}

/// Like [`step_fixed`], and also returns every value the step computed (`None` for values
/// in branches not taken). Used to check other models of the plan, value by value.
pub fn step_fixed_trace(
    plan: &Plan,
    vars: &mut [i128],
) -> Result<Vec<Option<i128>>, RangeViolation> {
    let mut m = Machine {
        plan,
        vals: vec![0; plan.vals.len()],
        decisions: Vec::new(),
    };
    let mut seen = vec![false; plan.vals.len()];
    m.block_traced(&plan.body, vars, &mut seen)?;
    Ok(m.vals
        .iter()
        .zip(seen)
        .map(|(v, s)| s.then_some(*v))
        .collect())
}

/// Whether the fixed step's decisions ([`step_fixed`]) equal the reference's ([`step_real`]):
/// every comparison the fixed step made, the reference made with the same outcome.
/// Comparisons whose value nothing uses are not in the plan, and do not count.
pub fn agree(fixed: &[(usize, bool)], real: &[(usize, bool)]) -> bool {
    fixed.iter().all(|f| real.contains(f))
}

struct Machine<'a> {
    plan: &'a Plan,
    vals: Vec<i128>,
    decisions: Vec<(usize, bool)>,
}

impl Machine<'_> {
    fn block(&mut self, stmts: &[LStmt], vars: &mut [i128]) -> Result<(), RangeViolation> {
        for s in stmts {
            match s {
                LStmt::Def(id) => {
                    let v = self.eval(*id, vars);
                    let val = self.plan.val(*id);
                    if !val.boolean && (v < val.lo || v > val.hi || !val.ty.holds(v, v)) {
                        return Err(RangeViolation {
                            val: *id,
                            got: v,
                            range: (val.lo, val.hi),
                        });
                    }
                    self.vals[id.0] = v;
                }
                LStmt::Store(sig, id) => vars[sig.0] = self.vals[id.0],
                LStmt::If(c, t, e) => {
                    if self.vals[c.0] != 0 {
                        self.block(t, vars)?
                    } else {
                        self.block(e, vars)?
                    }
                }
            }
        }
        Ok(())
    }

    fn block_traced(
        &mut self,
        stmts: &[LStmt],
        vars: &mut [i128],
        seen: &mut [bool],
    ) -> Result<(), RangeViolation> {
        for s in stmts {
            match s {
                LStmt::If(c, t, e) => {
                    if self.vals[c.0] != 0 {
                        self.block_traced(t, vars, seen)?
                    } else {
                        self.block_traced(e, vars, seen)?
                    }
                }
                other => {
                    if let LStmt::Def(id) = other {
                        seen[id.0] = true;
                    }
                    self.block(std::slice::from_ref(other), vars)?
                }
            }
        }
        Ok(())
    }

    fn eval(&mut self, id: ValId, vars: &[i128]) -> i128 {
        let g = |v: ValId| self.vals[v.0];
        match &self.plan.val(id).op {
            Op::Input(s) | Op::Load(s) => vars[s.0],
            Op::Const(c) => *c,
            Op::Cast(a) => g(*a),
            Op::Add(a, b) => g(*a) + g(*b),
            Op::Sub(a, b) => g(*a) - g(*b),
            Op::Neg(a) => -g(*a),
            Op::Shl(a, k) => g(*a) << k,
            Op::Shr(a, k) => g(*a) >> k,
            Op::Mul(a, b) => g(*a) * g(*b),
            Op::MulHi(a, b) => crate::lower::lir::mul_hi(g(*a), g(*b)),
            Op::Min(a, b) => g(*a).min(g(*b)),
            Op::Max(a, b) => g(*a).max(g(*b)),
            Op::Select(c, a, b) => {
                if g(*c) != 0 {
                    g(*a)
                } else {
                    g(*b)
                }
            }
            Op::Cmp(op, a, b) => {
                let r = op.eval(g(*a), g(*b));
                let k = self.plan.val(id).decision.unwrap_or(usize::MAX);
                self.decisions.push((k, r));
                i128::from(r)
            }
            Op::And(a, b) => i128::from(g(*a) != 0 && g(*b) != 0),
            Op::Or(a, b) => i128::from(g(*a) != 0 || g(*b) != 0),
            Op::Not(a) => i128::from(g(*a) == 0),
            Op::Low(a, k) => g(*a) & ((1i128 << k) - 1),
            Op::Lookup { table, delta, idx } => {
                let t = &self.plan.tables[*table];
                let v = if *delta { &t.deltas } else { &t.entries };
                // The index is proved in 0..=N; out of it, the interval check reports it.
                v[(g(*idx).max(0) as usize).min(v.len() - 1)]
            }
        }
    }
}

/// Runs one real-valued step of the program. `vars` holds input and state values by signal
/// id and is updated in place. Returns the comparisons it made, in execution order, as (the
/// comparison's static number, [`crate::ir::comparisons_in`], outcome).
pub fn step_real(prog: &Program, vars: &mut [f64]) -> Vec<(usize, bool)> {
    for (i, s) in prog.signals.iter().enumerate() {
        if s.kind == SigKind::Input {
            if let Some((lo, hi)) = s.range {
                vars[i] = vars[i].max(lo).min(hi);
            }
        }
    }
    let mut d = Decisions {
        next: 0,
        taken: Vec::new(),
        tables: &prog.tables,
    };
    run_block(prog, &prog.body, vars, &mut d);
    d.taken
}

/// The decisions of a real step, numbered statically (and the tables the step reads).
struct Decisions<'a> {
    next: usize,
    taken: Vec<(usize, bool)>,
    tables: &'a [crate::ir::Table],
}

fn run_block(prog: &Program, stmts: &[Stmt], vars: &mut [f64], d: &mut Decisions) {
    for s in stmts {
        match s {
            Stmt::Assign { target, value, .. } => {
                let mut v = eval(value, vars, d);
                let sig = prog.sig(*target);
                if sig.kind != SigKind::Local {
                    if let Some((lo, hi)) = sig.range {
                        v = v.max(lo).min(hi);
                    }
                }
                vars[target.0] = v;
            }
            Stmt::If { cond, then, els } => {
                if eval_cond(cond, vars, d) {
                    run_block(prog, then, vars, d);
                    d.next += comparisons_in(els);
                } else {
                    d.next += comparisons_in(then);
                    run_block(prog, els, vars, d)
                }
            }
        }
    }
}

fn eval(e: &Expr, vars: &[f64], d: &mut Decisions) -> f64 {
    match e {
        Expr::Const { value, .. } => *value,
        Expr::Var(id, _) => vars[id.0],
        Expr::Neg(a) => -eval(a, vars, d),
        Expr::Add(a, b) => eval(a, vars, d) + eval(b, vars, d),
        Expr::Sub(a, b) => eval(a, vars, d) - eval(b, vars, d),
        Expr::Mul(a, b, _) => eval(a, vars, d) * eval(b, vars, d),
        Expr::Min(a, b) => eval(a, vars, d).min(eval(b, vars, d)),
        Expr::Max(a, b) => eval(a, vars, d).max(eval(b, vars, d)),
        Expr::Table(t, a, _) => {
            let x = eval(a, vars, d);
            d.tables[*t].eval(x)
        }
        Expr::Select(c, a, b) => {
            // Same evaluation order as the plan: condition, then both arms.
            let c = eval_cond(c, vars, d);
            let (a, b) = (eval(a, vars, d), eval(b, vars, d));
            if c {
                a
            } else {
                b
            }
        }
    }
}

fn eval_cond(c: &Cond, vars: &[f64], d: &mut Decisions) -> bool {
    match c {
        Cond::Cmp(op, a, b) => {
            let k = d.next;
            d.next += 1;
            let (x, y) = (eval(a, vars, d), eval(b, vars, d));
            let r = op.eval(x, y);
            d.taken.push((k, r));
            r
        }
        Cond::And(a, b) => {
            let (x, y) = (eval_cond(a, vars, d), eval_cond(b, vars, d));
            x && y
        }
        Cond::Or(a, b) => {
            let (x, y) = (eval_cond(a, vars, d), eval_cond(b, vars, d));
            x || y
        }
        Cond::Not(a) => !eval_cond(a, vars, d),
    }
}
