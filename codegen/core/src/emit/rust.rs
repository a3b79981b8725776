//! Emits the fixed-point controller as a `#![no_std]`-compatible Rust module.
//!
//! `step` works on raw integers only: explicit casts, shifts, adds, widening multiplies,
//! compares. No division, no floating point, no `unwrap`, and no indexing but the constant
//! indices of a vector's elements on entry and exit (checked when the module compiles); every operation's range
//! is proved, so in release builds there is no panicking path, and in debug builds an
//! overflow check that fired would expose a wrong proof. `fixed` crate types carry the values
//! across the API.

use super::repeat::{Emit, Param, Repeat, Row, Sync};
use super::Member;
use crate::ir::{SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use crate::qformat::{IntTy, QFormat};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote, ToTokens};

/// The generated module for `plan`.
pub fn module(plan: &Plan) -> TokenStream {
    // The step's shared loop bodies, and the plan with their values' hulled intervals (the
    // module is emitted from it; it differs from `plan` only in those intervals).
    let em = super::repeat::emit(plan);
    let plan = &em.plan;
    let prog = &plan.prog;
    let modname = format_ident!("{}", prog.name);
    let mut doc = super::module_doc(plan, "fixed-point controller");
    if !plan.var_products().is_empty() {
        doc.push_str(
            "\nEach product of two non-constant values is an always-inlined function \
             `qloop_mul_<n>`, so that the proof harnesses (`qloop gen --lang kani`) can replace \
             it by a verified abstraction (`kani::stub`); the object code is the plain multiply.\n",
        );
    }
    if !em.repeats.is_empty() {
        doc.push_str(
            "\nEach `qloop_loop_<k>` is the body of a `for` loop, once for all its indices: \
             `step` calls it on one row of each state it updates per index.\n",
        );
    }
    let sigs = Sigs::new(plan);
    let structs = api_structs(plan, &sigs);
    let tables = super::signal_tables(plan);
    let controller = controller_struct(plan, &sigs);
    let state_api = state_methods(plan, &sigs);
    let bits_api = bits_methods(plan, &sigs);
    let step = step_method(&em, &sigs);
    let allows = super::allowed_lints();
    let period_us = Literal::u64_suffixed((prog.period * 1e6).round() as u64);
    let keep = if plan.vals.iter().any(|v| v.network) {
        keep_fn()
    } else {
        quote! {}
    };
    let muls = mul_fns(plan, &em.var_products());
    let loops = em
        .repeats
        .iter()
        .enumerate()
        .map(|(k, r)| loop_fn(plan, k, r));
    let table_items = table_arrays(plan);
    quote! {
        #[doc = #doc]
        #[allow(#allows)]
        pub mod #modname {
            #keep

            #table_items

            #muls

            #(#loops)*

            #structs

            #tables

            #controller

            impl Controller {
                /// Sample period in microseconds.
                pub const PERIOD_US: u64 = #period_us;

                #state_api

                #bits_api

                #step
            }
        }
    }
}

/// The controller's inputs, states and outputs in declaration order: one entry per scalar
/// signal (for the raw-integer API and the step's locals), and one per API field.
struct Sigs {
    inputs: Vec<SigId>,
    states: Vec<SigId>,
    outputs: Vec<SigId>,
    in_fields: Vec<Member>,
    state_fields: Vec<Member>,
    out_fields: Vec<Member>,
}

impl Sigs {
    fn new(plan: &Plan) -> Sigs {
        let kinds = |k: SigKind| plan.prog.ids_of(k).collect::<Vec<_>>();
        let fields = |k: SigKind| super::members(&plan.prog, k);
        Sigs {
            inputs: kinds(SigKind::Input),
            states: kinds(SigKind::State),
            outputs: kinds(SigKind::Output),
            in_fields: fields(SigKind::Input),
            state_fields: fields(SigKind::State),
            out_fields: fields(SigKind::Output),
        }
    }
}

/// A signal's name in the step (its local variable): `fc`, `theta_0`.
fn ident(plan: &Plan, id: SigId) -> Ident {
    format_ident!("{}", plan.prog.sig(id).name)
}

/// A signal as a field path: `fc`, `theta[0]`.
fn path(plan: &Plan, id: SigId) -> TokenStream {
    super::field_path(&plan.prog, id)
}

/// Signal `id`'s raw value from `e`, an expression of its storage type: a cast where its
/// vector stores it in a wider word (its value is within its own bounds, so the cast is
/// exact).
fn from_storage(plan: &Plan, id: SigId, e: TokenStream) -> TokenStream {
    let ty = plan.format(id).ty;
    if plan.storage_ty(id) == ty {
        return e;
    }
    let t = int_ty(ty);
    quote! { (#e as #t) }
}

/// `v`, a raw value of signal `id`'s own type, as its storage type.
fn to_storage(plan: &Plan, id: SigId, v: TokenStream) -> TokenStream {
    let st = plan.storage_ty(id);
    if st == plan.format(id).ty {
        return v;
    }
    let t = int_ty(st);
    quote! { (#v as #t) }
}

/// The API value of signal `id` from its raw value `raw` (exact: the API format has at least
/// the element's fraction bits and holds its bounds).
pub(crate) fn to_api(plan: &Plan, id: SigId, raw: TokenStream) -> TokenStream {
    let (q, a) = (plan.format(id), plan.api_format(id));
    let at = fixed_ty(a);
    if q == a {
        return quote! { <#at>::from_bits(#raw) };
    }
    let et = fixed_ty(q);
    quote! { <#at>::wrapping_from_num(<#et>::from_bits(#raw)) }
}

/// Signal `id`'s raw value from `v`, a value of its API type: in the element's own format,
/// fraction bits beyond it dropped (toward −∞) and saturated to its type.
pub(crate) fn from_api(plan: &Plan, id: SigId, v: TokenStream) -> TokenStream {
    let q = plan.format(id);
    if q == plan.api_format(id) {
        return quote! { #v.to_bits() };
    }
    let et = fixed_ty(q);
    quote! { <#et>::saturating_from_num(#v).to_bits() }
}

/// `name: value` for an API field, the value built per element by `f` (an array literal for
/// a vector or matrix).
fn init_field(plan: &Plan, m: &Member, f: impl Fn(SigId) -> TokenStream) -> TokenStream {
    let name = format_ident!("{}", m.name(&plan.prog));
    let v = super::nest(m.dims(), m.ids().into_iter().map(f).collect());
    quote! { #name: #v, }
}

/// `Inputs`, `Outputs` and `States`: the API's `fixed` values (arrays for vectors and
/// matrices), with their doc lines.
fn api_structs(plan: &Plan, sigs: &Sigs) -> TokenStream {
    let field = |m: &Member| {
        let name = format_ident!("{}", m.name(&plan.prog));
        let ty = super::array_ty(m.dims(), fixed_ty(plan.api_format(m.first())));
        let d = super::member_doc(plan, m);
        quote! { #[doc = #d] pub #name: #ty, }
    };
    let in_fields = sigs.in_fields.iter().map(field);
    let out_fields = sigs.out_fields.iter().map(field);
    let st_fields = sigs.state_fields.iter().map(field);
    let (di, ii) = super::default_impl(&plan.prog, "Inputs", &sigs.in_fields);
    let (do_, io) = super::default_impl(&plan.prog, "Outputs", &sigs.out_fields);
    let (ds, is) = super::default_impl(&plan.prog, "States", &sigs.state_fields);
    quote! {
        /// Inputs of one step. Each is clamped to its declared range on entry.
        #[derive(Clone, Copy, Debug, #di PartialEq, Eq)]
        pub struct Inputs { #(#in_fields)* }
        #ii

        /// Outputs of one step.
        #[derive(Clone, Copy, Debug, #do_ PartialEq, Eq)]
        pub struct Outputs { #(#out_fields)* }
        #io

        /// A snapshot of the controller's states.
        #[derive(Clone, Copy, Debug, #ds PartialEq, Eq)]
        pub struct States { #(#st_fields)* }
        #is
    }
}

/// `Controller` (its states as raw integers) and its `Default`.
fn controller_struct(plan: &Plan, sigs: &Sigs) -> TokenStream {
    let raw_fields = sigs.state_fields.iter().map(|m| {
        let name = format_ident!("{}", m.name(&plan.prog));
        let ty = super::array_ty(
            m.dims(),
            int_ty(plan.storage_ty(m.first())).into_token_stream(),
        );
        quote! { #name: #ty, }
    });
    quote! {
        /// The controller: its states as raw integers.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct Controller { #(#raw_fields)* }

        impl Default for Controller {
            fn default() -> Self {
                Self::new()
            }
        }
    }
}

/// `new`, `states` and `set_states` (which saturates each state to its bounds).
fn state_methods(plan: &Plan, sigs: &Sigs) -> TokenStream {
    let states = &sigs.states;
    let raw_inits = sigs
        .state_fields
        .iter()
        .map(|m| init_field(plan, m, |id| lit(plan.raw_init(id), plan.storage_ty(id))));
    // A vector or matrix converts as a whole (its elements share a format): one `map` per
    // dimension, not a line per element.
    let getters = sigs.state_fields.iter().map(|m| match m {
        Member::Group { name, dims, ids } if m.uniform(plan) => {
            let g = format_ident!("{name}");
            let ty = fixed_ty(plan.format(ids[0]));
            let mut f = quote! { <#ty>::from_bits };
            for _ in 1..dims.len() {
                f = quote! { |r| r.map(#f) };
            }
            quote! { #g: self.#g.map(#f), }
        }
        _ => init_field(plan, m, |id| {
            let p = path(plan, id);
            to_api(plan, id, from_storage(plan, id, quote! { self.#p }))
        }),
    });
    // A vector or matrix whose elements share their bounds saturates in one loop over its
    // elements; otherwise, and for scalars, a line per element.
    let setters = sigs.state_fields.iter().map(|m| {
        let each = |id: &SigId| {
            let p = path(plan, *id);
            let q = plan.format(*id);
            let (lo, hi) = plan.bounds(*id);
            let (lo, hi) = (lit(lo, q.ty), lit(hi, q.ty));
            let x = from_api(plan, *id, quote! { s.#p });
            let v = to_storage(
                plan,
                *id,
                quote! { ::core::cmp::max(::core::cmp::min(#x, #hi), #lo) },
            );
            quote! { self.#p = #v; }
        };
        match m {
            Member::Group { name, dims, ids }
                if m.uniform(plan)
                    && ids.iter().all(|id| plan.bounds(*id) == plan.bounds(ids[0])) =>
            {
                let g = format_ident!("{name}");
                let q = plan.format(ids[0]);
                let (lo, hi) = plan.bounds(ids[0]);
                let (lo, hi) = (lit(lo, q.ty), lit(hi, q.ty));
                let flat = (1..dims.len()).map(|_| quote! { .flatten() });
                let flat2 = flat.clone();
                quote! {
                    for (d, x) in self.#g.iter_mut() #(#flat)* .zip(s.#g.iter() #(#flat2)*) {
                        *d = ::core::cmp::max(::core::cmp::min(x.to_bits(), #hi), #lo);
                    }
                }
            }
            _ => {
                let lines = m.ids().iter().map(each).collect::<Vec<_>>();
                quote! { #(#lines)* }
            }
        }
    });
    // Controllers without states keep the same signature.
    let (no_states, _) = super::unused_params(states.is_empty(), false);
    quote! {
        /// The controller in its declared initial state.
        pub const fn new() -> Self {
            Controller { #(#raw_inits)* }
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
    }
}

/// `state_bits` and `step_bits`: the raw-integer API for generic runners, one entry per
/// scalar (a vector's elements in a row, row-major).
fn bits_methods(plan: &Plan, sigs: &Sigs) -> TokenStream {
    let (inputs, states, outputs) = (&sigs.inputs, &sigs.states, &sigs.outputs);
    let [ni, no, ns] = [inputs, outputs, states].map(|v| Literal::usize_unsuffixed(v.len()));
    let in_bits = sigs.in_fields.iter().map(|m| {
        init_field(plan, m, |id| {
            let k = inputs.iter().position(|i| *i == id).unwrap_or(0);
            let k = Literal::usize_unsuffixed(k);
            let q = plan.format(id);
            let ty = int_ty(q.ty);
            // Saturated to the type: its limits as i64 (`u64::MAX as i64` would be -1; `check`
            // refuses u64 inputs, so that never happens, but the clamp stays right for any type).
            let hi = if q.ty.max() > i64::MAX as i128 {
                quote! { i64::MAX }
            } else {
                quote! { #ty::MAX as i64 }
            };
            to_api(
                plan,
                id,
                quote! {
                    ::core::cmp::max(::core::cmp::min(i[#k], #hi), #ty::MIN as i64) as #ty
                },
            )
        })
    });
    let out_bits = outputs.iter().map(|id| {
        let p = path(plan, *id);
        let x = from_api(plan, *id, quote! { o.#p });
        quote! { #x as i64, }
    });
    let state_bits = states.iter().map(|id| {
        let p = path(plan, *id);
        quote! { self.#p as i64, }
    });
    // Controllers without inputs keep the same signature.
    let (_, no_inputs) = super::unused_params(false, inputs.is_empty());
    quote! {
        /// The current states as raw integers (`value · 2^frac`), in the order of
        /// [`STATES`].
        pub fn state_bits(&self) -> [i64; #ns] {
            [#(#state_bits)*]
        }

        /// [`Controller::step`] on raw integers, for generic runners (simulators, HAL
        /// glue): inputs in the order of [`INPUTS`], each saturated to its type, and
        /// outputs in the order of [`OUTPUTS`].
        pub fn step_bits(&mut self, i: [i64; #ni]) -> [i64; #no] {
            #no_inputs
            let o = self.step(Inputs { #(#in_bits)* });
            [#(#out_bits)*]
        }
    }
}

/// `step`: loads the states, runs the plan's body (its shared loop bodies as calls), saves
/// the states, returns the outputs.
fn step_method(em: &Emit, sigs: &Sigs) -> TokenStream {
    let plan = &em.plan;
    let sync = em.sync();
    let load_states = sigs
        .states
        .iter()
        .filter(|s| !sync.unnamed.contains(s))
        .map(|id| {
            let (name, p) = (ident(plan, *id), path(plan, *id));
            let ty = int_ty(plan.format(*id).ty);
            let v = from_storage(plan, *id, quote! { self.#p });
            quote! { let mut #name: #ty = #v; }
        });
    let decl_outputs = sigs.outputs.iter().map(|id| {
        let name = ident(plan, *id);
        let ty = int_ty(plan.format(*id).ty);
        quote! { let mut #name: #ty = 0; }
    });
    let mut body = TokenStream::new();
    let mut i = 0;
    while i < plan.body.len() {
        match em.repeats.iter().position(|r| r.start == i) {
            Some(k) => {
                body.extend(loop_call(em, &sync, k));
                i = em.repeats[k].run().end;
            }
            None => {
                body.extend(block(plan, &plan.body[i..=i]));
                i += 1;
            }
        }
    }
    let save_states = sigs
        .states
        .iter()
        .filter(|s| !sync.current.contains(s))
        .map(|id| {
            let (name, p) = (ident(plan, *id), path(plan, *id));
            let v = to_storage(plan, *id, quote! { #name });
            quote! { self.#p = #v; }
        });
    let ret = sigs.out_fields.iter().map(|m| {
        init_field(plan, m, |id| {
            let name = ident(plan, id);
            to_api(plan, id, quote! { #name })
        })
    });
    // A step that reads no input still takes them (one signature for every controller).
    let unused_inputs = if plan.vals.iter().any(|v| matches!(v.op, Op::Input(_))) {
        quote! {}
    } else {
        quote! { let _ = inputs; }
    };
    quote! {
        /// One control period: reads the inputs, updates the states, returns the outputs.
        pub fn step(&mut self, inputs: Inputs) -> Outputs {
            #unused_inputs
            #(#load_states)*
            #(#decl_outputs)*
            #body
            #(#save_states)*
            Outputs { #(#ret)* }
        }
    }
}

/// The name of the function of shared loop body `k`.
fn loop_name(k: usize) -> Ident {
    format_ident!("qloop_loop_{k}")
}

/// Element `s` (of the first copy) of row `r`, through the row's reference: `thf[0]`,
/// `P[1][2]`, or `*t0` for a row that is one element.
fn row_elem(plan: &Plan, r: &Row, s: SigId) -> TokenStream {
    let g = format_ident!("{}", r.group);
    let index = plan
        .prog
        .sig(s)
        .elem
        .as_ref()
        .map(|e| e.index[1..].to_vec())
        .unwrap_or_default();
    if index.is_empty() {
        return quote! { *#g };
    }
    let idx = index.iter().map(|i| Literal::usize_unsuffixed(*i));
    quote! { #g #([#idx])* }
}

/// Shared loop body `k` as a function: the first copy's statements on the rows of the state
/// it is called with (see [`super::repeat`]).
fn loop_fn(plan: &Plan, k: usize, r: &Repeat) -> TokenStream {
    let mut params = Vec::new();
    for row in &r.rows {
        let g = format_ident!("{}", row.group);
        let elem = int_ty(plan.storage_ty(row.elems[0])).into_token_stream();
        let ty = super::array_ty(&row.dims[1..], elem);
        params.push(quote! { #g: &mut #ty });
    }
    for q in &r.params {
        params.push(match *q {
            Param::Val(v) => {
                let name = val_name(plan, v);
                let val = plan.val(v);
                if val.boolean {
                    quote! { #name: bool }
                } else {
                    let ty = int_ty(val.ty);
                    quote! { #name: #ty }
                }
            }
            Param::Sig(s) => {
                let (name, ty) = (ident(plan, s), int_ty(plan.format(s).ty));
                quote! { #name: #ty }
            }
        });
    }
    let loads = r.rows.iter().flat_map(|row| {
        row.elems.iter().map(move |s| {
            let (name, ty) = (ident(plan, *s), int_ty(plan.format(*s).ty));
            let e = from_storage(plan, *s, row_elem(plan, row, *s));
            quote! { let mut #name: #ty = #e; }
        })
    });
    let stores = r.rows.iter().flat_map(|row| {
        row.stored.iter().map(move |s| {
            let name = ident(plan, *s);
            let e = row_elem(plan, row, *s);
            let v = to_storage(plan, *s, quote! { #name });
            quote! { #e = #v; }
        })
    });
    let body = block(plan, r.body(plan));
    let name = loop_name(k);
    let doc = format!(
        " Lines {}-{} of the spec, the body of a `for` loop, once for its {} indices: `step` \
         calls it on row `l` of each state it updates. Its values' intervals are the hull of \
         every index's.",
        r.lines.0, r.lines.1, r.count
    );
    quote! {
        #[doc = #doc]
        #[allow(clippy::too_many_arguments)]
        fn #name(#(#params),*) {
            #(#loads)*
            #body
            #(#stores)*
        }
    }
}

/// The call of shared loop body `k` in `step`, between the writes and reads of the step's
/// locals that [`Emit::sync`] asks for; the rows come from iterators (no indexing).
fn loop_call(em: &Emit, sync: &Sync, k: usize) -> TokenStream {
    let plan = &em.plan;
    let r = &em.repeats[k];
    let sync_before = sync.before[k].iter().map(|e| {
        let (name, p) = (ident(plan, *e), path(plan, *e));
        let v = to_storage(plan, *e, quote! { #name });
        quote! { self.#p = #v; }
    });
    let reload = sync.after[k].iter().map(|e| {
        let (name, p) = (ident(plan, *e), path(plan, *e));
        let v = from_storage(plan, *e, quote! { self.#p });
        quote! { #name = #v; }
    });
    let count = Literal::usize_unsuffixed(r.count);
    let mut iter = TokenStream::new();
    let mut pat = TokenStream::new();
    for (j, row) in r.rows.iter().enumerate() {
        let g = format_ident!("{}", row.group);
        let skip = (row.lead > 0).then(|| {
            let n = Literal::usize_unsuffixed(row.lead);
            quote! { .skip(#n) }
        });
        let it = quote! { self.#g.iter_mut() #skip };
        if j == 0 {
            iter = quote! { #it.take(#count) };
            pat = quote! { #g };
        } else {
            iter = quote! { #iter.zip(#it) };
            pat = quote! { (#pat, #g) };
        }
    }
    let mut args = Vec::new();
    for row in &r.rows {
        let g = format_ident!("{}", row.group);
        args.push(quote! { #g });
    }
    for q in &r.params {
        args.push(match *q {
            Param::Val(v) => val_name(plan, v).into_token_stream(),
            Param::Sig(s) => ident(plan, s).into_token_stream(),
        });
    }
    let name = loop_name(k);
    quote! {
        #(#sync_before)*
        for #pat in #iter {
            #name(#(#args),*);
        }
        #(#reload)*
    }
}

/// `qloop_keep(x)`: hides a shift-add term from LLVM where its re-formed multiply would be a library
/// call or a slow instruction: ARMv6-M (`__aeabi_lmul` for 64 bits, a 32-cycle `MULS` on the
/// small-multiplier M0) and RV32 without M (`__mulsi3`, `__muldi3`). Elsewhere the multiply
/// LLVM prefers is single-cycle and `qloop_keep` is the identity, so it costs nothing.
fn keep_fn() -> TokenStream {
    quote! {
        /// Keeps a shift-add term opaque where a multiply would be a library call (see the
        /// qloop book, "Targets, C output and object code").
        #[inline(always)]
        fn qloop_keep<T>(x: T) -> T {
            #[cfg(any(
                all(target_arch = "arm", not(target_feature = "v7")),
                all(target_arch = "riscv32", not(target_feature = "m"))
            ))]
            let x = ::core::hint::black_box(x);
            x
        }
    }
}

/// The name of the function computing the step's product `id` ([`Plan::var_products`]).
pub fn mul_fn_name(id: ValId) -> Ident {
    format_ident!("qloop_mul_{}", id.0)
}

/// `qloop_mul_<N>(a, b)`, one per product of two non-constant values the module computes:
/// functions only so that the Kani harnesses can stub them; always inlined, so the object code
/// is the multiply. Defined through one `macro_rules!`, a line per product (a large spec has
/// hundreds; the factors' intervals are in the harnesses' abstractions).
fn mul_fns(plan: &Plan, ids: &[ValId]) -> TokenStream {
    // The products grouped by signature, in order of first appearance.
    let mut groups: Vec<((IntTy, IntTy, IntTy), Vec<Ident>)> = Vec::new();
    for &id in ids {
        let v = plan.val(id);
        let Op::Mul(a, b) = v.op else {
            continue;
        };
        let sig = (plan.val(a).ty, plan.val(b).ty, v.ty);
        match groups.iter_mut().find(|(s, _)| *s == sig) {
            Some((_, names)) => names.push(mul_fn_name(id)),
            None => groups.push((sig, vec![mul_fn_name(id)])),
        }
    }
    if groups.is_empty() {
        return quote! {};
    }
    let entries = groups.iter().map(|((ta, tb, t), names)| {
        let (ta, tb, t) = (int_ty(*ta), int_ty(*tb), int_ty(*t));
        quote! { (#ta, #tb) -> #t: #(#names),*; }
    });
    quote! {
        /// Defines the step's products `qloop_mul_<n>` (see the module doc), by signature.
        macro_rules! qloop_muls {
            ($(($a:ty, $b:ty) -> $t:ty: $($name:ident),*;)*) => {$($(
                // Items a local macro defines get the lints the expansion's own code would
                // not: a module whose step a crate never calls leaves them unused.
                #[allow(dead_code)]
                #[inline(always)]
                pub(crate) fn $name(a: $a, b: $b) -> $t {
                    a * b
                }
            )*)*};
        }
        qloop_muls! { #(#entries)* }
    }
}

fn block(plan: &Plan, stmts: &[LStmt]) -> TokenStream {
    let parts = stmts.iter().map(|s| match s {
        LStmt::Def(id) => {
            let name = val_name(plan, *id);
            let v = plan.val(*id);
            let e = op_expr(plan, *id);
            if v.boolean {
                quote! { let #name: bool = #e; }
            } else if v.network {
                // A shift-add term: see `qloop_keep`.
                let ty = int_ty(v.ty);
                quote! { let #name: #ty = qloop_keep(#e); }
            } else {
                let ty = int_ty(v.ty);
                quote! { let #name: #ty = #e; }
            }
        }
        LStmt::Store(sig, id) => {
            let target = format_ident!("{}", plan.prog.sig(*sig).name);
            let v = val_name(plan, *id);
            quote! { #target = #v; }
        }
        LStmt::If(c, t, e) => {
            let c = val_name(plan, *c);
            let t = block(plan, t);
            if e.is_empty() {
                quote! { if #c { #t } }
            } else {
                let e = block(plan, e);
                quote! { if #c { #t } else { #e } }
            }
        }
    });
    quote! { #(#parts)* }
}

fn op_expr(plan: &Plan, id: ValId) -> TokenStream {
    let v = plan.val(id);
    let n = |x: &ValId| val_name(plan, *x);
    match &v.op {
        Op::Input(s) => {
            let f = path(plan, *s);
            from_api(plan, *s, quote! { inputs.#f })
        }
        Op::Load(s) => {
            let f = format_ident!("{}", plan.prog.sig(*s).name);
            quote! { #f }
        }
        Op::Const(c) => lit(*c, v.ty),
        Op::Cast(a) => {
            let (a, ty) = (n(a), int_ty(v.ty));
            quote! { #a as #ty }
        }
        Op::Add(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { #a + #b }
        }
        Op::Sub(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { #a - #b }
        }
        Op::Neg(a) => {
            let a = n(a);
            quote! { -#a }
        }
        Op::Shl(a, k) => {
            let (a, k) = (n(a), Literal::u32_unsuffixed(*k));
            quote! { #a << #k }
        }
        Op::Shr(a, k) => {
            let (a, k) = (n(a), Literal::u32_unsuffixed(*k));
            quote! { #a >> #k }
        }
        Op::Mul(a, b) => {
            let f = mul_fn_name(id);
            let (a, b) = (n(a), n(b));
            if plan.is_var_product(id) {
                quote! { #f(#a, #b) }
            } else {
                quote! { #a * #b }
            }
        }
        Op::MulHi(a, b) => {
            // `lower::lir::mul_hi`: three 16x16 -> 32 pieces, each proved to fit `i32`.
            let (a, b) = (n(a), n(b));
            quote! {{
                let (ha, hb) = (#a >> 16, #b >> 16);
                ha * hb + ((ha * (#b & 0xFFFF)) >> 16) + (((#a & 0xFFFF) * hb) >> 16)
            }}
        }
        Op::Min(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { ::core::cmp::min(#a, #b) }
        }
        Op::Max(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { ::core::cmp::max(#a, #b) }
        }
        Op::Select(c, a, b) => {
            let (c, a, b) = (n(c), n(a), n(b));
            quote! { if #c { #a } else { #b } }
        }
        Op::Cmp(op, a, b) => {
            let (a, b) = (n(a), n(b));
            let op: TokenStream = op.symbol().parse().unwrap_or_default();
            quote! { #a #op #b }
        }
        Op::And(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { #a && #b }
        }
        Op::Or(a, b) => {
            let (a, b) = (n(a), n(b));
            quote! { #a || #b }
        }
        Op::Not(a) => {
            let a = n(a);
            quote! { !#a }
        }
        Op::Low(a, k) => {
            let (a, m) = (n(a), lit((1i128 << k) - 1, v.ty));
            quote! { #a & #m }
        }
        Op::Lookup { table, delta, idx } => {
            // The index is proved in 0..=N; the mask (a no-op there) lets the compiler drop
            // the bounds check, so no panicking path remains.
            let layout = super::table_layouts(plan)[*table];
            let i = n(idx);
            if *delta && !layout.deltas {
                // `D[i]` as `T[i + 1] − T[i]` (`super::table_layouts`): exact in `T`'s type.
                let (arr, mask) = table_name(layout, *table, false);
                return quote! {
                    #arr[(#i as usize).wrapping_add(1) & #mask].wrapping_sub(#arr[(#i as usize) & #mask])
                };
            }
            let (arr, mask) = table_name(layout, *table, *delta);
            quote! { #arr[(#i as usize) & #mask] }
        }
    }
}

/// The name of table array `table` (samples or differences) and its index mask.
fn table_name(layout: super::TableLayout, table: usize, delta: bool) -> (Ident, Literal) {
    let len = layout.len;
    let name = if delta {
        format_ident!("QLOOP_DELTA_{}", table)
    } else {
        format_ident!("QLOOP_TABLE_{}", table)
    };
    (name, Literal::usize_unsuffixed(len - 1))
}

/// The table arrays of the step: `const` arrays, padded to a power of two.
fn table_arrays(plan: &Plan) -> TokenStream {
    let layouts = super::table_layouts(plan);
    let items = plan.tables.iter().enumerate().map(|(i, t)| {
        let layout = layouts[i];
        let len = layout.len;
        let doc = super::table_doc(plan, i);
        let mut out = TokenStream::new();
        for delta in [false, true] {
            if !(if delta { layout.deltas } else { layout.entries }) {
                continue;
            }
            let (name, _) = table_name(layout, i, delta);
            let (ty, src) = if delta {
                (t.delta_ty, &t.deltas)
            } else {
                (t.format.ty, &t.entries)
            };
            let vals = super::padded(src, len).into_iter().map(|v| lit(v, ty));
            let tyi = int_ty(ty);
            let l = Literal::usize_unsuffixed(len);
            let d = if delta {
                format!(" Differences of consecutive entries of [`QLOOP_TABLE_{i}`] (0 from the last on).")
            } else {
                doc.clone()
            };
            out.extend(quote! {
                #[doc = #d]
                const #name: [#tyi; #l] = [#(#vals),*];
            });
        }
        out
    });
    quote! { #(#items)* }
}

/// The emitted name of a value: the user's `let` name, or `_N`.
pub fn val_name(plan: &Plan, id: ValId) -> Ident {
    match &plan.val(id).name {
        Some(n) => Ident::new(n, Span::call_site()),
        None => format_ident!("_{}", id.0),
    }
}

/// `i32`, `u16`, ...
pub fn int_ty(t: IntTy) -> Ident {
    Ident::new(&t.rust_name(), Span::call_site())
}

/// `::fixed::FixedI32<::fixed::types::extra::U20>` for `Q(i32, 20)`.
pub fn fixed_ty(q: QFormat) -> TokenStream {
    let base = format_ident!("Fixed{}{}", if q.ty.signed { "I" } else { "U" }, q.ty.bits);
    let frac = format_ident!("U{}", q.frac.max(0) as u32);
    quote! { ::fixed::#base<::fixed::types::extra::#frac> }
}

/// An integer literal of type `ty` (`T::MIN` where the literal itself would overflow).
pub fn lit(v: i128, ty: IntTy) -> TokenStream {
    if ty.signed && v == ty.min() {
        let t = int_ty(ty);
        return quote! { #t::MIN };
    }
    let l = Literal::i128_unsuffixed(v.abs());
    if v < 0 {
        quote! { -#l }
    } else {
        quote! { #l }
    }
}
