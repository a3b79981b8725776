//! The `controller!` macro expands to exactly what `qloop gen --lang rust` (and `rust-ref`,
//! `kani`) writes: both go through `qloop::expand_macro`'s compiler and emitter, and this test
//! compares the text.

use proc_macro2::TokenStream;
use qloop_tests::specs_dir;
use quote::quote;

fn pretty(ts: TokenStream) -> String {
    prettyplease::unparse(&syn::parse2::<syn::File>(ts).expect("expansion parses as a file"))
}

/// Strips the `const _: &[u8] = include_bytes!(..);` rebuild hook of file mode.
fn without_rebuild_hook(ts: TokenStream) -> TokenStream {
    let mut f: syn::File = syn::parse2(ts).unwrap();
    assert!(
        matches!(&f.items[0], syn::Item::Const(c) if c.ident == "_"),
        "hook first"
    );
    f.items.remove(0);
    quote!(#f)
}

fn macro_expansion_equals_cli_output(stem: &str) {
    let dir = specs_dir();
    let dir = dir.parent().unwrap().to_str().unwrap();
    let src = qloop_tests::spec_source(stem);
    let plan = qloop_tests::plan(stem);
    let cli = qloop::gen_rust(&plan);
    let cli = cli.strip_prefix(qloop::GEN_HEADER).unwrap();
    let cli_ref = qloop::gen_reference(&plan);
    let cli_ref = cli_ref.strip_prefix(qloop::GEN_HEADER).unwrap();
    let cli_kani = qloop_tests::kani_text(stem);
    let cli_kani = cli_kani.strip_prefix(qloop::GEN_HEADER).unwrap();

    // File mode, as qloop-verified uses it.
    let path = format!("specs/{stem}.qloop");
    let file_mode = qloop::expand_macro(quote!(#path), Some(dir));
    assert_eq!(
        pretty(without_rebuild_hook(file_mode)),
        cli,
        "{stem}: file mode"
    );
    let ref_mode = qloop::expand_macro(quote!(#path, reference), Some(dir));
    assert_eq!(
        pretty(without_rebuild_hook(ref_mode)),
        cli_ref,
        "{stem}: reference"
    );
    let kani_mode = qloop::expand_macro(quote!(#path, kani), Some(dir));
    assert_eq!(
        pretty(without_rebuild_hook(kani_mode)),
        cli_kani,
        "{stem}: kani"
    );

    // Inline mode: the spec's tokens written inside `controller! { .. }`.
    let tokens: TokenStream = src.parse().unwrap();
    assert_eq!(
        pretty(qloop::expand_macro(tokens, None)),
        cli,
        "{stem}: inline"
    );
}
test_tools::spec_tests! {
    macro_expansion_equals_cli_output in "verified/specs";
    default: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
        koren_masory_safe, koren_masory_tuned, milling_acc,
    ];
    acceptance: [milling_multimodel];
}

#[test]
fn file_mode_rejects_unknown_modes() {
    let dir = verified_dir();
    let out = qloop::expand_macro(quote!("specs/koren_masory_1981.qloop", proofs), Some(&dir))
        .to_string();
    assert!(out.contains("compile_error"), "{out}");
    assert!(out.contains("kani"), "the error lists the modes: {out}");
}

/// `verified/`, the crate the file paths are relative to.
fn verified_dir() -> String {
    specs_dir().parent().unwrap().to_str().unwrap().to_string()
}

#[test]
fn file_mode_errors_carry_file_line_col() {
    let dir = std::env::temp_dir().join(format!("qloop-macro-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("bad.qloop"),
        "controller bad {\n    period 0.1 \"s\";\n    input x: [0.0, 1.0];\n    output y;\n    step { y = x / 2.0; }\n}\n",
    )
    .unwrap();
    let out = qloop::expand_macro(quote!("bad.qloop"), dir.to_str()).to_string();
    assert!(out.contains("compile_error"), "{out}");
    assert!(out.contains("bad.qloop:5:18"), "{out}");
    assert!(out.contains("division is not allowed"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}
