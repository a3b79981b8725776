//! Emits proof harnesses for the fixed-point module: Kani proofs that also run as randomized
//! property tests.
//!
//! Each harness body is a closure over one case: under `cargo kani --tests` it runs on one
//! symbolic case, `kani::any()` (any bits; the body's early returns restrict them), so a
//! harness is a proof over every value; under `cargo test` [bolero](https://docs.rs/bolero)
//! runs it on [`CASES`] random cases within the generator ranges. Kani does not go through
//! bolero's driver, whose panic paths it reported as unsupported constructs. They call the generated controller itself (`set_states`, `step`,
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
//!   bounds and invariants, and free parameters on their grid ([`crate::prop_eval::param_grids`]): the `assume`s
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
//! their exact binary values `m · 2^-f` ([`crate::prop_eval::exact_binary`]). The magnitude of every
//! intermediate is bounded here, from the raw ranges; a harness whose bound would exceed
//! 2^126 is not emitted, and a documented constant says why.
//!
//! Under Kani, a property whose conditions multiply two non-constant values is checked on
//! an exact-term model of the step with its products replaced by verified contracts
//! (`model`, which documents the chain of harnesses this rests on).
//!
//! One module per part: `sigs` (the signals, read once), `scaffold` (the shared items),
//! one per harness kind (`overflow`, `initial`, `invariant`, `property`), `exact`
//! (the exact `i128` evaluator), `model` (the step models, their product contracts and
//! `model_matches_*`), `docs` and `show` (doc text and literals).

mod abstraction;
mod docs;
mod exact;
mod initial;
mod invariant;
mod overflow;
mod property;
mod scaffold;
mod show;
mod sigs;

pub use show::{show_cond, show_expr};

use crate::lower::Plan;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// Random cases each harness runs under `cargo test` (bolero's own default is "as many as fit
/// in one second", which varies with the machine and the build): enough for the default test
/// run to exercise every harness in a fraction of a second. `BOLERO_RANDOM_ITERATIONS`
/// overrides it, and the acceptance tier sets it to [`ACCEPTANCE_CASES`]; under Kani it is
/// ignored.
pub const CASES: usize = 1_000;

/// Random cases per harness in the acceptance tier (`.ci/run` sets `BOLERO_RANDOM_ITERATIONS`
/// to this; the book's "Tests and their tiers").
pub const ACCEPTANCE_CASES: usize = 100_000;

/// Largest magnitude, as a power of two, an exactly evaluated intermediate may reach.
pub const LIMIT_BITS: u32 = 126;

/// Runs `body` (a closure over `&ty`) on every case: under Kani on one symbolic case
/// (`kani::any()`, any bits: the body's early returns restrict it), under `cargo test` on
/// [`CASES`] random cases drawn by bolero within the generator ranges. Kani does not go through
/// bolero's driver, whose panic paths Kani reports as unsupported constructs.
fn for_each_case(ty: &proc_macro2::Ident, body: TokenStream) -> TokenStream {
    quote! {
        let body = #body;
        #[cfg(kani)]
        body(&kani::any::<#ty>());
        #[cfg(not(kani))]
        bolero::check!()
            .with_type::<#ty>()
            .with_iterations(CASES)
            .for_each(body);
    }
}

/// Harnesses not emitted, with the reason: `(harness name, why)`.
type Skipped = Vec<(String, String)>;

/// The harness module for `plan`, named `<spec>_proofs`, to be placed next to the fixed-point
/// module (it refers to `super::<spec>`).
pub fn module(plan: &Plan) -> TokenStream {
    // Shared loop bodies: their products are one function each, over the copies' hull.
    let em = crate::emit::repeat::emit(plan);
    let plan = &em.plan;
    let prog = &plan.prog;
    let modname = format_ident!("{}_proofs", prog.name);
    let target = format_ident!("{}", prog.name);
    let sigs = sigs::Sigs::new(plan);
    let invs = invariant::Invariants::new(plan);
    let mut skipped = Skipped::new();
    let ranges = overflow::harness(plan, &sigs);
    let initial = initial::harness(plan, &sigs, &invs);
    let inv_harnesses = invariant::harnesses(plan, &sigs, &invs, &mut skipped);
    let abs = std::cell::RefCell::new(abstraction::Abstraction::new(plan, &em));
    let mut abstracted = Vec::new();
    let prop_harnesses =
        property::harnesses(plan, &sigs, &invs, &mut skipped, &mut abstracted, &abs);
    let abs = abs.into_inner();
    let (abs_items, abs_summary) = if abstracted.is_empty() {
        (TokenStream::new(), Vec::new())
    } else {
        (abs.items(), abs.summary())
    };
    let shared = scaffold::items(&sigs, &invs);

    let skipped_items = skipped.iter().map(|(h, why)| {
        let c = format_ident!("SKIPPED_{}", h.to_uppercase());
        let d = show::spaced(&format!("Harness `{h}` is not emitted: {why}."));
        quote! { #[doc = #d] pub const #c: &str = #why; }
    });

    let doc = docs::module_doc(plan, &skipped, &abstracted, &abs_summary);
    let allows = super::allowed_lints();
    let cases = Literal::usize_unsuffixed(CASES);
    let doc_s = show::spaced(&doc);
    quote! {
        #[doc = #doc_s]
        #[cfg(test)]
        #[allow(#allows, dead_code, unused_variables, clippy::too_many_arguments)]
        pub mod #modname {
            extern crate std;

            use super::#target::{Controller, Inputs, States};

            /// Random cases per harness under `cargo test` (`BOLERO_RANDOM_ITERATIONS`
            /// overrides it: the acceptance tier runs 100,000); Kani ignores it and covers
            /// every value.
            const CASES: usize = #cases;

            #shared

            #ranges
            #initial
            #(#inv_harnesses)*
            #(#prop_harnesses)*
            #abs_items
            #(#skipped_items)*
        }
    }
}
