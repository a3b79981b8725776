//! Issue 18, item 4: safety rules as reusable spec fragments (`rule`, `apply`, `use`).
//!
//! * A rule applied expands to exactly the spec a person would write by hand: the plan of a
//!   spec using a local rule equals the plan of the same spec written out (same generated
//!   Rust, names and all).
//! * Every misuse is a located error (line and column in the spec, or the `apply` line for a
//!   library rule), with what to do.
//! * qloop's own library parses and every rule in it is documented.

use qloop_core::{compile_str, gen_rust, Target};

const HOST: &str = r#"controller host {
    period 0.1 "s";
    word 16;
    input fc: [0.0, 5.0] "kN";
    state u: [0.05, 5.0] "mm/s" = 0.5;
    output feed "mm/s";
    const G: 0.25 "(mm/s)/kN";
    const FR: 1.5 "kN";
    RULES
    /// The output, written after every rule.
    rule out() on (x, y) { step { y = x; } }
    apply out on (x = u, y = feed);
    step {
        u += G * (FR - fc);
    }
}
"#;

fn host(rules: &str) -> String {
    HOST.replace("RULES", rules)
}

#[test]
fn a_local_rule_expands_to_the_spec_written_out() {
    let with_rule = host(
        r#"rule cap(LIMIT: 4.0 "mm/s") on (cmd) {
        /// Periods at the cap.
        state hits: [0.0, 8.0] = 0.0;
        pre { let before = cmd; }
        step {
            let capped = min(cmd, LIMIT);
            if capped < cmd { hits = hits + 1.0; }
            cmd = max(capped, before - LIMIT);
        }
        prove { property within { ensure next(cmd) <= LIMIT; } }
    }
    apply cap(LIMIT = 3.0) on (cmd = u) as top;"#,
    );
    // By hand: the parameter a constant, every declared name prefixed `top_`, the `pre`
    // statement first, the `step` statements after the law, in the order of the `apply`
    // items (`out`, applied after `cap`, writes the output last).
    let by_hand = r#"controller host {
    period 0.1 "s";
    word 16;
    input fc: [0.0, 5.0] "kN";
    state u: [0.05, 5.0] "mm/s" = 0.5;
    output feed "mm/s";
    const G: 0.25 "(mm/s)/kN";
    const FR: 1.5 "kN";
    /// Parameter `LIMIT` of rule `cap` (instance `top`).
    const TOP_LIMIT: 3.0 "mm/s";
    /// Periods at the cap.
    state top_hits: [0.0, 8.0] = 0.0;
    step {
        let top_before = u;
        u += G * (FR - fc);
        let top_capped = min(u, TOP_LIMIT);
        if top_capped < u { top_hits = top_hits + 1.0; }
        u = max(top_capped, top_before - TOP_LIMIT);
        feed = u;
    }
    prove { property top_within { ensure next(u) <= TOP_LIMIT; } }
}
"#;
    let t = Target::default();
    let a = gen_rust(
        &compile_str(&with_rule, &t).unwrap_or_else(|d| panic!("{}", d.render("a", &with_rule))),
    );
    let b = gen_rust(
        &compile_str(by_hand, &t).unwrap_or_else(|d| panic!("{}", d.render("b", by_hand))),
    );
    assert_eq!(a, b);
}

#[test]
fn the_library_parses_and_documents_every_rule() {
    for (name, _) in qloop_core::lang::rules::LIBRARIES {
        let rules = qloop_core::lang::rules::library_rules(name)
            .expect("listed")
            .unwrap_or_else(|d| panic!("{name}: {}", d.message));
        assert!(rules.len() >= 7, "{name}: {} rules", rules.len());
        for r in rules {
            assert!(!r.docs.is_empty(), "{name}: rule `{}` has no doc", r.name);
        }
    }
}

#[test]
fn the_safe_seed_spec_uses_every_rule_of_the_library() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let src = std::fs::read_to_string(root.join("verified/specs/koren_masory_safe.qloop"))
        .expect("safe spec");
    for r in qloop_core::lang::rules::library_rules("feed_safety")
        .expect("listed")
        .expect("parses")
    {
        assert!(
            src.contains(&format!("apply {}", r.name)),
            "koren_masory_safe does not apply `{}`",
            r.name
        );
    }
}

#[test]
fn misuses_are_located_errors() {
    let t = Target::default();
    let mut failed = Vec::new();
    for (name, rules, want, line_col) in [
        (
            "unknown library",
            "use safety;",
            "unknown rules library `safety`",
            ":9:9",
        ),
        (
            "library by path",
            r#"use "rules/mine.qloop";"#,
            "rules files by path are not supported",
            ":9:9",
        ),
        (
            "unknown rule",
            "use feed_safety;\n    apply fmx(LIMIT = 4.0) on (cmd = u);",
            "unknown rule `fmx`",
            ":10:11",
        ),
        (
            "unknown parameter",
            "use feed_safety;\n    apply fmax(LIMT = 4.0) on (cmd = u);",
            "rule `fmax` has no parameter `LIMT`",
            ":10:16",
        ),
        (
            "missing parameter",
            "use feed_safety;\n    apply fmax on (cmd = u);",
            "parameter `LIMIT` of rule `fmax` has no value",
            ":10:5",
        ),
        (
            "unbound port",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0) on ();",
            "port `cmd` of rule `fmax` is not bound",
            ":10:5",
        ),
        (
            "unknown port",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0) on (cmd = u, load = fc);",
            "rule `fmax` has no port `load`",
            ":10:42",
        ),
        (
            "port bound to an unknown signal",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0) on (cmd = uu);",
            "`uu` is not a signal of this spec",
            ":10:39",
        ),
        (
            "applied twice",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0) on (cmd = u);\n    apply fmax(LIMIT = 3.0) on (cmd = u);",
            "rule instance `fmax` is applied twice",
            ":11:11",
        ),
        (
            // The library rule's body is checked in the host: its `cmd` is written, so an
            // input cannot be bound to it; the error points at the binding.
            "an input bound to a written port",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0) on (cmd = fc);",
            "input `fc` is read-only",
            ":10:39",
        ),
        (
            // A parameter's value is a constant of the host.
            "a signal as a parameter",
            "use feed_safety;\n    apply fmax(LIMIT = fc) on (cmd = u);",
            "`fc` is a signal",
            ":10:24",
        ),
        (
            "an input in a rule",
            "rule r() on (x) { input y: [0.0, 1.0]; step { x = y; } }",
            "a rule's body holds",
            ":9:23",
        ),
        (
            "a port declared in the rule",
            "rule r() on (x) { state x: [0.0, 1.0] = 0.0; }",
            "`x` is a port of rule `r` and cannot be declared in it",
            ":9:29",
        ),
        (
            "rule defined twice",
            "rule r() on (x) { }\n    rule r() on (x) { }",
            "rule `r` is defined twice",
            ":10:10",
        ),
        (
            "a name the rule does not declare",
            "rule r() on (x) { step { x = min(x, fc); } }",
            "rule `r` uses `fc`, which is not its parameter, its port or declared in it",
            ":9:41",
        ),
        (
            "a language word declared in a rule",
            "rule r() on (x) { state next: [0.0, 1.0] = 0.0; }",
            "`next` is a word of the spec language",
            ":9:29",
        ),
        (
            "one signal bound to two ports",
            "rule r() on (x, y) { step { y = x; } }\n    apply r on (x = u, y = u);",
            "`u` is bound to two ports of rule `r`: `x` and `y`",
            ":10:28",
        ),
        (
            "a library rule defined again",
            "rule fmax(L \"mm/s\") on (x) { step { x = min(x, L); } }\n    use feed_safety;",
            "library `feed_safety` brings rule `fmax`, which is already defined",
            ":10:9",
        ),
        (
            "a library used twice",
            "use feed_safety;\n    use feed_safety;",
            "library `feed_safety` is used twice",
            ":10:9",
        ),
        (
            "a unit on an argument",
            "use feed_safety;\n    apply fmax(LIMIT = 4.0 \"mm/s\") on (cmd = u);",
            "an argument takes no unit",
            ":10:28",
        ),
        (
            "tuning a rule's default",
            "use feed_safety;\n    apply backoff(UP = 0.125, LOAD = 2.0, FLOOR = 0.05) on (load = fc, cmd = u);\n    tune BACKOFF_K in {1.0, 2.0};",
            "`BACKOFF_K` takes its value from a rule parameter's default",
            ":11:10",
        ),
        (
            "syntax",
            "apply fmax(LIMIT 4.0) on (cmd = u);",
            "write `apply NAME(PARAM = VALUE, ..)",
            ":9:22",
        ),
    ] {
        let src = host(rules);
        let d = match compile_str(&src, &t) {
            Ok(_) => {
                failed.push(format!("{name}: compiled"));
                continue;
            }
            Err(d) => d,
        };
        let err = d.render("x.qloop", &src);
        if !err.contains(want) || !err.contains(line_col) {
            failed.push(format!("{name}: want `{want}` at `{line_col}` in:\n{err}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn a_flag_is_an_output() {
    let t = Target::default();
    let src = host("").replace("    input fc:", "    #[flag]\n    input fc:");
    let Err(d) = compile_str(&src, &t) else {
        panic!("a flag on an input compiles")
    };
    let err = d.render("x.qloop", &src);
    assert!(err.contains("`#[flag]` applies to outputs only"), "{err}");
    assert!(err.contains(":4:5"), "{err}");
    let ok = host("").replace(
        "    output feed",
        "    #[flag]\n    output hold;\n    output feed",
    );
    let ok = ok.replace(
        "        u += G * (FR - fc);",
        "        u += G * (FR - fc);\n        hold = 0.0;",
    );
    let plan = compile_str(&ok, &t).unwrap_or_else(|d| panic!("{}", d.render("ok", &ok)));
    let hold = plan
        .prog
        .signals
        .iter()
        .find(|s| s.name == "hold")
        .expect("hold");
    assert!(hold.flag);
}

#[test]
fn an_output_computed_before_a_rule_changes_its_source_is_refused() {
    // The host's step writes `feed` from `u`; `fmax` caps `u` afterwards. Its property holds
    // on `u`, but `feed` would carry the uncapped value: refused, at the assignment.
    let t = Target::default();
    for (name, step, line_col) in [
        ("directly", "feed = u;", ":14:9"),
        (
            "through a let",
            "let v = 2.0 * u;\n        feed = 0.5 * v;",
            ":15:9",
        ),
        (
            "through a condition",
            "if u > 1.0 { feed = 1.0; } else { feed = 0.5; }",
            ":14:22",
        ),
    ] {
        let src = format!(
            r#"controller host {{
    period 0.1 "s";
    word 16;
    input fc: [0.0, 5.0] "kN";
    state u: [0.05, 5.0] "mm/s" = 0.5;
    output feed "mm/s";
    const G: 0.25 "(mm/s)/kN";
    const FR: 1.5 "kN";
    use feed_safety;
    apply fmax(LIMIT = 4.0) on (cmd = u);
    step {{
        u += G * (FR - fc);
        // the output
        {step}
    }}
}}
"#
        );
        let Err(d) = compile_str(&src, &t) else {
            panic!("{name}: compiled")
        };
        let err = d.render("x.qloop", &src);
        assert!(
            err.contains("output `feed` is computed from `u` before a rule changes `u`"),
            "{name}: {err}"
        );
        assert!(err.contains(line_col), "{name}: want {line_col} in {err}");
    }
}

/// Issue 35, item 3: library rules with decimal parameters under round-to-nearest
/// (`fixtures/decimal_rules.qloop`). Each parameter in the command's unit is moved down to a
/// multiple of the command's LSB (computed here from the plan's format), the report says so,
/// and on every raw command in range, with loads below, at and above each threshold and both
/// hold states, the compiled step (the plan interpreter) meets every rule's property, each
/// evaluated exactly (`prove::replay::property_holds`). With the parameters as written (the
/// quantisation switched off), 68,410 of the cases broke `backoff`'s speed-up limit, 45,066
/// `fmax`'s cap and 116,742 `idle_feed`'s air-cut feed: a sum or a stored constant rounded up.
#[test]
fn decimal_rule_parameters_are_moved_onto_the_commands_grid_and_every_property_holds() {
    use qloop::ir::SigKind;
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/decimal_rules.qloop"
    );
    let src = std::fs::read_to_string(path).unwrap();
    let plan = qloop::compile_str(&src, &Target::default())
        .unwrap_or_else(|d| panic!("{}", d.render(path, &src)));
    let prog = &plan.prog;
    let id = |n: &str| {
        qloop::ir::SigId(
            prog.signals
                .iter()
                .position(|s| s.name == n)
                .unwrap_or_else(|| panic!("no signal {n}")),
        )
    };
    let u = id("u");
    let frac = plan.format(u).frac;
    let lsb = 2f64.powi(-frac);
    // Written value → the multiple of the LSB at or below it, by counting LSBs.
    for (name, written) in [
        ("IDLE_FEED_FIDL", 0.3),
        ("BACKOFF_UP", 0.05),
        ("FMAX_LIMIT", 4.1),
    ] {
        let c = prog.constants.iter().find(|c| c.name == name).unwrap();
        let k = (written / lsb) as i64; // truncation = floor for positive values
        assert_eq!(c.value, k as f64 * lsb, "{name}");
        assert!(c.value <= written && written - c.value < lsb, "{name}");
        let q = c.quantised.as_ref().expect("quantised");
        assert_eq!((q.written, q.signal.as_str(), q.frac), (written, "u", frac));
    }
    // Parameters not in a written port's unit stay as written: the load thresholds, fmin's
    // LIMIT (fmin compares the command, it does not write it), and backoff's FLOOR (only its
    // properties read it; moved down below the range's lowest value, it would let them
    // assume a fall that saturation stops).
    for name in [
        "IDLE_FEED_POUT",
        "BACKOFF_LOAD",
        "FMIN_LIMIT",
        "BACKOFF_FLOOR",
    ] {
        let c = prog.constants.iter().find(|c| c.name == name).unwrap();
        assert!(c.quantised.is_none(), "{name}");
    }
    let report = qloop::report::check_report(&plan, "decimal_rules.qloop");
    assert!(
        report.contains(&format!(
            "BACKOFF_UP = 0.05 is used as 0.0498046875, the multiple of `u`'s LSB 2^-{frac} at or below it"
        )),
        "{report}"
    );

    // Every raw command, loads around each threshold, both hold states.
    let fc = id("fc");
    let fq = plan.format(fc);
    let raw = |v: f64| (v * 2f64.powi(fq.frac)).round() as i128;
    let loads: Vec<i128> = [0.0, 0.1, 2.0, 5.0]
        .iter()
        .flat_map(|&t| [raw(t) - 1, raw(t), raw(t) + 1])
        .filter(|r| (0..=raw(5.0)).contains(r))
        .collect();
    let (ulo, uhi) = plan.raw_bounds(u).unwrap();
    let (held, fault) = (id("held"), id("fault_code"));
    let (hlo, hhi) = plan.raw_bounds(held).unwrap();
    let mut checked = 0;
    for ur in ulo..=uhi {
        for &f in &loads {
            for h in [hlo, hhi] {
                let mut pre = vec![0i128; prog.signals.len()];
                for (i, s) in prog.signals.iter().enumerate() {
                    if s.kind == SigKind::State {
                        pre[i] = plan.raw_init(qloop::ir::SigId(i));
                    }
                }
                pre[u.0] = ur;
                pre[fc.0] = f;
                pre[held.0] = h;
                pre[fault.0] = plan.raw_init(fault);
                let mut post = pre.clone();
                qloop::interp::step_fixed(&plan, &mut post).unwrap();
                for (k, p) in prog.properties.iter().enumerate() {
                    assert_eq!(
                        qloop::prove::replay::property_holds(&plan, k, &pre, &post, &[]),
                        Some(true),
                        "property {} fails at u = {}, fc = {}, held = {h}",
                        p.name,
                        ur as f64 * lsb,
                        f as f64 * 2f64.powi(-fq.frac)
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 100_000, "{checked} property evaluations");
}
