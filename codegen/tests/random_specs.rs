//! No panics on bad input: mutated seed specs either compile or give a located error.
//!
//! (Soundness on random specs, every printed bound against exact arithmetic, is
//! `tests/tests/exact_bounds.rs`; that their code compiles and agrees bit for bit,
//! `tests/tests/random_compile.rs`.)

use proptest::prelude::*;
use qloop::Target;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(test_tools::cases(300)))]

    #[test]
    fn mutated_specs_never_panic(cut in 0usize..2000, len in 0usize..6, with in prop::sample::select(vec![
        "", "/", "%", "*", "-", "1e300", "-0.0", "(", "}", "[", "let", "if", "state", "#[q(i8, 7)]",
        "#[lsb(1e-30)]", "0.", "\"", "=", ";", "x", "1e-300", "99999999999999999999",
    ])) {
        for src in [qloop::DEMO_SPEC, include_str!("../../verified/specs/acc_fixed_gain.qloop")] {
            let at = cut % src.len();
            let at = (0..=at).rev().find(|&i| src.is_char_boundary(i)).unwrap_or(0);
            let end = (at + len).min(src.len());
            let end = (end..=src.len()).find(|&i| src.is_char_boundary(i)).unwrap_or(src.len());
            let mutated = format!("{}{}{}", &src[..at], with, &src[end..]);
            let r = std::panic::catch_unwind(|| {
                qloop::compile_str(&mutated, &Target::default()).map(|p| qloop::gen_rust(&p))
            });
            prop_assert!(r.is_ok(), "panic on:\n{mutated}");
            if let Ok(Err(d)) = r {
                let (line, col) = d.line_col();
                prop_assert!(line >= 1 && col >= 1, "error without a location: {d}");
                let rendered = d.render("x.qloop", &mutated);
                prop_assert!(rendered.contains("x.qloop:"), "{rendered}");
            }
        }
    }
}
