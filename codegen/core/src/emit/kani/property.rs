//! One harness per property: from inputs inside their declared ranges, states inside the
//! bounds and invariants, and free parameters on their grid, the `assume`s imply every
//! `ensure` after one step (the property obligations of `qloop prove`).

use super::docs::{param_names, property_doc};
use super::exact::Env;
use super::invariant::Invariants;
use super::show::{check, conjuncts, doc_lines, int, param_ty, show_cond, spaced};
use super::sigs::Sigs;
use super::Skipped;
use crate::lower::Plan;
use crate::prop_eval::{param_grids, ParamGrid};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// The property harnesses; a property that cannot be evaluated exactly is listed in `skipped`.
pub(super) fn harnesses(
    plan: &Plan,
    sigs: &Sigs,
    invs: &Invariants,
    skipped: &mut Skipped,
) -> Vec<TokenStream> {
    let prog = &plan.prog;
    let (in_names, step_args, pre_from_case) =
        (&sigs.in_names, sigs.step_args(), sigs.pre_from_case());
    let (input_fields_ranged, state_fields) = (sigs.input_fields_ranged(), sigs.state_fields());
    let mut prop_harnesses = Vec::new();
    for (k, p) in prog.properties.iter().enumerate() {
        let harness = format!("property_{}", p.name);
        if let Some(why) = &invs.blocked {
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

                        // Cases past the assumptions, counted under `cargo test` (Kani's
                        // `cover!` shows the same; no atomics on its path).
                        #[cfg(not(kani))]
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
                                #[cfg(not(kani))]
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
    prop_harnesses
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
    for e in p.ensures.iter().flat_map(conjuncts) {
        let text = show_cond(plan, &names, e);
        let c = env
            .cond(e)
            .map_err(|why| format!("`{text}` cannot be evaluated exactly in i128 ({why})"))?;
        let literal = format!("property `{}`: `{text}` is false after the step", p.name);
        let fmt = format!("{literal}; {{:?}} -> {{:?}}, {{:?}}");
        let holds = quote! { holds };
        let check = check(&holds, &literal, &fmt, quote! { pre, post, outputs });
        ensures.push(quote! {
            let holds: bool = #c;
            #check
        });
    }
    Ok((assumes, ensures))
}
