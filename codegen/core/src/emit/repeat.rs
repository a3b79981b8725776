//! Loops kept as loops (issue 37, item 3): the copies of a `for` body that the expander
//! unrolled ([`crate::lang::expand`]) and that compute the same operations, found again in
//! the plan, so that the emitters write the body once, as a function called once per index
//! on rows of the state.
//!
//! The plan stays unrolled: range analysis, formats, the interpreter and the SMT proofs see
//! every index, so every copy's facts are proved. What this module finds is where the
//! emitted text may share one body, and it is strict about when:
//!
//! * **The same operations.** A run of top-level statements of the step splits into `count`
//!   consecutive copies, and each copy matches the first statement by statement: the same
//!   operation, type, binary point, constants, shift amounts, tables and flags. Only the
//!   values' proved intervals may differ; the shared body is emitted with each value's
//!   interval the hull of its copies' ([`Emit::plan`]), so every choice an emitter takes
//!   from an interval (a byte-split shift, a 32-bit helper) is valid for every copy.
//! * **Rows of the state.** Copy `l` reads and writes the elements of a state vector or
//!   matrix at leading index `lead + l` where the first copy uses `lead` (`thf[l][j]`,
//!   `hist[l + 1][j]`), one row per group and copy, so the copies touch disjoint elements and
//!   the function can take the row by reference.
//! * **Everything else from before the run, read only.** A value defined before the run
//!   (an input, a shared `let`) is passed by value; a signal every copy reads at the same
//!   element is passed by value, and no copy may store it. No value a copy defines is read
//!   after the run or by another copy.
//!
//! Anything else stays unrolled. A body shorter than [`MIN_BODY`] statements stays
//! unrolled too: there a call costs more than the text it saves.

use crate::ir::{SigId, SigKind};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use std::collections::{BTreeSet, HashMap, HashSet};

/// The fewest statements (counted with nested ones) a copy must have to be shared: a short
/// body is cheaper unrolled than called.
pub const MIN_BODY: usize = 64;

/// Candidate periods tried at one position: the later statements from the same spec line,
/// and as many of those that follow another line.
const CANDIDATES: usize = 32;

/// One run of copies of a body.
#[derive(Clone, Debug)]
pub struct Repeat {
    /// Index in [`Plan::body`] of the first statement of the first copy.
    pub start: usize,
    /// Top-level statements per copy.
    pub len: usize,
    /// Copies (the trip count).
    pub count: usize,
    /// The rows of state the body reads or writes, in order of first use.
    pub rows: Vec<Row>,
    /// What the body reads from before the run, in order of first use.
    pub params: Vec<Param>,
    /// The first and last spec lines of the body.
    pub lines: (usize, usize),
    /// For each copy after the first, its values mapped to the first copy's.
    pub maps: Vec<HashMap<ValId, ValId>>,
}

/// A state vector or matrix the body uses one row of per copy: `G[lead + l][..]` in copy `l`.
#[derive(Clone, Debug)]
pub struct Row {
    /// The group's declared name.
    pub group: String,
    /// The leading index of the first copy's row.
    pub lead: usize,
    /// The group's dimensions (the leading one first).
    pub dims: Vec<usize>,
    /// The first copy's elements the body reads or writes, in order of first use.
    pub elems: Vec<SigId>,
    /// Those of them the body stores.
    pub stored: BTreeSet<SigId>,
}

/// A value the body reads from before the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// A value of the plan defined before the run.
    Val(ValId),
    /// A signal every copy loads at the same element and none stores: its value at the run.
    Sig(SigId),
}

impl Repeat {
    /// The statements of copy `l` in [`Plan::body`].
    pub fn copy(&self, l: usize) -> std::ops::Range<usize> {
        let s = self.start + l * self.len;
        s..s + self.len
    }

    /// The statements of the whole run in [`Plan::body`].
    pub fn run(&self) -> std::ops::Range<usize> {
        self.start..self.start + self.len * self.count
    }

    /// The first copy's statements: the shared body.
    pub fn body<'p>(&self, plan: &'p Plan) -> &'p [LStmt] {
        &plan.body[self.copy(0)]
    }

    /// The signals passed by value ([`Param::Sig`]).
    pub fn shared(&self) -> impl Iterator<Item = SigId> + '_ {
        self.params.iter().filter_map(|p| match p {
            Param::Sig(s) => Some(*s),
            Param::Val(_) => None,
        })
    }

    /// The element of copy `l` at the first copy's element `s0` of row `row`.
    pub fn elem_of(&self, plan: &Plan, row: &Row, s0: SigId, l: usize) -> Option<SigId> {
        let e = plan.prog.sig(s0).elem.as_ref()?;
        let mut index = e.index.clone();
        index[0] = row.lead + l;
        element(plan, &row.group, &index)
    }
}

/// The plan the emitters read where they share bodies, and the runs they share.
#[derive(Clone, Debug)]
pub struct Emit {
    /// `plan` with each shared value's interval the hull of its copies' (the interval the
    /// shared body's code must hold for), in every copy: the emitters read ranges from here.
    pub plan: Plan,
    /// The runs, in body order.
    pub repeats: Vec<Repeat>,
}

/// The runs of `plan` to share, and the plan with hulled intervals to emit them from.
pub fn emit(plan: &Plan) -> Emit {
    let repeats = find(plan);
    let mut p = plan.clone();
    for r in &repeats {
        let mut hull: HashMap<ValId, (i128, i128)> = HashMap::new();
        for map in &r.maps {
            for (&vl, &v0) in map {
                let (a, b) = (plan.val(vl), plan.val(v0));
                let h = hull.entry(v0).or_insert((b.lo, b.hi));
                *h = (h.0.min(a.lo), h.1.max(a.hi));
            }
        }
        // Every copy's values get the hull, so that a choice made from any copy's interval
        // (a helper the C needs, a Kani box) is the shared body's.
        for map in &r.maps {
            for (&vl, &v0) in map {
                let (lo, hi) = hull[&v0];
                for v in [vl, v0] {
                    p.vals[v.0].lo = lo;
                    p.vals[v.0].hi = hi;
                }
            }
        }
    }
    Emit { plan: p, repeats }
}

impl Emit {
    /// The run starting at top-level statement `i`, if any.
    pub fn at(&self, i: usize) -> Option<&Repeat> {
        self.repeats.iter().find(|r| r.start == i)
    }

    /// The statements emitted as text: the top-level ones outside every run, and each run's
    /// shared body once.
    pub fn emitted(&self) -> Vec<&LStmt> {
        let b = &self.plan.body;
        let mut out: Vec<&LStmt> = Vec::new();
        for (i, s) in b.iter().enumerate() {
            if let Some(r) = self.repeats.iter().find(|r| r.run().contains(&i)) {
                if r.copy(0).contains(&i) {
                    out.push(s);
                }
            } else {
                out.push(s);
            }
        }
        out
    }

    /// The step's products of two non-constant values that appear in the emitted text
    /// ([`Plan::var_products`] without the copies after the first).
    pub fn var_products(&self) -> Vec<ValId> {
        let shared: HashSet<ValId> = self
            .repeats
            .iter()
            .flat_map(|r| r.maps.iter().flat_map(|m| m.keys().copied()))
            .collect();
        self.plan
            .var_products()
            .into_iter()
            .filter(|v| !shared.contains(v))
            .collect()
    }

    /// The first copy's value that value `v` of a later copy is computed by, or `v`.
    pub fn representative(&self, v: ValId) -> ValId {
        self.repeats
            .iter()
            .find_map(|r| r.maps.iter().find_map(|m| m.get(&v).copied()))
            .unwrap_or(v)
    }

    /// Where the step's state locals and the state struct must be brought together around
    /// the calls. The step keeps every state in a local; a call reads and writes rows of
    /// the struct. So before run `k`, the locals of its rows that an earlier statement
    /// changed are written to the struct ([`Sync::before`]); after it, the locals of the
    /// elements it stored are read again from the struct where a later statement uses them
    /// ([`Sync::after`]); and at the end of the step, the elements a call stored and
    /// nothing read again are not written back from their (stale) locals
    /// ([`Sync::current`]).
    pub fn sync(&self) -> Sync {
        let body = &self.plan.body;
        let mut before = Vec::new();
        let mut after = Vec::new();
        // States whose local is newer than the struct; states whose struct is newer.
        let mut local: HashSet<SigId> = HashSet::new();
        let mut current: HashSet<SigId> = HashSet::new();
        // States the step's own text names (outside the calls).
        let mut named: HashSet<SigId> = HashSet::new();
        let mut i = 0;
        while i < body.len() {
            let Some(r) = self.at(i) else {
                touched(&self.plan, &body[i..=i], &mut |sig, store| {
                    if store {
                        local.insert(sig);
                        current.remove(&sig);
                    }
                    named.insert(sig);
                });
                i += 1;
                continue;
            };
            named.extend(r.shared());
            // Every copy's elements of the rows (or those the body stores).
            let elems = |stored: bool| {
                let mut v = Vec::new();
                for row in &r.rows {
                    let of: Vec<SigId> = if stored {
                        row.stored.iter().copied().collect()
                    } else {
                        row.elems.clone()
                    };
                    for l in 0..r.count {
                        v.extend(of.iter().filter_map(|s| r.elem_of(&self.plan, row, *s, l)));
                    }
                }
                v
            };
            let b: Vec<SigId> = elems(false)
                .into_iter()
                .filter(|e| local.remove(e))
                .collect();
            named.extend(b.iter().copied());
            before.push(b);
            // Used after the run from the step's locals: loaded or stored by a later
            // statement outside the runs, or passed by value to a later run (a later run's
            // rows read the struct, which is current).
            let mut used = HashSet::new();
            let mut j = r.run().end;
            while j < body.len() {
                if let Some(later) = self.at(j) {
                    used.extend(later.shared());
                    j = later.run().end;
                    continue;
                }
                touched(&self.plan, &body[j..=j], &mut |sig, _| {
                    used.insert(sig);
                });
                j += 1;
            }
            let mut a = Vec::new();
            for e in elems(true) {
                if used.contains(&e) {
                    current.remove(&e);
                    a.push(e);
                } else {
                    current.insert(e);
                }
            }
            named.extend(a.iter().copied());
            after.push(a);
            i = r.run().end;
        }
        let unnamed = current
            .iter()
            .filter(|s| !named.contains(s))
            .copied()
            .collect();
        Sync {
            before,
            after,
            current,
            unnamed,
        }
    }
}

/// The writes and reads between the step's state locals and the struct around the calls
/// ([`Emit::sync`]).
#[derive(Clone, Debug, Default)]
pub struct Sync {
    /// Per run: the locals to write to the struct before the call.
    pub before: Vec<Vec<SigId>>,
    /// Per run: the locals to read again from the struct after the call.
    pub after: Vec<Vec<SigId>>,
    /// The states whose struct element is current at the end of the step (a call stored it
    /// and no later statement used it): the step does not write their locals back.
    pub current: HashSet<SigId>,
    /// Those of them the step's text never names: it declares no local for them.
    pub unnamed: HashSet<SigId>,
}

/// Calls `f` on every statement of `stmts`, nested ones included.
fn walk<'a>(stmts: &'a [LStmt], f: &mut impl FnMut(&'a LStmt)) {
    for s in stmts {
        f(s);
        if let LStmt::If(_, t, e) = s {
            walk(t, f);
            walk(e, f);
        }
    }
}

/// Calls `f(signal, stored)` for every signal `stmts` (nested ones included) load or store.
fn touched(plan: &Plan, stmts: &[LStmt], f: &mut impl FnMut(SigId, bool)) {
    walk(stmts, &mut |s| match s {
        LStmt::Store(sig, _) => f(*sig, true),
        LStmt::Def(v) => {
            if let Op::Load(sig) = plan.val(*v).op {
                f(sig, false);
            }
        }
        LStmt::If(..) => {}
    });
}

/// The spec line of a statement.
fn line(plan: &Plan, s: &LStmt) -> usize {
    match s {
        LStmt::Def(v) | LStmt::Store(_, v) | LStmt::If(v, ..) => plan.val(*v).line,
    }
}

/// The signal of element `index` of group `group`.
fn element(plan: &Plan, group: &str, index: &[usize]) -> Option<SigId> {
    plan.prog
        .signals
        .iter()
        .position(|s| {
            s.elem
                .as_ref()
                .is_some_and(|e| e.group == group && e.index == index)
        })
        .map(SigId)
}

/// Statements of `stmts`, nested ones included.
fn size(stmts: &[LStmt]) -> usize {
    let mut n = 0;
    walk(stmts, &mut |_| n += 1);
    n
}

/// The runs of `plan`'s top-level statements that may share one body.
pub fn find(plan: &Plan) -> Vec<Repeat> {
    let body = &plan.body;
    let n = body.len();
    let lines: Vec<usize> = body.iter().map(|s| line(plan, s)).collect();
    // Later positions of each line, for the candidate periods.
    let mut at: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, l) in lines.iter().enumerate() {
        at.entry(*l).or_default().push(i);
    }
    let mut out = Vec::new();
    let mut i = 0;
    while i < n {
        let mut best: Option<Repeat> = None;
        // The next positions of the line, and the next where it starts again after another
        // line (a copy's first statement, past the rest of this copy's statements of the
        // same line: a body line lowered to more than `CANDIDATES` statements).
        let starts = |k: usize| k == 0 || lines[k - 1] != lines[k];
        let next = at[&lines[i]].iter().copied().filter(|&j| j > i);
        let mut later: Vec<usize> = next.clone().take(CANDIDATES).collect();
        if starts(i) {
            later.extend(
                next.filter(|&j| starts(j))
                    .take(CANDIDATES)
                    .filter(|j| !later.contains(j))
                    .collect::<Vec<_>>(),
            );
            later.sort_unstable();
        }
        for j in later {
            let q = j - i;
            if i + 2 * q > n {
                break;
            }
            let mut count = 1;
            while i + (count + 1) * q <= n
                && lines[i..i + q] == lines[i + count * q..i + (count + 1) * q]
            {
                count += 1;
            }
            if count < 2 || best.as_ref().is_some_and(|b| b.len * b.count >= q * count) {
                continue;
            }
            if size(&body[i..i + q]) < MIN_BODY {
                continue;
            }
            if let Some(r) = matched(plan, i, q, count) {
                best = Some(r);
            }
        }
        match best {
            Some(r) => {
                i = r.run().end;
                out.push(r);
            }
            None => i += 1,
        }
    }
    out
}

/// The longest run of `2..=count` copies of `body[start..start + len]` that may share it.
fn matched(plan: &Plan, start: usize, len: usize, count: usize) -> Option<Repeat> {
    let mut count = count;
    loop {
        if count < 2 {
            return None;
        }
        match check(plan, start, len, count) {
            Ok(r) => return Some(r),
            // Copy `k` does not match: try the copies before it.
            Err(Some(k)) if k < count => count = k,
            Err(_) => return None,
        }
    }
}

/// The run of `count` copies, or `Err(Some(k))` if copy `k` is the first that does not
/// match, `Err(None)` if the run as a whole cannot be shared.
fn check(plan: &Plan, start: usize, len: usize, count: usize) -> Result<Repeat, Option<usize>> {
    let body = &plan.body;
    let end = start + len * count;
    let mut run_defs: HashSet<ValId> = HashSet::new();
    let mut run_stored: HashSet<SigId> = HashSet::new();
    walk(&body[start..end], &mut |s| match s {
        LStmt::Def(v) => {
            run_defs.insert(*v);
        }
        LStmt::Store(sig, _) => {
            run_stored.insert(*sig);
        }
        LStmt::If(..) => {}
    });
    let mut m = Matcher {
        plan,
        run_defs: &run_defs,
        l: 0,
        map: HashMap::new(),
        rows: Vec::new(),
        params: Vec::new(),
        shared: BTreeSet::new(),
    };
    let first = &body[start..start + len];
    let mut maps = Vec::new();
    for l in 1..count {
        m.l = l;
        m.map.clear();
        let copy = &body[start + l * len..start + (l + 1) * len];
        if !m.stmts(first, copy) {
            return Err(Some(l));
        }
        maps.push(std::mem::take(&mut m.map));
    }
    // Signals read at one element by every copy: no copy may write them, and none may be
    // an element of the first copy's rows too (the function would have a parameter and a
    // row local of one name, and copy `l` would read its own row where the plan reads the
    // first's).
    if m.shared
        .iter()
        .any(|s| run_stored.contains(s) || m.rows.iter().any(|r| r.elems.contains(s)))
    {
        return Err(None);
    }
    // Nothing a copy defines is read after the run.
    let mut leaks = false;
    walk(&body[end..], &mut |s| {
        let reads = match s {
            LStmt::Def(v) => plan.val(*v).op.operands(),
            LStmt::Store(_, v) | LStmt::If(v, ..) => vec![*v],
        };
        leaks |= reads.iter().any(|v| run_defs.contains(v));
    });
    if leaks {
        return Err(None);
    }
    // A body that writes no row has no effect the call could carry out.
    if m.rows.is_empty() {
        return Err(None);
    }
    // Every row of every copy lies inside its group.
    for r in &m.rows {
        if r.lead + count > r.dims[0] {
            return Err(None);
        }
    }
    let mut lines = (usize::MAX, 0);
    walk(first, &mut |s| {
        let l = line(plan, s);
        if l > 0 {
            lines = (lines.0.min(l), lines.1.max(l));
        }
    });
    if lines.0 == usize::MAX {
        lines = (0, 0);
    }
    // Row elements in their declared order (the emitted loads read better so).
    let flat = |s: &SigId| plan.prog.sig(*s).elem.as_ref().map_or(0, |e| e.flat());
    for r in &mut m.rows {
        r.elems.sort_by_key(flat);
    }
    Ok(Repeat {
        start,
        len,
        count,
        rows: m.rows,
        params: m.params,
        lines,
        maps,
    })
}

/// Matches copy `l` against the first, statement by statement.
struct Matcher<'a> {
    plan: &'a Plan,
    run_defs: &'a HashSet<ValId>,
    /// The copy being matched.
    l: usize,
    /// Its values defined so far, mapped to the first copy's.
    map: HashMap<ValId, ValId>,
    rows: Vec<Row>,
    params: Vec<Param>,
    /// Signals loaded at the same element by every copy.
    shared: BTreeSet<SigId>,
}

impl Matcher<'_> {
    fn stmts(&mut self, a: &[LStmt], b: &[LStmt]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| self.stmt(x, y))
    }

    fn stmt(&mut self, a: &LStmt, b: &LStmt) -> bool {
        match (a, b) {
            (LStmt::Def(x), LStmt::Def(y)) => {
                if !self.val(*x, *y) {
                    return false;
                }
                self.map.insert(*y, *x);
                true
            }
            (LStmt::Store(s, x), LStmt::Store(t, y)) => {
                self.sig(*s, *t, true) && self.operand(*x, *y)
            }
            (LStmt::If(c, t0, e0), LStmt::If(d, t1, e1)) => {
                self.operand(*c, *d) && self.stmts(t0, t1) && self.stmts(e0, e1)
            }
            _ => false,
        }
    }

    /// Whether value `y` of copy `l` is computed as value `x` of the first copy.
    fn val(&mut self, x: ValId, y: ValId) -> bool {
        let (a, b) = (self.plan.val(x), self.plan.val(y));
        if a.ty != b.ty || a.frac != b.frac || a.boolean != b.boolean || a.network != b.network {
            return false;
        }
        let ops = |me: &mut Self, p: &[ValId], q: &[ValId]| {
            p.len() == q.len() && p.iter().zip(q).all(|(u, v)| me.operand(*u, *v))
        };
        match (&a.op, &b.op) {
            // The step reads its inputs in its prologue, before any loop; a body that read
            // them itself would need the inputs passed in, which nothing emits.
            (Op::Input(_), _) => false,
            (Op::Load(s), Op::Load(t)) => self.sig(*s, *t, false),
            (Op::Const(c), Op::Const(d)) => c == d,
            (Op::Shl(_, j), Op::Shl(_, k))
            | (Op::Shr(_, j), Op::Shr(_, k))
            | (Op::Low(_, j), Op::Low(_, k))
                if j != k =>
            {
                false
            }
            (Op::Cmp(o, ..), Op::Cmp(p, ..)) if o != p => false,
            (
                Op::Lookup {
                    table: t0,
                    delta: d0,
                    ..
                },
                Op::Lookup {
                    table: t1,
                    delta: d1,
                    ..
                },
            ) if t0 != t1 || d0 != d1 => false,
            (p, q) if std::mem::discriminant(p) == std::mem::discriminant(q) => {
                ops(self, &p.operands(), &q.operands())
            }
            _ => false,
        }
    }

    /// Whether operand `y` of copy `l` stands where the first copy reads `x`.
    fn operand(&mut self, x: ValId, y: ValId) -> bool {
        if let Some(&m) = self.map.get(&y) {
            return m == x;
        }
        // Not this copy's: the same value, from before the run.
        if x != y || self.run_defs.contains(&x) {
            return false;
        }
        if !self.params.contains(&Param::Val(x)) {
            self.params.push(Param::Val(x));
        }
        true
    }

    /// Whether signal `t` of copy `l` stands where the first copy uses `s`.
    fn sig(&mut self, s: SigId, t: SigId, store: bool) -> bool {
        let prog = &self.plan.prog;
        if s == t {
            if store {
                return false;
            }
            self.shared.insert(s);
            if !self.params.contains(&Param::Sig(s)) {
                self.params.push(Param::Sig(s));
            }
            return true;
        }
        let (a, b) = (prog.sig(s), prog.sig(t));
        let (Some(ea), Some(eb)) = (&a.elem, &b.elem) else {
            return false;
        };
        if a.kind != SigKind::State
            || b.kind != SigKind::State
            || ea.group != eb.group
            || ea.index[1..] != eb.index[1..]
            || eb.index[0] != ea.index[0] + self.l
        {
            return false;
        }
        match self.rows.iter_mut().find(|r| r.group == ea.group) {
            Some(r) if r.lead != ea.index[0] => return false,
            Some(r) => {
                if !r.elems.contains(&s) {
                    r.elems.push(s);
                }
                if store {
                    r.stored.insert(s);
                }
            }
            None => self.rows.push(Row {
                group: ea.group.clone(),
                lead: ea.index[0],
                dims: ea.dims.clone(),
                elems: vec![s],
                stored: if store { [s].into() } else { BTreeSet::new() },
            }),
        }
        true
    }
}
