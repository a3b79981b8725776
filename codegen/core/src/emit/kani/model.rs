//! The exact-term model of one step, for the property harnesses whose conditions multiply
//! two non-constant values (such as the gain-loop and estimator contractions): under Kani,
//! such a property is checked on a model of the step instead of the step itself, with every
//! product replaced by its verified contract.
//!
//! The model is the step's exact terms ([`crate::terms`]): products distributed over sums,
//! `ite`s and the parameter substitution `p = s·2^k + D`, so that a post-state product such
//! as `next(kc)·km` reads `kc·km + Δ·km` and shares `kc·km` with the step. Every distinct
//! product of two non-constant terms is a function `prod_<n>` (one per pair of factor
//! intervals, shared by the models) whose contract (under `cfg(kani)`) requires each factor
//! inside its interval and ensures the linear facts of exact multiplication over those
//! intervals that the SMT linear-envelope encoding of `qloop prove` uses: the four McCormick
//! planes (`(x − xₗ)(y − yₗ) ≥ 0` and the like) and the sign-split bounds (for a factor `x`
//! and the other's interval `[l, h]`, `x ≥ 0 ⇒ l·x ≤ x·y ≤ h·x`, `x ≤ 0 ⇒ h·x ≤ x·y ≤ l·x`).
//! Without the McCormick planes the 1981 gain-loop contraction fails spuriously where `K_c`
//! saturates.
//!
//! The chain of assumptions, each link a harness:
//! * `contract_prod_*` (`proof_for_contract`): the body, exact multiplication, meets the
//!   contract for every pair of factors inside the intervals;
//! * `model_matches_<property>`: for inputs inside their declared ranges, states inside their
//!   bounds and parameters on their grid, the model (products exact) computes the values the
//!   property reads after the step as the generated `step` does, bit for bit. CBMC's SAT
//!   back-end does not see that two multipliers of the same operands are equal (a single such
//!   equality took it over 200 s); an SMT solver's word-level rewriting does, so this harness
//!   runs on cvc5 (`kani::solver(cvc5)`);
//! * `property_*` (`stub_verified` on the products): the property holds on the model for
//!   every product value its contract allows, the exact ones among them.

use super::show::{i128_lit, param_fields, param_lets, spaced};
use super::LIMIT_BITS;
use crate::ir::{CmpOp, SigId, SigKind};
use crate::lower::Plan;
use crate::prop_eval::ParamGrid;
use crate::terms::{self, param_shift, param_state_pairs, PropTerms, Ranges, Terms, B, T};
use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote};
use std::collections::HashMap;
use std::rc::Rc;

/// The model of property `k`: its function, its product functions with their contract
/// harnesses, and what the property harness needs to call it.
pub(super) struct Model {
    /// The model function.
    pub items: TokenStream,
    /// The model function's name.
    pub func: Ident,
    /// The product functions it calls, to be `stub_verified` in the property harness.
    pub prods: Vec<Ident>,
}

/// The exact terms of one step for the property models: states inside their bounds and
/// inputs inside their declared ranges (the premises every property harness assumes).
fn step_terms(plan: &Plan) -> Terms {
    terms::terms(plan, &|id: SigId| {
        let q = plan.format(id);
        match plan.prog.sig(id).kind {
            SigKind::State | SigKind::Input => plan.bounds(id),
            _ => (q.ty.min(), q.ty.max()),
        }
    })
}

/// The model of property `k`, or `None` when its conditions multiply no two non-constant
/// terms (the direct harness decides those quickly). `Err` when a term could exceed
/// 2^[`LIMIT_BITS`].
pub(super) fn model(
    plan: &Plan,
    k: usize,
    grids: &[ParamGrid],
    prods: &mut Products,
) -> Option<Result<Model, String>> {
    let prog = &plan.prog;
    let p = &prog.properties[k];
    if !p.assumes.iter().chain(&p.ensures).any(multiplies) {
        return None;
    }
    let terms = step_terms(plan);
    let subst = param_state_pairs(plan, &p.assumes, &p.ensures);
    let mut pr = Printer::new();
    // Parameters: a free parameter compared with a state is `s·2^shift + D` (D a variable),
    // the others are variables over their grid.
    let mut params_t: Vec<(Rc<T>, i32)> = Vec::new();
    let mut d_defs = Vec::new();
    for (i, g) in grids.iter().enumerate() {
        let pv = format_ident!("param_{}", p.params[i].name);
        pr.vars.insert(g.var.clone(), quote! { #pv });
        let shifted = subst
            .get(&i)
            .and_then(|&s| Some((s, param_shift(plan, g, s, plan.bounds(s))?)));
        match shifted {
            Some((s, (shift, dlo, dhi))) => {
                let dname = format!("d_{}", g.var);
                let d = Rc::new(T::Var(dname.clone(), 0, true, dlo, dhi));
                let dv = format_ident!("d_{}", p.params[i].name);
                let sn = format_ident!("{}", prog.sig(s).name);
                d_defs.push(quote! { let #dv: i128 = #pv - (pre.#sn << #shift); });
                pr.vars.insert(dname, quote! { #dv });
                let t = terms::add(terms::shl(terms.pre[&s].clone(), shift), d);
                params_t.push((t, g.frac));
            }
            None => {
                let var = Rc::new(T::Var(g.var.clone(), g.width, true, g.lo, g.hi));
                params_t.push((var, g.frac));
            }
        }
    }
    for (id, t) in &terms.pre {
        let s = prog.sig(*id);
        let n = format_ident!("{}", s.name);
        let e = match s.kind {
            SigKind::Input => quote! { inputs.#n },
            _ => quote! { pre.#n },
        };
        if let T::Var(name, ..) = &**t {
            pr.vars.insert(name.clone(), e);
        }
    }
    let env = PropTerms {
        plan,
        terms: &terms,
        params: params_t,
        pre_as_post: false,
    };
    // The roots: invariants and assumes (premises), each ensure's conjuncts (goals).
    let mut premises = Vec::new();
    for inv in &prog.invariants {
        premises.push(env.cond(&inv.cond)?);
    }
    for a in &p.assumes {
        premises.push(env.cond(a)?);
    }
    let goals: Option<Vec<Rc<B>>> = p
        .ensures
        .iter()
        .flat_map(super::show::conjuncts)
        .map(|c| env.cond(c))
        .collect();
    let goals = goals?;
    let roots = Roots {
        premises,
        goals,
        d_defs,
    };
    Some(emit(plan, k, &terms, pr, roots, prods))
}

/// What a model computes besides the post-step values: its premises (invariants, `assume`s),
/// its goals (the conjuncts of the `ensure`s), and the definitions of the substituted
/// parameters' `D` variables.
struct Roots {
    premises: Vec<Rc<B>>,
    goals: Vec<Rc<B>>,
    d_defs: Vec<TokenStream>,
}

/// Prints the model function and its products.
fn emit(
    plan: &Plan,
    k: usize,
    terms: &Terms,
    mut pr: Printer,
    roots: Roots,
    prods: &mut Products,
) -> Result<Model, String> {
    let Roots {
        premises,
        goals,
        d_defs,
    } = roots;
    let prog = &plan.prog;
    let p = &prog.properties[k];
    // Only the values the property reads after the step: the rest of the step is not
    // modelled (and not checked by `model_matches_*`).
    let read = read_after(plan, k);
    let after: Vec<TokenStream> = read
        .iter()
        .map(|id| pr.term(&terms.post[id], prods))
        .collect::<Result<_, String>>()?;
    let n_after = after.len();
    let prem: Vec<TokenStream> = premises
        .iter()
        .map(|b| pr.boolean(b, prods))
        .collect::<Result<_, String>>()?;
    let goal: Vec<TokenStream> = goals
        .iter()
        .map(|b| pr.boolean(b, prods))
        .collect::<Result<_, String>>()?;
    let prem = if prem.is_empty() {
        quote! { true }
    } else {
        quote! { #(#prem)&&* }
    };
    let n_goals = goal.len();
    let func = format_ident!("model_{}", p.name);
    let params = p.params.iter().map(|fp| format_ident!("param_{}", fp.name));
    let lets = &pr.lets;
    let doc = spaced(&format!(
        "The exact-term model of one step for property `{}`: the values it reads after the \
         step ({}, raw), whether the premises hold (invariants and `assume`s), and each \
         conjunct of the `ensure`s.",
        p.name,
        read.iter()
            .map(|id| format!("`{}`", prog.sig(*id).name))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    let items = quote! {
        #[doc = #doc]
        fn #func(inputs: &InputRaw, pre: &StateRaw, #(#params: i128),*)
            -> ([i128; #n_after], bool, [bool; #n_goals])
        {
            #(#d_defs)*
            #(#lets)*
            ([#(#after),*], #prem, [#(#goal),*])
        }
    };
    Ok(Model {
        items,
        func,
        prods: pr.used,
    })
}

/// Whether a condition multiplies two non-constant expressions: the properties whose
/// direct harness makes CBMC relate products it computes twice.
fn multiplies(c: &crate::ir::PCond) -> bool {
    use crate::ir::PExpr;
    let mut found = false;
    c.walk(&mut |e| {
        if let PExpr::Mul(a, b) = e {
            if !matches!(**a, PExpr::Const(_)) && !matches!(**b, PExpr::Const(_)) {
                found = true;
            }
        }
    });
    found
}

/// One product function: its name and the intervals of its factors.
struct Prod {
    name: Ident,
    a: (i128, i128),
    b: (i128, i128),
}

/// The product functions of all models of a spec, one per pair of factor intervals (the
/// contract depends on nothing else), so that each contract is verified once.
#[derive(Default)]
pub(super) struct Products {
    list: Vec<Prod>,
}

impl Products {
    /// The function for factors in `a` and `b`, added if new.
    fn get(&mut self, a: (i128, i128), b: (i128, i128)) -> Ident {
        if let Some(p) = self.list.iter().find(|p| p.a == a && p.b == b) {
            return p.name.clone();
        }
        let name = format_ident!("prod_{}", self.list.len());
        self.list.push(Prod {
            name: name.clone(),
            a,
            b,
        });
        name
    }

    /// Every product function with its contract and `proof_for_contract` harness.
    pub(super) fn items(&self) -> TokenStream {
        let items = self.list.iter().map(Prod::items);
        quote! { #(#items)* }
    }
}

impl Prod {
    /// The function, its contract (under `cfg(kani)`) and its `proof_for_contract` harness.
    fn items(&self) -> TokenStream {
        let name = &self.name;
        let check = format_ident!("contract_{}", name);
        let ((al, ah), (bl, bh)) = (self.a, self.b);
        let [al_, ah_, bl_, bh_] = [al, ah, bl, bh].map(i128_lit);
        // x ≥ 0 ⇒ l·x ≤ r ≤ h·x; x ≤ 0 ⇒ h·x ≤ r ≤ l·x, for each factor x.
        let split = |x: TokenStream, l: &TokenStream, h: &TokenStream| {
            quote! {
                (#x < 0 || (#l * #x <= *r && *r <= #h * #x))
                    && (#x > 0 || (#h * #x <= *r && *r <= #l * #x))
            }
        };
        let sa = split(quote! { a }, &bl_, &bh_);
        let sb = split(quote! { b }, &al_, &ah_);
        // McCormick: (a − al)(b − bl) ≥ 0 and (ah − a)(bh − b) ≥ 0 bound r below,
        // (a − al)(bh − b) ≥ 0 and (ah − a)(b − bl) ≥ 0 above.
        let plane = |ka: i128, kb: i128, c: i128| {
            let (ka, kb, c) = (i128_lit(ka), i128_lit(kb), i128_lit(c));
            quote! { #ka * a + #kb * b + #c }
        };
        let lo1 = plane(bl, al, -al * bl);
        let lo2 = plane(bh, ah, -ah * bh);
        let hi1 = plane(bh, al, -al * bh);
        let hi2 = plane(bl, ah, -ah * bl);
        // The narrowest type holding the factors and the product: the contract's proof
        // multiplies in it.
        let big = [al, ah, bl, bh, al * bl, al * bh, ah * bl, ah * bh]
            .iter()
            .map(|v| v.unsigned_abs())
            .max()
            .unwrap_or(0);
        let body = if big < 1u128 << 31 {
            quote! { i128::from((a as i32) * (b as i32)) }
        } else if big < 1u128 << 63 {
            quote! { i128::from((a as i64) * (b as i64)) }
        } else {
            quote! { a * b }
        };
        let doc = spaced(&format!(
            "A product of the step model, `a·b` with `a` in [{al}, {ah}] and `b` in \
             [{bl}, {bh}] (raw). Under Kani its contract states the McCormick planes and the \
             sign-split bounds of exact multiplication over these intervals, verified by \
             `{check}`. The body multiplies in the narrowest type holding both factors and \
             the product; `model_matches_*` check it against the generated step."
        ));
        let cdoc = spaced(&format!(
            "`{name}` meets its contract for every pair of factors its `requires` admits."
        ));
        quote! {
            #[doc = #doc]
            #[cfg_attr(kani, kani::requires((#al_..=#ah_).contains(&a) && (#bl_..=#bh_).contains(&b)))]
            #[cfg_attr(kani, kani::ensures(|r: &i128| (#sa) && (#sb)
                && *r >= #lo1 && *r >= #lo2 && *r <= #hi1 && *r <= #hi2))]
            fn #name(a: i128, b: i128) -> i128 {
                #body
            }

            #[doc = #cdoc]
            #[cfg(kani)]
            #[kani::proof_for_contract(#name)]
            fn #check() {
                let a: i128 = kani::any();
                let b: i128 = kani::any();
                #name(a, b);
            }
        }
    }
}

/// Prints terms as `let` bindings, each distinct term once; products become calls.
struct Printer {
    /// Each variable's Rust expression.
    vars: HashMap<String, TokenStream>,
    names: HashMap<Rc<T>, TokenStream>,
    lets: Vec<TokenStream>,
    ranges: Ranges,
    /// The product functions this model calls.
    used: Vec<Ident>,
}

fn limit() -> i128 {
    1i128 << LIMIT_BITS
}

impl Printer {
    fn new() -> Printer {
        Printer {
            vars: HashMap::new(),
            names: HashMap::new(),
            lets: Vec::new(),
            ranges: Ranges::default(),
            used: Vec::new(),
        }
    }

    /// A name (or literal) for the value of `t`.
    fn term(&mut self, t: &Rc<T>, prods: &mut Products) -> Result<TokenStream, String> {
        if let Some(n) = self.names.get(t) {
            return Ok(n.clone());
        }
        let (lo, hi) = self.ranges.of(t);
        if lo < -limit() || hi > limit() {
            return Err(format!(
                "a term of the step model can exceed 2^{LIMIT_BITS} in magnitude"
            ));
        }
        let body = match &**t {
            T::Var(name, ..) => self
                .vars
                .get(name)
                .cloned()
                .ok_or_else(|| format!("the step model has no value for `{name}`"))?,
            T::Const(c) => return Ok(i128_lit(*c)),
            T::Add(a, b) => {
                let (x, y) = (self.term(a, prods)?, self.term(b, prods)?);
                quote! { #x + #y }
            }
            T::Sub(a, b) => {
                let (x, y) = (self.term(a, prods)?, self.term(b, prods)?);
                quote! { #x - #y }
            }
            T::Neg(a) => {
                let x = self.term(a, prods)?;
                quote! { -#x }
            }
            T::Mul(a, b) => {
                let (x, y) = (self.term(a, prods)?, self.term(b, prods)?);
                let (ra, rb) = (self.ranges.of(a), self.ranges.of(b));
                let name = prods.get(ra, rb);
                if !self.used.contains(&name) {
                    self.used.push(name.clone());
                }
                quote! { #name(#x, #y) }
            }
            T::Shl(a, k) => {
                let x = self.term(a, prods)?;
                quote! { #x << #k }
            }
            T::Shr(a, k) => {
                let x = self.term(a, prods)?;
                quote! { #x >> #k }
            }
            T::Ite(c, a, b) => {
                let c = self.boolean(c, prods)?;
                let (x, y) = (self.term(a, prods)?, self.term(b, prods)?);
                quote! { if #c { #x } else { #y } }
            }
            T::Sum(ts, c) => {
                // `c + k₁·x₁ − k₂·x₂ …`, a zero constant left out, unit coefficients bare.
                let mut sum: Option<TokenStream> = (*c != 0).then(|| i128_lit(*c));
                for (k, a) in ts {
                    let x = self.term(a, prods)?;
                    let mag = k.unsigned_abs() as i128;
                    let scaled = if mag == 1 {
                        x
                    } else {
                        let m = i128_lit(mag);
                        quote! { #m * #x }
                    };
                    sum = Some(match (sum, *k < 0) {
                        (None, false) => scaled,
                        (None, true) => quote! { -(#scaled) },
                        (Some(s), false) => quote! { #s + #scaled },
                        (Some(s), true) => quote! { #s - #scaled },
                    });
                }
                sum.unwrap_or_else(|| i128_lit(0))
            }
        };
        if let T::Var(..) = &**t {
            self.names.insert(t.clone(), body.clone());
            return Ok(body);
        }
        let n = format_ident!("t{}", self.lets.len());
        self.lets.push(quote! { let #n: i128 = #body; });
        let name = quote! { #n };
        self.names.insert(t.clone(), name.clone());
        Ok(name)
    }

    /// The Rust expression of a boolean term.
    fn boolean(&mut self, b: &Rc<B>, prods: &mut Products) -> Result<TokenStream, String> {
        Ok(match &**b {
            B::Cmp(op, x, y) => {
                let (x, y) = (self.term(x, prods)?, self.term(y, prods)?);
                match op {
                    CmpOp::Lt => quote! { (#x < #y) },
                    CmpOp::Le => quote! { (#x <= #y) },
                    CmpOp::Gt => quote! { (#x > #y) },
                    CmpOp::Ge => quote! { (#x >= #y) },
                    CmpOp::Eq => quote! { (#x == #y) },
                    CmpOp::Ne => quote! { (#x != #y) },
                }
            }
            B::And(x, y) => {
                let (x, y) = (self.boolean(x, prods)?, self.boolean(y, prods)?);
                quote! { (#x && #y) }
            }
            B::Or(x, y) => {
                let (x, y) = (self.boolean(x, prods)?, self.boolean(y, prods)?);
                quote! { (#x || #y) }
            }
            B::Not(x) => {
                let x = self.boolean(x, prods)?;
                quote! { (!#x) }
            }
        })
    }
}

/// `model_matches_<property>`, one per modelled property: for inputs inside their declared
/// ranges, states inside their bounds and parameters on their grid, the model with exact
/// products computes the values the property reads after the step as the generated step does.
pub(super) fn matches_harnesses(
    plan: &Plan,
    sigs: &super::sigs::Sigs,
    modelled: &[super::property::Modelled],
) -> Vec<TokenStream> {
    modelled
        .iter()
        .map(|m| matches_harness(plan, sigs, m))
        .collect()
}

fn matches_harness(
    plan: &Plan,
    sigs: &super::sigs::Sigs,
    m: &super::property::Modelled,
) -> TokenStream {
    let prog = &plan.prog;
    let (in_names, step_args, pre_from_case) =
        (&sigs.in_names, sigs.step_args(), sigs.pre_from_case());
    let (input_fields_ranged, state_fields) = (sigs.input_fields_ranged(), sigs.state_fields());
    let p = &prog.properties[m.index];
    let grids = crate::prop_eval::param_grids(plan, m.index);
    let (param_fields, params) = (param_fields(p, &grids), param_lets(p));
    let args = p.params.iter().map(|fp| format_ident!("param_{}", fp.name));
    let func = &m.func;
    let mut eqs = Vec::new();
    let read = read_after(plan, m.index);
    for (j, id) in read.iter().enumerate() {
        let sig = prog.sig(*id);
        let n = format_ident!("{}", sig.name);
        let (what, var) = match sig.kind {
            SigKind::State => ("state", quote! { post }),
            _ => ("output", quote! { outputs }),
        };
        let literal = format!("model `{func}`: {what} `{n}` differs from the step's");
        let fmt = format!("{literal}: {{}} vs {{}}");
        let check = super::show::check(
            &quote! { holds },
            &literal,
            &fmt,
            quote! { after[#j], #var.#n },
        );
        eqs.push(quote! {
            let holds = after[#j] == #var.#n;
            #check
        });
    }
    let fname = format_ident!("model_matches_{}", p.name);
    let shown = read
        .iter()
        .map(|id| format!("`{}`", prog.sig(*id).name))
        .collect::<Vec<_>>()
        .join(", ");
    let doc = spaced(&format!(
        "The step model of property `{}` is the generated step: for inputs inside their \
         declared ranges, states inside their bounds and any parameter values, `{func}` \
         computes, with exact products, the values after the step that the property reads \
         ({shown}) as `{}::Controller::step` does, bit for bit (the model computes no other \
         post-step value). `property_{}` assumes this under Kani.\n\nIt runs on \
         CBMC's SMT back-end (`kani::solver(cvc5)`): the model and the step multiply the same \
         operands, which a SAT solver cannot match up bit by bit and an SMT solver's \
         word-level rewriting can.",
        p.name, prog.name, p.name
    ));
    quote! {
        #[doc = #doc]
        #[test]
        #[cfg_attr(kani, kani::proof)]
        #[cfg_attr(kani, kani::solver(cvc5))]
        fn #fname() {
            /// Inputs inside their declared ranges, states inside their bounds, parameters
            /// on their grids (raw).
            #[derive(Clone, Copy, Debug, bolero::TypeGenerator)]
            struct Case { #(#input_fields_ranged)* #(#state_fields)* #(#param_fields)* }
            bolero::check!()
                .with_type::<Case>()
                .with_iterations(CASES)
                .for_each(|c: &Case| {
                    let inputs = inputs_raw(#(c.#in_names),*);
                    let pre = #pre_from_case;
                    if !(inputs_in_range(&inputs) && in_bounds(&pre)) {
                        return;
                    }
                    #(#params)*
                    let (post, outputs) = step(#step_args);
                    let (after, _, _) = #func(&inputs, &pre, #(#args),*);
                    #(#eqs)*
                });
        }
    }
}

/// The states and outputs property `k` reads after the step (`next(s)`, outputs), in
/// declaration order.
fn read_after(plan: &Plan, k: usize) -> Vec<SigId> {
    let p = &plan.prog.properties[k];
    let mut out = std::collections::BTreeSet::new();
    for c in p.assumes.iter().chain(&p.ensures) {
        c.post_signals(&mut out, false);
    }
    out.into_iter().collect()
}
