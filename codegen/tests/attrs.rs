//! Malformed format attributes get a located error, never a panic. The first case is the
//! input cargo-fuzz found (CI, 2026-12-02): `#[q(μ8, 3)]` made the checker split the type
//! name inside its first character.

use qloop::Target;

/// A spec whose state `s` carries the attribute `attr`.
fn spec(attr: &str) -> String {
    format!(
        "controller attrs {{\n    period 0.01 \"s\";\n    input x: [-1.0, 1.0];\n    output y;\n    \
         {attr}\n    state s: [-2.0, 2.0] = 0.0;\n    step {{ s = x; y = s; }}\n}}\n"
    )
}

#[test]
fn malformed_q_types_are_located_errors() {
    let ok = qloop::compile_str(&spec("#[q(i16, 12)]"), &Target::default());
    assert!(
        ok.is_ok(),
        "the well-formed attribute: {:?}",
        ok.err().map(|e| e.message)
    );
    for ty in ["μ8", "ü16", "i", "u", "x32", "i12", "u33", "i3a", "µ"] {
        let src = spec(&format!("#[q({ty}, 3)]"));
        let e = qloop::compile_str(&src, &Target::default())
            .err()
            .unwrap_or_else(|| panic!("`{ty}` accepted"));
        assert!(
            e.message.contains("expected `#[q(TYPE, FRAC)]`"),
            "`{ty}`: {}",
            e.message
        );
        // The attribute's line and its `#` (line 5, column 5, both counted from 1).
        assert_eq!(e.line_col(), (5, 5), "`{ty}`: {}", e.message);
    }
}
