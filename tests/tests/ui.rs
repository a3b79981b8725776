//! Compile-fail tests: the `controller!` macro's errors carry spans and say what to do.

#[test]
fn macro_errors() {
    let t = trybuild::TestCases::new();
    t.compile_fail("ui/*.rs");
}
