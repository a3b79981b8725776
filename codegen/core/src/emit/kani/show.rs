//! Text and literals for the harnesses: spec syntax of conditions, doc-comment wrapping, integer
//! literals.

use super::super::rust::int_ty;
use crate::ir::{PCond, PExpr, Property, SigKind, When};
use crate::lower::Plan;
use crate::prop_eval::ParamGrid;
use crate::qformat::IntTy;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

/// The narrowest signed Rust type holding a parameter grid.
pub(super) fn param_ty(g: &ParamGrid) -> Ident {
    match IntTy::signed_for(g.lo, g.hi, 8) {
        Some(t) => int_ty(t),
        None => Ident::new("i128", Span::call_site()),
    }
}

/// An unsuffixed integer literal (negative as `-N`); the context gives its type.
pub(super) fn int(v: i128) -> TokenStream {
    let l = Literal::i128_unsuffixed(v.unsigned_abs() as i128);
    if v < 0 {
        quote! { -#l }
    } else {
        quote! { #l }
    }
}

/// An `i128` literal.
pub(super) fn i128_lit(v: i128) -> TokenStream {
    if v == i128::MIN {
        return quote! { i128::MIN };
    }
    let l = Literal::i128_suffixed(v.abs());
    if v < 0 {
        quote! { (-#l) }
    } else {
        quote! { #l }
    }
}

/// A doc attribute's text: each line after a space, as `///` comments are written, and
/// long lines (the ones written here; spec docs come wrapped) wrapped at 96 columns, list
/// items with a hanging indent.
pub(super) fn spaced(d: &str) -> String {
    const WIDTH: usize = 96;
    let mut out: Vec<String> = Vec::new();
    for l in d.lines() {
        if l.is_empty() {
            out.push(String::new());
            continue;
        }
        let hang = if l.starts_with("* ") { "   " } else { " " };
        // A line must not start with something Markdown reads as block structure (a quote,
        // a list item, a heading): such words stay with the word before them.
        let mut words: Vec<String> = Vec::new();
        for w in l.split(' ') {
            let risky = w.starts_with(['>', '<', '-', '+', '*', '#', '=', '|'])
                || w.trim_end_matches(['.', ')'])
                    .chars()
                    .all(|c| c.is_ascii_digit())
                    && w.ends_with(['.', ')']);
            match words.last_mut() {
                Some(last) if risky => {
                    last.push(' ');
                    last.push_str(w);
                }
                _ => words.push(w.to_string()),
            }
        }
        let mut cur = String::from(" ");
        for w in &words {
            if cur.trim().is_empty() {
                cur.push_str(w);
            } else if cur.chars().count() + 1 + w.chars().count() > WIDTH {
                out.push(std::mem::replace(&mut cur, format!("{hang}{w}")));
            } else {
                cur.push(' ');
                cur.push_str(w);
            }
        }
        out.push(cur);
    }
    out.join("\n")
}

/// A spec item's doc lines as a paragraph (empty if none).
pub(super) fn doc_lines(docs: &[String]) -> String {
    let mut d = docs.join("\n");
    if !d.is_empty() {
        d.push_str("\n\n");
    }
    d
}

/// `a, b and c`.
pub(super) fn list(items: impl Iterator<Item = String>) -> String {
    let v: Vec<String> = items.collect();
    match v.len() {
        0 => "none".into(),
        1 => v[0].clone(),
        n => format!("{} and {}", v[..n - 1].join(", "), v[n - 1]),
    }
}

/// Spec syntax of a property expression (precedence: 0 sum, 1 product, 2 atom).
pub fn show_expr(plan: &Plan, params: &[String], e: &PExpr) -> String {
    fn go(plan: &Plan, params: &[String], e: &PExpr, min: u8) -> String {
        let (s, prec) = match e {
            PExpr::Const(c) => (format!("{c}"), if *c < 0.0 { 0 } else { 2 }),
            PExpr::Sig(id, when) => {
                let s = plan.prog.sig(*id);
                let n = match (s.kind, when) {
                    (SigKind::State, When::Post) => format!("next({})", s.name),
                    _ => s.name.clone(),
                };
                (n, 2)
            }
            PExpr::Param(i) => (
                params
                    .get(*i)
                    .cloned()
                    .unwrap_or_else(|| format!("param{i}")),
                2,
            ),
            PExpr::Neg(a) => (format!("-{}", go(plan, params, a, 2)), 2),
            PExpr::Abs(a) => (format!("abs({})", go(plan, params, a, 0)), 2),
            PExpr::Min(a, b) => (
                format!(
                    "min({}, {})",
                    go(plan, params, a, 0),
                    go(plan, params, b, 0)
                ),
                2,
            ),
            PExpr::Max(a, b) => (
                format!(
                    "max({}, {})",
                    go(plan, params, a, 0),
                    go(plan, params, b, 0)
                ),
                2,
            ),
            PExpr::Add(a, b) => (
                format!("{} + {}", go(plan, params, a, 0), go(plan, params, b, 1)),
                0,
            ),
            PExpr::Sub(a, b) => (
                format!("{} - {}", go(plan, params, a, 0), go(plan, params, b, 1)),
                0,
            ),
            PExpr::Mul(a, b) => (
                format!("{} * {}", go(plan, params, a, 1), go(plan, params, b, 2)),
                1,
            ),
        };
        if prec < min {
            format!("({s})")
        } else {
            s
        }
    }
    go(plan, params, e, 0)
}

/// Spec syntax of a property condition.
pub fn show_cond(plan: &Plan, params: &[String], c: &PCond) -> String {
    fn go(plan: &Plan, params: &[String], c: &PCond, min: u8) -> String {
        let (s, prec) = match c {
            PCond::Cmp(op, a, b) => (
                format!(
                    "{} {} {}",
                    show_expr(plan, params, a),
                    op.symbol(),
                    show_expr(plan, params, b)
                ),
                2,
            ),
            PCond::Or(a, b) => (
                format!("{} || {}", go(plan, params, a, 0), go(plan, params, b, 0)),
                0,
            ),
            PCond::And(a, b) => (
                format!("{} && {}", go(plan, params, a, 1), go(plan, params, b, 1)),
                1,
            ),
            PCond::Not(a) => (format!("!{}", go(plan, params, a, 3)), 3),
        };
        if prec < min {
            format!("({s})")
        } else {
            s
        }
    }
    go(plan, params, c, 0)
}

/// Asserts `holds`. Under Kani the message is a literal naming what failed (Kani reports a
/// formatted message only as "a placeholder message"); under `cargo test` it is the formatted
/// one, with the values (`fmt` and its `args`).
pub(super) fn check(
    holds: &TokenStream,
    literal: &str,
    fmt: &str,
    args: TokenStream,
) -> TokenStream {
    quote! {
        #[cfg(kani)]
        kani::assert(#holds, #literal);
        #[cfg(not(kani))]
        assert!(#holds, #fmt, #args);
    }
}

/// The conjuncts of a condition (`a && b && c` → `[a, b, c]`), each asserted on its own so
/// that a failure names the clause.
pub(super) fn conjuncts(c: &PCond) -> Vec<&PCond> {
    match c {
        PCond::And(a, b) => {
            let mut v = conjuncts(a);
            v.extend(conjuncts(b));
            v
        }
        _ => vec![c],
    }
}

/// Generator fields of a property's free parameters: each on its grid (raw).
pub(super) fn param_fields(p: &Property, grids: &[ParamGrid]) -> Vec<TokenStream> {
    p.params
        .iter()
        .zip(grids)
        .map(|(fp, g)| {
            let n = format_ident!("{}", fp.name);
            let t = param_ty(g);
            let (lo, hi) = (int(g.lo), int(g.hi));
            quote! { #[generator(#lo..=#hi)] #n: #t, }
        })
        .collect()
}

/// Whether every free parameter of a property is on its grid: the generator ranges of
/// [`param_fields`], checked where Kani draws any bits (`true` for none).
pub(super) fn param_ranges(p: &Property, grids: &[ParamGrid]) -> TokenStream {
    let parts: Vec<TokenStream> = p
        .params
        .iter()
        .zip(grids)
        .map(|(fp, g)| {
            let v = format_ident!("param_{}", fp.name);
            let (lo, hi) = (int(g.lo), int(g.hi));
            quote! { (#lo..=#hi).contains(&#v) }
        })
        .collect();
    if parts.is_empty() {
        quote! { true }
    } else {
        quote! { #(#parts)&&* }
    }
}

/// `let param_<name> = i128::from(c.<name>);` for each free parameter of a property.
pub(super) fn param_lets(p: &Property) -> Vec<TokenStream> {
    p.params
        .iter()
        .map(|fp| {
            let (v, n) = (
                format_ident!("param_{}", fp.name),
                format_ident!("{}", fp.name),
            );
            quote! { let #v = i128::from(c.#n); }
        })
        .collect()
}
