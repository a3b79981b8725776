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

/// The names of qloop's rule libraries, for messages: `` `feed_safety` ``.
pub fn library_names() -> String {
    LIBRARIES
        .iter()
        .map(|(n, _)| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The text of the rule library `name`, if qloop ships one.
pub fn library(name: &str) -> Option<&'static str> {
    LIBRARIES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The rules of the library `name`.
pub fn library_rules(name: &str) -> Option<Result<Vec<RuleDef>>> {
    library(name).map(parse_rule_file)
}

/// A spec with its rules applied.
pub struct Instantiated {
    /// The spec without `rule`, `apply` and `use` items.
    pub ast: SpecAst,
    /// The constants made from a rule parameter's default (not from an `apply` argument):
    /// their value's text is the rule's, so `qloop tune` may not rewrite it.
    pub defaults: HashSet<String>,
    /// The parameters in the unit of a port the rule writes that its code reads, which
    /// `check` quantises to that signal's resolution.
    pub port_params: Vec<PortParam>,
}

/// A rule parameter or rule constant written in the unit of a port the rule writes, and read
/// by the rule's code (`UP "@cmd"` of `backoff`, which assigns `cmd = min(cmd, before + UP)`):
/// the code adds, subtracts or stores it into that signal, and the properties compare the
/// signal with it. `check` moves it onto a multiple of the signal's LSB, so that the code uses
/// it exactly and the properties speak of the value the code uses (`0.05` on a signal with LSB
/// 2^-12 would otherwise be added and rounded to nearest, and `next(cmd) <= cmd + UP` refuted
/// by a fraction of an LSB). It moves so that the signal comes out no higher than the spec
/// wrote: down where the code adds or stores it, up where the code only subtracts it
/// (`backoff`'s `DOWN = K · UP` in `before - DOWN`: more back-off, never less). A parameter
/// only the properties read, such as `backoff`'s `FLOOR`, stays as written: nothing rounds it.
#[derive(Clone, Debug)]
pub struct PortParam {
    /// The constant's name (`BACKOFF_UP`).
    pub constant: String,
    /// The spec's signal bound to the port.
    pub signal: String,
    /// Up to the multiple at or above the value (every read of it in the code is the
    /// subtrahend of a `-`), else down to the one at or below it.
    pub up: bool,
}

/// Expands every `apply` of `ast` and drops its `rule` and `use` items.
pub fn instantiate(ast: &SpecAst) -> Result<Instantiated> {
    let mut rules: HashMap<String, RuleDef> = HashMap::new();
    // A rule defined twice: at the second definition in the spec, or at the `use` that
    // brought the second (a library rule's own spans are not the spec's).
    let add = |r: RuleDef,
               at: Option<&proc_macro2::Ident>,
               rules: &mut HashMap<String, RuleDef>|
     -> Result<()> {
        let key = r.name.to_string();
        if rules.contains_key(&key) {
            return Err(match at {
                None => Diag::new(r.name.span(), format!("rule `{key}` is defined twice"))
                    .help("rename one of them"),
                Some(lib) => Diag::new(
                    lib.span(),
                    format!("library `{lib}` brings rule `{key}`, which is already defined"),
                )
                .help("rename the spec's own rule, or write the `use` once"),
            });
        }
        check_def(&r)?;
        rules.insert(key, r);
        Ok(())
    };
    let mut used: HashSet<String> = HashSet::new();
    for item in &ast.items {
        match item {
            Item::Rule(r) => add((**r).clone(), None, &mut rules)?,
            Item::Use { name } => {
                if !used.insert(name.to_string()) {
                    return Err(
                        Diag::new(name.span(), format!("library `{name}` is used twice"))
                            .help("write the `use` once"),
                    );
                }
                let lib = library_rules(&name.to_string()).ok_or_else(|| {
                    Diag::new(name.span(), format!("unknown rules library `{name}`")).help(format!(
                        "qloop ships {}; `qloop rules` prints them",
                        library_names()
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
                    add(r, Some(name), &mut rules)?;
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
    let mut defaults = HashSet::new();
    let mut port_params = Vec::new();
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
                defaults.extend(x.defaults);
                port_params.extend(x.port_params);
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
                stale_outputs(ast, &b.stmts, &post)?;
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
    Ok(Instantiated {
        ast: SpecAst {
            docs: ast.docs.clone(),
            name: ast.name.clone(),
            items,
        },
        defaults,
        port_params,
    })
}

/// Refuses an output the host's step computes from a signal a rule writes afterwards: the
/// output would carry the value from before the rule (a feed above FMAX, say), while the
/// rule's property, proved on the signal, holds.
fn stale_outputs(ast: &SpecAst, host: &[syn::Stmt], post: &[syn::Stmt]) -> Result<()> {
    let outputs: HashSet<String> = ast
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Signal(s) if s.kind == SignalKw::Output => Some(s.name.to_string()),
            _ => None,
        })
        .collect();
    let mut written = HashSet::new();
    for st in post {
        writes(st, &mut written);
    }
    let mut tainted: HashMap<String, String> =
        written.iter().map(|w| (w.clone(), w.clone())).collect();
    for st in host {
        stale_stmt(st, &outputs, &mut tainted, None)?;
    }
    Ok(())
}

/// The names assigned (`=`, `+=`, `-=`) anywhere in `st`.
fn writes(st: &syn::Stmt, out: &mut HashSet<String>) {
    struct W<'a>(&'a mut HashSet<String>);
    impl<'ast> syn::visit::Visit<'ast> for W<'_> {
        fn visit_expr_assign(&mut self, e: &'ast syn::ExprAssign) {
            self.0.extend(target_name(&e.left));
            syn::visit::visit_expr_assign(self, e);
        }
        fn visit_expr_binary(&mut self, e: &'ast syn::ExprBinary) {
            if matches!(e.op, syn::BinOp::AddAssign(_) | syn::BinOp::SubAssign(_)) {
                self.0.extend(target_name(&e.left));
            }
            syn::visit::visit_expr_binary(self, e);
        }
    }
    syn::visit::Visit::visit_stmt(&mut W(out), st);
}

/// Whether every read of the name `c` in `stmts` is the right operand of a binary `-`
/// (`before - c`), so that a larger `c` gives a lower result ([`PortParam::up`]).
fn only_subtracted<'a>(stmts: impl Iterator<Item = &'a syn::Stmt>, c: &str) -> bool {
    struct S<'a> {
        c: &'a str,
        reads: usize,
        subtracted: usize,
    }
    impl<'ast> syn::visit::Visit<'ast> for S<'_> {
        fn visit_expr_binary(&mut self, e: &'ast syn::ExprBinary) {
            if matches!(e.op, syn::BinOp::Sub(_))
                && target_name(&e.right).as_deref() == Some(self.c)
            {
                self.subtracted += 1;
            }
            syn::visit::visit_expr_binary(self, e);
        }
        fn visit_ident(&mut self, i: &'ast proc_macro2::Ident) {
            if i == self.c {
                self.reads += 1;
            }
        }
    }
    let mut v = S {
        c,
        reads: 0,
        subtracted: 0,
    };
    for st in stmts {
        syn::visit::Visit::visit_stmt(&mut v, st);
    }
    v.reads > 0 && v.reads == v.subtracted
}

/// The plain name an assignment writes (`x` in `x = ..`), if it is one.
fn target_name(e: &syn::Expr) -> Option<String> {
    match e {
        syn::Expr::Path(p) => p.path.get_ident().map(|i| i.to_string()),
        _ => None,
    }
}

/// The first name of `tainted` that `e` reads, with the rule-written signal behind it.
fn reads_tainted(e: &syn::Expr, tainted: &HashMap<String, String>) -> Option<String> {
    struct R<'a>(&'a HashMap<String, String>, Option<String>);
    impl<'ast> syn::visit::Visit<'ast> for R<'_> {
        fn visit_expr_path(&mut self, p: &'ast syn::ExprPath) {
            if let Some(i) = p.path.get_ident() {
                if let Some(src) = self.0.get(&i.to_string()) {
                    self.1.get_or_insert(src.clone());
                }
            }
        }
    }
    let mut r = R(tainted, None);
    syn::visit::Visit::visit_expr(&mut r, e);
    r.1
}

/// [`stale_outputs`] for one statement; `cond` is the tainted signal an enclosing `if`'s
/// condition reads, if any.
fn stale_stmt(
    st: &syn::Stmt,
    outputs: &HashSet<String>,
    tainted: &mut HashMap<String, String>,
    cond: Option<&String>,
) -> Result<()> {
    use syn::spanned::Spanned;
    match st {
        syn::Stmt::Local(l) => {
            if let (syn::Pat::Ident(pi), Some(init)) = (&l.pat, &l.init) {
                if let Some(src) = reads_tainted(&init.expr, tainted).or(cond.cloned()) {
                    tainted.insert(pi.ident.to_string(), src);
                }
            }
            Ok(())
        }
        syn::Stmt::Expr(e, _) => stale_expr(e, outputs, tainted, cond, e.span()),
        _ => Ok(()),
    }
}

fn stale_expr(
    e: &syn::Expr,
    outputs: &HashSet<String>,
    tainted: &mut HashMap<String, String>,
    cond: Option<&String>,
    span: Span,
) -> Result<()> {
    let (target, value) = match e {
        syn::Expr::Assign(a) => (&*a.left, &*a.right),
        syn::Expr::Binary(b)
            if matches!(b.op, syn::BinOp::AddAssign(_) | syn::BinOp::SubAssign(_)) =>
        {
            (&*b.left, &*b.right)
        }
        syn::Expr::If(i) => {
            let c = reads_tainted(&i.cond, tainted).or(cond.cloned());
            for st in &i.then_branch.stmts {
                stale_stmt(st, outputs, tainted, c.as_ref())?;
            }
            if let Some((_, els)) = &i.else_branch {
                stale_expr(els, outputs, tainted, c.as_ref(), span)?;
            }
            return Ok(());
        }
        syn::Expr::Block(b) => {
            for st in &b.block.stmts {
                stale_stmt(st, outputs, tainted, cond)?;
            }
            return Ok(());
        }
        _ => return Ok(()),
    };
    let Some(name) = target_name(target) else {
        return Ok(());
    };
    if !outputs.contains(&name) {
        return Ok(());
    }
    if let Some(src) = reads_tainted(value, tainted).or(cond.cloned()) {
        return Err(Diag::new(
            span,
            format!(
                "output `{name}` is computed from `{src}` before a rule changes `{src}`: it \
                 would carry the value from before the rule"
            ),
        )
        .help(format!(
            "let a rule write the output after the others (qloop's `feed_hold`, or your own \
             `rule out() on (x, y) {{ step {{ y = x; }} }}` applied last), or compute `{name}` \
             from signals no rule writes"
        )));
    }
    Ok(())
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
    defaults: Vec<String>,
    port_params: Vec<PortParam>,
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
    let declared = declared(&r.body);
    for n in r.params.iter().map(|p| &p.name).chain(&declared) {
        if LANGUAGE.contains(&n.to_string().as_str()) {
            return Err(Diag::new(
                n.span(),
                format!("`{n}` is a word of the spec language and cannot be declared in a rule"),
            )
            .help("choose another name"));
        }
    }
    let mut used = Vec::new();
    idents(&r.body, &mut used);
    for i in used {
        let s = i.to_string();
        let known = LANGUAGE.contains(&s.as_str())
            || r.ports.contains(&i)
            || r.params.iter().any(|p| p.name == i)
            || declared.contains(&i);
        if !known {
            return Err(Diag::new(
                i.span(),
                format!(
                    "rule `{}` uses `{s}`, which is not its parameter, its port or declared in it",
                    r.name
                ),
            )
            .help(format!(
                "a rule reads the spec only through its ports: add `{s}` to `on (..)` and bind \
                 it in each `apply`, or make it a parameter"
            )));
        }
    }
    for n in declared {
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
    const KEYWORDS: [&str; 10] = [
        "const",
        "param",
        "state",
        "output",
        "table",
        "let",
        "invariant",
        "property",
        "forall",
        "for",
    ];
    let mut out: Vec<proc_macro2::Ident> = Vec::new();
    let mut after_kw = false;
    // `table NAME(x: ..)`: the variable is the first identifier of the group after the name.
    let (mut table_name_next, mut table_group_next) = (false, false);
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
                table_group_next = table_name_next;
                table_name_next = s == "table";
                after_kw = KEYWORDS.contains(&s.as_str());
            }
            TokenTree::Group(g) => {
                after_kw = false;
                if table_group_next {
                    if let Some(TokenTree::Ident(v)) = g.stream().into_iter().next() {
                        if !out.contains(&v) {
                            out.push(v);
                        }
                    }
                }
                table_group_next = false;
                table_name_next = false;
                for n in declared(&g.stream()) {
                    if !out.contains(&n) {
                        out.push(n);
                    }
                }
            }
            _ => {
                after_kw = false;
                table_name_next = false;
                table_group_next = false;
            }
        }
    }
    out
}

/// The words a rule's body may use besides its parameters, ports and declared names: the
/// spec language's keywords, functions, attributes and integer types. A rule may not declare
/// these, and any other name is an error (a rule reads the host only through its ports).
const LANGUAGE: &[&str] = &[
    "const",
    "param",
    "state",
    "output",
    "table",
    "let",
    "mut",
    "if",
    "else",
    "for",
    "in",
    "pre",
    "step",
    "prove",
    "invariant",
    "property",
    "forall",
    "assume",
    "ensure",
    "next",
    "true",
    "false",
    "doc",
    "q",
    "lsb",
    "range",
    "unsaturated",
    "flag",
    "error",
    "min",
    "max",
    "clamp",
    "abs",
    "convert",
    "sum",
    "dot",
    "det",
    "newton_recip",
    "recip_track",
    "exp",
    "ln",
    "sqrt",
    "powf",
    "period",
    "i8",
    "i16",
    "i32",
    "i64",
    "u8",
    "u16",
    "u32",
    "u64",
];

/// Every identifier of `body` (recursively) with its span.
fn idents(body: &TokenStream, out: &mut Vec<proc_macro2::Ident>) {
    for tt in body.clone() {
        match tt {
            TokenTree::Ident(i) => out.push(i),
            TokenTree::Group(g) => idents(&g.stream(), out),
            _ => {}
        }
    }
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
                    let port = text
                        .strip_prefix("\"@")
                        .and_then(|t| t.strip_suffix('"'))
                        .filter(|p| self.rule.ports.iter().any(|q| q == p));
                    let mut l = match port {
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
        if let Some((q, _)) = ports.iter().find(|(_, t)| **t == s) {
            return Err(Diag::new(
                s.span(),
                format!(
                    "`{s}` is bound to two ports of rule `{}`: `{q}` and `{p}`",
                    rule.name
                ),
            )
            .help("each port needs a signal of its own"));
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
    let mut defaults = Vec::new();
    for p in &rule.params {
        let value = match (args.get(&p.name.to_string()), &p.default) {
            (Some(v), _) => (*v).clone(),
            (None, Some(d)) => {
                defaults.push(prefixed(&inst, &p.name.to_string()));
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
    // The parameters the rule's code (`pre`, `step`) reads, in the unit of a port it assigns.
    let mut written = HashSet::new();
    let mut read = Vec::new();
    for st in pre.iter().chain(&post) {
        writes(st, &mut written);
        idents(&quote::ToTokens::to_token_stream(st), &mut read);
    }
    let read: HashSet<String> = read.iter().map(|i| i.to_string()).collect();
    // The rule's parameters and its own constants, with the unit the rule wrote.
    let own_consts: Vec<(proc_macro2::Ident, Option<syn::LitStr>)> =
        parse_rule_body(rule.body.clone())?
            .into_iter()
            .filter_map(|it| match it {
                RuleItem::Item(i) => match *i {
                    Item::Constant(c) => Some((c.name, c.unit)),
                    _ => None,
                },
                RuleItem::Pre(_) => None,
            })
            .collect();
    let port_params = rule
        .params
        .iter()
        .map(|p| (&p.name, &p.unit))
        .chain(own_consts.iter().map(|(n, u)| (n, u)))
        .filter_map(|(name, unit)| {
            let port = unit.as_ref()?.value().strip_prefix('@')?.to_string();
            let signal = ports.get(&port)?.to_string();
            let constant = prefixed(&inst, &name.to_string());
            (written.contains(&signal) && read.contains(&constant)).then(|| PortParam {
                up: only_subtracted(pre.iter().chain(&post), &constant),
                constant,
                signal,
            })
        })
        .collect();
    Ok(Instance {
        items,
        defaults,
        port_params,
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

#[cfg(test)]
mod tests {
    use super::only_subtracted;

    fn stmts(src: &str) -> Vec<syn::Stmt> {
        syn::parse_str::<syn::Block>(src).unwrap().stmts
    }

    /// A port constant moves up only when every read of it is a subtrahend.
    #[test]
    fn a_constant_moves_up_only_where_the_code_only_subtracts_it() {
        for (code, up) in [
            ("{ cmd = min(cmd, before - D); }", true),
            ("{ cmd = before - D; if x > 0.0 { cmd = cmd - D; } }", true),
            ("{ cmd = min(cmd, before + D); }", false),
            ("{ cmd = D; }", false),
            // Read with both signs, or not as a plain subtrahend: down, as any limit.
            ("{ cmd = before + D; cmd = cmd - D; }", false),
            ("{ cmd = before - 2.0 * D; }", false),
            ("{ cmd = D - before; }", false),
            // Not read at all: nothing to move.
            ("{ cmd = before; }", false),
        ] {
            assert_eq!(only_subtracted(stmts(code).iter(), "D"), up, "{code}");
        }
    }
}
