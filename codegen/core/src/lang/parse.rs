//! The one parser for specs, used by both the `controller!` macro and the `qloop` CLI.
//!
//! Specs are Rust token trees, so `syn` does the lexing, and the `step` body is parsed as an
//! ordinary Rust block; [`crate::check`] later rejects what qloop does not support.

use super::ast::*;
use crate::diag::{Diag, Result};
use proc_macro2::TokenStream;
use syn::parse::{Parse, ParseStream};
use syn::{braced, bracketed, Attribute, Expr, Ident, LitStr, Token};

mod kw {
    syn::custom_keyword!(controller);
    syn::custom_keyword!(period);
    syn::custom_keyword!(rounding);
    syn::custom_keyword!(word);
    syn::custom_keyword!(input);
    syn::custom_keyword!(state);
    syn::custom_keyword!(output);
    syn::custom_keyword!(param);
    syn::custom_keyword!(step);
    syn::custom_keyword!(prove);
    syn::custom_keyword!(invariant);
    syn::custom_keyword!(property);
    syn::custom_keyword!(forall);
    syn::custom_keyword!(assume);
    syn::custom_keyword!(ensure);
    syn::custom_keyword!(table);
    syn::custom_keyword!(error);
    syn::custom_keyword!(tune);
    syn::custom_keyword!(pow2);
    syn::custom_keyword!(rule);
    syn::custom_keyword!(apply);
    syn::custom_keyword!(on);
    syn::custom_keyword!(pre);
}

const TUNE_HELP: &str = "write `tune NAME in {A, B, ..};`, `tune NAME in [LO, HI], step H;` or \
`tune NAME in [LO, HI], pow2;` (every power of two in the range: shift gains)";

const ITEM_HELP: &str = "a controller body holds `period`, `rounding`, `word`, `input`, `param`, \
`const`, `table`, `state`, `output`, `tune`, `rule`, `apply`, `use`, `step { .. }` and \
`prove { .. }` items";

const RULE_HELP: &str = "write `rule NAME(PARAM: DEFAULT \"unit\", ..) on (PORT, ..) { .. }`: \
parameters with an optional default and unit, the ports the body uses, and a body of `const`, \
`state`, `output`, `table`, `pre { .. }`, `step { .. }` and `prove { .. }` items";

const APPLY_HELP: &str = "write `apply NAME(PARAM = VALUE, ..) on (PORT = SIGNAL, ..);`, \
optionally followed by `as ALIAS` before the `;`";

const TABLE_HELP: &str = "write `table NAME(x: [A, B] \"unit\") = EXPR, step H;` (optionally \
`, error E`): EXPR a compile-time expression of x, H a power of two";

impl Parse for SpecAst {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let attrs = input.call(Attribute::parse_outer)?;
        let docs = doc_lines(&attrs);
        if let Some(a) = attrs.iter().find(|a| !a.path().is_ident("doc")) {
            return Err(syn::Error::new_spanned(
                a,
                "only doc comments may stand above `controller`",
            ));
        }
        input
            .parse::<kw::controller>()
            .map_err(|e| syn::Error::new(e.span(), "expected `controller NAME { ... }`"))?;
        let name: Ident = input.parse()?;
        let content;
        braced!(content in input);
        let mut items = Vec::new();
        while !content.is_empty() {
            items.push(parse_item(&content)?);
        }
        if !input.is_empty() {
            return Err(input.error("unexpected tokens after the controller's closing brace"));
        }
        Ok(SpecAst { docs, name, items })
    }
}

fn parse_item(input: ParseStream) -> syn::Result<Item> {
    let attrs = input.call(Attribute::parse_outer)?;
    let la = input.lookahead1();
    if la.peek(kw::period) {
        let span = input.parse::<kw::period>()?.span;
        let value = parse_value(input)?;
        let unit = parse_unit(input)?;
        input.parse::<Token![;]>()?;
        Ok(Item::Period { value, unit, span })
    } else if la.peek(kw::rounding) {
        input.parse::<kw::rounding>()?;
        let mode: Ident = input.parse()?;
        input.parse::<Token![;]>()?;
        Ok(Item::Rounding { mode })
    } else if la.peek(kw::word) {
        input.parse::<kw::word>()?;
        let bits = input.parse()?;
        input.parse::<Token![;]>()?;
        Ok(Item::Word { bits })
    } else if la.peek(kw::input) || la.peek(kw::state) || la.peek(kw::output) {
        let (kind, kw_span) = if input.peek(kw::input) {
            (SignalKw::Input, input.parse::<kw::input>()?.span)
        } else if input.peek(kw::state) {
            (SignalKw::State, input.parse::<kw::state>()?.span)
        } else {
            (SignalKw::Output, input.parse::<kw::output>()?.span)
        };
        let name: Ident = input.parse()?;
        let mut dims = Vec::new();
        while input.peek(syn::token::Bracket) {
            let content;
            bracketed!(content in input);
            let d: Expr = content.parse()?;
            if !content.is_empty() {
                return Err(content.error(
                    "a dimension is one number: `x[3]` for a vector, `P[3][3]` for a matrix",
                ));
            }
            dims.push(d);
        }
        let range = if input.peek(Token![:]) {
            input.parse::<Token![:]>()?;
            Some(parse_range_decl(input)?)
        } else {
            None
        };
        let unit = parse_unit(input)?;
        let init = if input.peek(Token![=]) {
            input.parse::<Token![=]>()?;
            Some(parse_value(input)?)
        } else {
            None
        };
        input.parse::<Token![;]>()?;
        Ok(Item::Signal(Box::new(SignalDecl {
            attrs,
            kind,
            kw_span,
            name,
            dims,
            range,
            unit,
            init,
            elem: None,
        })))
    } else if la.peek(kw::param) || la.peek(Token![const]) {
        let is_param = if input.peek(kw::param) {
            input.parse::<kw::param>()?;
            true
        } else {
            input.parse::<Token![const]>()?;
            false
        };
        let name: Ident = input.parse()?;
        input.parse::<Token![:]>()?;
        let value = parse_value(input)?;
        let unit = parse_unit(input)?;
        input.parse::<Token![;]>()?;
        Ok(Item::Constant(ConstDecl {
            attrs,
            is_param,
            name,
            value,
            unit,
        }))
    } else if la.peek(kw::table) {
        input.parse::<kw::table>()?;
        Ok(Item::Table(Box::new(parse_table(input, attrs)?)))
    } else if la.peek(kw::step) {
        input.parse::<kw::step>()?;
        Ok(Item::Step(input.parse()?))
    } else if la.peek(kw::tune) {
        if let Some(a) = attrs.first() {
            return Err(syn::Error::new_spanned(
                a,
                "a `tune` item takes no attributes",
            ));
        }
        let span = input.parse::<kw::tune>()?.span;
        Ok(Item::Tune(Box::new(parse_tune(input, span)?)))
    } else if la.peek(kw::rule) {
        Ok(Item::Rule(Box::new(parse_rule(input, &attrs, false)?)))
    } else if la.peek(kw::apply) {
        if let Some(a) = attrs.iter().find(|a| !a.path().is_ident("doc")) {
            return Err(syn::Error::new_spanned(
                a,
                "only doc comments may stand on an `apply` item",
            ));
        }
        let mut a = parse_apply(input)?;
        a.docs = doc_lines(&attrs);
        Ok(Item::Apply(Box::new(a)))
    } else if la.peek(Token![use]) {
        if let Some(a) = attrs.iter().find(|a| !a.path().is_ident("doc")) {
            return Err(syn::Error::new_spanned(
                a,
                "only doc comments may stand on a `use` item",
            ));
        }
        input.parse::<Token![use]>()?;
        if input.peek(LitStr) {
            let lit: LitStr = input.parse()?;
            return Err(syn::Error::new(
                lit.span(),
                "rules files by path are not supported: `use` takes one of qloop's rule \
                 libraries (`use feed_safety;`); define your own rules in the spec with \
                 `rule NAME(..) on (..) { .. }`",
            ));
        }
        let name: Ident = input.parse()?;
        input.parse::<Token![;]>()?;
        Ok(Item::Use { name })
    } else if la.peek(kw::prove) {
        let span = input.parse::<kw::prove>()?.span;
        let content;
        braced!(content in input);
        let mut items = Vec::new();
        while !content.is_empty() {
            items.push(parse_prop_item(&content)?);
        }
        Ok(Item::Prove { items, span })
    } else {
        let e = la.error();
        Err(syn::Error::new(e.span(), format!("{e}; {ITEM_HELP}")))
    }
}

fn parse_tune(input: ParseStream, span: proc_macro2::Span) -> syn::Result<TuneDecl> {
    let name: Ident = input.parse()?;
    input
        .parse::<Token![in]>()
        .map_err(|e| syn::Error::new(e.span(), TUNE_HELP))?;
    let set = if input.peek(syn::token::Brace) {
        let content;
        braced!(content in input);
        let list = content.parse_terminated(Expr::parse, Token![,])?;
        if list.is_empty() {
            return Err(syn::Error::new(
                content.span(),
                "no candidates: list at least one value",
            ));
        }
        TuneSet::List(list.into_iter().collect())
    } else if input.peek(syn::token::Bracket) {
        let range = match parse_range_decl(input)? {
            RangeDecl::One(r) => r,
            RangeDecl::PerElement(a) => return Err(syn::Error::new_spanned(a, TUNE_HELP)),
        };
        input
            .parse::<Token![,]>()
            .map_err(|e| syn::Error::new(e.span(), TUNE_HELP))?;
        if input.peek(kw::pow2) {
            input.parse::<kw::pow2>()?;
            TuneSet::Pow2(range)
        } else if input.peek(kw::step) {
            input.parse::<kw::step>()?;
            TuneSet::Step(range, Box::new(parse_value(input)?))
        } else {
            return Err(input.error(TUNE_HELP));
        }
    } else {
        return Err(input.error(TUNE_HELP));
    };
    input.parse::<Token![;]>()?;
    Ok(TuneDecl { name, set, span })
}

/// `rule NAME(PARAMS) on (PORTS) { BODY }` after its attributes; `library` for a rule read
/// from one of qloop's libraries.
pub(crate) fn parse_rule(
    input: ParseStream,
    attrs: &[Attribute],
    library: bool,
) -> syn::Result<RuleDef> {
    if let Some(a) = attrs.iter().find(|a| !a.path().is_ident("doc")) {
        return Err(syn::Error::new_spanned(
            a,
            "only doc comments may stand on a rule",
        ));
    }
    input.parse::<kw::rule>()?;
    let name: Ident = input.parse()?;
    let content;
    syn::parenthesized!(content in input);
    let mut params = Vec::new();
    while !content.is_empty() {
        let pname: Ident = content.parse()?;
        let default = if content.peek(Token![:]) {
            content.parse::<Token![:]>()?;
            Some(parse_arg(&content)?)
        } else {
            None
        };
        let unit = parse_unit(&content)?;
        params.push(RuleParam {
            name: pname,
            default,
            unit,
        });
        if !content.is_empty() {
            content
                .parse::<Token![,]>()
                .map_err(|e| syn::Error::new(e.span(), RULE_HELP))?;
        }
    }
    input
        .parse::<kw::on>()
        .map_err(|e| syn::Error::new(e.span(), RULE_HELP))?;
    let content;
    syn::parenthesized!(content in input);
    let ports = content
        .parse_terminated(Ident::parse, Token![,])?
        .into_iter()
        .collect();
    let body;
    braced!(body in input);
    Ok(RuleDef {
        docs: doc_lines(attrs),
        name,
        params,
        ports,
        body: body.parse()?,
        library,
    })
}

/// `apply NAME(ARGS) on (BINDINGS) [as ALIAS];`
fn parse_apply(input: ParseStream) -> syn::Result<ApplyDecl> {
    let span = input.parse::<kw::apply>()?.span;
    let rule: Ident = input.parse()?;
    let mut args = Vec::new();
    if input.peek(syn::token::Paren) {
        let content;
        syn::parenthesized!(content in input);
        while !content.is_empty() {
            let name: Ident = content.parse()?;
            content
                .parse::<Token![=]>()
                .map_err(|e| syn::Error::new(e.span(), APPLY_HELP))?;
            args.push((name, parse_arg(&content)?));
            if content.peek(LitStr) {
                return Err(content.error(
                    "an argument takes no unit: the rule's parameter declares it (a value in \
                     another unit: `convert(..)` is not available here, write it in that unit)",
                ));
            }
            if !content.is_empty() {
                content
                    .parse::<Token![,]>()
                    .map_err(|e| syn::Error::new(e.span(), APPLY_HELP))?;
            }
        }
    }
    input
        .parse::<kw::on>()
        .map_err(|e| syn::Error::new(e.span(), APPLY_HELP))?;
    let content;
    syn::parenthesized!(content in input);
    let mut ports = Vec::new();
    while !content.is_empty() {
        let port: Ident = content.parse()?;
        content
            .parse::<Token![=]>()
            .map_err(|e| syn::Error::new(e.span(), APPLY_HELP))?;
        ports.push((port, content.parse()?));
        if !content.is_empty() {
            content.parse::<Token![,]>()?;
        }
    }
    let alias = if input.peek(Token![as]) {
        input.parse::<Token![as]>()?;
        Some(input.parse()?)
    } else {
        None
    };
    input
        .parse::<Token![;]>()
        .map_err(|e| syn::Error::new(e.span(), APPLY_HELP))?;
    Ok(ApplyDecl {
        docs: Vec::new(),
        rule,
        args,
        ports,
        alias,
        span,
    })
}

/// A constant expression inside an argument list: stops before `,` or a unit string.
fn parse_arg(input: ParseStream) -> syn::Result<Expr> {
    let mut tokens = TokenStream::new();
    while !input.is_empty() && !input.peek(Token![,]) && !input.peek(LitStr) {
        let tt: proc_macro2::TokenTree = input.parse()?;
        tokens.extend(std::iter::once(tt));
    }
    if tokens.is_empty() {
        return Err(input.error("expected a value"));
    }
    syn::parse2(tokens)
}

/// The items of a rule's body (after renaming): the controller items it may hold, plus
/// `pre { .. }` (statements placed before the host's step).
pub(crate) fn parse_rule_body(tokens: TokenStream) -> Result<Vec<RuleItem>> {
    let parser = |input: ParseStream| -> syn::Result<Vec<RuleItem>> {
        let mut items = Vec::new();
        while !input.is_empty() {
            if input.peek(kw::pre) && input.peek2(syn::token::Brace) {
                input.parse::<kw::pre>()?;
                items.push(RuleItem::Pre(input.parse()?));
            } else {
                items.push(RuleItem::Item(Box::new(parse_item(input)?)));
            }
        }
        Ok(items)
    };
    syn::parse::Parser::parse2(parser, tokens).map_err(Diag::from)
}

/// The rules of a library file: `rule` items only.
pub(crate) fn parse_rule_file(src: &str) -> Result<Vec<RuleDef>> {
    let tokens: TokenStream = src
        .parse()
        .map_err(|e: proc_macro2::LexError| Diag::new(e.span(), format!("cannot lex: {e}")))?;
    let parser = |input: ParseStream| -> syn::Result<Vec<RuleDef>> {
        let mut rules = Vec::new();
        while !input.is_empty() {
            let attrs = input.call(Attribute::parse_inner)?;
            if !attrs.is_empty() {
                continue;
            }
            let attrs = input.call(Attribute::parse_outer)?;
            rules.push(parse_rule(input, &attrs, true)?);
        }
        Ok(rules)
    };
    syn::parse::Parser::parse2(parser, tokens).map_err(Diag::from)
}

/// One item of a rule's body.
pub(crate) enum RuleItem {
    /// A controller item.
    Item(Box<Item>),
    /// `pre { .. }`.
    Pre(syn::Block),
}

const PROVE_HELP: &str = "a `prove` block holds `invariant NAME: COND;` and \
`property NAME { forall P in [LO, HI]; assume COND; ensure COND; }` items, and `for l in A..B { .. }` \
loops over them";

fn parse_prop_item(input: ParseStream) -> syn::Result<PropItem> {
    let attrs = input.call(Attribute::parse_outer)?;
    let docs = doc_lines(&attrs);
    if let Some(a) = attrs.iter().find(|a| !a.path().is_ident("doc")) {
        return Err(syn::Error::new_spanned(
            a,
            "only doc comments may stand on properties",
        ));
    }
    let la = input.lookahead1();
    if la.peek(Token![for]) {
        if !attrs.is_empty() {
            return Err(syn::Error::new_spanned(
                &attrs[0],
                "doc comments stand on the items inside the loop",
            ));
        }
        input.parse::<Token![for]>()?;
        let var: Ident = input.parse()?;
        input.parse::<Token![in]>()?;
        let range = match Expr::parse_without_eager_brace(input)? {
            Expr::Range(r) => r,
            other => {
                return Err(syn::Error::new_spanned(
                    other,
                    "expected a range: `for l in 0..N { .. }`",
                ))
            }
        };
        let body;
        braced!(body in input);
        let mut items = Vec::new();
        while !body.is_empty() {
            items.push(parse_prop_item(&body)?);
        }
        Ok(PropItem::For(Box::new(PropFor { var, range, items })))
    } else if la.peek(kw::invariant) {
        input.parse::<kw::invariant>()?;
        let name: Ident = input.parse()?;
        input.parse::<Token![:]>()?;
        let cond: Expr = input.parse()?;
        input.parse::<Token![;]>()?;
        Ok(PropItem::Invariant { docs, name, cond })
    } else if la.peek(kw::property) {
        input.parse::<kw::property>()?;
        let name: Ident = input.parse()?;
        let body;
        braced!(body in input);
        let (mut foralls, mut assumes, mut ensures) = (Vec::new(), Vec::new(), Vec::new());
        while !body.is_empty() {
            let la = body.lookahead1();
            if la.peek(kw::forall) {
                body.parse::<kw::forall>()?;
                let p: Ident = body.parse()?;
                body.parse::<Token![in]>()?;
                let range = parse_range(&body)?;
                foralls.push((p, range, parse_unit(&body)?));
            } else if la.peek(kw::assume) {
                body.parse::<kw::assume>()?;
                assumes.push(body.parse()?);
            } else if la.peek(kw::ensure) {
                body.parse::<kw::ensure>()?;
                ensures.push(body.parse()?);
            } else {
                let e = la.error();
                return Err(syn::Error::new(
                    e.span(),
                    format!("{e}; a property holds `forall P in [LO, HI];`, `assume COND;` and `ensure COND;`"),
                ));
            }
            body.parse::<Token![;]>()?;
        }
        if ensures.is_empty() {
            return Err(syn::Error::new(
                name.span(),
                "a property needs at least one `ensure COND;`",
            ));
        }
        Ok(PropItem::Property {
            docs,
            name,
            foralls,
            assumes,
            ensures,
        })
    } else {
        let e = la.error();
        Err(syn::Error::new(e.span(), format!("{e}; {PROVE_HELP}")))
    }
}

/// A constant expression: stops before a unit string, `=` or `;`.
fn parse_value(input: ParseStream) -> syn::Result<Expr> {
    // `Expr::parse_without_eager_brace` stops at `;`, `=` is not a binary operator here since
    // assignment expressions are only parsed at statement level by `syn` 2.
    let mut tokens = TokenStream::new();
    while !input.is_empty()
        && !input.peek(Token![;])
        && !input.peek(Token![=])
        && !input.peek(LitStr)
    {
        let tt: proc_macro2::TokenTree = input.parse()?;
        tokens.extend(std::iter::once(tt));
    }
    if tokens.is_empty() {
        return Err(input.error("expected a value"));
    }
    syn::parse2(tokens)
}

fn parse_unit(input: ParseStream) -> syn::Result<Option<LitStr>> {
    if input.peek(LitStr) {
        Ok(Some(input.parse()?))
    } else {
        Ok(None)
    }
}

fn parse_range(input: ParseStream) -> syn::Result<RangeAst> {
    let content;
    let bracket = bracketed!(content in input);
    let span = bracket.span.join();
    let lo: Expr = content.parse()?;
    content
        .parse::<Token![,]>()
        .map_err(|e| syn::Error::new(e.span(), "a range is written `[LO, HI]`"))?;
    let hi: Expr = content.parse()?;
    if !content.is_empty() {
        return Err(content.error("a range is written `[LO, HI]`"));
    }
    Ok(RangeAst { lo, hi, span })
}

/// The rest of `table NAME(x: [A, B] "unit") = EXPR, step H, error E;`.
fn parse_table(input: ParseStream, attrs: Vec<Attribute>) -> syn::Result<TableDecl> {
    let name: Ident = input.parse()?;
    let args;
    syn::parenthesized!(args in input);
    let var: Ident = args
        .parse()
        .map_err(|e| syn::Error::new(e.span(), TABLE_HELP))?;
    args.parse::<Token![:]>()
        .map_err(|e| syn::Error::new(e.span(), TABLE_HELP))?;
    let range = parse_range(&args)?;
    let unit = parse_unit(&args)?;
    if !args.is_empty() {
        return Err(args.error(TABLE_HELP));
    }
    input
        .parse::<Token![=]>()
        .map_err(|e| syn::Error::new(e.span(), TABLE_HELP))?;
    let value: Expr = input.parse()?;
    let (mut step, mut error) = (None, None);
    while input.peek(Token![,]) {
        input.parse::<Token![,]>()?;
        if input.peek(kw::step) {
            input.parse::<kw::step>()?;
            step = Some(input.parse::<Expr>()?);
        } else if input.peek(kw::error) {
            input.parse::<kw::error>()?;
            error = Some(input.parse::<Expr>()?);
        } else {
            return Err(input.error(TABLE_HELP));
        }
    }
    let step = step.ok_or_else(|| {
        syn::Error::new(
            name.span(),
            format!("table `{name}` needs a grid step: `, step H` with H a power of two"),
        )
    })?;
    input.parse::<Token![;]>()?;
    Ok(TableDecl {
        attrs,
        name,
        var,
        range,
        unit,
        value,
        step,
        error,
    })
}

/// A signal's declared range: `[LO, HI]`, or per-element ranges `[[LO, HI], [LO, HI], ..]`.
fn parse_range_decl(input: ParseStream) -> syn::Result<RangeDecl> {
    let content;
    let bracket = bracketed!(content in input);
    let span = bracket.span.join();
    let items = syn::punctuated::Punctuated::<Expr, Token![,]>::parse_terminated(&content)?;
    let arrays = items.iter().filter(|e| matches!(e, Expr::Array(_))).count();
    if arrays == 0 && items.len() == 2 && !items.trailing_punct() {
        let mut it = items.into_iter();
        if let (Some(lo), Some(hi)) = (it.next(), it.next()) {
            return Ok(RangeDecl::One(Box::new(RangeAst { lo, hi, span })));
        }
        return Err(syn::Error::new(span, "a range is written `[LO, HI]`"));
    }
    if arrays > 0 && arrays == items.len() {
        return Ok(RangeDecl::PerElement(syn::ExprArray {
            attrs: Vec::new(),
            bracket_token: bracket,
            elems: items,
        }));
    }
    Err(syn::Error::new(
        span,
        "a range is written `[LO, HI]`; a vector's or matrix's per-element ranges \
         `[[LO, HI], [LO, HI], ..]`",
    ))
}

/// The text of `///` doc attributes, one entry per line, leading space trimmed.
pub fn doc_lines(attrs: &[Attribute]) -> Vec<String> {
    attrs
        .iter()
        .filter(|a| a.path().is_ident("doc"))
        .filter_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(
                    s.value()
                        .strip_prefix(' ')
                        .map(str::to_owned)
                        .unwrap_or(s.value()),
                ),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

/// Parses a spec from tokens (the macro's input, or a file lexed by [`parse_str`]).
pub fn parse_tokens(tokens: TokenStream) -> Result<SpecAst> {
    super::scan::nesting(&tokens)?;
    syn::parse2(tokens).map_err(Diag::from)
}

/// Lexes and parses a `.qloop` file's text. Spans then carry line/column within `src`.
pub fn parse_str(src: &str) -> Result<SpecAst> {
    super::scan::brackets(src)?;
    let tokens: TokenStream = src.parse().map_err(|e: proc_macro2::LexError| {
        Diag::new(e.span(), format!("cannot lex the spec: {e}"))
            .help("a spec uses Rust tokens: check for unbalanced brackets or unterminated strings")
    })?;
    // An error at the end of the input (`expected `}``, an empty file) carries no site of
    // its own: point at the end of the text.
    parse_tokens(tokens).map_err(|d| {
        if d.line_col().0 == 0 {
            Diag {
                span: super::scan::span_at(src, src.trim_end().len()),
                ..d
            }
        } else {
            d
        }
    })
}
