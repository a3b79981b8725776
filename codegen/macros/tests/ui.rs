//! Compile-fail tests: the `controller!` macro's errors carry spans and say what to do. Here,
//! in the macro's own package, trybuild builds the cases against the macro and its compiler
//! core alone (in `qloop-tests` it built every workspace crate again: about 4 minutes).

#[test]
fn macro_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/*.rs");
}
