//! Products under Kani, for the property harnesses whose conditions multiply two non-constant
//! values (the gain-loop and estimator contractions).
//!
//! CBMC bit-blasts every multiplication of two variables into a multiplier circuit, and a SAT
//! solver cannot relate two such circuits (the step's `kc·km` and the property's `kc·km`, or
//! `next(kc)·km` and `kc·km`): those harnesses did not finish in 20 minutes. Under Kani they
//! run the generated step itself with each of its products replaced by an abstraction, and
//! evaluate the property's own products through the same abstractions:
//!
//! * **Step products.** The Rust emitter computes each product of two non-constant values of
//!   the step in its own function `qloop_mul_<n>` (always inlined: the object code is the
//!   multiply). The harness `kani::stub`s it with `abs_mul_<n>`, which asserts that each factor
//!   is inside the interval the range analysis proved for it, and returns a fresh value that
//!   satisfies the clauses below. Equal factors give the same value (the last call is
//!   remembered): the product is a pure function, so the abstraction contains the exact
//!   multiplication.
//! * **The property's products**, rewritten exactly onto those of the step: `x·y` of two
//!   pre-step values that the step multiplies is that call (same arguments, same value);
//!   `next(x)·y` is `lo·y` where `x` saturated at its lower bound, `hi·y` at its upper bound,
//!   and otherwise `x·y + (next(x) − x)·y`; a free parameter `p` that the property compares
//!   with a state `s` is `s·2^k + d`, so `p·y = (s·y)·2^k + d·y`. The new products
//!   (`(next(x) − x)·y`, `d·y`, and any other product of the property) are harness-only
//!   functions `exact_prod_<n>` (plain multiplication), abstracted the same way by
//!   `abs_prod_<n>`.
//!
//! The clauses an abstraction assumes, for factors `x ∈ [xₗ, xᵤ]`, `y ∈ [yₗ, yᵤ]` and the
//! product `z`, are the facts the linear envelope of `qloop prove` uses:
//! * the four McCormick planes, `(x − xₗ)(y − yₗ) ≥ 0` and the like, for the products the
//!   property reads itself (without them the 1981 gain-loop contraction fails spuriously
//!   where `K_c` saturates);
//! * the sign-split bounds, `x ≥ 0 ⇒ yₗ·x ≤ z ≤ yᵤ·x`, `x ≤ 0 ⇒ yᵤ·x ≤ z ≤ yₗ·x` and the same
//!   for `y`, for every product (the differences `(next(x) − x)·y` and the step's other
//!   products need no more; measured in BENCHMARKS.md, "Issue 14").
//!
//! The chain of assumptions, each link a harness:
//! * `lemma_<product>_<clause>` (a plain `kani::proof`, one per clause: a failure names it):
//!   for every pair of factors inside the intervals, the production function (or the
//!   harness-only exact product) satisfies the clause;
//! * `property_<name>` (with the stubs): for inputs inside their declared ranges, states inside
//!   their bounds and the invariants, and parameters on their grid, the property holds for
//!   every product value the clauses allow, the exact ones among them; each stub's factor
//!   assertions are checked here.
//!
//! Kani's `stub_verified` would replace each call by an independent value, and the step's
//! `kc·km` and the property's `kc·km` must be one value; `proof_for_contract` proves all of a
//! product's clauses in one run, 2–4× slower than one harness per clause. Both are measured
//! reasons for the plain stubs and lemma harnesses used instead.

use super::exact::Ev;
use super::show::spaced;
use crate::emit::repeat::Emit;
use crate::ir::{PCond, PExpr, SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use crate::qformat::IntTy;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};
use std::collections::{BTreeMap, HashSet};

/// A value a property reads, as a factor of a product.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Atom {
    /// An input, or a state before the step.
    Pre(SigId),
    /// A state after the step.
    Post(SigId),
    /// A free parameter (its index).
    Param(usize),
}

/// Whether a condition multiplies two non-constant values.
pub(super) fn multiplies(c: &PCond) -> bool {
    let mut found = false;
    c.walk(&mut |x| {
        if let PExpr::Mul(a, b) = x {
            if !matches!(**a, PExpr::Const(_)) && !matches!(**b, PExpr::Const(_)) {
                found = true;
            }
        }
    });
    found
}

/// Which clauses an abstraction assumes (and its lemmas prove).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
enum Clauses {
    /// The sign-split bounds.
    Sign,
    /// The McCormick planes and the sign-split bounds.
    Full,
}

/// One clause over factor intervals `x ∈ [xl, xu]`, `y ∈ [yl, yu]` and the product `z`.
#[derive(Clone, Copy, Debug)]
enum Clause {
    /// McCormick plane 1-4.
    Plane(u8),
    /// Sign-split bound 1-4: `x ≥ 0`, `x ≤ 0`, `y ≥ 0`, `y ≤ 0`.
    Sign(u8),
}

/// One abstracted product.
struct Product {
    /// For a step product, its value (`qloop_mul_<n>`); `None` for a harness-only product.
    step: Option<ValId>,
    /// Harness-only: its number.
    n: usize,
    /// Factor and result type.
    ty: IntTy,
    x: (i128, i128),
    y: (i128, i128),
    clauses: Clauses,
    /// What it multiplies, for docs and messages.
    what: String,
    /// Calls of it in the step: one, or one per index of a shared loop body.
    calls: usize,
}

impl Product {
    /// The function it abstracts: `qloop_mul_<n>` of the step or `exact_prod_<n>`.
    fn label(&self) -> String {
        match self.step {
            Some(v) => format!("qloop_mul_{}", v.0),
            None => format!("exact_prod_{}", self.n),
        }
    }

    /// The tag of its abstraction (`abs_<tag>`) and lemmas (`lemma_<tag>_*`): `mul_<n>` or
    /// `prod_<n>`.
    fn tag(&self) -> String {
        match self.step {
            Some(v) => format!("mul_{}", v.0),
            None => format!("prod_{}", self.n),
        }
    }

    /// `[xl, xu] × [yl, yu]`.
    fn factor_box(&self) -> String {
        format!(
            "[{}, {}] × [{}, {}]",
            self.x.0, self.x.1, self.y.0, self.y.1
        )
    }

    /// The clauses it assumes, in words.
    fn clauses_text(&self) -> &'static str {
        match self.clauses {
            Clauses::Full => "McCormick planes and sign-split bounds",
            Clauses::Sign => "sign-split bounds",
        }
    }
}

/// A step product's factors as atoms (a state read before any store to it, or an input).
struct StepFactors {
    val: ValId,
    a: Option<SigId>,
    b: Option<SigId>,
    /// Its abstraction in [`Abstraction::products`]: the first copy's product where a loop
    /// body is shared.
    product: usize,
}

/// The products of one harness module.
pub(super) struct Abstraction<'p> {
    plan: &'p Plan,
    /// The fixed-point module's name.
    ctl: Ident,
    step: Vec<StepFactors>,
    products: Vec<Product>,
    /// The current property's parameter substitutions: index → (state, shift, d interval).
    subst: BTreeMap<usize, (SigId, u32, i128, i128)>,
    /// The current property's parameter names.
    param_names: Vec<String>,
    /// The invariants' conditions over `pre`, products abstracted, once the first property
    /// harness needed them: emitted once as `invariants_abstracted` and called by every
    /// abstracted harness (they read no parameter, so every harness's are the same).
    invariants: Option<Vec<TokenStream>>,
}

impl<'p> Abstraction<'p> {
    /// The step's products of `plan`, none used yet.
    ///
    /// `em` says which products a shared loop body computes for all its indices: those are
    /// one function of the module (the first copy's), with one abstraction over the hull of
    /// the copies' factor intervals (`em.plan`'s, which `plan` must be).
    pub(super) fn new(plan: &'p Plan, em: &Emit) -> Abstraction<'p> {
        let mut step = Vec::new();
        step_factors(plan, &plan.body, &mut HashSet::new(), &mut step);
        let mut products: Vec<Product> = Vec::new();
        for f in &mut step {
            let rep = em.representative(f.val);
            if let Some(i) = products.iter().position(|p| p.step == Some(rep)) {
                products[i].calls += 1;
                f.product = i;
                continue;
            }
            let v = plan.val(rep);
            let Op::Mul(a, b) = v.op else {
                unreachable!("a var product is a Mul")
            };
            let (va, vb) = (plan.val(a), plan.val(b));
            f.product = products.len();
            products.push(Product {
                step: Some(rep),
                n: 0,
                ty: v.ty,
                x: (va.lo, va.hi),
                y: (vb.lo, vb.hi),
                clauses: Clauses::Sign,
                what: format!(
                    "the step's `{} * {}`",
                    factor_name(plan, f.a, a),
                    factor_name(plan, f.b, b)
                ),
                calls: 1,
            });
        }
        Abstraction {
            plan,
            ctl: format_ident!("{}", plan.prog.name),
            step,
            products,
            subst: BTreeMap::new(),
            param_names: Vec::new(),
            invariants: None,
        }
    }

    /// Whether the invariants' abstracted conditions have been recorded.
    pub(super) fn has_invariants(&self) -> bool {
        self.invariants.is_some()
    }

    /// Records the invariants' abstracted conditions (`pre.<state>` terms), for
    /// `invariants_abstracted`.
    pub(super) fn set_invariants(&mut self, conds: Vec<TokenStream>) {
        self.invariants = Some(conds);
    }

    /// Sets the parameter substitutions and names of the property about to be evaluated.
    pub(super) fn set_params(
        &mut self,
        subst: BTreeMap<usize, (SigId, u32, i128, i128)>,
        names: &[String],
    ) {
        self.subst = subst;
        self.param_names = names.to_vec();
    }

    /// The `kani::stub` arguments: each step product and its abstraction.
    pub(super) fn stubs(&self) -> Vec<TokenStream> {
        let ctl = &self.ctl;
        self.products
            .iter()
            .filter(|p| p.step.is_some())
            .map(|p| {
                let (f, a) = (
                    format_ident!("{}", p.label()),
                    format_ident!("abs_{}", p.tag()),
                );
                quote! { super::#ctl::#f, #a }
            })
            .collect()
    }

    /// The `i128` expression of the product of `a` and `b` (neither constant), rewritten onto
    /// the abstractions.
    pub(super) fn product(&mut self, a: &Ev, b: &Ev) -> Result<TokenStream, String> {
        if let (Some(Atom::Pre(x)), Some(Atom::Pre(y))) = (a.atom, b.atom) {
            if let Some(call) = self.base(x, y, &a.t, &b.t) {
                return Ok(call);
            }
        }
        for (p, q) in [(a, b), (b, a)] {
            let (Some(pa), Some(Atom::Pre(y))) = (p.atom, q.atom) else {
                continue;
            };
            let (pt, qt) = (&p.t, &q.t);
            match pa {
                Atom::Post(x) if self.plan.prog.sig(x).kind == SigKind::State => {
                    let pre = format_ident!("pre");
                    let xn = format_ident!("{}", self.plan.prog.sig(x).name);
                    let pre_x = quote! { #pre.#xn };
                    let Some(base) = self.base(x, y, &pre_x, qt) else {
                        continue;
                    };
                    let (lo, hi) = self.plan.bounds(x);
                    let d = quote! { (#pt - #pre_x) };
                    let what = format!(
                        "(next({0}) − {0}) · {1}",
                        self.plan.prog.sig(x).name,
                        self.plan.prog.sig(y).name
                    );
                    let delta = self.extra(
                        (lo - hi, hi - lo),
                        (q.lo, q.hi),
                        Clauses::Sign,
                        &d,
                        qt,
                        what,
                    )?;
                    let s = self.plan.prog.sig(x);
                    if s.range.is_some() && !s.unsaturated {
                        let (l, h) = (lit(lo), lit(hi));
                        return Ok(quote! {
                            (if #pt == #l { #l * #qt } else if #pt == #h { #h * #qt } else { #base + #delta })
                        });
                    }
                    return Ok(quote! { (#base + #delta) });
                }
                Atom::Param(i) => {
                    let Some(&(s, shift, dlo, dhi)) = self.subst.get(&i) else {
                        continue;
                    };
                    let pre = format_ident!("pre");
                    let sn = format_ident!("{}", self.plan.prog.sig(s).name);
                    let pre_s = quote! { #pre.#sn };
                    let Some(base) = self.base(s, y, &pre_s, qt) else {
                        continue;
                    };
                    let k = Literal::u32_unsuffixed(shift);
                    let (scaled_s, scaled_base) = if shift == 0 {
                        (pre_s.clone(), base)
                    } else {
                        (quote! { (#pre_s << #k) }, quote! { (#base << #k) })
                    };
                    let d = quote! { (#pt - #scaled_s) };
                    let what = format!(
                        "({} − {}) · {}",
                        self.param_names.get(i).map_or("parameter", String::as_str),
                        self.plan.prog.sig(s).name,
                        self.plan.prog.sig(y).name
                    );
                    let delta =
                        self.extra((dlo, dhi), (q.lo, q.hi), Clauses::Sign, &d, qt, what)?;
                    return Ok(quote! { (#scaled_base + #delta) });
                }
                _ => {}
            }
        }
        let what = "a product of the property".to_string();
        self.extra((a.lo, a.hi), (b.lo, b.hi), Clauses::Full, &a.t, &b.t, what)
    }

    /// The call of the step product of pre-step values `x` and `y` (either order), with the
    /// step's argument order, if the step computes it; it then assumes every clause.
    fn base(
        &mut self,
        x: SigId,
        y: SigId,
        tx: &TokenStream,
        ty: &TokenStream,
    ) -> Option<TokenStream> {
        let i = self
            .step
            .iter()
            .position(|f| (f.a, f.b) == (Some(x), Some(y)) || (f.a, f.b) == (Some(y), Some(x)))?;
        let (t1, t2) = if self.step[i].a == Some(x) {
            (tx, ty)
        } else {
            (ty, tx)
        };
        let p = &mut self.products[self.step[i].product];
        p.clauses = Clauses::Full;
        let f = format_ident!("abs_{}", p.tag());
        let t = ty_tokens(p.ty);
        Some(quote! { i128::from(#f(#t1 as #t, #t2 as #t)) })
    }

    /// The call of a harness-only product over `x`, `y` (shared by equal intervals).
    fn extra(
        &mut self,
        x: (i128, i128),
        y: (i128, i128),
        clauses: Clauses,
        tx: &TokenStream,
        ty: &TokenStream,
        what: String,
    ) -> Result<TokenStream, String> {
        let m = mag(x).checked_mul(mag(y)).unwrap_or(i128::MAX);
        let int = if m < 1i128 << 60 {
            IntTy::signed(64)
        } else if m < 1i128 << 124 {
            IntTy::signed(128)
        } else {
            return Err(format!("the product {what} can exceed 2^124"));
        };
        let found = self
            .products
            .iter()
            .position(|p| p.step.is_none() && p.x == x && p.y == y);
        let i = match found {
            Some(i) => i,
            None => {
                let n = self.products.iter().filter(|p| p.step.is_none()).count();
                self.products.push(Product {
                    step: None,
                    n,
                    ty: int,
                    x,
                    y,
                    clauses,
                    what,
                    calls: 1,
                });
                self.products.len() - 1
            }
        };
        let p = &mut self.products[i];
        p.clauses = p.clauses.max(clauses);
        let f = format_ident!("abs_{}", p.tag());
        let t = ty_tokens(p.ty);
        Ok(quote! { i128::from(#f(#tx as #t, #ty as #t)) })
    }

    /// The abstractions, their memo slots, the harness-only exact products and the lemma
    /// harnesses.
    pub(super) fn items(&self) -> TokenStream {
        let ctl = &self.ctl;
        let mut out = TokenStream::new();
        if let Some(conds) = &self.invariants {
            out.extend(quote! {
                /// Whether every invariant holds of `pre`, products abstracted: the premise
                /// of every abstracted property harness (Kani only).
                #[cfg(kani)]
                fn invariants_abstracted(pre: &StateRaw) -> bool {
                    #(
                        if !(#conds) {
                            return false;
                        }
                    )*
                    true
                }
            });
        }
        for p in &self.products {
            let t = ty_tokens(p.ty);
            let (label, tag) = (p.label(), p.tag());
            let abs = format_ident!("abs_{tag}");
            let memo = format_ident!("MEMO_{}", tag.to_uppercase());
            let f = format_ident!("{label}");
            let real = match p.step {
                Some(_) => quote! { super::#ctl::#f },
                None => {
                    let d = spaced(&format!(
                        "Harness-only product {}: exact multiplication, abstracted by `{abs}`.",
                        p.what
                    ));
                    out.extend(quote! {
                        #[doc = #d]
                        #[cfg(kani)]
                        fn #f(a: #t, b: #t) -> #t {
                            a * b
                        }
                    });
                    quote! { #f }
                }
            };
            let w = wide(p);
            let clauses = clause_list(p);
            let assumes = clauses.iter().map(|&c| {
                let e = clause(c, p);
                quote! { kani::assume(#e); }
            });
            let (xl, xu, yl, yu) = (lit(p.x.0), lit(p.x.1), lit(p.y.0), lit(p.y.1));
            let msg_a = format!(
                "{label} ({}): factor 1 outside [{}, {}] (raw), the interval its clauses hold on",
                p.what, p.x.0, p.x.1
            );
            let msg_b = format!(
                "{label} ({}): factor 2 outside [{}, {}] (raw), the interval its clauses hold on",
                p.what, p.y.0, p.y.1
            );
            let doc = spaced(&format!(
                "Abstraction of `{label}` ({}): asserts the factors inside {} (raw) and returns \
                 a value satisfying the {}, each proved by a `lemma_{}_*` harness; equal \
                 factors give the same value ({}).",
                p.what,
                p.factor_box(),
                p.clauses_text(),
                tag,
                if p.calls == 1 {
                    "the last call is remembered".to_string()
                } else {
                    format!(
                        "the first {} distinct calls are remembered, one per index of the shared \
                         loop body",
                        p.calls
                    )
                }
            ));
            // The memo: the last call's arguments and value, or (one call per index of a
            // shared loop body) a slot per call, so that the property's product meets the
            // step's of its own index. Only the memo differs between the two.
            let (decl, lookup, remember) = if p.calls == 1 {
                (
                    quote! { static mut #memo: Option<(#t, #t, #t)> = None; },
                    quote! {
                        if let Some((x, y, r)) = unsafe { #memo } {
                            if x == a && y == b {
                                return r;
                            }
                        }
                    },
                    quote! {
                        unsafe {
                            #memo = Some((a, b, r));
                        }
                    },
                )
            } else {
                let n = Literal::usize_unsuffixed(p.calls);
                (
                    quote! { static mut #memo: [Option<(#t, #t, #t)>; #n] = [None; #n]; },
                    quote! {
                        let memo = unsafe { &mut *::core::ptr::addr_of_mut!(#memo) };
                        for (x, y, r) in memo.iter().flatten() {
                            if *x == a && *y == b {
                                return *r;
                            }
                        }
                    },
                    quote! {
                        if let Some(slot) = memo.iter_mut().find(|s| s.is_none()) {
                            *slot = Some((a, b, r));
                        }
                    },
                )
            };
            out.extend(quote! {
                #[cfg(kani)]
                #decl
                #[doc = #doc]
                #[cfg(kani)]
                fn #abs(a: #t, b: #t) -> #t {
                    kani::assert((#xl..=#xu).contains(&a), #msg_a);
                    kani::assert((#yl..=#yu).contains(&b), #msg_b);
                    #lookup
                    let r: #t = kani::any();
                    let (x, y, z) = (a as #w, b as #w, r as #w);
                    #(#assumes)*
                    #remember
                    r
                }
            });
            for c in clauses {
                let name = format_ident!("lemma_{}_{}", tag, clause_name(c));
                let e = clause(c, p);
                let text = clause_text(c, p);
                let msg = format!("{label} ({}): {text} fails", p.what);
                let doc = spaced(&format!(
                    "Lemma: for factors in {} (raw), `{label}` satisfies {text} (assumed by \
                     `abs_{}`).",
                    p.factor_box(),
                    tag
                ));
                out.extend(quote! {
                    #[doc = #doc]
                    #[cfg(kani)]
                    #[kani::solver(kissat)]
                    #[kani::proof]
                    fn #name() {
                        let a: #t = kani::any();
                        let b: #t = kani::any();
                        kani::assume((#xl..=#xu).contains(&a) && (#yl..=#yu).contains(&b));
                        let r = #real(a, b);
                        let (x, y, z) = (a as #w, b as #w, r as #w);
                        kani::assert(#e, #msg);
                    }
                });
            }
        }
        out
    }

    /// One line per abstraction, for the module doc.
    pub(super) fn summary(&self) -> Vec<String> {
        self.products
            .iter()
            .map(|p| {
                let name = format!("`{}`", p.label());
                format!(
                    "{name}, {}: {} (raw), {} ({} lemma harnesses)",
                    p.what,
                    p.factor_box(),
                    p.clauses_text(),
                    clause_list(p).len()
                )
            })
            .collect()
    }
}

/// The step's products, in order, with their factors as atoms where a factor is an input's
/// entry value or a state read before any store to it.
fn step_factors(
    plan: &Plan,
    stmts: &[LStmt],
    stored: &mut HashSet<SigId>,
    out: &mut Vec<StepFactors>,
) {
    for s in stmts {
        match s {
            LStmt::Def(id) => {
                if plan.is_var_product(*id) && !out.iter().any(|f| f.val == *id) {
                    let Op::Mul(a, b) = plan.val(*id).op else {
                        continue;
                    };
                    out.push(StepFactors {
                        val: *id,
                        a: atom_of(plan, a, stored),
                        b: atom_of(plan, b, stored),
                        product: 0,
                    });
                }
            }
            LStmt::Store(sig, _) => {
                stored.insert(*sig);
            }
            LStmt::If(_, t, e) => {
                let mut st = stored.clone();
                step_factors(plan, t, &mut st, out);
                let mut se = stored.clone();
                step_factors(plan, e, &mut se, out);
                stored.extend(st);
                stored.extend(se);
            }
        }
    }
}

/// The signal whose pre-step value `v` is, through widening casts: a state loaded before any
/// store to it, or an input's entry value (equal to the raw input inside its declared range,
/// which every abstracted harness assumes).
fn atom_of(plan: &Plan, v: ValId, stored: &HashSet<SigId>) -> Option<SigId> {
    let val = plan.val(v);
    if let Some(name) = &val.name {
        let s = plan.prog.signals.iter().position(|s| &s.name == name)?;
        let id = SigId(s);
        return (plan.prog.sig(id).kind == SigKind::Input).then_some(id);
    }
    match val.op {
        Op::Cast(a) => {
            let inner = plan.val(a);
            if val.ty.holds(inner.ty.min(), inner.ty.max()) {
                atom_of(plan, a, stored)
            } else {
                None
            }
        }
        Op::Load(id) if plan.prog.sig(id).kind == SigKind::State && !stored.contains(&id) => {
            Some(id)
        }
        _ => None,
    }
}

/// A factor for docs: the signal it reads (a state the step has already updated says so), a
/// `let`'s name, or the value's number.
fn factor_name(plan: &Plan, atom: Option<SigId>, v: ValId) -> String {
    if let Some(s) = atom {
        return plan.prog.sig(s).name.clone();
    }
    let mut x = v;
    loop {
        let val = plan.val(x);
        if let Some(n) = &val.name {
            return n.clone();
        }
        match val.op {
            Op::Cast(a) => x = a,
            Op::Load(id) => return format!("{} (as updated)", plan.prog.sig(id).name),
            _ => return format!("_{}", v.0),
        }
    }
}

fn mag((lo, hi): (i128, i128)) -> i128 {
    lo.checked_abs()
        .unwrap_or(i128::MAX)
        .max(hi.checked_abs().unwrap_or(i128::MAX))
}

/// The integer type the clauses are evaluated in: `i64` where three corner products and the
/// product itself cannot reach 2^63, else `i128`.
fn wide(p: &Product) -> TokenStream {
    let m = mag(p.x).checked_mul(mag(p.y)).unwrap_or(i128::MAX);
    let z = mag((p.ty.min(), p.ty.max()));
    if m < 1i128 << 60 && z < 1i128 << 60 {
        quote! { i64 }
    } else {
        quote! { i128 }
    }
}

fn ty_tokens(t: IntTy) -> TokenStream {
    let i = format_ident!("{}", t.rust_name());
    quote! { #i }
}

fn lit(v: i128) -> TokenStream {
    let l = Literal::i128_unsuffixed(v.abs());
    if v < 0 {
        quote! { (-#l) }
    } else {
        quote! { #l }
    }
}

/// The clauses `p` assumes: the planes for [`Clauses::Full`], and each sign-split bound whose
/// premise some factor value meets.
fn clause_list(p: &Product) -> Vec<Clause> {
    let mut out = Vec::new();
    if p.clauses == Clauses::Full {
        out.extend((1..=4).map(Clause::Plane));
    }
    if p.x.1 >= 0 {
        out.push(Clause::Sign(1));
    }
    if p.x.0 <= 0 {
        out.push(Clause::Sign(2));
    }
    if p.y.1 >= 0 {
        out.push(Clause::Sign(3));
    }
    if p.y.0 <= 0 {
        out.push(Clause::Sign(4));
    }
    out
}

fn clause_name(c: Clause) -> String {
    match c {
        Clause::Plane(k) => format!("plane_{k}"),
        Clause::Sign(k) => format!("sign_{k}"),
    }
}

/// The clause as a `bool` expression over `x`, `y`, `z`.
fn clause(c: Clause, p: &Product) -> TokenStream {
    let (xl, xu, yl, yu) = (lit(p.x.0), lit(p.x.1), lit(p.y.0), lit(p.y.1));
    let (cxl, cxu) = (lit(p.x.0 * p.y.0), lit(p.x.1 * p.y.1));
    let (cxuyl, cxlyu) = (lit(p.x.1 * p.y.0), lit(p.x.0 * p.y.1));
    match c {
        Clause::Plane(1) => quote! { z >= #xl * y + x * #yl - #cxl },
        Clause::Plane(2) => quote! { z >= #xu * y + x * #yu - #cxu },
        Clause::Plane(3) => quote! { z <= #xu * y + x * #yl - #cxuyl },
        Clause::Plane(_) => quote! { z <= #xl * y + x * #yu - #cxlyu },
        Clause::Sign(1) => quote! { x < 0 || (#yl * x <= z && z <= #yu * x) },
        Clause::Sign(2) => quote! { x > 0 || (#yu * x <= z && z <= #yl * x) },
        Clause::Sign(3) => quote! { y < 0 || (#xl * y <= z && z <= #xu * y) },
        Clause::Sign(_) => quote! { y > 0 || (#xu * y <= z && z <= #xl * y) },
    }
}

/// The clause in words, for messages and docs.
fn clause_text(c: Clause, p: &Product) -> String {
    let (xl, xu, yl, yu) = (p.x.0, p.x.1, p.y.0, p.y.1);
    match c {
        Clause::Plane(1) => format!("McCormick plane (x − {xl})(y − {yl}) ≥ 0"),
        Clause::Plane(2) => format!("McCormick plane ({xu} − x)({yu} − y) ≥ 0"),
        Clause::Plane(3) => format!("McCormick plane ({xu} − x)(y − {yl}) ≥ 0"),
        Clause::Plane(_) => format!("McCormick plane (x − {xl})({yu} − y) ≥ 0"),
        Clause::Sign(1) => format!("sign bound x ≥ 0 ⇒ {yl}·x ≤ x·y ≤ {yu}·x"),
        Clause::Sign(2) => format!("sign bound x ≤ 0 ⇒ {yu}·x ≤ x·y ≤ {yl}·x"),
        Clause::Sign(3) => format!("sign bound y ≥ 0 ⇒ {xl}·y ≤ x·y ≤ {xu}·y"),
        Clause::Sign(_) => format!("sign bound y ≤ 0 ⇒ {xu}·y ≤ x·y ≤ {xl}·y"),
    }
}
