//! Compile-time mathematics: the values of `param`s, `const`s, `period`, ranges and initial
//! values. Besides `+ - *` these may divide and call `exp`, `ln`, `sqrt`, `powf`, `abs`,
//! `min`, `max`, `clamp` (as functions or methods), because nothing of them runs on the target: the
//! value is computed here, in f64, and each use quantises it (that error is counted in
//! `qloop check`, like any constant's). Division in `step` stays a located error.
//!
//! f64 semantics: `+ − × ÷` and `sqrt` are correctly rounded (IEEE 754); `exp`, `ln` and `powf`
//! are Rust's (the platform libm, within an ulp or two). A result that is not finite (division
//! by zero, `ln` of a non-positive number, `sqrt` of a negative one, overflow) is an error at
//! the operator or call, and so is an underflow: a product, quotient or `exp`/`powf` of
//! non-zero values below 2.2e-308 in magnitude (`exp(-800.0)`, `1e-200 * 1e-200`), which f64
//! holds only as 0 or with lost digits. (A sum that cancels to 0 is exact, not an underflow.)

use super::{lit_value, path_ident, Checker, DIVISION_HELP};
use crate::diag::{Diag, Result};
use proc_macro2::Span;
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, UnOp};

/// `v`, or the overflow error at `span`.
fn finite(v: f64, span: Span) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Diag::new(
            span,
            "this constant expression overflows: its value is beyond the f64 range (±1.8e308)",
        )
        .label("overflows")
        .help("use smaller constants: scale the units, or write the product's value directly"))
    }
}

/// The underflow error at `span`.
pub(super) fn underflow(span: Span) -> Diag {
    Diag::new(
        span,
        "this constant is below the f64 range (2.2e-308 in magnitude): it would be 0 or lose its digits",
    )
    .label("underflows")
    .help("scale the units so that the constant is nearer 1, or write 0 if 0 is meant")
}

/// `v`, or the underflow error at `span` where `v` is below the normal f64 range although the
/// operation's operands are not zero.
fn normal(v: f64, operands_nonzero: bool, span: Span) -> Result<f64> {
    if operands_nonzero && v.abs() < f64::MIN_POSITIVE {
        Err(underflow(span))
    } else {
        Ok(v)
    }
}

/// The functions a constant expression may call, with their argument counts.
const FUNCTIONS: &[(&str, usize)] = &[
    ("exp", 1),
    ("ln", 1),
    ("sqrt", 1),
    ("powf", 2),
    ("abs", 1),
    ("min", 2),
    ("max", 2),
    ("clamp", 3),
];

impl Checker {
    /// The value of a constant expression (see the module docs).
    pub(super) fn const_eval(&self, e: &SExpr) -> Result<f64> {
        let v = match e {
            SExpr::Lit(l) => lit_value(&l.lit)?,
            SExpr::Paren(p) => self.const_eval(&p.expr)?,
            SExpr::Group(g) => self.const_eval(&g.expr)?,
            SExpr::Path(_) => self.const_name(e)?,
            SExpr::Unary(u) => match u.op {
                UnOp::Neg(_) => -self.const_eval(&u.expr)?,
                _ => {
                    return Err(Diag::new(u.op.span(), "unsupported unary operator")
                        .help("a constant expression uses numbers, names, + - * / and exp, ln, sqrt, powf, abs, min, max, clamp"))
                }
            },
            SExpr::Binary(b) => {
                let (x, y) = (self.const_eval(&b.left)?, self.const_eval(&b.right)?);
                let v = match b.op {
                    BinOp::Add(_) => x + y,
                    BinOp::Sub(_) => x - y,
                    BinOp::Mul(_) => x * y,
                    BinOp::Div(_) if y == 0.0 => {
                        return Err(Diag::new(b.op.span(), "division by zero in a constant expression")
                            .label("divides by 0"))
                    }
                    BinOp::Div(_) => x / y,
                    BinOp::Rem(_) => return Err(Diag::new(b.op.span(), "`%` is not supported")
                        .help(DIVISION_HELP)),
                    _ => {
                        return Err(Diag::new(b.op.span(), "unsupported operator in a constant expression")
                            .help("a constant expression uses numbers, names, + - * / and exp, ln, sqrt, powf, abs, min, max, clamp"))
                    }
                };
                // An overflow or underflow is reported at the operator that makes it.
                let scaling = matches!(b.op, BinOp::Mul(_) | BinOp::Div(_));
                normal(finite(v, b.op.span())?, scaling && x != 0.0 && y != 0.0, b.op.span())?
            }
            SExpr::Call(c) => {
                let f = path_ident(&c.func)
                    .ok_or_else(|| Diag::new(c.func.span(), "unknown function"))?;
                let args: Vec<&SExpr> = c.args.iter().collect();
                self.const_call(&f.to_string(), f.span(), &args, c.span())?
            }
            SExpr::MethodCall(m) => {
                let mut args: Vec<&SExpr> = vec![&m.receiver];
                args.extend(m.args.iter());
                self.const_call(&m.method.to_string(), m.method.span(), &args, m.span())?
            }
            other => {
                return Err(Diag::new(other.span(), "expected a constant expression").help(
                    "a constant expression uses numbers, names, + - * / and exp, ln, sqrt, powf, abs, min, max, clamp",
                ))
            }
        };
        finite(v, e.span())
    }

    /// A name in a constant expression: a `param`, `const` or `period` declared before it.
    fn const_name(&self, e: &SExpr) -> Result<f64> {
        let ident = path_ident(e).ok_or_else(|| Diag::new(e.span(), "expected a name"))?;
        let n = ident.to_string();
        match self.consts.get(&n) {
            Some(&(v, _)) if v.is_nan() => Err(Diag::new(
                ident.span(),
                "`period` is used before it is declared",
            )),
            Some(&(v, _)) => Ok(v),
            None if self.lookup(&n).is_some() => Err(Diag::new(
                ident.span(),
                format!("`{n}` is a signal: a constant expression is computed at compile time"),
            )
            .help("use literals, `param`s, `const`s and `period`")),
            None => Err(super::unknown(&ident)),
        }
    }

    /// `f(args)` in a constant expression.
    fn const_call(&self, f: &str, fspan: Span, args: &[&SExpr], span: Span) -> Result<f64> {
        if f == "convert" {
            if args.len() != 2 {
                return Err(Diag::new(span, "`convert` takes 2 arguments")
                    .help("write `convert(x, \"mm/s\")`"));
            }
            return Ok(self.const_eval(args[0])? * self.convert_factor(args)?);
        }
        let Some(&(_, want)) = FUNCTIONS.iter().find(|(n, _)| *n == f) else {
            return Err(Diag::new(fspan, format!("unknown function `{f}` in a constant expression"))
                .help("constant expressions may call exp, ln, sqrt, powf, abs, min, max, clamp and convert"));
        };
        if args.len() != want {
            return Err(Diag::new(span, format!("`{f}` takes {want} argument(s)")));
        }
        let a: Vec<f64> = args
            .iter()
            .map(|x| self.const_eval(x))
            .collect::<Result<_>>()?;
        let v = match f {
            "exp" => normal(a[0].exp(), true, span)?,
            "powf" if a[0] != 0.0 => normal(a[0].powf(a[1]), true, span)?,
            "ln" if a[0] <= 0.0 => {
                return Err(Diag::new(span, format!("`ln` of {}: not positive", a[0]))
                    .label("no real logarithm"))
            }
            "ln" => a[0].ln(),
            "sqrt" if a[0] < 0.0 => {
                return Err(Diag::new(span, format!("`sqrt` of {}: negative", a[0]))
                    .label("no real square root"))
            }
            "sqrt" => a[0].sqrt(),
            "powf" => a[0].powf(a[1]),
            "abs" => a[0].abs(),
            "min" => a[0].min(a[1]),
            "max" => a[0].max(a[1]),
            _ if a[1] > a[2] => {
                return Err(Diag::new(
                    span,
                    format!("clamp bounds are reversed: {} > {}", a[1], a[2]),
                ))
            }
            _ => a[0].max(a[1]).min(a[2]),
        };
        if v.is_nan() {
            return Err(Diag::new(span, format!("`{f}` has no real value here"))
                .help("`powf` of a negative base needs an integer exponent"));
        }
        Ok(v)
    }
}
