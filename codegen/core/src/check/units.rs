//! Checking physical units (see [`crate::units`] for the unit algebra).
//!
//! Rules, checked on the spec's syntax so that every error points at the operator or
//! operand at fault:
//! - a name has its declared unit; a name declared without one is dimensionless; a `let`
//!   has the unit of its value; `period` is in seconds;
//! - a number literal takes the unit of whatever it is added to or compared with (`fc > 0.15`
//!   compares kN with kN), and is dimensionless as a factor;
//! - `+ - min max clamp`, the arms of a value `if`, comparisons and assignments need the same
//!   unit on both sides: the same dimension *and* the same scale. `N` against `kN` is an error
//!   naming both; `convert(x, "kN")` converts explicitly (a constant factor, here 10⁻³);
//! - `*` multiplies units (`kc * km` is `(mm/s)/kN · kN/(mm/s)`, dimensionless); `abs`,
//!   `next` and unary `-` keep them.

use super::{path_ident, Checker};
use crate::diag::{Diag, Result};
use crate::ir::SigId;
use crate::text::g;
use crate::units::{self, Unit};
use proc_macro2::Span;
use std::collections::HashMap;
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, LitStr, UnOp};

/// The unit of an expression.
#[derive(Clone, Debug)]
pub(crate) enum Ty {
    /// A number literal (or an expression of literals only): adopts the other operand's unit.
    Lit,
    /// A unit, with the text that names it in messages.
    Of(Unit, String),
}

impl Ty {
    /// A declared unit (dimensionless if none).
    pub(crate) fn declared(unit: Option<&LitStr>) -> Result<Ty> {
        let Some(lit) = unit else {
            return Ok(Ty::Of(Unit::ONE, "1".into()));
        };
        let text = lit.value();
        match units::parse(&text) {
            Ok(u) => Ok(Ty::Of(u, display(&text))),
            Err(e) => {
                let mut d = Diag::new(
                    lit.span(),
                    format!(
                        "{} in the unit \"{text}\" (at character {})",
                        e.message,
                        e.at + 1
                    ),
                )
                .label("unknown unit");
                d = match e.suggestion {
                    Some(s) => d.help(format!(
                        "did you mean `{s}`? Units are SI symbols with prefixes (mm, kN, kW, ms) \
                         and rev, rpm, min, h, deg, rad, in, %, joined with * / ^ and parentheses"
                    )),
                    None => d.help(
                        "units are SI symbols with prefixes (mm, kN, kW, ms) and rev, rpm, min, \
                         h, deg, rad, in, %, joined with * / ^ and parentheses; see the qloop book, Units",
                    ),
                };
                Err(d)
            }
        }
    }

    /// The unit, dimensionless for a literal.
    pub(crate) fn unit(&self) -> Unit {
        match self {
            Ty::Lit => Unit::ONE,
            Ty::Of(u, _) => *u,
        }
    }

    /// The unit's text for reports: `None` if dimensionless (or a literal).
    pub(crate) fn report_text(&self) -> Option<String> {
        match self {
            Ty::Of(_, t) if t != "1" => Some(t.clone()),
            _ => None,
        }
    }

    fn text(&self) -> String {
        match self {
            Ty::Lit => "a number".into(),
            Ty::Of(_, t) => t.clone(),
        }
    }
}

/// The reciprocal unit: `1/N` for `N` (dimensionless for a literal).
pub(crate) fn inverse(t: &Ty) -> Ty {
    match t {
        Ty::Lit => Ty::Of(Unit::ONE, "1".into()),
        Ty::Of(u, text) if text == "1" => Ty::Of(Unit::ONE / *u, "1".into()),
        Ty::Of(u, text) => Ty::Of(Unit::ONE / *u, format!("1/{}", wrap(text))),
    }
}

/// A unit's text for messages: `1` reads as "dimensionless".
fn display(text: &str) -> String {
    if text.trim().is_empty() || text.trim() == "1" {
        "1".into()
    } else {
        text.to_string()
    }
}

/// A unit's text, parenthesised if it is compound.
fn wrap(s: &str) -> String {
    if s.contains(['/', '·', '*', '^']) {
        format!("({s})")
    } else {
        s.to_string()
    }
}

/// `a · b` as text, parenthesised where a quotient would read wrongly.
fn product_text(a: &str, b: &str) -> String {
    match (a, b) {
        ("1", x) | (x, "1") => x.to_string(),
        _ => format!("{}·{}", wrap(a), wrap(b)),
    }
}

/// Describes a unit for a message: its text, and what it is in SI where that helps.
fn describe(t: &Ty) -> String {
    match t {
        Ty::Lit => "a number".into(),
        Ty::Of(u, text) => {
            let name = u.dimension_name().unwrap_or("");
            let si = u.to_string();
            match (text == "1", name.is_empty()) {
                (true, _) => "dimensionless".into(),
                (false, true) => format!("{text} (= {si})"),
                (false, false) if si == *text => format!("{text} ({name})"),
                (false, false) => format!("{text} ({name}, = {si})"),
            }
        }
    }
}

/// Free parameters' units while checking a property.
pub(crate) type ParamUnits = HashMap<String, Ty>;

/// Both sides of `what` (an operator or a role: "+", "assignment") at `span` in one unit.
pub(crate) fn same(a: Ty, b: Ty, span: Span, what: &str) -> Result<Ty> {
    let (ua, ub) = match (&a, &b) {
        (Ty::Lit, _) => return Ok(b),
        (_, Ty::Lit) => return Ok(a),
        (Ty::Of(ua, _), Ty::Of(ub, _)) => (*ua, *ub),
    };
    if ua.same(&ub) {
        return Ok(a);
    }
    let (ta, tb) = (a.text(), b.text());
    if let Some(f) = ub.factor_to(&ua) {
        return Err(Diag::new(
            span,
            format!(
                "{what}: {} and {} are the same dimension in different units",
                describe(&a),
                describe(&b)
            ),
        )
        .label(format!("{ta} vs {tb}"))
        .help(format!(
            "1 {tb} = {} {ta}: qloop does not rescale silently; declare both in one unit, \
             or convert explicitly with `convert(x, \"{ta}\")` (a constant factor)",
            g(f)
        )));
    }
    Err(Diag::new(
        span,
        format!(
            "{what}: {} and {} have different dimensions",
            describe(&a),
            describe(&b)
        ),
    )
    .label(format!("{ta} vs {tb}"))
    .help(
        "only quantities of one unit add, subtract, compare or assign: check the formula; a \
         name declared without a unit is dimensionless (`const C1: 0.25 \"s/mm\";` gives one)",
    ))
}

impl Checker {
    /// The unit of signal `id`.
    pub(crate) fn sig_unit(&self, id: SigId) -> Ty {
        self.sig_units
            .get(id.0)
            .cloned()
            .unwrap_or(Ty::Of(Unit::ONE, "1".into()))
    }

    /// The unit of expression `e` (already checked for names by [`Checker::expr`] or the
    /// property checker), checking every sum, comparison and selection inside it.
    pub(crate) fn unit_of(&self, e: &SExpr, params: &ParamUnits) -> Result<Ty> {
        match e {
            SExpr::Lit(_) => Ok(Ty::Lit),
            SExpr::Paren(p) => self.unit_of(&p.expr, params),
            SExpr::Group(g) => self.unit_of(&g.expr, params),
            SExpr::Path(_) => Ok(self.name_unit(e, params)),
            SExpr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => self.unit_of(&u.expr, params),
            SExpr::Binary(b) => {
                let (l, r) = (
                    self.unit_of(&b.left, params)?,
                    self.unit_of(&b.right, params)?,
                );
                match b.op {
                    BinOp::Mul(_) => Ok(match (l, r) {
                        (Ty::Lit, x) | (x, Ty::Lit) => x,
                        (Ty::Of(a, ta), Ty::Of(c, tc)) => {
                            let u = a * c;
                            let text = if u.same(&Unit::ONE) {
                                "1".to_string()
                            } else {
                                product_text(&ta, &tc)
                            };
                            Ty::Of(u, text)
                        }
                    }),
                    // Only constant expressions divide (the checker refuses `/` in `step`).
                    BinOp::Div(_) => Ok(match (l, r) {
                        (x, Ty::Lit) => x,
                        (Ty::Lit, Ty::Of(u, t)) => Ty::Of(Unit::ONE / u, format!("1/{}", wrap(&t))),
                        (Ty::Of(a, ta), Ty::Of(c, tc)) => {
                            let u = a / c;
                            let text = if u.same(&Unit::ONE) {
                                "1".to_string()
                            } else {
                                format!("{}/{}", wrap(&ta), wrap(&tc))
                            };
                            Ty::Of(u, text)
                        }
                    }),
                    BinOp::Add(_) => same(l, r, b.op.span(), "`+`"),
                    BinOp::Sub(_) => same(l, r, b.op.span(), "`-`"),
                    _ => Ok(l),
                }
            }
            SExpr::Call(c) => {
                let args: Vec<&SExpr> = c.args.iter().collect();
                let f = path_ident(&c.func)
                    .map(|f| f.to_string())
                    .unwrap_or_default();
                self.call_unit(&f, &args, c.span(), params)
            }
            SExpr::MethodCall(m) => {
                let mut args: Vec<&SExpr> = vec![&m.receiver];
                args.extend(m.args.iter());
                self.call_unit(&m.method.to_string(), &args, m.span(), params)
            }
            SExpr::If(i) => {
                self.check_cond_units(&i.cond, params)?;
                let a = match i.then_branch.stmts.last() {
                    Some(syn::Stmt::Expr(x, None)) => self.unit_of(x, params)?,
                    _ => Ty::Lit,
                };
                let b = match &i.else_branch {
                    Some((_, x)) => match &**x {
                        SExpr::Block(bl) => match bl.block.stmts.last() {
                            Some(syn::Stmt::Expr(x, None)) => self.unit_of(x, params)?,
                            _ => Ty::Lit,
                        },
                        other => self.unit_of(other, params)?,
                    },
                    None => Ty::Lit,
                };
                same(a, b, i.if_token.span, "the arms of this `if`")
            }
            _ => Ok(Ty::Lit),
        }
    }

    fn name_unit(&self, e: &SExpr, params: &ParamUnits) -> Ty {
        let Some(ident) = path_ident(e) else {
            return Ty::Lit;
        };
        let n = ident.to_string();
        if let Some(t) = params.get(&n) {
            return t.clone();
        }
        if let Some(id) = self.lookup(&n) {
            return self.sig_unit(id);
        }
        self.const_units.get(&n).cloned().unwrap_or(Ty::Lit)
    }

    fn call_unit(&self, f: &str, args: &[&SExpr], span: Span, params: &ParamUnits) -> Result<Ty> {
        let tys: Vec<Ty> = args
            .iter()
            .map(|a| self.unit_of(a, params))
            .collect::<Result<_>>()?;
        if let Some(t) = self.table_index(f) {
            let (tin, tout) = self.table_units[t].clone();
            if let [x] = tys.as_slice() {
                same(
                    tin,
                    x.clone(),
                    args[0].span(),
                    &format!("the argument of table `{f}`"),
                )?;
            }
            return Ok(tout);
        }
        match (f, tys.as_slice()) {
            ("min" | "max", [a, b]) => same(a.clone(), b.clone(), span, &format!("`{f}`")),
            ("clamp", [x, lo, hi]) => {
                let t = same(
                    x.clone(),
                    lo.clone(),
                    args[1].span(),
                    "`clamp`'s lower bound",
                )?;
                same(t, hi.clone(), args[2].span(), "`clamp`'s upper bound")
            }
            ("exp" | "ln", [x]) => {
                if let Ty::Of(u, t) = x {
                    if !u.same(&Unit::ONE) {
                        return Err(Diag::new(
                            span,
                            format!(
                                "`{f}` of {}: its argument must be dimensionless",
                                describe(x)
                            ),
                        )
                        .label(t.clone())
                        .help(format!(
                            "divide by a quantity of the same unit first: `{f}(-period / TAU)`"
                        )));
                    }
                }
                Ok(match x {
                    Ty::Lit => Ty::Lit,
                    _ => Ty::Of(Unit::ONE, "1".into()),
                })
            }
            ("sqrt", [x]) => {
                match x {
                    Ty::Lit => Ok(Ty::Lit),
                    Ty::Of(u, t) => {
                        if u.dims.iter().any(|d| d % 2 != 0) {
                            return Err(Diag::new(
                            span,
                            format!("`sqrt` of {}: not a square unit", describe(x)),
                        )
                        .label(t.clone())
                        .help("take the root of a squared unit (`m^2`), or of a dimensionless ratio"));
                        }
                        let mut half = *u;
                        half.scale = u.scale.sqrt();
                        for d in &mut half.dims {
                            *d /= 2;
                        }
                        Ok(Ty::Of(half, format!("sqrt({t})")))
                    }
                }
            }
            ("powf", [_, e]) if !matches!(e, Ty::Lit) && !e.unit().same(&Unit::ONE) => {
                Err(Diag::new(
                    args[1].span(),
                    format!(
                        "the exponent of `powf` is {}: it must be dimensionless",
                        describe(e)
                    ),
                )
                .label(e.text())
                .help("divide by a quantity of the same unit first: `powf(0.5, T / TAU)`"))
            }
            ("powf", [x, _]) => match x {
                Ty::Lit => Ok(Ty::Lit),
                Ty::Of(u, _) if u.same(&Unit::ONE) => Ok(x.clone()),
                Ty::Of(u, t) => {
                    let n = match args[1] {
                        SExpr::Lit(l) => super::lit_value(&l.lit).ok(),
                        SExpr::Unary(syn::ExprUnary {
                            op: UnOp::Neg(_),
                            expr,
                            ..
                        }) => match &**expr {
                            SExpr::Lit(l) => super::lit_value(&l.lit).ok().map(|v| -v),
                            _ => None,
                        },
                        _ => None,
                    }
                    .filter(|n| n.fract() == 0.0 && n.abs() <= 9.0);
                    match n {
                        Some(n) => Ok(Ty::Of(u.powi(n as i8), format!("{}^{n}", wrap(t)))),
                        None => Err(Diag::new(
                            span,
                            format!("`powf` of {}: a quantity with a unit takes a whole-number literal exponent", describe(x)),
                        )
                        .label(t.clone())
                        .help("write the exponent as a literal (`powf(T, 2.0)`), or make the base dimensionless")),
                    }
                }
            },
            ("convert", [x, _]) => self.convert(x, args).map(|(to, _)| to),
            (_, [a, ..]) => Ok(a.clone()),
            _ => Ok(Ty::Lit),
        }
    }

    /// The target unit of `convert(x, "unit")`.
    fn convert_target(&self, args: &[&SExpr]) -> Result<Ty> {
        match args.get(1) {
            Some(SExpr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            })) => Ty::declared(Some(s)),
            Some(other) => Err(Diag::new(other.span(), "expected a unit string")
                .help("write `convert(x, \"mm/s\")`")),
            None => Err(Diag::new(Span::call_site(), "`convert` takes 2 arguments")
                .help("write `convert(x, \"mm/s\")`")),
        }
    }

    /// `convert(x, "unit")` with `x` in `from`: the target unit and the factor from `from` to
    /// it (1 for a number literal, which takes the target unit); refused across dimensions.
    fn convert(&self, from: &Ty, args: &[&SExpr]) -> Result<(Ty, f64)> {
        let to = self.convert_target(args)?;
        let Ty::Of(u, text) = from else {
            return Ok((to, 1.0));
        };
        match u.factor_to(&to.unit()) {
            Some(f) => Ok((to, f)),
            None => Err(Diag::new(
                args[1].span(),
                format!(
                    "cannot convert {} to {}: different dimensions",
                    describe(from),
                    describe(&to)
                ),
            )
            .label(format!("{text} → {}", to.text()))
            .help("`convert` changes the unit within one dimension (N → kN, mm/s → mm/min); check the formula")),
        }
    }

    /// The factor of `convert(x, "unit")`: from `x`'s unit to the named one, the units inside
    /// `x` checked.
    pub(crate) fn convert_factor(&self, args: &[&SExpr]) -> Result<f64> {
        let from = self.unit_of(args[0], &ParamUnits::new())?;
        self.convert(&from, args).map(|(_, f)| f)
    }

    /// Checks the units in a condition (`if`, `assume`, `ensure`, `invariant`).
    pub(crate) fn check_cond_units(&self, e: &SExpr, params: &ParamUnits) -> Result<()> {
        match e {
            SExpr::Paren(p) => self.check_cond_units(&p.expr, params),
            SExpr::Unary(u) => self.check_cond_units(&u.expr, params),
            SExpr::Binary(b) if matches!(b.op, BinOp::And(_) | BinOp::Or(_)) => {
                self.check_cond_units(&b.left, params)?;
                self.check_cond_units(&b.right, params)
            }
            SExpr::Binary(b) => {
                let (l, r) = (
                    self.unit_of(&b.left, params)?,
                    self.unit_of(&b.right, params)?,
                );
                same(l, r, b.op.span(), "this comparison").map(|_| ())
            }
            _ => Ok(()),
        }
    }

    /// Checks that `value` can be stored in `target` (an assignment, `+=`, `-=`).
    pub(crate) fn check_store_units(&self, target: SigId, value: &SExpr, span: Span) -> Result<()> {
        let v = self.unit_of(value, &ParamUnits::new())?;
        let t = self.sig_unit(target);
        let name = &self.signals[target.0].name;
        same(t, v, span, &format!("assignment to `{name}`")).map(|_| ())
    }
}
