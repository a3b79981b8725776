//! The proof harnesses `qloop gen --lang kani` writes: a snapshot per seed spec (review every
//! changed `.snap` as a code diff), every invariant and property covered, and the fallback for
//! conditions too wide for exact `i128` evaluation.

use qloop_tests::all_specs;

fn compile(src: &str) -> qloop::Plan {
    qloop::compile_str(src, &qloop::Target::default()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn harness_snapshots() {
    let specs = all_specs();
    assert!(specs.len() >= 2, "seed specs missing");
    for (stem, src) in specs {
        let plan = compile(&src);
        let text = qloop::gen_kani(&plan);
        assert!(
            text.contains(&format!("pub mod {stem}_proofs")),
            "{stem}: the harness module does not parse:\n{text}"
        );
        // The seed specs evaluate exactly in i128: nothing is skipped.
        assert!(!text.contains("SKIPPED_"), "{stem}: a harness was skipped");
        let mut harnesses = vec!["ranges_and_overflow".to_string(), "initial".to_string()];
        harnesses.extend(
            plan.prog
                .invariants
                .iter()
                .map(|i| format!("invariant_{}", i.name)),
        );
        harnesses.extend(
            plan.prog
                .properties
                .iter()
                .map(|p| format!("property_{}", p.name)),
        );
        // Properties checked on a step model under Kani have a harness proving the model.
        harnesses.extend(
            plan.prog
                .properties
                .iter()
                .filter(|p| text.contains(&format!("fn model_{}(", p.name)))
                .map(|p| format!("model_matches_{}", p.name)),
        );
        for h in &harnesses {
            let at = text
                .find(&format!("fn {h}()"))
                .unwrap_or_else(|| panic!("{stem}: harness {h} missing"));
            // The attributes: `#[test]`, the Kani proof, then any `stub_verified` or solver.
            let attrs: Vec<&str> = text[..at]
                .lines()
                .rev()
                .skip(1)
                .take_while(|l| l.trim_start().starts_with("#["))
                .map(str::trim)
                .collect();
            let stubs = attrs
                .iter()
                .take_while(|a| {
                    a.starts_with("#[cfg_attr(kani, kani::stub_verified(")
                        || a.starts_with("#[cfg_attr(kani, kani::solver(")
                })
                .count();
            assert_eq!(
                &attrs[stubs..],
                &["#[cfg_attr(kani, kani::proof)]", "#[test]"],
                "{stem}: {h} is not both a test and a Kani proof"
            );
        }
        assert_eq!(
            text.matches("#[cfg_attr(kani, kani::proof)]").count(),
            harnesses.len(),
            "{stem}: unexpected harnesses"
        );
        insta::assert_snapshot!(format!("{stem}_kani"), text);
    }
}

/// The chain of assumptions is closed: every function a harness `stub_verified`s has a
/// `proof_for_contract` harness, every contract harness checks a function some harness
/// stubs, and every step model a property harness runs under Kani has its
/// `model_matches_*` harness. The 1981 gain-loop and estimator contraction are modelled.
#[test]
fn every_stub_has_a_verified_contract_and_every_model_a_match() {
    let mut modelled = Vec::new();
    for (stem, src) in all_specs() {
        let text = qloop::gen_kani(&compile(&src));
        let names = |pat: &str| -> std::collections::BTreeSet<String> {
            text.match_indices(pat)
                .map(|(i, _)| {
                    let rest = &text[i + pat.len()..];
                    rest[..rest.find(')').expect("closing parenthesis")].to_string()
                })
                .collect()
        };
        let stubbed = names("kani::stub_verified(");
        let verified = names("#[kani::proof_for_contract(");
        assert_eq!(
            stubbed, verified,
            "{stem}: stubs without contracts, or unused contracts"
        );
        for f in &stubbed {
            assert!(
                text.contains(&format!("fn {f}(a: i128, b: i128)")),
                "{stem}: stubbed function {f} is not defined"
            );
        }
        for m in names("let (_, premises, goals) = model_") {
            let prop = m.split('(').next().unwrap_or_default().to_string();
            assert!(
                text.contains(&format!("fn model_matches_{prop}()")),
                "{stem}: model of {prop} has no model_matches harness"
            );
            modelled.push(format!("{stem}::{prop}"));
        }
    }
    for p in [
        "koren_masory_1981::gain_loop_contraction",
        "koren_masory_1981::estimator_contraction",
    ] {
        assert!(
            modelled.iter().any(|m| m == p),
            "{p} is not modelled: {modelled:?}"
        );
    }
}

/// A spec whose 64-bit state cubed needs ~2^189: that property (and, for a too-wide
/// invariant, everything assuming it) is not emitted, and the module says why.
#[test]
fn conditions_too_wide_for_i128_are_skipped_with_a_reason() {
    let spec = |invariant: &str| {
        format!(
            r#"controller wide {{
                period 1 "ms";
                word 64;
                input x: [-1000.0, 1000.0];
                state s: [-1000.0, 1000.0] = 0.0;
                output y;
                step {{ s = x; y = s; }}
                prove {{
                    {invariant}
                    property follows {{ ensure next(s) <= 1000.0; }}
                    property cube {{ ensure next(s) * next(s) * next(s) <= 1000000000.0; }}
                }}
            }}"#
        )
    };

    let text = qloop::gen_kani(&compile(&spec("")));
    assert!(text.contains("pub mod wide_proofs"), "{text}");
    assert!(text.contains("fn property_follows()"), "{text}");
    assert!(!text.contains("fn property_cube()"), "{text}");
    assert!(
        text.contains("pub const SKIPPED_PROPERTY_CUBE: &str"),
        "{text}"
    );
    assert!(
        text.contains("a product can exceed 2^126 in magnitude"),
        "{text}"
    );

    // An invariant too wide to evaluate: every harness that assumes it goes too.
    let text = qloop::gen_kani(&compile(&spec("invariant huge: s * s * s * s >= -1.0;")));
    assert!(text.contains("fn ranges_and_overflow()"), "{text}");
    assert!(text.contains("fn initial()"), "{text}");
    for h in ["invariant_huge", "property_follows", "property_cube"] {
        assert!(!text.contains(&format!("fn {h}()")), "{h}: {text}");
        assert!(
            text.contains(&format!("SKIPPED_{}", h.to_uppercase())),
            "{h}: {text}"
        );
    }
    assert!(text.contains("it assumes invariant `huge`"), "{text}");
}
