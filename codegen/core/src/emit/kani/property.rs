//! One harness per property: from inputs inside their declared ranges, states inside the
//! bounds and invariants, and free parameters on their grid, the `assume`s imply every
//! `ensure` after one step (the property obligations of `qloop prove`).

use super::abstraction::{multiplies, Abstraction};
use super::docs::{param_names, property_doc};
use super::exact::Env;
use super::invariant::Invariants;
use super::show::{
    check, conjuncts, doc_lines, param_fields, param_lets, param_ranges, show_cond, spaced,
};
use super::sigs::Sigs;
use super::Skipped;
use crate::ir::PCond;
use crate::lower::Plan;
use crate::prop_eval::{param_grids, ParamGrid};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use std::cell::RefCell;

/// The property harnesses; a property that cannot be evaluated exactly is listed in `skipped`.
/// Properties that multiply two non-constant values run, under Kani, on the step with its
/// products abstracted ([`Abstraction`]); their names are listed in `abstracted`.
pub(super) fn harnesses(
    plan: &Plan,
    sigs: &Sigs,
    invs: &Invariants,
    skipped: &mut Skipped,
    abstracted: &mut Vec<String>,
    abs: &RefCell<Abstraction<'_>>,
) -> Vec<TokenStream> {
    let prog = &plan.prog;
    let (in_names, step_args, pre_from_case) =
        (&sigs.in_names, sigs.step_args(), sigs.pre_from_case());
    let (input_fields_ranged, state_fields) = (sigs.input_fields_ranged(), sigs.state_fields());
    let mut prop_harnesses = Vec::new();
    for (k, p) in prog.properties.iter().enumerate() {
        if let Some(why) = &invs.blocked {
            skipped.push((format!("property_{}", p.name), why.clone()));
            continue;
        }
        let grids = param_grids(plan, k);
        let (assumes, all_ensures) = match property(plan, k, &grids) {
            Ok(body) => body,
            Err(why) => {
                skipped.push((format!("property_{}", p.name), why));
                continue;
            }
        };
        let names = param_names(p);
        let clauses: Vec<&PCond> = p.ensures.iter().flat_map(conjuncts).collect();
        // One harness per clause of the `ensure`s where there are several, so that each is
        // decided (and timed) on its own: CBMC checks a harness's assertions in one SAT
        // problem, and the two clauses of the grinding `pi_law_eq8` together do not finish
        // in 120 s where each alone does.
        let parts: Vec<Option<usize>> = if clauses.len() > 1 {
            (0..clauses.len()).map(Some).collect()
        } else {
            vec![None]
        };
        for part in parts {
            let harness = match part {
                None => format!("property_{}", p.name),
                Some(j) => format!("property_{}_clause_{}", p.name, j + 1),
            };
            let fname = format_ident!("{harness}");
            let mut doc = doc_lines(&p.docs);
            doc.push_str(&property_doc(plan, k, &grids));
            if let Some(j) = part {
                doc.push_str(&format!(
                    "\n\nThis harness checks clause {} of {}, `{}`; each clause has its own \
                         harness, so that Kani decides and times each on its own.",
                    j + 1,
                    clauses.len(),
                    show_cond(plan, &names, clauses[j])
                ));
            }
            let (param_fields, params) = (param_fields(p, &grids), param_lets(p));
            let param_ranges = param_ranges(p, &grids);
            // Kani draws any bits: free parameters on their grid (bolero draws them there).
            let param_check = if p.params.is_empty() {
                TokenStream::new()
            } else {
                quote! {
                    #[cfg(kani)]
                    if !(#param_ranges) {
                        return;
                    }
                }
            };
            let report = format!("{harness}: {{}} cases satisfied the assumptions");
            let cover = format!("the assumptions of property `{}` are satisfiable", p.name);
            let ensures: Vec<&TokenStream> = all_ensures
                .iter()
                .enumerate()
                .filter(|(j, _)| part.is_none_or(|only| only == *j))
                .map(|(_, e)| e)
                .collect();
            let wants = p.assumes.iter().chain(&p.ensures).any(multiplies);
            let (kani_path, stubs) =
                match wants.then(|| abstracted_path(plan, k, &grids, &step_args, abs, part)) {
                    Some(Ok(path)) => {
                        doc.push_str(ABSTRACTED_DOC);
                        if !abstracted.contains(&p.name) {
                            abstracted.push(p.name.clone());
                        }
                        (Some(path), abs.borrow().stubs())
                    }
                    Some(Err(why)) => {
                        doc.push_str(&format!(
                            "\n\nUnder Kani this harness runs the generated step with exact \
                             products: {why}."
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
            let cases = super::for_each_case(
                &format_ident!("Case"),
                quote! {
                    |c: &Case| {
                        let inputs = inputs_raw(#(c.#in_names),*);
                        let pre = #pre_from_case;
                        #(#params)*
                        #param_check
                        #kani_path
                        #direct
                    }
                },
            );
            prop_harnesses.push(quote! {
                    #[doc = #doc_s]
                    #[test]
                    #[cfg_attr(kani, kani::proof)]
            #[cfg_attr(kani, kani::solver(kissat))]
                    #(#[cfg_attr(kani, kani::stub(#stubs))])*
                    fn #fname() {
                        /// Inputs inside their declared ranges, states inside their bounds,
                        /// free parameters on their grid (raw).
                        #[derive(Clone, Copy, Debug, bolero::TypeGenerator)]
                        #[cfg_attr(kani, derive(kani::Arbitrary))]
                        struct Case { #(#input_fields_ranged)* #(#state_fields)* #(#param_fields)* }

                        // Cases past the assumptions, counted under `cargo test` (Kani's
                        // `cover!` shows the same; no atomics on its path).
                        #[cfg(not(kani))]
                        let held = ::core::sync::atomic::AtomicUsize::new(0);
                        #cases
                        #[cfg(not(kani))]
                        {
                            let held = held.into_inner();
                            std::println!(#report, held);
                        }
                    }
                });
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
    let env = Env::step(plan, grids, &names, None);
    let assumes = early_returns(&env, &names, &p.assumes)?;
    let mut ensures = Vec::new();
    for e in p.ensures.iter().flat_map(conjuncts) {
        let text = show_cond(plan, &names, e);
        let c = exact_cond(&env, &names, e)?;
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

/// The `bool` expression of `c`, or why it cannot be evaluated exactly.
fn exact_cond(env: &Env, names: &[String], c: &PCond) -> Result<TokenStream, String> {
    env.cond(c).map_err(|why| {
        let text = show_cond(env.plan, names, c);
        format!("`{text}` cannot be evaluated exactly in i128 ({why})")
    })
}

/// An early `return` unless each condition holds (an `assume` under Kani and bolero).
fn early_returns(env: &Env, names: &[String], conds: &[PCond]) -> Result<Vec<TokenStream>, String> {
    conds
        .iter()
        .map(|a| {
            let c = exact_cond(env, names, a)?;
            Ok(quote! {
                if !(#c) {
                    return;
                }
            })
        })
        .collect()
}

/// What the harness doc says of a property whose products are abstracted under Kani.
const ABSTRACTED_DOC: &str = "\n\nUnder Kani this harness runs the generated step with its \
    products of two non-constant values stubbed by their abstractions (`abs_mul_*`), and \
    evaluates the invariants and this property's own products through the same abstractions, \
    rewritten exactly onto the step's (module doc): each abstraction asserts its factors' \
    intervals and assumes only clauses that a `lemma_*` harness proves. Under `cargo test` \
    it runs the generated step and multiplies exactly.";

/// The Kani path of property `k` with abstracted products: the premises (inputs, states,
/// invariants), the step, the `assume`s, a `cover!`, one `kani::assert` per conjunct of the
/// `ensure`s.
fn abstracted_path(
    plan: &Plan,
    k: usize,
    grids: &[ParamGrid],
    step_args: &TokenStream,
    abs: &RefCell<Abstraction<'_>>,
    only: Option<usize>,
) -> Result<TokenStream, String> {
    let p = &plan.prog.properties[k];
    let names = param_names(p);
    let subst = crate::terms::param_state_pairs(plan, &p.assumes, &p.ensures)
        .into_iter()
        .filter_map(|(i, s)| {
            let g = grids.get(i)?;
            let (shift, dlo, dhi) = crate::terms::param_shift(plan, g, s, plan.bounds(s))?;
            Some((i, (s, shift, dlo, dhi)))
        })
        .collect();
    abs.borrow_mut().set_params(subst, &names);
    let env = Env::step(plan, grids, &names, Some(abs));
    if !abs.borrow().has_invariants() {
        let inv_env = Env::states(plan, "pre", Some(abs));
        let mut conds = Vec::new();
        for inv in &plan.prog.invariants {
            conds.push(
                inv_env
                    .cond(&inv.cond)
                    .map_err(|why| format!("invariant `{}`: {why}", inv.name))?,
            );
        }
        abs.borrow_mut().set_invariants(conds);
    }
    let assumes = early_returns(&env, &names, &p.assumes)?;
    let mut asserts = Vec::new();
    for (j, e) in p.ensures.iter().flat_map(conjuncts).enumerate() {
        if only.is_some_and(|o| o != j) {
            continue;
        }
        let text = show_cond(plan, &names, e);
        let c = exact_cond(&env, &names, e)?;
        let literal = format!("property `{}`: `{text}` is false after the step", p.name);
        asserts.push(quote! { kani::assert(#c, #literal); });
    }
    let cover = format!("the assumptions of property `{}` are satisfiable", p.name);
    Ok(quote! {
        // Assume: inputs in range, states in bounds, invariants hold (products abstracted).
        if !(inputs_in_range(&inputs) && in_bounds(&pre)) {
            return;
        }
        if !invariants_abstracted(&pre) {
            return;
        }
        let (post, outputs) = step(#step_args);
        #(#assumes)*
        kani::cover!(true, #cover);
        #(#asserts)*
    })
}
