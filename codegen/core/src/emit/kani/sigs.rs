//! The controller's signals as the harnesses see them: names, raw storage types, `fixed` types
//! and raw bounds, read once from the plan.

use super::super::rust::{from_api, int_ty, to_api};
use super::show::int;
use crate::ir::{SigId, SigKind};
use crate::lower::Plan;
use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote};

/// Inputs, states and outputs in declaration order, with what every harness needs of them.
pub(super) struct Sigs {
    /// State ids.
    pub states: Vec<SigId>,
    /// Field names.
    pub in_names: Vec<Ident>,
    pub st_names: Vec<Ident>,
    pub out_names: Vec<Ident>,
    /// Argument names of the harnesses' `step` (`in_x`, `st_x`).
    pub in_args: Vec<Ident>,
    pub st_args: Vec<Ident>,
    /// Raw storage types.
    pub in_tys: Vec<Ident>,
    pub st_tys: Vec<Ident>,
    /// Raw bounds of each state and declared (inward-quantised) range of each input.
    pub st_bounds: Vec<(i128, i128)>,
    pub in_ranges: Vec<(i128, i128)>,
    /// Each state's raw value read from the `States` value `s` (`s.theta[0].to_bits()`, a
    /// conversion where its vector's API format is not its own), and each output's from `out`.
    pub st_paths: Vec<TokenStream>,
    pub out_paths: Vec<TokenStream>,
    /// `States { .. }` from the harness arguments `st_*`, and `Inputs { .. }` from `in_*`.
    pub states_value: TokenStream,
    pub inputs_value: TokenStream,
}

impl Sigs {
    /// Reads the signals of `plan`.
    pub fn new(plan: &Plan) -> Sigs {
        let prog = &plan.prog;
        let ids = |k: SigKind| prog.ids_of(k).collect::<Vec<_>>();
        let (inputs, states, outputs) = (
            ids(SigKind::Input),
            ids(SigKind::State),
            ids(SigKind::Output),
        );
        let name = |id: &SigId| format_ident!("{}", prog.sig(*id).name);
        let arg = |pre: &str, id: &SigId| format_ident!("{pre}_{}", prog.sig(*id).name);
        let storage = |id: &SigId| int_ty(plan.format(*id).ty);
        let path = |id: &SigId| crate::emit::field_path(prog, *id);
        let value = |k: SigKind, pre: &str| {
            let fields = crate::emit::members(prog, k).into_iter().map(|m| {
                let n = format_ident!("{}", m.name(prog));
                let items = m
                    .ids()
                    .iter()
                    .map(|id| {
                        let a = arg(pre, id);
                        to_api(plan, *id, quote! { #a })
                    })
                    .collect();
                let v = crate::emit::nest(m.dims(), items);
                quote! { #n: #v, }
            });
            quote! { #(#fields)* }
        };
        // Each signal's raw value read from the API value `from` (`s`, `out`).
        let reads = |ids: &[SigId], from: TokenStream| -> Vec<TokenStream> {
            ids.iter()
                .map(|id| {
                    let p = path(id);
                    from_api(plan, *id, quote! { #from.#p })
                })
                .collect()
        };
        Sigs {
            st_paths: reads(&states, quote! { s }),
            out_paths: reads(&outputs, quote! { out }),
            states_value: value(SigKind::State, "st"),
            inputs_value: value(SigKind::Input, "in"),
            in_names: inputs.iter().map(name).collect(),
            st_names: states.iter().map(name).collect(),
            out_names: outputs.iter().map(name).collect(),
            in_args: inputs.iter().map(|id| arg("in", id)).collect(),
            st_args: states.iter().map(|id| arg("st", id)).collect(),
            in_tys: inputs.iter().map(storage).collect(),
            st_tys: states.iter().map(storage).collect(),
            st_bounds: states.iter().map(|id| plan.bounds(*id)).collect(),
            in_ranges: inputs.iter().map(|id| plan.bounds(*id)).collect(),
            states,
        }
    }

    /// Generator fields of the states: each inside its bounds.
    pub fn state_fields(&self) -> Vec<TokenStream> {
        ranged_fields(&self.st_names, &self.st_tys, &self.st_bounds)
    }

    /// Generator fields of the inputs: any bits.
    pub fn input_fields_any(&self) -> Vec<TokenStream> {
        self.in_names
            .iter()
            .zip(&self.in_tys)
            .map(|(n, t)| quote! { #n: #t, })
            .collect()
    }

    /// Generator fields of the inputs: each inside its declared range.
    pub fn input_fields_ranged(&self) -> Vec<TokenStream> {
        ranged_fields(&self.in_names, &self.in_tys, &self.in_ranges)
    }

    /// The harness `step`'s arguments, read from a generated case `c`.
    pub fn step_args(&self) -> TokenStream {
        let (i, s) = (&self.in_names, &self.st_names);
        quote! { #(c.#i,)* #(c.#s,)* }
    }

    /// The pre-step raw states of a generated case `c`.
    pub fn pre_from_case(&self) -> TokenStream {
        let s = &self.st_names;
        quote! { states_raw(#(c.#s),*) }
    }
}

/// `#[generator(lo..=hi)] name: ty,` per signal.
fn ranged_fields(names: &[Ident], tys: &[Ident], bounds: &[(i128, i128)]) -> Vec<TokenStream> {
    names
        .iter()
        .zip(tys)
        .zip(bounds)
        .map(|((n, t), (lo, hi))| {
            let (lo, hi) = (int(*lo), int(*hi));
            quote! { #[generator(#lo..=#hi)] #n: #t, }
        })
        .collect()
}
