//! The reference semantics of a spec in exact rational arithmetic, written independently of
//! the compiler: the truth that error bounds and branch decisions are checked against.
//!
//! The same semantics as the f64 reference (`qloop::interp::step_real`, the emitted
//! `_ref` module), without its rounding: constants are the exact values of their f64 literals,
//! inputs are clamped to their declared ranges, states and ranged outputs saturate to theirs on
//! every write, `min`/`max`/`clamp`/`if` as written, every operand evaluated.

use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, Zero};
use qloop::ir::{comparisons_in, Cond, Expr, Program, SigKind, Stmt};

/// An exact rational.
pub type Q = BigRational;

/// The exact value of an f64.
pub fn of_f64(v: f64) -> Q {
    BigRational::from_float(v).expect("finite")
}

/// `raw · 2^-frac`, exactly.
pub fn of_raw(raw: i128, frac: i32) -> Q {
    let r = BigRational::from_integer(BigInt::from(raw));
    let p = BigRational::from_integer(BigInt::from(1) << frac.unsigned_abs());
    if frac >= 0 {
        r / p
    } else {
        r * p
    }
}

/// A decimal such as `1.563e-4` or `-0.25`, exactly (what qloop printed).
pub fn of_decimal(s: &str) -> Option<Q> {
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let neg = mant.starts_with('-');
    let mant = mant.trim_start_matches(['-', '+']);
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let digits: BigInt = format!("{int}{frac}").parse().ok()?;
    let scale = exp - frac.len() as i32;
    let ten = BigInt::from(10).pow(scale.unsigned_abs());
    let mut q = if scale >= 0 {
        BigRational::from_integer(digits * ten)
    } else {
        BigRational::new(digits, ten)
    };
    if neg {
        q = -q;
    }
    Some(q)
}

/// One comparison as evaluated: its static number (`qloop::ir::comparisons_in`), its outcome
/// and `lhs − rhs`.
#[derive(Clone, Debug)]
pub struct Decision {
    /// The comparison's number.
    pub number: usize,
    /// The outcome.
    pub taken: bool,
    /// The difference of its operands.
    pub margin: Q,
}

/// Runs one exact step. `vars` holds the input values and the state values by signal id
/// (others `None`) and is updated in place; lets and outputs are written as they are
/// assigned. Returns the comparisons it made, in evaluation order.
pub fn step(prog: &Program, vars: &mut [Option<Q>]) -> Vec<Decision> {
    for (i, s) in prog.signals.iter().enumerate() {
        if s.kind == SigKind::Input {
            if let (Some(v), Some(r)) = (vars[i].take(), s.range) {
                vars[i] = Some(clamp(v, r));
            }
        }
    }
    let mut d = Decisions {
        tables: prog.tables.clone(),
        ..Decisions::default()
    };
    block(prog, &prog.body, vars, &mut d);
    d.made
}

/// Decisions so far, and the number of the next comparison (and the tables the step reads).
#[derive(Default)]
struct Decisions {
    next: usize,
    made: Vec<Decision>,
    tables: Vec<qloop::ir::Table>,
}

/// A table's value in exact arithmetic: the linear interpolation of its f64 samples, the
/// argument clamped to the grid's range (`ir::Table::eval` without the f64 rounding).
fn table(t: &qloop::ir::Table, x: Q) -> Q {
    use num_traits::ToPrimitive;
    let x = clamp(x, (t.lo, t.hi));
    let u = (x - of_f64(t.lo)) / of_f64(t.step);
    let i = u
        .floor()
        .to_integer()
        .to_usize()
        .unwrap_or(0)
        .min(t.segments() - 1);
    let tt = u - Q::from_integer(BigInt::from(i));
    let (s0, s1) = (of_f64(t.samples[i]), of_f64(t.samples[i + 1]));
    s0.clone() + tt * (s1 - s0)
}

fn clamp(v: Q, (lo, hi): (f64, f64)) -> Q {
    let (lo, hi) = (of_f64(lo), of_f64(hi));
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

fn block(prog: &Program, stmts: &[Stmt], vars: &mut [Option<Q>], d: &mut Decisions) {
    for s in stmts {
        match s {
            Stmt::Assign { target, value, .. } => {
                let mut v = eval(value, vars, d);
                let sig = prog.sig(*target);
                if sig.kind != SigKind::Local {
                    if let Some(r) = sig.range {
                        v = clamp(v, r);
                    }
                }
                vars[target.0] = Some(v);
            }
            Stmt::If { cond: c, then, els } => {
                if cond(c, vars, d) {
                    block(prog, then, vars, d);
                    d.next += comparisons_in(els);
                } else {
                    d.next += comparisons_in(then);
                    block(prog, els, vars, d)
                }
            }
        }
    }
}

fn eval(e: &Expr, vars: &[Option<Q>], d: &mut Decisions) -> Q {
    match e {
        Expr::Const { value, .. } => of_f64(*value),
        Expr::Var(id, _) => vars[id.0].clone().expect("read after write"),
        Expr::Neg(a) => -eval(a, vars, d),
        Expr::Add(a, b) => eval(a, vars, d) + eval(b, vars, d),
        Expr::Sub(a, b) => eval(a, vars, d) - eval(b, vars, d),
        Expr::Mul(a, b, _) => eval(a, vars, d) * eval(b, vars, d),
        Expr::Min(a, b) => eval(a, vars, d).min(eval(b, vars, d)),
        Expr::Max(a, b) => eval(a, vars, d).max(eval(b, vars, d)),
        Expr::Table(t, a, _) => {
            let x = eval(a, vars, d);
            table(&d.tables[*t], x)
        }
        Expr::Select(c, a, b) => {
            let c = cond(c, vars, d);
            let (a, b) = (eval(a, vars, d), eval(b, vars, d));
            if c {
                a
            } else {
                b
            }
        }
    }
}

fn cond(c: &Cond, vars: &[Option<Q>], d: &mut Decisions) -> bool {
    match c {
        Cond::Cmp(op, a, b) => {
            let number = d.next;
            d.next += 1;
            let (x, y) = (eval(a, vars, d), eval(b, vars, d));
            let taken = op.eval(&x, &y);
            d.made.push(Decision {
                number,
                taken,
                margin: x - y,
            });
            taken
        }
        Cond::And(a, b) => {
            let (x, y) = (cond(a, vars, d), cond(b, vars, d));
            x && y
        }
        Cond::Or(a, b) => {
            let (x, y) = (cond(a, vars, d), cond(b, vars, d));
            x || y
        }
        Cond::Not(a) => !cond(a, vars, d),
    }
}

/// `|a − b|`.
pub fn dist(a: &Q, b: &Q) -> Q {
    (a - b).abs()
}

/// Whether `q` is zero.
pub fn is_zero(q: &Q) -> bool {
    q.is_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_and_raw_values_are_exact() {
        assert_eq!(
            of_decimal("1.563e-4"),
            Some(BigRational::new(1563.into(), 10_000_000.into()))
        );
        assert_eq!(of_decimal("-0.25"), Some(of_f64(-0.25)));
        assert_eq!(of_decimal("3e2"), Some(of_f64(300.0)));
        assert_eq!(of_raw(3, 2), of_f64(0.75));
        assert_eq!(of_raw(3, -2), of_f64(12.0));
        // 0.1 is not 1/10: the f64 literal is a binary fraction.
        assert_ne!(of_f64(0.1), of_decimal("0.1").unwrap());
    }
}
