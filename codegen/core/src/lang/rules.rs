//! Safety rules: reusable, proved spec fragments (issue 18, item 4), expanded before
//! everything else so that the rest of the compiler sees one flat spec.
//!
//! A rule is a fragment of a spec with parameters and ports:
//!
//! ```text
//! rule fmax(LIMIT "mm/s") on (cmd) {
//!     step { cmd = min(cmd, LIMIT); }
//!     prove { property within { ensure next(cmd) <= LIMIT; } }
//! }
//! apply fmax(LIMIT = 4.0) on (cmd = u);
//! ```
//!
//! `apply` makes one instance, named by the rule or by `as ALIAS`:
//! * each parameter becomes a `const` of the host, named `INSTANCE_PARAM` (upper case) and
//!   valued by the argument or the default, in the parameter's unit;
//! * every name the body declares (constants, states, outputs, tables, `let`s, properties,
//!   invariants, `forall` variables) is prefixed with the instance's name, `fmax_within`
//!   (upper case for upper-case names), so instances never collide;
//! * every port is replaced by the host signal bound to it;
//! * the body's `const`, `state`, `output` and `table` items join the host's; its `pre { .. }`
//!   statements go before the host's `step` body, its `step { .. }` statements after it, both
//!   in the order of the `apply` items; its `prove` items join the host's.
//!
//! A rule acts after the law: its `step` sees the law's results and may override them, and its
//! properties are proved on the composed step, so a later rule that breaks an earlier rule's
//! property is refuted, not hidden. `use feed_safety;` brings qloop's machining rules
//! ([`library`]). A library rule's tokens are given the span of the `apply` item, so that an
//! error inside one points at the line that applied it.

use super::ast::*;
use super::parse::{parse_rule_body, parse_rule_file, RuleItem};
use crate::diag::{Diag, Result};
use proc_macro2::{Group, Span, TokenStream, TokenTree};
use std::collections::{HashMap, HashSet};

/// qloop's rule libraries, by name, with their text.
pub const LIBRARIES: [(&str, &str); 1] =
    [("feed_safety", include_str!("../../rules/feed_safety.qloop"))];

/// The text of the rule library `name`, if qloop ships one.
pub fn library(name: &str) -> Option<&'static str> {
    LIBRARIES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The rules of the library `name`.
pub fn library_rules(name: &str) -> Option<Result<Vec<RuleDef>>> {
    library(name).map(parse_rule_file)
}

/// Expands every `apply` of `ast` and drops its `rule` and `use` items.
pub fn instantiate(ast: &SpecAst) -> Result<SpecAst> {
    let mut rules: HashMap<String, RuleDef> = HashMap::new();
    let add = |r: RuleDef, rules: &mut HashMap<String, RuleDef>| -> Result<()> {
        let key = r.name.to_string();
        if rules.contains_key(&key) {
            return Err(
                Diag::new(r.name.span(), format!("rule `{key}` is defined twice"))
                    .help("rename one of them"),
            );
        }
        check_def(&r)?;
        rules.insert(key, r);
        Ok(())
    };
    for item in &ast.items {
        match item {
            Item::Rule(r) => add((**r).clone(), &mut rules)?,
            Item::Use { name } => {
                let lib = library_rules(&name.to_string()).ok_or_else(|| {
                    Diag::new(name.span(), format!("unknown rules library `{name}`")).help(format!(
                        "qloop ships {}; `qloop rules` prints them",
                        LIBRARIES
                            .iter()
                            .map(|(n, _)| format!("`{n}`"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?;
                // The library's own text is qloop's: a parse error in it is a bug, shown at
                // the `use` that read it.
                let lib = lib.map_err(|d| {
                    Diag::new(
                        name.span(),
                        format!(
                            "qloop's rules library `{name}` does not parse: {}",
                            d.message
                        ),
                    )
                })?;
                for r in lib {
                    add(r, &mut rules)?;
                }
            }
            _ => {}
        }
    }
    // The host's signals' units, for the `"@port"` units of rules.
    let units: HashMap<String, String> = ast
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Signal(s) => Some((
                s.name.to_string(),
                s.unit.as_ref().map_or(String::new(), |u| u.value()),
            )),
            _ => None,
        })
        .collect();
    let mut items = Vec::with_capacity(ast.items.len());
    let (mut pre, mut post, mut props) = (Vec::new(), Vec::new(), Vec::new());
    let mut instances: HashMap<String, Span> = HashMap::new();
    let mut step_at = None;
    for item in &ast.items {
        match item {
            Item::Rule(_) | Item::Use { .. } => {}
            Item::Apply(a) => {
                let rule = rules.get(&a.rule.to_string()).ok_or_else(|| {
                    let mut known: Vec<_> = rules.keys().cloned().collect();
                    known.sort();
                    Diag::new(a.rule.span(), format!("unknown rule `{}`", a.rule)).help(
                        if known.is_empty() {
                            "define it with `rule NAME(..) on (..) { .. }`, or bring qloop's \
                             machining rules with `use feed_safety;`"
                                .to_string()
                        } else {
                            format!("the rules in scope are {}", known.join(", "))
                        },
                    )
                })?;
                let inst = a.alias.as_ref().unwrap_or(&a.rule);
                if let Some(prev) = instances.insert(inst.to_string(), inst.span()) {
                    let _ = prev;
                    return Err(Diag::new(
                        inst.span(),
                        format!("rule instance `{inst}` is applied twice"),
                    )
                    .help("name the second instance: `apply RULE(..) on (..) as OTHER_NAME;`"));
                }
                let x = instance(rule, a, &units)?;
                items.extend(x.items);
                pre.extend(x.pre);
                post.extend(x.post);
                props.extend(x.props);
            }
            Item::Step(_) => {
                step_at = Some(items.len());
                items.push(item.clone());
            }
            other => items.push(other.clone()),
        }
    }
    if let Some(i) = step_at {
        if let Item::Step(b) = &mut items[i] {
            if !pre.is_empty() || !post.is_empty() {
                let mut stmts = pre;
                stmts.extend(b.stmts.drain(..).map(terminated));
                stmts.extend(post);
                b.stmts = stmts;
            }
        }
    }
    if !props.is_empty() {
        items.push(Item::Prove {
            items: props,
            span: Span::call_site(),
        });
    }
    Ok(SpecAst {
        docs: ast.docs.clone(),
        name: ast.name.clone(),
        items,
    })
}

/// `e` as a statement with its `;`, so that statements can follow it.
fn terminated(s: syn::Stmt) -> syn::Stmt {
    match s {
        syn::Stmt::Expr(e, None) if !matches!(e, syn::Expr::If(_) | syn::Expr::Block(_)) => {
            let semi = syn::Token![;](proc_macro2::Span::call_site());
            syn::Stmt::Expr(e, Some(semi))
        }
        other => other,
    }
}

/// What one instance adds to the host.
struct Instance {
    items: Vec<Item>,
    pre: Vec<syn::Stmt>,
    post: Vec<syn::Stmt>,
    props: Vec<PropItem>,
}

/// Checks a rule definition on its own: parameters and ports are distinct, and the body
/// parses and holds only what a rule may hold.
fn check_def(r: &RuleDef) -> Result<()> {
    let mut seen = HashSet::new();
    for n in r.params.iter().map(|p| &p.name).chain(&r.ports) {
        if !seen.insert(n.to_string()) {
            return Err(Diag::new(
                n.span(),
                format!("`{n}` is declared twice in rule `{}`", r.name),
            )
            .help("parameters and ports need distinct names"));
        }
    }
    let items = parse_rule_body(r.body.clone())?;
    for it in &items {
        if let Some(span) = forbidden(it) {
            return Err(Diag::new(
                span,
                "a rule's body holds `const`, `param`, `state`, `output`, `table`, \
                 `pre { .. }`, `step { .. }` and `prove { .. }` items only",
            )
            .help(
                "inputs come in through the rule's ports; `period`, `word` and `rounding` \
                 are the host spec's",
            ));
        }
    }
    for n in declared(&r.body) {
        if r.ports.contains(&n) {
            return Err(Diag::new(
                n.span(),
                format!(
                    "`{n}` is a port of rule `{}` and cannot be declared in it",
                    r.name
                ),
            ));
        }
    }
    Ok(())
}

/// The span of an item a rule may not hold.
fn forbidden(it: &RuleItem) -> Option<Span> {
    match it {
        RuleItem::Pre(_) => None,
        RuleItem::Item(i) => match i.as_ref() {
            Item::Constant(_) | Item::Table(_) | Item::Step(_) | Item::Prove { .. } => None,
            Item::Signal(s) if s.kind != SignalKw::Input => None,
            Item::Signal(s) => Some(s.kw_span),
            Item::Period { span, .. } => Some(*span),
            Item::Rounding { mode } => Some(mode.span()),
            Item::Word { bits } => Some(bits.span()),
            Item::Tune(t) => Some(t.span),
            Item::Rule(r) => Some(r.name.span()),
            Item::Apply(a) => Some(a.span),
            Item::Use { name } => Some(name.span()),
        },
    }
}

/// The names a rule's body declares: the identifier after `const`, `param`, `state`,
/// `output`, `table`, `let`, `invariant`, `property` and `forall`.
fn declared(body: &TokenStream) -> Vec<proc_macro2::Ident> {
    const KEYWORDS: [&str; 9] = [
        "const",
        "param",
        "state",
        "output",
        "table",
        "let",
        "invariant",
        "property",
        "forall",
    ];
    let mut out: Vec<proc_macro2::Ident> = Vec::new();
    let mut after_kw = false;
    for tt in body.clone() {
        match tt {
            TokenTree::Ident(i) => {
                let s = i.to_string();
                // `let mut x`: the name follows `mut`.
                if after_kw && s == "mut" {
                    continue;
                }
                if after_kw && !out.contains(&i) {
                    out.push(i);
                }
                after_kw = KEYWORDS.contains(&s.as_str());
            }
            TokenTree::Group(g) => {
                after_kw = false;
                for n in declared(&g.stream()) {
                    if !out.contains(&n) {
                        out.push(n);
                    }
                }
            }
            _ => after_kw = false,
        }
    }
    out
}

/// The instance's name for a name `n` the rule declares: `inst_n`, upper case if `n` is.
fn prefixed(inst: &str, n: &str) -> String {
    let upper =
        n.chars().any(|c| c.is_ascii_uppercase()) && !n.chars().any(|c| c.is_ascii_lowercase());
    if upper {
        format!("{}_{n}", inst.to_ascii_uppercase())
    } else {
        format!("{inst}_{n}")
    }
}

/// How one instance rewrites its rule's tokens.
struct Rewrite<'a> {
    /// Name → replacement, with the replacement's span if it has its own (a port's binding).
    names: HashMap<String, (String, Option<Span>)>,
    /// Port → the unit of the host signal bound to it, for `"@port"` units.
    units: HashMap<String, String>,
    /// For a library rule, the span every token gets (the `apply` item's).
    all: Option<Span>,
    /// The rule, for errors.
    rule: &'a RuleDef,
}

impl Rewrite<'_> {
    /// The unit a rule writes as `text`: `"@port"` is the unit of the signal bound to `port`.
    fn unit(&self, text: &str, span: Span) -> Result<String> {
        match text.strip_prefix('@') {
            None => Ok(text.to_string()),
            Some(port) => self.units.get(port).cloned().ok_or_else(|| {
                Diag::new(
                    self.all.unwrap_or(span),
                    format!(
                        "unit `\"{text}\"` in rule `{}` names `{port}`, which is not a port bound to a signal",
                        self.rule.name
                    ),
                )
                .help("`\"@PORT\"` is the unit of the signal bound to PORT; bind PORT to an input, state or output")
            }),
        }
    }

    fn tokens(&self, ts: &TokenStream) -> Result<TokenStream> {
        let all = self.all;
        let mut out = TokenStream::new();
        for tt in ts.clone() {
            out.extend(std::iter::once(match tt {
                TokenTree::Group(g) => {
                    let mut ng = Group::new(g.delimiter(), self.tokens(&g.stream())?);
                    ng.set_span(all.unwrap_or(g.span()));
                    TokenTree::Group(ng)
                }
                TokenTree::Ident(i) => {
                    let span = all.unwrap_or(i.span());
                    match self.names.get(&i.to_string()) {
                        Some((n, s)) => {
                            TokenTree::Ident(proc_macro2::Ident::new(n, s.unwrap_or(span)))
                        }
                        None => {
                            let mut i = i;
                            i.set_span(span);
                            TokenTree::Ident(i)
                        }
                    }
                }
                TokenTree::Literal(l) => {
                    let text = l.to_string();
                    let mut l = match text.strip_prefix("\"@").and_then(|t| t.strip_suffix('"')) {
                        Some(port) => {
                            let u = self.unit(&format!("@{port}"), l.span())?;
                            proc_macro2::Literal::string(&u)
                        }
                        None => l,
                    };
                    l.set_span(all.unwrap_or(l.span()));
                    TokenTree::Literal(l)
                }
                mut other => {
                    if let Some(s) = all {
                        other.set_span(s);
                    }
                    other
                }
            }));
        }
        Ok(out)
    }
}

/// One `apply` of `rule`.
fn instance(rule: &RuleDef, a: &ApplyDecl, units: &HashMap<String, String>) -> Result<Instance> {
    let inst = a.alias.as_ref().unwrap_or(&a.rule).to_string();
    let all = rule.library.then_some(a.span);
    // Arguments: each names a parameter, once.
    let mut args: HashMap<String, &syn::Expr> = HashMap::new();
    for (n, v) in &a.args {
        if !rule.params.iter().any(|p| p.name == *n) {
            return Err(Diag::new(
                n.span(),
                format!("rule `{}` has no parameter `{n}`", rule.name),
            )
            .help(param_list(rule)));
        }
        if args.insert(n.to_string(), v).is_some() {
            return Err(Diag::new(
                n.span(),
                format!("parameter `{n}` is given twice"),
            ));
        }
    }
    // Ports: each bound, once, to a host name.
    let mut ports: HashMap<String, &proc_macro2::Ident> = HashMap::new();
    for (p, s) in &a.ports {
        if !rule.ports.iter().any(|q| q == p) {
            return Err(
                Diag::new(p.span(), format!("rule `{}` has no port `{p}`", rule.name))
                    .help(port_list(rule)),
            );
        }
        if !units.contains_key(&s.to_string()) {
            return Err(
                Diag::new(s.span(), format!("`{s}` is not a signal of this spec")).help(format!(
                "bind port `{p}` of rule `{}` to an input, state or output declared in the spec",
                rule.name
            )),
            );
        }
        if ports.insert(p.to_string(), s).is_some() {
            return Err(Diag::new(p.span(), format!("port `{p}` is bound twice")));
        }
    }
    if let Some(p) = rule
        .ports
        .iter()
        .find(|p| !ports.contains_key(&p.to_string()))
    {
        return Err(Diag::new(
            a.span,
            format!("port `{p}` of rule `{}` is not bound", rule.name),
        )
        .help(format!(
            "bind it to a signal of the spec: `on (.., {p} = SIGNAL)`; {}",
            port_list(rule)
        )));
    }
    let mut rw = Rewrite {
        names: HashMap::new(),
        units: HashMap::new(),
        all,
        rule,
    };
    for (p, s) in &ports {
        rw.names.insert(p.clone(), (s.to_string(), Some(s.span())));
        if let Some(u) = units.get(&s.to_string()) {
            rw.units.insert(p.clone(), u.clone());
        }
    }
    for n in rule
        .params
        .iter()
        .map(|p| &p.name)
        .cloned()
        .chain(declared(&rule.body))
    {
        rw.names
            .insert(n.to_string(), (prefixed(&inst, &n.to_string()), None));
    }
    let mut items = Vec::new();
    for p in &rule.params {
        let value = match (args.get(&p.name.to_string()), &p.default) {
            (Some(v), _) => (*v).clone(),
            (None, Some(d)) => {
                let toks = rw.tokens(&quote::ToTokens::to_token_stream(d))?;
                syn::parse2(toks).map_err(Diag::from)?
            }
            (None, None) => {
                return Err(Diag::new(
                    a.span,
                    format!(
                        "parameter `{}` of rule `{}` has no value",
                        p.name, rule.name
                    ),
                )
                .help(format!(
                    "give it one: `apply {}({} = VALUE, ..) on (..);`",
                    rule.name, p.name
                )))
            }
        };
        let span = all.unwrap_or(p.name.span());
        let mut docs = vec![format!(
            " Parameter `{}` of rule `{}` (instance `{inst}`).",
            p.name, rule.name
        )];
        docs.extend(a.docs.iter().map(|d| format!(" {d}")));
        items.push(Item::Constant(ConstDecl {
            attrs: docs
                .iter()
                .map(|d| syn::parse_quote!(#[doc = #d]))
                .collect(),
            is_param: false,
            name: proc_macro2::Ident::new(&prefixed(&inst, &p.name.to_string()), span),
            value,
            unit: match &p.unit {
                Some(u) => Some(syn::LitStr::new(
                    &rw.unit(&u.value(), u.span())?,
                    all.unwrap_or(u.span()),
                )),
                None => None,
            },
        }));
    }
    let body = parse_rule_body(rw.tokens(&rule.body)?)?;
    let (mut pre, mut post, mut props) = (Vec::new(), Vec::new(), Vec::new());
    for it in body {
        match it {
            RuleItem::Pre(b) => pre.extend(b.stmts.into_iter().map(terminated)),
            RuleItem::Item(i) => match *i {
                Item::Step(b) => post.extend(b.stmts.into_iter().map(terminated)),
                Item::Prove { items: p, .. } => props.extend(p),
                i => items.push(i),
            },
        }
    }
    Ok(Instance {
        items,
        pre,
        post,
        props,
    })
}

fn param_list(rule: &RuleDef) -> String {
    if rule.params.is_empty() {
        return format!("rule `{}` takes no parameters", rule.name);
    }
    format!(
        "its parameters are {}",
        rule.params
            .iter()
            .map(|p| format!("`{}`", p.name))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

fn port_list(rule: &RuleDef) -> String {
    format!(
        "its ports are {}",
        rule.ports
            .iter()
            .map(|p| format!("`{p}`"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}
