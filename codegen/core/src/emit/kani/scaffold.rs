//! The items every harness shares: raw-value structs, the step-case generator, widening,
//! bounds and range checks, the invariants, and `step`, which drives the generated
//! controller itself.

use super::invariant::Invariants;
use super::show::{check, int};
use super::sigs::Sigs;
use proc_macro2::TokenStream;
use quote::quote;

/// The shared items, in the order they appear in the module.
pub(super) fn items(sigs: &Sigs, invs: &Invariants) -> TokenStream {
    let Sigs {
        in_names,
        st_names,
        out_names,
        in_args,
        st_args,
        in_tys,
        st_tys,
        st_bounds,
        in_ranges,
        st_paths,
        out_paths,
        states_value,
        inputs_value,
        ..
    } = sigs;
    let bound_checks = st_names.iter().zip(st_bounds).map(|(n, (lo, hi))| {
        let (lo, hi) = (int(*lo), int(*hi));
        quote! { (#lo..=#hi).contains(&s.#n) }
    });
    let range_checks = in_names.iter().zip(in_ranges).map(|(n, (lo, hi))| {
        let (lo, hi) = (int(*lo), int(*hi));
        quote! { (#lo..=#hi).contains(&i.#n) }
    });
    let bound_asserts = st_names.iter().zip(st_bounds).map(|(n, (lo, hi))| {
        let literal = format!("state `{n}` is outside its bounds [{lo}, {hi}] (raw)");
        let fmt = format!("{{}}: state `{n}` = raw {{}} is outside [{lo}, {hi}]");
        let (lo, hi) = (int(*lo), int(*hi));
        let check = check(&quote! { inside }, &literal, &fmt, quote! { when, s.#n });
        quote! {
            let inside = (#lo..=#hi).contains(&s.#n);
            #check
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
    let (input_fields_any, state_fields) = (sigs.input_fields_any(), sigs.state_fields());
    let inv_fns = &invs.fns;
    let invariants_body = invs.all();
    quote! {
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
        #[cfg_attr(kani, derive(kani::Arbitrary))]
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
            ctl.set_states(States { #states_value });
            let out = ctl.step(Inputs { #inputs_value });
            let s = ctl.states();
            (
                states_raw(#(#st_paths),*),
                OutputRaw { #(#out_names: i128::from(#out_paths),)* },
            )
        }
    }
}
