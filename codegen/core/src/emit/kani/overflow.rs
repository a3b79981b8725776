//! The `ranges_and_overflow` harness: for any input bits and any states inside their bounds,
//! one step overflows nothing and leaves every state inside its bounds (the overflow and
//! range obligations of `qloop prove`).

use super::show::{list, spaced};
use super::sigs::Sigs;
use crate::lower::Plan;
use crate::text::g;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// The harness.
pub(super) fn harness(plan: &Plan, sigs: &Sigs) -> TokenStream {
    let prog = &plan.prog;
    let (step_args, pre_from_case) = (sigs.step_args(), sigs.pre_from_case());
    let ranges_doc = format!(
        "Ranges and overflow: for any input bits and any states inside their bounds, one step \
         of the generated `{name}::Controller` overflows no intermediate (a failed check under \
         Kani, a debug-build panic under `cargo test`) and leaves every state inside its \
         bounds, the declared range quantised inward: {bounds}. Mirrors the overflow \
         obligations of `qloop prove` and its \"… stays inside its range\" obligations.",
        name = prog.name,
        bounds = list(
            sigs.states
                .iter()
                .zip(&sigs.st_bounds)
                .map(|(id, (lo, hi))| {
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
                })
        )
    );
    let ranges_doc_s = spaced(&ranges_doc);
    let cases = super::for_each_case(
        &format_ident!("StepCase"),
        quote! {
            |c: &StepCase| {
                let pre = #pre_from_case;
                // Assume: states inside their bounds.
                if !in_bounds(&pre) {
                    return;
                }
                let (post, _) = step(#step_args);
                assert_in_bounds(&post, "after a step");
            }
        },
    );
    quote! {
        #[doc = #ranges_doc_s]
        #[test]
        #[cfg_attr(kani, kani::proof)]
        #[cfg_attr(kani, kani::solver(kissat))]
        fn ranges_and_overflow() {
            #cases
        }
    }
}
