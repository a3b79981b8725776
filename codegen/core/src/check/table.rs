//! `table NAME(x: [A, B] "unit") = EXPR, step H;`: checks the declaration, samples the
//! expression on its grid, bounds the interpolation error, and resolves the calls `NAME(e)`
//! of `step`.
//!
//! The grid is `A, A + H, .., B` with `H` a power of two and `A` a multiple of it, so that in
//! any binary format fine enough to hold the grid the segment index of a value is a shift of
//! its offset from `A` (`lower`). At most [`MAX_SEGMENTS`] segments.

use super::curvature::{Dual, Trouble, I};
use super::enclose::{f64_down, f64_up, rat, to_f64, Enc};
use super::units::{self, ParamUnits, Ty};
use super::{path_ident, Checker};
use crate::diag::{Diag, Result};
use crate::ir::{Expr, Table};
use crate::lang::ast::TableDecl;
use crate::lang::parse::doc_lines;
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::Zero;
use proc_macro2::Span;
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, UnOp};

/// Most segments a table may have (its arrays hold one entry more).
pub const MAX_SEGMENTS: usize = 256;

impl Checker {
    /// Checks and samples a table declaration (see the module docs).
    pub(super) fn table(&mut self, t: &TableDecl) -> Result<()> {
        self.define(&t.name)?;
        let var = t.var.to_string();
        if self.consts.contains_key(&var) || self.lookup(&var).is_some() {
            return Err(
                Diag::new(t.var.span(), format!("`{var}` is already defined"))
                    .help("name the table's variable differently"),
            );
        }
        let name = t.name.to_string();
        let (a, b) = (self.const_eval(&t.range.lo)?, self.const_eval(&t.range.hi)?);
        if a >= b {
            return Err(Diag::new(t.range.span, format!("empty range [{a}, {b}]")));
        }
        let h = self.const_eval(&t.step)?;
        let pow2 = h > 0.0 && h.is_finite() && h == 2f64.powi(h.log2().round() as i32);
        if !pow2 {
            return Err(Diag::new(t.step.span(), format!("the grid step {h} is not a power of two"))
                .label("not 2^k")
                .help("the segment index is a shift, so the step is a power of two: 0.25, 1, 8, 2^-6 = 0.015625"));
        }
        let (na, nb) = (a / h, b / h);
        if na != na.round() || nb != nb.round() {
            return Err(Diag::new(
                t.range.span,
                format!("the range [{a}, {b}] does not start and end on the grid of step {h}"),
            )
            .help("make both ends multiples of the step"));
        }
        let n = (nb - na) as usize;
        if n > MAX_SEGMENTS {
            return Err(Diag::new(
                t.step.span(),
                format!("{n} segments: a table has at most {MAX_SEGMENTS}"),
            )
            .help("use a coarser step; the interpolation error grows with its square"));
        }
        // Units: the variable's, and the expression's with it.
        let in_unit = Ty::declared(t.unit.as_ref())?;
        for e in [&t.range.lo, &t.range.hi] {
            let u = self.unit_of(e, &ParamUnits::new())?;
            units::same(
                in_unit.clone(),
                u,
                e.span(),
                &format!("the range of `{var}`"),
            )?;
        }
        let mut params = ParamUnits::new();
        params.insert(var.clone(), in_unit.clone());
        let out_unit = match self.unit_of(&t.value, &params)? {
            Ty::Lit => Ty::declared(None)?,
            u => u,
        };
        // The samples: the expression at each grid point, the f64 nearest the middle of its
        // exact enclosure (`enclose`), so that no cancellation of an f64 evaluation gets into
        // the table; and how far each may be from the exact value.
        let mut samples = Vec::with_capacity(n + 1);
        let mut sample_err = BigRational::zero();
        let mut grid: Vec<Enc> = Vec::with_capacity(n + 1);
        for i in 0..=n {
            let x = a + i as f64 * h;
            let at = |d: Diag| {
                let at = format!(" (at {var} = {})", crate::text::g(x));
                Diag {
                    message: d.message.clone() + &at,
                    ..d
                }
            };
            // The f64 evaluation reports what is undefined, at its operator.
            self.consts.insert(var.clone(), (x, t.var.span()));
            let v = self.const_eval(&t.value);
            self.consts.remove(&var);
            v.map_err(at)?;
            let enc = self.enclose(&t.value, Some((&var, &rat(x)))).ok_or_else(|| {
                at(Diag::new(t.value.span(), "cannot bound the exact value of the table's expression here")
                    .help("qloop samples a table in exact arithmetic: keep the expression defined, and its numbers within the f64 range, on the whole grid"))
            })?;
            let s = to_f64(&enc.mid());
            if !s.is_finite() {
                return Err(at(Diag::new(
                    t.value.span(),
                    "the table's value is beyond the f64 range here",
                )));
            }
            sample_err = sample_err.max(enc.dist_max(&rat(s)));
            samples.push(s);
            grid.push(enc);
        }
        // The interpolation error: h²/8·max|f''| per segment, plus the samples' distance from
        // the exact values (the interpolant of the samples is within that of the interpolant
        // of the exact values).
        let mut interp = 0f64;
        for i in 0..n {
            let x = I::new(a + i as f64 * h, a + (i + 1) as f64 * h);
            let d = self.dual_eval(&t.value, &var, Dual::variable(x))?;
            interp = interp.max(h * h / 8.0 * d.d2.mag());
        }
        // h²/8 is exact (h is a power of two); the product and the sum round up.
        let interp_err = f64_up(&(rat(interp.next_up()) + sample_err));
        let format = self.table_format(t, &samples)?;
        // A witness: a lower bound on |L(x) − f(x)| at the grid points (their enclosures from
        // above) and 7 points inside each segment, L exact over the samples and f enclosed.
        // Where f'' dominates, |L − f| on a segment is a parabola with its peak near the
        // middle: the nearest of the points j/8 is within 1/16 of a segment of the peak, where
        // the parabola is within (1/8)² = 1.6 % of it. (Each point is an exact enclosure, and
        // they are most of the time a table takes to check.)
        let mut witness = (a, 0f64);
        let mut best = BigRational::zero();
        let mut consider = |x: f64, lb: BigRational| {
            if lb > best {
                witness = (x, f64_down(&lb));
                best = lb;
            }
        };
        let srat: Vec<BigRational> = samples.iter().map(|v| rat(*v)).collect();
        for (i, (f, si)) in grid.iter().zip(&srat).enumerate() {
            consider(a + i as f64 * h, f.dist_min(si));
        }
        for i in 0..n {
            let (si, sj) = (&srat[i], &srat[i + 1]);
            for j in 1..8 {
                let u = BigRational::new(BigInt::from(j), BigInt::from(8));
                let xr = rat(a) + (BigRational::from_integer(BigInt::from(i)) + &u) * rat(h);
                if let Some(f) = self.enclose(&t.value, Some((&var, &xr))) {
                    let l = si + &u * (sj - si);
                    consider(to_f64(&xr), f.dist_min(&l));
                }
            }
        }
        // The claim's enclosure: proved against its lower end, refuted against its upper.
        let claim = match &t.error {
            Some(e) => {
                let c = self.const_eval(e)?;
                // Where the claim cannot be enclosed exactly, its f64 value widened by four ulps
                // each way (the allowance `enclose` gives a library function).
                let (lo, hi) = match self.enclose(e, None).or_else(|| Enc::around(c)) {
                    Some(enc) => (f64_down(&enc.lo), f64_up(&enc.hi)),
                    None => (f64::NEG_INFINITY, f64::INFINITY),
                };
                Some((c, lo, hi))
            }
            None => None,
        };
        self.tables.push(Table {
            name,
            lo: a,
            hi: b,
            step: h,
            samples,
            in_unit: t.unit.as_ref().map(|u| u.value()),
            unit: out_unit.report_text(),
            interp_err,
            claim: claim.map(|c| c.0),
            claim_bounds: claim.map(|c| (c.1, c.2)),
            witness,
            docs: doc_lines(&t.attrs),
            format,
            span: t.name.span(),
        });
        self.table_units.push((in_unit, out_unit));
        Ok(())
    }

    /// The table named `n`, if one is declared.
    pub(super) fn table_index(&self, n: &str) -> Option<usize> {
        self.tables.iter().position(|t| t.name == n)
    }

    /// `NAME(x)` in `step`.
    pub(super) fn table_call(&self, t: usize, args: &[&SExpr], span: Span) -> Result<Expr> {
        let name = &self.tables[t].name;
        let [x] = args else {
            return Err(Diag::new(span, format!("table `{name}` takes 1 argument")));
        };
        Ok(Expr::Table(t, Box::new(self.expr(x)?), span))
    }

    /// `e` on second-order dual numbers with interval parts: the value and first two
    /// derivatives with respect to `var` over `x`'s interval (see `curvature`).
    fn dual_eval(&self, e: &SExpr, var: &str, x: Dual) -> Result<Dual> {
        let fail = |sp: Span, t: Trouble| {
            let why = match t {
                Trouble::Domain(w) => w.to_string(),
                Trouble::Overflow => "a value beyond the f64 range".to_string(),
            };
            Diag::new(sp, format!("cannot bound the table's curvature here: {why}"))
                .help("qloop bounds the interpolation error by the second derivative over each segment: keep the expression smooth and defined on the whole range")
        };
        let sp = e.span();
        let v = match e {
            SExpr::Lit(_) => Dual::constant(self.const_eval(e)?),
            SExpr::Paren(p) => self.dual_eval(&p.expr, var, x)?,
            SExpr::Group(g) => self.dual_eval(&g.expr, var, x)?,
            SExpr::Path(_) if path_ident(e).is_some_and(|i| i == var) => x,
            SExpr::Path(_) => Dual::constant(self.const_eval(e)?),
            SExpr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => {
                self.dual_eval(&u.expr, var, x)?.neg()
            }
            SExpr::Binary(b) => {
                let (l, r) = (
                    self.dual_eval(&b.left, var, x)?,
                    self.dual_eval(&b.right, var, x)?,
                );
                match b.op {
                    BinOp::Add(_) => l.add(r),
                    BinOp::Sub(_) => l.sub(r),
                    BinOp::Mul(_) => l.mul(r),
                    BinOp::Div(_) => l.div(r),
                    _ => return Err(Diag::new(b.op.span(), "unsupported operator in a table")),
                }
                .map_err(|t| fail(sp, t))?
            }
            SExpr::Call(_) | SExpr::MethodCall(_) => {
                let (f, args): (String, Vec<&SExpr>) = match e {
                    SExpr::Call(c) => (
                        path_ident(&c.func)
                            .map(|i| i.to_string())
                            .unwrap_or_default(),
                        c.args.iter().collect(),
                    ),
                    SExpr::MethodCall(m) => {
                        let mut a = vec![&*m.receiver];
                        a.extend(m.args.iter());
                        (m.method.to_string(), a)
                    }
                    _ => unreachable!("matched above"),
                };
                let u = match args.first() {
                    Some(a0) => self.dual_eval(a0, var, x)?,
                    None => return Err(Diag::new(sp, format!("`{f}` needs an argument"))),
                };
                match (f.as_str(), args.len()) {
                    ("exp", 1) => u.exp(),
                    ("ln", 1) => u.ln(),
                    ("sqrt", 1) => u.sqrt(),
                    ("powf", 2) => {
                        let c = self.const_eval(args[1]).map_err(|_| {
                            Diag::new(args[1].span(), "a table's `powf` needs a constant exponent")
                        })?;
                        u.powc(c)
                    }
                    _ if !uses_var(e, var) => Ok(Dual::constant(self.const_eval(e)?)),
                    _ => {
                        return Err(Diag::new(sp, format!("cannot bound the curvature of `{f}`"))
                            .help("a table's expression may use + - * /, exp, ln, sqrt and powf with a constant exponent of its variable; `abs`, `min`, `max` and `clamp` are not smooth"))
                    }
                }
                .map_err(|t| fail(sp, t))?
            }
            other => {
                return Err(Diag::new(
                    other.span(),
                    "expected a constant expression of the table's variable",
                ))
            }
        };
        Ok(v)
    }
}

/// Whether `e` mentions `var`.
impl Checker {
    /// A table's pinned sample format, `#[q(TYPE, FRAC)]`: a signed type that holds every
    /// sample rounded to nearest. Every other attribute but doc comments is refused, at it.
    fn table_format(
        &self,
        t: &TableDecl,
        samples: &[f64],
    ) -> Result<Option<crate::qformat::QFormat>> {
        for a in &t.attrs {
            let p = a.path();
            if !(p.is_ident("doc") || p.is_ident("q")) {
                return Err(Diag::new(a.span(), "unknown attribute on a `table`").help(
                    "a table takes `#[q(TYPE, FRAC)]`, the format of its samples (for example \
                     `#[q(i16, 14)]` to store them in 16 bits)",
                ));
            }
        }
        let Some(q) = super::fmt_attrs(&t.attrs, &|e| self.const_eval(e))?.pin else {
            return Ok(None);
        };
        let span = t
            .attrs
            .iter()
            .find(|a| a.path().is_ident("q"))
            .map_or(t.name.span(), |a| a.span());
        if !q.ty.signed || q.ty.bits > 32 {
            return Err(Diag::new(
                span,
                format!(
                    "a table's samples are signed words of at most 32 bits, not {}",
                    q.ty
                ),
            )
            .help("pin `i8`, `i16` or `i32`"));
        }
        let (lo, hi) = samples
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let (rl, rh) = (q.raw_nearest(lo), q.raw_nearest(hi));
        if !q.ty.holds(rl, rh) {
            let best = crate::qformat::QFormat::best_for(q.ty, lo, hi);
            let mut d = Diag::new(
                span,
                format!(
                    "the samples of table `{}` span [{lo:e}, {hi:e}], which Q({}, {}) cannot hold",
                    t.name, q.ty, q.frac
                ),
            )
            .label("too few integer bits");
            if let Some(b) = best {
                d = d.help(format!(
                    "at most {} fraction bits in {}: `#[q({}, {})]`",
                    b.frac, q.ty, q.ty, b.frac
                ));
            }
            return Err(d);
        }
        Ok(Some(q))
    }
}

fn uses_var(e: &SExpr, var: &str) -> bool {
    struct Find<'a>(&'a str, bool);
    impl<'v> syn::visit::Visit<'v> for Find<'_> {
        fn visit_ident(&mut self, i: &'v proc_macro2::Ident) {
            if i == self.0 {
                self.1 = true;
            }
        }
    }
    let mut f = Find(var, false);
    syn::visit::Visit::visit_expr(&mut f, e);
    f.1
}
