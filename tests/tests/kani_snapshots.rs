//! The proof harnesses `qloop gen --lang kani` writes: a snapshot per seed spec (review every
//! changed `.snap` as a code diff), every invariant and property covered, and the fallback for
//! conditions too wide for exact `i128` evaluation.

use qloop_tests::snapshot::snapshot_text;

/// The clauses of an `ensure`: its conjuncts.
fn count_clauses(c: &qloop::ir::PCond) -> usize {
    match c {
        qloop::ir::PCond::And(a, b) => count_clauses(a) + count_clauses(b),
        _ => 1,
    }
}

/// The attributes that end `text` (the ones of the item after it), nearest first, each on one
/// line: an attribute the formatter broke over several lines (a long `kani::stub` path) is
/// joined, `#[cfg_attr(\n    kani,\n    kani::stub(a, b)\n)]` as `#[cfg_attr(kani, kani::stub(a, b))]`.
fn attributes_before(text: &str) -> Vec<String> {
    let mut rest = text.trim_end();
    let mut out = Vec::new();
    while rest.ends_with(']') {
        // The `[` that opens the last `]`.
        let b = rest.as_bytes();
        let mut depth = 0usize;
        let mut open = None;
        for i in (0..b.len()).rev() {
            match b[i] {
                b']' => depth += 1,
                b'[' => {
                    depth -= 1;
                    if depth == 0 {
                        open = Some(i);
                        break;
                    }
                }
                _ => {}
            }
        }
        let Some(i) = open.filter(|&i| i > 0 && b[i - 1] == b'#') else {
            break;
        };
        let joined = rest[i - 1..]
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        out.push(
            joined
                .replace("( ", "(")
                .replace(" )", ")")
                .replace(",)", ")"),
        );
        rest = rest[..i - 1].trim_end();
    }
    out
}

/// The functions of the harness module (at its indentation), by name: where the `fn` starts
/// and its text up to its closing brace. One pass, so that a 27 MB module is searched once.
fn items(text: &str) -> std::collections::BTreeMap<&str, (usize, &str)> {
    let mut out = std::collections::BTreeMap::new();
    for (i, _) in text.match_indices("\n    fn ") {
        let at = i + "\n    ".len();
        let rest = &text[at..];
        let name = &rest["fn ".len()..rest.find('(').expect("parameters")];
        let end = rest.find("\n    }\n").expect("end of item");
        out.insert(name, (at, &rest[..end]));
    }
    out
}

/// `kani::stub(` arguments and `kani::assume(` clauses as the formatter may write them, with a
/// trailing comma when broken over lines: without it.
fn without_trailing_comma(s: &str) -> String {
    s.strip_suffix(',').unwrap_or(s).to_string()
}

fn compile(src: &str) -> qloop::Plan {
    qloop::compile_str(src, &qloop::Target::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn harness_snapshots(stem: &str) {
    let plan = qloop_tests::plan(stem);
    let text = qloop_tests::kani_text(stem);
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
    // One harness per property, or per clause of its `ensure`s where there are several.
    for p in &plan.prog.properties {
        let clauses: usize = p.ensures.iter().map(count_clauses).sum();
        if clauses == 1 {
            harnesses.push(format!("property_{}", p.name));
        } else {
            harnesses.extend((1..=clauses).map(|j| format!("property_{}_clause_{j}", p.name)));
        }
    }
    let items = items(text);
    for h in &harnesses {
        let at = items
            .get(h.as_str())
            .unwrap_or_else(|| panic!("{stem}: harness {h} missing"))
            .0;
        // The attributes: `#[test]`, the Kani proof, then any stub or solver.
        let attrs = attributes_before(&text[..at]);
        let stubs = attrs
            .iter()
            .take_while(|a| {
                a.starts_with("#[cfg_attr(kani, kani::stub(")
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
    insta::assert_snapshot!(format!("{stem}_kani"), snapshot_text(text));
}

/// The chain of assumptions is closed: every function a harness stubs is replaced by an
/// abstraction defined in the module, and every clause an abstraction assumes is the clause a
/// `lemma_*` harness (a plain `kani::proof`) asserts of the function it abstracts, over the
/// same factor box that the abstraction asserts. The gain-loop and estimator contractions of
/// the 1981 controller and of its milling retune are abstracted.
fn every_assumed_clause_is_a_lemma_over_the_asserted_box(stem: &str) {
    let text = qloop_tests::kani_text(stem);
    let items = items(text);
    let body = |name: &str| -> &str {
        items
            .get(name)
            .unwrap_or_else(|| panic!("{stem}: {name} is not defined"))
            .1
    };
    // `kani::stub(super::<module>::qloop_mul_<n>, abs_mul_<n>)`
    let mut stubbed = std::collections::BTreeSet::new();
    for (i, _) in text.match_indices("kani::stub(") {
        let rest = &text[i + "kani::stub(".len()..];
        let args: String = rest[..rest.find(')').expect("closing parenthesis")]
            .split_whitespace()
            .collect();
        let args = without_trailing_comma(&args);
        let (real, abs) = args.split_once(',').expect("two arguments");
        let n = real.rsplit("qloop_mul_").next().unwrap_or_default();
        assert_eq!(
            abs,
            format!("abs_mul_{n}"),
            "{stem}: {real} stubbed by {abs}"
        );
        stubbed.insert(abs.to_string());
    }
    // Every abstraction: stubbed ones and the harness-only products they call.
    let mut abstractions = stubbed.clone();
    for (i, _) in text.match_indices("fn abs_prod_") {
        let rest = &text[i + 3..];
        abstractions.insert(rest[..rest.find('(').expect("parameters")].to_string());
    }
    let between = |s: &str, a: &str, b: &str| -> Vec<String> {
        s.match_indices(a)
            .map(|(i, _)| {
                let rest = &s[i + a.len()..];
                rest[..rest.find(b).expect("terminator")].trim().to_string()
            })
            .collect()
    };
    let squeeze = |s: &str| -> String { s.split_whitespace().collect() };
    for abs in &abstractions {
        let b = squeeze(body(abs));
        let b = b.as_str();
        let assumed: Vec<String> = between(b, "kani::assume(", ");")
            .iter()
            .map(|c| without_trailing_comma(c))
            .collect();
        assert!(!assumed.is_empty(), "{stem}: {abs} assumes nothing");
        let boxes = between(b, "kani::assert(", ".contains(&");
        assert_eq!(
            boxes.len(),
            2,
            "{stem}: {abs} does not assert both factors' intervals"
        );
        let tag = abs.trim_start_matches("abs_");
        let prefix = format!("lemma_{tag}_");
        let lemmas: Vec<(usize, &str)> = items
            .range(prefix.as_str()..)
            .take_while(|(name, _)| name.starts_with(&prefix))
            .map(|(_, &(at, body))| (at, body))
            .collect();
        assert_eq!(
            lemmas.len(),
            assumed.len(),
            "{stem}: {abs} assumes {} clauses, {} lemmas",
            assumed.len(),
            lemmas.len()
        );
        for clause in &assumed {
            let proved = lemmas.iter().any(|&(i, lemma)| {
                let l = squeeze(lemma);
                let attrs = &text[..i];
                attrs.trim_end().ends_with("#[kani::proof]")
                    && l.contains(&format!("kani::assert({clause},"))
                    && boxes.iter().all(|r| l.contains(&format!("{r}.contains(&")))
            });
            assert!(
                proved,
                "{stem}: {abs} assumes `{clause}`, which no lemma over its box proves"
            );
        }
    }
    if matches!(stem, "koren_masory_1981" | "milling_acc") {
        for p in ["gain_loop_contraction", "estimator_contraction"] {
            let h = format!("property_{p}");
            assert!(
                items.contains_key(h.as_str()) && body(&h).contains("abs_mul_"),
                "{stem}: {p} is not abstracted"
            );
        }
    }
}
test_tools::spec_tests! {
    harness_snapshots,
    every_assumed_clause_is_a_lemma_over_the_asserted_box in "verified/specs";
    default: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
        koren_masory_safe, koren_masory_tuned, milling_acc,
    ];
    acceptance: [milling_multimodel];
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
