//! The nesting and length limits of `lang::scan` keep every stage within its stack: the deepest
//! specs the limits admit go through every stage (check, lowering, every emitter, the proof
//! obligations) in a thread with a 2 MiB stack, in the debug build the tests use; specs one
//! step beyond get a located error; and the issue-12 specs that aborted `qloop check` with a
//! stack overflow get one too.

use qloop::lang::scan::{measure, MAX_LENGTH, MAX_NESTING};
use qloop::Target;

/// A spec whose step assigns `y = EXPR;` (brackets used by the spec itself: 2).
fn spec(expr: &str) -> String {
    format!(
        "controller deep {{\n    period 0.01 \"s\";\n    input x: [-1.0, 1.0];\n    output y;\n    \
         step {{ {expr} }}\n}}\n"
    )
}

/// Runs `f` on a thread with a 2 MiB stack (Rust's default for spawned threads).
fn small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(f)
        .expect("spawn")
        .join()
        .expect("no stack overflow, no panic")
}

/// Every stage: check, lower, Rust, reference, Kani, C, LinuxCNC, the proof obligations.
fn every_stage(src: String) -> Result<usize, String> {
    small_stack(move || {
        let plan = qloop::compile_str(&src, &Target::default()).map_err(|e| e.message)?;
        let n = qloop::gen_rust(&plan).len()
            + qloop::gen_reference(&plan).len()
            + qloop::gen_kani(&plan).len()
            + qloop::gen_c(&plan).1.len()
            + qloop::gen_linuxcnc(&plan).map_or(0, |s| s.len());
        let obligations = qloop::prove::obligations::obligations(&plan);
        Ok(n + obligations.len())
    })
}

/// (expression at the limit, the same one step beyond it)
fn cases() -> Vec<(&'static str, String, String)> {
    let n = MAX_NESTING - 2; // the controller's and the step's braces
    let parens = |k: usize| format!("y = {}x{};", "(".repeat(k), ")".repeat(k));
    let negs = |k: usize| format!("y = {}x;", "-".repeat(k));
    let clamps = |k: usize| format!("y = {}x{};", "clamp(".repeat(k), ", -1.0, 1.0)".repeat(k));
    let neg_parens = |k: usize| format!("y = {}x{};", "-(".repeat(k), ")".repeat(k));
    let ifs = |k: usize| {
        format!(
            "if x > 0.5 {{ y = x; }} {} else {{ y = x * 0.125; }}",
            "else if x > 0.25 { y = x * 0.5; } ".repeat(k)
        )
    };
    // `y = x + ... + x`: `=` and the `+`s.
    let sum = |k: usize| format!("y = {};", vec!["x"; k].join(" + "));
    // `x > 0.0 && ..`: each term adds `>` and `&&` (two tokens).
    let conj = |k: usize| {
        format!(
            "if {} {{ y = x; }} else {{ y = x * 0.5; }}",
            vec!["x > 0.0"; k].join(" && ")
        )
    };
    let product = |k: usize| format!("y = {};", vec!["x"; k].join(" * "));
    vec![
        ("parentheses", parens(n), parens(n + 1)),
        (
            "flat conjunction",
            conj((MAX_LENGTH - 8) / 3),
            conj(MAX_LENGTH / 3 + 1),
        ),
        (
            "flat product",
            product(MAX_LENGTH - 2),
            product(MAX_LENGTH + 1),
        ),
        ("unary minus", negs(n), negs(n + 1)),
        (
            "clamp calls (the `-1.0` adds one)",
            clamps(n - 1),
            clamps(n),
        ),
        ("-( pairs", neg_parens(n / 2), neg_parens(n / 2 + 1)),
        ("else if chain (its blocks add one)", ifs(n - 1), ifs(n)),
        ("flat sum", sum(MAX_LENGTH - 2), sum(MAX_LENGTH + 1)),
    ]
}

#[test]
fn deepest_admitted_specs_compile_in_a_small_stack() {
    for (what, at, beyond) in cases() {
        eprintln!("case {what}");
        let r = every_stage(spec(&at));
        assert!(r.is_ok(), "{what} at the limit: {r:?}");
        let e = every_stage(spec(&beyond)).expect_err(what);
        assert!(
            e.contains("nest more than") || e.contains("nests more than") || e.contains("too long"),
            "{what} beyond the limit: {e}"
        );
    }
}

/// The specs of issue 12 that aborted with a stack overflow now get an error at a place.
#[test]
fn issue_12_stack_overflows_are_located_errors() {
    let cases = [
        (
            spec(&format!("y = {}x{};", "(".repeat(4000), ")".repeat(4000))),
            5,
            78,
        ),
        (spec(&format!("y = {}x;", "-".repeat(10000))), 5, 78),
        (
            spec(&format!("y = {};", vec!["x"; 10000].join(" + "))),
            5,
            1030,
        ),
        (
            spec(&format!(
                "{}y = x;{}",
                "if x > 0.0 { ".repeat(2000),
                " } else { y = x; }".repeat(2000)
            )),
            5,
            0,
        ),
        (
            spec(&format!(
                "y = {}x{};",
                "clamp(".repeat(3000),
                ", -1.0, 1.0)".repeat(3000)
            )),
            5,
            0,
        ),
    ];
    for (src, line, col) in cases {
        let d = small_stack(move || {
            qloop::compile_str(&src, &Target::default())
                .err()
                .map(|d| (d.message.clone(), d.line_col()))
        })
        .expect("refused");
        assert!(d.0.contains("nest") || d.0.contains("too long"), "{}", d.0);
        eprintln!("{} at {:?}", d.0, d.1);
        assert_eq!(d.1 .0, line, "{}", d.0);
        if col > 0 {
            assert_eq!(d.1 .1, col, "{}", d.0);
        }
    }
}

/// The limits are far above what controllers need: every seed spec stays below a third of
/// each. (It was a quarter until the multi-model controller, whose longest expression, a
/// pole-placement check, has length 65 of 256; its nesting is 9 of 64.)
#[test]
fn seed_specs_are_far_from_the_limits() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../verified/specs");
    for e in std::fs::read_dir(dir).expect("specs") {
        let p = e.expect("entry").path();
        let src = std::fs::read_to_string(&p).expect("read");
        let (nest, len) = measure(&src.parse().expect("lexes")).expect("within the limits");
        eprintln!("{}: nesting {nest}, length {len}", p.display());
        assert!(
            nest * 3 < MAX_NESTING && len * 3 < MAX_LENGTH,
            "{}: {nest}, {len}",
            p.display()
        );
    }
}
