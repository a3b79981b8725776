//! Emits proof harnesses for the fixed-point module: Kani proofs that also run as randomized
//! property tests.
//!
//! The harnesses use [bolero](https://docs.rs/bolero): under `cargo kani --tests` each
//! `bolero::check!()` draws its values with `kani::any()` (and `kani::assume` for the
//! generators' ranges), so a harness is a proof over every value; under `cargo test` it runs
//! [`CASES`] random cases. They call the generated controller itself (`set_states`, `step`,
//! `states`), so what they check is the code that ships, and they mirror the SMT obligations of
//! the `qloop` crate's `prove::obligations`:
//!
//! * `ranges_and_overflow`: any input bits and any states inside their bounds: one step
//!   overflows nothing (Kani's arithmetic checks; debug-build overflow panics under `cargo
//!   test`) and leaves every state inside its bounds.
//! * `initial`: the initial state is inside the bounds and satisfies every invariant.
//! * `invariant_<name>`: one step from any state inside the bounds satisfying the invariants,
//!   with any input bits, keeps the invariant.
//! * `property_<name>`: one step from inputs inside their declared ranges, states inside the
//!   bounds and invariants, and free parameters on their grid ([`param_grids`]): the `assume`s
//!   imply every `ensure`.
//!
//! Assumptions are early `return`s. Under Kani a path that returns before an assertion cannot
//! violate it, so an early return restricts the proof exactly like `kani::assume`; under
//! `cargo test` the case is skipped (property harnesses count how many cases got past their
//! assumptions).
//!
//! Property and invariant conditions are evaluated exactly, with the semantics of
//! `qloop`'s `prove::replay` but in `i128`: a signal is `raw · 2^-frac`, binary points are
//! aligned by left shifts, products multiply raw values and add fractions, and constants are
//! their exact binary values `m · 2^-f` ([`exact_binary`]). The magnitude of every
//! intermediate is bounded here, from the raw ranges; a harness whose bound would exceed
//! 2^126 is not emitted, and a documented constant says why.

use super::rust::{fixed_ty, int_ty};
use crate::ir::{CmpOp, PCond, PExpr, Property, SigId, SigKind, When};
use crate::lower::Plan;
use crate::prop_eval::{self, param_grids, Arith, ExactDomain, ParamGrid};
use crate::qformat::IntTy;
use crate::text::g;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

/// Random cases each harness runs under `cargo test` (bolero's own default is "as many as fit
/// in one second", which varies with the machine and the build). `BOLERO_RANDOM_ITERATIONS`
/// overrides it; under Kani it is ignored.
pub const CASES: usize = 100_000;

/// Largest magnitude, as a power of two, an exactly evaluated intermediate may reach.
pub const LIMIT_BITS: u32 = 126;

/// The harness module for `plan`, named `<spec>_proofs`, to be placed next to the fixed-point
/// module (it refers to `super::<spec>`).
pub fn module(plan: &Plan) -> TokenStream {
    let prog = &plan.prog;
    let modname = format_ident!("{}_proofs", prog.name);
    let target = format_ident!("{}", prog.name);
    let ids = |k: SigKind| prog.ids_of(k).collect::<Vec<_>>();
    let (inputs, states, outputs) = (
        ids(SigKind::Input),
        ids(SigKind::State),
        ids(SigKind::Output),
    );
    let name = |id: &SigId| format_ident!("{}", prog.sig(*id).name);
    let in_names: Vec<Ident> = inputs.iter().map(name).collect();
    let st_names: Vec<Ident> = states.iter().map(name).collect();
    let out_names: Vec<Ident> = outputs.iter().map(name).collect();
    let in_args: Vec<Ident> = inputs
        .iter()
        .map(|id| format_ident!("in_{}", prog.sig(*id).name))
        .collect();
    let st_args: Vec<Ident> = states
        .iter()
        .map(|id| format_ident!("st_{}", prog.sig(*id).name))
        .collect();
    let storage = |id: &SigId| int_ty(plan.format(*id).ty);
    let in_tys: Vec<Ident> = inputs.iter().map(storage).collect();
    let st_tys: Vec<Ident> = states.iter().map(storage).collect();
    let in_fixed: Vec<TokenStream> = inputs.iter().map(|id| fixed_ty(plan.format(*id))).collect();
    let st_fixed: Vec<TokenStream> = states.iter().map(|id| fixed_ty(plan.format(*id))).collect();

    // Exact evaluation of the invariants; any that cannot be evaluated in i128 disables the
    // harnesses that assume it.
    let mut skipped: Vec<(String, String)> = Vec::new();
    let mut inv_fns = Vec::new();
    let mut inv_calls = Vec::new();
    let mut inv_ok = Vec::new();
    let mut inv_blocked: Option<String> = None;
    for inv in &prog.invariants {
        let env = Env {
            plan,
            grids: &[],
            params: &[],
            pre: format_ident!("s"),
            post: format_ident!("s"),
        };
        let text = show_cond(plan, &[], &inv.cond);
        match env.cond(&inv.cond) {
            Ok(c) => {
                let f = format_ident!("inv_{}", inv.name);
                let d = spaced(&format!(
                    "Invariant `{}`: `{text}`, evaluated exactly on raw states.",
                    inv.name
                ));
                inv_fns.push(quote! {
                    #[doc = #d]
                    fn #f(s: &StateRaw) -> bool { #c }
                });
                inv_calls.push(quote! { #f(s) });
                inv_ok.push(Some(f));
            }
            Err(why) => {
                inv_blocked.get_or_insert_with(|| {
                    format!(
                        "it assumes invariant `{}` (`{text}`), which cannot be evaluated \
                         exactly in i128 ({why}); `initial` does not check it either",
                        inv.name
                    )
                });
                inv_ok.push(None);
            }
        }
    }
    let invariants_body = if inv_calls.is_empty() {
        quote! { true }
    } else {
        quote! { #(#inv_calls)&&* }
    };

    // Bounds of each state and declared ranges of each input, as raw integers.
    let st_bounds: Vec<(i128, i128)> = states.iter().map(|id| plan.bounds(*id)).collect();
    let in_ranges: Vec<(i128, i128)> = inputs.iter().map(|id| plan.bounds(*id)).collect();
    let bound_checks = st_names.iter().zip(&st_bounds).map(|(n, (lo, hi))| {
        let (lo, hi) = (int(*lo), int(*hi));
        quote! { (#lo..=#hi).contains(&s.#n) }
    });
    let range_checks = in_names.iter().zip(&in_ranges).map(|(n, (lo, hi))| {
        let (lo, hi) = (int(*lo), int(*hi));
        quote! { (#lo..=#hi).contains(&i.#n) }
    });
    let bound_asserts = st_names.iter().zip(&st_bounds).map(|(n, (lo, hi))| {
        let msg = format!("{{}}: state `{n}` = raw {{}} is outside [{lo}, {hi}]");
        let (lo, hi) = (int(*lo), int(*hi));
        quote! {
            let inside = (#lo..=#hi).contains(&s.#n);
            assert!(inside, #msg, when, s.#n);
        }
    });
    let and_all = |v: Vec<TokenStream>| {
        if v.is_empty() {
            quote! { true }
        } else {
            quote! { #(#v)&&* }
        }
    };
    let in_bounds_body = and_all(bound_checks.collect());
    let in_range_body = and_all(range_checks.collect());

    // Generator fields: inputs (any bits, or their declared range), states (their bounds).
    let state_fields: Vec<TokenStream> = st_names
        .iter()
        .zip(&st_tys)
        .zip(&st_bounds)
        .map(|((n, t), (lo, hi))| {
            let (lo, hi) = (int(*lo), int(*hi));
            quote! { #[generator(#lo..=#hi)] #n: #t, }
        })
        .collect();
    let input_fields_any = in_names
        .iter()
        .zip(&in_tys)
        .map(|(n, t)| quote! { #n: #t, });
    let input_fields_ranged: Vec<TokenStream> = in_names
        .iter()
        .zip(&in_tys)
        .zip(&in_ranges)
        .map(|((n, t), (lo, hi))| {
            let (lo, hi) = (int(*lo), int(*hi));
            quote! { #[generator(#lo..=#hi)] #n: #t, }
        })
        .collect();

    let step_args = quote! { #(c.#in_names,)* #(c.#st_names,)* };
    let pre_from_case = quote! { states_raw(#(c.#st_names),*) };

    // (a) ranges and overflow.
    let ranges_doc = format!(
        "Ranges and overflow: for any input bits and any states inside their bounds, one step \
         of the generated `{name}::Controller` overflows no intermediate (a failed check under \
         Kani, a debug-build panic under `cargo test`) and leaves every state inside its \
         bounds, the declared range quantised inward: {bounds}. Mirrors the overflow \
         obligations of `qloop prove` and its \"… stays inside its range\" obligations.",
        name = prog.name,
        bounds = list(states.iter().zip(&st_bounds).map(|(id, (lo, hi))| {
            let s = prog.sig(*id);
            let declared = s.range.map_or(String::new(), |(a, b)| {
                let unit = s
                    .unit
                    .as_deref()
                    .map(|u| format!(" {u}"))
                    .unwrap_or_default();
                format!(" ∈ [{}, {}]{unit}", g(a), g(b))
            });
            format!(
                "`{}`{declared} (raw [{lo}, {hi}] · 2^-{})",
                s.name,
                plan.format(*id).frac
            )
        }))
    );
    let ranges_doc_s = spaced(&ranges_doc);
    let ranges = quote! {
        #[doc = #ranges_doc_s]
        #[test]
        #[cfg_attr(kani, kani::proof)]
        fn ranges_and_overflow() {
            bolero::check!()
                .with_type::<StepCase>()
                .with_iterations(CASES)
                .for_each(|c: &StepCase| {
                    let pre = #pre_from_case;
                    // Assume: states inside their bounds.
                    if !in_bounds(&pre) {
                        return;
                    }
                    let (post, _) = step(#step_args);
                    assert_in_bounds(&post, "after a step");
                });
        }
    };

    // (b) initial.
    let init_doc = format!(
        "Initial state: `{}::Controller::new()` is inside the state bounds and satisfies every \
         invariant.",
        prog.name
    );
    let init_invs = prog.invariants.iter().zip(&inv_ok).filter_map(|(inv, f)| {
        let f = f.as_ref()?;
        let msg = format!(
            "invariant `{}` (`{}`) is false initially: {{:?}}",
            inv.name,
            show_cond(plan, &[], &inv.cond)
        );
        Some(quote! {
            let holds = #f(&pre);
            assert!(holds, #msg, pre);
        })
    });
    let init_doc_s = spaced(&init_doc);
    let initial = quote! {
        #[doc = #init_doc_s]
        #[test]
        #[cfg_attr(kani, kani::proof)]
        fn initial() {
            let s = Controller::new().states();
            let pre = states_raw(#(s.#st_names.to_bits()),*);
            assert_in_bounds(&pre, "initially");
            #(#init_invs)*
        }
    };

    // (c) one inductive harness per invariant.
    let mut inv_harnesses = Vec::new();
    for (inv, f) in prog.invariants.iter().zip(&inv_ok) {
        // Every inductive harness assumes all invariants: if one cannot be evaluated, none
        // is emitted (dropping an assumption could only produce false alarms).
        let (Some(f), None) = (f, &inv_blocked) else {
            skipped.push((
                format!("invariant_{}", inv.name),
                inv_blocked.clone().unwrap_or_default(),
            ));
            continue;
        };
        let text = show_cond(plan, &[], &inv.cond);
        let mut doc = doc_lines(&inv.docs);
        doc.push_str(&format!(
            "Invariant `{}` is inductive: from any states inside their bounds satisfying every \
             invariant, one step with any input bits keeps `{text}`. With `initial`, it holds \
             in every reachable state (the invariant obligations of `qloop prove`).",
            inv.name
        ));
        let harness = format_ident!("invariant_{}", inv.name);
        let msg = format!(
            "invariant `{}` (`{text}`) is false after a step: {{:?}} -> {{:?}}",
            inv.name
        );
        let doc_s = spaced(&doc);
        inv_harnesses.push(quote! {
            #[doc = #doc_s]
            #[test]
            #[cfg_attr(kani, kani::proof)]
            fn #harness() {
                bolero::check!()
                    .with_type::<StepCase>()
                    .with_iterations(CASES)
                    .for_each(|c: &StepCase| {
                        let pre = #pre_from_case;
                        // Assume: states inside their bounds, invariants hold.
                        if !(in_bounds(&pre) && invariants(&pre)) {
                            return;
                        }
                        let (post, _) = step(#step_args);
                        let holds = #f(&post);
                        assert!(holds, #msg, pre, post);
                    });
            }
        });
    }

    // (d) one harness per property.
    let mut prop_harnesses = Vec::new();
    for (k, p) in prog.properties.iter().enumerate() {
        let harness = format!("property_{}", p.name);
        if let Some(why) = &inv_blocked {
            skipped.push((harness, why.clone()));
            continue;
        }
        let grids = param_grids(plan, k);
        match property(plan, k, &grids) {
            Ok(body) => {
                let fname = format_ident!("{harness}");
                let mut doc = doc_lines(&p.docs);
                doc.push_str(&property_doc(plan, k, &grids));
                let param_fields = p.params.iter().zip(&grids).map(|(fp, g)| {
                    let n = format_ident!("{}", fp.name);
                    let t = param_ty(g);
                    let (lo, hi) = (int(g.lo), int(g.hi));
                    quote! { #[generator(#lo..=#hi)] #n: #t, }
                });
                let params = p.params.iter().map(|fp| {
                    let (v, n) = (
                        format_ident!("param_{}", fp.name),
                        format_ident!("{}", fp.name),
                    );
                    quote! { let #v = i128::from(c.#n); }
                });
                let report = format!("{harness}: {{}} cases satisfied the assumptions");
                let cover = format!("the assumptions of property `{}` are satisfiable", p.name);
                let (assumes, ensures) = body;
                let doc_s = spaced(&doc);
                prop_harnesses.push(quote! {
                    #[doc = #doc_s]
                    #[test]
                    #[cfg_attr(kani, kani::proof)]
                    fn #fname() {
                        /// Inputs inside their declared ranges, states inside their bounds,
                        /// free parameters on their grid (raw).
                        #[derive(Clone, Copy, Debug, bolero::TypeGenerator)]
                        struct Case { #(#input_fields_ranged)* #(#state_fields)* #(#param_fields)* }

                        let held = ::core::sync::atomic::AtomicUsize::new(0);
                        bolero::check!()
                            .with_type::<Case>()
                            .with_iterations(CASES)
                            .for_each(|c: &Case| {
                                let inputs = inputs_raw(#(c.#in_names),*);
                                let pre = #pre_from_case;
                                // Assume: inputs in range, states in bounds, invariants hold.
                                if !(inputs_in_range(&inputs) && in_bounds(&pre) && invariants(&pre)) {
                                    return;
                                }
                                #(#params)*
                                let (post, outputs) = step(#step_args);
                                #(#assumes)*
                                held.fetch_add(1, ::core::sync::atomic::Ordering::Relaxed);
                                #[cfg(kani)]
                                kani::cover!(true, #cover);
                                #(#ensures)*
                            });
                        #[cfg(not(kani))]
                        {
                            let held = held.into_inner();
                            std::println!(#report, held);
                        }
                    }
                });
            }
            Err(why) => skipped.push((harness, why)),
        }
    }

    let skipped_items = skipped.iter().map(|(h, why)| {
        let c = format_ident!("SKIPPED_{}", h.to_uppercase());
        let d = spaced(&format!("Harness `{h}` is not emitted: {why}."));
        quote! { #[doc = #d] pub const #c: &str = #why; }
    });

    let doc = module_doc(plan, &skipped);
    let allows = super::allowed_lints();
    let cases = Literal::usize_unsuffixed(CASES);
    let doc_s = spaced(&doc);
    quote! {
        #[doc = #doc_s]
        #[cfg(test)]
        #[allow(#allows, dead_code, unused_variables)]
        pub mod #modname {
            extern crate std;

            use super::#target::{Controller, Inputs, States};

            /// Random cases per harness under `cargo test` (`BOLERO_RANDOM_ITERATIONS`
            /// overrides it); Kani ignores it and covers every value.
            const CASES: usize = #cases;

            /// Raw state values (pre- or post-step), widened to `i128` for exact arithmetic.
            #[derive(Clone, Copy, Debug)]
            struct StateRaw { #(#st_names: i128,)* }

            /// Raw input values, widened to `i128`.
            #[derive(Clone, Copy, Debug)]
            struct InputRaw { #(#in_names: i128,)* }

            /// Raw output values, widened to `i128`.
            #[derive(Clone, Copy, Debug)]
            struct OutputRaw { #(#out_names: i128,)* }

            /// One step's raw data: any input bits, states inside their bounds.
            #[derive(Clone, Copy, Debug, bolero::TypeGenerator)]
            struct StepCase { #(#input_fields_any)* #(#state_fields)* }

            /// Widens raw states.
            fn states_raw(#(#st_names: #st_tys),*) -> StateRaw {
                StateRaw { #(#st_names: i128::from(#st_names),)* }
            }

            /// Widens raw inputs.
            fn inputs_raw(#(#in_names: #in_tys),*) -> InputRaw {
                InputRaw { #(#in_names: i128::from(#in_names),)* }
            }

            /// Whether every state is inside its bounds (declared range quantised inward).
            fn in_bounds(s: &StateRaw) -> bool {
                #in_bounds_body
            }

            /// Asserts that every state is inside its bounds.
            fn assert_in_bounds(s: &StateRaw, when: &str) {
                #(#bound_asserts)*
            }

            /// Whether every input is inside its declared range (quantised inward).
            fn inputs_in_range(i: &InputRaw) -> bool {
                #in_range_body
            }

            #(#inv_fns)*

            /// Whether every invariant holds.
            fn invariants(s: &StateRaw) -> bool {
                #invariants_body
            }

            /// One step of the generated controller from raw input bits and raw states (which
            /// `set_states` saturates: a no-op inside the bounds). Returns the raw post-step
            /// states and the raw outputs.
            fn step(#(#in_args: #in_tys,)* #(#st_args: #st_tys,)*) -> (StateRaw, OutputRaw) {
                let mut ctl = Controller::new();
                ctl.set_states(States { #(#st_names: <#st_fixed>::from_bits(#st_args),)* });
                let out = ctl.step(Inputs { #(#in_names: <#in_fixed>::from_bits(#in_args),)* });
                let s = ctl.states();
                (
                    states_raw(#(s.#st_names.to_bits()),*),
                    OutputRaw { #(#out_names: i128::from(out.#out_names.to_bits()),)* },
                )
            }

            #ranges
            #initial
            #(#inv_harnesses)*
            #(#prop_harnesses)*
            #(#skipped_items)*
        }
    }
}

/// The module's doc comment.
fn module_doc(plan: &Plan, skipped: &[(String, String)]) -> String {
    let p = &plan.prog;
    let intro: Vec<&str> = p
        .docs
        .iter()
        .map(|l| l.trim())
        .take_while(|l| !l.is_empty())
        .collect();
    let mut d = format!(
        "Proof harnesses for [`super::{name}`], generated by qloop {ver} from spec `{name}`: \
         {intro}\n\n\
         Each harness is a Kani proof (`cargo kani --tests`) and, through bolero, a randomized \
         property test under `cargo test` ({CASES} cases each). They drive the generated \
         controller itself (`set_states`, `step`, `states`).\n\n\
         * `ranges_and_overflow`: no overflow, states stay inside their bounds.\n\
         * `initial`: the initial state is inside the bounds and the invariants.\n",
        name = p.name,
        ver = env!("CARGO_PKG_VERSION"),
        intro = intro.join(" "),
    );
    for inv in &p.invariants {
        d.push_str(&format!(
            "* `invariant_{}`: `{}` is inductive.\n",
            inv.name,
            show_cond(plan, &[], &inv.cond)
        ));
    }
    for pr in &p.properties {
        let names = param_names(pr);
        let show = |cs: &[PCond]| {
            list(
                cs.iter()
                    .map(|c| format!("`{}`", show_cond(plan, &names, c))),
            )
        };
        let mut line = format!("* `property_{}`: ", pr.name);
        if !pr.params.is_empty() {
            line.push_str(&format!(
                "for all {}, ",
                list(names.iter().map(|n| format!("`{n}`")))
            ));
        }
        if !pr.assumes.is_empty() {
            line.push_str(&format!("if {} then ", show(&pr.assumes)));
        }
        line.push_str(&format!("{}.\n", show(&pr.ensures)));
        d.push_str(&line);
    }
    d.push_str(
        "\nAssumptions are early `return`s: under Kani a path that returns before an assertion \
         cannot violate it, so an early return restricts the proof exactly like `kani::assume`; \
         under `cargo test` the case is skipped.\n\n\
         Conditions are evaluated exactly in `i128`: a signal is `raw · 2^-frac`, binary points \
         are aligned by left shifts, products add fraction bits, constants are their exact \
         binary values; every intermediate is bounded by 2^126 at generation time.\n\n\
         Overflow means Rust's arithmetic overflow checks (Kani's, or a debug build's). Bits \
         lost by a left shift or a narrowing `as` cast are not such an overflow: the bounds \
         assertions catch them where they reach a state, and the overflow obligations of \
         `qloop prove` cover every value.\n",
    );
    let claimed: Vec<String> = p
        .signals
        .iter()
        .filter(|s| s.claim.is_some())
        .map(|s| format!("`{}`", s.name))
        .collect();
    if !claimed.is_empty() {
        d.push_str(&format!(
            "\nThe `#[range]` claims on {} size the computation but are not visible through the \
             controller's API: only `qloop prove` checks them.\n",
            list(claimed.into_iter())
        ));
    }
    if !skipped.is_empty() {
        d.push_str("\nNot emitted:\n\n");
        for (h, why) in skipped {
            d.push_str(&format!("* `{h}`: {why}.\n"));
        }
    }
    d
}

/// A property's doc: what the harness checks.
fn property_doc(plan: &Plan, k: usize, grids: &[ParamGrid]) -> String {
    let p = &plan.prog.properties[k];
    let mut d = format!(
        "Property `{}`: for all inputs inside their declared ranges and states inside their \
         bounds satisfying every invariant",
        p.name
    );
    for (fp, g) in p.params.iter().zip(grids) {
        d.push_str(&format!(
            ", all `{}` in [{}, {}] (raw [{}, {}] · 2^-{})",
            fp.name, fp.range.0, fp.range.1, g.lo, g.hi, g.frac
        ));
    }
    d.push_str(": if ");
    if p.assumes.is_empty() {
        d.push_str("true");
    } else {
        d.push_str(&list(
            p.assumes
                .iter()
                .map(|c| format!("`{}`", show_cond(plan, &param_names(p), c))),
        ));
    }
    d.push_str(" then, after one step, ");
    d.push_str(&list(
        p.ensures
            .iter()
            .map(|c| format!("`{}`", show_cond(plan, &param_names(p), c))),
    ));
    d.push_str(". `x` is the state before the step, `next(x)` after it; inputs are read before, outputs after.");
    d
}

/// The names of a property's free parameters.
fn param_names(p: &Property) -> Vec<String> {
    p.params.iter().map(|fp| fp.name.clone()).collect()
}

/// The `assume` early returns and `ensure` assertions of property `k`.
fn property(
    plan: &Plan,
    k: usize,
    grids: &[ParamGrid],
) -> Result<(Vec<TokenStream>, Vec<TokenStream>), String> {
    let p = &plan.prog.properties[k];
    let names = param_names(p);
    let env = Env {
        plan,
        grids,
        params: &names,
        pre: format_ident!("pre"),
        post: format_ident!("post"),
    };
    let mut assumes = Vec::new();
    for a in &p.assumes {
        let text = show_cond(plan, &names, a);
        let c = env
            .cond(a)
            .map_err(|why| format!("`{text}` cannot be evaluated exactly in i128 ({why})"))?;
        assumes.push(quote! {
            if !(#c) {
                return;
            }
        });
    }
    let mut ensures = Vec::new();
    for e in &p.ensures {
        let text = show_cond(plan, &names, e);
        let c = env
            .cond(e)
            .map_err(|why| format!("`{text}` cannot be evaluated exactly in i128 ({why})"))?;
        let msg = format!(
            "property `{}`: `{text}` is false after the step; {{:?}} -> {{:?}}, {{:?}}",
            p.name
        );
        ensures.push(quote! {
            let holds: bool = #c;
            assert!(holds, #msg, pre, post, outputs);
        });
    }
    Ok((assumes, ensures))
}

/// Where a property expression reads its values.
struct Env<'a> {
    plan: &'a Plan,
    /// Free parameters: grids and names.
    grids: &'a [ParamGrid],
    params: &'a [String],
    /// Pre-step states.
    pre: Ident,
    /// Post-step states.
    post: Ident,
}

/// An exactly evaluated `i128` expression: its tokens, its binary point and the bounds of its
/// raw value.
struct Ev {
    t: TokenStream,
    frac: i32,
    lo: i128,
    hi: i128,
    /// The raw value, if constant.
    konst: Option<i128>,
}

fn limit() -> i128 {
    1i128 << LIMIT_BITS
}

fn checked(lo: Option<i128>, hi: Option<i128>, what: &str) -> Result<(i128, i128), String> {
    match (lo, hi) {
        (Some(lo), Some(hi)) if lo >= -limit() && hi <= limit() => Ok((lo, hi)),
        _ => Err(format!(
            "{what} can exceed 2^{LIMIT_BITS} in magnitude, too wide for exact i128 arithmetic"
        )),
    }
}

impl Ev {
    fn konst(v: i128, frac: i32) -> Ev {
        Ev {
            t: i128_lit(v),
            frac,
            lo: v,
            hi: v,
            konst: Some(v),
        }
    }

    /// The same value with `f ≥ frac` fraction bits.
    fn at(self, f: i32) -> Result<Ev, String> {
        let k = (f - self.frac) as u32;
        if k == 0 {
            return Ok(self);
        }
        let scale = (k <= LIMIT_BITS).then(|| 1i128 << k);
        let (lo, hi) = checked(
            scale.and_then(|s| self.lo.checked_mul(s)),
            scale.and_then(|s| self.hi.checked_mul(s)),
            "a binary-point alignment",
        )?;
        if let Some(v) = self.konst {
            return Ok(Ev::konst(v << k, f));
        }
        let t = self.t;
        let k = Literal::u32_unsuffixed(k);
        Ok(Ev {
            t: quote! { (#t << #k) },
            frac: f,
            lo,
            hi,
            konst: None,
        })
    }
}

impl Env<'_> {
    fn cond(&self, c: &PCond) -> Result<TokenStream, String> {
        prop_eval::cond(&mut &*self, c)
    }
}

/// `i128` Rust expressions, each with the interval of its raw value: a harness refuses a
/// property it could not evaluate without overflow.
impl ExactDomain for &Env<'_> {
    type Value = Ev;
    type Bool = TokenStream;
    type Error = String;

    fn frac(v: &Ev) -> i32 {
        v.frac
    }

    fn inexact(&self, c: f64) -> String {
        format!("the constant {c} has no exact binary value")
    }

    fn constant(&mut self, m: i128, frac: i32) -> Result<Ev, String> {
        Ok(Ev::konst(m, frac))
    }

    fn signal(&mut self, id: SigId, when: When) -> Result<Ev, String> {
        let plan = self.plan;
        let s = plan.prog.sig(id);
        let q = plan.format(id);
        let n = format_ident!("{}", s.name);
        let (t, (lo, hi)) = match (s.kind, when) {
            (SigKind::Input, _) => (quote! { inputs.#n }, plan.bounds(id)),
            (SigKind::State, When::Pre) => {
                let v = &self.pre;
                (quote! { #v.#n }, plan.bounds(id))
            }
            (SigKind::State, When::Post) => {
                let v = &self.post;
                let r = if s.unsaturated {
                    (q.ty.min(), q.ty.max())
                } else {
                    plan.bounds(id)
                };
                (quote! { #v.#n }, r)
            }
            _ => (quote! { outputs.#n }, (q.ty.min(), q.ty.max())),
        };
        Ok(Ev {
            t,
            frac: q.frac,
            lo,
            hi,
            konst: None,
        })
    }

    fn param(&mut self, i: usize) -> Result<Ev, String> {
        let (g, name) = self
            .grids
            .get(i)
            .zip(self.params.get(i))
            .ok_or_else(|| format!("free parameter {i} is not declared"))?;
        let n = format_ident!("param_{name}");
        Ok(Ev {
            t: quote! { #n },
            frac: g.frac,
            lo: g.lo,
            hi: g.hi,
            konst: None,
        })
    }

    fn neg(&mut self, a: Ev) -> Result<Ev, String> {
        if let Some(v) = a.konst {
            return Ok(Ev::konst(-v, a.frac));
        }
        let t = a.t;
        Ok(Ev {
            t: quote! { (-#t) },
            frac: a.frac,
            lo: -a.hi,
            hi: -a.lo,
            konst: None,
        })
    }

    fn abs(&mut self, a: Ev) -> Result<Ev, String> {
        if let Some(v) = a.konst {
            return Ok(Ev::konst(v.abs(), a.frac));
        }
        let (lo, hi) = if a.lo >= 0 {
            (a.lo, a.hi)
        } else if a.hi <= 0 {
            (-a.hi, -a.lo)
        } else {
            (0, a.hi.max(-a.lo))
        };
        let t = a.t;
        Ok(Ev {
            t: quote! { #t.abs() },
            frac: a.frac,
            lo,
            hi,
            konst: None,
        })
    }

    fn arith(&mut self, op: Arith, a: Ev, b: Ev, f: i32) -> Result<Ev, String> {
        let (a, b) = (a.at(f)?, b.at(f)?);
        let (x, y) = (a.t, b.t);
        let (t, (lo, hi)) = match op {
            Arith::Add => (
                quote! { (#x + #y) },
                checked(a.lo.checked_add(b.lo), a.hi.checked_add(b.hi), "a sum")?,
            ),
            Arith::Sub => (
                quote! { (#x - #y) },
                checked(
                    a.lo.checked_sub(b.hi),
                    a.hi.checked_sub(b.lo),
                    "a difference",
                )?,
            ),
            Arith::Min => (
                quote! { ::core::cmp::min(#x, #y) },
                (a.lo.min(b.lo), a.hi.min(b.hi)),
            ),
            Arith::Max => (
                quote! { ::core::cmp::max(#x, #y) },
                (a.lo.max(b.lo), a.hi.max(b.hi)),
            ),
        };
        Ok(Ev {
            t,
            frac: f,
            lo,
            hi,
            konst: None,
        })
    }

    fn mul(&mut self, a: Ev, b: Ev) -> Result<Ev, String> {
        let corners = [
            a.lo.checked_mul(b.lo),
            a.lo.checked_mul(b.hi),
            a.hi.checked_mul(b.lo),
            a.hi.checked_mul(b.hi),
        ];
        let all: Option<Vec<i128>> = corners.into_iter().collect();
        let (lo, hi) = checked(
            all.as_ref().and_then(|v| v.iter().min().copied()),
            all.as_ref().and_then(|v| v.iter().max().copied()),
            "a product",
        )?;
        let frac = a.frac + b.frac;
        if let (Some(x), Some(y)) = (a.konst, b.konst) {
            return Ok(Ev::konst(x * y, frac));
        }
        let (x, y) = (a.t, b.t);
        Ok(Ev {
            t: quote! { (#x * #y) },
            frac,
            lo,
            hi,
            konst: None,
        })
    }

    fn cmp(&mut self, op: CmpOp, a: Ev, b: Ev, f: i32) -> Result<TokenStream, String> {
        let (x, y) = (a.at(f)?.t, b.at(f)?.t);
        let op: TokenStream = op.symbol().parse().unwrap_or_default();
        Ok(quote! { #x #op #y })
    }

    fn and(&mut self, x: TokenStream, y: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { (#x && #y) })
    }

    fn or(&mut self, x: TokenStream, y: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { (#x || #y) })
    }

    fn not(&mut self, x: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { !(#x) })
    }
}

/// The narrowest signed Rust type holding a parameter grid.
fn param_ty(g: &ParamGrid) -> Ident {
    match IntTy::signed_for(g.lo, g.hi, 8) {
        Some(t) => int_ty(t),
        None => Ident::new("i128", Span::call_site()),
    }
}

/// An unsuffixed integer literal (negative as `-N`); the context gives its type.
fn int(v: i128) -> TokenStream {
    let l = Literal::i128_unsuffixed(v.unsigned_abs() as i128);
    if v < 0 {
        quote! { -#l }
    } else {
        quote! { #l }
    }
}

/// An `i128` literal.
fn i128_lit(v: i128) -> TokenStream {
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
fn spaced(d: &str) -> String {
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

fn doc_lines(docs: &[String]) -> String {
    let mut d = docs.join("\n");
    if !d.is_empty() {
        d.push_str("\n\n");
    }
    d
}

/// `a, b and c`.
fn list(items: impl Iterator<Item = String>) -> String {
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
