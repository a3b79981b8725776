//! The LinuxCNC HAL component (`qloop gen --lang linuxcnc`):
//! * a snapshot of the 1981 controller's `.comp` (review every changed `.snap` line by line),
//!   and the committed example `targets/linuxcnc/example/` equal to it;
//! * its C: the controller section has no division, modulo or floating point, the whole C
//!   section no division or modulo; the markers `run.sh` relies on are there;
//! * what a component cannot represent is refused with a message, never a panic;
//! * every seed spec's component, built by `halcompile --install` and run in a `halrun` servo
//!   thread by `targets/linuxcnc/run.sh`, matches the Rust controller (`qloop-verified`) period
//!   by period. It needs halcompile and halrun (LinuxCNC), and root or password-less sudo;
//!   missing, the test skips with a note unless `QLOOP_REQUIRE_TOOLS` is set.

use qloop::emit::linuxcnc::{component_name, MARKERS};
use qloop_tests::{plan_for, run, scratch, skip, tool};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The component of a seed spec, planned for `host` as `qloop gen --lang linuxcnc` does.
fn comp(stem: &str) -> String {
    qloop::gen_linuxcnc(&plan_for(stem, "host")).unwrap_or_else(|e| panic!("{stem}: {e}"))
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The text between two marker lines.
fn between<'a>(text: &'a str, begin: &str, end: &str) -> &'a str {
    let a = text.find(begin).expect("begin marker") + begin.len();
    let b = text[a..].find(end).expect("end marker") + a;
    &text[a..b]
}

/// C source without its comments (string literals kept).
fn strip_comments(c: &str) -> String {
    let (b, mut o, mut i) = (c.as_bytes(), Vec::new(), 0);
    while i < b.len() {
        if b[i..].starts_with(b"/*") {
            i += c[i..].find("*/").map_or(b.len() - i, |k| k + 2);
            o.push(b' ');
        } else if b[i..].starts_with(b"//") {
            i += c[i..].find('\n').unwrap_or(b.len() - i);
        } else if b[i] == b'"' {
            let end = (i + 1..b.len())
                .find(|&k| b[k] == b'"' && b[k - 1] != b'\\')
                .unwrap_or(b.len() - 1);
            o.extend_from_slice(&b[i..=end]);
            i = end + 1;
        } else {
            o.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(o).unwrap()
}

/// Identifier and number tokens of a line of C.
fn tokens(line: &str) -> Vec<&str> {
    let mut v = Vec::new();
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'.' {
            let s = i;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric()
                    || b[i] == b'_'
                    || b[i] == b'.'
                    || ((b[i] == b'+' || b[i] == b'-')
                        && matches!(b[i - 1], b'e' | b'E' | b'p' | b'P')
                        && b[s].is_ascii_digit()))
            {
                i += 1;
            }
            v.push(&line[s..i]);
        } else {
            i += 1;
        }
    }
    v
}

/// A line of C without the path of a system `#include` (`#include <avr/pgmspace.h>`, which
/// the table arrays of the controller need on AVR): a `/` there is no division.
fn arithmetic(line: &str) -> &str {
    let path = line
        .trim_start()
        .strip_prefix("#include <")
        .and_then(|p| p.trim_end().strip_suffix('>'));
    match path {
        Some(p)
            if p.bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"_/.".contains(&b)) =>
        {
            ""
        }
        _ => line,
    }
}

/// A floating constant: a decimal number with a point or an exponent, or a hexadecimal one
/// with a binary exponent.
fn is_float_literal(t: &str) -> bool {
    let hex = t.starts_with("0x") || t.starts_with("0X");
    (t.starts_with(|c: char| c.is_ascii_digit()) || (t.starts_with('.') && t.len() > 1))
        && if hex {
            t.contains(['p', 'P'])
        } else {
            t.contains(['.', 'e', 'E'])
        }
}

#[test]
fn koren_masory_1981_component_snapshot() {
    insta::assert_snapshot!("koren_masory_1981_comp", comp("koren_masory_1981"));
}

#[test]
fn committed_example_is_the_emitters_output() {
    let stem = "koren_masory_1981";
    let path = root().join(format!("targets/linuxcnc/example/qloop_{stem}.comp"));
    let committed = std::fs::read_to_string(&path).unwrap();
    assert!(
        committed == comp(stem),
        "{} differs from the emitter's output; regenerate it with\n  cargo run -p qloop -- gen \
         verified/specs/{stem}.qloop --lang linuxcnc --out targets/linuxcnc/example",
        path.display()
    );
}

fn every_seed_spec_is_a_component_with_the_pins_run_sh_expects(stem: &str) {
    let plan = plan_for(stem, "host");
    let text = comp(stem);
    let name = component_name(&plan);
    assert!(text.starts_with(&format!("component {name} ")), "{stem}");
    let n_in = plan.prog.ids_of(qloop::ir::SigKind::Input).count();
    let in_pins: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("pin in float "))
        .map(|l| l.split(' ').next().unwrap())
        .collect();
    assert_eq!(in_pins.len(), n_in, "{stem}");
    assert_eq!(in_pins[0], "spindle_load", "{stem}");
    for p in &in_pins {
        assert!(
            text.contains(&format!("\npin out s32 {p}_raw ")),
            "{stem}: {p}_raw"
        );
    }
    for p in [
        "pin out float adaptive_feed ",
        "pin out u32 steps ",
        "param r u32 period_us = ",
        "\nfunction _ ",
        "\nFUNCTION(_)\n",
        "\nEXTRA_SETUP()\n",
    ] {
        assert!(text.contains(p), "{stem}: no `{p}`");
    }
    // halcompile makes a macro of the bare name of every pin, param and variable, and of
    // `data`: each of those, read from the declarations themselves (not from the list
    // the emitter pushes), must be pushed away before the controller and popped after it.
    let pushes: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("#pragma push_macro(\""))
        .filter_map(|l| l.strip_suffix("\")"))
        .collect();
    let pops: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("#pragma pop_macro(\""))
        .filter_map(|l| l.strip_suffix("\")"))
        .collect();
    let declared: Vec<&str> = text
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            match w.first().copied() {
                Some("pin") | Some("param") => w.get(3).copied(),
                Some("variable") => w.get(2).copied(),
                _ => None,
            }
        })
        .map(|n| n.trim_end_matches(';'))
        .chain(["data"])
        .collect();
    for name in &declared {
        assert!(pushes.contains(name), "{stem}: `{name}` is not pushed away");
        assert!(pops.contains(name), "{stem}: `{name}` is not popped back");
    }
    // The controller's own identifiers from the spec, too.
    for sig in &plan.prog.signals {
        let id = qloop::emit::c::ident(&sig.name);
        assert!(
            pushes.contains(&id.as_str()),
            "{stem}: spec name `{id}` not pushed"
        );
    }
    assert_eq!(pushes, pops, "{stem}: pops differ from pushes");
    let mut at = 0;
    for m in MARKERS {
        at += text[at..]
            .find(m)
            .unwrap_or_else(|| panic!("{stem}: marker {m} missing or out of order"));
    }
}

fn controller_has_no_division_or_float_and_the_component_no_division(stem: &str) {
    let text = comp(stem);
    let controller = strip_comments(between(&text, MARKERS[0], MARKERS[1]));
    assert!(controller.contains(&format!("{stem}_step(")), "{stem}");
    let params: Vec<&str> = controller
        .lines()
        .filter_map(|l| l.strip_prefix("#define "))
        .map(|l| l.split(' ').next().unwrap())
        .filter(|m| m.contains("_PARAM_"))
        .collect();
    for line in controller.lines() {
        assert!(
            !arithmetic(line).contains('/') && !line.contains('%'),
            "{stem}: division or modulo in the controller: {line}"
        );
        let toks = tokens(line);
        assert!(
            !toks.iter().any(|t| *t == "float" || *t == "double"),
            "{stem}: floating-point type in the controller: {line}"
        );
        // The compiled-in params are documented as macros; nothing may use them.
        if params
            .iter()
            .any(|m| line.starts_with(&format!("#define {m} ")))
        {
            continue;
        }
        assert!(
            !toks.iter().any(|t| is_float_literal(t)),
            "{stem}: floating constant in the controller: {line}"
        );
        assert!(
            !toks.iter().any(|t| params.contains(t)),
            "{stem}: a param macro is used: {line}"
        );
    }
    // The glue and the HAL function convert floats by multiplications only.
    let c = strip_comments(text.split_once("\n;;\n").expect("C section").1);
    for line in c.lines() {
        assert!(
            !arithmetic(line).contains('/') && !line.contains('%'),
            "{stem}: division or modulo in the component's C: {line}"
        );
    }
}

/// The entries of a glue array `static const T NAME[..] = { a, b }; /* .. */`.
fn glue_array(text: &str, name: &str) -> Vec<String> {
    let line = text
        .lines()
        .find(|l| l.starts_with("static const") && l.contains(&format!(" {name}[")))
        .unwrap_or_else(|| panic!("no {name}"));
    let inner = between(line, "{ ", " }");
    inner.split(", ").map(str::to_string).collect()
}

/// The value after `prefix` on the line that starts with it, up to `end`.
fn value_after<'a>(text: &'a str, prefix: &str, end: char) -> &'a str {
    let line = text
        .lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line `{prefix}`"));
    line[prefix.len()..].split(end).next().unwrap()
}

/// The constants run.sh's checker takes from the glue (conversion scales, raw bounds, the
/// override multiplier, rounding, period) and the params' values, recomputed from the plan.
fn glue_constants_and_params_are_the_plans(stem: &str) {
    use qloop::ir::SigKind;
    let plan = plan_for(stem, "host");
    let text = comp(stem);
    let glue = between(&text, MARKERS[2], MARKERS[3]);
    let ins: Vec<_> = plan.prog.ids_of(SigKind::Input).collect();
    let outs: Vec<_> = plan.prog.ids_of(SigKind::Output).collect();
    let scale = |e: i32| format!("0x1p{e}");
    let want: Vec<String> = ins.iter().map(|i| scale(plan.format(*i).frac)).collect();
    assert_eq!(glue_array(glue, "qloop_in_scale"), want, "{stem}");
    let bounds: Vec<(i128, i128)> = ins.iter().map(|i| plan.raw_bounds(*i).unwrap()).collect();
    let lo: Vec<String> = bounds.iter().map(|b| b.0.to_string()).collect();
    let hi: Vec<String> = bounds.iter().map(|b| b.1.to_string()).collect();
    assert_eq!(glue_array(glue, "qloop_in_min"), lo, "{stem}");
    assert_eq!(glue_array(glue, "qloop_in_max"), hi, "{stem}");
    let want: Vec<String> = outs.iter().map(|o| scale(-plan.format(*o).frac)).collect();
    assert_eq!(glue_array(glue, "qloop_out_scale"), want, "{stem}");
    let ovr: f64 = value_after(glue, "static const double qloop_override_scale = ", ';')
        .parse()
        .unwrap();
    assert_eq!(ovr, 1.0 / plan.summary[outs[0].0].range.1, "{stem}");
    let nearest = plan.prog.rounding == qloop::qformat::Rounding::Nearest;
    assert_eq!(
        value_after(glue, "#define QLOOP_ROUND_NEAREST ", ' '),
        if nearest { "1" } else { "0" },
        "{stem}"
    );
    let period_us = (plan.prog.period * 1e6).round() as u64;
    assert_eq!(
        value_after(glue, "#define QLOOP_PERIOD_US ", 'U'),
        period_us.to_string()
    );
    assert_eq!(
        value_after(&text, "param r u32 period_us = ", ' '),
        period_us.to_string()
    );
    for c in plan.prog.constants.iter().filter(|c| c.is_param) {
        let prefix = format!("param r float {} = ", c.name.to_lowercase());
        let v: f64 = value_after(&text, &prefix, ' ').parse().unwrap();
        assert_eq!(v, c.value, "{stem}: {}", c.name);
    }
}
test_tools::spec_tests! {
    every_seed_spec_is_a_component_with_the_pins_run_sh_expects,
    controller_has_no_division_or_float_and_the_component_no_division,
    glue_constants_and_params_are_the_plans in "verified/specs";
    default: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
        koren_masory_safe, koren_masory_tuned, milling_acc,
    ];
    acceptance: [milling_multimodel];
}

#[test]
fn the_checks_see_what_they_look_for() {
    assert!(is_float_literal("0.5") && is_float_literal("0x1p-12") && is_float_literal("1e3"));
    assert!(!is_float_literal("20480") && !is_float_literal("0x1e") && !is_float_literal("_1e5"));
    assert_eq!(tokens("x = 1.5e-3 * y;"), ["x", "1.5e-3", "y"]);
    assert_eq!(arithmetic("#include <avr/pgmspace.h>"), "");
    for l in [
        "x = a / b;",
        "#include <a/b.h> /* x */ y = a / b;",
        "#include \"a/b.h\"",
    ] {
        assert_eq!(arithmetic(l), l);
    }
    assert_eq!(
        strip_comments("a /* b / c */ d // e\n\"/\""),
        "a   d \n\"/\""
    );
}

/// Compiles a spec for `host` and generates its component; the error message if refused.
fn refusal(src: &str) -> String {
    let plan = qloop::compile_str(src, &qloop::targets::by_name("host").unwrap())
        .unwrap_or_else(|e| panic!("{e}\n{src}"));
    match qloop::gen_linuxcnc(&plan) {
        Ok(_) => panic!("accepted:\n{src}"),
        Err(e) => e.to_string(),
    }
}

/// A small spec: `decls` inside the controller, and a body.
fn spec(name: &str, decls: &str, body: &str) -> String {
    format!("controller {name} {{\n period 0.01 \"s\";\n {decls}\n step {{ {body} }}\n}}\n")
}

#[test]
fn what_a_component_cannot_represent_is_refused_with_a_message() {
    let cases = [
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; output y: [-1.0, 0.0];",
                "y = -x;",
            ),
            "range maximum, which is 0",
        ),
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; state s: [0.0, 1.0] = 0.0;",
                "s = x;",
            ),
            "no output",
        ),
        (
            spec(
                "t",
                "#[q(i64, 40)] input x: [0.0, 1.0]; output y;",
                "y = x;",
            ),
            "does not fit a HAL s32 pin",
        ),
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; input ω: [0.0, 1.0]; output y;",
                "y = x + ω;",
            ),
            "not an ASCII identifier",
        ),
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; input time: [0.0, 1.0]; output y;",
                "y = x + time;",
            ),
            "`time` is reserved",
        ),
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; param STEPS: 2.0; output y;",
                "y = x * STEPS;",
            ),
            "would both be the HAL name `steps`",
        ),
        (
            spec(
                "t",
                "input x: [0.0, 1.0]; input b: [0.0, 1.0]; output b_raw;",
                "b_raw = x + b;",
            ),
            "would both be the HAL name `b_raw`",
        ),
        (
            spec(
                "a_controller_name_too_long_for_hal",
                "input x: [0.0, 1.0]; output y;",
                "y = x;",
            ),
            "more than HAL's 47",
        ),
    ];
    for (src, want) in cases {
        let msg = refusal(&src);
        assert!(msg.contains(want), "expected `{want}` in: {msg}\n{src}");
        assert!(msg.starts_with("spec `"), "{msg}");
    }
}

/// Whether `halcompile --install` can run: as root, or with password-less sudo (a prompt
/// would hang the test).
fn can_install() -> bool {
    let uid = Command::new("id").arg("-u").output().ok();
    let root = uid.is_some_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let sudo = || {
        Command::new("sudo")
            .args(["-n", "true"])
            .status()
            .is_ok_and(|s| s.success())
    };
    if root || sudo() {
        return true;
    }
    skip("halcompile --install needs root or password-less sudo");
    false
}

/// The machine-wide HAL session: one halrun test at a time.
static HAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The seed spec's component in a halrun servo thread matches the Rust controller. One halrun
/// at a time (`run.sh` holds the machine-wide HAL session): under `cargo test` the [`HAL`]
/// lock, under nextest the `halrun` test group (`.config/nextest.toml`).
fn halrun_matches_the_rust_controller(stem: &str) {
    if tool("halcompile").is_none() || tool("halrun").is_none() || !can_install() {
        return;
    }
    let _hal = HAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch(&format!("linuxcnc-{stem}"));
    let plan = plan_for(stem, "host");
    let comp_file = dir.join(format!("{}.comp", component_name(&plan)));
    std::fs::write(&comp_file, comp(stem)).unwrap();
    // The 1981 controller gets the full 20,000 periods, the others a shorter run, but at
    // least 25 controller steps at run.sh's 1 ms thread (`gac_surface_finish`, one step a
    // second, runs 25 s).
    let steps_25 = (25.0 * plan.prog.period * 1e3).ceil() as usize;
    let rows = if stem == "koren_masory_1981" {
        20_000
    } else {
        steps_25.max(6000)
    };
    let out = run(Command::new("bash")
        .arg(root().join("targets/linuxcnc/run.sh"))
        .arg(&comp_file)
        .arg("rust")
        .env("QLOOP_TEST_ROWS", rows.to_string())
        .env("CARGO_TARGET_DIR", root().join("target/linuxcnc-ref")));
    let pass = out.lines().find(|l| l.starts_with("PASS: "));
    assert!(pass.is_some(), "{stem}: no PASS line:\n{out}");
    eprintln!("{stem}: {}", pass.unwrap_or_default());
}
// Each replays seconds of real time in a 1 ms thread, one at a time: the acceptance tier's.
test_tools::spec_tests! {
    halrun_matches_the_rust_controller in "verified/specs";
    default: [];
    acceptance: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
        koren_masory_safe, koren_masory_tuned, milling_acc, milling_multimodel,
    ];
}

/// Issue 18, item 4: the safe spec's component has the bit pin `feed-hold` (its `#[flag]`
/// output) and the pin `fault`, and in halrun a spindle load held constant (a stuck sensor)
/// sets the hold on the 10th unchanged reading: FALSE at 0.5 s, TRUE at 1.8 s with fault 3 and
/// the feed 0 (`targets/linuxcnc/hold.sh`).
#[test]
fn the_safe_component_has_the_feed_hold_and_fault_pins() {
    let c = comp("koren_masory_safe");
    assert!(
        c.contains("\npin out bit feed_hold "),
        "no bit pin feed_hold"
    );
    assert!(c.contains("\npin out float fault "), "no pin fault");
}

/// The halrun half of the test above, with real time: the acceptance tier's.
#[test]
#[ignore = "acceptance tier (docs/book/src/internals/tests.md)"]
fn halrun_sets_feed_hold_and_fault_on_the_safe_component() {
    let c = comp("koren_masory_safe");
    if tool("halcompile").is_none() || tool("halrun").is_none() || !can_install() {
        return;
    }
    let _hal = HAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("linuxcnc-hold");
    let plan = plan_for("koren_masory_safe", "host");
    let comp_file = dir.join(format!("{}.comp", component_name(&plan)));
    std::fs::write(&comp_file, c).unwrap();
    let out = run(Command::new("bash")
        .arg(root().join("targets/linuxcnc/hold.sh"))
        .arg(&comp_file));
    let pass = out.lines().find(|l| l.starts_with("PASS: "));
    assert!(pass.is_some(), "no PASS line:\n{out}");
    eprintln!("{}", pass.unwrap_or_default());
}
