//! Expansion of vectors, matrices and `for` loops into scalars, before checking.
//!
//! The estimators of the source papers (RLS in Koren's survey, eq. 29 and Rubio & De la Sen, the pole estimate of Jenkins & Kurfess)
//! work on short vectors: a regressor φ, a parameter estimate θ, a covariance P. qloop writes
//! them as arrays of signals and keeps one scalar IR: this pass rewrites the parsed spec so
//! that the checker, range analysis, format choice, the proofs and every emitter see scalars
//! only.
//!
//! * `state theta[3]: [LO, HI] = INIT;` becomes `theta_0`, `theta_1`, `theta_2`, each marked
//!   with its [`Elem`] (the emitters' APIs group them back into arrays). A matrix is declared
//!   `P[ROWS][COLS]`. The range is one `[LO, HI]` for every element or one per element,
//!   row-major (`[[LO, HI], ..]`, rows may be nested); the initial value is one value or an
//!   array literal with one per element.
//! * `x[i]`, `P[i][j]`: constant indices only (literals, loop variables, integer `const`s and
//!   `+ - *` of them), checked against the dimensions here.
//! * `for i in A..B { .. }` (or `A..=B`) in `step` is unrolled; a `let` inside the body is
//!   renamed per iteration (`let k` becomes `k_0`, `k_1`, ..), so each iteration has its own.
//! * `let g = [a, b, c];` binds a vector of `let`s (`g_0`, `g_1`, `g_2`); nested arrays bind a
//!   matrix.
//! * `sum(v)` and `dot(a, b)` take a vector, a matrix row `P[i]`, a whole matrix (`sum` only,
//!   all elements) or an array literal, and become the sum of the elements or of the products.
//!
//! * `newton_recip(d, [LO, HI], K)` is the fixed-step reciprocal of `clamp(d, LO, HI)`: `K`
//!   Newton steps `r ← r·(2 − d·r)` from the seed `2/(LO + HI)`, hoisted into `let`s before
//!   the statement that uses it. In real arithmetic `1 − d·r_{k+1} = (1 − d·r_k)²` exactly,
//!   so after `K` steps `0 ≤ 1 − d·r ≤ ((HI − LO)/(HI + LO))^(2^K)` for every `d` in the
//!   range. With a fourth argument, a table (of 1/x over `[LO, HI]`), the seed is that
//!   table's value at `d` instead. Each iterate is clamped to the interval real arithmetic keeps it in (a no-op
//!   there), so that ranges stay structural: no claim, no correlation for a prover to find,
//!   and the bound on `1 − d·r` follows from the real-arithmetic one and qloop's rounding
//!   bound on `r`. No division runs on the target.
//!
//! Everything is unrolled, so sizes are small by design: at most [`MAX_ELEMENTS`] elements per
//! declaration and [`MAX_UNROLLED`] statements made by loops in one spec.

use super::ast::*;
use crate::diag::{Diag, Result};
use crate::ir::Elem;
use proc_macro2::Span;
use std::collections::{HashMap, HashSet};
use syn::spanned::Spanned;
use syn::visit_mut::VisitMut;
use syn::{BinOp, Expr, Ident, UnOp};

/// Largest order of `det` (a 5 × 5 determinant expands into 120 products; symmetric, 73).
pub const MAX_DET: usize = 5;

/// The minor of `rows` on its first `r` rows and the `r` columns in `cols` (a bit set),
/// `r` = the number of columns, expanded along its last row (Laplace):
/// `Σ_t (−1)^(r−1+t) · M[r−1][j_t] · minor(rows 0..r−1, cols − {j_t})`, with `j_t` the `t`-th
/// column of `cols`. The positive terms come first, so that no term is subtracted from zero;
/// a literal zero element drops its term.
fn minor(rows: &[Vec<Expr>], cols: u32, span: Span) -> Expr {
    let js: Vec<usize> = (0..32).filter(|j| cols & (1 << j) != 0).collect();
    let r = js.len();
    if r == 1 {
        let a = &rows[0][js[0]];
        return syn::parse_quote_spanned!(span=> #a);
    }
    let mut terms: Vec<(bool, Expr)> = Vec::new();
    for (t, &j) in js.iter().enumerate() {
        let a = &rows[r - 1][j];
        if literal_number(a) == Some(0.0) {
            continue;
        }
        let sub = minor(rows, cols & !(1 << j), span);
        let prod: Expr = syn::parse_quote_spanned!(span=> (#a) * (#sub));
        terms.push(((r - 1 + t).is_multiple_of(2), prod));
    }
    terms.sort_by_key(|(plus, _)| !*plus);
    let mut it = terms.into_iter();
    let Some((plus, first)) = it.next() else {
        return syn::parse_quote_spanned!(span=> 0.0);
    };
    let first: Expr = if plus {
        first
    } else {
        syn::parse_quote_spanned!(span=> 0.0 - #first)
    };
    it.fold(first, |acc, (plus, t)| {
        if plus {
            syn::parse_quote_spanned!(span=> #acc + #t)
        } else {
            syn::parse_quote_spanned!(span=> #acc - #t)
        }
    })
}

/// The leading minor of order `k` of `rows` by Leibniz's formula, `Σ_σ sign(σ)·Π_i M[i][σ(i)]`,
/// with the products of the same elements merged (elements compare by their expanded text), so
/// that a symmetric matrix written with one name per pair gives the short form (4 × 4: 17
/// monomials, 5 × 5: 73). The form of a `det` in a property: the prover distributes every
/// product of its exact terms, so the step's expansion by minors ([`minor`]) and this one are
/// the same polynomial there, monomial for monomial.
fn leibniz(rows: &[Vec<Expr>], k: usize, span: Span) -> Expr {
    // Each element's key: the index of its text among the distinct texts, row-major.
    let mut texts: Vec<String> = Vec::new();
    let key: Vec<Vec<usize>> = rows[..k]
        .iter()
        .map(|r| {
            r[..k]
                .iter()
                .map(|x| {
                    let t = quote::quote!(#x).to_string();
                    match texts.iter().position(|u| *u == t) {
                        Some(i) => i,
                        None => {
                            texts.push(t);
                            texts.len() - 1
                        }
                    }
                })
                .collect()
        })
        .collect();
    let elem = |id: usize| -> &Expr {
        let (i, j) = (0..k)
            .flat_map(|i| (0..k).map(move |j| (i, j)))
            .find(|&(i, j)| key[i][j] == id)
            .unwrap_or((0, 0));
        &rows[i][j]
    };
    // Leibniz: Σ_σ sign(σ)·Π_i M[i][σ(i)], merged by the multiset of element keys, in
    // the order the permutations (lexicographic) first produce each monomial.
    let mut terms: Vec<(Vec<usize>, i64)> = Vec::new();
    for (perm, sign) in permutations(k) {
        let mut mono: Vec<usize> = (0..k).map(|i| key[i][perm[i]]).collect();
        mono.sort_unstable();
        match terms.iter_mut().find(|t| t.0 == mono) {
            Some(t) => t.1 += sign,
            None => terms.push((mono, sign)),
        }
    }
    let mut acc: Option<Expr> = None;
    for (mono, c) in terms.into_iter().filter(|t| t.1 != 0) {
        let mut factors: Vec<Expr> = mono.iter().map(|&id| elem(id).clone()).collect();
        let first = factors.remove(0);
        let mut prod = factors.into_iter().fold(
            syn::parse_quote_spanned!(span=> (#first)),
            |a: Expr, f| syn::parse_quote_spanned!(span=> #a * (#f)),
        );
        let mag = c.unsigned_abs();
        if mag != 1 {
            let lit = syn::LitFloat::new(&format!("{mag}.0"), span);
            prod = syn::parse_quote_spanned!(span=> #lit * #prod);
        }
        acc = Some(match (acc, c > 0) {
            (None, true) => prod,
            (None, false) => syn::parse_quote_spanned!(span=> 0.0 - #prod),
            (Some(a), true) => syn::parse_quote_spanned!(span=> #a + #prod),
            (Some(a), false) => syn::parse_quote_spanned!(span=> #a - #prod),
        });
    }
    acc.unwrap_or_else(|| syn::parse_quote_spanned!(span=> 0.0))
}

/// The permutations of `0..k` in lexicographic order, each with its sign.
fn permutations(k: usize) -> Vec<(Vec<usize>, i64)> {
    if k == 0 {
        return vec![(Vec::new(), 1)];
    }
    let mut out = Vec::new();
    for first in 0..k {
        for (rest, sign) in permutations(k - 1) {
            // `rest` permutes 0..k-1; lift it to the elements other than `first`.
            let mut p = vec![first];
            p.extend(rest.iter().map(|&r| if r >= first { r + 1 } else { r }));
            // Moving `first` to the front takes `first` transpositions.
            out.push((p, if first % 2 == 0 { sign } else { -sign }));
        }
    }
    out
}

/// Most elements one vector or matrix may have.
pub const MAX_ELEMENTS: usize = 256;

/// Most statements all the `for` loops of a spec may produce when unrolled.
pub const MAX_UNROLLED: usize = 4096;

const INDEX_HELP: &str = "an index or loop bound is a whole number known at compile time: a \
literal, a loop variable, an integer `const`, or `+ - *` of those";

/// The expanded spec, and the element of a vector `let` each generated `let` name stands for.
pub struct Expanded {
    /// The spec with scalars only.
    pub ast: SpecAst,
    /// `pphi_0` → `pphi[0]` for `let pphi = [..];`.
    pub let_elems: HashMap<String, Elem>,
    /// The `newton_recip` sites, in order.
    pub recips: Vec<RecipSite>,
    /// The constants valued by a rule parameter's default (see [`super::rules`]).
    pub rule_defaults: HashSet<String>,
    /// The rule parameters `check` quantises to a port's resolution.
    pub port_params: Vec<super::rules::PortParam>,
}

/// One `newton_recip(d, [LO, HI], K)` of the step.
#[derive(Clone)]
pub struct RecipSite {
    /// The call.
    pub span: Span,
    /// `LO` and `HI` as written (constant expressions).
    pub lo: Expr,
    /// See `lo`.
    pub hi: Expr,
    /// Newton steps.
    pub steps: u32,
    /// The generated `let`s: the clamped `d`, then per step `t_k = 2 − d·r_{k−1}` and the
    /// iterate `r_k`; the last is the result.
    pub lets: Vec<String>,
    /// The generated constants: the seed and the iterates' bounds.
    pub consts: Vec<String>,
    /// The table that seeds the iteration, if one is given (else the constant seed).
    pub seed_table: Option<String>,
}

/// Most Newton steps `newton_recip` takes (each doubles the correct bits; 6 take a seed
/// error of 0.9 to 1e-3, and a table seed needs fewer).
pub const MAX_NEWTON_STEPS: i64 = 8;

/// The relative margin of the clamps of Newton iterates over their real-arithmetic bounds,
/// for the rounding of the fixed-point computation.
const NEWTON_MARGIN: f64 = 1.0 / 256.0;

/// Rewrites `ast` so that every signal, `let` and expression is a scalar.
pub fn expand(ast: &SpecAst) -> Result<Expanded> {
    let inst = super::rules::instantiate(ast)?;
    let ast = &inst.ast;
    let mut x = Expander::default();
    let mut items = Vec::with_capacity(ast.items.len());
    for item in &ast.items {
        match item {
            Item::Constant(c) => {
                x.declare(&c.name)?;
                if let Ok(v) = x.int(&c.value) {
                    x.ints.insert(c.name.to_string(), v);
                }
                items.push(item.clone());
            }
            Item::Signal(s) => {
                x.declare(&s.name)?;
                for d in x.signal(s)? {
                    items.push(Item::Signal(Box::new(d)));
                }
            }
            Item::Step(block) => {
                let mut b = block.clone();
                x.in_step = true;
                b.stmts = x.stmts(&block.stmts)?;
                x.in_step = false;
                // The seeds of `newton_recip`, declared just before the step.
                items.append(&mut x.seeds);
                items.push(Item::Step(b));
            }
            Item::Prove { items: props, span } => {
                let props = x.props(props)?;
                items.push(Item::Prove {
                    items: props,
                    span: *span,
                });
            }
            other => items.push(other.clone()),
        }
    }
    Ok(Expanded {
        ast: SpecAst {
            docs: ast.docs.clone(),
            name: ast.name.clone(),
            items,
        },
        let_elems: x.let_elems,
        recips: x.recips,
        rule_defaults: inst.defaults,
        port_params: inst.port_params,
    })
}

/// What a name stands for inside an unrolled loop iteration.
#[derive(Clone)]
enum Subst {
    /// The loop variable's value in this iteration.
    Int(i64),
    /// A `let` of the loop body, renamed for this iteration.
    Name(String),
}

#[derive(Default)]
struct Expander {
    /// Integer-valued `const`s, for dimensions, indices and loop bounds.
    ints: HashMap<String, i64>,
    /// Dimensions of every vector and matrix (signals and `let`s), by generated name.
    shapes: HashMap<String, Vec<usize>>,
    /// Names declared at the top level (constants, signals), which loop variables may not
    /// reuse.
    names: HashSet<String>,
    /// Substitutions of the loops being unrolled, innermost last.
    frames: Vec<HashMap<String, Subst>>,
    /// The element each generated `let` of a vector `let` stands for.
    let_elems: HashMap<String, Elem>,
    /// Whether the step body is being expanded (not `prove`).
    in_step: bool,
    /// `let`s hoisted out of the statement being expanded (`newton_recip`).
    hoisted: Vec<syn::Stmt>,
    /// `const` items the step needs (the seeds of `newton_recip`).
    seeds: Vec<Item>,
    /// The `newton_recip` sites.
    recips: Vec<RecipSite>,
    /// Statements produced by unrolling so far.
    unrolled: usize,
    /// The values of the `for` loops of `prove` being unrolled, outermost first.
    prop_suffix: Vec<i64>,
    /// The first error met inside a visitor callback.
    err: Option<Diag>,
}

impl Expander {
    // ---- declarations ----------------------------------------------------------------

    /// Records a declared name; a second declaration of a vector's name is refused here
    /// (the checker sees only its elements).
    fn declare(&mut self, name: &Ident) -> Result<()> {
        let n = name.to_string();
        if !self.names.insert(n.clone()) {
            return Err(Diag::new(name.span(), format!("`{n}` is already defined"))
                .help("every constant, signal and `let` needs its own name"));
        }
        Ok(())
    }

    /// The scalar declarations of `s`: itself, or one per element of a vector or matrix.
    fn signal(&mut self, s: &SignalDecl) -> Result<Vec<SignalDecl>> {
        let group = s.name.to_string();
        if s.dims.is_empty() {
            if let Some(RangeDecl::PerElement(a)) = &s.range {
                return Err(Diag::new(
                    a.span(),
                    format!("per-element ranges need a vector: `{group}` is a scalar"),
                )
                .help(format!(
                    "declare `{group}[N]: [[LO, HI], ..]`, or give one range `[LO, HI]`"
                )));
            }
            if let Some(Expr::Array(a)) = &s.init {
                return Err(Diag::new(
                    a.span(),
                    format!("an array of initial values needs a vector: `{group}` is a scalar"),
                )
                .help(format!("declare `{group}[N]`, or give one initial value")));
            }
            return Ok(vec![s.clone()]);
        }
        let dims = s
            .dims
            .iter()
            .map(|d| self.dim(d))
            .collect::<Result<Vec<_>>>()?;
        if dims.len() > 3 {
            return Err(
                Diag::new(s.dims[3].span(), "a signal has at most three dimensions")
                    .help("declare a vector `x[N]`, a matrix `P[ROWS][COLS]`, or a stack of matrices `P[K][ROWS][COLS]` (one per estimator, say)"),
            );
        }
        let n: usize = dims.iter().product();
        if n > MAX_ELEMENTS {
            return Err(Diag::new(
                s.name.span(),
                format!("`{group}` has {n} elements; qloop unrolls every vector, and allows at most {MAX_ELEMENTS}"),
            )
            .help("the estimators qloop targets use n ≤ 3 parameters; split the signal"));
        }
        let ranges: Vec<Option<RangeDecl>> = match &s.range {
            None => vec![None; n],
            Some(RangeDecl::One(r)) => vec![Some(RangeDecl::One(r.clone())); n],
            Some(RangeDecl::PerElement(a)) => {
                let mut leaves = Vec::new();
                range_leaves(&Expr::Array(a.clone()), &mut leaves)?;
                if leaves.len() != n {
                    return Err(Diag::new(
                        a.span(),
                        format!("{} ranges for the {n} elements of `{group}`", leaves.len()),
                    )
                    .help("give one `[LO, HI]` per element, row-major, or one for all"));
                }
                leaves.into_iter().map(Some).collect()
            }
        };
        let inits: Vec<Option<Expr>> = match &s.init {
            None => vec![None; n],
            Some(Expr::Array(a)) => {
                let mut leaves = Vec::new();
                value_leaves(&Expr::Array(a.clone()), &mut leaves);
                if leaves.len() != n {
                    return Err(Diag::new(
                        a.span(),
                        format!(
                            "{} initial values for the {n} elements of `{group}`",
                            leaves.len()
                        ),
                    )
                    .help("give one value per element, row-major, or one for all"));
                }
                leaves.into_iter().map(Some).collect()
            }
            Some(e) => vec![Some(e.clone()); n],
        };
        let attrs = element_attrs(&s.attrs, n, &group)?;
        self.shapes.insert(group.clone(), dims.clone());
        let out = ranges
            .into_iter()
            .zip(inits)
            .zip(attrs)
            .enumerate()
            .map(|(k, ((range, init), attrs))| {
                let index = unflatten(k, &dims);
                let name = Ident::new(&Elem::ident(&group, &index), s.name.span());
                SignalDecl {
                    name,
                    dims: Vec::new(),
                    range,
                    init,
                    attrs,
                    elem: Some(Elem {
                        group: group.clone(),
                        index,
                        dims: dims.clone(),
                    }),
                    ..s.clone()
                }
            })
            .collect();
        Ok(out)
    }

    /// A declared dimension: a whole number ≥ 1.
    fn dim(&self, d: &Expr) -> Result<usize> {
        let v = self.int(d)?;
        if v < 1 {
            return Err(Diag::new(
                d.span(),
                format!("dimension {v}: a vector has at least one element"),
            ));
        }
        usize::try_from(v).map_err(|_| Diag::new(d.span(), "dimension out of range"))
    }

    // ---- compile-time integers --------------------------------------------------------

    /// A compile-time integer: an index, a dimension or a loop bound.
    fn int(&self, e: &Expr) -> Result<i64> {
        let bad = || {
            Diag::new(e.span(), "expected a whole number known at compile time").help(INDEX_HELP)
        };
        match e {
            Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Int(l),
                ..
            }) if l.suffix().is_empty() => l.base10_parse().map_err(|_| bad()),
            Expr::Paren(p) => self.int(&p.expr),
            Expr::Group(g) => self.int(&g.expr),
            Expr::Unary(u) if matches!(u.op, UnOp::Neg(_)) => {
                self.int(&u.expr)?.checked_neg().ok_or_else(bad)
            }
            Expr::Binary(b) => {
                let (l, r) = (self.int(&b.left)?, self.int(&b.right)?);
                match b.op {
                    BinOp::Add(_) => l.checked_add(r),
                    BinOp::Sub(_) => l.checked_sub(r),
                    BinOp::Mul(_) => l.checked_mul(r),
                    _ => None,
                }
                .ok_or_else(bad)
            }
            Expr::Path(_) => {
                let id = path_ident(e).ok_or_else(bad)?;
                let n = id.to_string();
                match self.resolve(&n) {
                    Some(Subst::Int(v)) => Ok(v),
                    _ => self.ints.get(&n).copied().ok_or_else(bad),
                }
            }
            _ => Err(bad()),
        }
    }

    /// The substitution of `n` in the loops being unrolled, innermost first.
    fn resolve(&self, n: &str) -> Option<Subst> {
        self.frames.iter().rev().find_map(|f| f.get(n).cloned())
    }

    /// The name `n` has in the current iteration (itself outside loops).
    fn renamed(&self, n: &str) -> String {
        match self.resolve(n) {
            Some(Subst::Name(m)) => m,
            _ => n.to_string(),
        }
    }

    // ---- statements ------------------------------------------------------------------

    fn stmts(&mut self, stmts: &[syn::Stmt]) -> Result<Vec<syn::Stmt>> {
        let mut out = Vec::with_capacity(stmts.len());
        for s in stmts {
            let mark = self.hoisted.len();
            let mut one = Vec::new();
            match s {
                syn::Stmt::Expr(Expr::ForLoop(f), _) => self.unroll(f, &mut one)?,
                syn::Stmt::Local(l) => self.local(l, &mut one)?,
                syn::Stmt::Expr(e, semi) => {
                    let mut e = e.clone();
                    self.expr(&mut e)?;
                    one.push(syn::Stmt::Expr(e, *semi));
                }
                other => one.push(other.clone()),
            }
            // What the statement's expressions hoisted goes before it.
            out.extend(self.hoisted.drain(mark..));
            out.append(&mut one);
        }
        Ok(out)
    }

    /// A `let`: renamed inside a loop; an array literal binds one `let` per element.
    fn local(&mut self, l: &syn::Local, out: &mut Vec<syn::Stmt>) -> Result<()> {
        let syn::Pat::Ident(p) = &l.pat else {
            out.push(syn::Stmt::Local(l.clone()));
            return Ok(());
        };
        let name = self.renamed(&p.ident.to_string());
        let ident = Ident::new(&name, p.ident.span());
        self.names.insert(name.clone());
        if self.shapes.contains_key(&name) {
            return Err(
                Diag::new(p.ident.span(), format!("`{name}` is already defined"))
                    .help("every constant, signal and `let` needs its own name"),
            );
        }
        let with_name = |ident: Ident, init: Option<syn::LocalInit>| {
            let mut l = l.clone();
            if let syn::Pat::Ident(p) = &mut l.pat {
                p.ident = ident;
            }
            l.init = init;
            syn::Stmt::Local(l)
        };
        let Some(init) = &l.init else {
            out.push(with_name(ident, None));
            return Ok(());
        };
        if let Expr::Array(a) = &*init.expr {
            let dims = array_dims(a)?;
            let mut leaves = Vec::new();
            value_leaves(&init.expr, &mut leaves);
            if dims.iter().product::<usize>() > MAX_ELEMENTS {
                return Err(Diag::new(
                    a.span(),
                    format!("at most {MAX_ELEMENTS} elements"),
                ));
            }
            for (k, mut v) in leaves.into_iter().enumerate() {
                self.expr(&mut v)?;
                let index = unflatten(k, &dims);
                let el = Ident::new(&Elem::ident(&name, &index), p.ident.span());
                self.let_elems.insert(
                    el.to_string(),
                    Elem {
                        group: name.clone(),
                        index,
                        dims: dims.clone(),
                    },
                );
                let mut i = init.clone();
                i.expr = Box::new(v);
                out.push(with_name(el, Some(i)));
            }
            self.shapes.insert(name, dims);
            return Ok(());
        }
        let mut i = init.clone();
        self.expr(&mut i.expr)?;
        out.push(with_name(ident, Some(i)));
        Ok(())
    }

    /// The items of a `prove` block with their expressions rewritten and `for` loops
    /// unrolled: each item of a loop's body once per value `k` of the loop variable, named
    /// `NAME_k`.
    fn props(&mut self, props: &[PropItem]) -> Result<Vec<PropItem>> {
        let mut out = Vec::new();
        for p in props {
            match p {
                PropItem::Invariant { docs, name, cond } => {
                    let mut cond = cond.clone();
                    self.expr(&mut cond)?;
                    out.push(PropItem::Invariant {
                        docs: docs.clone(),
                        name: self.prop_name(name),
                        cond,
                    });
                }
                PropItem::Property {
                    docs,
                    name,
                    foralls,
                    assumes,
                    ensures,
                } => {
                    let mut assumes = assumes.clone();
                    let mut ensures = ensures.clone();
                    for e in assumes.iter_mut().chain(ensures.iter_mut()) {
                        self.expr(e)?;
                    }
                    out.push(PropItem::Property {
                        docs: docs.clone(),
                        name: self.prop_name(name),
                        foralls: foralls.clone(),
                        assumes,
                        ensures,
                    });
                }
                PropItem::For(f) => {
                    let v = f.var.to_string();
                    if self.names.contains(&v)
                        || self.shapes.contains_key(&v)
                        || self.resolve(&v).is_some()
                    {
                        return Err(Diag::new(f.var.span(), format!("`{v}` is already defined"))
                            .help("name the loop variable differently"));
                    }
                    let (Some(lo), Some(hi)) = (&f.range.start, &f.range.end) else {
                        return Err(Diag::new(
                            f.range.span(),
                            "a loop range needs both ends: `A..B`",
                        ));
                    };
                    let (lo, mut hi) = (self.int(lo)?, self.int(hi)?);
                    if matches!(f.range.limits, syn::RangeLimits::Closed(_)) {
                        hi = hi.saturating_add(1);
                    }
                    let count = usize::try_from(hi.saturating_sub(lo)).unwrap_or(0);
                    let made = count.saturating_mul(f.items.len());
                    if self.unrolled.saturating_add(made) > MAX_UNROLLED {
                        return Err(Diag::new(
                            f.range.span(),
                            format!(
                                "unrolling this loop would make more than {MAX_UNROLLED} items"
                            ),
                        ));
                    }
                    self.unrolled += made;
                    for k in lo..hi {
                        self.frames
                            .push(HashMap::from([(v.clone(), Subst::Int(k))]));
                        self.prop_suffix.push(k);
                        let body = self.props(&f.items);
                        self.prop_suffix.pop();
                        self.frames.pop();
                        out.extend(body?);
                    }
                }
            }
        }
        Ok(out)
    }

    /// `name`, with the values of the enclosing `for` loops of `prove` appended (`name_2`).
    fn prop_name(&self, name: &Ident) -> Ident {
        let mut n = name.to_string();
        for k in &self.prop_suffix {
            n.push_str(&format!("_{k}"));
        }
        Ident::new(&n, name.span())
    }

    /// Unrolls `for i in A..B { body }` into `out`.
    fn unroll(&mut self, f: &syn::ExprForLoop, out: &mut Vec<syn::Stmt>) -> Result<()> {
        if let Some(l) = &f.label {
            return Err(Diag::new(l.span(), "loop labels are not supported"));
        }
        let var = match &*f.pat {
            syn::Pat::Ident(p) if p.mutability.is_none() && p.subpat.is_none() => &p.ident,
            other => {
                return Err(Diag::new(
                    other.span(),
                    "expected a loop variable: `for i in 0..N`",
                ))
            }
        };
        let v = var.to_string();
        if self.names.contains(&v) || self.shapes.contains_key(&v) || self.resolve(&v).is_some() {
            return Err(Diag::new(var.span(), format!("`{v}` is already defined"))
                .help("name the loop variable differently"));
        }
        let Expr::Range(r) = &*f.expr else {
            return Err(
                Diag::new(f.expr.span(), "expected a range: `for i in 0..N`")
                    .help("qloop unrolls loops over compile-time ranges `A..B` and `A..=B`"),
            );
        };
        let (Some(lo), Some(hi)) = (&r.start, &r.end) else {
            return Err(Diag::new(r.span(), "a loop range needs both ends: `A..B`"));
        };
        let (lo, mut hi) = (self.int(lo)?, self.int(hi)?);
        if matches!(r.limits, syn::RangeLimits::Closed(_)) {
            hi = hi.saturating_add(1);
        }
        let count = usize::try_from(hi.saturating_sub(lo)).unwrap_or(0);
        let made = count.saturating_mul(f.body.stmts.len());
        if self.unrolled.saturating_add(made) > MAX_UNROLLED {
            return Err(Diag::new(
                f.expr.span(),
                format!("unrolling this loop would make more than {MAX_UNROLLED} statements"),
            )
            .help("qloop unrolls every loop; loops run over the few elements of a vector"));
        }
        self.unrolled += made;
        let mut lets = LetNames::default();
        syn::visit::Visit::visit_block(&mut lets, &f.body);
        if lets.0.contains(&v) {
            return Err(Diag::new(
                var.span(),
                format!("`{v}` is also a `let` of the loop body"),
            )
            .help("name the loop variable differently"));
        }
        for k in lo..hi {
            let mut frame = HashMap::from([(v.clone(), Subst::Int(k))]);
            for n in &lets.0 {
                frame.insert(n.clone(), Subst::Name(format!("{}_{k}", self.renamed(n))));
            }
            self.frames.push(frame);
            let body = self.stmts(&f.body.stmts);
            self.frames.pop();
            out.extend(body?);
        }
        Ok(())
    }

    // ---- expressions -----------------------------------------------------------------

    /// Rewrites `e` in place: loop variables, renamed `let`s, indices, `sum` and `dot`.
    fn expr(&mut self, e: &mut Expr) -> Result<()> {
        self.visit_expr_mut(e);
        match self.err.take() {
            Some(d) => Err(d),
            None => Ok(()),
        }
    }

    /// The element names a vector argument of `sum`/`dot` stands for.
    fn vector_arg(&mut self, e: &Expr) -> Result<Vec<Expr>> {
        match e {
            Expr::Paren(p) => self.vector_arg(&p.expr),
            Expr::Array(a) => a
                .elems
                .iter()
                .map(|x| {
                    let mut x = x.clone();
                    self.expr(&mut x)?;
                    Ok(x)
                })
                .collect(),
            Expr::Path(_) | Expr::Index(_) => {
                let (name, dims, index, span) = self.indexed(e)?;
                if index.len() == dims.len() {
                    return Err(
                        Diag::new(span, "expected a vector, found one element").help(
                            "`sum` and `dot` take a vector, a matrix row `P[i]` or `[a, b, ..]`",
                        ),
                    );
                }
                let rest = &dims[index.len()..];
                let n: usize = rest.iter().product();
                Ok((0..n)
                    .map(|k| {
                        let mut full = index.clone();
                        full.extend(unflatten(k, rest));
                        path(&Elem::ident(&name, &full), span)
                    })
                    .collect())
            }
            other => Err(Diag::new(other.span(), "expected a vector")
                .help("`sum` and `dot` take a vector, a matrix row `P[i]` or `[a, b, ..]`")),
        }
    }

    /// `x`, `x[i]`, `P[i]`, `P[i][j]` over a declared vector or matrix: its generated name, its
    /// dimensions, the (checked) indices given, and the site.
    fn indexed(&self, e: &Expr) -> Result<(String, Vec<usize>, Vec<usize>, Span)> {
        let mut idx = Vec::new();
        let mut cur = e;
        while let Expr::Index(i) = cur {
            idx.push(&*i.index);
            cur = &i.expr;
        }
        idx.reverse();
        let base = path_ident(cur).ok_or_else(|| {
            Diag::new(
                cur.span(),
                "only a declared vector or matrix can be indexed",
            )
        })?;
        let name = self.renamed(&base.to_string());
        let Some(dims) = self.shapes.get(&name).cloned() else {
            return Err(
                Diag::new(base.span(), format!("`{name}` is not a vector or matrix")).help(
                    format!("declare it with a dimension, `state {name}[N]: ..`"),
                ),
            );
        };
        if idx.len() > dims.len() {
            return Err(Diag::new(
                e.span(),
                format!(
                    "`{name}` has {} dimension(s), indexed {} times",
                    dims.len(),
                    idx.len()
                ),
            ));
        }
        let mut index = Vec::new();
        for (ie, &d) in idx.iter().zip(&dims) {
            let v = self.int(ie)?;
            if v < 0 || v as usize >= d {
                return Err(Diag::new(
                    ie.span(),
                    format!("index {v} is out of bounds: `{name}` has {d} along this dimension"),
                )
                .label("out of bounds")
                .help(format!("indices run from 0 to {}", d - 1)));
            }
            index.push(v as usize);
        }
        Ok((name, dims, index, e.span()))
    }

    fn rewrite(&mut self, e: &mut Expr) -> Result<bool> {
        match e {
            Expr::Path(_) => {
                let Some(id) = path_ident(e) else {
                    return Ok(false);
                };
                let n = id.to_string();
                match self.resolve(&n) {
                    Some(Subst::Int(v)) => {
                        *e = Expr::Lit(syn::ExprLit {
                            attrs: Vec::new(),
                            lit: syn::Lit::Int(syn::LitInt::new(&v.to_string(), id.span())),
                        });
                        return Ok(true);
                    }
                    Some(Subst::Name(m)) => *e = path(&m, id.span()),
                    None => {}
                }
                let name = self.renamed(&n);
                if let Some(d) = self.shapes.get(&name) {
                    let (what, eg) = match d.as_slice() {
                        [n] => (format!("a vector of {n}"), "[0]"),
                        [r, c] => (format!("a {r}×{c} matrix"), "[0][0]"),
                        _ => (
                            format!(
                                "an array of {}",
                                d.iter()
                                    .map(|x| x.to_string())
                                    .collect::<Vec<_>>()
                                    .join("×")
                            ),
                            "[0][0][0]",
                        ),
                    };
                    return Err(Diag::new(
                        id.span(),
                        format!("`{name}` is {what}: use one element, or `sum`/`dot`"),
                    )
                    .label("not a number")
                    .help(format!(
                        "write `{name}{eg}`, `sum({name})` or `dot({name}, ..)`; a `for` loop \
                         visits every element"
                    )));
                }
                Ok(true)
            }
            Expr::Index(_) => {
                let (name, dims, index, span) = self.indexed(e)?;
                if index.len() < dims.len() {
                    return Err(Diag::new(
                        span,
                        format!("this is a row of `{name}`, not a number"),
                    )
                    .help(format!(
                        "index every dimension (`{name}[i][j]`), or pass the row to `sum`/`dot`"
                    )));
                }
                *e = path(&Elem::ident(&name, &index), span);
                Ok(true)
            }
            Expr::Call(c) => {
                let Some(f) = path_ident(&c.func) else {
                    return Ok(false);
                };
                let f = f.to_string();
                if f == "newton_recip" {
                    let args: Vec<Expr> = c.args.iter().cloned().collect();
                    *e = self.newton_recip(&args, c.span())?;
                    return Ok(true);
                }
                if f == "det" {
                    let args: Vec<Expr> = c.args.iter().cloned().collect();
                    *e = self.det(&args, c.span())?;
                    return Ok(true);
                }
                if f != "sum" && f != "dot" {
                    return Ok(false);
                }
                let span = c.span();
                let want = if f == "sum" { 1 } else { 2 };
                if c.args.len() != want {
                    return Err(Diag::new(span, format!("`{f}` takes {want} argument(s)")));
                }
                let a = self.vector_arg(&c.args[0])?;
                let terms: Vec<Expr> = if f == "sum" {
                    a
                } else {
                    let b = self.vector_arg(&c.args[1])?;
                    if a.len() != b.len() {
                        return Err(Diag::new(
                            span,
                            format!("`dot` of vectors of {} and {} elements", a.len(), b.len()),
                        )
                        .help("both vectors need the same length"));
                    }
                    a.iter()
                        .zip(&b)
                        .map(|(x, y)| syn::parse_quote_spanned!(span=> (#x) * (#y)))
                        .collect()
                };
                let mut it = terms.into_iter();
                let first = it
                    .next()
                    .ok_or_else(|| Diag::new(span, "an empty vector"))?;
                let acc = it.fold(
                    first,
                    |acc, t| syn::parse_quote_spanned!(span=> #acc + (#t)),
                );
                *e = syn::parse_quote_spanned!(span=> (#acc));
                Ok(true)
            }
            Expr::ForLoop(f) => Err(Diag::new(f.span(), "a `for` loop is a statement of `step`")
                .help("write the loop on its own inside `step`; it cannot be a value")),
            _ => Ok(false),
        }
    }
}

impl Expander {
    /// `det(M)` or `det(M, K)`: the determinant of the square matrix `M` (an array literal of
    /// rows, or a declared or `let` matrix), or its leading principal minor of order `K`.
    /// In `step`, expanded by minors ([`minor`]): the expression names each minor of the top
    /// rows by the same text wherever it occurs, and the lowering, which computes a
    /// subexpression once per statement, evaluates the 2^K − 1 minors once (5 × 5: 75
    /// products, against 292 for Leibniz's formula with the products of a symmetric matrix
    /// merged), with the leading minors of lower order of the same matrix in the same
    /// statement among them. In a property, by Leibniz's formula ([`leibniz`]). Both are exact,
    /// as every product and sum of a spec expression is, and the same polynomial in the
    /// prover's exact terms (products distributed, each monomial's factors in one order): a
    /// run-time test in `step` and an invariant on the stored values read alike to a prover.
    /// At most [`MAX_DET`] × [`MAX_DET`].
    fn det(&mut self, args: &[Expr], span: Span) -> Result<Expr> {
        const HELP: &str =
            "write `det(M)` or `det(M, K)`: `M` a square matrix (`[[a, b], [c, d]]`, \
                            or a declared or `let` matrix), `K` the order of the leading principal \
                            minor (default: all of M)";
        let (m, k) = match args {
            [m] => (m, None),
            [m, k] => (m, Some(k)),
            _ => return Err(Diag::new(span, "`det` takes 1 or 2 arguments").help(HELP)),
        };
        let rows: Vec<Vec<Expr>> = match m {
            Expr::Array(a) => a
                .elems
                .iter()
                .map(|r| match r {
                    Expr::Array(_) => self.vector_arg(r),
                    other => {
                        Err(Diag::new(other.span(), "expected a row, `[a, b, ..]`").help(HELP))
                    }
                })
                .collect::<Result<_>>()?,
            Expr::Path(_) | Expr::Index(_) => {
                // A matrix, or one matrix of a stack (`P[l]`).
                let (name, dims, index, sp) = self.indexed(m)?;
                if dims.len() != index.len() + 2 {
                    return Err(
                        Diag::new(sp, format!("this is not a matrix of `{name}`")).help(HELP)
                    );
                }
                let (r, c) = (dims[index.len()], dims[index.len() + 1]);
                (0..r)
                    .map(|i| {
                        (0..c)
                            .map(|j| {
                                let mut full = index.clone();
                                full.extend([i, j]);
                                path(&Elem::ident(&name, &full), sp)
                            })
                            .collect()
                    })
                    .collect()
            }
            other => return Err(Diag::new(other.span(), "expected a matrix").help(HELP)),
        };
        let n = rows.len();
        if n == 0 || rows.iter().any(|r| r.len() != n) {
            return Err(Diag::new(m.span(), "`det` needs a square matrix").help(HELP));
        }
        let k = match k {
            None => n,
            Some(k) => {
                let v = self.int(k)?;
                if v < 1 || v as usize > n {
                    return Err(Diag::new(
                        k.span(),
                        format!("a leading minor of order {v} of a {n} × {n} matrix"),
                    )
                    .help(format!("the order runs from 1 to {n}")));
                }
                v as usize
            }
        };
        if k > MAX_DET {
            return Err(Diag::new(
                span,
                format!("`det` of order {k}: at most {MAX_DET} (the expansion has K! products)"),
            )
            .help("a larger matrix needs a factorisation (LDLᵀ, UD) in `step` instead"));
        }
        let m = if self.in_step {
            minor(&rows, (1u32 << k) - 1, span)
        } else {
            leibniz(&rows, k, span)
        };
        Ok(syn::parse_quote_spanned!(span=> (#m)))
    }

    /// `newton_recip(d, [LO, HI], K)`: hoists the claimed `d` and the `K` Newton iterates
    /// into `let`s, declares the seed `2/(LO + HI)` as a `const`, and returns the last
    /// iterate's name (see the module docs).
    fn newton_recip(&mut self, args: &[Expr], span: Span) -> Result<Expr> {
        const HELP: &str = "write `newton_recip(d, [LO, HI], K)` or `newton_recip(d, [LO, HI], K, \
                            TABLE)`: `d` clamped to the constant range [LO, HI] (0 < LO < HI), `K` \
                            Newton steps, and optionally a table of 1/x over [LO, HI] as the seed";
        if !self.in_step {
            return Err(Diag::new(span, "`newton_recip` computes in `step`")
                .help("properties compare values; compute the reciprocal in `step` and store it"));
        }
        let (d, range, k, table) = match args {
            [d, range, k] => (d, range, k, None),
            [d, range, k, t] => {
                let name = path_ident(t).ok_or_else(|| {
                    Diag::new(t.span(), "expected the name of a table (the seed)").help(HELP)
                })?;
                (d, range, k, Some(name))
            }
            _ => return Err(Diag::new(span, "`newton_recip` takes 3 or 4 arguments").help(HELP)),
        };
        let Expr::Array(r) = range else {
            return Err(
                Diag::new(range.span(), "expected the range of `d`, `[LO, HI]`").help(HELP),
            );
        };
        let (Some(lo), Some(hi), 2) = (r.elems.first(), r.elems.get(1), r.elems.len()) else {
            return Err(Diag::new(range.span(), "expected `[LO, HI]`").help(HELP));
        };
        // Literal ends are checked here, where the message can say what is wrong (named
        // constants are checked where they are evaluated).
        if let (Some(l), Some(h)) = (literal_number(lo), literal_number(hi)) {
            if !(0.0 < l && l < h) {
                return Err(Diag::new(
                    range.span(),
                    format!("`newton_recip` needs 0 < LO < HI; the range is [{l}, {h}]"),
                )
                .label("not 0 < LO < HI")
                .help("the reciprocal is taken of `d` clamped to [LO, HI]: give a positive range that excludes 0, e.g. [0.25, 4.0]"));
            }
        }
        let steps = self.int(k)?;
        if !(1..=MAX_NEWTON_STEPS).contains(&steps) {
            return Err(Diag::new(
                k.span(),
                format!("{steps} Newton steps: `newton_recip` takes 1 to {MAX_NEWTON_STEPS}"),
            )
            .help("each step doubles the correct bits of the seed; narrow [LO, HI] rather than add steps"));
        }
        let mut d = d.clone();
        self.expr(&mut d)?;
        let first_const = self.seeds.len();
        let n = self.recips.len();
        let id = format!("qloop_recip{n}");
        let float = |v: f64| {
            let mut l = proc_macro2::Literal::f64_unsuffixed(v);
            l.set_span(span);
            l
        };
        let margin = float(NEWTON_MARGIN);
        let mut konst = |name: &Ident, doc: &str, value: Expr| {
            self.seeds.push(Item::Constant(ConstDecl {
                attrs: vec![syn::parse_quote_spanned!(span=> #[doc = #doc])],
                is_param: false,
                name: name.clone(),
                value,
                unit: None,
            }));
        };
        let dn = Ident::new(&format!("{id}_d"), span);
        self.hoisted.push(syn::parse_quote_spanned!(span=>
            let #dn = clamp(#d, #lo, #hi);
        ));
        let mut lets = vec![dn.to_string()];
        let mut prev = match &table {
            // A table seed: r0 = TABLE(d), a `let` like the iterates.
            Some(t) => {
                let r0 = Ident::new(&format!("{id}_r0"), span);
                self.hoisted.push(syn::parse_quote_spanned!(span=>
                    let #r0 = #t(#dn);
                ));
                lets.push(r0.to_string());
                r0
            }
            None => {
                let seed = Ident::new(&format!("{id}_seed"), span);
                konst(
                    &seed,
                    " The seed of a `newton_recip`: 2/(LO + HI), which minimises the largest |1 − d·r₀| over [LO, HI].",
                    syn::parse_quote_spanned!(span=> 2.0 / ((#lo) + (#hi))),
                );
                seed
            }
        };
        for k in 1..=steps {
            let rk = Ident::new(&format!("{id}_r{k}"), span);
            let (lo_k, hi_k) = (
                Ident::new(&format!("{id}_lo{k}"), span),
                Ident::new(&format!("{id}_hi{k}"), span),
            );
            let pow = float(2f64.powi(k as i32));
            // In real arithmetic 0 ≤ 1 − d·r_k ≤ E^(2^k), E = (HI − LO)/(HI + LO), so
            // r_k ∈ [(1 − E^(2^k))/HI, 1/LO]: the clamp to that (with a margin for rounding)
            // never acts in real arithmetic, and keeps the iterate's range from compounding
            // through interval arithmetic.
            konst(
                &lo_k,
                " A lower bound of a `newton_recip` iterate: (1 − E^(2^k))/HI, less a margin.",
                syn::parse_quote_spanned!(span=>
                    (1.0 - (((#hi) - (#lo)) / ((#hi) + (#lo))).powf(#pow)) / (#hi) * (1.0 - #margin)
                ),
            );
            konst(
                &hi_k,
                " An upper bound of a `newton_recip` iterate: 1/LO, plus a margin.",
                syn::parse_quote_spanned!(span=> 1.0 / (#lo) * (1.0 + #margin)),
            );
            // `t = 2 − d·r` in a word of its own (the checker sizes it), so that the step's
            // products stay single widening multiplies of two words.
            let tk = Ident::new(&format!("{id}_t{k}"), span);
            self.hoisted.push(syn::parse_quote_spanned!(span=>
                let #tk = 2.0 - #dn * #prev;
            ));
            self.hoisted.push(syn::parse_quote_spanned!(span=>
                let #rk = clamp(#prev * #tk, #lo_k, #hi_k);
            ));
            lets.push(tk.to_string());
            lets.push(rk.to_string());
            prev = rk;
        }
        let consts = self.seeds[first_const..]
            .iter()
            .filter_map(|i| match i {
                Item::Constant(c) => Some(c.name.to_string()),
                _ => None,
            })
            .collect();
        self.recips.push(RecipSite {
            consts,
            seed_table: table.map(|t| t.to_string()),
            span,
            lo: lo.clone(),
            hi: hi.clone(),
            steps: steps as u32,
            lets,
        });
        Ok(syn::parse_quote_spanned!(span=> #prev))
    }
}

impl VisitMut for Expander {
    fn visit_expr_mut(&mut self, e: &mut Expr) {
        if self.err.is_some() {
            return;
        }
        match self.rewrite(e) {
            Ok(true) => {}
            Ok(false) => syn::visit_mut::visit_expr_mut(self, e),
            Err(d) => self.err = Some(d),
        }
    }

    fn visit_block_mut(&mut self, b: &mut syn::Block) {
        if self.err.is_some() {
            return;
        }
        match self.stmts(&b.stmts) {
            Ok(s) => b.stmts = s,
            Err(d) => self.err = Some(d),
        }
    }
}

/// The names of every `let` in a loop body (nested blocks included).
#[derive(Default)]
struct LetNames(Vec<String>);

impl<'a> syn::visit::Visit<'a> for LetNames {
    fn visit_local(&mut self, l: &'a syn::Local) {
        if let syn::Pat::Ident(p) = &l.pat {
            self.0.push(p.ident.to_string());
        }
        syn::visit::visit_local(self, l);
    }
}

/// The `[LO, HI]` leaves of a per-element range list, row-major.
fn range_leaves(e: &Expr, out: &mut Vec<RangeDecl>) -> Result<()> {
    let Expr::Array(a) = e else {
        return Err(Diag::new(e.span(), "expected `[LO, HI]`"));
    };
    if a.elems.iter().any(|x| matches!(x, Expr::Array(_))) {
        for x in &a.elems {
            range_leaves(x, out)?;
        }
        return Ok(());
    }
    if a.elems.len() != 2 {
        return Err(Diag::new(a.span(), "a range is written `[LO, HI]`"));
    }
    out.push(RangeDecl::One(Box::new(RangeAst {
        lo: a.elems[0].clone(),
        hi: a.elems[1].clone(),
        span: a.bracket_token.span.join(),
    })));
    Ok(())
}

/// The attributes of each of the `n` elements of vector `group` from the vector's: each
/// element its own where `#[q]` or `#[lsb]` lists one per element, row-major
/// (`#[q([i16, 12], [i32, 28])]`, `#[lsb([1e-3, 1e-4])]`, nested by rows or flat), and
/// every other attribute as written.
fn element_attrs(
    attrs: &[syn::Attribute],
    n: usize,
    group: &str,
) -> Result<Vec<Vec<syn::Attribute>>> {
    let mut out = vec![Vec::new(); n];
    for a in attrs {
        let (q, lsb) = (a.path().is_ident("q"), a.path().is_ident("lsb"));
        let per: Option<Vec<proc_macro2::TokenStream>> = if q || lsb {
            let args = a
                .parse_args_with(
                    syn::punctuated::Punctuated::<Expr, syn::Token![,]>::parse_terminated,
                )
                .ok();
            match args {
                Some(args)
                    if args
                        .iter()
                        .next()
                        .is_some_and(|e| matches!(e, Expr::Array(_))) =>
                {
                    let mut leaves = Vec::new();
                    for e in &args {
                        if q {
                            format_leaves(e, &mut leaves)?;
                        } else {
                            value_leaves(e, &mut leaves);
                        }
                    }
                    if leaves.len() != n {
                        let what = if q { "formats" } else { "LSBs" };
                        return Err(Diag::new(
                            a.span(),
                            format!("{} {what} for the {n} elements of `{group}`", leaves.len()),
                        )
                        .help("give one per element, row-major, or one for all"));
                    }
                    Some(
                        leaves
                            .iter()
                            .map(|l| match l {
                                Expr::Array(p) => {
                                    let items = p.elems.iter();
                                    quote::quote_spanned!(p.span()=> #(#items),*)
                                }
                                other => quote::quote! { #other },
                            })
                            .collect(),
                    )
                }
                _ => None,
            }
        } else {
            None
        };
        match per {
            Some(items) => {
                let path = a.path().clone();
                for (o, it) in out.iter_mut().zip(items) {
                    o.push(syn::parse_quote_spanned!(a.span()=> #[#path(#it)]));
                }
            }
            None => out.iter_mut().for_each(|o| o.push(a.clone())),
        }
    }
    Ok(out)
}

/// The `[TYPE, FRAC]` leaves of a (nested) array of formats, row-major.
fn format_leaves(e: &Expr, out: &mut Vec<Expr>) -> Result<()> {
    let Expr::Array(a) = e else {
        return Err(Diag::new(
            e.span(),
            "expected `[TYPE, FRAC]`, e.g. `[i16, 12]`",
        ));
    };
    if a.elems.iter().any(|x| matches!(x, Expr::Array(_))) {
        for x in &a.elems {
            format_leaves(x, out)?;
        }
        return Ok(());
    }
    out.push(e.clone());
    Ok(())
}

/// The non-array leaves of a (nested) array literal, row-major.
fn value_leaves(e: &Expr, out: &mut Vec<Expr>) {
    match e {
        Expr::Array(a) => a.elems.iter().for_each(|x| value_leaves(x, out)),
        other => out.push(other.clone()),
    }
}

/// The dimensions of an array literal: `[a, b]` → `[2]`, `[[a, b], [c, d], [e, f]]` → `[3, 2]`.
fn array_dims(a: &syn::ExprArray) -> Result<Vec<usize>> {
    let rows = a.elems.len();
    if rows == 0 {
        return Err(Diag::new(a.span(), "an empty array"));
    }
    let inner: Vec<&syn::ExprArray> = a
        .elems
        .iter()
        .filter_map(|x| match x {
            Expr::Array(r) => Some(r),
            _ => None,
        })
        .collect();
    if inner.is_empty() {
        return Ok(vec![rows]);
    }
    let cols = inner[0].elems.len();
    let flat = inner
        .iter()
        .all(|r| !r.elems.iter().any(|x| matches!(x, Expr::Array(_))));
    if inner.len() != rows || !flat || inner.iter().any(|r| r.elems.len() != cols) || cols == 0 {
        return Err(
            Diag::new(a.span(), "a matrix literal has rows of equal length").help(
                "write `[[a, b], [c, d]]`: at most two dimensions, every row the same length",
            ),
        );
    }
    Ok(vec![rows, cols])
}

/// The index of the `k`-th element (row-major) of an array of dimensions `dims`.
fn unflatten(mut k: usize, dims: &[usize]) -> Vec<usize> {
    let mut idx = vec![0; dims.len()];
    for (i, d) in dims.iter().enumerate().rev() {
        idx[i] = k % d;
        k /= d;
    }
    idx
}

/// `name` as a path expression at `span`.
fn path(name: &str, span: Span) -> Expr {
    let id = Ident::new(name, span);
    syn::parse_quote_spanned!(span=> #id)
}

/// The identifier of a one-segment path expression.
fn path_ident(e: &Expr) -> Option<Ident> {
    match e {
        Expr::Path(p) if p.qself.is_none() => p.path.get_ident().cloned(),
        _ => None,
    }
}

/// The value of a numeric literal, possibly negated (`2.0`, `-1`), or `None`.
fn literal_number(e: &Expr) -> Option<f64> {
    match e {
        Expr::Lit(l) => match &l.lit {
            syn::Lit::Float(f) => f.base10_parse().ok(),
            syn::Lit::Int(i) => i.base10_parse::<i64>().ok().map(|v| v as f64),
            _ => None,
        },
        Expr::Unary(u) if matches!(u.op, syn::UnOp::Neg(_)) => literal_number(&u.expr).map(|v| -v),
        Expr::Paren(p) => literal_number(&p.expr),
        Expr::Group(g) => literal_number(&g.expr),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::parse::parse_str;

    /// Compiles a controller with `items` (line 2 onwards); the error's message, line and
    /// column.
    fn err(items: &str) -> (String, usize, usize) {
        let src = format!("controller t {{\n{items}\n}}\n");
        let d = parse_str(&src)
            .and_then(|a| crate::check::check(&a))
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{src}"));
        let (l, c) = d.line_col();
        (d.message, l, c)
    }

    const HEAD: &str =
        "period 0.1 \"s\";\ninput x[3]: [0.0, 1.0];\nstate s[2]: [-1.0, 1.0] = 0.0;\noutput y;";

    #[test]
    fn rejections_name_the_place() {
        let cases: &[(&str, &str, usize, usize)] = &[
            ("step { y = x[3]; }", "index 3 is out of bounds", 6, 14),
            ("step { y = x[0 - 1]; }", "index -1 is out of bounds", 6, 14),
            ("step { y = x; }", "`x` is a vector of 3", 6, 12),
            (
                "step { y = x[0][1]; }",
                "has 1 dimension(s), indexed 2 times",
                6,
                12,
            ),
            (
                "step { y = dot(x, s); }",
                "`dot` of vectors of 3 and 2 elements",
                6,
                12,
            ),
            (
                "step { y = sum(x[0]); }",
                "expected a vector, found one element",
                6,
                16,
            ),
            (
                "step { y = x[0.5]; }",
                "expected a whole number known at compile time",
                6,
                14,
            ),
            (
                "step { y = x[k]; }",
                "expected a whole number known at compile time",
                6,
                14,
            ),
            (
                "step { for i in 0..4 { s[i] = 0.0; } y = x[0]; }",
                "index 2 is out of bounds",
                6,
                26,
            ),
            (
                "step { for x in 0..2 { s[x] = 0.0; } y = 0.0; }",
                "`x` is already defined",
                6,
                12,
            ),
            (
                "step { for i in 0.. { s[i] = 0.0; } y = 0.0; }",
                "a loop range needs both ends",
                6,
                17,
            ),
            (
                "step { for i in 0..100000 { s[0] = 0.0; } y = 0.0; }",
                "more than 4096 statements",
                6,
                17,
            ),
            (
                "step { let s_0 = 1.0; y = s_0; }",
                "`s_0` is the generated name of `s[0]`",
                6,
                12,
            ),
            (
                "step { let g = [[1.0, 2.0], [3.0]]; y = 0.0; }",
                "rows of equal length",
                6,
                16,
            ),
            (
                "step { let g = [1.0, 2.0]; y = g[2]; }",
                "index 2 is out of bounds",
                6,
                34,
            ),
            (
                "state q[2]: [[0.0, 1.0]] = 0.0;\nstep { y = 0.0; }",
                "1 ranges for the 2 elements of `q`",
                6,
                13,
            ),
            (
                "state q[2]: [0.0, 1.0] = [0.0, 0.5, 1.0];\nstep { y = 0.0; }",
                "3 initial values for the 2 elements",
                6,
                26,
            ),
            (
                "state q: [[0.0, 1.0]] = 0.0;\nstep { y = 0.0; }",
                "per-element ranges need a vector",
                6,
                10,
            ),
            (
                "state q[0]: [0.0, 1.0] = 0.0;\nstep { y = 0.0; }",
                "a vector has at least one element",
                6,
                9,
            ),
            (
                "state q[17][17]: [0.0, 1.0] = 0.0;\nstep { y = 0.0; }",
                "`q` has 289 elements",
                6,
                7,
            ),
            (
                "state q[2][2][2][2]: [0.0, 1.0] = 0.0;\nstep { y = 0.0; }",
                "at most three dimensions",
                6,
                18,
            ),
            (
                "state q[2]: [0.0, 1.0] = [0.0, 2.0];\nstep { y = 0.0; }",
                "initial value 2 is outside the range",
                6,
                32,
            ),
        ];
        for (items, msg, line, col) in cases {
            let (m, l, c) = err(&format!("{HEAD}\n{items}"));
            assert!(m.contains(msg), "{items}: got `{m}`");
            assert_eq!((l, c), (*line, *col), "{items}: {m}");
        }
    }

    /// The expanded step of `items`, as text.
    fn expanded(items: &str) -> String {
        let src = format!("controller t {{\n{HEAD}\n{items}\n}}\n");
        let x = expand(&parse_str(&src).unwrap()).unwrap();
        let step = x.ast.items.iter().find_map(|i| match i {
            Item::Step(b) => Some(b.clone()),
            _ => None,
        });
        let b = step.unwrap();
        quote::quote!(#b).to_string()
    }

    #[test]
    fn loops_unroll_and_name_their_lets_per_iteration() {
        assert_eq!(
            expanded("step { for i in 0..2 { let k = x[i + 1] * 0.5; s[i] = k; } y = 0.0; }"),
            "{ let k_0 = x_1 * 0.5 ; s_0 = k_0 ; let k_1 = x_2 * 0.5 ; s_1 = k_1 ; y = 0.0 ; }"
        );
        // Nested loops: the inner bound may use the outer variable; `..=` is inclusive.
        assert_eq!(
            expanded("step { for i in 0..2 { for j in i..=1 { s[j] += x[i]; } } y = 0.0; }"),
            "{ s_0 += x_0 ; s_1 += x_0 ; s_1 += x_1 ; y = 0.0 ; }"
        );
    }

    #[test]
    fn sum_and_dot_expand_to_sums_of_elements() {
        assert_eq!(
            expanded("step { y = sum(x) + dot(s, [x[0], 2.0]); }"),
            "{ y = (x_0 + (x_1) + (x_2)) + ((s_0) * (x_0) + ((s_1) * (2.0))) ; }"
        );
        assert_eq!(
            expanded("step { let m = [[x[0], 1.0], [2.0, x[1]]]; y = dot(m[1], s) + sum(m); }"),
            "{ let m_0_0 = x_0 ; let m_0_1 = 1.0 ; let m_1_0 = 2.0 ; let m_1_1 = x_1 ; \
             y = ((m_1_0) * (s_0) + ((m_1_1) * (s_1))) + (m_0_0 + (m_0_1) + (m_1_0) + (m_1_1)) ; }"
        );
    }

    #[test]
    fn det_expands_by_minors_of_the_top_rows() {
        // 2 × 2: a·c − b·b, the positive term first; the matrix read whole and as a leading
        // minor.
        assert_eq!(
            expanded("step { y = det([[x[0], x[1]], [x[1], x[2]]]); }"),
            "{ y = ((x_2) * (x_0) - (x_1) * (x_1)) ; }"
        );
        assert_eq!(
            expanded("step { y = det([[x[0], x[1]], [x[1], x[2]]], 1); }"),
            "{ y = (x_0) ; }"
        );
        // A literal zero drops its term.
        assert_eq!(
            expanded("step { y = det([[x[0], x[1]], [0.0, x[2]]]); }"),
            "{ y = ((x_2) * (x_0)) ; }"
        );
        // The order-2 minor of the top rows is the same text inside the order-3 one, where
        // the lowering computes it once.
        let m = "[[x[0], x[1], x[2]], [x[1], x[0], x[1]], [x[2], x[1], x[0]]]";
        let two = expanded(&format!("step {{ y = det({m}, 2); }}"));
        let three = expanded(&format!("step {{ y = det({m}); }}"));
        let inner = two.trim_start_matches("{ y = (").trim_end_matches(") ; }");
        assert_eq!(inner, "(x_0) * (x_0) - (x_1) * (x_1)");
        assert!(three.contains(&format!("(x_0) * ({inner})")), "{three}");
    }

    /// Evaluates an expanded `det` (products, sums, differences, parentheses, integer
    /// literals and the names of `vals`) exactly.
    fn eval(e: &Expr, vals: &std::collections::HashMap<String, i128>) -> i128 {
        match e {
            Expr::Paren(p) => eval(&p.expr, vals),
            Expr::Binary(b) => {
                let (l, r) = (eval(&b.left, vals), eval(&b.right, vals));
                match b.op {
                    syn::BinOp::Add(_) => l + r,
                    syn::BinOp::Sub(_) => l - r,
                    syn::BinOp::Mul(_) => l * r,
                    _ => panic!("unexpected operator in {}", quote::quote!(#e)),
                }
            }
            Expr::Lit(l) => match &l.lit {
                syn::Lit::Float(f) => f.base10_parse::<f64>().unwrap() as i128,
                syn::Lit::Int(i) => i.base10_parse::<i128>().unwrap(),
                _ => panic!("literal"),
            },
            Expr::Path(p) => vals[&quote::quote!(#p).to_string()],
            other => panic!("unexpected {}", quote::quote!(#other)),
        }
    }

    #[test]
    fn det_by_minors_equals_leibniz_on_every_order() {
        // Integer matrices (some symmetric, some with zeros): the expansion by minors and
        // Leibniz's formula over the permutations agree exactly, for every leading minor.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 41) as i128 - 20
        };
        for case in 0..60 {
            let n = 1 + case % MAX_DET;
            let mut a: Vec<Vec<i128>> = Vec::new();
            for i in 0..n {
                let row = (0..n)
                    .map(|j| {
                        if case % 3 == 0 && j < i {
                            a[j][i]
                        } else {
                            next()
                        }
                    })
                    .collect();
                a.push(row);
            }
            let names: Vec<Vec<String>> = (0..n)
                .map(|i| (0..n).map(|j| format!("m{i}{j}")).collect())
                .collect();
            let mut vals = std::collections::HashMap::new();
            let rows: Vec<Vec<Expr>> = (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| {
                            let v = a[i][j];
                            if v == 0 && case % 2 == 0 {
                                syn::parse_quote!(0.0)
                            } else {
                                vals.insert(names[i][j].clone(), v);
                                let id = Ident::new(&names[i][j], Span::call_site());
                                syn::parse_quote!(#id)
                            }
                        })
                        .collect()
                })
                .collect();
            for k in 1..=n {
                let got = eval(&minor(&rows, (1u32 << k) - 1, Span::call_site()), &vals);
                let want: i128 = permutations(k)
                    .iter()
                    .map(|(p, s)| i128::from(*s) * (0..k).map(|i| a[i][p[i]]).product::<i128>())
                    .sum();
                assert_eq!(got, want, "order {k} of {a:?}");
            }
        }
    }

    #[test]
    fn loops_over_prove_items_name_each_copy() {
        let src = format!(
            "controller t {{\n{HEAD}\nstep {{ y = 0.0; }}\nprove {{ for l in 0..2 {{ \
             invariant small: s[l] <= 1.0; for j in 1..=1 {{ property p {{ ensure x[l + j] >= 0.0; }} }} }} }}\n}}\n"
        );
        let x = expand(&parse_str(&src).unwrap()).unwrap();
        let names: Vec<String> = x
            .ast
            .items
            .iter()
            .filter_map(|i| match i {
                Item::Prove { items, .. } => Some(items),
                _ => None,
            })
            .flatten()
            .map(|p| match p {
                PropItem::Invariant { name, cond, .. } => {
                    format!("{name}: {}", quote::quote!(#cond))
                }
                PropItem::Property { name, ensures, .. } => {
                    let e = &ensures[0];
                    format!("{name}: {}", quote::quote!(#e))
                }
                PropItem::For(_) => "unexpanded".into(),
            })
            .collect();
        assert_eq!(
            names,
            [
                "small_0: s_0 <= 1.0",
                "p_0_1: x_1 >= 0.0",
                "small_1: s_1 <= 1.0",
                "p_1_1: x_2 >= 0.0"
            ]
        );
    }

    #[test]
    fn permutations_carry_their_signs() {
        for k in 1..=5 {
            let ps = permutations(k);
            assert_eq!(ps.len(), (1..=k).product::<usize>());
            for (p, sign) in &ps {
                // The sign by counting inversions.
                let inv = (0..k)
                    .flat_map(|i| (i + 1..k).map(move |j| (i, j)))
                    .filter(|&(i, j)| p[i] > p[j])
                    .count();
                assert_eq!(*sign, if inv % 2 == 0 { 1 } else { -1 }, "{p:?}");
            }
        }
    }

    #[test]
    fn unflatten_is_row_major() {
        assert_eq!(unflatten(0, &[2, 3]), vec![0, 0]);
        assert_eq!(unflatten(4, &[2, 3]), vec![1, 1]);
        assert_eq!(unflatten(5, &[2, 3]), vec![1, 2]);
        for k in 0..6 {
            let e = Elem {
                group: "P".into(),
                index: unflatten(k, &[2, 3]),
                dims: vec![2, 3],
            };
            assert_eq!(e.flat(), k);
        }
    }
}
