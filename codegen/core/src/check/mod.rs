//! Checking: resolves names, folds constants, validates declarations and turns the `step`
//! body into the real-valued [`ir`](crate::ir). Every rejection names the place and says what
//! to write instead.

use crate::diag::{Diag, Result};
use crate::ir::*;
use crate::lang::ast::*;
use crate::lang::parse::doc_lines;
use crate::qformat::{IntTy, QFormat, Rounding, WIDTHS};

mod const_eval;
pub(crate) mod curvature;
mod enclose;
mod flags;
mod props;
mod table;
mod track;
mod tune;
mod units;
use proc_macro2::Span;
use std::collections::{BTreeSet, HashMap};
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, Lit, UnOp};
use units::{ParamUnits, Ty};

/// Help text for any `/` or `%` in a spec.
pub const DIVISION_HELP: &str = "qloop never emits division: a small controller has no divide \
instruction and a software divide is slow and has a panicking path. Koren & Masory (1981) replace \
K_c = K / K_m (Koren & Masory 1981, eq. 3) by an integrating loop that converges to the \
quotient without dividing: E_c(i+1) = K - K_c(i)*K_m(i); K_c(i+1) = K_c(i) + C2*E_c(i+1) \
(eqs. 12-13). Write the quotient as a state updated that way, or, for a constant divisor, \
multiply by its reciprocal (`x * 0.25`, not `x / 4.0`)";

/// Names the generated code uses itself.
const RESERVED: [&str; 6] = [
    "inputs",
    "Inputs",
    "Outputs",
    "States",
    "Controller",
    "Reference",
];

/// Checks a parsed spec and builds the IR.
pub fn check(ast: &SpecAst) -> Result<Program> {
    let x = crate::lang::expand::expand(ast)?;
    let mut generated: std::collections::HashSet<String> = Default::default();
    for r in &x.recips {
        generated.extend(r.lets.iter().cloned());
        generated.extend(r.consts.iter().cloned());
    }
    Checker {
        let_elems: x.let_elems,
        generated,
        recip_sites: x.recips,
        rule_defaults: x.rule_defaults,
        port_params: x.port_params,
        ..Checker::default()
    }
    .run(&x.ast)
}

#[derive(Default)]
struct Checker {
    consts: HashMap<String, (f64, Span)>,
    constants: Vec<Constant>,
    signals: Vec<Signal>,
    /// Name → signal, for inputs, states, outputs and the `let`s in scope.
    scope: Vec<HashMap<String, SigId>>,
    /// Outputs definitely assigned at the current point.
    assigned: BTreeSet<SigId>,
    /// The unit of each signal, indexed like `signals`.
    sig_units: Vec<Ty>,
    /// The unit of each `param` and `const`, and of `period`.
    const_units: HashMap<String, Ty>,
    /// Boolean `let`s in scope (`let over = fc > FR;`), one map per block: a name stands for
    /// its condition wherever a condition is expected.
    bools: Vec<HashMap<String, BoolLet>>,
    /// Names [`crate::lang::expand`] made, which may use the reserved prefix `qloop_`.
    generated: std::collections::HashSet<String>,
    /// The `newton_recip` sites.
    recip_sites: Vec<crate::lang::expand::RecipSite>,
    /// The default word width (known once the items before `step` are read).
    word: u32,
    /// The `recip_track`s of the step, for their properties.
    pending_tracks: Vec<track::PendingTrack>,
    /// The tables, in declaration order.
    tables: Vec<Table>,
    /// Each table's argument and result units.
    table_units: Vec<(Ty, Ty)>,
    /// The vector element each `let` made by [`crate::lang::expand`] stands for.
    let_elems: HashMap<String, Elem>,
    /// How many assignments each signal has had so far (for [`BoolLet`]).
    writes: HashMap<SigId, usize>,
    /// The span of each constant's value expression (for `tune`).
    const_value_spans: HashMap<String, Span>,
    /// Constants valued by a rule parameter's default: not tunable (their text is the rule's).
    rule_defaults: std::collections::HashSet<String>,
    /// Rule parameters to quantise to their port's resolution.
    port_params: Vec<crate::lang::rules::PortParam>,
    /// The value expression of each of them, for its exact value.
    port_exprs: HashMap<String, syn::Expr>,
    /// The `if`s around the statement being checked, outermost first (for a tracker's
    /// property, which holds where its branch runs).
    branches: Vec<track::Branch>,
}

impl Checker {
    fn run(mut self, ast: &SpecAst) -> Result<Program> {
        let name = ast.name.to_string();
        if name != name.to_lowercase() {
            return Err(
                Diag::new(ast.name.span(), "controller names are snake_case")
                    .help(format!("write `controller {} {{ .. }}`", to_snake(&name))),
            );
        }
        let mut period = None;
        let mut rounding = None;
        let mut word = None;
        let mut body = None;
        let mut prove_items: Vec<PropItem> = Vec::new();
        let mut tune_items = Vec::new();
        self.scope.push(HashMap::new());
        self.bools.push(HashMap::new());
        self.consts
            .insert("period".into(), (f64::NAN, Span::call_site()));
        self.const_units.insert(
            "period".into(),
            Ty::Of(crate::units::Unit::SECOND, "s".into()),
        );
        for item in &ast.items {
            match item {
                Item::Period { value, unit, span } => {
                    dup(&period, *span, "period")?;
                    let mut v = self.const_eval(value)?;
                    match unit.as_ref().map(|u| u.value()) {
                        None => {}
                        Some(u) if u == "s" => {}
                        Some(u) if u == "ms" => v *= 1e-3,
                        Some(u) => {
                            return Err(Diag::new(unit.span(), format!("unknown time unit `{u}`"))
                                .help("write the period in \"s\" or \"ms\""))
                        }
                    }
                    if !(v > 0.0 && v.is_finite()) {
                        return Err(Diag::new(value.span(), "the period must be positive"));
                    }
                    // The generated code exports the period as an integer, PERIOD_US.
                    let us = v * 1e6;
                    if us < 0.5 || (us - us.round()).abs() > 1e-6 * us {
                        return Err(Diag::new(
                            value.span(),
                            format!(
                                "the period {} s is not a whole number of microseconds",
                                crate::text::g(v)
                            ),
                        )
                        .label("not whole µs")
                        .help(format!(
                            "the generated code exports the period as the integer PERIOD_US, \
                             which would be {}; write a whole number of microseconds",
                            us.round()
                        )));
                    }
                    period = Some((v, *span));
                    self.consts.insert("period".into(), (v, *span));
                }
                Item::Rounding { mode } => {
                    dup(&rounding, mode.span(), "rounding")?;
                    let m = match mode.to_string().as_str() {
                        "floor" => Rounding::Floor,
                        "nearest" => Rounding::Nearest,
                        other => {
                            return Err(Diag::new(
                                mode.span(),
                                format!("unknown rounding `{other}`"),
                            )
                            .help("write `rounding floor;` (default) or `rounding nearest;`"))
                        }
                    };
                    rounding = Some((m, mode.span()));
                }
                Item::Word { bits } => {
                    dup(&word, bits.span(), "word")?;
                    no_suffix(bits.span(), bits.base10_digits(), bits.suffix())?;
                    let b: u32 = bits.base10_parse().unwrap_or(0);
                    if !WIDTHS.contains(&b) {
                        return Err(Diag::new(bits.span(), "word width must be 8, 16, 32 or 64"));
                    }
                    word = Some((b, bits.span()));
                }
                Item::Constant(c) => self.constant(c)?,
                Item::Table(t) => self.table(t)?,
                Item::Signal(s) => self.signal(s)?,
                Item::Step(block) => {
                    if body.is_some() {
                        return Err(Diag::new(block.span(), "a controller has one `step` body"));
                    }
                    body = Some(block);
                }
                Item::Prove { items, .. } => prove_items.extend(items.iter().cloned()),
                Item::Tune(t) => tune_items.push(t.as_ref()),
                // Expanded away by `lang::rules` before this pass.
                Item::Rule(_) | Item::Apply(_) | Item::Use { .. } => {}
            }
        }
        let (period, _) = period.ok_or_else(|| {
            Diag::new(ast.name.span(), "missing sample period")
                .help("add `period 0.1 \"s\";` inside the controller")
        })?;
        let block = body.ok_or_else(|| {
            Diag::new(ast.name.span(), "missing `step { .. }` body")
                .help("add the update law as `step { .. }`")
        })?;
        self.word = word.map_or(32, |w| w.0);
        self.refuse_budgets_on_ports()?;
        self.quantise_port_params();
        let body = self.block(&block.stmts)?;
        for (i, s) in self.signals.iter().enumerate() {
            if s.kind == SigKind::Output && !self.assigned.contains(&SigId(i)) {
                return Err(Diag::new(
                    s.span,
                    format!(
                        "output `{}` is not assigned on every path of `step`",
                        s.name
                    ),
                )
                .help("assign it after the `if`, or in both branches"));
            }
        }
        flags::check(&self.signals, &body)?;
        let (track_props, tracks) = self.track_properties()?;
        prove_items.extend(track_props);
        let (invariants, properties) = self.prove(&prove_items)?;
        let recips = self.recips()?;
        let tunes = self.tunes(&tune_items)?;
        Ok(Program {
            tunes,
            invariants,
            properties,
            recips,
            tracks,
            tables: self.tables,
            name,
            docs: ast.docs.clone(),
            period,
            rounding: rounding.map_or(Rounding::Floor, |r| r.0),
            word: word.map_or(32, |w| w.0),
            constants: self.constants,
            signals: self.signals,
            body,
        })
    }

    fn define(&mut self, name: &syn::Ident) -> Result<()> {
        let n = name.to_string();
        if let Some(e) = self
            .lookup(&n)
            .and_then(|id| self.signals[id.0].elem.as_ref())
        {
            return Err(Diag::new(
                name.span(),
                format!("`{n}` is the generated name of `{}`", e.label()),
            )
            .help("generated code names vector elements `NAME_INDEX`: choose another name"));
        }
        if self.consts.contains_key(&n) || self.lookup(&n).is_some() || self.bool_let(&n).is_some()
        {
            return Err(Diag::new(name.span(), format!("`{n}` is already defined"))
                .help("every constant, signal and `let` needs its own name"));
        }
        if [
            "min",
            "max",
            "clamp",
            "abs",
            "convert",
            "sum",
            "dot",
            "newton_recip",
            "recip_track",
        ]
        .contains(&n.as_str())
        {
            return Err(Diag::new(
                name.span(),
                format!("`{n}` is a built-in function"),
            ));
        }
        let made = self.generated.contains(&n);
        if !made
            && (n.starts_with('_') || n.starts_with("qloop_") || RESERVED.contains(&n.as_str()))
        {
            return Err(Diag::new(name.span(), format!("`{n}` is reserved for generated code"))
                .help("names may not start with `_` or `qloop_` or be one of: inputs, Inputs, Outputs, States, Controller, Reference"));
        }
        Ok(())
    }

    /// For a `let` of a `newton_recip`, its clamped `d` and which it is: `'r'` for an
    /// iterate `r_k` (in the reciprocal of `d`'s unit), `'t'` for `t_k = 2 − d·r_{k−1}`
    /// (dimensionless).
    fn recip_iterate_of(&self, n: &str) -> Option<(SigId, char)> {
        if !self.generated.contains(n) {
            return None;
        }
        let (site, kind, k) = split_step_name(n)?;
        k.parse::<u32>().ok()?;
        Some((self.lookup(&format!("{site}_d"))?, kind))
    }

    /// The format of `newton_recip`'s `let` `n`: the default word, best for its range (the
    /// clamp of an iterate; for `t_k = 2 − d·r_{k−1}`, what `d ∈ [LO, HI]` and the previous
    /// iterate's range give).
    fn iterate_format(&self, n: &str) -> Option<QFormat> {
        let (site, kind, k) = split_step_name(n)?;
        let k: u32 = k.parse().ok()?;
        let c = |name: String| self.consts.get(&name).map(|c| c.0);
        let (lo, hi) = if kind == 'r' && k == 0 {
            // A table seed in the default word too, whatever its samples' format (a
            // `#[q(i16, ..)]` table), so that the first step's products are of full words.
            let r = self
                .recip_sites
                .iter()
                .find(|r| r.lets[0] == format!("{site}_d"))?;
            self.table_hull(r.seed_table.as_ref()?, &r.lo, &r.hi)?
        } else if kind == 'r' {
            (c(format!("{site}_lo{k}"))?, c(format!("{site}_hi{k}"))?)
        } else {
            let r = self
                .recip_sites
                .iter()
                .find(|r| r.lets[0] == format!("{site}_d"))?;
            let (pl, ph) = if k == 1 {
                match &r.seed_table {
                    None => {
                        let s = c(format!("{site}_seed"))?;
                        (s, s)
                    }
                    // A table seed: the hull of its samples over the segments `d ∈ [LO, HI]`
                    // reaches, where its interpolant lies (and, stored, within half an LSB).
                    Some(t) => self.table_hull(t, &r.lo, &r.hi)?,
                }
            } else {
                (
                    c(format!("{site}_lo{}", k - 1))?,
                    c(format!("{site}_hi{}", k - 1))?,
                )
            };
            let (dl, dh) = (self.const_eval(&r.lo).ok()?, self.const_eval(&r.hi).ok()?);
            (2.0 - dh * ph, 2.0 - dl * pl)
        };
        QFormat::best_for(IntTy::signed(self.word), lo, hi)
    }

    /// The smallest and largest stored sample of table `name` (each rounded to nearest in the
    /// table's stored format, exactly as `lower::table` stores it) over the segments that
    /// `[lo, hi]` reaches: the interpolant, its rounding and its clamp stay inside them.
    fn table_hull(&self, name: &str, lo: &syn::Expr, hi: &syn::Expr) -> Option<(f64, f64)> {
        let t = self.tables.iter().find(|t| t.name == name)?;
        let (lo, hi) = (self.const_eval(lo).ok()?, self.const_eval(hi).ok()?);
        let first = ((lo - t.lo) / t.step).floor().max(0.0) as usize;
        let last = ((hi - t.lo) / t.step).ceil().max(0.0) as usize;
        let q = t.stored_format(self.word)?;
        let (a, b) = t.sample_hull(first, last);
        (a <= b).then(|| (q.value(q.raw_nearest(a)), q.value(q.raw_nearest(b))))
    }

    /// The `newton_recip` sites as IR, with their ranges evaluated and checked.
    fn recips(&self) -> Result<Vec<Recip>> {
        let mut out = Vec::new();
        for r in &self.recip_sites {
            let (lo, hi) = (self.const_eval(&r.lo)?, self.const_eval(&r.hi)?);
            if !(lo > 0.0 && lo < hi) {
                return Err(Diag::new(
                    r.span,
                    format!("`newton_recip` needs 0 < LO < HI; the range is [{lo}, {hi}]"),
                )
                .help("the reciprocal of a range containing 0 is unbounded; for a negative `d`, use `-newton_recip(-d, [..], K)`"));
            }
            let id = |n: &str| {
                self.signals
                    .iter()
                    .position(|s| s.name == n)
                    .map(SigId)
                    .ok_or_else(|| Diag::new(r.span, "internal: a `newton_recip` let is missing"))
            };
            let seed = r
                .consts
                .iter()
                .find(|c| c.ends_with("_seed"))
                .and_then(|c| self.consts.get(c))
                .map_or(f64::NAN, |c| c.0);
            let seed_table = match &r.seed_table {
                None => None,
                Some(t) => {
                    let ti = self.table_index(t).ok_or_else(|| {
                        Diag::new(r.span, format!("`{t}` is not a table"))
                            .help("the fourth argument of `newton_recip` names a table of 1/x")
                    })?;
                    let tab = &self.tables[ti];
                    if tab.lo > lo || tab.hi < hi {
                        return Err(Diag::new(
                            r.span,
                            format!(
                                "the seed table `{t}` covers [{}, {}], not the whole range [{lo}, {hi}]",
                                tab.lo, tab.hi
                            ),
                        ));
                    }
                    Some((ti, id(&r.lets[1])?))
                }
            };
            out.push(Recip {
                seed_table,
                seed,
                d: id(&r.lets[0])?,
                r: id(r.lets.last().map_or("", |s| s.as_str()))?,
                lo,
                hi,
                steps: r.steps,
                span: r.span,
            });
        }
        Ok(out)
    }

    fn lookup(&self, n: &str) -> Option<SigId> {
        self.scope.iter().rev().find_map(|s| s.get(n).copied())
    }

    fn constant(&mut self, c: &ConstDecl) -> Result<()> {
        self.define(&c.name)?;
        let mut v = self.const_eval(&c.value)?;
        let name = c.name.to_string();
        if self.generated.contains(&name) && name.ends_with("_seed") {
            // A `newton_recip` seed: 2/(LO + HI) to 6 significant bits, so that it is exact
            // in any format (the bound of `lower::newton` starts from its exact value) and
            // costs at most a few adders.
            v = crate::lower::newton::short_dyadic(v, 6);
        }
        let inferred = self.unit_of(&c.value, &ParamUnits::new())?;
        let unit = match &c.unit {
            Some(lit) => units::same(
                Ty::declared(Some(lit))?,
                inferred,
                c.value.span(),
                &format!("the value of `{name}`"),
            )?,
            // A constant `lang::expand` made of literals (a `newton_recip` seed or bound)
            // takes the unit of what it meets, like a literal.
            None if self.generated.contains(&name) => inferred,
            None => match inferred {
                Ty::Lit => Ty::declared(None)?,
                t => t,
            },
        };
        self.const_units.insert(name.clone(), unit);
        self.consts.insert(name.clone(), (v, c.name.span()));
        self.const_value_spans.insert(name.clone(), c.value.span());
        if self.port_params.iter().any(|p| p.constant == name) {
            self.port_exprs.insert(name.clone(), c.value.clone());
        }
        let (reference, nominal) = const_attrs(c)?;
        for (flag, mark, prev) in [
            (
                reference,
                "#[reference]",
                self.constants.iter().find(|k| k.reference),
            ),
            (
                nominal,
                "#[nominal]",
                self.constants.iter().find(|k| k.nominal),
            ),
        ] {
            if let (true, Some(p)) = (flag, prev) {
                return Err(Diag::new(
                    c.name.span(),
                    format!("`{}` is already the spec's `{mark}`", p.name),
                )
                .help(format!("mark one `param` with `{mark}`")));
            }
        }
        self.constants.push(Constant {
            name,
            is_param: c.is_param,
            value: v,
            unit: c.unit.as_ref().map(|u| u.value()),
            docs: doc_lines(&c.attrs),
            reference,
            nominal,
            quantised: None,
        });
        Ok(())
    }

    /// Moves each rule parameter in a written port's unit onto a multiple of the port signal's
    /// LSB, before the step and the properties read it, so that the rule's code uses it
    /// exactly and its properties are about the value the code uses
    /// ([`crate::lang::rules::PortParam`]; the report prints each one moved). Down (or up, for
    /// one the code only subtracts), because the library's parameters in the command's unit
    /// are limits on it (FMAX, the rise per period, the air-cut feed, the back-off per
    /// period): the command never exceeds what the spec wrote. A parameter whose signal has
    /// no format yet (a vector, a range that does not fit) is left as written: the format's
    /// own error comes later.
    /// A rule's port keeps the format it has without a budget: its parameters are moved onto
    /// that format's grid here, before any format search, and the rule's properties are about
    /// the moved values.
    fn refuse_budgets_on_ports(&self) -> Result<()> {
        for pp in &self.port_params {
            let Some(id) = self.lookup(&pp.signal) else {
                continue;
            };
            if let Some(b) = self.signals[id.0].budget {
                return Err(Diag::new(
                    b.span,
                    format!("`{}` is a rule's port: its format is fixed", pp.signal),
                )
                .label("not applied")
                .help(
                    "the rule's parameters in its unit are moved onto the port's grid before \
                     formats are searched; remove `#[error(..)]` here and budget the signals \
                     that feed it",
                ));
            }
        }
        Ok(())
    }

    fn quantise_port_params(&mut self) {
        // Each value's exact enclosure first, from the parameters as written (a rule constant
        // `K * UP` is moved from `K · UP`, not from `UP` moved), or its f64 value where it has
        // none; then the end on the side it moves to.
        let mut moves = Vec::new();
        for pp in std::mem::take(&mut self.port_params) {
            let Some(id) = self.lookup(&pp.signal) else {
                continue;
            };
            let Ok(q) = crate::lower::choose_format(&self.signals[id.0], self.word) else {
                continue;
            };
            let Some(&(v, span)) = self.consts.get(&pp.constant) else {
                continue;
            };
            let exact = self
                .port_exprs
                .get(&pp.constant)
                .and_then(|e| self.enclose(e, None))
                .unwrap_or_else(|| enclose::Enc::point(enclose::rat(v)));
            // The format's own rounding and value, of the f64 at or beyond the exact end on
            // that side: scaling by a power of two and rounding to an integer are exact in f64.
            let raw = if pp.up {
                q.raw_ceil(enclose::f64_up(&exact.hi))
            } else {
                q.raw_floor(enclose::f64_down(&exact.lo))
            };
            moves.push((pp, q, v, span, q.value(raw)));
        }
        for (pp, q, v, span, moved) in moves {
            if !moved.is_finite() {
                continue;
            }
            self.consts.insert(pp.constant.clone(), (moved, span));
            if let Some(c) = self.constants.iter_mut().find(|c| c.name == pp.constant) {
                c.value = moved;
                c.quantised = (moved != v).then(|| crate::ir::Quantised {
                    written: v,
                    signal: pp.signal.clone(),
                    frac: q.frac,
                    up: pp.up,
                });
            }
        }
    }

    fn signal(&mut self, s: &SignalDecl) -> Result<()> {
        self.define(&s.name)?;
        let name = s.name.to_string();
        let Attrs {
            pin,
            lsb,
            budget,
            claim,
            unsaturated,
            flag,
        } = fmt_attrs(&s.attrs, &|e| self.const_eval(e))?;
        if let Some(b) = budget {
            if s.kind == SignalKw::Input {
                return Err(
                    Diag::new(b.span, "an input has no error budget: it is read exactly").help(
                        "put `#[error(BOUND)]` on the states and outputs whose accuracy you need",
                    ),
                );
            }
            if pin.is_some() {
                return Err(Diag::new(
                    b.span,
                    "a pinned format leaves nothing to choose against an error budget",
                )
                .help(
                    "remove `#[q(..)]` to let qloop choose the format, or remove `#[error(..)]`",
                ));
            }
        }
        if let (Some(sp), false) = (flag, s.kind == SignalKw::Output) {
            return Err(Diag::new(sp, "`#[flag]` applies to outputs only")
                .help("a flag is a 0/1 output: a `bit` pin in the LinuxCNC component"));
        }
        if let Some((_, sp)) = claim {
            return Err(
                Diag::new(sp, "`#[range]` claims go on `let` bindings").help(
                    "declared ranges of inputs, states and outputs are written `name: [LO, HI]`",
                ),
            );
        }
        if unsaturated.is_some() && s.kind != SignalKw::State {
            return Err(Diag::new(
                unsaturated.unwrap_or(s.kw_span),
                "`#[unsaturated]` applies to states only",
            ));
        }
        let unit = Ty::declared(s.unit.as_ref())?;
        let range = match &s.range {
            Some(RangeDecl::PerElement(a)) => {
                // `lang::expand` splits these over the elements; a scalar never has them.
                return Err(Diag::new(a.span(), "per-element ranges need a vector"));
            }
            Some(RangeDecl::One(r)) => {
                let (lo, hi) = (self.const_eval(&r.lo)?, self.const_eval(&r.hi)?);
                for e in [&r.lo, &r.hi] {
                    let t = self.unit_of(e, &ParamUnits::new())?;
                    units::same(unit.clone(), t, e.span(), &format!("the range of `{name}`"))?;
                }
                if lo >= hi {
                    return Err(Diag::new(r.span, format!("empty range [{lo}, {hi}]"))
                        .help("write `[LO, HI]` with LO < HI"));
                }
                Some((lo, hi))
            }
            None => None,
        };
        let kind = match s.kind {
            SignalKw::Input => SigKind::Input,
            SignalKw::State => SigKind::State,
            SignalKw::Output => SigKind::Output,
        };
        if range.is_none() && kind != SigKind::Output {
            let what = if kind == SigKind::Input {
                "input"
            } else {
                "state"
            };
            return Err(
                Diag::new(s.name.span(), format!("{what} `{name}` has no range"))
                    .label("range needed")
                    .help(format!(
                "qloop chooses formats and proves the absence of overflow from declared ranges: \
                 write `{what} {name}: [LO, HI] \"unit\"{};`",
                if kind == SigKind::State { " = INIT" } else { "" }
            )),
            );
        }
        let init = match (&s.init, kind) {
            (Some(e), SigKind::State) => {
                let v = self.const_eval(e)?;
                let t = self.unit_of(e, &ParamUnits::new())?;
                units::same(
                    unit.clone(),
                    t,
                    e.span(),
                    &format!("the initial value of `{name}`"),
                )?;
                let (lo, hi) = range.unwrap_or((v, v));
                if v < lo || v > hi {
                    return Err(Diag::new(
                        e.span(),
                        format!("initial value {v} is outside the range [{lo}, {hi}]"),
                    ));
                }
                Some(v)
            }
            (None, SigKind::State) => {
                return Err(Diag::new(
                    s.name.span(),
                    format!("state `{name}` has no initial value"),
                )
                .help(format!("write `state {name}: [LO, HI] = INIT;`")))
            }
            (Some(e), _) => return Err(Diag::new(e.span(), "only states take an initial value")),
            (None, _) => None,
        };
        if let Some(p) = pin {
            if !p.fits_fixed_crate() {
                return Err(Diag::new(
                    s.name.span(),
                    format!(
                        "{p} cannot cross the API: fraction bits must be in 0..={}",
                        p.ty.bits
                    ),
                ));
            }
            // `step` clamps every input's raw bits to the declared range; qloop's arithmetic
            // is signed and at most 64 bits wide, which holds no u64 beyond 2^63.
            if kind == SigKind::Input && !p.ty.signed && p.ty.bits == 64 {
                return Err(Diag::new(
                    s.name.span(),
                    format!("input `{name}` cannot be a u64: its raw bits could not be clamped"),
                )
                .label("u64 input")
                .help("pin `i64` (the same range with one fraction bit fewer) or `u32`"));
            }
        }
        let id = SigId(self.signals.len());
        self.sig_units.push(unit);
        self.signals.push(Signal {
            name: name.clone(),
            kind,
            elem: s.elem.clone(),
            range,
            init,
            unit: s.unit.as_ref().map(|u| u.value()),
            pin,
            lsb,
            budget,
            claim: None,
            unsaturated: unsaturated.is_some(),
            flag: flag.is_some(),
            docs: doc_lines(&s.attrs),
            span: s.name.span(),
        });
        if let Some(top) = self.scope.last_mut() {
            top.insert(name, id);
        }
        Ok(())
    }

    // ---- statements ------------------------------------------------------------------

    fn block(&mut self, stmts: &[syn::Stmt]) -> Result<Vec<Stmt>> {
        self.scope.push(HashMap::new());
        self.bools.push(HashMap::new());
        let mut out = Vec::new();
        for s in stmts {
            self.stmt(s, &mut out)?;
        }
        self.scope.pop();
        self.bools.pop();
        Ok(out)
    }

    /// The condition a boolean `let` named `n` stands for, if one is in scope.
    fn bool_let(&self, n: &str) -> Option<&Cond> {
        self.bools
            .iter()
            .rev()
            .find_map(|s| s.get(n))
            .map(|b| &b.cond)
    }

    /// The condition of the boolean `let` `ident` at a use: refused if a signal it reads has
    /// been assigned since it was written (it is evaluated where it is used, so it would see
    /// the new value).
    fn use_bool_let(&self, ident: &syn::Ident) -> Result<Cond> {
        let n = ident.to_string();
        let Some(b) = self.bools.iter().rev().find_map(|s| s.get(&n)) else {
            return Err(Diag::new(ident.span(), "expected a comparison"));
        };
        for (id, seen) in &b.reads {
            if self.writes.get(id).copied().unwrap_or(0) != *seen {
                let sig = &self.signals[id.0].name;
                return Err(Diag::new(
                    ident.span(),
                    format!(
                        "`{n}` reads `{sig}`, which is assigned after `let {n}` (line {})",
                        b.line
                    ),
                )
                .label("would see the new value")
                .help(format!(
                    "a boolean `let` names its condition and is evaluated where it is used; \
                     keep the old value in a numeric `let` (`let old = {sig};`) and compare \
                     that, or write the boolean `let` after the assignment"
                )));
            }
        }
        Ok(b.cond.clone())
    }

    /// Counts an assignment to `id` (see [`Checker::use_bool_let`]).
    fn note_write(&mut self, id: SigId) {
        *self.writes.entry(id).or_insert(0) += 1;
    }

    /// Whether `e` is a condition (a comparison, `&&`, `||`, `!`, or a boolean `let`) rather
    /// than a number.
    fn is_condition(&self, e: &SExpr) -> bool {
        match e {
            SExpr::Paren(p) => self.is_condition(&p.expr),
            SExpr::Unary(u) => matches!(u.op, UnOp::Not(_)),
            SExpr::Binary(b) => {
                matches!(b.op, BinOp::And(_) | BinOp::Or(_)) || cmp_op(&b.op).is_some()
            }
            SExpr::Path(_) => {
                path_ident(e).is_some_and(|i| self.bool_let(&i.to_string()).is_some())
            }
            _ => false,
        }
    }

    fn stmt(&mut self, s: &syn::Stmt, out: &mut Vec<Stmt>) -> Result<()> {
        match s {
            syn::Stmt::Local(local) => {
                let ident = match &local.pat {
                    syn::Pat::Ident(p) if p.mutability.is_none() && p.subpat.is_none() => &p.ident,
                    syn::Pat::Type(t) => {
                        return Err(Diag::new(t.colon_token.span(), "`let` takes no type").help(
                            "qloop chooses the format; pin one with `#[q(i32, 16)] let x = ..;`",
                        ))
                    }
                    p => {
                        return Err(Diag::new(p.span(), "expected `let NAME = EXPR;`").help(
                            "`let` bindings are immutable; assign states or outputs instead",
                        ))
                    }
                };
                let init = local.init.as_ref().ok_or_else(|| {
                    Diag::new(local.span(), "`let` needs a value: `let NAME = EXPR;`")
                })?;
                if let Some((e, _)) = &init.diverge {
                    return Err(Diag::new(e.span(), "`let .. else` is not supported"));
                }
                if self.is_condition(&init.expr) {
                    // A boolean `let`: a name for a condition, substituted where it is used.
                    let cond = self.cond(&init.expr)?;
                    self.check_cond_units(&init.expr, &ParamUnits::new())?;
                    if let Some(a) = local.attrs.iter().find(|a| !a.path().is_ident("doc")) {
                        return Err(Diag::new(
                            a.span(),
                            "a boolean `let` takes no format attribute",
                        ));
                    }
                    self.define(ident)?;
                    let mut read = BTreeSet::new();
                    cond_reads(&cond, &mut read);
                    let reads = read
                        .into_iter()
                        .map(|id| (id, self.writes.get(&id).copied().unwrap_or(0)))
                        .collect();
                    let line = ident.span().start().line;
                    let src = self.branch_source(&init.expr);
                    if let Some(top) = self.bools.last_mut() {
                        top.insert(
                            ident.to_string(),
                            BoolLet {
                                cond,
                                src,
                                reads,
                                line,
                            },
                        );
                    }
                    return Ok(());
                }
                let value = self.expr(&init.expr)?;
                let unit = self.unit_of(&init.expr, &ParamUnits::new())?;
                // A Newton iterate of `newton_recip` is in the reciprocal of `d`'s unit (its
                // seed, a constant of the range's literals, may carry none).
                let unit = match self.recip_iterate_of(&ident.to_string()) {
                    Some((d, 'r')) => units::inverse(&self.sig_units[d.0]),
                    Some(_) => Ty::declared(None)?,
                    None => unit,
                };
                let Attrs {
                    pin,
                    lsb,
                    budget,
                    claim,
                    unsaturated,
                    flag,
                } = fmt_attrs(&local.attrs, &|e| self.const_eval(e))?;
                if let Some(b) = budget {
                    return Err(Diag::new(b.span, "`#[error]` applies to states and outputs").help(
                        "a `let` is sized for the budgets of the states and outputs it feeds; put `#[error(BOUND)]` on those",
                    ));
                }
                if let Some(sp) = unsaturated {
                    return Err(Diag::new(sp, "`#[unsaturated]` applies to states only"));
                }
                if let Some(sp) = flag {
                    return Err(Diag::new(sp, "`#[flag]` applies to outputs only"));
                }
                // A Newton iterate is stored in the default word, sized to its clamp: its
                // product with `d` then stays a single widening multiply.
                let pin = match (pin, self.recip_iterate_of(&ident.to_string())) {
                    (None, Some(_)) => self.iterate_format(&ident.to_string()),
                    (p, _) => p,
                };
                self.define(ident)?;
                let id = SigId(self.signals.len());
                let unit_text = unit.report_text();
                self.sig_units.push(unit);
                self.signals.push(Signal {
                    name: ident.to_string(),
                    kind: SigKind::Local,
                    elem: self.let_elems.get(&ident.to_string()).cloned(),
                    range: None,
                    init: None,
                    unit: unit_text,
                    pin,
                    lsb,
                    budget: None,
                    claim: claim.map(|c| c.0),
                    unsaturated: false,
                    flag: false,
                    docs: doc_lines(&local.attrs),
                    span: ident.span(),
                });
                if let Some(top) = self.scope.last_mut() {
                    top.insert(ident.to_string(), id);
                }
                out.push(Stmt::Assign {
                    target: id,
                    value,
                    span: local.span(),
                });
                Ok(())
            }
            syn::Stmt::Expr(e, semi) => self.expr_stmt(e, semi.is_some(), out),
            syn::Stmt::Item(i) => Err(Diag::new(i.span(), "items are not allowed inside `step`")),
            syn::Stmt::Macro(m) => Err(Diag::new(m.span(), "macros are not allowed inside `step`")),
        }
    }

    fn expr_stmt(&mut self, e: &SExpr, _semi: bool, out: &mut Vec<Stmt>) -> Result<()> {
        match e {
            SExpr::Assign(a) => {
                let target = self.target(&a.left)?;
                let value = self.expr(&a.right)?;
                self.check_store_units(target, &a.right, a.eq_token.span)?;
                self.note_write(target);
                self.mark_assigned(target);
                out.push(Stmt::Assign {
                    target,
                    value,
                    span: a.span(),
                });
                Ok(())
            }
            SExpr::Binary(b) if matches!(b.op, BinOp::AddAssign(_) | BinOp::SubAssign(_)) => {
                let target = self.target(&b.left)?;
                if self.signals[target.0].kind == SigKind::Output
                    && !self.assigned.contains(&target)
                {
                    return Err(Diag::new(
                        b.left.span(),
                        "output read before it is assigned",
                    ));
                }
                let cur = Box::new(Expr::Var(target, b.left.span()));
                let rhs = Box::new(self.expr(&b.right)?);
                self.check_store_units(target, &b.right, b.op.span())?;
                self.note_write(target);
                let value = match b.op {
                    BinOp::AddAssign(_) => Expr::Add(cur, rhs),
                    _ => Expr::Sub(cur, rhs),
                };
                out.push(Stmt::Assign {
                    target,
                    value,
                    span: b.span(),
                });
                Ok(())
            }
            SExpr::Binary(b) if matches!(b.op, BinOp::DivAssign(_) | BinOp::RemAssign(_)) => {
                Err(division(b.op.span()))
            }
            SExpr::Binary(b) if matches!(b.op, BinOp::MulAssign(_)) => {
                Err(Diag::new(b.op.span(), "`*=` is not supported").help("write `x = x * y;`"))
            }
            SExpr::Call(c) if path_ident(&c.func).is_some_and(|f| f == "recip_track") => {
                self.recip_track(c, out)
            }
            SExpr::If(i) => {
                let cond = self.cond(&i.cond)?;
                self.check_cond_units(&i.cond, &ParamUnits::new())?;
                let before = self.assigned.clone();
                let branch = self.branch(&i.cond);
                self.branches.push(branch.clone());
                let then = self.block(&i.then_branch.stmts);
                self.branches.pop();
                let then = then?;
                let after_then = std::mem::replace(&mut self.assigned, before);
                self.branches.push(branch.negated());
                let els = match &i.else_branch {
                    None => Ok(Vec::new()),
                    Some((_, e)) => match &**e {
                        SExpr::Block(b) => self.block(&b.block.stmts),
                        nested @ SExpr::If(_) => {
                            let mut v = Vec::new();
                            self.expr_stmt(nested, true, &mut v).map(|()| v)
                        }
                        other => Err(Diag::new(other.span(), "expected a block after `else`")),
                    },
                };
                self.branches.pop();
                let els = els?;
                self.assigned = after_then.intersection(&self.assigned).copied().collect();
                out.push(Stmt::If { cond, then, els });
                Ok(())
            }
            other => Err(Diag::new(other.span(), "unsupported statement").help(
                "`step` holds `let` bindings, assignments (`=`, `+=`, `-=`), `if`/`else`, `for` \
                 loops and `recip_track(r, x, G);`",
            )),
        }
    }

    fn mark_assigned(&mut self, id: SigId) {
        if self.signals[id.0].kind == SigKind::Output {
            self.assigned.insert(id);
        }
    }

    fn target(&self, e: &SExpr) -> Result<SigId> {
        let ident =
            path_ident(e).ok_or_else(|| Diag::new(e.span(), "expected a state or output name"))?;
        let n = ident.to_string();
        match self.lookup(&n) {
            Some(id) => match self.signals[id.0].kind {
                SigKind::State | SigKind::Output => Ok(id),
                SigKind::Input => Err(Diag::new(ident.span(), format!("input `{n}` is read-only"))),
                SigKind::Local => Err(Diag::new(ident.span(), format!("`{n}` is a `let` binding"))
                    .help("`let` bindings are immutable; declare a `state` to keep a value")),
            },
            None if self.consts.contains_key(&n) => {
                Err(Diag::new(ident.span(), format!("`{n}` is a constant")))
            }
            None => Err(unknown(&ident)),
        }
    }

    // ---- expressions -----------------------------------------------------------------

    /// One expression. A thin dispatcher: each form has its own function, so that the frame
    /// this recursion repeats per nesting level stays small (see `lang::scan`).
    fn expr(&self, e: &SExpr) -> Result<Expr> {
        match e {
            SExpr::Lit(l) => Ok(Expr::Const {
                value: lit_value(&l.lit)?,
                name: None,
                span: l.span(),
            }),
            SExpr::Paren(p) => self.expr(&p.expr),
            SExpr::Group(g) => self.expr(&g.expr),
            SExpr::Path(_) => self.name_expr(e),
            SExpr::Unary(u) => self.unary_expr(u),
            SExpr::Binary(b) => self.binary_expr(b),
            SExpr::Call(c) => {
                let f = path_ident(&c.func)
                    .ok_or_else(|| Diag::new(c.func.span(), "unknown function"))?;
                let args: Vec<&SExpr> = c.args.iter().collect();
                self.builtin(&f, &args, c.span())
            }
            SExpr::MethodCall(m) => {
                let mut args: Vec<&SExpr> = vec![&m.receiver];
                args.extend(m.args.iter());
                self.builtin(&m.method, &args, m.span())
            }
            SExpr::If(i) => self.if_expr(i),
            other => Err(unsupported_expr(other)),
        }
    }

    fn name_expr(&self, e: &SExpr) -> Result<Expr> {
        let ident = path_ident(e).ok_or_else(|| Diag::new(e.span(), "expected a name"))?;
        let n = ident.to_string();
        if self.bool_let(&n).is_some() {
            return Err(Diag::new(ident.span(), format!("`{n}` is a condition, not a number"))
                .label("boolean `let`")
                .help(format!(
                    "use it where a condition goes: `if {n} {{ .. }}`, or select a value with `if {n} {{ a }} else {{ b }}`"
                )));
        }
        if let Some(id) = self.lookup(&n) {
            let s = &self.signals[id.0];
            if s.kind == SigKind::Output && !self.assigned.contains(&id) {
                return Err(Diag::new(
                    ident.span(),
                    format!("output `{n}` is read before it is assigned"),
                ));
            }
            return Ok(Expr::Var(id, ident.span()));
        }
        match self.consts.get(&n) {
            Some(&(v, _)) if v.is_nan() => Err(Diag::new(
                ident.span(),
                "`period` is used before it is declared",
            )),
            Some(&(v, _)) => Ok(Expr::Const {
                value: v,
                name: Some(n),
                span: ident.span(),
            }),
            None => Err(unknown(&ident)),
        }
    }

    fn unary_expr(&self, u: &syn::ExprUnary) -> Result<Expr> {
        match u.op {
            UnOp::Neg(_) => fold1(Expr::Neg(Box::new(self.expr(&u.expr)?)), u.op.span()),
            _ => Err(Diag::new(u.op.span(), "unsupported unary operator")
                .help("only `-x` is an arithmetic unary operator; `!` belongs in conditions")),
        }
    }

    fn binary_expr(&self, b: &syn::ExprBinary) -> Result<Expr> {
        let op_span = b.op.span();
        let make: fn(Box<Expr>, Box<Expr>, Span) -> Expr = match b.op {
            BinOp::Add(_) => |a, b, _| Expr::Add(a, b),
            BinOp::Sub(_) => |a, b, _| Expr::Sub(a, b),
            BinOp::Mul(_) => Expr::Mul,
            BinOp::Div(_) | BinOp::Rem(_) => return Err(division(op_span)),
            BinOp::Lt(_)
            | BinOp::Le(_)
            | BinOp::Gt(_)
            | BinOp::Ge(_)
            | BinOp::Eq(_)
            | BinOp::Ne(_)
            | BinOp::And(_)
            | BinOp::Or(_) => {
                return Err(Diag::new(op_span, "a comparison is not a number").help(
                    "use comparisons in `if` conditions; `if c { a } else { b }` selects a value; \
                     `let over = fc > FR;` names a condition",
                ))
            }
            _ => {
                return Err(Diag::new(op_span, "unsupported operator").help(
                    "qloop chooses shifts and bit operations itself: write `+ - *`, `min`, `max`, `clamp`",
                ))
            }
        };
        let (l, r) = (self.expr(&b.left)?, self.expr(&b.right)?);
        fold1(make(Box::new(l), Box::new(r), op_span), op_span)
    }

    fn if_expr(&self, i: &syn::ExprIf) -> Result<Expr> {
        let cond = self.cond(&i.cond)?;
        let a = block_value(&i.then_branch)?;
        let b = match &i.else_branch {
            Some((_, e)) => match &**e {
                SExpr::Block(b) => block_value(&b.block)?,
                other => other,
            },
            None => {
                return Err(Diag::new(
                    i.span(),
                    "an `if` used as a value needs an `else`",
                ))
            }
        };
        Ok(Expr::Select(
            Box::new(cond),
            Box::new(self.expr(a)?),
            Box::new(self.expr(b)?),
        ))
    }

    fn builtin(&self, f: &syn::Ident, args: &[&SExpr], span: Span) -> Result<Expr> {
        let n = f.to_string();
        if let Some(t) = self.table_index(&n) {
            return self.table_call(t, args, span);
        }
        let want = match n.as_str() {
            "abs" => {
                if args.len() != 1 {
                    return Err(Diag::new(span, "`abs` takes 1 argument"));
                }
                // |x| = max(x, -x): branch-free, total (the negation is widened).
                let x = self.expr(args[0])?;
                return fold1(
                    Expr::Max(Box::new(x.clone()), Box::new(Expr::Neg(Box::new(x)))),
                    span,
                );
            }
            "convert" => {
                if args.len() != 2 {
                    return Err(Diag::new(span, "`convert` takes 2 arguments")
                        .help("write `convert(x, \"mm/s\")`"));
                }
                let x = self.expr(args[0])?;
                let factor = self.convert_factor(args)?;
                let k = Expr::Const {
                    value: factor,
                    name: None,
                    span,
                };
                return fold1(Expr::Mul(Box::new(x), Box::new(k), span), span);
            }
            "min" | "max" => 2,
            "clamp" => 3,
            "div" | "recip" | "div_euclid" | "rem" | "rem_euclid" | "checked_div"
            | "wrapping_div" | "saturating_div" | "inv" => {
                return Err(Diag::new(
                    f.span(),
                    format!("`{n}` divides: division is not allowed in a qloop spec"),
                )
                .label("division")
                .help(DIVISION_HELP))
            }
            _ => {
                return Err(Diag::new(f.span(), format!("unknown function `{n}`")).help(
                    "the built-in functions are `min(a, b)`, `max(a, b)`, `clamp(x, lo, hi)`, \
                     `abs(x)` and `convert(x, \"unit\")`",
                ))
            }
        };
        if args.len() != want {
            return Err(Diag::new(span, format!("`{n}` takes {want} arguments")));
        }
        let a: Vec<Expr> = args.iter().map(|e| self.expr(e)).collect::<Result<_>>()?;
        let mut it = a.into_iter().map(Box::new);
        let (x, y) = (
            it.next().unwrap_or_else(zero),
            it.next().unwrap_or_else(zero),
        );
        match n.as_str() {
            "min" => fold1(Expr::Min(x, y), span),
            "max" => fold1(Expr::Max(x, y), span),
            _ => {
                let hi = it.next().unwrap_or_else(zero);
                if let (Expr::Const { value: l, .. }, Expr::Const { value: h, .. }) = (&*y, &*hi) {
                    if l > h {
                        return Err(Diag::new(
                            span,
                            format!("clamp bounds are reversed: {l} > {h}"),
                        ));
                    }
                }
                // clamp(x, lo, hi) = min(max(x, lo), hi): total, never panics.
                fold1(Expr::Min(Box::new(fold1(Expr::Max(x, y), span)?), hi), span)
            }
        }
    }

    fn cond(&self, e: &SExpr) -> Result<Cond> {
        match e {
            SExpr::Paren(p) => self.cond(&p.expr),
            SExpr::Path(_) => match path_ident(e) {
                Some(i) if self.bool_let(&i.to_string()).is_some() => self.use_bool_let(&i),
                _ => Err(Diag::new(e.span(), "expected a comparison").help(
                    "conditions compare numbers with < <= > >= == != and join them with && || !; \
                     a boolean `let` names one",
                )),
            },
            SExpr::Unary(u) if matches!(u.op, UnOp::Not(_)) => {
                Ok(Cond::Not(Box::new(self.cond(&u.expr)?)))
            }
            SExpr::Binary(b) => {
                let op = match b.op {
                    BinOp::And(_) => {
                        return Ok(Cond::And(
                            Box::new(self.cond(&b.left)?),
                            Box::new(self.cond(&b.right)?),
                        ))
                    }
                    BinOp::Or(_) => {
                        return Ok(Cond::Or(
                            Box::new(self.cond(&b.left)?),
                            Box::new(self.cond(&b.right)?),
                        ))
                    }
                    other => cmp_op(&other).ok_or_else(|| {
                        Diag::new(b.span(), "expected a comparison")
                            .help("conditions compare numbers with < <= > >= == != and join them with && || !")
                    })?,
                };
                Ok(Cond::Cmp(op, self.expr(&b.left)?, self.expr(&b.right)?))
            }
            other => Err(Diag::new(other.span(), "expected a comparison").help(
                "conditions compare numbers with < <= > >= == != and join them with && || !",
            )),
        }
    }
}

/// A boolean `let`: its condition, the signals it reads with how many assignments each had
/// when it was written, and its line.
struct BoolLet {
    cond: Cond,
    /// The condition as written, for a tracker's property ([`Checker::branch_source`]).
    src: SExpr,
    reads: Vec<(SigId, usize)>,
    line: usize,
}

/// Adds the signals `c` reads to `out`.
fn cond_reads(c: &Cond, out: &mut BTreeSet<SigId>) {
    match c {
        Cond::Cmp(_, a, b) => {
            expr_reads(a, out);
            expr_reads(b, out);
        }
        Cond::And(a, b) | Cond::Or(a, b) => {
            cond_reads(a, out);
            cond_reads(b, out);
        }
        Cond::Not(a) => cond_reads(a, out),
    }
}

/// Adds the signals `e` reads to `out`.
fn expr_reads(e: &Expr, out: &mut BTreeSet<SigId>) {
    match e {
        Expr::Const { .. } => {}
        Expr::Var(id, _) => {
            out.insert(*id);
        }
        Expr::Neg(a) => expr_reads(a, out),
        Expr::Add(a, b)
        | Expr::Sub(a, b)
        | Expr::Mul(a, b, _)
        | Expr::Min(a, b)
        | Expr::Max(a, b) => {
            expr_reads(a, out);
            expr_reads(b, out);
        }
        Expr::Select(c, a, b) => {
            cond_reads(c, out);
            expr_reads(a, out);
            expr_reads(b, out);
        }
        Expr::Table(_, a, _) => expr_reads(a, out),
    }
}

/// The comparison a binary operator denotes, if any.
pub(crate) fn cmp_op(op: &BinOp) -> Option<CmpOp> {
    Some(match op {
        BinOp::Lt(_) => CmpOp::Lt,
        BinOp::Le(_) => CmpOp::Le,
        BinOp::Gt(_) => CmpOp::Gt,
        BinOp::Ge(_) => CmpOp::Ge,
        BinOp::Eq(_) => CmpOp::Eq,
        BinOp::Ne(_) => CmpOp::Ne,
        _ => return None,
    })
}

fn zero() -> Box<Expr> {
    Box::new(Expr::Const {
        value: 0.0,
        name: None,
        span: Span::call_site(),
    })
}

/// Folds an operator node whose operands are all constants; a result beyond the f64 range
/// (`1e300 * 1e300`) is an error at `span`, the operator.
fn fold1(e: Expr, span: Span) -> Result<Expr> {
    let e = fold_value(e);
    match e {
        Expr::Const { value, .. } if !value.is_finite() => Err(Diag::new(
            span,
            "this constant expression overflows: its value is beyond the f64 range (±1.8e308)",
        )
        .label("overflows")
        .help("use smaller constants: scale the units, or write the product's value directly")),
        e => Ok(e),
    }
}

fn fold_value(e: Expr) -> Expr {
    let c = |x: &Expr| match x {
        Expr::Const { value, .. } => Some(*value),
        _ => None,
    };
    let (value, span) = match &e {
        Expr::Neg(a) => match c(a) {
            Some(v) => (-v, a.span()),
            None => return e,
        },
        Expr::Add(a, b)
        | Expr::Sub(a, b)
        | Expr::Mul(a, b, _)
        | Expr::Min(a, b)
        | Expr::Max(a, b) => match (c(a), c(b)) {
            (Some(x), Some(y)) => (
                match &e {
                    Expr::Add(..) => x + y,
                    Expr::Sub(..) => x - y,
                    Expr::Mul(..) => x * y,
                    Expr::Min(..) => x.min(y),
                    _ => x.max(y),
                },
                a.span(),
            ),
            _ => return e,
        },
        _ => return e,
    };
    Expr::Const {
        value,
        name: None,
        span,
    }
}

fn unsupported_expr(e: &SExpr) -> Diag {
    Diag::new(e.span(), "unsupported expression").help(
        "expressions use numbers, names, `+ - *`, unary `-`, `min`, `max`, `clamp` and `if .. else`",
    )
}

fn block_value(b: &syn::Block) -> Result<&SExpr> {
    match b.stmts.as_slice() {
        [syn::Stmt::Expr(e, None)] => Ok(e),
        _ => Err(
            Diag::new(b.span(), "a value `if` branch holds one expression")
                .help("write `if c { a } else { b }`"),
        ),
    }
}

fn path_ident(e: &SExpr) -> Option<syn::Ident> {
    match e {
        SExpr::Path(p) if p.qself.is_none() => p.path.get_ident().cloned(),
        _ => None,
    }
}

fn unknown(ident: &syn::Ident) -> Diag {
    Diag::new(ident.span(), format!("unknown name `{ident}`"))
        .label("not declared")
        .help("declare it as an `input`, `state`, `output`, `param` or `const`, or bind it with `let` before use")
}

fn division(span: Span) -> Diag {
    Diag::new(span, "division is not allowed in a qloop spec")
        .label("division")
        .help(DIVISION_HELP)
}

fn dup<T>(prev: &Option<T>, span: Span, what: &str) -> Result<()> {
    match prev {
        Some(_) => Err(Diag::new(span, format!("`{what}` is declared twice"))),
        None => Ok(()),
    }
}

/// Refuses a number literal with a Rust suffix (`0.5KC`, `16u8`): the lexer reads `0.5KC` as
/// 0.5 with suffix `KC`, so a missing `*` would otherwise silently drop a factor.
fn no_suffix(span: Span, digits: &str, suffix: &str) -> Result<()> {
    if suffix.is_empty() {
        return Ok(());
    }
    Err(Diag::new(
        span,
        format!("the number `{digits}{suffix}` has a suffix `{suffix}`; qloop numbers take none"),
    )
    .label("suffix")
    .help(format!(
        "if `{suffix}` is a name, write the product with `*`: `{digits} * {suffix}`"
    )))
}

fn lit_value(l: &Lit) -> Result<f64> {
    let v = match l {
        Lit::Float(f) => {
            no_suffix(f.span(), f.base10_digits(), f.suffix())?;
            f.base10_parse::<f64>().map_err(Diag::from)?
        }
        Lit::Int(i) => {
            no_suffix(i.span(), i.base10_digits(), i.suffix())?;
            i.base10_parse::<i64>().map_err(Diag::from)? as f64
        }
        other => {
            return Err(Diag::new(other.span(), "expected a number")
                .help("units go after a declaration as a string: `input f: [0.0, 5.0] \"kN\";`"))
        }
    };
    if !v.is_finite() {
        return Err(Diag::new(l.span(), "number out of range"));
    }
    // A literal whose digits are not all zero but whose value f64 cannot hold: `1e-400`
    // parses to 0 (and `1e-310` to a subnormal with fewer digits than written).
    if v.abs() < f64::MIN_POSITIVE && has_nonzero_digit(l) {
        return Err(const_eval::underflow(l.span()));
    }
    Ok(v)
}

/// Whether a number literal has a non-zero digit (so that a value of 0 is an underflow).
fn has_nonzero_digit(l: &Lit) -> bool {
    let digits = match l {
        Lit::Float(f) => f.base10_digits().to_string(),
        Lit::Int(i) => i.base10_digits().to_string(),
        _ => return false,
    };
    let mantissa = digits.split(['e', 'E']).next().unwrap_or("");
    mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b))
}

/// The attributes of a `param` or `const`: `#[reference]` and `#[nominal]` on a `param`.
/// Formats are refused: a constant is quantised where it is used (each use at the precision
/// of the value it meets, its error counted in `check`), so there is no one quantum to set.
fn const_attrs(c: &ConstDecl) -> Result<(bool, bool)> {
    let (mut reference, mut nominal) = (false, false);
    let kw = if c.is_param { "param" } else { "const" };
    for a in &c.attrs {
        let p = a.path();
        if p.is_ident("doc") {
            continue;
        }
        let flag = if p.is_ident("reference") {
            &mut reference
        } else if p.is_ident("nominal") {
            &mut nominal
        } else if p.is_ident("lsb") || p.is_ident("q") {
            return Err(Diag::new(
                a.span(),
                format!("a `{kw}` has no format of its own"),
            )
            .label("not applied")
            .help(
                "a constant is quantised where it is used, at the precision of the value it \
                 meets; `qloop check` lists each constant's quantisation error. Pin the format \
                 of the `let` or signal that uses it instead",
            ));
        } else {
            return Err(Diag::new(a.span(), format!("unknown attribute on a `{kw}`")).help(
                "a `param` takes `#[reference]` (the set point closed-loop runs measure against) \
                 or `#[nominal]` (the nominal feed an override output multiplies)",
            ));
        };
        if !c.is_param {
            return Err(
                Diag::new(a.span(), "`#[reference]` and `#[nominal]` mark a `param`")
                    .help(format!("write `param {}` instead of `const`", c.name)),
            );
        }
        if !matches!(a.meta, syn::Meta::Path(_)) {
            return Err(Diag::new(a.span(), "this attribute takes no arguments"));
        }
        *flag = true;
    }
    Ok((reference, nominal))
}

/// Format and proof attributes of a declaration.
struct Attrs {
    pin: Option<QFormat>,
    lsb: Option<f64>,
    budget: Option<crate::ir::Budget>,
    claim: Option<((f64, f64), Span)>,
    unsaturated: Option<Span>,
    flag: Option<Span>,
}

/// The number literal of `#[NAME(NUMBER)]`: its f64 value, its exact decimal value and its
/// span.
fn number_attr(
    a: &syn::Attribute,
    name: &str,
) -> Result<(f64, Option<num_rational::BigRational>, Span)> {
    let e: SExpr = a.parse_args().map_err(Diag::from)?;
    match &e {
        SExpr::Lit(l) => Ok((lit_value(&l.lit)?, enclose::lit_rational(&l.lit), e.span())),
        _ => Err(Diag::new(
            e.span(),
            format!("expected a number: `#[{name}(1e-3)]`"),
        )),
    }
}

/// `qloop_recip0_r3` → (`qloop_recip0`, `'r'`, `"3"`); the same for `_t3`.
fn split_step_name(n: &str) -> Option<(&str, char, &str)> {
    let (head, k) = n.rsplit_once('_')?;
    let kind = k.chars().next()?;
    if !matches!(kind, 'r' | 't') || !k[1..].chars().all(|c| c.is_ascii_digit()) || k.len() < 2 {
        return None;
    }
    Some((head, kind, &k[1..]))
}

/// Reads `#[q(i32, 20)]`, `#[lsb(1e-3)]`, `#[range(LO, HI)]` and `#[unsaturated]`: the format
/// attributes of a declaration; `eval` gives the value of a `#[range]` bound (a constant
/// expression).
fn fmt_attrs(attrs: &[syn::Attribute], eval: &dyn Fn(&SExpr) -> Result<f64>) -> Result<Attrs> {
    let mut pin = None;
    let mut lsb = None;
    let mut budget = None;
    let mut claim = None;
    let mut unsaturated = None;
    let mut flag = None;
    for a in attrs {
        if a.path().is_ident("doc") {
            continue;
        }
        if a.path().is_ident("q") {
            let args = a
                .parse_args_with(
                    syn::punctuated::Punctuated::<SExpr, syn::Token![,]>::parse_terminated,
                )
                .map_err(Diag::from)?;
            let bad = || {
                Diag::new(a.span(), "expected `#[q(TYPE, FRAC)]`, e.g. `#[q(i32, 20)]`")
                    .help("TYPE is i8, i16, i32, i64, u8, u16, u32 or u64; FRAC is the number of fraction bits")
            };
            let v: Vec<&SExpr> = args.iter().collect();
            let [t, f] = v.as_slice() else {
                return Err(bad());
            };
            let ty = path_ident(t).ok_or_else(bad)?.to_string();
            let (signed, bits) = match (ty.strip_prefix('i'), ty.strip_prefix('u')) {
                (Some(b), _) => ("i", b),
                (_, Some(b)) => ("u", b),
                _ => return Err(bad()),
            };
            let bits: u32 = bits.parse().map_err(|_| bad())?;
            if !WIDTHS.contains(&bits) {
                return Err(bad());
            }
            let frac = match f {
                SExpr::Lit(syn::ExprLit {
                    lit: Lit::Int(i), ..
                }) => {
                    no_suffix(i.span(), i.base10_digits(), i.suffix())?;
                    i.base10_parse::<i32>().map_err(|_| bad())?
                }
                _ => return Err(bad()),
            };
            pin = Some(QFormat {
                ty: IntTy {
                    signed: signed == "i",
                    bits,
                },
                frac,
            });
        } else if a.path().is_ident("unsaturated") {
            unsaturated = Some(a.span());
        } else if a.path().is_ident("flag") {
            flag = Some(a.span());
        } else if a.path().is_ident("range") {
            let args = a
                .parse_args_with(
                    syn::punctuated::Punctuated::<SExpr, syn::Token![,]>::parse_terminated,
                )
                .map_err(Diag::from)?;
            let bad = || Diag::new(a.span(), "expected `#[range(LO, HI)]`");
            let v: Vec<f64> = args.iter().map(eval).collect::<Result<_>>()?;
            if v.len() != 2 {
                return Err(bad());
            }
            match v.as_slice() {
                [lo, hi] if lo < hi => claim = Some(((*lo, *hi), a.span())),
                _ => return Err(bad().help("LO < HI")),
            }
        } else if a.path().is_ident("lsb") {
            let (v, _, at) = number_attr(a, "lsb")?;
            if v <= 0.0 {
                return Err(Diag::new(at, "the LSB must be positive"));
            }
            lsb = Some(v);
        } else if a.path().is_ident("error") {
            let (v, exact, at) = number_attr(a, "error")?;
            if !(v > 0.0 && v.is_finite()) {
                return Err(Diag::new(at, "an error budget must be positive and finite"));
            }
            // The f64 at or below the written decimal: a bound within it is within the budget.
            budget = Some(crate::ir::Budget {
                err: exact.map_or(v, |r| enclose::f64_down(&r)),
                span: a.span(),
            });
        } else {
            return Err(Diag::new(a.span(), "unknown attribute").help(
                "declarations take `///` docs, `#[q(TYPE, FRAC)]`, `#[lsb(RESOLUTION)]`, `#[error(BOUND)]` (on states and outputs), `#[range(LO, HI)]` (on `let`), `#[unsaturated]` (on states) and `#[flag]` (on outputs)",
            ));
        }
    }
    Ok(Attrs {
        pin,
        lsb,
        budget,
        claim,
        unsaturated,
        flag,
    })
}

fn to_snake(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.extend(c.to_lowercase());
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::lang::parse::parse_str;

    /// Compiles `body` inside a minimal controller; returns the error's message and
    /// line:col (line 1 is the `controller` line).
    fn err(items: &str) -> (String, usize, usize) {
        let src = format!("controller t {{\n{items}\n}}\n");
        let d = parse_str(&src)
            .and_then(|a| super::check(&a))
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{src}"));
        let (l, c) = d.line_col();
        (d.message, l, c)
    }

    const HEAD: &str = "period 0.1 \"s\";\ninput x: [0.0, 1.0];\noutput y;";

    #[test]
    fn rejections_name_the_place() {
        let cases: &[(&str, &str, usize, usize)] = &[
            ("step { y = x / 2.0; }", "division is not allowed", 5, 14),
            ("step { y = x % 2.0; }", "division is not allowed", 5, 14),
            (
                "step { y = x; y /= 2.0; }",
                "division is not allowed",
                5,
                17,
            ),
            ("step { y = x * k; }", "unknown name `k`", 5, 16),
            ("step { y = 0.5k * x; }", "has a suffix `k`", 5, 12),
            ("step { y = 2u8 * x; }", "has a suffix `u8`", 5, 12),
            (
                "step { let _t = x; y = _t; }",
                "reserved for generated code",
                5,
                12,
            ),
            (
                "step { let inputs = x; y = inputs; }",
                "reserved for generated code",
                5,
                12,
            ),
            (
                "step { let qloop_mul_3 = x; y = qloop_mul_3; }",
                "reserved for generated code",
                5,
                12,
            ),
            ("step { x = 1.0; y = x; }", "input `x` is read-only", 5, 8),
            (
                "step { let a = x; a = 2.0; y = a; }",
                "`a` is a `let` binding",
                5,
                19,
            ),
            (
                "step { if x > 0.5 { y = x; } }",
                "output `y` is not assigned on every path",
                4,
                8,
            ),
            (
                "step { y = y + x; }",
                "output `y` is read before it is assigned",
                5,
                12,
            ),
            ("step { y = x << 2; }", "unsupported operator", 5, 14),
            ("step { y = sqrt(x); }", "unknown function `sqrt`", 5, 12),
            (
                "step { y = clamp(x, 1.0, 0.0); }",
                "clamp bounds are reversed",
                5,
                12,
            ),
            (
                "step { let a = x; let a = x; y = a; }",
                "`a` is already defined",
                5,
                23,
            ),
            (
                "state s: [0.0, 1.0];\nstep { y = x; }",
                "state `s` has no initial value",
                5,
                7,
            ),
            (
                "state s: [0.0, 1.0] = 2.0;\nstep { y = x; }",
                "outside the range",
                5,
                23,
            ),
            (
                "state s: [1.0, 0.0] = 0.5;\nstep { y = x; }",
                "empty range",
                5,
                10,
            ),
            (
                "#[q(i32, 40)] state s: [0.0, 1.0] = 0.5;\nstep { y = x; }",
                "cannot cross the API",
                5,
                21,
            ),
            (
                "#[q(f32, 4)] state s: [0.0, 1.0] = 0.5;\nstep { y = x; }",
                "expected `#[q(TYPE, FRAC)]`",
                5,
                1,
            ),
            (
                "#[inline] state s: [0.0, 1.0] = 0.5;\nstep { y = x; }",
                "unknown attribute",
                5,
                1,
            ),
            ("step { y = x; }\nstep { y = x; }", "one `step` body", 6, 6),
            (
                "rounding sideways;\nstep { y = x; }",
                "unknown rounding `sideways`",
                5,
                10,
            ),
            (
                "word 12;\nstep { y = x; }",
                "word width must be 8, 16, 32 or 64",
                5,
                6,
            ),
            ("state s: [0.0, 1.0] = 0.5;\nprove { invariant i: next(s) < 1.0; }\nstep { y = x; }", "not allowed in an invariant", 6, 22),
            ("state s: [0.0, 1.0] = 0.5;\nprove { invariant i: x < 1.0; }\nstep { y = x; }", "may only mention states", 6, 22),
            ("prove { property p { assume x > 0.5; } }\nstep { y = x; }", "at least one `ensure", 5, 18),
            ("prove { property p { ensure y <= x / 2.0; } }\nstep { y = x; }", "division is not allowed in properties", 5, 36),
            ("prove { property p { forall x in [0.0, 1.0]; ensure y <= x; } }\nstep { y = x; }", "`x` is already defined", 5, 29),
            ("prove { property p { ensure next(x) <= 1.0; } }\nstep { y = x; }", "takes a state or output", 5, 34),
            ("prove { property p { ensure sqrt(y) <= 1.0; } }\nstep { y = x; }", "unknown function `sqrt`", 5, 29),
            ("prove { invariant i: 1.0 > 0.0; invariant i: 1.0 > 0.0; }\nstep { y = x; }", "already exists", 5, 43),
            ("#[range(0.0, 1.0)] input z: [0.0, 1.0];\nstep { y = x; }", "claims go on `let`", 5, 1),
            ("step { #[unsaturated] let a = x; y = a; }", "applies to states only", 5, 8),
            ("step { y = if x > 0.5 { x }; }", "needs an `else`", 5, 12),
        ];
        for (items, msg, line, col) in cases {
            let (m, l, c) = err(&format!("{HEAD}\n{items}"));
            assert!(m.contains(msg), "{items}: got `{m}`, want `{msg}`");
            assert_eq!((l, c), (*line, *col), "{items}: {m}");
        }
    }

    #[test]
    fn missing_period_and_step() {
        let (m, l, _) = err("input x: [0.0, 1.0];\noutput y;\nstep { y = x; }");
        assert!(m.contains("missing sample period") && l == 1, "{m}");
        let (m, ..) = err("period 1 \"ms\";\ninput x: [0.0, 1.0];");
        assert!(m.contains("missing `step"), "{m}");
    }

    #[test]
    fn constants_fold_and_period_is_a_name() {
        let src = "controller t {\nperiod 2 \"ms\";\nconst A: 3.0 * period - 0.5 * 0.002;\ninput x: [0.0, 1.0];\noutput y \"s\";\nstep { y = x * A; }\n}";
        let p = super::check(&parse_str(src).unwrap()).unwrap();
        assert_eq!(p.period, 0.002);
        assert_eq!(p.constants[0].value, 3.0 * 0.002 - 0.5 * 0.002);
    }

    /// Compile-time mathematics (issue 16): `/`, `exp`, `ln`, `sqrt`, `powf` in constants,
    /// checked against values computed independently here (the closed forms, to the digits
    /// the literals give) and their units; errors at the operator or call; division in
    /// `step` is still refused.
    #[test]
    fn constants_may_divide_and_call_exp_ln_sqrt_powf() {
        let src = "controller t {
period 2 \"ms\";
param TAU: 0.02 \"s\";
const A: exp(-period / TAU);
const W: 2.0 * 3.141592653589793 * 50.0 \"1/s\";
const T: 1.0 / W \"s\";
const R: sqrt(2.0);
const L: ln(8.0) / ln(2.0);
const P: powf(2.0, 0.5);
const M: (0.5).powf(3.0) + TAU.abs() \"s\";
const S: sqrt(4.0 * TAU * TAU) \"s\";
input x: [0.0, 1.0];
output y;
step { y = x * A; }
}";
        let p = super::check(&parse_str(src).unwrap()).unwrap();
        let v = |n: &str| p.constants.iter().find(|c| c.name == n).unwrap().value;
        assert!(
            (v("A") - 0.904_837_418_035_959_6).abs() < 1e-15,
            "{}",
            v("A")
        ); // e^-0.1
        assert!(
            (v("T") - 0.003_183_098_861_837_907).abs() < 1e-17,
            "{}",
            v("T")
        ); // 1/(100π)
        assert_eq!(v("R"), std::f64::consts::SQRT_2); // correctly rounded
        assert!((v("L") - 3.0).abs() < 1e-15);
        assert!((v("P") - std::f64::consts::SQRT_2).abs() < 1e-15);
        assert_eq!(v("M"), 0.125 + 0.02);
        assert!((v("S") - 0.04).abs() < 1e-17);
        let base = "input x: [0.0, 1.0];\noutput y;\nstep { y = x; }";
        for (items, want, line, col) in [
            ("const Z: 1.0 / (2.0 - 2.0);", "division by zero", 3, 14),
            ("const Z: ln(0.0);", "`ln` of 0", 3, 10),
            ("const Z: sqrt(-1.0);", "`sqrt` of -1", 3, 10),
            ("const Z: powf(-2.0, 0.5);", "no real value", 3, 10),
            (
                "const Z: exp(period);",
                "its argument must be dimensionless",
                3,
                10,
            ),
            ("const Z: sin(1.0);", "unknown function `sin`", 3, 10),
            (
                "param F: 1.0 \"kN\";\nconst Z: sqrt(F);",
                "not a square unit",
                4,
                10,
            ),
        ] {
            let (m, l, c) = err(&format!("period 0.1 \"s\";\n{items}\n{base}"));
            assert!(m.contains(want), "{items}: {m}");
            assert_eq!((l, c), (line, col), "{items}: {m}");
        }
        // Run-time division stays a located error.
        let (m, l, c) = err(&format!("{HEAD}\nstep {{ y = x / 2.0; }}"));
        assert!(m.contains("division"), "{m}");
        assert_eq!((l, c), (5, 14));
    }

    /// A boolean `let` names its condition, evaluated where it is used: a use after an
    /// assignment to a signal it reads is refused at the use (it would see the new value);
    /// assigning inside the `if` it decides is fine.
    #[test]
    fn a_boolean_let_cannot_be_outdated_by_a_later_assignment() {
        let (m, l, c) = err(&format!(
            "{HEAD}\nstate u: [0.0, 5.0] = 1.0;\nstep {{ let over = u > 2.0; u = u * 0.5; if over {{ u = 0.0; }} y = x; }}"
        ));
        assert!(
            m.contains("`over` reads `u`, which is assigned after `let over`"),
            "{m}"
        );
        assert_eq!((l, c), (6, 44));
        let src = format!(
            "controller t {{\n{HEAD}\nstate u: [0.0, 5.0] = 1.0;\nstep {{ let slow = u < 1.0; if slow {{ u = u + 0.5; }} y = x; }}\n}}\n"
        );
        assert!(super::check(&parse_str(&src).unwrap()).is_ok());
    }
}
