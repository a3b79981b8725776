//! The C outputs of a spec with vectors and matrices (tests/vectors.qloop: `input phi[2]`,
//! `state theta[2]`, `state P[2][2]`, `output dtheta[2]`), where the structs hold arrays and
//! `step` works on one scalar local per element:
//!
//! * the fixed-point C (`qloop gen --lang c`) of every built-in target's plan compiles without
//!   a warning with that target's compiler, and, built for the host with UBSan, computes bit
//!   for bit what qloop's plan interpreter computes, from the initial state and from random
//!   and corner states inside the bounds, on random raw inputs (also beyond the ranges);
//! * Frama-C Eva proves it free of run-time errors, with its ACSL contract, for every state
//!   in bounds and every raw input (host and 16-bit `int`);
//! * its macros: one `_FRAC` per vector, `_MIN`/`_MAX` per element, no name twice;
//! * the float C (`qloop::emit::c_float`) agrees with qloop's real-arithmetic interpreter
//!   (`step_real`, which the f64 reference equals: vectors.rs) within single precision;
//! * the LinuxCNC component has one pin per element with distinct names, is built by
//!   `halcompile --compile` (no install, no root), and its controller and glue, compiled for
//!   the host with `targets/linuxcnc/test/host_ref.c` as `run.sh` does, match the interpreter;
//!   an element whose pin name another pin has is refused.
//!
//! Tools that are not installed skip their part (`qloop_tests::tool`).

use qloop::emit::c_float;
use qloop::emit::linuxcnc::MARKERS;
use qloop::interp::{step_fixed, step_real};
use qloop::ir::{SigId, SigKind};
use qloop::Plan;
use qloop_tests::{run, scratch, tool};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const SPEC: &str = include_str!("vectors.qloop");

fn plan_for(target: &str) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    qloop::compile_str(SPEC, &t).unwrap_or_else(|e| panic!("vectors.qloop for {target}: {e}"))
}

fn ids(plan: &Plan, k: SigKind) -> Vec<SigId> {
    plan.prog.ids_of(k).collect()
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// xorshift64: a fixed, dependency-free stream of test values.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn in_range(&mut self, lo: i128, hi: i128) -> i128 {
        lo + (self.next() as i128).rem_euclid(hi - lo + 1)
    }

    /// Uniform in `[lo, hi]`, rounded to `f32` (so C and Rust see the same value).
    fn float_in(&mut self, lo: f64, hi: f64) -> f64 {
        let t = (self.next() >> 11) as f64 / (1u64 << 53) as f64;
        f64::from((lo + t * (hi - lo)) as f32)
    }
}

/// A signal as the struct field the API promises: `y`, or `phi[1]`, `P[1][0]` for an element
/// (the spec's indexing, row-major arrays). Written here, not taken from the emitters, so
/// that an emitter that stored elements at other indices fails the comparisons below.
fn path(plan: &Plan, id: SigId) -> String {
    let s = plan.prog.sig(id);
    match &s.elem {
        None => s.name.clone(),
        Some(e) => e
            .index
            .iter()
            .fold(e.group.clone(), |p, i| format!("{p}[{i}]")),
    }
}

/// A raw input value: mostly inside the declared range, sometimes anywhere in the storage
/// type (step clamps it), sometimes at the edges.
fn raw_input(plan: &Plan, id: SigId, rng: &mut Rng) -> i128 {
    let q = plan.format(id);
    let (lo, hi) = plan.bounds(id);
    match rng.next() % 16 {
        0 => q.ty.min(),
        1 => q.ty.max(),
        2 => lo,
        3 => hi,
        4 | 5 => rng.in_range(q.ty.min(), q.ty.max()),
        _ => rng.in_range(lo, hi),
    }
}

/// Runs `exe` on `script` (stdin); its output lines as numbers.
fn run_lines<T: std::str::FromStr>(exe: &Path, script: &str) -> Vec<Vec<T>>
where
    T::Err: std::fmt::Debug,
{
    let mut child = Command::new(exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", exe.display()));
    let mut stdin = child.stdin.take().unwrap();
    let script = script.to_string();
    let feeder = std::thread::spawn(move || {
        use std::io::Write as _;
        stdin.write_all(script.as_bytes()).unwrap();
    });
    let o = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    assert!(
        o.status.success(),
        "{} failed ({}): {}",
        exe.display(),
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// Writes `vectors.h`/`vectors.c` into `dir`; the `.c` path.
fn write_c(plan: &Plan, dir: &Path) -> PathBuf {
    let (h, c) = qloop::gen_c(plan);
    std::fs::write(dir.join("vectors.h"), h).unwrap();
    let p = dir.join("vectors.c");
    std::fs::write(&p, c).unwrap();
    p
}

/// A driver reading commands from stdin: `S v..` sets the raw states, `I v..` runs one step
/// on raw inputs and prints the raw outputs, then the raw states (scalars in declaration
/// order, a vector's elements row-major, through the struct's arrays).
fn fixed_driver(plan: &Plan) -> String {
    let field = |id: &SigId| path(plan, *id);
    let ty = |id: &SigId| qloop::emit::c::c_ty(plan.format(*id).ty);
    let mut d = String::from(
        "#include \"vectors.h\"\n#include <stdio.h>\nint main(void) {\n    vectors_state s;\n    \
         vectors_inputs in;\n    vectors_outputs out;\n    long long v;\n    char op;\n    \
         vectors_init(&s);\n    while (scanf(\" %c\", &op) == 1) {\n        if (op == 'S') {\n",
    );
    for id in ids(plan, SigKind::State) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            s.{} = ({})v;",
            field(&id),
            ty(&id)
        );
    }
    d.push_str("        } else {\n");
    for id in ids(plan, SigKind::Input) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            in.{} = ({})v;",
            field(&id),
            ty(&id)
        );
    }
    d.push_str("            vectors_step(&s, &in, &out);\n");
    for (what, k) in [("out", SigKind::Output), ("s", SigKind::State)] {
        for id in ids(plan, k) {
            let f = field(&id);
            let _ = writeln!(d, "            printf(\"%lld \", (long long){what}.{f});");
        }
    }
    d.push_str("            printf(\"\\n\");\n        }\n    }\n    return 0;\n}\n");
    d
}

#[test]
fn fixed_c_holds_arrays_and_one_frac_per_vector() {
    let plan = plan_for("host");
    let (h, c) = qloop::gen_c(&plan);
    for want in [
        "    int32_t phi[2]; /* input: phi[0] [-1, 1], phi[1] [-1, 1] ",
        "    int32_t y; /* input: [-4, 4] ",
        "    int32_t theta[2]; /* state: theta[0] [-2, 2], theta[1] [-1, 1] ",
        "    int32_t P[2][2]; /* state: P[0][0] [0, 2], P[0][1] [-1, 1], P[1][0] [-1, 1], P[1][1] [0, 2] ",
        "    int32_t dtheta[2]; /* output: ",
        "#define VECTORS_P_FRAC 29\n#define VECTORS_P_0_0_MIN ((int32_t)0)\n",
        "#define VECTORS_P_1_0_MAX ((int32_t)536870912)\n",
        "#define VECTORS_THETA_1_MIN ((int32_t)-536870912)\n",
    ] {
        assert!(h.contains(want), "no `{want}` in the header:\n{h}");
    }
    for want in [
        "    self->P[1][1] = ((int32_t)536870912);\n",
        "    int32_t P_1_0 = self->P[1][0];\n",
        "    self->P[1][0] = P_1_0;\n",
        "    out->dtheta[1] = dtheta_1;\n",
        " = in->phi[1];\n",
        "    requires VECTORS_P_1_0_MIN <= self->P[1][0] <= VECTORS_P_1_0_MAX;\n",
        "    s.P[0][1] = (int32_t)Frama_C_long_long_interval(",
    ] {
        assert!(c.contains(want), "no `{want}` in the source:\n{c}");
    }
    // One FRAC per vector, bounds per element; no macro twice.
    let defines: Vec<&str> = h
        .lines()
        .filter_map(|l| l.strip_prefix("#define "))
        .map(|l| l.split(' ').next().unwrap())
        .collect();
    let mut seen = std::collections::HashSet::new();
    for d in &defines {
        assert!(seen.insert(*d), "`{d}` defined twice");
    }
    let fracs: Vec<&str> = defines
        .iter()
        .copied()
        .filter(|d| d.ends_with("_FRAC"))
        .collect();
    assert_eq!(
        fracs,
        [
            "VECTORS_PHI_FRAC",
            "VECTORS_Y_FRAC",
            "VECTORS_THETA_FRAC",
            "VECTORS_P_FRAC",
            "VECTORS_YHAT_FRAC",
            "VECTORS_DTHETA_FRAC"
        ]
    );
    let n_bounded = [SigKind::Input, SigKind::State, SigKind::Output]
        .iter()
        .flat_map(|k| ids(&plan, *k))
        .filter(|id| plan.raw_bounds(*id).is_some())
        .count();
    assert_eq!(
        defines.iter().filter(|d| d.ends_with("_MIN")).count(),
        n_bounded
    );
}

#[test]
fn fixed_c_compiles_without_warnings_for_every_target() {
    for t in qloop::targets::builtin() {
        let Some(cc) = t.toolchain.cc.as_deref().and_then(tool) else {
            continue;
        };
        let plan = plan_for(&t.name);
        let dir = scratch(&format!("c-vectors-warn-{}", t.name));
        let c = write_c(&plan, &dir);
        let mut flags = t.toolchain.cflags.clone();
        if t.name == "host" {
            flags.push("-Wconversion".into());
        }
        run(Command::new(&cc)
            .args(["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c"])
            .args(&flags)
            .arg(&c)
            .arg("-o")
            .arg(dir.join("step.o")));
    }
}

#[test]
fn fixed_c_matches_the_interpreter_bit_for_bit() {
    let Some(cc) = tool("cc") else { return };
    for t in qloop::targets::builtin() {
        // Plans differ per target in how they multiply; each one's C must compute its plan.
        let plan = plan_for(&t.name);
        let dir = scratch(&format!("c-vectors-interp-{}", t.name));
        let (states, inputs, outputs) = (
            ids(&plan, SigKind::State),
            ids(&plan, SigKind::Input),
            ids(&plan, SigKind::Output),
        );
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ t.name.len() as u64);
        let mut script = String::new();
        let mut want: Vec<Vec<i64>> = Vec::new();
        let mut vars = vec![0i128; plan.prog.signals.len()];
        for id in &states {
            vars[id.0] = plan.raw_init(*id);
        }
        // 500 steps along the trajectory from the initial state (no `S`: `init`'s values),
        // then 4000 steps each from a state of its own: the corners first, then random.
        for case in 0..4_500usize {
            if case >= 500 {
                let c = case - 500;
                for (k, id) in states.iter().enumerate() {
                    let (lo, hi) = plan.raw_bounds(*id).unwrap();
                    vars[id.0] = match c {
                        0..64 if (c >> (k % 6)) & 1 == 0 => lo,
                        0..64 => hi,
                        _ => rng.in_range(lo, hi),
                    };
                }
                script.push('S');
                for id in &states {
                    let _ = write!(script, " {}", vars[id.0]);
                }
                script.push('\n');
            }
            for id in &inputs {
                vars[id.0] = raw_input(&plan, *id, &mut rng);
            }
            script.push('I');
            for id in &inputs {
                let _ = write!(script, " {}", vars[id.0]);
            }
            script.push('\n');
            step_fixed(&plan, &mut vars).unwrap_or_else(|e| panic!("{}: {e:?}", t.name));
            want.push(
                outputs
                    .iter()
                    .chain(&states)
                    .map(|id| vars[id.0] as i64)
                    .collect(),
            );
        }
        let c = write_c(&plan, &dir);
        std::fs::write(dir.join("driver.c"), fixed_driver(&plan)).unwrap();
        let exe = dir.join("driver");
        run(Command::new(&cc)
            .args(["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror"])
            .args(["-fsanitize=undefined", "-fno-sanitize-recover=all"])
            .arg(&c)
            .arg(dir.join("driver.c"))
            .arg("-o")
            .arg(&exe));
        let got: Vec<Vec<i64>> = run_lines(&exe, &script);
        assert_eq!(got.len(), want.len(), "{}: step count", t.name);
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "{}: step {k}: C vs interpreter", t.name);
        }
    }
}

/// Frama-C Eva on the fixed-point C: 0 alarms, every contract property valid, every
/// element's bounds a proved postcondition.
#[test]
fn fixed_c_is_free_of_runtime_errors_by_frama_c_eva() {
    let Some(frama) = tool("frama-c") else { return };
    for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
        let plan = plan_for(target);
        let dir = scratch(&format!("c-vectors-eva-{target}"));
        let c = write_c(&plan, &dir);
        let out = run(Command::new(&frama)
            .args(["-machdep", machdep])
            .args(["-warn-signed-downcast", "-warn-unsigned-downcast"])
            .args(["-eva", "-main", "vectors_eva_main"])
            .arg(&c)
            .args(["-then", "-report"]));
        assert!(
            out.contains("0 alarms generated by the analysis"),
            "{target}: Eva raised alarms:\n{out}"
        );
        for l in out
            .lines()
            .filter(|l| l.contains(" valid ") && l.contains(" unknown "))
        {
            let w: Vec<&str> = l.split_whitespace().collect();
            let count = |what: &str| {
                w.iter()
                    .position(|x| *x == what)
                    .and_then(|i| w[i - 1].parse::<u32>().ok())
            };
            assert_eq!(count("unknown"), Some(0), "{target}: {l}\n{out}");
            assert_eq!(count("invalid"), Some(0), "{target}: {l}\n{out}");
        }
        assert!(!out.contains("Invalid"), "{target}:\n{out}");
        let posts = out
            .lines()
            .filter(|l| l.starts_with("[  Valid  ] Post-condition (file"))
            .count();
        let n_states = ids(&plan, SigKind::State).len();
        assert!(
            posts >= n_states,
            "{target}: {posts} postconditions proved, want ≥ {n_states}:\n{out}"
        );
    }
}

/// A driver for `vectors_f`: `S s..` sets the states, `X i..` steps and prints the outputs
/// then the states, `I` re-initialises and prints the states.
fn float_driver(plan: &Plan) -> String {
    let fields =
        |k: SigKind| -> Vec<String> { ids(plan, k).iter().map(|id| path(plan, *id)).collect() };
    let (inputs, states, outputs) = (
        fields(SigKind::Input),
        fields(SigKind::State),
        fields(SigKind::Output),
    );
    let read = |v: &[String], s: &str| {
        v.iter()
            .map(|f| format!("            {s}.{f} = rd();\n"))
            .collect::<String>()
    };
    let print = |v: &[String], s: &str| {
        v.iter()
            .map(|f| format!("            printf(\" %.9g\", (double){s}.{f});\n"))
            .collect::<String>()
    };
    format!(
        "#include <stdio.h>\n#include <stdlib.h>\n#include \"vectors_f.h\"\n\n\
         static float rd(void)\n{{\n    float v;\n    if (scanf(\"%f\", &v) != 1) exit(2);\n    return v;\n}}\n\n\
         int main(void)\n{{\n    vectors_f_state s;\n    vectors_f_inputs in;\n    vectors_f_outputs out;\n    char c;\n\
         \x20   vectors_f_init(&s);\n\
         \x20   while (scanf(\" %c\", &c) == 1) {{\n\
         \x20       if (c == 'I') {{\n            vectors_f_init(&s);\n{}            printf(\"\\n\");\n        }} else if (c == 'S') {{\n{}\
         \x20       }} else if (c == 'X') {{\n{}            vectors_f_step(&s, &in, &out);\n{}{}            printf(\"\\n\");\n\
         \x20       }} else {{\n            return 3;\n        }}\n    }}\n    return 0;\n}}\n",
        print(&states, "s"),
        read(&states, "s"),
        read(&inputs, "in"),
        print(&outputs, "out"),
        print(&states, "s"),
    )
}

/// Random `float` values inside each declared range, for inputs also 10% beyond it (the clamp),
/// with the range ends now and then.
fn draw(rng: &mut Rng, plan: &Plan, kind: SigKind) -> Vec<f64> {
    ids(plan, kind)
        .iter()
        .map(|id| {
            let (lo, hi) = plan.prog.sig(*id).range.expect("ranged");
            let m = if kind == SigKind::Input {
                0.1 * (hi - lo)
            } else {
                0.0
            };
            match rng.next() % 16 {
                0 => f64::from(lo as f32),
                1 => f64::from(hi as f32),
                _ => rng.float_in(lo - m, hi + m),
            }
        })
        .collect()
}

/// The float step against `step_real` from the same (`float`) states and inputs. The bound:
/// every value of vectors.qloop stays within 8 in magnitude and takes at most a dozen
/// roundings of 2^-24 relative in one step, so 2^-16 absolute (about 3× the worst case);
/// an element read or written at another index is off by far more.
#[test]
fn float_c_matches_the_real_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let plan = plan_for("host");
    let prog = &plan.prog;
    let (h, c) = c_float::source(prog);
    for want in [
        "    float phi[2]; /* input: phi[0] [-1, 1], phi[1] [-1, 1]  */",
        "    float P[2][2]; /* state: ",
        "    float dtheta[2]; /* output: ",
    ] {
        assert!(h.contains(want), "no `{want}` in:\n{h}");
    }
    for want in [
        "qloop_clampf(in->phi[1], ",
        "    float P_1_0 = self->P[1][0];\n",
        "    self->P[1][0] = P_1_0;\n",
        "    out->dtheta[0] = dtheta_0;\n",
        "    self->theta[0] = 5e-1f;\n",
    ] {
        assert!(c.contains(want), "no `{want}` in:\n{c}");
    }
    let dir = scratch("c-vectors-float");
    std::fs::write(dir.join("vectors_f.h"), &h).unwrap();
    std::fs::write(dir.join("vectors_f.c"), &c).unwrap();
    std::fs::write(dir.join("driver.c"), float_driver(&plan)).unwrap();
    let exe = dir.join("driver");
    run(Command::new(&cc)
        .args(["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"])
        .args(["-Wdouble-promotion", "-O2"])
        .arg(dir.join("vectors_f.c"))
        .arg(dir.join("driver.c"))
        .arg("-o")
        .arg(&exe));

    let init: Vec<f64> = ids(&plan, SigKind::State)
        .iter()
        .map(|id| f64::from(prog.sig(*id).init.unwrap_or(0.0) as f32))
        .collect();
    // `%.9g` round-trips a float: parsed as f32, then widened.
    let floats = |script: &str| -> Vec<Vec<f64>> {
        run_lines::<f32>(&exe, script)
            .into_iter()
            .map(|l| l.into_iter().map(f64::from).collect())
            .collect()
    };
    assert_eq!(floats("I\n"), [init], "init");

    let mut rng = Rng(0x5eed_f10a_7000_0001);
    let (mut script, mut want) = (String::new(), Vec::new());
    let mut paths = std::collections::BTreeSet::new();
    for _ in 0..3_000 {
        let st = draw(&mut rng, &plan, SigKind::State);
        let inp = draw(&mut rng, &plan, SigKind::Input);
        let text = |v: &[f64]| {
            v.iter()
                .map(|x| format!(" {}", *x as f32))
                .collect::<String>()
        };
        let _ = writeln!(script, "S{}\nX{}", text(&st), text(&inp));
        let mut vars = vec![0.0; prog.signals.len()];
        for (id, v) in ids(&plan, SigKind::State).iter().zip(&st) {
            vars[id.0] = *v;
        }
        for (id, v) in ids(&plan, SigKind::Input).iter().zip(&inp) {
            vars[id.0] = *v;
        }
        paths.insert(step_real(prog, &mut vars));
        let row: Vec<f64> = ids(&plan, SigKind::Output)
            .iter()
            .chain(&ids(&plan, SigKind::State))
            .map(|id| vars[id.0])
            .collect();
        want.push(row);
    }
    // Both ways through the reset `if`.
    assert!(paths.len() >= 2, "branch coverage {paths:?}");
    let got = floats(&script);
    assert_eq!(got.len(), want.len());
    let names: Vec<String> = ids(&plan, SigKind::Output)
        .iter()
        .chain(&ids(&plan, SigKind::State))
        .map(|id| prog.sig(*id).label())
        .collect();
    let tol = 2f64.powi(-16);
    let mut worst = 0.0f64;
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.len(), w.len(), "case {k}");
        for ((g, w), n) in g.iter().zip(w).zip(&names) {
            let d = (g - w).abs();
            worst = worst.max(d);
            assert!(
                d <= tol,
                "case {k}: `{n}` is {g} in C float, {w} in real arithmetic"
            );
        }
    }
    println!("float C: {} steps, worst |diff| {worst:e}", want.len());
}

/// The `.comp` of vectors.qloop, as `qloop gen --lang linuxcnc` writes it (planned for host).
fn component(plan: &Plan) -> String {
    qloop::gen_linuxcnc(plan).unwrap_or_else(|e| panic!("{e}"))
}

/// `pin DIR TYPE NAME` / `param DIR TYPE NAME` declarations: (kind, type, name).
fn declared(comp: &str) -> Vec<(String, String, String)> {
    comp.lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            match w.first().copied() {
                Some("pin") | Some("param") => Some((
                    format!("{} {}", w[0], w[1]),
                    w[2].to_string(),
                    w[3].trim_end_matches(';').to_string(),
                )),
                _ => None,
            }
        })
        .collect()
}

#[test]
fn linuxcnc_component_has_one_pin_per_element() {
    let plan = plan_for("host");
    let comp = component(&plan);
    let decl = declared(&comp);
    let pins = |kind: &str, ty: &str| -> Vec<String> {
        decl.iter()
            .filter(|(k, t, _)| k == kind && t == ty)
            .map(|(.., n)| n.clone())
            .collect()
    };
    // The first input, phi[0], is the spindle-load pin; every other element a pin of its own.
    assert_eq!(pins("pin in", "float"), ["spindle_load", "phi_1", "y"]);
    assert_eq!(
        pins("pin out", "float"),
        ["adaptive_feed", "yhat", "dtheta_0", "dtheta_1"]
    );
    assert_eq!(
        pins("pin out", "s32"),
        [
            "yhat_raw",
            "dtheta_0_raw",
            "dtheta_1_raw",
            "spindle_load_raw",
            "phi_1_raw",
            "y_raw"
        ]
    );
    assert!(comp.contains("pin in float phi_1 \"Regressor φ. The spec's input phi[1], "));
    // Every pin and param name distinct, in C (halcompile's macros) and in HAL.
    let mut c_names = std::collections::HashSet::new();
    let mut hal_names = std::collections::HashSet::new();
    for (.., n) in &decl {
        assert!(c_names.insert(n.clone()), "`{n}` declared twice");
        assert!(
            hal_names.insert(n.replace('_', "-")),
            "HAL name of `{n}` twice"
        );
    }
    // halcompile's macros of the pins, and the spec's names the controller uses (the vectors'
    // names too: they are struct fields), are pushed away around the controller.
    let pushes: Vec<&str> = comp
        .lines()
        .filter_map(|l| l.strip_prefix("#pragma push_macro(\""))
        .filter_map(|l| l.strip_suffix("\")"))
        .collect();
    for n in decl
        .iter()
        .map(|(.., n)| n.as_str())
        .chain(["phi", "theta", "P", "dtheta", "data"])
    {
        assert!(pushes.contains(&n), "`{n}` is not pushed away");
    }
    // The glue passes the raw values through the structs' arrays.
    for want in [
        "    in.phi[0] = (int32_t)in_raw[0];",
        "    in.phi[1] = (int32_t)in_raw[1];",
        "    out_raw[2] = (int32_t)out.dtheta[1];",
        "/* phi[0], phi[1], y */",
    ] {
        assert!(comp.contains(want), "no `{want}`");
    }
}

#[test]
fn linuxcnc_component_builds_with_halcompile() {
    let Some(halcompile) = tool("halcompile") else {
        return;
    };
    let plan = plan_for("host");
    let dir = scratch("c-vectors-halcompile");
    let file = dir.join(format!(
        "{}.comp",
        qloop::emit::linuxcnc::component_name(&plan)
    ));
    std::fs::write(&file, component(&plan)).unwrap();
    run(Command::new(halcompile)
        .arg("--compile")
        .arg(&file)
        .current_dir(&dir));
}

/// The component's controller and glue (as `run.sh` extracts them), compiled for the host with
/// `targets/linuxcnc/test/host_ref.c`, run from the initial state on raw inputs inside the
/// glue's saturation bounds: every step's raw outputs are the interpreter's.
#[test]
fn linuxcnc_glue_and_controller_match_the_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let plan = plan_for("host");
    let comp = component(&plan);
    let begin = comp.find(MARKERS[0]).expect("controller marker");
    let end = comp.find(MARKERS[3]).expect("glue end marker") + MARKERS[3].len();
    let dir = scratch("c-vectors-linuxcnc-ref");
    let inc = dir.join("controller.inc");
    std::fs::write(&inc, format!("{}\n", &comp[begin..end])).unwrap();
    let exe = dir.join("host_ref");
    run(Command::new(&cc)
        .args([
            "-std=c99",
            "-O1",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wno-unused-function",
        ])
        .args(["-fsanitize=undefined", "-fno-sanitize-recover=all"])
        .arg(format!("-DQLOOP_CONTROLLER_INC=\"{}\"", inc.display()))
        .arg(root().join("targets/linuxcnc/test/host_ref.c"))
        .arg("-o")
        .arg(&exe));
    let (states, inputs, outputs) = (
        ids(&plan, SigKind::State),
        ids(&plan, SigKind::Input),
        ids(&plan, SigKind::Output),
    );
    let mut vars = vec![0i128; plan.prog.signals.len()];
    for id in &states {
        vars[id.0] = plan.raw_init(*id);
    }
    let mut rng = Rng(0x0c0f_fee0_1981_2024);
    let (mut script, mut want) = (String::new(), Vec::new());
    for _ in 0..3_000 {
        let row: Vec<String> = inputs
            .iter()
            .map(|id| {
                let (lo, hi) = plan.raw_bounds(*id).unwrap();
                vars[id.0] = rng.in_range(lo, hi);
                vars[id.0].to_string()
            })
            .collect();
        let _ = writeln!(script, "{}", row.join(" "));
        step_fixed(&plan, &mut vars).unwrap();
        want.push(
            outputs
                .iter()
                .map(|id| vars[id.0] as i64)
                .collect::<Vec<_>>(),
        );
    }
    let got: Vec<Vec<i64>> = run_lines(&exe, &script);
    assert_eq!(got, want);
}

/// A pin name that two signals would share is refused, whichever of them is a vector's
/// element; so is an element name halcompile would change (`v__0`).
#[test]
fn colliding_element_pins_are_refused() {
    let host = qloop::targets::by_name("host").unwrap();
    let spec = |decls: &str, body: &str| {
        format!(
            "controller t {{\n period 0.01 \"s\";\n input x: [0.0, 1.0];\n {decls}\n \
             output y;\n step {{ y = x + {body}; }}\n}}\n"
        )
    };
    for (src, want) in [
        (
            spec(
                "input P[2][2]: [0.0, 1.0];\n input p_1_0: [0.0, 1.0];",
                "P[1][0] + p_1_0",
            ),
            "input `p_1_0` and input `P[1][0]` would both be the HAL name `p_1_0`",
        ),
        (
            spec("input v_[2]: [0.0, 1.0];", "v_[1]"),
            "input `v_[0]`: halcompile would rename `v__0`",
        ),
    ] {
        let plan = qloop::compile_str(&src, &host).unwrap_or_else(|e| panic!("{e}\n{src}"));
        let msg = qloop::gen_linuxcnc(&plan).expect_err(&src).to_string();
        assert!(msg.contains(want), "expected `{want}` in: {msg}");
    }
}
