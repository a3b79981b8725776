//! Checking `prove { .. }` blocks: invariants over the states and step properties over
//! pre-state, post-state (`next(x)`), inputs, outputs and free parameters.

use super::units::{ParamUnits, Ty};
use super::{lit_value, path_ident, unknown, Checker};
use crate::diag::{Diag, Result};
use crate::ir::*;
use crate::lang::ast::PropItem;
use std::collections::HashMap;
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, UnOp};

/// What a property expression may refer to.
struct Ctx<'a> {
    /// Free parameters in scope.
    params: &'a HashMap<String, usize>,
    /// Invariants see only pre-state states and constants.
    invariant: bool,
}

impl Checker {
    /// Checks the items of all `prove` blocks.
    pub(super) fn prove(&self, items: &[PropItem]) -> Result<(Vec<Invariant>, Vec<Property>)> {
        let mut invariants = Vec::new();
        let mut properties = Vec::new();
        let mut names: HashMap<String, proc_macro2::Span> = HashMap::new();
        for item in items {
            let (name, span) =
                match item {
                    PropItem::Invariant { name, .. } | PropItem::Property { name, .. } => {
                        (name.to_string(), name.span())
                    }
                    PropItem::For(f) => return Err(Diag::new(
                        f.var.span(),
                        "internal error: a `for` loop of `prove` reached the checker unexpanded",
                    )),
                };
            if names.insert(name.clone(), span).is_some() {
                return Err(Diag::new(
                    span,
                    format!("a property named `{name}` already exists"),
                ));
            }
            match item {
                PropItem::Invariant { docs, cond, .. } => {
                    let ctx = Ctx {
                        params: &HashMap::new(),
                        invariant: true,
                    };
                    self.check_cond_units(cond, &ParamUnits::new())?;
                    invariants.push(Invariant {
                        name,
                        docs: docs.clone(),
                        cond: self.pcond(cond, &ctx)?,
                        span,
                    });
                }
                PropItem::Property {
                    docs,
                    foralls,
                    assumes: assumes_src,
                    ensures: ensures_src,
                    ..
                } => {
                    let mut params = Vec::new();
                    let mut index = HashMap::new();
                    let mut units = ParamUnits::new();
                    for (p, r, unit) in foralls {
                        let n = p.to_string();
                        if self.consts.contains_key(&n)
                            || self.lookup(&n).is_some()
                            || index.contains_key(&n)
                        {
                            return Err(Diag::new(p.span(), format!("`{n}` is already defined"))
                                .help("free parameters need names of their own"));
                        }
                        let (lo, hi) = (self.const_eval(&r.lo)?, self.const_eval(&r.hi)?);
                        if lo >= hi {
                            return Err(Diag::new(r.span, format!("empty range [{lo}, {hi}]")));
                        }
                        units.insert(n.clone(), Ty::declared(unit.as_ref())?);
                        index.insert(n.clone(), params.len());
                        params.push(FreeParam {
                            name: n,
                            range: (lo, hi),
                        });
                    }
                    let ctx = Ctx {
                        params: &index,
                        invariant: false,
                    };
                    let assumes = assumes_src
                        .iter()
                        .map(|c| self.pcond(c, &ctx))
                        .collect::<Result<_>>()?;
                    let ensures = ensures_src
                        .iter()
                        .map(|c| self.pcond(c, &ctx))
                        .collect::<Result<_>>()?;
                    for c in assumes_src.iter().chain(ensures_src) {
                        self.check_cond_units(c, &units)?;
                    }
                    properties.push(Property {
                        name,
                        docs: docs.clone(),
                        params,
                        assumes,
                        ensures,
                        span,
                    });
                }
                // Refused above.
                PropItem::For(_) => {}
            }
        }
        Ok((invariants, properties))
    }

    /// `e` (a condition of `step`) as a property condition, where inputs and states stand for
    /// their values before the step (see [`Checker::recip_track`]).
    pub(super) fn step_condition(&self, e: &SExpr) -> Result<PCond> {
        let params = HashMap::new();
        self.pcond(
            e,
            &Ctx {
                params: &params,
                invariant: false,
            },
        )
    }

    fn pcond(&self, e: &SExpr, ctx: &Ctx) -> Result<PCond> {
        match e {
            SExpr::Paren(p) => self.pcond(&p.expr, ctx),
            SExpr::Unary(u) if matches!(u.op, UnOp::Not(_)) => {
                Ok(PCond::Not(Box::new(self.pcond(&u.expr, ctx)?)))
            }
            SExpr::Binary(b) => {
                let op = match b.op {
                    BinOp::And(_) => {
                        return Ok(PCond::And(
                            Box::new(self.pcond(&b.left, ctx)?),
                            Box::new(self.pcond(&b.right, ctx)?),
                        ))
                    }
                    BinOp::Or(_) => {
                        return Ok(PCond::Or(
                            Box::new(self.pcond(&b.left, ctx)?),
                            Box::new(self.pcond(&b.right, ctx)?),
                        ))
                    }
                    other => super::cmp_op(&other).ok_or_else(|| not_a_condition(e))?,
                };
                Ok(PCond::Cmp(
                    op,
                    self.pexpr(&b.left, ctx)?,
                    self.pexpr(&b.right, ctx)?,
                ))
            }
            _ => Err(not_a_condition(e)),
        }
    }

    fn pexpr(&self, e: &SExpr, ctx: &Ctx) -> Result<PExpr> {
        let bx = |x: PExpr| Box::new(x);
        Ok(match e {
            SExpr::Lit(l) => PExpr::Const(lit_value(&l.lit)?),
            SExpr::Paren(p) => self.pexpr(&p.expr, ctx)?,
            SExpr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => match self.pexpr(&u.expr, ctx)? {
                PExpr::Const(v) => PExpr::Const(-v),
                x => PExpr::Neg(bx(x)),
            },
            SExpr::Binary(b) => {
                let (l, r) = (
                    bx(self.pexpr(&b.left, ctx)?),
                    bx(self.pexpr(&b.right, ctx)?),
                );
                // Constants combined by `+ - *` fold into one when the f64 result is exact
                // (`(1.0 - C2 * KM_MIN)` with binary fractions): the claim stays the same
                // number, and the prover sees one constant instead of a product.
                if let (PExpr::Const(a), PExpr::Const(c)) = (l.as_ref(), r.as_ref()) {
                    let exact = match b.op {
                        BinOp::Add(_) => exact_sum(*a, *c),
                        BinOp::Sub(_) => exact_sum(*a, -*c),
                        BinOp::Mul(_) => exact_product(*a, *c),
                        _ => None,
                    };
                    if let Some(v) = exact {
                        return Ok(PExpr::Const(v));
                    }
                }
                match b.op {
                    BinOp::Add(_) => PExpr::Add(l, r),
                    BinOp::Sub(_) => PExpr::Sub(l, r),
                    BinOp::Mul(_) => PExpr::Mul(l, r),
                    BinOp::Div(_) | BinOp::Rem(_) => {
                        return Err(Diag::new(
                            b.op.span(),
                            "division is not allowed in properties either",
                        )
                        .help("multiply out: write `a <= b * c` rather than `a / c <= b`"))
                    }
                    _ => {
                        return Err(Diag::new(b.op.span(), "unsupported operator in a property")
                            .help("property expressions use + - *, abs, min, max, next(state)"))
                    }
                }
            }
            SExpr::Call(c) => {
                let f = path_ident(&c.func)
                    .ok_or_else(|| Diag::new(c.func.span(), "unknown function"))?;
                let args: Vec<&SExpr> = c.args.iter().collect();
                let want = |n: usize| -> Result<()> {
                    if args.len() == n {
                        Ok(())
                    } else {
                        Err(Diag::new(c.span(), format!("`{f}` takes {n} argument(s)")))
                    }
                };
                match f.to_string().as_str() {
                    "next" => {
                        want(1)?;
                        if ctx.invariant {
                            return Err(Diag::new(f.span(), "`next(..)` is not allowed in an invariant")
                                .help("an invariant is a condition on one state; it is proved initial and inductive"));
                        }
                        let id = path_ident(args[0])
                            .and_then(|i| self.lookup(&i.to_string()))
                            .filter(|id| {
                                matches!(self.signals[id.0].kind, SigKind::State | SigKind::Output)
                            })
                            .ok_or_else(|| {
                                Diag::new(args[0].span(), "`next(..)` takes a state or output name")
                            })?;
                        PExpr::Sig(id, When::Post)
                    }
                    "abs" => {
                        want(1)?;
                        PExpr::Abs(bx(self.pexpr(args[0], ctx)?))
                    }
                    "min" | "max" => {
                        want(2)?;
                        let (a, b) = (bx(self.pexpr(args[0], ctx)?), bx(self.pexpr(args[1], ctx)?));
                        if f == "min" {
                            PExpr::Min(a, b)
                        } else {
                            PExpr::Max(a, b)
                        }
                    }
                    // `convert(x, "unit")`: `x` times the unit factor, the exact value of its
                    // f64 (as every constant of a property is), the same factor `step` uses.
                    "convert" => {
                        want(2)?;
                        let k = self.convert_factor(&args)?;
                        let x = self.pexpr(args[0], ctx)?;
                        match &x {
                            PExpr::Const(v) => match exact_product(*v, k) {
                                Some(p) => PExpr::Const(p),
                                None => PExpr::Mul(bx(x), bx(PExpr::Const(k))),
                            },
                            _ => PExpr::Mul(bx(x), bx(PExpr::Const(k))),
                        }
                    }
                    other => {
                        return Err(Diag::new(
                            f.span(),
                            format!("unknown function `{other}` in a property"),
                        )
                        .help("properties use `next(x)`, `abs(a)`, `min(a, b)`, `max(a, b)`, `convert(x, \"unit\")`"))
                    }
                }
            }
            SExpr::Path(_) => {
                let ident = path_ident(e).ok_or_else(|| Diag::new(e.span(), "expected a name"))?;
                let n = ident.to_string();
                if let Some(&i) = ctx.params.get(&n) {
                    PExpr::Param(i)
                } else if let Some(id) = self.lookup(&n) {
                    let kind = self.signals[id.0].kind;
                    match (kind, ctx.invariant) {
                        (SigKind::State, _) => PExpr::Sig(id, When::Pre),
                        (SigKind::Input, false) => PExpr::Sig(id, When::Pre),
                        (SigKind::Output, false) => PExpr::Sig(id, When::Post),
                        (SigKind::Local, _) => {
                            return Err(Diag::new(
                                ident.span(),
                                format!("`{n}` is a `let` inside `step`"),
                            )
                            .help("properties talk about inputs, states and outputs"))
                        }
                        _ => {
                            return Err(Diag::new(
                                ident.span(),
                                "an invariant may only mention states and constants",
                            )
                            .help("write a `property` to relate inputs or outputs to the states"))
                        }
                    }
                } else if let Some(&(v, _)) = self.consts.get(&n) {
                    PExpr::Const(v)
                } else {
                    return Err(unknown(&ident));
                }
            }
            _ => return Err(
                Diag::new(e.span(), "unsupported expression in a property").help(
                    "property expressions use numbers, names, next(state), + - *, abs, min, max",
                ),
            ),
        })
    }
}

/// `a + b` if the f64 sum is exact (its rounding error, by Knuth's two-sum, is zero).
fn exact_sum(a: f64, b: f64) -> Option<f64> {
    let s = a + b;
    let bb = s - a;
    let err = (a - (s - bb)) + (b - bb);
    (s.is_finite() && err == 0.0).then_some(s)
}

/// `a · b` if the f64 product is exact (a fused multiply-add recovers its rounding error).
fn exact_product(a: f64, b: f64) -> Option<f64> {
    let p = a * b;
    (p.is_finite() && a.mul_add(b, -p) == 0.0).then_some(p)
}

fn not_a_condition(e: &SExpr) -> Diag {
    Diag::new(e.span(), "expected a condition")
        .help("compare with < <= > >= == != and join with && || !")
}
