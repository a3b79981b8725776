//! Seed controllers compiled by qloop from `verified/specs/*.qloop` through the
//! `controller!` macro. `#![no_std]`: the fixed-point modules use only integer arithmetic.
//!
//! * [`koren_masory_1981`]: the adaptive ACC of Koren & Masory (1981), process estimator
//!   (Koren & Masory 1981, eqs. 8-9) and variable-gain loop (eqs. 12-13).
//! * [`koren_masory_tuned`]: the same controller with the loop gain K = 0.2 that `qloop tune`
//!   chose on the turning plant (`specs/koren_masory_tuned.qloop`, written by the tuner).
//! * [`koren_masory_safe`]: the tuned controller with qloop's machining safety rules
//!   (`use feed_safety;`: air-cut feed, asymmetric back-off, FMAX, FMIN, overload and
//!   unknown-load holds, the latched feed hold), each rule's properties proved on the composed
//!   step.
//! * [`acc_fixed_gain`]: conventional ACC with a fixed gain (Koren's survey, eqs. 6-9).
//! * [`grinding_pi`]: the fixed-gain PI grinding force controller of Jenkins & Kurfess
//!   (Jenkins & Kurfess, eqs. 3, 5, 8).
//! * [`milling_acc`]: the same 1981 adaptive ACC retuned for the milling process of
//!   Rubio & De la Sen (eqs. 1-3; T = 0.0839 s, F_r = 1.2 kN).
//! * [`gac_surface_finish`]: geometric adaptive control of the surface finish, one step per
//!   part: recursive least squares of Koren's survey, eq. 29 and a Newton step on
//!   the feed, both division-free (`newton_recip`).
//! * [`milling_multimodel`]: the multi-model adaptive controller of Rubio & De la Sen
//!   (Rubio & De la Sen, eqs. 4-11 and its switching rule): seven recursive
//!   least-squares estimators on β-FROH discretisations, a model-following pole-placement law
//!   per estimate (the Diophantine equation solved by Cramer's rule with a division-free
//!   reciprocal), and a supervisor that switches to the best predictor after a residence
//!   time of N_r = 2 periods. Its modules are behind the default feature
//!   `milling_multimodel`: firmware that does not run it builds without it
//!   (`default-features = false`), in a fraction of the time.
//!
//! The `*_ref` modules are the f64 reference controllers compiled from the same specs.
//!
//! The `*_proofs` modules are the proof harnesses of each spec: Kani proofs under `cargo kani
//! --tests -p qloop-verified`, bolero property tests under `cargo test`. They are generated only
//! under `cfg(any(test, kani))`, never for a firmware, doc or package build; the multi-model
//! spec's (27 MB of Rust) only under `cfg(kani)` and in the acceptance tier's test target
//! `multimodel_harnesses` (the book's "Tests and their tiers").
#![no_std]

/// One seed spec: its fixed-point module, its f64 reference and, under `cargo test` and Kani
/// only, its proof harnesses (the harness `controller!` call is configured out before the macro
/// runs, so the harness text is never generated for a firmware, doc or package build).
macro_rules! seed {
    ($spec:tt) => {
        qloop_macros::controller!($spec);
        qloop_macros::controller!($spec, reference);
        #[cfg(any(test, kani))]
        qloop_macros::controller!($spec, kani);
    };
}

seed!("specs/koren_masory_1981.qloop");
seed!("specs/koren_masory_tuned.qloop");
seed!("specs/koren_masory_safe.qloop");
seed!("specs/acc_fixed_gain.qloop");
seed!("specs/milling_acc.qloop");
seed!("specs/grinding_pi.qloop");
seed!("specs/grinding_adaptive_pzc.qloop");
seed!("specs/gac_surface_finish.qloop");
// The multi-model controller: with the default feature `milling_multimodel` (Cargo.toml).
#[cfg(feature = "milling_multimodel")]
qloop_macros::controller!("specs/milling_multimodel.qloop");
#[cfg(feature = "milling_multimodel")]
qloop_macros::controller!("specs/milling_multimodel.qloop", reference);
// Its harness module is 27 MB of Rust: under Kani here, under `cargo test` in the acceptance
// tier's `tests/multimodel_harnesses.rs`.
#[cfg(all(kani, feature = "milling_multimodel"))]
qloop_macros::controller!("specs/milling_multimodel.qloop", kani);
