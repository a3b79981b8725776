//! Emits the f64 reference controller: the same spec in real arithmetic.
//!
//! Semantics match [`crate::interp::step_real`]: inputs clamped to their declared ranges,
//! states (and ranged outputs) saturated to their declared ranges on every write, constants
//! exact, no rounding. The plants issue runs it beside the fixed-point controller.

use crate::ir::{Cond, Expr, Program, SigKind, Stmt};
use crate::lower::Plan;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// The generated reference module for `plan`, named `<spec>_ref`.
pub fn module(plan: &Plan) -> TokenStream {
    let prog = &plan.prog;
    let modname = format_ident!("{}_ref", prog.name);
    let doc = super::module_doc(plan, "f64 reference controller (real arithmetic)");
    let ids = |k: SigKind| prog.ids_of(k).collect::<Vec<_>>();
    let (inputs, states, outputs) = (
        ids(SigKind::Input),
        ids(SigKind::State),
        ids(SigKind::Output),
    );
    let name = |id: &crate::ir::SigId| format_ident!("{}", prog.sig(*id).name);
    let path = |id: &crate::ir::SigId| super::field_path(prog, *id);
    let members = |k: SigKind| super::members(prog, k);
    let (mi, mo, ms) = (
        members(SigKind::Input),
        members(SigKind::Output),
        members(SigKind::State),
    );
    let fields = |v: &[super::Member]| {
        v.iter()
            .map(|m| {
                let n = format_ident!("{}", m.name(prog));
                let ty = super::array_ty(m.dims(), quote! { f64 });
                let d = super::member_doc(plan, m);
                quote! { #[doc = #d] pub #n: #ty, }
            })
            .collect::<Vec<_>>()
    };
    let init_field = |m: &super::Member, g: &dyn Fn(&crate::ir::SigId) -> TokenStream| {
        let n = format_ident!("{}", m.name(prog));
        let v = super::nest(m.dims(), m.ids().iter().map(g).collect());
        quote! { #n: #v, }
    };
    let (fi, fo, fs) = (fields(&mi), fields(&mo), fields(&ms));
    let (di, ii) = super::default_impl(prog, "Inputs", &mi);
    let (do_, io) = super::default_impl(prog, "Outputs", &mo);
    let (ds, is) = super::default_impl(prog, "States", &ms);
    let raw_fields = ms.iter().map(|m| {
        let n = format_ident!("{}", m.name(prog));
        let ty = super::array_ty(m.dims(), quote! { f64 });
        quote! { #n: #ty, }
    });
    let inits: Vec<TokenStream> = ms
        .iter()
        .map(|m| init_field(m, &|id| f(prog.sig(*id).init.unwrap_or(0.0))))
        .collect();
    let getters: Vec<TokenStream> = ms
        .iter()
        .map(|m| {
            init_field(m, &|id| {
                let p = path(id);
                quote! { self.#p }
            })
        })
        .collect();
    let setters = states.iter().map(|id| {
        let p = path(id);
        let v = sat(prog, *id, quote! { s.#p });
        quote! { self.#p = #v; }
    });
    let read_inputs = inputs.iter().map(|id| {
        let (n, p) = (name(id), path(id));
        let v = sat(prog, *id, quote! { inputs.#p });
        quote! { let #n: f64 = #v; }
    });
    let load = states.iter().map(|id| {
        let (n, p) = (name(id), path(id));
        quote! { let mut #n: f64 = self.#p; }
    });
    let decl_out = outputs.iter().map(|id| {
        let n = name(id);
        quote! { let mut #n: f64 = 0.0; }
    });
    let allows = super::allowed_lints();
    let body = block(prog, &prog.body);
    let save = states.iter().map(|id| {
        let (n, p) = (name(id), path(id));
        quote! { self.#p = #n; }
    });
    let ret: Vec<TokenStream> = mo
        .iter()
        .map(|m| match m {
            // Field init shorthand, as before vectors existed.
            super::Member::Scalar(id) => {
                let n = name(id);
                quote! { #n, }
            }
            _ => init_field(m, &|id| {
                let n = name(id);
                quote! { #n }
            }),
        })
        .collect();
    let tables = super::signal_tables(plan);
    let table_fns = table_fns(prog);
    let [ni, no, ns] = [&inputs, &outputs, &states].map(|v| Literal::usize_unsuffixed(v.len()));
    let in_vals: Vec<TokenStream> = mi
        .iter()
        .map(|m| {
            init_field(m, &|id| {
                let k = inputs.iter().position(|i| i == id).unwrap_or(0);
                let k = Literal::usize_unsuffixed(k);
                quote! { i[#k] }
            })
        })
        .collect();
    let out_vals = outputs.iter().map(|id| {
        let p = path(id);
        quote! { o.#p, }
    });
    let state_vals = states.iter().map(|id| {
        let p = path(id);
        quote! { self.#p, }
    });
    // Controllers without states or inputs keep the same signatures.
    let (no_states, no_inputs) = super::unused_params(states.is_empty(), inputs.is_empty());
    quote! {
        #[doc = #doc]
        // The reference reads the spec as written: an input or `let` the step never uses is
        // an unused variable here (the fixed-point plan drops it).
        #[allow(#allows, unused_variables)]
        pub mod #modname {
            #tables

            #table_fns

            /// Inputs of one step (clamped to their declared ranges on entry).
            #[derive(Clone, Copy, Debug, #di PartialEq)]
            pub struct Inputs { #(#fi)* }
            #ii
            /// Outputs of one step.
            #[derive(Clone, Copy, Debug, #do_ PartialEq)]
            pub struct Outputs { #(#fo)* }
            #io
            /// A snapshot of the states.
            #[derive(Clone, Copy, Debug, #ds PartialEq)]
            pub struct States { #(#fs)* }
            #is
            /// The reference controller.
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct Reference { #(#raw_fields)* }
            impl Default for Reference {
                fn default() -> Self {
                    Self::new()
                }
            }
            impl Reference {
                /// The controller in its declared initial state.
                pub const fn new() -> Self {
                    Reference { #(#inits)* }
                }
                /// The current states.
                pub fn states(&self) -> States {
                    States { #(#getters)* }
                }
                /// Overwrites the states, saturating each to its declared range.
                pub fn set_states(&mut self, s: States) {
                    #no_states
                    #(#setters)*
                }
                /// The current states, in the order of [`STATES`].
                pub fn state_values(&self) -> [f64; #ns] {
                    [#(#state_vals)*]
                }
                /// [`Reference::step`] on arrays, for generic runners: inputs in the order of
                /// [`INPUTS`], outputs in the order of [`OUTPUTS`].
                pub fn step_values(&mut self, i: [f64; #ni]) -> [f64; #no] {
                    #no_inputs
                    let o = self.step(Inputs { #(#in_vals)* });
                    [#(#out_vals)*]
                }
                /// One control period in real arithmetic.
                pub fn step(&mut self, inputs: Inputs) -> Outputs {
                    #(#read_inputs)*
                    #(#load)*
                    #(#decl_out)*
                    #body
                    #(#save)*
                    Outputs { #(#ret)* }
                }
            }
        }
    }
}

fn f(v: f64) -> TokenStream {
    let l = Literal::f64_suffixed(v.abs());
    if v.is_sign_negative() && v != 0.0 {
        quote! { (-#l) }
    } else {
        quote! { #l }
    }
}

fn sat(prog: &Program, id: crate::ir::SigId, e: TokenStream) -> TokenStream {
    match prog.sig(id).range {
        Some((lo, hi)) => {
            let (lo, hi) = (f(lo), f(hi));
            quote! { (#e).max(#lo).min(#hi) }
        }
        None => e,
    }
}

/// Each table as its f64 samples and the interpolation of [`crate::ir::Table::eval`], with the
/// same operations in the same order (so the reference equals the interpreter exactly).
fn table_fns(prog: &Program) -> TokenStream {
    let items = prog.tables.iter().enumerate().map(|(i, t)| {
        let arr = format_ident!("QLOOP_SAMPLES_{}", i);
        let fname = format_ident!("qloop_table_{}", i);
        let len = Literal::usize_unsuffixed(t.samples.len());
        let last = Literal::usize_unsuffixed(t.segments() - 1);
        let vals = t.samples.iter().map(|v| f(*v));
        let (lo, hi, inv) = (f(t.lo), f(t.hi), f(1.0 / t.step));
        let doc = format!(
            " Table `{}`: linear interpolation of its samples over [{}, {}], step {}.",
            t.name,
            crate::text::g(t.lo),
            crate::text::g(t.hi),
            crate::text::g(t.step)
        );
        quote! {
            const #arr: [f64; #len] = [#(#vals),*];
            #[doc = #doc]
            fn #fname(x: f64) -> f64 {
                let x = x.max(#lo).min(#hi);
                let u = (x - #lo) * #inv;
                let i = ::core::cmp::min(u as usize, #last);
                let t = u - i as f64;
                #arr[i] + t * (#arr[i + 1] - #arr[i])
            }
        }
    });
    quote! { #(#items)* }
}

/// Operator nesting above which a subexpression is hoisted into a `let` of its own. Keeps
/// the emitted source shallow (it is re-parsed by `syn` and compiled by rustc) for long
/// chains such as a 200-term sum; the seed specs nest far less, so they read as written.
const MAX_INLINE: usize = 16;

fn block(prog: &Program, stmts: &[Stmt]) -> TokenStream {
    let parts = stmts.iter().map(|s| {
        let mut x = Exprs {
            prog,
            pre: Vec::new(),
        };
        let stmt = match s {
            Stmt::Assign { target, value, .. } => {
                let sig = prog.sig(*target);
                let n = format_ident!("{}", sig.name);
                let v = x.expr(value).0;
                if sig.kind == SigKind::Local {
                    quote! { let #n: f64 = #v; }
                } else {
                    let v = sat(prog, *target, v);
                    quote! { #n = #v; }
                }
            }
            Stmt::If { cond: c, then, els } => {
                let c = x.cond(c).0;
                let t = block(prog, then);
                if els.is_empty() {
                    quote! { if #c { #t } }
                } else {
                    let e = block(prog, els);
                    quote! { if #c { #t } else { #e } }
                }
            }
        };
        let pre = x.pre;
        quote! { #(#pre)* #stmt }
    });
    quote! { #(#parts)* }
}

/// Emits the expressions of one statement; subexpressions nested deeper than [`MAX_INLINE`]
/// become `let _rN: f64 = ..;` statements in `pre`, emitted before the statement. The
/// reference's arithmetic is pure, so evaluating a subexpression earlier changes nothing.
struct Exprs<'a> {
    prog: &'a Program,
    pre: Vec<TokenStream>,
}

impl Exprs<'_> {
    /// The expression's tokens and their nesting depth.
    fn expr(&mut self, e: &Expr) -> (TokenStream, usize) {
        let (t, d) = self.expr_inline(e);
        self.hoist(t, d, quote! { f64 })
    }

    /// `t` as it is, or, nested deeper than [`MAX_INLINE`], a `let` of type `ty` in `pre`.
    fn hoist(&mut self, t: TokenStream, d: usize, ty: TokenStream) -> (TokenStream, usize) {
        if d <= MAX_INLINE {
            return (t, d);
        }
        let tmp = format_ident!("_r{}", self.pre.len());
        self.pre.push(quote! { let #tmp: #ty = #t; });
        (quote! { #tmp }, 1)
    }

    fn expr_inline(&mut self, e: &Expr) -> (TokenStream, usize) {
        let two = |s: &mut Self, a: &Expr, b: &Expr| {
            let ((a, da), (b, db)) = (s.expr(a), s.expr(b));
            (a, b, da.max(db) + 1)
        };
        match e {
            Expr::Const { value, .. } => {
                let v = f(*value);
                (quote! { (#v) }, 1)
            }
            Expr::Var(id, _) => {
                let n = format_ident!("{}", self.prog.sig(*id).name);
                (quote! { #n }, 1)
            }
            Expr::Table(t, a, _) => {
                let (a, d) = self.expr(a);
                let fname = format_ident!("qloop_table_{}", t);
                (quote! { #fname(#a) }, d + 1)
            }
            Expr::Neg(a) => {
                let (a, d) = self.expr(a);
                (quote! { (-#a) }, d + 1)
            }
            Expr::Add(a, b) => {
                let (a, b, d) = two(self, a, b);
                (quote! { (#a + #b) }, d)
            }
            Expr::Sub(a, b) => {
                let (a, b, d) = two(self, a, b);
                (quote! { (#a - #b) }, d)
            }
            Expr::Mul(a, b, _) => {
                let (a, b, d) = two(self, a, b);
                (quote! { (#a * #b) }, d)
            }
            Expr::Min(a, b) => {
                let (a, b, d) = two(self, a, b);
                (quote! { (#a).min(#b) }, d)
            }
            Expr::Max(a, b) => {
                let (a, b, d) = two(self, a, b);
                (quote! { (#a).max(#b) }, d)
            }
            Expr::Select(c, a, b) => {
                // Evaluate the condition and both arms (as the plan does), then select.
                let (c, dc) = self.cond(c);
                let (a, b, d) = two(self, a, b);
                (
                    quote! { { let _c: bool = #c; let _a: f64 = #a; let _b: f64 = #b; if _c { _a } else { _b } } },
                    d.max(dc + 1),
                )
            }
        }
    }

    /// The condition's tokens and their nesting depth; hoisted like [`Self::expr`].
    fn cond(&mut self, c: &Cond) -> (TokenStream, usize) {
        let (t, d) = self.cond_inline(c);
        self.hoist(t, d, quote! { bool })
    }

    fn cond_inline(&mut self, c: &Cond) -> (TokenStream, usize) {
        match c {
            Cond::Cmp(op, a, b) => {
                let ((a, da), (b, db)) = (self.expr(a), self.expr(b));
                let op: TokenStream = op.symbol().parse().unwrap_or_default();
                (quote! { #a #op #b }, da.max(db) + 1)
            }
            Cond::And(a, b) => {
                let ((a, da), (b, db)) = (self.cond(a), self.cond(b));
                (quote! { ((#a) & (#b)) }, da.max(db) + 2)
            }
            Cond::Or(a, b) => {
                let ((a, da), (b, db)) = (self.cond(a), self.cond(b));
                (quote! { ((#a) | (#b)) }, da.max(db) + 2)
            }
            Cond::Not(a) => {
                let (a, d) = self.cond(a);
                (quote! { !(#a) }, d + 1)
            }
        }
    }
}
