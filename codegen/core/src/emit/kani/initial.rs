//! The `initial` harness: `Controller::new()` is inside the state bounds and satisfies every
//! invariant (the initial obligations of `qloop prove`).

use super::invariant::Invariants;
use super::show::{check, show_cond, spaced};
use super::sigs::Sigs;
use crate::lower::Plan;
use proc_macro2::TokenStream;
use quote::quote;

/// The harness.
pub(super) fn harness(plan: &Plan, sigs: &Sigs, invs: &Invariants) -> TokenStream {
    let prog = &plan.prog;
    let st_paths = &sigs.st_paths;
    let init_doc = format!(
        "Initial state: `{}::Controller::new()` is inside the state bounds and satisfies every \
         invariant.",
        prog.name
    );
    let init_invs = prog.invariants.iter().zip(&invs.ok).filter_map(|(inv, f)| {
        let f = f.as_ref()?;
        let literal = format!(
            "invariant `{}` (`{}`) is false initially",
            inv.name,
            show_cond(plan, &[], &inv.cond)
        );
        let check = check(
            &quote! { holds },
            &literal,
            &format!("{literal}: {{:?}}"),
            quote! { pre },
        );
        Some(quote! {
            let holds = #f(&pre);
            #check
        })
    });
    let init_doc_s = spaced(&init_doc);
    quote! {
        #[doc = #init_doc_s]
        #[test]
        #[cfg_attr(kani, kani::proof)]
        #[cfg_attr(kani, kani::solver(kissat))]
        fn initial() {
            let s = Controller::new().states();
            let pre = states_raw(#(#st_paths),*);
            assert_in_bounds(&pre, "initially");
            #(#init_invs)*
        }
    }
}
