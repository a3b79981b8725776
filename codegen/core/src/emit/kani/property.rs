//! One harness per property: from inputs inside their declared ranges, states inside the
//! bounds and invariants, and free parameters on their grid, the `assume`s imply every
//! `ensure` after one step (the property obligations of `qloop prove`).

use super::docs::{param_names, property_doc};
use super::exact::Env;
use super::invariant::Invariants;
use super::model;
use super::show::{check, conjuncts, doc_lines, param_fields, param_lets, show_cond, spaced};
use super::sigs::Sigs;
use super::Skipped;
use crate::lower::Plan;
use crate::prop_eval::{param_grids, ParamGrid};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// A property checked on the step model under Kani ([`model`]): what its
/// `model_matches_<property>` harness needs.
pub(super) struct Modelled {
    /// The property's index.
    pub index: usize,
    /// The model function.
    pub func: proc_macro2::Ident,
}

/// The property harnesses; a property that cannot be evaluated exactly is listed in `skipped`.
/// Properties checked on the step model under Kani are listed in `modelled`, and their
/// models and products are part of the returned items.
pub(super) fn harnesses(
    plan: &Plan,
    sigs: &Sigs,
    invs: &Invariants,
    skipped: &mut Skipped,
    modelled: &mut Vec<Modelled>,
    prods: &mut model::Products,
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
                let (param_fields, params) = (param_fields(p, &grids), param_lets(p));
                let report = format!("{harness}: {{}} cases satisfied the assumptions");
                let cover = format!("the assumptions of property `{}` are satisfiable", p.name);
                let (assumes, ensures) = body;
                let (kani_path, stubs) = match model::model(plan, k, &grids, prods) {
                    Some(Ok(m)) => {
                        doc.push_str(&model_doc(&p.name, &m));
                        let path = model_path(plan, k, &m);
                        let stubs = m.prods.clone();
                        prop_harnesses.push(m.items);
                        modelled.push(Modelled {
                            index: k,
                            func: m.func,
                        });
                        (Some(path), stubs)
                    }
                    Some(Err(why)) => {
                        doc.push_str(&format!(
                            "\n\nUnder Kani this harness runs the generated step itself: {why}."
                        ));
                        (None, Vec::new())
                    }
                    None => (None, Vec::new()),
                };
                let direct = quote! {
                    // Assume: inputs in range, states in bounds, invariants hold.
                    if !(inputs_in_range(&inputs) && in_bounds(&pre) && invariants(&pre)) {
                        return;
                    }
                    let (post, outputs) = step(#step_args);
                    #(#assumes)*
                    #[cfg(not(kani))]
                    held.fetch_add(1, ::core::sync::atomic::Ordering::Relaxed);
                    #[cfg(kani)]
                    kani::cover!(true, #cover);
                    #(#ensures)*
                };
                let direct = if kani_path.is_some() {
                    quote! { #[cfg(not(kani))] { #direct } }
                } else {
                    direct
                };
                let kani_path = kani_path.map(|path| {
                    quote! {
                        #[cfg(kani)]
                        {
                            #path
                        }
                    }
                });
                let doc_s = spaced(&doc);
                prop_harnesses.push(quote! {
                    #[doc = #doc_s]
                    #[test]
                    #[cfg_attr(kani, kani::proof)]
                    #(#[cfg_attr(kani, kani::stub_verified(#stubs))])*
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
                                #(#params)*
                                #kani_path
                                #direct
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

/// What the harness doc says of a property checked on the step model.
fn model_doc(name: &str, m: &model::Model) -> String {
    format!(
        "\n\nUnder Kani this property is checked on the exact-term model `{}` of the step \
         (`model_matches_{name}` checks it against the generated step), with its {} products \
         replaced by their contracts (`stub_verified`, each checked by its `contract_*` \
         harness): products distributed and shared, each bounded by the McCormick planes and \
         sign-split bounds of exact multiplication. Under `cargo test` it runs the generated \
         step.",
        m.func,
        m.prods.len()
    )
}

/// The Kani path of a property checked on its model: the premises assumed on the model, a
/// `cover!`, one `kani::assert` per conjunct of the `ensure`s.
fn model_path(plan: &Plan, k: usize, m: &model::Model) -> TokenStream {
    let p = &plan.prog.properties[k];
    let names = param_names(p);
    let func = &m.func;
    let args = p.params.iter().map(|fp| format_ident!("param_{}", fp.name));
    let cover = format!("the assumptions of property `{}` are satisfiable", p.name);
    let asserts = p
        .ensures
        .iter()
        .flat_map(conjuncts)
        .enumerate()
        .map(|(j, e)| {
            let text = show_cond(plan, &names, e);
            let literal = format!("property `{}`: `{text}` is false after the step", p.name);
            quote! { kani::assert(goals[#j], #literal); }
        });
    quote! {
        // Assume: inputs in range, states in bounds; then, on the model, the invariants and
        // the `assume`s.
        if !(inputs_in_range(&inputs) && in_bounds(&pre)) {
            return;
        }
        let (_, premises, goals) = #func(&inputs, &pre, #(#args),*);
        if !premises {
            return;
        }
        kani::cover!(true, #cover);
        #(#asserts)*
    }
}
