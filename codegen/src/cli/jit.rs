//! Compiles a spec's generated Rust (the fixed-point module and the f64 reference) into a
//! shared library with cargo, loads it, and wraps both as closed-loop controllers.
//!
//! `qloop sim` must run *the real compiled routine*, not an interpretation of it, for any
//! spec. So the exact text `qloop gen --lang rust` prints is compiled by rustc (release
//! profile) together with a thin C-ABI shim over the module's array entry points
//! (`Controller::step_bits`, `state_bits`; `Reference::step_values`, `state_values`) and its
//! signal tables. The crate lives under the cache directory, keyed by a hash of its text;
//! every spec shares one target directory, so the `fixed` crate compiles once.

use super::error::{CliError, CliResult};
use super::files::{create_dir, write_atomic};
use libloading::Library;
use qloop::Plan;
use qloop_plant::{Controller, Signals};
use std::ffi::c_void;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

/// Version of the shim's C ABI; bump when the exported functions change.
const ABI: u32 = 1;

/// The version of the `fixed` crate the generated code is compiled against (the workspace's).
const FIXED_VERSION: &str = "1.31";

type NewFn = unsafe extern "C" fn() -> *mut c_void;
type FreeFn = unsafe extern "C" fn(*mut c_void);
type StepBitsFn = unsafe extern "C" fn(*mut c_void, *const i64, *mut i64);
type StateBitsFn = unsafe extern "C" fn(*const c_void, *mut i64);
type StepValuesFn = unsafe extern "C" fn(*mut c_void, *const f64, *mut f64);
type StateValuesFn = unsafe extern "C" fn(*const c_void, *mut f64);
type SignalFn = unsafe extern "C" fn(u32, usize, u32, *mut usize) -> *const u8;
type FracFn = unsafe extern "C" fn(u32, usize) -> i32;
type ShapeFn = unsafe extern "C" fn(*mut usize);
type AbiFn = unsafe extern "C" fn() -> u32;
type PeriodFn = unsafe extern "C" fn() -> u64;

/// A loaded, compiled spec: makes fixed-point and reference controller instances.
pub struct Compiled {
    lib: Arc<Library>,
    signals: Signals,
    frac: [Vec<i32>; 3],
    period: f64,
    fixed: (NewFn, FreeFn, StepBitsFn, StateBitsFn),
    reference: (NewFn, FreeFn, StepValuesFn, StateValuesFn),
}

/// The shim compiled next to the generated modules.
fn shim(m: &str) -> String {
    format!(
        r#"
// qloop sim: C-ABI shim over the generated modules (not part of the generated firmware).
use core::ffi::c_void;
use {m} as fx;
use {m}_ref as rf;

#[no_mangle]
pub extern "C" fn qloop_abi() -> u32 {{ {ABI} }}

#[no_mangle]
pub extern "C" fn qloop_period_us() -> u64 {{ fx::Controller::PERIOD_US }}

#[no_mangle]
pub unsafe extern "C" fn qloop_shape(out: *mut usize) {{
    *out = fx::INPUTS.len();
    *out.add(1) = fx::STATES.len();
    *out.add(2) = fx::OUTPUTS.len();
}}

/// kind 0/1/2 = input/state/output; unit 0 = name, 1 = unit.
#[no_mangle]
pub unsafe extern "C" fn qloop_signal(kind: u32, i: usize, unit: u32, len: *mut usize) -> *const u8 {{
    let t: &[&str] = match (kind, unit) {{
        (0, 0) => &fx::INPUTS, (0, _) => &fx::INPUT_UNITS,
        (1, 0) => &fx::STATES, (1, _) => &fx::STATE_UNITS,
        (_, 0) => &fx::OUTPUTS, (_, _) => &fx::OUTPUT_UNITS,
    }};
    match t.get(i) {{
        Some(s) => {{ *len = s.len(); s.as_ptr() }}
        None => core::ptr::null(),
    }}
}}

#[no_mangle]
pub extern "C" fn qloop_frac(kind: u32, i: usize) -> i32 {{
    let t: &[i32] = match kind {{ 0 => &fx::INPUT_FRAC, 1 => &fx::STATE_FRAC, _ => &fx::OUTPUT_FRAC }};
    t.get(i).copied().unwrap_or(0)
}}

#[no_mangle]
pub extern "C" fn qloop_fixed_new() -> *mut c_void {{
    Box::into_raw(Box::new(fx::Controller::new())).cast()
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_fixed_free(p: *mut c_void) {{
    drop(Box::from_raw(p.cast::<fx::Controller>()));
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_fixed_step(p: *mut c_void, x: *const i64, y: *mut i64) {{
    let c = &mut *p.cast::<fx::Controller>();
    let mut i = [0i64; fx::INPUTS.len()];
    i.copy_from_slice(core::slice::from_raw_parts(x, fx::INPUTS.len()));
    let o = c.step_bits(i);
    core::slice::from_raw_parts_mut(y, fx::OUTPUTS.len()).copy_from_slice(&o);
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_fixed_states(p: *const c_void, s: *mut i64) {{
    let c = &*p.cast::<fx::Controller>();
    core::slice::from_raw_parts_mut(s, fx::STATES.len()).copy_from_slice(&c.state_bits());
}}

#[no_mangle]
pub extern "C" fn qloop_ref_new() -> *mut c_void {{
    Box::into_raw(Box::new(rf::Reference::new())).cast()
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_ref_free(p: *mut c_void) {{
    drop(Box::from_raw(p.cast::<rf::Reference>()));
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_ref_step(p: *mut c_void, x: *const f64, y: *mut f64) {{
    let c = &mut *p.cast::<rf::Reference>();
    let mut i = [0f64; rf::INPUTS.len()];
    i.copy_from_slice(core::slice::from_raw_parts(x, rf::INPUTS.len()));
    let o = c.step_values(i);
    core::slice::from_raw_parts_mut(y, rf::OUTPUTS.len()).copy_from_slice(&o);
}}
#[no_mangle]
pub unsafe extern "C" fn qloop_ref_states(p: *const c_void, s: *mut f64) {{
    let c = &*p.cast::<rf::Reference>();
    core::slice::from_raw_parts_mut(s, rf::STATES.len()).copy_from_slice(&c.state_values());
}}
"#
    )
}

/// The first 16 hex digits of the SHA-256 of `text`: names the crate after its source.
fn key(text: &str) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(text.as_bytes())
        .iter()
        .take(8)
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The cache directory for compiled specs.
fn cache_dir() -> PathBuf {
    std::env::var_os("QLOOP_CACHE")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/qloop")))
        .unwrap_or_else(|| std::env::temp_dir().join("qloop-cache"))
        .join("sim")
}

/// Writes `text` to `path` unless it already holds exactly that (keeps cargo's freshness).
fn write_if_changed(path: &Path, text: &str) -> CliResult {
    if std::fs::read_to_string(path).ok().as_deref() == Some(text) {
        return Ok(());
    }
    write_atomic(path, text)
}

/// Generates, compiles (cargo, release) and loads `plan`'s fixed-point module and reference.
pub fn compile(plan: &Plan) -> CliResult<Compiled> {
    let m = plan.prog.name.clone();
    let src = format!(
        "{}\n{}\n{}",
        qloop::gen_rust(plan),
        qloop::gen_reference(plan),
        shim(&m)
    );
    let key = key(&src);
    let krate = format!("qloop_sim_{m}_{key}");
    let root = cache_dir();
    let dir = root.join(&krate);
    let target = root.join("target");
    create_dir(&dir).map_err(|e| {
        e.with_note(
            "compiled controllers are cached there; set $QLOOP_CACHE to a writable directory",
        )
    })?;
    let manifest = format!(
        "# Generated by `qloop sim`: the spec's generated code, compiled for the closed-loop runner.\n\
         [package]\nname = \"{krate}\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n\
         [lib]\npath = \"lib.rs\"\ncrate-type = [\"cdylib\"]\n\n\
         [dependencies]\nfixed = \"{FIXED_VERSION}\"\n\n\
         [profile.release]\nopt-level = 3\ndebug = false\n\n\
         [workspace]\n"
    );
    write_if_changed(&dir.join("Cargo.toml"), &manifest)?;
    write_if_changed(&dir.join("lib.rs"), &src)?;
    let lib_path = target.join("release").join(format!(
        "{}{krate}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    ));
    build(&dir, &target)?;
    load(&lib_path)
}

/// `cargo build --release`, offline first (the `fixed` crate is normally in the local
/// registry already), then online.
fn build(dir: &Path, target: &Path) -> CliResult {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let run = |offline: bool| {
        let mut c = Command::new(&cargo);
        c.arg("build")
            .arg("--release")
            .arg("--quiet")
            .arg("--manifest-path")
            .arg(dir.join("Cargo.toml"))
            .arg("--target-dir")
            .arg(target);
        if offline {
            c.arg("--offline");
        }
        // The workspace's own RUSTFLAGS (e.g. -D warnings in CI) are not the shim's concern.
        c.env_remove("RUSTFLAGS").env_remove("CARGO_TARGET_DIR");
        c.output()
    };
    let out = match run(true) {
        Ok(o) if o.status.success() => return Ok(()),
        Ok(_) => run(false),
        Err(e) => {
            return Err(CliError::tool(format!(
                "`qloop sim` compiles the generated controller with cargo, which did not start ({e}); install Rust with rustup or set $CARGO"
            )));
        }
    };
    match out {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(CliError::tool(format!(
            "compiling the generated controller failed (crate in `{}`):\n{}",
            dir.display(),
            String::from_utf8_lossy(&o.stderr)
        ))),
        Err(e) => Err(CliError::tool(format!("cannot run cargo: {e}"))),
    }
}

/// Looks up `name` in `lib` (a function of type `T`).
fn sym<T: Copy>(lib: &Library, name: &str) -> CliResult<T> {
    // SAFETY: the shim above defines every looked-up name with exactly the type `T` used for
    // it here, and the ABI version is checked first.
    unsafe { lib.get::<T>(name.as_bytes()).map(|s| *s) }
        .map_err(|e| CliError::tool(format!("the compiled controller lacks `{name}`: {e}")))
}

fn load(path: &Path) -> CliResult<Compiled> {
    // SAFETY: the library is the one just built from the shim above; loading runs no
    // initialisers of ours beyond Rust's own.
    let lib = unsafe { Library::new(path) }
        .map_err(|e| CliError::tool(format!("cannot load `{}`: {e}", path.display())))?;
    let abi: AbiFn = sym(&lib, "qloop_abi")?;
    // SAFETY: `qloop_abi` takes nothing and returns a u32.
    if unsafe { abi() } != ABI {
        return Err(CliError::tool(format!(
            "`{}` was built by another qloop version; remove it and retry",
            path.display()
        )));
    }
    let period_us: PeriodFn = sym(&lib, "qloop_period_us")?;
    // SAFETY: takes nothing, returns a u64.
    let period = qloop_plant::controller::period_s(unsafe { period_us() });
    let shape: ShapeFn = sym(&lib, "qloop_shape")?;
    let signal: SignalFn = sym(&lib, "qloop_signal")?;
    let frac: FracFn = sym(&lib, "qloop_frac")?;
    let mut n = [0usize; 3];
    // SAFETY: writes three usizes.
    unsafe { shape(n.as_mut_ptr()) };
    let text = |kind: u32, i: usize, unit: u32| -> &'static str {
        let mut len = 0usize;
        // SAFETY: returns a pointer to a `'static str` of the library and its length, or null.
        let p = unsafe { signal(kind, i, unit, &mut len) };
        if p.is_null() {
            return "";
        }
        // SAFETY: `p..p+len` is a valid UTF-8 `&'static str` inside the loaded library; the
        // copy is leaked so the names outlive it (a handful of short strings per process).
        let s = unsafe { std::str::from_utf8_unchecked(std::slice::from_raw_parts(p, len)) };
        Box::leak(s.to_string().into_boxed_str())
    };
    let table = |kind: u32| -> Vec<(&'static str, &'static str)> {
        (0..n[kind as usize])
            .map(|i| (text(kind, i, 0), text(kind, i, 1)))
            .collect()
    };
    let signals = Signals {
        inputs: table(0),
        states: table(1),
        outputs: table(2),
    };
    let fracs = |kind: u32| -> Vec<i32> {
        // SAFETY: a pure lookup.
        (0..n[kind as usize])
            .map(|i| unsafe { frac(kind, i) })
            .collect()
    };
    let frac = [fracs(0), fracs(1), fracs(2)];
    Ok(Compiled {
        fixed: (
            sym(&lib, "qloop_fixed_new")?,
            sym(&lib, "qloop_fixed_free")?,
            sym(&lib, "qloop_fixed_step")?,
            sym(&lib, "qloop_fixed_states")?,
        ),
        reference: (
            sym(&lib, "qloop_ref_new")?,
            sym(&lib, "qloop_ref_free")?,
            sym(&lib, "qloop_ref_step")?,
            sym(&lib, "qloop_ref_states")?,
        ),
        lib: Arc::new(lib),
        signals,
        frac,
        period,
    })
}

impl Compiled {
    /// The controller's signal tables.
    pub fn signals(&self) -> &Signals {
        &self.signals
    }

    /// A new instance of the compiled fixed-point controller, in its initial state.
    pub fn fixed(&self) -> Box<dyn Controller + Send> {
        // SAFETY: `new` returns a fresh boxed controller, freed by `Drop`.
        let obj = unsafe { (self.fixed.0)() };
        Box::new(FixedInstance {
            _lib: self.lib.clone(),
            obj,
            f: self.fixed,
            signals: self.signals.clone(),
            frac: self.frac.clone(),
            period: self.period,
            raw_in: vec![0; self.signals.inputs.len()],
            raw_out: vec![0; self.signals.outputs.len()],
            raw_st: std::cell::RefCell::new(vec![0; self.signals.states.len()]),
        })
    }

    /// A new instance of the compiled f64 reference controller.
    pub fn reference(&self) -> Box<dyn Controller + Send> {
        // SAFETY: as in `fixed`.
        let obj = unsafe { (self.reference.0)() };
        Box::new(ReferenceInstance {
            _lib: self.lib.clone(),
            obj,
            f: self.reference,
            signals: self.signals.clone(),
            period: self.period,
        })
    }
}

/// One compiled fixed-point controller instance.
struct FixedInstance {
    _lib: Arc<Library>,
    obj: *mut c_void,
    f: (NewFn, FreeFn, StepBitsFn, StateBitsFn),
    signals: Signals,
    frac: [Vec<i32>; 3],
    period: f64,
    raw_in: Vec<i64>,
    raw_out: Vec<i64>,
    raw_st: std::cell::RefCell<Vec<i64>>,
}

// SAFETY: the instance owns its boxed controller (plain integers) exclusively; the library is
// kept loaded by the `Arc`.
unsafe impl Send for FixedInstance {}

impl Controller for FixedInstance {
    fn signals(&self) -> Signals {
        self.signals.clone()
    }
    fn period(&self) -> f64 {
        self.period
    }
    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        for ((r, v), f) in self.raw_in.iter_mut().zip(inputs).zip(&self.frac[0]) {
            *r = qloop_plant::controller::to_bits(*v, *f);
        }
        // SAFETY: the buffers hold exactly the module's input and output counts.
        unsafe { (self.f.2)(self.obj, self.raw_in.as_ptr(), self.raw_out.as_mut_ptr()) };
        for ((y, r), f) in outputs.iter_mut().zip(&self.raw_out).zip(&self.frac[2]) {
            *y = qloop_plant::controller::from_bits(*r, *f);
        }
    }
    fn states(&self, out: &mut [f64]) {
        let mut raw = self.raw_st.borrow_mut();
        // SAFETY: the buffer holds exactly the module's state count.
        unsafe { (self.f.3)(self.obj, raw.as_mut_ptr()) };
        for ((y, r), f) in out.iter_mut().zip(raw.iter()).zip(&self.frac[1]) {
            *y = qloop_plant::controller::from_bits(*r, *f);
        }
    }
}

impl Drop for FixedInstance {
    fn drop(&mut self) {
        // SAFETY: `obj` came from this library's `new` and is freed once.
        unsafe { (self.f.1)(self.obj) }
    }
}

/// One compiled f64 reference controller instance.
struct ReferenceInstance {
    _lib: Arc<Library>,
    obj: *mut c_void,
    f: (NewFn, FreeFn, StepValuesFn, StateValuesFn),
    signals: Signals,
    period: f64,
}

// SAFETY: as for `FixedInstance`.
unsafe impl Send for ReferenceInstance {}

impl Controller for ReferenceInstance {
    fn signals(&self) -> Signals {
        self.signals.clone()
    }
    fn period(&self) -> f64 {
        self.period
    }
    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        // The runner sizes both slices from the same signal tables; anything else is a bug in
        // qloop, and must not reach the foreign call.
        assert!(
            inputs.len() == self.signals.inputs.len()
                && outputs.len() == self.signals.outputs.len()
        );
        // SAFETY: the slices hold exactly the module's input and output counts (checked).
        unsafe { (self.f.2)(self.obj, inputs.as_ptr(), outputs.as_mut_ptr()) };
    }
    fn states(&self, out: &mut [f64]) {
        assert!(out.len() == self.signals.states.len());
        // SAFETY: `out` holds the module's state count.
        unsafe { (self.f.3)(self.obj, out.as_mut_ptr()) };
    }
}

impl Drop for ReferenceInstance {
    fn drop(&mut self) {
        // SAFETY: `obj` came from this library's `new` and is freed once.
        unsafe { (self.f.1)(self.obj) }
    }
}
