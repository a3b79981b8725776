//! The machinery of the tests of qloop's C outputs (`tests/c_vectors.rs`, `tests/c_tables.rs`,
//! and in part `tests/c_output.rs`, `tests/c_float.rs`, `tests/random_compile.rs`), for any
//! spec's plan:
//!
//! * the fixed-point C (`qloop::gen_c`) compiled with `-Werror` by a target's compiler
//!   ([`warning_free`]);
//! * a stdin-driven host driver of it, built with UBSan, run on [`Case`]s and compared bit for
//!   bit with qloop's plan interpreter ([`fixed_c_matches_interpreter`]);
//! * Frama-C Eva on it ([`eva`]);
//! * the float C (`qloop::emit::c_float`) against the real-arithmetic interpreter
//!   ([`float_c_matches_real`]);
//! * the LinuxCNC component built by `halcompile` ([`halcompile_builds`]) and its controller
//!   and glue against the interpreter ([`linuxcnc_matches_interpreter`]).
//!
//! The C files are named after the spec (`NAME.h`/`NAME.c`, `NAME_f.h`/`NAME_f.c`). A struct
//! field is written here from the spec's names ([`field`]; only a name C reserves is escaped
//! as the emitters do), not taken from the emitters, so that an emitter that stored an
//! element at another index fails the comparisons. Each function assumes its tool is there:
//! the caller asks [`crate::tool`] first.

use qloop::emit::c_float;
use qloop::emit::linuxcnc::MARKERS;
use qloop::interp::{step_fixed, step_real};
use qloop::ir::{SigId, SigKind};
use qloop::Plan;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::run;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The signals of one kind, in declaration order (a vector's elements row-major).
pub fn ids(plan: &Plan, k: SigKind) -> Vec<SigId> {
    plan.prog.ids_of(k).collect()
}

/// A fixed stream of test values: [`Rng`], or a test's own generator.
pub trait Stream {
    /// The next 64 bits.
    fn next_u64(&mut self) -> u64;

    /// Uniform in `[lo, hi]`, rounded to `f32` (so C and Rust see the same value).
    fn float_in(&mut self, lo: f64, hi: f64) -> f64 {
        let t = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        f64::from((lo + t * (hi - lo)) as f32)
    }
}

/// xorshift64: a fixed, dependency-free stream of test values.
pub struct Rng(pub u64);

impl Stream for Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

impl Rng {
    /// Uniform (nearly) in `[lo, hi]`.
    pub fn in_range(&mut self, lo: i128, hi: i128) -> i128 {
        lo + (self.next_u64() as i128).rem_euclid(hi - lo + 1)
    }
}

/// A signal as the struct field the API promises: `y`, or `phi[1]`, `P[1][0]` for an element
/// (the spec's indexing, row-major arrays), a name C reserves with the trailing underscore of
/// the fixed-point C (`qloop::emit::c::ident`).
pub fn field(plan: &Plan, id: SigId) -> String {
    field_as(plan, id, qloop::emit::c::ident)
}

/// [`field`] with the names made C identifiers by `ident` (`c_float::ident` for the float C,
/// whose reserved names are not the fixed-point C's).
pub fn field_as(plan: &Plan, id: SigId, ident: fn(&str) -> String) -> String {
    let s = plan.prog.sig(id);
    match &s.elem {
        None => ident(&s.name),
        Some(e) => e
            .index
            .iter()
            .fold(ident(&e.group), |p, i| format!("{p}[{i}]")),
    }
}

/// A raw input value: mostly inside the declared range, sometimes anywhere in the storage
/// type (step clamps it), sometimes at the edges.
pub fn raw_input(plan: &Plan, id: SigId, rng: &mut Rng) -> i128 {
    let q = plan.format(id);
    let (lo, hi) = plan.bounds(id);
    match rng.next_u64() % 16 {
        0 => q.ty.min(),
        1 => q.ty.max(),
        2 => lo,
        3 => hi,
        4 | 5 => rng.in_range(q.ty.min(), q.ty.max()),
        _ => rng.in_range(lo, hi),
    }
}

/// Runs `exe` with `script` on its stdin (written from another thread, so that neither pipe
/// fills up); its stdout. Panics if it cannot be started, if it fails (with its stderr) or if
/// it did not take all of the script.
pub fn run_stdin(exe: &Path, script: &str) -> String {
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
        stdin.write_all(script.as_bytes())
    });
    let o = child.wait_with_output().unwrap();
    let fed = feeder.join().unwrap();
    assert!(
        o.status.success(),
        "{} failed ({}):\n{}",
        exe.display(),
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    fed.unwrap_or_else(|e| panic!("writing the script to {}: {e}", exe.display()));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// [`run_stdin`]; its output lines as numbers.
pub fn run_lines<T: std::str::FromStr>(exe: &Path, script: &str) -> Vec<Vec<T>>
where
    T::Err: std::fmt::Debug,
{
    run_stdin(exe, script)
        .lines()
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// Writes `NAME.h`/`NAME.c` (`qloop::gen_c`) into `dir`; the `.c` path.
pub fn write_c(plan: &Plan, dir: &Path) -> PathBuf {
    let n = &plan.prog.name;
    let (h, c) = qloop::gen_c(plan);
    std::fs::write(dir.join(format!("{n}.h")), h).unwrap();
    let p = dir.join(format!("{n}.c"));
    std::fs::write(&p, c).unwrap();
    p
}

/// Compiles the plan's fixed-point C (written into `dir`) to an object with the plan's target
/// compiler `cc` and flags, `-std=c99 -pedantic -Wall -Wextra -Werror`, and `-Wconversion` on
/// the host; the object's path.
pub fn warning_free(plan: &Plan, cc: &Path, dir: &Path) -> PathBuf {
    let c = write_c(plan, dir);
    let mut flags = plan.target.toolchain.cflags.clone();
    if plan.target.name == "host" {
        flags.push("-Wconversion".into());
    }
    let obj = dir.join(format!("{}.o", plan.prog.name));
    run(Command::new(cc)
        .args(["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c"])
        .args(&flags)
        .arg(&c)
        .arg("-o")
        .arg(&obj));
    obj
}

/// A driver reading commands from stdin: `S v..` sets the raw states, `I v..` runs one step
/// on raw inputs and prints the raw outputs, then the raw states (scalars in declaration
/// order, a vector's elements row-major, through the struct's arrays).
pub fn fixed_driver(plan: &Plan) -> String {
    let n = &plan.prog.name;
    // The struct field's type (a vector's widest element's, where its elements differ).
    let ty = |id: &SigId| qloop::emit::c::c_ty(plan.storage_ty(*id));
    let mut d = format!(
        "#include \"{n}.h\"\n#include <stdio.h>\nint main(void) {{\n    {n}_state s;\n    \
         {n}_inputs in;\n    {n}_outputs out;\n    long long v;\n    char op;\n    \
         {n}_init(&s);\n    while (scanf(\" %c\", &op) == 1) {{\n        if (op == 'S') {{\n",
    );
    for id in ids(plan, SigKind::State) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            s.{} = ({})v;",
            field(plan, id),
            ty(&id)
        );
    }
    d.push_str("        } else {\n");
    for id in ids(plan, SigKind::Input) {
        let _ = writeln!(
            d,
            "            if (scanf(\"%lld\", &v) != 1) return 2;\n            in.{} = ({})v;",
            field(plan, id),
            ty(&id)
        );
    }
    let _ = writeln!(d, "            {n}_step(&s, &in, &out);");
    for (what, k) in [("out", SigKind::Output), ("s", SigKind::State)] {
        for id in ids(plan, k) {
            let f = field(plan, id);
            let _ = writeln!(d, "            printf(\"%lld \", (long long){what}.{f});");
        }
    }
    d.push_str("            printf(\"\\n\");\n        }\n    }\n    return 0;\n}\n");
    d
}

/// One step of a test: from the states so far (`None`: the previous step's, or `init`'s) or
/// from these raw states, on these raw inputs (both in declaration order).
#[derive(Clone, Debug)]
pub struct Case {
    pub states: Option<Vec<i128>>,
    pub inputs: Vec<i128>,
}

/// `along` steps along the trajectory from the initial state, then `apart` steps each from a
/// state of its own: the corners of the state bounds first (64 of them), then random states
/// inside the bounds; every input drawn by [`raw_input`].
pub fn trajectory_and_states(plan: &Plan, rng: &mut Rng, along: usize, apart: usize) -> Vec<Case> {
    let (states, inputs) = (ids(plan, SigKind::State), ids(plan, SigKind::Input));
    (0..along + apart)
        .map(|case| {
            let states = (case >= along).then(|| {
                let c = case - along;
                states
                    .iter()
                    .enumerate()
                    .map(|(k, id)| {
                        let (lo, hi) = plan.raw_bounds(*id).unwrap();
                        match c {
                            0..64 if (c >> (k % 6)) & 1 == 0 => lo,
                            0..64 => hi,
                            _ => rng.in_range(lo, hi),
                        }
                    })
                    .collect()
            });
            let inputs = inputs.iter().map(|id| raw_input(plan, *id, rng)).collect();
            Case { states, inputs }
        })
        .collect()
}

/// The plan interpreter's variables in the initial state: every state its raw initial value,
/// every other signal 0.
fn initial_vars(plan: &Plan) -> Vec<i128> {
    let mut vars = vec![0i128; plan.prog.signals.len()];
    for id in ids(plan, SigKind::State) {
        vars[id.0] = plan.raw_init(id);
    }
    vars
}

/// What qloop's plan interpreter computes for the cases from the initial state: per step, the
/// raw outputs, then the raw states.
pub fn interpreted(plan: &Plan, cases: &[Case]) -> Vec<Vec<i64>> {
    let (states, inputs, outputs) = (
        ids(plan, SigKind::State),
        ids(plan, SigKind::Input),
        ids(plan, SigKind::Output),
    );
    let mut vars = initial_vars(plan);
    cases
        .iter()
        .map(|case| {
            for (id, v) in states.iter().zip(case.states.iter().flatten()) {
                vars[id.0] = *v;
            }
            for (id, v) in inputs.iter().zip(&case.inputs) {
                vars[id.0] = *v;
            }
            step_fixed(plan, &mut vars)
                .unwrap_or_else(|e| panic!("{}: {case:?}: {e:?}", plan.target.name));
            outputs
                .iter()
                .chain(&states)
                .map(|id| i64::try_from(vars[id.0]).expect("a 64-bit value"))
                .collect()
        })
        .collect()
}

/// The plan's fixed-point C and [`fixed_driver`], written into `dir` and built for the host
/// with `cc` and UBSan (every sanitizer error fatal); the executable.
pub fn fixed_driver_exe(plan: &Plan, cc: &Path, dir: &Path) -> PathBuf {
    let c = write_c(plan, dir);
    std::fs::write(dir.join("driver.c"), fixed_driver(plan)).unwrap();
    let exe = dir.join("driver");
    run(Command::new(cc)
        .args(["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror"])
        .args(["-fsanitize=undefined", "-fno-sanitize-recover=all"])
        .arg(&c)
        .arg(dir.join("driver.c"))
        .arg("-o")
        .arg(&exe));
    exe
}

/// The plan's fixed-point C, built for the host with `cc` and UBSan (every sanitizer error
/// fatal) with [`fixed_driver`] in `dir`, run on the cases: every step's raw outputs and
/// states are the interpreter's. Returns the number of steps compared.
pub fn fixed_c_matches_interpreter(plan: &Plan, cc: &Path, dir: &Path, cases: &[Case]) -> usize {
    let mut script = String::new();
    for case in cases {
        if let Some(s) = &case.states {
            script.push('S');
            for v in s {
                let _ = write!(script, " {v}");
            }
            script.push('\n');
        }
        script.push('I');
        for v in &case.inputs {
            let _ = write!(script, " {v}");
        }
        script.push('\n');
    }
    let want = interpreted(plan, cases);
    let got: Vec<Vec<i64>> = run_lines(&fixed_driver_exe(plan, cc, dir), &script);
    let t = &plan.target.name;
    assert_eq!(got.len(), want.len(), "{t}: step count");
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w, "{t}: step {k} ({:?}): C vs interpreter", cases[k]);
    }
    want.len()
}

/// Frama-C Eva (`frama`) on the plan's fixed-point C, written into `dir`, from its
/// `NAME_eva_main` (every state in bounds, every raw input) with the machdep `machdep`: 0
/// alarms, no property unknown or invalid, a proved postcondition per state at least. Returns
/// Eva's output.
pub fn eva(plan: &Plan, frama: &Path, machdep: &str, dir: &Path) -> String {
    let c = write_c(plan, dir);
    eva_file(plan, frama, machdep, &c)
}

/// Frama-C Eva's output on a C file of the plan (its own, or altered), with the options of
/// [`eva`]; nothing checked.
pub fn eva_output(plan: &Plan, frama: &Path, machdep: &str, c: &Path) -> String {
    run(Command::new(frama)
        .args(["-machdep", machdep])
        .args(["-warn-signed-downcast", "-warn-unsigned-downcast"])
        // A table read compactly splits its index over its values, up to 257
        // (`qloop::emit::c`, `compact_pairs`); Eva's default limit is 100.
        .args(["-eva-split-limit", "257"])
        .args(["-eva", "-main", &format!("{}_eva_main", plan.prog.name)])
        .arg(c)
        .args(["-then", "-report"]))
}

/// [`eva`] on a given C file of the plan.
pub fn eva_file(plan: &Plan, frama: &Path, machdep: &str, c: &Path) -> String {
    let target = &plan.target.name;
    let out = eva_output(plan, frama, machdep, c);
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
    let n_states = ids(plan, SigKind::State).len();
    assert!(
        posts >= n_states,
        "{target}: {posts} postconditions proved, want ≥ {n_states}:\n{out}"
    );
    out
}

/// A driver for `NAME_f`: `S s..` sets the states, `X i..` steps and prints the outputs
/// then the states, `I` re-initialises and prints the states.
pub fn float_driver(plan: &Plan) -> String {
    let n = &plan.prog.name;
    let fields = |k: SigKind| -> Vec<String> {
        ids(plan, k)
            .iter()
            .map(|id| field_as(plan, *id, c_float::ident))
            .collect()
    };
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
        "#include <stdio.h>\n#include <stdlib.h>\n#include \"{n}_f.h\"\n\n\
         static float rd(void)\n{{\n    float v;\n    if (scanf(\"%f\", &v) != 1) exit(2);\n    return v;\n}}\n\n\
         int main(void)\n{{\n    {n}_f_state s;\n    {n}_f_inputs in;\n    {n}_f_outputs out;\n    char c;\n\
         \x20   {n}_f_init(&s);\n\
         \x20   while (scanf(\" %c\", &c) == 1) {{\n\
         \x20       if (c == 'I') {{\n            {n}_f_init(&s);\n{}            printf(\"\\n\");\n        }} else if (c == 'S') {{\n{}\
         \x20       }} else if (c == 'X') {{\n{}            {n}_f_step(&s, &in, &out);\n{}{}            printf(\"\\n\");\n\
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
pub fn draw(rng: &mut impl Stream, plan: &Plan, kind: SigKind) -> Vec<f64> {
    ids(plan, kind)
        .iter()
        .map(|id| {
            let (lo, hi) = plan.prog.sig(*id).range.expect("ranged");
            let m = if kind == SigKind::Input {
                0.1 * (hi - lo)
            } else {
                0.0
            };
            match rng.next_u64() % 16 {
                0 => f64::from(lo as f32),
                1 => f64::from(hi as f32),
                _ => rng.float_in(lo - m, hi + m),
            }
        })
        .collect()
}

/// What [`float_c_matches_real`] saw.
pub struct FloatRun {
    /// Steps compared.
    pub steps: usize,
    /// The largest |C float − real| per compared value (the outputs, then the states).
    pub worst: Vec<f64>,
    /// The paths `step_real` took (branch coverage).
    pub paths: BTreeSet<Vec<(usize, bool)>>,
}

/// The float C (`qloop::emit::c_float`, written into `dir` with [`float_driver`], built by
/// `cc` with `-Werror -Wdouble-promotion -O2`): its `init` is the spec's initial values (as
/// `float`), and `steps` steps from random `float` states and inputs ([`draw`]) are within
/// `tol[k]` of `step_real` from the same values, for the k-th of the outputs then the states.
pub fn float_c_matches_real(
    plan: &Plan,
    cc: &Path,
    dir: &Path,
    rng: &mut Rng,
    steps: usize,
    tol: &[f64],
) -> FloatRun {
    let prog = &plan.prog;
    let n = &prog.name;
    let (h, c) = c_float::source(prog);
    std::fs::write(dir.join(format!("{n}_f.h")), &h).unwrap();
    std::fs::write(dir.join(format!("{n}_f.c")), &c).unwrap();
    std::fs::write(dir.join("driver.c"), float_driver(plan)).unwrap();
    let exe = dir.join("driver");
    run(Command::new(cc)
        .args(["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"])
        .args(["-Wdouble-promotion", "-O2"])
        .arg(dir.join(format!("{n}_f.c")))
        .arg(dir.join("driver.c"))
        .arg("-o")
        .arg(&exe));

    let (states, inputs, outputs) = (
        ids(plan, SigKind::State),
        ids(plan, SigKind::Input),
        ids(plan, SigKind::Output),
    );
    let init: Vec<f64> = states
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

    let (mut script, mut want) = (String::new(), Vec::new());
    let mut paths = BTreeSet::new();
    for _ in 0..steps {
        let st = draw(rng, plan, SigKind::State);
        let inp = draw(rng, plan, SigKind::Input);
        let text = |v: &[f64]| {
            v.iter()
                .map(|x| format!(" {}", *x as f32))
                .collect::<String>()
        };
        let _ = writeln!(script, "S{}\nX{}", text(&st), text(&inp));
        let mut vars = vec![0.0; prog.signals.len()];
        for (id, v) in states.iter().zip(&st) {
            vars[id.0] = *v;
        }
        for (id, v) in inputs.iter().zip(&inp) {
            vars[id.0] = *v;
        }
        paths.insert(step_real(prog, &mut vars));
        want.push((
            inp,
            outputs
                .iter()
                .chain(&states)
                .map(|id| vars[id.0])
                .collect::<Vec<f64>>(),
        ));
    }
    let got = floats(&script);
    assert_eq!(got.len(), want.len());
    let names: Vec<String> = outputs
        .iter()
        .chain(&states)
        .map(|id| prog.sig(*id).label())
        .collect();
    assert_eq!(tol.len(), names.len(), "one tolerance per output and state");
    let mut worst = vec![0.0f64; names.len()];
    for (k, (g, (inp, w))) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.len(), w.len(), "case {k}");
        for (j, (g, w)) in g.iter().zip(w).enumerate() {
            let d = (g - w).abs();
            worst[j] = worst[j].max(d);
            assert!(
                d <= tol[j],
                "case {k} (inputs {inp:?}): `{}` is {g} in C float, {w} in real arithmetic",
                names[j]
            );
        }
    }
    FloatRun {
        steps: want.len(),
        worst,
        paths,
    }
}

/// The plan's `.comp` (`qloop gen --lang linuxcnc`).
pub fn component(plan: &Plan) -> String {
    qloop::gen_linuxcnc(plan).unwrap_or_else(|e| panic!("{e}"))
}

/// `halcompile --compile` (no install, no root) of the plan's component, written into `dir`.
pub fn halcompile_builds(plan: &Plan, halcompile: &Path, dir: &Path) {
    let file = dir.join(format!(
        "{}.comp",
        qloop::emit::linuxcnc::component_name(plan)
    ));
    std::fs::write(&file, component(plan)).unwrap();
    run(Command::new(halcompile)
        .arg("--compile")
        .arg(&file)
        .current_dir(dir));
}

/// The component's controller and glue (as `targets/linuxcnc/run.sh` extracts them), compiled
/// for the host by `cc` with `targets/linuxcnc/test/host_ref.c` and UBSan, run from the
/// initial state on `steps` random raw inputs inside the glue's saturation bounds: every
/// step's raw outputs are the interpreter's.
pub fn linuxcnc_matches_interpreter(
    plan: &Plan,
    cc: &Path,
    dir: &Path,
    rng: &mut Rng,
    steps: usize,
) {
    let comp = component(plan);
    let begin = comp.find(MARKERS[0]).expect("controller marker");
    let end = comp.find(MARKERS[3]).expect("glue end marker") + MARKERS[3].len();
    let inc = dir.join("controller.inc");
    std::fs::write(&inc, format!("{}\n", &comp[begin..end])).unwrap();
    let exe = dir.join("host_ref");
    run(Command::new(cc)
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
    let (inputs, outputs) = (ids(plan, SigKind::Input), ids(plan, SigKind::Output));
    let mut vars = initial_vars(plan);
    let (mut script, mut want) = (String::new(), Vec::new());
    for _ in 0..steps {
        let row: Vec<String> = inputs
            .iter()
            .map(|id| {
                let (lo, hi) = plan.raw_bounds(*id).unwrap();
                vars[id.0] = rng.in_range(lo, hi);
                vars[id.0].to_string()
            })
            .collect();
        let _ = writeln!(script, "{}", row.join(" "));
        step_fixed(plan, &mut vars).unwrap();
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
