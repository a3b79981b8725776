//! Lowering: real-valued IR → fixed-point plan.
//!
//! The rules (see the book's "Fixed-point semantics", docs/book/src/reference/semantics.md):
//! * Inputs, states and outputs get a storage [`QFormat`] from their declared range (and
//!   `#[lsb]` request or `#[q]` pin); unranged outputs from the range analysis.
//! * Every intermediate is exact where it can be: `a ± b` aligns binary points by left
//!   shifts, `a · b` uses a widening multiply whose result has `fa + fb` fraction bits. The
//!   working type is the narrowest signed type (at least the target's native word) that holds
//!   the proved raw interval, so nothing overflows. Only when an exact intermediate would need
//!   more than 64 bits are fraction bits dropped, with explicit rounding.
//! * Multiplication by a constant is a shift-add network ([`shift_add`]) unless the target's
//!   multiplier is cheaper; a power of two costs nothing beyond moving the binary point.
//! * Rounding happens only where fraction bits are dropped: on stores to states and outputs,
//!   at pinned `let`s and where an intermediate would exceed 64 bits. Floor is one arithmetic
//!   shift; nearest adds half an LSB first.
//! * Stores saturate to the declared range (quantised inward); clamps the analysis proves
//!   unnecessary are not emitted. Inputs are clamped to their declared range on entry.

pub mod budget;
mod compare;
mod const_mul;
pub mod cost;
pub use const_mul::CONST_REL;
pub mod dce;
mod err_bound;
pub mod lir;
pub mod newton;
mod rounding;
pub mod shift_add;
pub mod table;
pub mod target;

use crate::diag::{Diag, Result};
use crate::ir::*;
use crate::qformat::{pow2, IntTy, QFormat, WIDTHS};
use compare::{const_side, floor_ceil_scaled};
use lir::*;
use proc_macro2::Span;
use std::collections::HashMap;
use target::Target;

/// A compiled controller: the program, its formats and the integer plan.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The checked program.
    pub prog: Program,
    /// The target the cost model used.
    pub target: Target,
    /// All values.
    pub vals: Vec<Val>,
    /// The step body.
    pub body: Vec<LStmt>,
    /// What the analysis found for each signal (indexed by [`SigId`]).
    pub summary: Vec<SigSummary>,
    /// One line per constant multiplication: how it was lowered.
    pub mults: Vec<MulNote>,
    /// The integer arrays of the step's table look-ups.
    pub tables: Vec<table::LTable>,
    /// The formats searched against the spec's `#[error]` budgets, if it has any.
    pub tuning: Option<budget::Tuning>,
}

/// What the plan fixes for one signal: every consumer (emitters, prover, interpreter,
/// reports) reads these instead of deriving them again.
#[derive(Clone, Debug)]
pub struct SigSummary {
    /// Physical range of the value (declared, or proved for locals and unranged outputs).
    pub range: (f64, f64),
    /// Its format (storage format, or the working format of a `let`).
    pub format: QFormat,
    /// The raw values it holds: an input after its entry clamp and a state or ranged output
    /// after its saturation, the declared range quantised inward (`⌈lo·2^f⌉`, `⌊hi·2^f⌋`); an
    /// unranged output its whole type; a `let` its proved interval.
    pub bounds: (i128, i128),
    /// A state's raw initial value: the declared one rounded to nearest, inside `bounds`.
    pub init: Option<i128>,
    /// Worst-case error of one step against real arithmetic (for an input: the gap its entry
    /// clamp leaves at a range bound that is off the grid, else 0).
    pub err: f64,
}

/// How one constant multiplication was lowered.
#[derive(Clone, Debug)]
pub struct MulNote {
    /// The constant as written (folded).
    pub constant: f64,
    /// Its name, if it is a `param`/`const`.
    pub name: Option<String>,
    /// Quantised as `m · 2^-k`.
    pub m: i128,
    /// Exponent.
    pub k: i32,
    /// Adders used (0 for a power of two).
    pub adders: usize,
    /// Shifts used.
    pub shifts: usize,
    /// Whether the hardware multiplier was used instead.
    pub hw_mul: bool,
    /// Cost of shift-add and of the multiplier in the target's model.
    pub costs: (u32, u32),
    /// Where the product is rounded by `n` bits into a 32-bit word although it needs a wider
    /// one: `(q, c, n)` with `m = q·2^n + c`, computed as `q·x + round(c·x / 2^n)` in 32 bits
    /// (exact; `lower::const_mul`).
    pub split: Option<(i128, i128, u32)>,
}

impl Plan {
    /// The value `id`.
    pub fn val(&self, id: ValId) -> &Val {
        &self.vals[id.0]
    }

    /// The step's products of two non-constant values, in the order the step defines them.
    /// The Rust emitter computes each in its own always-inlined function, so that proof
    /// harnesses can replace the product by an abstraction (`kani::stub`) while the object
    /// code stays the plain multiply.
    pub fn var_products(&self) -> Vec<ValId> {
        fn walk(plan: &Plan, stmts: &[LStmt], out: &mut Vec<ValId>) {
            for s in stmts {
                match s {
                    LStmt::Def(id) => {
                        if plan.is_var_product(*id) && !out.contains(id) {
                            out.push(*id);
                        }
                    }
                    LStmt::Store(..) => {}
                    LStmt::If(_, t, e) => {
                        walk(plan, t, out);
                        walk(plan, e, out);
                    }
                }
            }
        }
        let mut out = Vec::new();
        walk(self, &self.body, &mut out);
        out
    }

    /// Whether value `id` is a product of two non-constant values ([`Plan::var_products`]).
    pub fn is_var_product(&self, id: ValId) -> bool {
        let var = |x: ValId| !matches!(self.val(x).op, Op::Const(_));
        matches!(self.val(id).op, Op::Mul(a, b) if var(a) && var(b))
    }

    /// The format of a signal: its storage format, or a `let`'s working format.
    pub fn format(&self, id: SigId) -> QFormat {
        self.summary[id.0].format
    }

    /// The raw values a signal holds ([`SigSummary::bounds`]).
    pub fn bounds(&self, id: SigId) -> (i128, i128) {
        self.summary[id.0].bounds
    }

    /// The raw saturation (or entry clamp) interval of a signal with a declared range.
    pub fn raw_bounds(&self, id: SigId) -> Option<(i128, i128)> {
        self.prog.sig(id).range.map(|_| self.bounds(id))
    }

    /// A state's raw initial value (0 for other signals).
    pub fn raw_init(&self, id: SigId) -> i128 {
        self.summary[id.0].init.unwrap_or(0)
    }

    /// The elements of the vector or matrix that `id` belongs to, row-major (`[id]` for a
    /// scalar).
    pub fn group_of(&self, id: SigId) -> Vec<SigId> {
        let s = self.prog.sig(id);
        let Some(e) = &s.elem else {
            return vec![id];
        };
        self.prog
            .ids_of(s.kind)
            .filter(|o| {
                self.prog
                    .sig(*o)
                    .elem
                    .as_ref()
                    .is_some_and(|f| f.group == e.group)
            })
            .collect()
    }

    /// The integer type signal `id` is stored in in the generated structs: its own, or its
    /// vector's ([`Plan::group_storage`]).
    pub fn storage_ty(&self, id: SigId) -> IntTy {
        self.group_storage(&self.group_of(id))
    }

    /// The format that carries signal `id` across the Rust API: its own, or its vector's
    /// ([`Plan::group_api_format`]) where the vector's elements differ in format.
    pub fn api_format(&self, id: SigId) -> QFormat {
        self.group_api_format(&self.group_of(id))
            .expect("lowering refuses a vector whose elements no API format carries")
    }

    /// Whether the elements `ids` of a vector share one format.
    pub fn shares_format(&self, ids: &[SigId]) -> bool {
        ids.iter().all(|id| self.format(*id) == self.format(ids[0]))
    }

    /// The integer type of a vector's or matrix's elements `ids` in the generated structs:
    /// the narrowest that holds every element's type (their own type where they share one).
    /// Each element keeps its own format in it: the raw value `v · 2^f` of its own `f`.
    pub fn group_storage(&self, ids: &[SigId]) -> IntTy {
        let mut t = self.format(ids[0]).ty;
        for id in ids {
            t = t.join(self.format(*id).ty);
        }
        t
    }

    /// The `fixed` format that carries every element of the vector or matrix `ids` across the
    /// Rust API exactly: its elements' format where they share one; else the most fraction
    /// bits of any element and the narrowest type holding each element's raw bounds at that
    /// binary point (`None` when no 64-bit type does).
    pub fn group_api_format(&self, ids: &[SigId]) -> Option<QFormat> {
        if self.shares_format(ids) {
            return Some(self.format(ids[0]));
        }
        let frac = ids.iter().map(|id| self.format(*id).frac).max()?;
        let signed = ids.iter().any(|id| self.format(*id).ty.signed);
        let (mut lo, mut hi) = (0i128, 0i128);
        for id in ids {
            let q = self.format(*id);
            if q.frac < 0 {
                return None;
            }
            let d = u32::try_from(frac - q.frac).ok()?;
            let (a, b) = self.bounds(*id);
            lo = lo.min(a.checked_mul(1i128.checked_shl(d)?)?);
            hi = hi.max(b.checked_mul(1i128.checked_shl(d)?)?);
        }
        WIDTHS
            .iter()
            .map(|&b| IntTy { signed, bits: b })
            .map(|ty| QFormat { ty, frac })
            .find(|q| q.ty.holds(lo, hi) && q.fits_fixed_crate())
    }

    /// The storage formats of the inputs, states and outputs.
    pub fn storage_formats(&self) -> impl Iterator<Item = QFormat> + '_ {
        self.prog
            .signals
            .iter()
            .zip(&self.summary)
            .filter(|(s, _)| s.kind != SigKind::Local)
            .map(|(_, sm)| sm.format)
    }
}

/// The raw values a declared signal of format `q` holds at a step boundary: its declared range
/// quantised inward, within the type; an unranged output, the whole type.
fn storage_bounds(sig: &Signal, q: QFormat) -> (i128, i128) {
    match sig.range {
        Some((lo, hi)) => (
            q.raw_ceil(lo).max(q.ty.min()),
            q.raw_floor(hi).min(q.ty.max()),
        ),
        None => (q.ty.min(), q.ty.max()),
    }
}

/// Lowers a checked program for a target.
pub fn lower(prog: &Program, target: &Target) -> Result<Plan> {
    if prog.signals.iter().any(|s| s.budget.is_some()) {
        return budget::tune(prog, target);
    }
    lower_formats(prog, target)
}

/// Lowers `prog` with the formats its declarations give (ranges, the default word, pins):
/// each element of a vector or matrix its own, from its own range, except where one format
/// for all of a vector's elements is cheaper on the target.
///
/// Elements of different binary points cost alignment shifts wherever they meet (a dot
/// product's terms, a sum of two of them), which a vector in one format (the hull of its
/// elements' ranges) does not pay, at some precision. So each vector whose elements' formats
/// differ is tried in one format, in declaration order, and kept so where the cost model's
/// estimate ([`cost::estimate`]: cycles, then size) falls.
fn lower_formats(prog: &Program, target: &Target) -> Result<Plan> {
    let mut hulled = std::collections::BTreeSet::new();
    let mut plan = lower_elementwise(prog, target, &hulled)?;
    let mixed: Vec<String> = mixed_groups(&plan);
    if !mixed.is_empty() {
        let mut best = cost::estimate(&plan);
        for g in mixed {
            let mut h = hulled.clone();
            h.insert(g);
            let Ok(p) = lower_elementwise(prog, target, &h) else {
                continue;
            };
            let c = cost::estimate(&p);
            if c < best {
                (best, plan, hulled) = (c, p, h);
            }
        }
    }
    api_formats(&plan)?;
    Ok(plan)
}

/// The declared vectors and matrices of `plan` whose elements' formats differ, in declaration
/// order, but those with an element pinned or given an LSB.
fn mixed_groups(plan: &Plan) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for (i, s) in plan.prog.signals.iter().enumerate() {
        let Some(e) = &s.elem else { continue };
        if s.kind == SigKind::Local || out.contains(&e.group) {
            continue;
        }
        let ids = plan.group_of(SigId(i));
        // Elements pinned or with an LSB request keep what they asked for.
        let pinned = ids.iter().any(|id| {
            let s = plan.prog.sig(*id);
            s.pin.is_some() || s.lsb.is_some()
        });
        if !pinned && !plan.shares_format(&ids) {
            out.push(e.group.clone());
        }
    }
    out
}

/// Refuses a plan whose vectors' elements have formats that no one `fixed` type carries
/// across the Rust API ([`Plan::group_api_format`]), or no one integer type of at most 64
/// bits stores ([`Plan::group_storage`]).
fn api_formats(plan: &Plan) -> Result<()> {
    for kind in [SigKind::Input, SigKind::State, SigKind::Output] {
        let mut groups: std::collections::BTreeMap<&str, Vec<SigId>> = Default::default();
        for id in plan.prog.ids_of(kind) {
            if let Some(e) = &plan.prog.sig(id).elem {
                groups.entry(&e.group).or_default().push(id);
            }
        }
        for (name, ids) in groups {
            if plan.group_api_format(&ids).is_some() && plan.group_storage(&ids).bits <= 64 {
                continue;
            }
            let (lo, hi) = ids.iter().map(|id| plan.format(*id)).fold(
                (plan.format(ids[0]), plan.format(ids[0])),
                |(a, b), q| {
                    (
                        if q.frac < a.frac { q } else { a },
                        if q.frac > b.frac { q } else { b },
                    )
                },
            );
            return Err(Diag::new(
                plan.prog.sig(ids[0]).span,
                format!(
                    "the elements of `{name}` take formats from {lo} to {hi}, and no `fixed` \
                     type of at most 64 bits carries all of them across the Rust API, or no \
                     integer type of at most 64 bits holds them in the structs"
                ),
            )
            .help("pin one format for the whole vector (`#[q(i32, F)]`), or narrow its ranges"));
        }
    }
    Ok(())
}

/// Lowers `prog` with each declared signal's own format, but one format for all the
/// elements of each vector in `hulled` (the hull of their ranges).
fn lower_elementwise(
    prog: &Program,
    target: &Target,
    hulled: &std::collections::BTreeSet<String>,
) -> Result<Plan> {
    let mut formats = vec![None; prog.signals.len()];
    for (i, s) in prog.signals.iter().enumerate() {
        if s.kind != SigKind::Local && (s.range.is_some() || s.pin.is_some()) {
            formats[i] = Some(choose_format(s, prog.word)?);
        }
    }
    hull_groups(prog, hulled, &mut formats)?;
    let unranged: Vec<SigId> = prog
        .ids_of(SigKind::Output)
        .filter(|id| formats[id.0].is_none())
        .collect();
    if unranged.is_empty() {
        let done = Lowerer::new(prog, target, formats.clone()).run()?;
        return Ok(done.finish(formats));
    }
    // First pass: learn the value range each unranged output receives. The format chosen
    // from it changes the binary points upstream (constants take their context's), so the
    // next pass computes slightly different values: repeat until every unranged output's
    // format holds everything it receives, so that its saturation never acts.
    let mut ranges: HashMap<SigId, (f64, f64)> = Lowerer::new(prog, target, formats.clone())
        .run()?
        .seen
        .into_iter()
        .filter(|(id, _)| unranged.contains(id))
        .collect();
    let mut unstable = unranged[0];
    for _ in 0..UNRANGED_PASSES {
        for &id in &unranged {
            let (lo, hi) = ranges[&id];
            let s = prog.sig(id);
            let q = QFormat::best_for(IntTy::signed(prog.word), lo, hi).ok_or_else(|| {
                Diag::new(
                    s.span,
                    format!(
                        "output `{}` spans [{lo:e}, {hi:e}], too wide for {}-bit words",
                        s.name, prog.word
                    ),
                )
                .help("declare its range (`output y: [LO, HI];`) so it saturates, or pin a format")
            })?;
            formats[id.0] = Some(q);
        }
        let done = Lowerer::new(prog, target, formats.clone()).run()?;
        let mut stable = true;
        for &id in &unranged {
            let q = formats[id.0].expect("chosen above");
            let (lo, hi) = done.received[&id];
            if !q.ty.holds(q.raw_floor(lo), q.raw_ceil(hi)) {
                let r = ranges.get_mut(&id).expect("recorded in the first pass");
                *r = (r.0.min(lo), r.1.max(hi));
                stable = false;
                unstable = id;
            }
        }
        if stable {
            return Ok(done.finish(formats));
        }
    }
    let id = unstable;
    Err(Diag::new(
        prog.sig(id).span,
        format!(
            "could not find a format for the unranged output `{}` that holds every value it \
             receives",
            prog.sig(id).name
        ),
    )
    .help("declare its range (`output y: [LO, HI];`) so it saturates, or pin a format"))
}

/// Gives every element of each vector in `hulled` one format: the format of the hull of the
/// elements' ranges, checked against each element's own range.
fn hull_groups(
    prog: &Program,
    hulled: &std::collections::BTreeSet<String>,
    formats: &mut [Option<QFormat>],
) -> Result<()> {
    let mut groups: std::collections::BTreeMap<&str, Vec<usize>> = Default::default();
    for (i, s) in prog.signals.iter().enumerate() {
        if let (Some(e), Some(_)) = (&s.elem, formats[i]) {
            if hulled.contains(&e.group) {
                groups.entry(&e.group).or_default().push(i);
            }
        }
    }
    for ids in groups.values() {
        let mut hull = prog.signals[ids[0]].clone();
        for i in ids {
            if let (Some((lo, hi)), Some((a, b))) = (prog.signals[*i].range, hull.range) {
                hull.range = Some((lo.min(a), hi.max(b)));
            }
        }
        let q = choose_format(&hull, prog.word)?;
        for i in ids {
            let mut one = prog.signals[*i].clone();
            one.pin = Some(q);
            formats[*i] = Some(choose_format(&one, prog.word)?);
        }
    }
    Ok(())
}

/// Widens `id`'s hull in `map` to include `[lo, hi]`.
fn widen(map: &mut HashMap<SigId, (f64, f64)>, id: SigId, (lo, hi): (f64, f64)) {
    let e = map.entry(id).or_insert((lo, hi));
    *e = (e.0.min(lo), e.1.max(hi));
}

/// The `ctx` of an expression with no binary point to inherit (a `let`, an unranged output):
/// a bare constant then takes the default word's full precision.
const NO_CTX: i32 = i32::MIN;

/// Passes over the step that may refine the formats of unranged outputs.
const UNRANGED_PASSES: usize = 4;

/// Picks the storage format of a declared signal (`check` also quantises a rule parameter in
/// its unit to it).
pub(crate) fn choose_format(s: &Signal, word: u32) -> Result<QFormat> {
    let (lo, hi) = s.range.unwrap_or((0.0, 0.0));
    if let Some(p) = s.pin {
        if s.range.is_some() && !p.ty.holds(p.raw_floor(lo), p.raw_ceil(hi)) {
            return Err(Diag::new(
                s.span,
                format!(
                    "pinned format {p} cannot hold the range [{lo}, {hi}] of `{}`",
                    s.name
                ),
            )
            .help("use fewer fraction bits or a wider word, or remove the pin"));
        }
    }
    let q = match s.pin {
        Some(p) => p,
        None => choose_format_unchecked(s, word, lo, hi)?,
    };
    if s.range.is_some() && q.raw_floor(hi) <= q.raw_ceil(lo) {
        return Err(Diag::new(
            s.span,
            format!(
                "the range [{}, {}] of `{}` is narrower than one step of its format {q} \
                 (LSB {:.3e}): every value would be stored as {}",
                crate::text::g(lo),
                crate::text::g(hi),
                s.name,
                q.lsb(),
                crate::text::g(q.value(q.raw_ceil(lo)))
            ),
        )
        .label("too narrow to represent")
        .help(
            "change the signal's unit so that its range spans many LSBs (e.g. µN instead of \
             kN), or pin a format with more fraction bits, `#[q(i64, 60)]`",
        ));
    }
    Ok(q)
}

/// The format of an unpinned signal, before the check that its range spans two raw values.
fn choose_format_unchecked(s: &Signal, word: u32, lo: f64, hi: f64) -> Result<QFormat> {
    let fit = |ty: IntTy| QFormat::best_for(ty, lo, hi);
    let q = match s.lsb {
        Some(lsb) => {
            // Unsigned where the range allows, but never a u64 input (see `check`: its raw
            // bits could not be clamped in signed 64-bit arithmetic).
            let u64_ok = s.kind != SigKind::Input;
            let candidates = WIDTHS.iter().flat_map(|&b| {
                let mut v = vec![IntTy::signed(b)];
                if lo >= 0.0 && (b < 64 || u64_ok) {
                    v.push(IntTy::unsigned(b));
                }
                v
            });
            candidates.filter_map(fit).find(|q| q.lsb() <= lsb).ok_or_else(|| {
                Diag::new(s.span, format!("no format up to 64 bits gives `{}` an LSB of {lsb:e} over [{lo}, {hi}]", s.name))
            })?
        }
        None => fit(IntTy::signed(word)).ok_or_else(|| {
            Diag::new(
                s.span,
                format!(
                    "the range [{lo}, {hi}] of `{}` does not fit a {word}-bit word",
                    s.name
                ),
            )
            .help("declare a wider `word`, or pin a format with `#[q(i64, F)]`")
        })?,
    };
    Ok(q)
}

/// A value about to be defined ([`Lowerer::push`]): its operation, working type, binary point,
/// proved raw interval `[lo, hi]` and one-step error bound (physical units).
struct NewVal {
    op: Op,
    ty: IntTy,
    frac: i32,
    lo: i128,
    hi: i128,
    err: f64,
}

impl NewVal {
    /// The constant `c` (raw, at binary point `frac`), carrying error bound `err`; its interval
    /// is `[c, c]`.
    fn constant(c: i128, ty: IntTy, frac: i32, err: f64) -> NewVal {
        NewVal {
            op: Op::Const(c),
            ty,
            frac,
            lo: c,
            hi: c,
            err,
        }
    }

    /// A value computed exactly from exact operands (error 0), with raw interval `[lo, hi]`.
    fn exact(op: Op, ty: IntTy, frac: i32, (lo, hi): (i128, i128)) -> NewVal {
        NewVal {
            op,
            ty,
            frac,
            lo,
            hi,
            err: 0.0,
        }
    }
}

/// Abstract value of a state/output variable.
#[derive(Clone, Copy, Debug)]
struct Abs {
    lo: i128,
    hi: i128,
    err: f64,
    /// Binary point of the stored raw value (the storage format's, except in the first pass
    /// for an unranged output).
    frac: i32,
}

struct Lowerer<'a> {
    prog: &'a Program,
    target: &'a Target,
    formats: Vec<Option<QFormat>>,
    vals: Vec<Val>,
    env: HashMap<SigId, Abs>,
    locals: HashMap<SigId, ValId>,
    inputs: HashMap<SigId, ValId>,
    /// Physical hull of values stored to each output.
    seen: HashMap<SigId, (f64, f64)>,
    /// Physical hull of the values each output receives before its saturation.
    received: HashMap<SigId, (f64, f64)>,
    mults: Vec<MulNote>,
    /// The arrays of the table look-ups lowered so far.
    tables: Vec<table::LTable>,
    /// Spec line of the statement being lowered.
    line: usize,
    /// Comparisons lowered so far (the next one's [`Val::decision`]).
    decisions: usize,
    /// The spec site of what is being lowered (a statement, a condition, an input's
    /// declaration): where an error without a site of its own points.
    here: Span,
    /// The arithmetic values of the statement being lowered, by their definition
    /// ([`cse_key`]): an expression that repeats a subexpression (a `det` expanded by minors)
    /// computes it once. Cleared at every statement, so that a value is reused only in the
    /// statement list that defines it, and the copies of a `for` body stay alike.
    cse: HashMap<String, ValId>,
    /// The exact products of a value and an integer constant ([`Lowerer::mul_const`]): the
    /// rounded factor, the constant and its [`MulNote`], for [`Lowerer::const_split`].
    const_products: HashMap<ValId, ConstProduct>,
    /// The constant products rounded in 32 bits so far.
    splits: Vec<Split>,
}

/// A product `x · m` computed exactly ([`Lowerer::mul_const`]): `x`, `m`, and the index of
/// its [`MulNote`] in [`Lowerer::mults`].
#[derive(Clone, Copy, Debug)]
struct ConstProduct {
    x: ValId,
    m: i128,
    note: usize,
}

/// The key of a value for [`Lowerer::push`]'s reuse within a statement: its operation,
/// type, binary point, interval and error bound. `None` for what is never merged: inputs,
/// loads, constants, table reads, comparisons and Boolean operations (each comparison has
/// a decision number of its own).
fn cse_key(v: &NewVal) -> Option<String> {
    match v.op {
        Op::Cast(_)
        | Op::Add(..)
        | Op::Sub(..)
        | Op::Neg(_)
        | Op::Shl(..)
        | Op::Shr(..)
        | Op::Mul(..)
        | Op::MulHi(..)
        | Op::Min(..)
        | Op::Max(..) => Some(format!(
            "{:?} {} {} {} {} {}",
            v.op,
            v.ty,
            v.frac,
            v.lo,
            v.hi,
            v.err.to_bits()
        )),
        _ => None,
    }
}

struct Lowered {
    prog: Program,
    target: Target,
    vals: Vec<Val>,
    body: Vec<LStmt>,
    env: HashMap<SigId, Abs>,
    locals: HashMap<SigId, ValId>,
    inputs: HashMap<SigId, ValId>,
    seen: HashMap<SigId, (f64, f64)>,
    received: HashMap<SigId, (f64, f64)>,
    mults: Vec<MulNote>,
    tables: Vec<table::LTable>,
    splits: Vec<Split>,
}

/// A constant product rounded in 32 bits ([`Lowerer::const_split`]): its [`MulNote`], the
/// value computed, and `(q, c, n)`. The note says so only where the value is used (an
/// attempt that a surrounding rewrite dropped leaves a dead value).
#[derive(Clone, Copy, Debug)]
struct Split {
    note: usize,
    val: ValId,
    qcn: (i128, i128, u32),
}

impl Lowered {
    fn finish(self, formats: Vec<Option<QFormat>>) -> Plan {
        let summary = self
            .prog
            .signals
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let id = SigId(i);
                match s.kind {
                    SigKind::Local => {
                        let v = &self.vals[self.locals[&id].0];
                        let q = QFormat {
                            ty: v.ty,
                            frac: v.frac,
                        };
                        SigSummary {
                            range: (q.value(v.lo), q.value(v.hi)),
                            format: q,
                            err: v.err,
                            bounds: (v.lo, v.hi),
                            init: None,
                        }
                    }
                    _ => {
                        let q = formats[i].expect("every declared signal has a storage format");
                        let bounds = storage_bounds(s, q);
                        let init = s.init.map(|v| q.raw_nearest(v).clamp(bounds.0, bounds.1));
                        let range = s
                            .range
                            .or_else(|| self.seen.get(&id).copied())
                            .unwrap_or((0.0, 0.0));
                        let err = match s.kind {
                            SigKind::Input => {
                                self.inputs.get(&id).map_or(0.0, |v| self.vals[v.0].err)
                            }
                            _ => self.env.get(&id).map_or(0.0, |a| a.err),
                        };
                        SigSummary {
                            range,
                            format: q,
                            err,
                            bounds,
                            init,
                        }
                    }
                }
            })
            .collect();
        let live = dce::live(&self.vals, &self.body);
        let mut mults = self.mults;
        for sp in &self.splits {
            if live[sp.val.0] {
                mults[sp.note].split = Some(sp.qcn);
            }
        }
        let (vals, body) = dce::eliminate(self.vals, self.body);
        Plan {
            prog: self.prog,
            target: self.target,
            vals,
            body,
            summary,
            mults,
            tables: self.tables,
            tuning: None,
        }
    }
}

impl<'a> Lowerer<'a> {
    fn new(prog: &'a Program, target: &'a Target, formats: Vec<Option<QFormat>>) -> Self {
        Lowerer {
            prog,
            target,
            formats,
            vals: Vec::new(),
            env: HashMap::new(),
            locals: HashMap::new(),
            inputs: HashMap::new(),
            seen: HashMap::new(),
            received: HashMap::new(),
            mults: Vec::new(),
            tables: Vec::new(),
            line: 0,
            decisions: 0,
            here: Span::call_site(),
            cse: HashMap::new(),
            const_products: HashMap::new(),
            splits: Vec::new(),
        }
    }

    fn run(mut self) -> Result<Lowered> {
        let mut body = Vec::new();
        // States hold values inside their saturation interval at the start of every step.
        for id in self.prog.ids_of(SigKind::State).collect::<Vec<_>>() {
            let (lo, hi) = self.bounds(id);
            let frac = self.fmt(id).frac;
            self.env.insert(
                id,
                Abs {
                    lo,
                    hi,
                    err: 0.0,
                    frac,
                },
            );
        }
        // Inputs: read raw bits, clamp to the declared range.
        for id in self.prog.ids_of(SigKind::Input).collect::<Vec<_>>() {
            self.here = self.prog.sig(id).span;
            let q = self.fmt(id);
            let raw = self.push(
                NewVal::exact(Op::Input(id), q.ty, q.frac, (q.ty.min(), q.ty.max())),
                &mut body,
            );
            let (lo, hi) = self.bounds(id);
            let v = self.clamp(raw, lo, hi, &mut body)?;
            // Input bits beyond a range bound off the grid clamp to the bound's grid point
            // inside, where the reference clamps to the bound itself: that gap is the input's
            // error.
            if let Some((l, h)) = self.prog.sig(id).range {
                let below = if q.ty.min() < lo {
                    err_bound::sub(err_bound::value(lo, q.frac, true), l)
                } else {
                    0.0
                };
                let above = if q.ty.max() > hi {
                    err_bound::sub(h, err_bound::value(hi, q.frac, false))
                } else {
                    0.0
                };
                self.vals[v.0].err = below.max(above).max(0.0);
            }
            self.vals[v.0].name = Some(self.prog.sig(id).name.clone());
            self.inputs.insert(id, v);
        }
        for s in &self.prog.body {
            self.stmt(s, &mut body)?;
        }
        Ok(Lowered {
            prog: self.prog.clone(),
            target: self.target.clone(),
            vals: self.vals,
            body,
            env: self.env,
            locals: self.locals,
            inputs: self.inputs,
            seen: self.seen,
            received: self.received,
            mults: self.mults,
            tables: self.tables,
            splits: self.splits,
        })
    }

    fn fmt(&self, id: SigId) -> QFormat {
        self.formats[id.0].unwrap_or(QFormat {
            ty: IntTy::signed(self.prog.word),
            frac: 0,
        })
    }

    fn bounds(&self, id: SigId) -> (i128, i128) {
        storage_bounds(self.prog.sig(id), self.fmt(id))
    }

    // ---- value construction ----------------------------------------------------------

    /// Defines a new value in `out`.
    fn push(&mut self, v: NewVal, out: &mut Vec<LStmt>) -> ValId {
        let NewVal {
            op,
            ty,
            frac,
            lo,
            hi,
            err,
        } = v;
        debug_assert!(lo <= hi && ty.holds(lo, hi), "{op:?} {ty} [{lo}, {hi}]");
        debug_assert!(
            !matches!(op, Op::Shl(_, k) | Op::Shr(_, k) if k >= ty.bits),
            "{op:?}: a shift as wide as its {ty} operand"
        );
        let key = cse_key(&NewVal {
            op: op.clone(),
            ty,
            frac,
            lo,
            hi,
            err,
        });
        if let Some(&id) = key.as_ref().and_then(|k| self.cse.get(k)) {
            let w = &self.vals[id.0];
            if w.name.is_none() && !w.claimed && !w.network && !w.boolean {
                return id;
            }
        }
        let id = ValId(self.vals.len());
        if let Some(k) = key {
            self.cse.insert(k, id);
        }
        self.vals.push(Val {
            op,
            ty,
            frac,
            lo,
            hi,
            err,
            name: None,
            boolean: false,
            claimed: false,
            network: false,
            line: self.line,
            decision: None,
        });
        out.push(LStmt::Def(id));
        id
    }

    /// Like [`Self::push`], but a range that does not fit `ty` is cut to `ty` and marked as
    /// claimed (only used where a user claim sized the type).
    fn push_fit(&mut self, v: NewVal, out: &mut Vec<LStmt>) -> ValId {
        let ty = v.ty;
        if ty.holds(v.lo, v.hi) {
            return self.push(v, out);
        }
        let (l, h) = (v.lo.max(ty.min()), v.hi.min(ty.max()));
        let (l, h) = if l <= h { (l, h) } else { (ty.min(), ty.max()) };
        let id = self.push(NewVal { lo: l, hi: h, ..v }, out);
        self.vals[id.0].claimed = true;
        id
    }

    /// Narrows `v`'s interval to a user claim `[lo, hi]` (physical), in a working type sized by
    /// the claim. The new value is marked claimed if the claim is narrower than the analysis.
    fn claim(
        &mut self,
        v: ValId,
        (lo, hi): (f64, f64),
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let x = self.v(v).clone();
        let q = QFormat {
            ty: x.ty,
            frac: x.frac,
        };
        let (cl, ch) = (q.raw_floor(lo).max(x.lo), q.raw_ceil(hi).min(x.hi));
        if cl > ch {
            return Err(Diag::new(
                span,
                format!(
                    "the claimed range [{lo}, {hi}] misses every value the expression can take"
                ),
            ));
        }
        if (cl, ch) == (x.lo, x.hi) {
            return Ok(v);
        }
        let ty = self.working(cl, ch, span)?;
        let id = self.push(
            NewVal {
                op: Op::Cast(v),
                ty,
                frac: x.frac,
                lo: cl,
                hi: ch,
                err: x.err,
            },
            out,
        );
        self.vals[id.0].claimed = true;
        Ok(id)
    }

    fn v(&self, id: ValId) -> &Val {
        &self.vals[id.0]
    }

    /// The working type for raw values in `[lo, hi]`.
    fn working(&self, lo: i128, hi: i128, span: Span) -> Result<IntTy> {
        IntTy::signed_for(lo, hi, self.target.min_work_bits()).ok_or_else(|| {
            Diag::new(span, format!("an intermediate needs more than 64 bits (raw range [{lo}, {hi}])"))
                .help("narrow the declared ranges, or pin coarser formats with `#[q(..)]` / `#[lsb(..)]` on `let`s")
        })
    }

    /// A copy of `v` (a cast to its own type) with error bound `err`: a value of its own, for
    /// a name or a bound that `v`, defined before and used elsewhere, must not take.
    fn copy(&mut self, v: ValId, err: f64, out: &mut Vec<LStmt>) -> ValId {
        let y = self.v(v).clone();
        self.push(
            NewVal {
                op: Op::Cast(v),
                ty: y.ty,
                frac: y.frac,
                lo: y.lo,
                hi: y.hi,
                err,
            },
            out,
        )
    }

    /// `v` converted to type `ty` (a no-op if it already has it).
    fn cast(&mut self, v: ValId, ty: IntTy, out: &mut Vec<LStmt>) -> ValId {
        let x = self.v(v).clone();
        if x.ty == ty {
            return v;
        }
        self.push(
            NewVal {
                op: Op::Cast(v),
                ty,
                frac: x.frac,
                lo: x.lo,
                hi: x.hi,
                err: x.err,
            },
            out,
        )
    }

    // ---- statements ------------------------------------------------------------------

    fn stmt(&mut self, s: &Stmt, out: &mut Vec<LStmt>) -> Result<()> {
        self.cse.clear();
        match s {
            Stmt::Assign {
                target,
                value,
                span,
            } => {
                self.line = span.start().line;
                self.here = *span;
                let sig = self.prog.sig(*target).clone();
                if sig.kind == SigKind::Local {
                    let mut v = match (value, sig.claim) {
                        (Expr::Mul(a, b, mspan), Some(claim)) => match (&**a, &**b) {
                            (Expr::Const { value: c, name, .. }, x)
                            | (x, Expr::Const { value: c, name, .. }) => {
                                let xv = self.expr(x, NO_CTX, out)?;
                                self.mul_const(xv, *c, name.clone(), Some(claim), *mspan, out)?
                            }
                            _ => self.expr(value, NO_CTX, out)?,
                        },
                        _ => self.expr(value, NO_CTX, out)?,
                    };
                    if let Some(claim) = sig.claim {
                        v = self.claim(v, claim, sig.span, out)?;
                    }
                    let x = self.v(v).clone();
                    if let Some(p) = sig.pin {
                        v = self.rescale(v, p.frac, *span, out)?;
                        let y = self.v(v).clone();
                        if !p.ty.holds(y.lo, y.hi) {
                            return Err(Diag::new(
                                sig.span,
                                format!(
                                    "`{}` spans [{}, {}], which does not fit the pinned {p}",
                                    sig.name,
                                    p.value(y.lo),
                                    p.value(y.hi)
                                ),
                            )
                            .help("widen the pinned word or use fewer fraction bits"));
                        }
                        // The pin names the binding's type too.
                        v = self.cast(v, p.ty, out);
                    } else if let Some(lsb) = sig.lsb {
                        let f = (-lsb.log2()).ceil() as i32;
                        if f < x.frac {
                            v = self.round(v, (x.frac - f) as u32, *span, out)?;
                        }
                    }
                    // Give the binding its own name in the emitted code.
                    if self.vals[v.0].name.is_some() {
                        let err = self.v(v).err;
                        v = self.copy(v, err, out);
                    }
                    self.vals[v.0].name = Some(sig.name.clone());
                    self.locals.insert(*target, v);
                    // An iterate or the result of a `newton_recip`: its error against real
                    // arithmetic from Newton's contraction (`newton::iterate_err`,
                    // `newton::result_err`), far below what interval propagation through
                    // the iterates gives.
                    self.newton_err(*target, v);
                    return Ok(());
                }
                let q = self.formats[target.0];
                let ctx = q.map_or(NO_CTX, |q| q.frac);
                let v = match (value, q) {
                    // `x = a ± b` rounds once, to x's grid. When one operand already lies on
                    // that grid, rounding the other first gives the identical result
                    // (floor(a + b) = a + floor(b) for a on the grid; likewise for nearest)
                    // in a narrower add: `km += C1*em` becomes `km + (em >> n)`.
                    (Expr::Add(a, b), Some(q)) => {
                        self.binary_rounded(a, b, q.frac, Bin::Add, out)?
                    }
                    (Expr::Sub(a, b), Some(q)) => {
                        self.binary_rounded(a, b, q.frac, Bin::Sub, out)?
                    }
                    _ => self.expr(value, ctx, out)?,
                };
                self.store(*target, v, *span, out)
            }
            Stmt::If { cond, then, els } => {
                self.here = cond.span();
                self.line = self.here.start().line;
                let c = self.cond(cond, out)?;
                let before = self.env.clone();
                let mut t = Vec::new();
                for s in then {
                    self.stmt(s, &mut t)?;
                }
                let after_then = std::mem::replace(&mut self.env, before);
                let mut e = Vec::new();
                for s in els {
                    self.stmt(s, &mut e)?;
                }
                for (id, a) in after_then {
                    let merged = match self.env.get(&id) {
                        Some(b) => Abs {
                            lo: a.lo.min(b.lo),
                            hi: a.hi.max(b.hi),
                            err: a.err.max(b.err),
                            frac: a.frac,
                        },
                        None => a,
                    };
                    self.env.insert(id, merged);
                }
                out.push(LStmt::If(c, t, e));
                Ok(())
            }
        }
    }

    /// Tightens the error of `v`, bound to `target`, where `target` is an iterate (or the
    /// result) of a `newton_recip`: to the bound from Newton's contraction where that is the
    /// smaller ([`newton::iterate_err`], [`newton::result_err`]).
    fn newton_err(&mut self, target: SigId, v: ValId) {
        let name = &self.prog.sig(target).name;
        for r in &self.prog.recips {
            let Some(site) = self.prog.sig(r.d).name.strip_suffix("_d") else {
                continue;
            };
            // The iterates are `{site}_r1` .. `{site}_rK` (`lang::expand`).
            let step = if r.r == target {
                Some(r.steps)
            } else {
                (1..=r.steps).find(|k| *name == format!("{site}_r{k}"))
            };
            let (Some(k), Some(d)) = (step, self.locals.get(&r.d)) else {
                continue;
            };
            let d_err = self.vals[d.0].err;
            let mut e = newton::iterate_err(self.prog, &self.vals, r, k, d_err);
            if r.r == target {
                let res = newton::result_err(self.prog, &self.vals, r, d_err);
                e = match (e, res) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
            }
            if let Some(e) = e {
                let own = &mut self.vals[v.0].err;
                *own = own.min(e);
            }
            return;
        }
    }

    /// Rounds, saturates and casts `v` into `target`'s storage, then writes it.
    fn store(&mut self, target: SigId, v: ValId, span: Span, out: &mut Vec<LStmt>) -> Result<()> {
        let x = self.v(v).clone();
        let Some(q) = self.formats[target.0] else {
            // First pass for an unranged output: only record what it receives.
            let q = QFormat {
                ty: x.ty,
                frac: x.frac,
            };
            widen(&mut self.seen, target, (q.value(x.lo), q.value(x.hi)));
            self.env.insert(
                target,
                Abs {
                    lo: x.lo,
                    hi: x.hi,
                    err: x.err,
                    frac: x.frac,
                },
            );
            return Ok(());
        };
        let (lo, hi) = self.bounds(target);
        let sig = self.prog.sig(target);
        let mut v = v;
        // Whether the value is saturated before it is shifted (then the gap counts even if
        // the shifted value lands exactly on a bound).
        let mut pre_clamped = false;
        if sig.range.is_some() && !sig.unsaturated && q.frac > x.frac {
            // A left shift to the storage format that would overflow 64 bits (a value far
            // beyond the range, or a full-width `word 64` sum): saturate first, in the
            // value's own format, to one step beyond the bounds. The shift then fits, and
            // the exact clamp after it gives the same result as shifting first.
            let s = (q.frac - x.frac) as u32;
            let fits = shl_exact(x.lo, s as i32)
                .zip(shl_exact(x.hi, s as i32))
                .is_some_and(|(l, h)| IntTy::signed_for(l.min(x.lo), h.max(x.hi), 8).is_some());
            if !fits {
                // Floor and ceiling of the bounds at the value's binary point (an `i128` shift
                // by 127 already gives 0 or ±1 for any bound, as a wider one would).
                let k = s.min(127);
                let (plo, phi) = (lo >> k, -((-hi) >> k));
                pre_clamped = x.lo < plo || x.hi > phi;
                v = self.clamp(v, plo, phi, out)?;
            }
        }
        let mut v = self.rescale(v, q.frac, span, out)?;
        let y = self.v(v).clone();
        let received = (y.lo as f64 * pow2(-y.frac), y.hi as f64 * pow2(-y.frac));
        widen(&mut self.received, target, received);
        let mut err = y.err;
        if self.prog.sig(target).unsaturated {
            // No clamp: the declared range is a claim the prover must discharge.
            if y.lo < lo || y.hi > hi {
                let x = self.v(v).clone();
                let (cl, ch) = (x.lo.max(lo).min(hi), x.hi.min(hi).max(lo));
                let ty = self.working(cl, ch, span)?;
                v = self.push(
                    NewVal {
                        op: Op::Cast(v),
                        ty,
                        frac: x.frac,
                        lo: cl,
                        hi: ch,
                        err: x.err,
                    },
                    out,
                );
                self.vals[v.0].claimed = true;
            }
        } else if pre_clamped || y.lo < lo || y.hi > hi {
            v = self.clamp(v, lo, hi, out)?;
            if let Some((l, h)) = self.prog.sig(target).range {
                let gap = err_bound::sub(err_bound::value(lo, q.frac, true), l)
                    .max(err_bound::sub(h, err_bound::value(hi, q.frac, false)))
                    .max(0.0);
                err = err_bound::add(err, gap);
            }
        }
        self.vals[v.0].err = err;
        let v = self.cast(v, q.ty, out);
        let z = self.v(v).clone();
        widen(&mut self.seen, target, (q.value(z.lo), q.value(z.hi)));
        out.push(LStmt::Store(target, v));
        self.env.insert(
            target,
            Abs {
                lo: z.lo,
                hi: z.hi,
                err,
                frac: q.frac,
            },
        );
        Ok(())
    }

    // ---- expressions -----------------------------------------------------------------

    /// Lowers `e`; a bare constant takes `ctx` fraction bits (or more, if that makes it exact).
    fn expr(&mut self, e: &Expr, ctx: i32, out: &mut Vec<LStmt>) -> Result<ValId> {
        // A thin dispatcher: this recursion repeats once per operator, so each form has its own
        // function and the frame repeated per level stays small (see `lang::scan`).
        match e {
            Expr::Const { value, span, .. } => self.constant(*value, ctx, *span, out),
            Expr::Var(id, span) => self.var(*id, *span, out),
            Expr::Neg(a) => self.neg(a, ctx, out),
            Expr::Add(a, b) => self.binary(a, b, ctx, Bin::Add, out),
            Expr::Sub(a, b) => self.binary(a, b, ctx, Bin::Sub, out),
            Expr::Min(a, b) => self.binary(a, b, ctx, Bin::Min, out),
            Expr::Max(a, b) => self.binary(a, b, ctx, Bin::Max, out),
            Expr::Mul(a, b, span) => self.product(a, b, *span, ctx, out),
            Expr::Select(c, a, b) => self.select(c, a, b, ctx, out),
            Expr::Table(t, a, span) => self.table(*t, a, *span, out),
        }
    }

    fn neg(&mut self, a: &Expr, ctx: i32, out: &mut Vec<LStmt>) -> Result<ValId> {
        let a = self.expr(a, ctx, out)?;
        let x = self.v(a).clone();
        // The type holds the operand as well as the result: [0, 2^31] negates into i32, but
        // is cast there first.
        let ty = self.working(x.lo.min(-x.hi), x.hi.max(-x.lo), self.here)?;
        let c = self.cast(a, ty, out);
        Ok(self.push(
            NewVal {
                op: Op::Neg(c),
                ty,
                frac: x.frac,
                lo: -x.hi,
                hi: -x.lo,
                err: x.err,
            },
            out,
        ))
    }

    fn product(
        &mut self,
        a: &Expr,
        b: &Expr,
        span: Span,
        ctx: i32,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        match (a, b) {
            (Expr::Const { value, name, .. }, x) | (x, Expr::Const { value, name, .. }) => {
                // `(y · c₁) · c₂`: perhaps one constant multiplication (`mul_const_chain`).
                if let Expr::Mul(p, q, inner) = x {
                    if let (
                        Expr::Const {
                            value: c1,
                            name: n1,
                            ..
                        },
                        y,
                    )
                    | (
                        y,
                        Expr::Const {
                            value: c1,
                            name: n1,
                            ..
                        },
                    ) = (&**p, &**q)
                    {
                        if !matches!(y, Expr::Const { .. }) {
                            let yv = self.expr(y, ctx, out)?;
                            return self.mul_const_chain(
                                yv,
                                (*c1, n1.clone()),
                                (*value, name.clone()),
                                (*inner, span),
                                out,
                            );
                        }
                    }
                }
                let xv = self.expr(x, ctx, out)?;
                self.mul_const(xv, *value, name.clone(), None, span, out)
            }
            _ => {
                let av = self.expr(a, ctx, out)?;
                let bv = self.expr(b, ctx, out)?;
                self.mul(av, bv, span, out)
            }
        }
    }

    fn select(
        &mut self,
        c: &Cond,
        a: &Expr,
        b: &Expr,
        ctx: i32,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let c = self.cond(c, out)?;
        let (a, b) = self.pair(a, b, ctx, out)?;
        let (a, b, f, ty) = self.align(a, b, Bin::Hull, self.here, out)?;
        let (x, y) = (self.v(a), self.v(b));
        let (lo, hi, err) = (x.lo.min(y.lo), x.hi.max(y.hi), x.err.max(y.err));
        Ok(self.push(
            NewVal {
                op: Op::Select(c, a, b),
                ty,
                frac: f,
                lo,
                hi,
                err,
            },
            out,
        ))
    }

    fn var(&mut self, id: SigId, span: Span, out: &mut Vec<LStmt>) -> Result<ValId> {
        let s = self.prog.sig(id);
        match s.kind {
            SigKind::Input => Ok(self.inputs[&id]),
            SigKind::Local => Ok(self.locals[&id]),
            SigKind::State | SigKind::Output => {
                let a = *self.env.get(&id).ok_or_else(|| {
                    Diag::new(span, format!("`{}` is read before it is assigned", s.name))
                })?;
                let q = self.fmt(id);
                let ty = match self.formats[id.0] {
                    Some(q) => q.ty,
                    // First pass of an unranged output: the stored value is unconverted.
                    None => IntTy::signed_for(a.lo, a.hi, 8).unwrap_or(q.ty),
                };
                let frac = a.frac;
                Ok(self.push(
                    NewVal {
                        op: Op::Load(id),
                        ty,
                        frac,
                        lo: a.lo,
                        hi: a.hi,
                        err: a.err,
                    },
                    out,
                ))
            }
        }
    }

    fn constant(&mut self, c: f64, ctx: i32, span: Span, out: &mut Vec<LStmt>) -> Result<ValId> {
        // Without a context (a `let` or an unranged output made of constants only), the
        // constant gets the default word's full precision instead of an integer's.
        let ctx = match c.abs() {
            _ if ctx != NO_CTX => ctx,
            0.0 => 0,
            m => self.prog.word as i32 - 1 - (m.log2().floor() as i32 + 1).max(0),
        };
        // Prefer a binary point at which the constant is exact, up to 16 bits finer than ctx;
        // but never so fine that the raw value needs more than 62 bits (a large constant next
        // to a finely resolved value: `align` then drops bits of the sum, not the constant).
        let cap = match c.abs() {
            0.0 => i32::MAX,
            m => 61 - m.log2().floor() as i32,
        };
        let frac = (ctx..=ctx + 16)
            .find(|&f| {
                let r = (c * pow2(f)).round();
                r * pow2(-f) == c
            })
            .unwrap_or(ctx)
            .min(cap);
        let scaled = c * pow2(frac);
        let raw = scaled.round() as i128;
        if raw == 0 && c != 0.0 {
            return Err(Diag::new(
                span,
                format!(
                    "the constant {} vanishes here: at the resolution of the value it meets \
                     (LSB {:.3e}) it rounds to 0",
                    crate::text::g(c),
                    pow2(-frac)
                ),
            )
            .label("rounds to 0")
            .help(
                "remove it if it is negligible; otherwise give the other operand a finer format \
                 (`#[lsb(..)]` or `#[q(..)]`), or change units so that the constant is larger",
            ));
        }
        let ty = self.working(raw, raw, span)?;
        // The fraction part of an f64 is exact in f64, and so is scaling by a power of two.
        let err = (scaled - scaled.round()).abs() * pow2(-frac);
        Ok(self.push(NewVal::constant(raw, ty, frac, err), out))
    }

    /// Lowers two operands; a constant operand takes the other operand's binary point.
    fn pair(
        &mut self,
        a: &Expr,
        b: &Expr,
        ctx: i32,
        out: &mut Vec<LStmt>,
    ) -> Result<(ValId, ValId)> {
        Ok(match (a, b) {
            (Expr::Const { value, span, .. }, x) if !matches!(x, Expr::Const { .. }) => {
                let xv = self.expr(x, ctx, out)?;
                let f = self.v(xv).frac;
                (self.constant(*value, f, *span, out)?, xv)
            }
            (x, Expr::Const { value, span, .. }) if !matches!(x, Expr::Const { .. }) => {
                let xv = self.expr(x, ctx, out)?;
                let f = self.v(xv).frac;
                (xv, self.constant(*value, f, *span, out)?)
            }
            _ => (self.expr(a, ctx, out)?, self.expr(b, ctx, out)?),
        })
    }

    /// Brings `a` and `b` to a common binary point and working type that also holds the
    /// result of `op`. Drops fraction bits (rounding) only if exact alignment needs > 64 bits.
    fn align(
        &mut self,
        a: ValId,
        b: ValId,
        op: Bin,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<(ValId, ValId, i32, IntTy)> {
        let (x, y) = (self.v(a).clone(), self.v(b).clone());
        let mut f = x.frac.max(y.frac);
        let at = |v: &Val, f: i32| -> Option<(i128, i128)> {
            if f >= v.frac {
                Some((shl_exact(v.lo, f - v.frac)?, shl_exact(v.hi, f - v.frac)?))
            } else {
                let k = (v.frac - f).min(127) as u32;
                Some((v.lo >> k, (v.hi >> k) + 1))
            }
        };
        let ty = loop {
            let (Some((xl, xh)), Some((yl, yh))) = (at(&x, f), at(&y, f)) else {
                f -= 1;
                continue;
            };
            let (rl, rh) = op.range((xl, xh), (yl, yh));
            let lo = xl.min(yl).min(rl);
            let hi = xh.max(yh).max(rh);
            if let Some(t) = IntTy::signed_for(lo, hi, self.target.min_work_bits()) {
                break t;
            }
            if f <= x.frac.min(y.frac) - 64 {
                return Err(Diag::new(
                    span,
                    "operands too far apart in magnitude for 64-bit arithmetic",
                ));
            }
            f -= 1;
        };
        let a = self.rescale(a, f, span, out)?;
        let b = self.rescale(b, f, span, out)?;
        let a = self.cast(a, ty, out);
        let b = self.cast(b, ty, out);
        Ok((a, b, f, ty))
    }

    fn binary(
        &mut self,
        a: &Expr,
        b: &Expr,
        ctx: i32,
        op: Bin,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        if let (Bin::Min | Bin::Max, Some((x, c))) = (op, const_side(a, b)) {
            return self.min_max_const(x, c, ctx, op, out);
        }
        let (a, b) = self.pair(a, b, ctx, out)?;
        self.binary_vals(a, b, op, out)
    }

    /// `min(x, c)` / `max(x, c)` for a constant `c`: just `x` where `c` lies beyond `x`'s
    /// proved interval on the side that makes the operation a no-op (exact, and it keeps a
    /// huge bound such as `min(x, 1e14)` from costing `x` its fraction bits); else the
    /// constant on `x`'s grid, as for any operand pair.
    fn min_max_const(
        &mut self,
        x: &Expr,
        c: (f64, Span),
        ctx: i32,
        op: Bin,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let v = self.expr(x, ctx, out)?;
        let xv = self.v(v).clone();
        let (fl, ce) = floor_ceil_scaled(c.0, xv.frac);
        // min(x, c) = x when c ≥ max x, i.e. ⌊c·2^f⌋ ≥ hi; max(x, c) = x when ⌈c·2^f⌉ ≤ lo.
        if matches!(op, Bin::Min) && fl >= xv.hi || matches!(op, Bin::Max) && ce <= xv.lo {
            return Ok(v);
        }
        let k = self.constant(c.0, xv.frac, c.1, out)?;
        self.binary_vals(v, k, op, out)
    }

    /// `a ± b` about to be rounded to `frac` bits: rounds the finer operand first where that
    /// is exact (the other operand on the grid; for `-`, only the minuend may be finer).
    fn binary_rounded(
        &mut self,
        a: &Expr,
        b: &Expr,
        frac: i32,
        op: Bin,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let (mut a, mut b) = self.pair(a, b, frac, out)?;
        let (fa, fb) = (self.v(a).frac, self.v(b).frac);
        if fb <= frac && fa > frac {
            a = self.round(a, (fa - frac) as u32, self.here, out)?;
        } else if matches!(op, Bin::Add) && fa <= frac && fb > frac {
            b = self.round(b, (fb - frac) as u32, self.here, out)?;
        }
        self.binary_vals(a, b, op, out)
    }

    fn binary_vals(&mut self, a: ValId, b: ValId, op: Bin, out: &mut Vec<LStmt>) -> Result<ValId> {
        let (a, b, f, ty) = self.align(a, b, op, self.here, out)?;
        let (x, y) = (self.v(a).clone(), self.v(b).clone());
        let (lo, hi) = op.range((x.lo, x.hi), (y.lo, y.hi));
        let (o, err) = match op {
            Bin::Add => (Op::Add(a, b), err_bound::add(x.err, y.err)),
            Bin::Sub => (Op::Sub(a, b), err_bound::add(x.err, y.err)),
            Bin::Min => (Op::Min(a, b), x.err.max(y.err)),
            Bin::Max => (Op::Max(a, b), x.err.max(y.err)),
            Bin::Hull | Bin::Mul => unreachable!("not an additive operation"),
        };
        Ok(self.push(
            NewVal {
                op: o,
                ty,
                frac: f,
                lo,
                hi,
                err,
            },
            out,
        ))
    }

    /// Variable × variable: a widening multiply, exact unless the product would exceed 64 bits.
    /// Then the operand with more significant bits loses fraction bits, one at a time in the
    /// count, until the product fits, and each operand is rounded once by its total (one
    /// rounding each: a chain of one-bit roundings to nearest would round twice).
    fn mul(&mut self, a: ValId, b: ValId, span: Span, out: &mut Vec<LStmt>) -> Result<ValId> {
        let (mut a, mut b) = (a, b);
        let (mut drop_a, mut drop_b) = self.bits_to_drop(a, b);
        if self.target.multiplier.high_product {
            // On a target with high products, an operand wider than 32 bits (an inner product
            // rounded only as far as the 64-bit product needs) is rounded until it fits `i32`:
            // it keeps at least 31 significant bits, and the product is one of 32×32 bits,
            // which `rounding::high_product` and `rounding::high_sum` can take.
            for (v, d) in [(a, &mut drop_a), (b, &mut drop_b)] {
                let x = self.v(v);
                while !x.boolean && *d < 64 && {
                    let (lo, hi) = self.rounded(x.lo, x.hi, *d);
                    !rounding::fits_i32(lo, hi)
                } {
                    *d += 1;
                }
            }
        }
        if drop_a > 0 {
            a = self.round(a, drop_a, span, out)?;
        }
        if drop_b > 0 {
            b = self.round(b, drop_b, span, out)?;
        }
        loop {
            let (x, y) = (self.v(a).clone(), self.v(b).clone());
            let (lo, hi) = Bin::Mul.range((x.lo, x.hi), (y.lo, y.hi));
            let (lo, hi) = (lo.min(x.lo).min(y.lo), hi.max(x.hi).max(y.hi));
            if let Some(ty) = IntTy::signed_for(lo, hi, self.target.min_work_bits()) {
                let a2 = self.cast(a, ty, out);
                let b2 = self.cast(b, ty, out);
                let (plo, phi) = Bin::Mul.range((x.lo, x.hi), (y.lo, y.hi));
                let mx = err_bound::magnitude(x.lo.abs().max(x.hi.abs()), x.frac);
                let my = err_bound::magnitude(y.lo.abs().max(y.hi.abs()), y.frac);
                let err = err_bound::add(
                    err_bound::add(err_bound::mul(mx, y.err), err_bound::mul(my, x.err)),
                    err_bound::mul(3.0, err_bound::mul(x.err, y.err)),
                );
                return Ok(self.push(
                    NewVal {
                        op: Op::Mul(a2, b2),
                        ty,
                        frac: x.frac + y.frac,
                        lo: plo,
                        hi: phi,
                        err,
                    },
                    out,
                ));
            }
            // Too wide: drop one fraction bit from the operand with more of them.
            let bits = |v: &Val| 128 - v.lo.abs().max(v.hi.abs()).leading_zeros();
            if bits(&x) <= 1 && bits(&y) <= 1 {
                return Err(Diag::new(span, "product does not fit 64 bits"));
            }
            if bits(&x) >= bits(&y) {
                a = self.round(a, 1, span, out)?;
            } else {
                b = self.round(b, 1, span, out)?;
            }
        }
    }
}

impl Lowerer<'_> {
    /// How many fraction bits to drop from `a` and from `b` so that their product (and both
    /// operands) fit a 64-bit working type: one bit at a time from the operand with more
    /// significant bits (the search the multiply's own loop made, counted before rounding).
    fn bits_to_drop(&self, a: ValId, b: ValId) -> (u32, u32) {
        let (x, y) = (self.v(a), self.v(b));
        let bits = |(lo, hi): (i128, i128)| 128 - lo.abs().max(hi.abs()).leading_zeros();
        let (mut da, mut db) = (0u32, 0u32);
        loop {
            let xr = self.rounded(x.lo, x.hi, da);
            let yr = self.rounded(y.lo, y.hi, db);
            let (lo, hi) = Bin::Mul.range(xr, yr);
            let (lo, hi) = (lo.min(xr.0).min(yr.0), hi.max(xr.1).max(yr.1));
            if IntTy::signed_for(lo, hi, self.target.min_work_bits()).is_some() {
                return (da, db);
            }
            let (bx, by) = (bits(xr), bits(yr));
            if bx <= 1 && by <= 1 {
                // Hopeless: the caller's loop reports it at the product.
                return (da, db);
            }
            if bx >= by {
                da += 1;
            } else {
                db += 1;
            }
        }
    }
}

/// `v · 2^k` if it fits comfortably in an `i128` (the analysis only needs up to 2^66).
fn shl_exact(v: i128, k: i32) -> Option<i128> {
    if !(0..100).contains(&k) {
        return None;
    }
    let r = v.checked_mul(1i128 << k)?;
    (r.unsigned_abs() < 1u128 << 100).then_some(r)
}

/// Binary operation kinds for range computation.
#[derive(Clone, Copy, Debug)]
enum Bin {
    Add,
    Sub,
    Mul,
    Min,
    Max,
    /// Both operands kept (select, compare): the range is their hull.
    Hull,
}

impl Bin {
    fn range(self, (al, ah): (i128, i128), (bl, bh): (i128, i128)) -> (i128, i128) {
        match self {
            Bin::Add => (al + bl, ah + bh),
            Bin::Sub => (al - bh, ah - bl),
            Bin::Mul => {
                let c = [al * bl, al * bh, ah * bl, ah * bh];
                (
                    c.iter().copied().min().unwrap_or(0),
                    c.iter().copied().max().unwrap_or(0),
                )
            }
            Bin::Min => (al.min(bl), ah.min(bh)),
            Bin::Max => (al.max(bl), ah.max(bh)),
            Bin::Hull => (al.min(bl), ah.max(bh)),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::{compile_str, Target};

    const SPEC: &str = r#"controller c {
        period 0.01 "s";
        rounding floor;
        input a: [0.0, 1.05];
        state t: [0.0, 1.7174183932661489] = 0.8587091966330744;
        output y;
        step {
            let l0 = min(t * t, t * t);
            let q = (if a < a { -3.405 } else { 0.0 }) + 1.362;
            t = t;
            y = q + l0;
        }
    }"#;

    fn summary(name: &str) -> crate::lower::SigSummary {
        let plan = compile_str(SPEC, &Target::default()).expect("compiles");
        let i = plan
            .prog
            .signals
            .iter()
            .position(|s| s.name == name)
            .expect("signal");
        plan.summary[i].clone()
    }

    /// Found by random_specs: the unranged output's format came from a pass in which the
    /// constants had no binary point to inherit, so it held up to 4 while the final pass
    /// stored up to 4.31 (silently saturated).
    #[test]
    fn an_unranged_output_format_holds_what_it_receives() {
        let y = summary("y");
        let hi = 1.362 + 1.7174183932661489f64.powi(2);
        assert!(y.range.1 >= hi - 1e-6, "{:?}", y.range);
        let raw = y.format.raw_ceil(hi);
        assert!(y.format.ty.holds(raw, raw), "{} cannot hold {hi}", y.format);
    }

    /// A `let` made of constants only keeps the word's precision, not an integer's.
    #[test]
    fn a_constant_only_let_is_not_rounded_to_an_integer() {
        let q = summary("q");
        assert!(q.err < 1e-8, "error bound {}", q.err);
        assert!((q.range.0 - (-3.405 + 1.362)).abs() < 1e-8, "{:?}", q.range);
    }

    /// A store whose value has far fewer fraction bits than the target (here 1e300 times a
    /// 12-bit value into a 14-bit state: ~1000 bits apart) is refused with a located error;
    /// the pre-clamp at the value's own binary point used to shift an `i128` by that many
    /// bits (found by `codegen/tests/random_specs.rs`).
    #[test]
    fn a_store_from_a_vastly_coarser_value_is_refused_not_a_panic() {
        let src = include_str!("../../../../verified/specs/acc_fixed_gain.qloop");
        let src = src.replace("u += KC * e;", "u += 1e300 * KC * e;");
        assert_ne!(
            src,
            include_str!("../../../../verified/specs/acc_fixed_gain.qloop")
        );
        let e = crate::compile_str(&src, &Target::default()).unwrap_err();
        assert!(e.message.contains("more than 64 bits"), "{}", e.message);
    }

    /// A gain times a unit conversion, `(f·n · 157.08) · (1/60000)` (issue 15's power
    /// estimate), becomes one constant multiplication by their product: one network with
    /// fewer adders than the two (12 + 8 before), and an error bound within 1 % of the two in
    /// sequence; a chain whose fold would lose precision (`0.333333 · s · 1e-6`, where only
    /// the second factor's fine grid keeps the product exact) stays a sequence.
    #[test]
    fn a_chain_of_constant_factors_becomes_one_where_the_bound_allows() {
        let spec = |body: &str| {
            format!(
                "controller c {{ period 0.1 \"s\"; word 16; input f: [0.0, 5.0]; \
                 input n: [100.0, 1000.0]; input s: [-1000.0, 1000.0]; \
                 state ff: [0.0, 5.0] = 0.0; output y; step {{ {body} }} }}"
            )
        };
        let plan = compile_str(
            &spec("ff += 0.5 * (f - ff); y = ff * n * 157.07963 * 0.000016666666666666667;"),
            &Target::default(),
        )
        .expect("compiles");
        // ff carries the filter's rounding error, which the fold's quantisation adds ≤ 1 % to.
        let m = plan
            .mults
            .iter()
            .find(|m| m.constant != 0.5)
            .expect("the folded product");
        assert_eq!(plan.mults.len(), 2, "{:?}", plan.mults);
        assert_eq!(m.constant, 157.07963 * 0.000016666666666666667);
        assert!(m.adders < 20, "{} adders", m.adders);
        let plan = compile_str(&spec("y = 0.333333 * s * 0.000001;"), &Target::default())
            .expect("compiles");
        assert_eq!(plan.mults.len(), 2, "{:?}", plan.mults);
    }
}
