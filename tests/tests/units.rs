//! The units corpus (issue 15): unit combinations a spec may write, and ones it must not,
//! each refused at its place (the `@` in a case marks the expected line and column) with the
//! message that names the problem. The right ones also compile to code whose constant
//! conversions are checked against the SI definitions of the units.

use qloop::Target;

/// Declarations every case sees.
const DECLS: &str = r#"
    input fc: [0.0, 5.0] "kN";
    input f_n: [0.0, 5000.0] "N";
    input n: [100.0, 3000.0] "rpm";
    input fr: [0.01, 0.5] "mm/rev";
    input v: [0.0, 10.0] "mm/s";
    input ovr: [10.0, 200.0] "%";
    param FR: 1.5 "kN";
    param K: 0.5;
    param KC: 0.2 "(mm/s)/kN";
    param FNOM: 5.0 "mm/s";
    param TAU: 10.0 * period;
    state u: [0.0, 10.0] "mm/s" = 1.0;
    state km: [0.1, 6.0] "kN/(mm/s)" = 1.0;
    state r: [0.0, 2.0] = 1.0;
"#;

/// A spec from a case: extra declarations, the step body, and an optional `prove` block.
fn spec(extra: &str, body: &str, prove: &str) -> String {
    format!(
        "controller units_case {{\n    period 0.1 \"s\";{DECLS}    {extra}\n    step {{\n        {body}\n    }}\n    prove {{ {prove} }}\n}}\n"
    )
}

/// Cases that must compile: (extra declarations, body, prove).
const RIGHT: &[(&str, &str, &str)] = &[
    ("output y: [0.0, 10.0] \"mm/s\";", "u += KC * (FR - fc); y = u;", ""),
    ("output y \"mm/s\";", "let e = fc - FR; u -= KC * e; y = u;", ""),
    ("const C1: 0.25 \"s/mm\"; output y \"kN/(mm/s)\";", "km += C1 * (fc - u * km); y = km;", ""),
    ("output y \"mm/s\";", "if fc > 0.15 { u = u - 0.1; } y = u;", ""),
    ("output y \"mm/s\";", "if fc > FR && u < 5.0 { u = u - 0.1; } y = u;", ""),
    ("output y \"mm/min\";", "y = convert(u, \"mm/min\");", ""),
    ("output y \"mm/s\";", "y = convert(fr * n, \"mm/s\");", ""),
    ("output y \"kN\";", "y = convert(f_n, \"kN\");", ""),
    ("output y \"kN\";", "y = max(fc, convert(f_n, \"kN\"));", ""),
    ("output y;", "y = K * r;", ""),
    ("output y \"%\";", "y = clamp(ovr, 10.0, 150.0);", ""),
    ("output y \"kW\";", "y = convert(fc * v, \"kW\");", ""),
    ("output y;", "y = km * KC;", ""),
    ("output y \"mm/s\";", "let big = fc > FR; if big { u -= 0.5; } y = u;", ""),
    ("output y \"mm/s\";", "u = if fc > FR { u - 0.1 } else { u + 0.1 }; y = u;", ""),
    ("output y \"kN\";", "y = abs(FR - fc);", ""),
    ("param F2: 2.0 * FR; output y \"mm/s\";", "if fc > F2 { u = 0.0; } y = u;", ""),
    ("output y \"s\";", "y = TAU * r;", ""),
    ("output y \"rev/s\";", "y = convert(n, \"rev/s\");", ""),
    ("const CN: 0.5 \"1/s\"; output y \"mm/s\";", "u -= CN * period * u; y = u;", ""),
    ("output y \"N\";", "y = f_n + convert(fc, \"N\");", ""),
    ("output y \"mm/s\";", "u = min(u, convert(ovr, \"1\") * FNOM); y = u;", ""),
    (
        "output y \"mm/s\";",
        "y = u;",
        "property p { forall kp in [0.1, 6.0] \"kN/(mm/s)\"; assume abs(fc - u * kp) <= 0.01; ensure y >= 0.0; }",
    ),
    ("output y \"mm/s\";", "y = u;", "invariant i: km * u >= 0.0 && u <= FNOM * 2.0;"),
    ("output y \"kN\";", "y = fc;", "property q { assume fc > FR; ensure next(u) <= u + 1e-3; }"),
    ("output y \"(mm/s)/kN\";", "y = KC;", ""),
    ("output y \"mm/(s*kN)\";", "y = KC;", ""),
    ("const D: powf(TAU, -1.0) \"1/s\"; output y \"1/s\";", "y = D * r;", ""),
    ("const FRN: convert(FR, \"N\") \"N\"; output y \"N\";", "y = FRN * r;", ""),
    ("const A: exp(-period / TAU); output y;", "y = A * r;", ""),
    (
        "output y \"mm/min\";",
        "y = convert(u, \"mm/min\");",
        "property c { ensure y <= convert(u, \"mm/min\") + 0.01; }",
    ),
];

/// Cases that must be refused: (extra declarations, body, prove, message fragment). One of
/// the three texts holds `@` where the error must point.
const WRONG: &[(&str, &str, &str, &str)] = &[
    ("output y \"mm/s\";", "u @+= fc; y = u;", "", "assignment to `u`: mm/s (velocity"),
    ("output y \"mm/s\";", "let s = fc @+ u; y = u;", "", "`+`: kN (force"),
    ("output y \"mm/s\";", "if fc @> u { u = 0.0; } y = u;", "", "this comparison"),
    ("output y \"kN\";", "y @= f_n;", "", "same dimension in different units"),
    ("output y \"mm/s\";", "y @= fr * n;", "", "same dimension in different units"),
    ("output y \"mm/s\";", "u = @min(u, convert(ovr, \"1\") * 5.0); y = u;", "", "`min`"),
    ("output y \"mm/s\";", "u = clamp(u, 0.0, @FR); y = u;", "", "`clamp`'s upper bound"),
    ("param F3: @FR \"N\"; output y;", "y = r;", "", "the value of `F3`"),
    ("input q: [0.0, 1.0] @\"mm/sec\"; output y;", "y = r;", "", "unknown unit `sec`"),
    ("input q: [0.0, 1.0] @\"kn\"; output y;", "y = r;", "", "unknown unit `kn`"),
    ("input q: [0.0, 1.0] @\"RPM\"; output y;", "y = r;", "", "unknown unit `RPM`"),
    ("input q: [0.0, 1.0] @\"furlong\"; output y;", "y = r;", "", "unknown unit `furlong`"),
    ("input q: [0.0, 1.0] @\"kN/(mm/s\"; output y;", "y = r;", "", "expected `)`"),
    ("output y \"mm/s\";", "u = @if fc > FR { u } else { fc }; y = u;", "", "the arms of this `if`"),
    (
        "output y;",
        "y = r;",
        "property p { forall kp in [0.1, 6.0]; assume abs(fc @- u * kp) <= 0.01; ensure y >= 0.0; }",
        "`-`: kN (force",
    ),
    ("output y;", "y = r;", "invariant i: km @>= u;", "this comparison"),
    ("output y \"kN\";", "y = convert(u, @\"kN\");", "", "cannot convert"),
    ("output y \"mm/s\";", "let b = fc > FR; u = @b; y = u;", "", "is a condition, not a number"),
    ("output y;", "km @+= fc * 0.25; y = r;", "", "assignment to `km`"),
    ("output y;", "if fc @> TAU { u = 0.0; } y = r;", "", "this comparison"),
    ("state z: [0.0, @TAU] \"kN\" = 0.0; output y;", "y = r;", "", "the range of `z`"),
    ("output y \"Hz\";", "y @= n;", "", "different dimensions"),
    ("output y;", "y @= ovr;", "", "same dimension in different units"),
    ("output y \"mm\";", "y @= fr;", "", "different dimensions"),
    ("state z: [0.0, 5.0] \"kN\" = @FNOM; output y;", "y = r;", "", "the initial value of `z`"),
    ("output y \"mm/s\";", "y @= u * ovr;", "", "same dimension in different units"),
    (
        "output y;",
        "y = r;",
        "property q { assume fc > FR; ensure next(u) @<= km; }",
        "this comparison",
    ),
    ("const D: powf(0.5, @TAU); output y;", "y = r;", "", "the exponent of `powf`"),
    ("const D: @exp(TAU); output y;", "y = r;", "", "its argument must be dimensionless"),
    ("const D: @sqrt(FR); output y;", "y = r;", "", "not a square unit"),
];

#[test]
fn right_units_compile() {
    assert!(RIGHT.len() >= 20);
    for (extra, body, prove) in RIGHT {
        let src = spec(extra, body, prove);
        if let Err(e) = qloop::compile_str(&src, &Target::default()) {
            panic!("must compile: {body}\n{}", e.render("case.qloop", &src));
        }
    }
}

#[test]
fn wrong_units_are_refused_at_their_place() {
    assert!(WRONG.len() >= 20);
    let mut failed = Vec::new();
    for (extra, body, prove, msg) in WRONG {
        let marked = spec(extra, body, prove);
        let at = marked.find('@').expect("a case marks its place with @");
        let line = marked[..at].matches('\n').count() + 1;
        let col = marked[..at].rfind('\n').map_or(at, |nl| at - nl - 1) + 1;
        let src = marked.replacen('@', "", 1);
        match qloop::compile_str(&src, &Target::default()) {
            Ok(_) => failed.push(format!("must be refused: {body} {extra} {prove}")),
            Err(e) => {
                let shown = e.render("case.qloop", &src);
                if !e.message.contains(msg) {
                    failed.push(format!("`{msg}` not in:\n{shown}"));
                } else if e.line_col() != (line, col) {
                    failed.push(format!("wrong place, want {line}:{col}:\n{shown}"));
                } else if e.help.is_none() {
                    failed.push(format!("no help:\n{shown}"));
                }
            }
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn unknown_units_suggest_the_known_spelling() {
    for (text, want) in [
        ("mm/sec", "`s`"),
        ("kn", "`kN`"),
        ("RPM", "`rpm`"),
        ("Nm", "`N*m`"),
    ] {
        let src = spec(
            &format!("input q: [0.0, 1.0] \"{text}\"; output y;"),
            "y = r;",
            "",
        );
        let e = qloop::compile_str(&src, &Target::default()).expect_err(text);
        let help = e.help.unwrap_or_default();
        assert!(help.contains(want), "{text}: {help}");
    }
}

/// `convert` multiplies by the ratio of the units' SI definitions: checked on the f64
/// reference interpreter against values computed here by hand from the definitions
/// (1 mm/rev · 1 rpm = 1/60 mm/s; 1 kN · 1 mm/s = 1 W = 10⁻³ kW; 1 N = 10⁻³ kN).
#[test]
fn convert_scales_by_the_si_ratio() {
    for (out, expr, inputs, want) in [
        (
            "mm/s",
            "convert(fr * n, \"mm/s\")",
            [("fr", 0.3), ("n", 1200.0)],
            0.3 * 1200.0 / 60.0,
        ),
        (
            "kW",
            "convert(fc * v, \"kW\")",
            [("fc", 2.0), ("v", 4.0)],
            2.0 * 4.0 * 1e-3,
        ),
        (
            "kN",
            "convert(f_n, \"kN\") + fc",
            [("f_n", 1500.0), ("fc", 0.5)],
            2.0,
        ),
        (
            "mm/min",
            "convert(v, \"mm/min\")",
            [("v", 2.5), ("fc", 0.0)],
            150.0,
        ),
    ] {
        let src = spec(&format!("output y \"{out}\";"), &format!("y = {expr};"), "");
        let plan = qloop::compile_str(&src, &Target::default()).unwrap();
        let prog = &plan.prog;
        let mut vars: Vec<f64> = prog.signals.iter().map(|s| s.init.unwrap_or(0.0)).collect();
        let index = |name: &str| prog.signals.iter().position(|s| s.name == name).unwrap();
        for (name, v) in inputs {
            vars[index(name)] = v;
        }
        qloop::interp::step_real(prog, &mut vars);
        let y = [vars[index("y")]];
        assert!(
            (y[0] - want).abs() <= 1e-12 * want.abs().max(1.0),
            "{expr}: {} vs {want}",
            y[0]
        );
    }
}

/// Issue 35: `convert` in a property (it was "unknown function convert"): the signal times the
/// unit factor, the same 60 as `step`'s for mm/s to mm/min, and the property evaluates exactly
/// on a step of the plan (true for the output within its rounding, false 1 mm/min below it).
#[test]
fn convert_in_a_property_is_the_steps_factor() {
    use qloop::ir::{PCond, PExpr};
    let prove = "property c { ensure y <= convert(u, \"mm/min\") + 0.01; } \
                 property d { ensure y <= convert(u, \"mm/min\") - 1.0; }";
    let src = spec("output y \"mm/min\";", "y = convert(u, \"mm/min\");", prove);
    let plan = qloop::compile_str(&src, &Target::default())
        .unwrap_or_else(|d| panic!("{}", d.render("units_case", &src)));
    let p = &plan.prog.properties[0];
    let PCond::Cmp(_, _, rhs) = &p.ensures[0] else {
        panic!("{:?}", p.ensures)
    };
    let PExpr::Add(conv, _) = rhs else {
        panic!("{rhs:?}")
    };
    assert!(
        matches!(conv.as_ref(), PExpr::Mul(_, k) if matches!(k.as_ref(), PExpr::Const(v) if *v == 60.0)),
        "{conv:?}"
    );
    let id = |n: &str| plan.prog.signals.iter().position(|s| s.name == n).unwrap();
    let (u, y) = (id("u"), id("y"));
    let uq = plan.format(qloop::ir::SigId(u));
    let mut pre = vec![0i128; plan.prog.signals.len()];
    for (i, s) in plan.prog.signals.iter().enumerate() {
        if s.kind == qloop::ir::SigKind::State {
            pre[i] = plan.raw_init(qloop::ir::SigId(i));
        }
    }
    pre[u] = (3.7 * 2f64.powi(uq.frac)) as i128;
    let mut post = pre.clone();
    qloop::interp::step_fixed(&plan, &mut post).unwrap();
    assert_ne!(post[y], 0);
    let holds = |k| qloop::prove::replay::property_holds(&plan, k, &pre, &post, &[]);
    assert_eq!(holds(0), Some(true));
    assert_eq!(holds(1), Some(false));
}
