//! Exact integer terms of a step and of property conditions: the algebra shared by the
//! prover's exact-term SMT encodings and the Kani model harnesses.
//!
//! Where no value wraps (the overflow obligations and harnesses prove it), the machine
//! arithmetic of the step equals exact integer arithmetic, so the step is a term over the
//! inputs and pre-states, which admits algebra that bit-level reasoning finds hard:
//!
//! * multiplication distributes over `+`, `-` and `ite` (`(kc + d)·km = kc·km + d·km`), so a
//!   post-state product shares its multipliers with the pre-state terms it came from;
//! * products are put in a canonical operand order, so equal products are one term;
//! * [`Ranges`] gives every term its interval from its variables' ranges.
//!
//! `floor` shifts (`>>`) are kept as they are: the rounding is part of what is proved.

use crate::ir::{CmpOp, PCond, PExpr, Program, SigId, SigKind, When};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use crate::prop_eval::{self, Arith, ExactDomain};
use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::rc::Rc;

/// The exact-term variable of an input (`in_<name>`).
pub fn input_var(prog: &Program, id: SigId) -> String {
    format!("in_{}", prog.sig(id).name)
}

/// The exact-term variable of a state before the step (`pre_<name>`).
pub fn pre_var(prog: &Program, id: SigId) -> String {
    format!("pre_{}", prog.sig(id).name)
}

/// An exact integer term.
///
/// Terms are DAGs (a post-state shares its pre-state subterms), so [`Hash`] reads only the
/// top six levels (`HASH_DEPTH`): a full hash would walk the DAG as a tree, exponential in its
/// depth (a recursive least-squares update through two Newton steps never finished hashing).
/// Equal terms still hash equally; `Eq` decides. For the same reason the order ([`Ord`], the
/// derived one's) answers `Equal` at once for two references to one node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum T {
    /// A declared variable: name, SMT width, signedness, and its assumed raw range.
    Var(String, u32, bool, i128, i128),
    /// A constant.
    Const(i128),
    /// Sum.
    Add(Rc<T>, Rc<T>),
    /// Difference.
    Sub(Rc<T>, Rc<T>),
    /// Negation.
    Neg(Rc<T>),
    /// Product.
    Mul(Rc<T>, Rc<T>),
    /// `a · 2^k`.
    Shl(Rc<T>, u32),
    /// `floor(a / 2^k)`.
    Shr(Rc<T>, u32),
    /// `if c { a } else { b }`.
    Ite(Rc<B>, Rc<T>, Rc<T>),
    /// Linear normal form `Σ cᵢ·aᵢ + c`: atoms sorted, merged, none zero.
    Sum(Vec<(i128, Rc<T>)>, i128),
}

/// A linear combination of atoms, as a map, and a constant.
type Lin = (BTreeMap<Rc<T>, i128>, i128);

/// The linear normal form of `t`.
fn lin(t: &Rc<T>) -> Lin {
    let mut m: BTreeMap<Rc<T>, i128> = BTreeMap::new();
    match &**t {
        T::Const(c) => return (m, *c),
        T::Sum(terms, c) => {
            for (k, a) in terms {
                *m.entry(a.clone()).or_insert(0) += k;
            }
            return (m, *c);
        }
        T::Add(a, b) | T::Sub(a, b) => {
            let (ma, ca) = lin(a);
            let (mb, cb) = lin(b);
            let sign = if matches!(**t, T::Sub(..)) { -1 } else { 1 };
            m = ma;
            for (k, v) in mb {
                *m.entry(k).or_insert(0) += sign * v;
            }
            return (m, ca + sign * cb);
        }
        T::Neg(a) => {
            let (ma, ca) = lin(a);
            return (ma.into_iter().map(|(k, v)| (k, -v)).collect(), -ca);
        }
        T::Shl(a, k) => {
            let (ma, ca) = lin(a);
            return (ma.into_iter().map(|(x, v)| (x, v << k)).collect(), ca << k);
        }
        _ => {}
    }
    m.insert(t.clone(), 1);
    (m, 0)
}

/// `s` where the sum `Σ kᵢ·aᵢ + c` is `x − 2^s·⌊x/2^s⌋` exactly, for some term `x`: one
/// atom is `⌊x/2^s⌋` with coefficient `−2^s`, and the rest is `x`'s linear form.
fn low_bits(terms: &[(i128, Rc<T>)], c: i128) -> Option<u32> {
    terms.iter().enumerate().find_map(|(i, (k, a))| {
        let T::Shr(x, s) = &**a else { return None };
        if *s == 0 || *s >= 100 || *k != -(1i128 << s) {
            return None;
        }
        let (mx, cx) = lin(x);
        let mut rest: BTreeMap<Rc<T>, i128> = BTreeMap::new();
        for (j, (kj, aj)) in terms.iter().enumerate() {
            if j != i {
                *rest.entry(aj.clone()).or_insert(0) += kj;
            }
        }
        rest.retain(|_, v| *v != 0);
        let mx: BTreeMap<Rc<T>, i128> = mx.into_iter().filter(|(_, v)| *v != 0).collect();
        (rest == mx && cx == c).then_some(*s)
    })
}

/// The term of a linear combination.
fn from_lin((m, c): Lin) -> Rc<T> {
    let terms: Vec<(i128, Rc<T>)> = m
        .into_iter()
        .filter(|(_, k)| *k != 0)
        .map(|(a, k)| (k, a))
        .collect();
    match terms.as_slice() {
        [] => Rc::new(T::Const(c)),
        [(1, a)] if c == 0 => a.clone(),
        _ => Rc::new(T::Sum(terms, c)),
    }
}

/// An exact boolean term (hashed to a bounded depth and ordered with shared nodes, as [`T`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum B {
    /// Comparison.
    Cmp(CmpOp, Rc<T>, Rc<T>),
    /// Conjunction.
    And(Rc<B>, Rc<B>),
    /// Disjunction.
    Or(Rc<B>, Rc<B>),
    /// Negation.
    Not(Rc<B>),
}

/// `a` against `b`, `Equal` at once when they are one node.
fn rc_cmp<X: Ord>(a: &Rc<X>, b: &Rc<X>) -> Ordering {
    if Rc::ptr_eq(a, b) {
        Ordering::Equal
    } else {
        (**a).cmp(&**b)
    }
}

impl T {
    /// The variant's position in the declaration (the derived order's first key).
    fn rank(&self) -> u8 {
        match self {
            T::Var(..) => 0,
            T::Const(_) => 1,
            T::Add(..) => 2,
            T::Sub(..) => 3,
            T::Neg(_) => 4,
            T::Mul(..) => 5,
            T::Shl(..) => 6,
            T::Shr(..) => 7,
            T::Ite(..) => 8,
            T::Sum(..) => 9,
        }
    }
}

impl PartialOrd for T {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// The order `#[derive(Ord)]` would give (variant, then fields in order, sequences
/// lexicographically), with shared nodes compared by address first.
impl Ord for T {
    fn cmp(&self, o: &Self) -> Ordering {
        if std::ptr::eq(self, o) {
            return Ordering::Equal;
        }
        match (self, o) {
            (T::Var(n, w, s, l, h), T::Var(n2, w2, s2, l2, h2)) => {
                (n, w, s, l, h).cmp(&(n2, w2, s2, l2, h2))
            }
            (T::Const(a), T::Const(b)) => a.cmp(b),
            (T::Add(a, b), T::Add(a2, b2))
            | (T::Sub(a, b), T::Sub(a2, b2))
            | (T::Mul(a, b), T::Mul(a2, b2)) => rc_cmp(a, a2).then_with(|| rc_cmp(b, b2)),
            (T::Neg(a), T::Neg(a2)) => rc_cmp(a, a2),
            (T::Shl(a, k), T::Shl(a2, k2)) | (T::Shr(a, k), T::Shr(a2, k2)) => {
                rc_cmp(a, a2).then_with(|| k.cmp(k2))
            }
            (T::Ite(c, a, b), T::Ite(c2, a2, b2)) => rc_cmp(c, c2)
                .then_with(|| rc_cmp(a, a2))
                .then_with(|| rc_cmp(b, b2)),
            (T::Sum(v, c), T::Sum(v2, c2)) => v
                .iter()
                .zip(v2)
                .map(|((k, a), (k2, a2))| k.cmp(k2).then_with(|| rc_cmp(a, a2)))
                .find(|x| x.is_ne())
                .unwrap_or_else(|| v.len().cmp(&v2.len()))
                .then_with(|| c.cmp(c2)),
            _ => self.rank().cmp(&o.rank()),
        }
    }
}

impl B {
    /// The variant's position in the declaration.
    fn rank(&self) -> u8 {
        match self {
            B::Cmp(..) => 0,
            B::And(..) => 1,
            B::Or(..) => 2,
            B::Not(_) => 3,
        }
    }
}

impl PartialOrd for B {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// As for [`T`]: the derived order, shared nodes first.
impl Ord for B {
    fn cmp(&self, o: &Self) -> Ordering {
        if std::ptr::eq(self, o) {
            return Ordering::Equal;
        }
        match (self, o) {
            (B::Cmp(op, a, b), B::Cmp(op2, a2, b2)) => op
                .cmp(op2)
                .then_with(|| rc_cmp(a, a2))
                .then_with(|| rc_cmp(b, b2)),
            (B::And(a, b), B::And(a2, b2)) | (B::Or(a, b), B::Or(a2, b2)) => {
                rc_cmp(a, a2).then_with(|| rc_cmp(b, b2))
            }
            (B::Not(a), B::Not(a2)) => rc_cmp(a, a2),
            _ => self.rank().cmp(&o.rank()),
        }
    }
}

/// How many levels of a term its hash reads.
const HASH_DEPTH: u32 = 6;

impl Hash for T {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.hash_to(h, HASH_DEPTH);
    }
}

impl Hash for B {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.hash_to(h, HASH_DEPTH);
    }
}

impl T {
    /// Hashes the top `depth` levels of the term.
    fn hash_to<H: Hasher>(&self, h: &mut H, depth: u32) {
        std::mem::discriminant(self).hash(h);
        match self {
            T::Var(name, w, s, lo, hi) => (name, w, s, lo, hi).hash(h),
            T::Const(c) => c.hash(h),
            _ if depth == 0 => {}
            T::Add(a, b) | T::Sub(a, b) | T::Mul(a, b) => {
                a.hash_to(h, depth - 1);
                b.hash_to(h, depth - 1);
            }
            T::Neg(a) => a.hash_to(h, depth - 1),
            T::Shl(a, k) | T::Shr(a, k) => {
                k.hash(h);
                a.hash_to(h, depth - 1);
            }
            T::Ite(c, a, b) => {
                c.hash_to(h, depth - 1);
                a.hash_to(h, depth - 1);
                b.hash_to(h, depth - 1);
            }
            T::Sum(terms, c) => {
                (terms.len(), c).hash(h);
                for (k, a) in terms {
                    k.hash(h);
                    a.hash_to(h, depth - 1);
                }
            }
        }
    }
}

impl B {
    /// Hashes the top `depth` levels of the term.
    fn hash_to<H: Hasher>(&self, h: &mut H, depth: u32) {
        std::mem::discriminant(self).hash(h);
        if depth == 0 {
            return;
        }
        match self {
            B::Cmp(op, a, b) => {
                std::mem::discriminant(op).hash(h);
                a.hash_to(h, depth - 1);
                b.hash_to(h, depth - 1);
            }
            B::And(a, b) | B::Or(a, b) => {
                a.hash_to(h, depth - 1);
                b.hash_to(h, depth - 1);
            }
            B::Not(a) => a.hash_to(h, depth - 1),
        }
    }
}

/// `a + b` in linear normal form.
pub fn add(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    let (mut m, c) = lin(&a);
    let (mb, cb) = lin(&b);
    for (k, v) in mb {
        *m.entry(k).or_insert(0) += v;
    }
    from_lin((m, c + cb))
}

/// `a - b` in linear normal form.
pub fn sub(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    add(a, neg(b))
}

/// `-a` in linear normal form.
pub fn neg(a: Rc<T>) -> Rc<T> {
    let (m, c) = lin(&a);
    from_lin((m.into_iter().map(|(k, v)| (k, -v)).collect(), -c))
}

/// `a · 2^k` in linear normal form.
pub fn shl(a: Rc<T>, k: u32) -> Rc<T> {
    if k == 0 {
        return a;
    }
    let (m, c) = lin(&a);
    from_lin((m.into_iter().map(|(x, v)| (x, v << k)).collect(), c << k))
}

/// Product, distributed over `+`, `-`, negation and `ite`, with canonical operand order.
pub fn mul(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    if let T::Ite(c, x, y) = &*a {
        return ite(c.clone(), mul(x.clone(), b.clone()), mul(y.clone(), b));
    }
    if let T::Ite(c, x, y) = &*b {
        return ite(c.clone(), mul(a.clone(), x.clone()), mul(a, y.clone()));
    }
    let ((ma, ca), (mb, cb)) = (lin(&a), lin(&b));
    let mut m: BTreeMap<Rc<T>, i128> = BTreeMap::new();
    for (x, kx) in &ma {
        for (y, ky) in &mb {
            *m.entry(product(x.clone(), y.clone())).or_insert(0) += kx * ky;
        }
        if cb != 0 {
            *m.entry(x.clone()).or_insert(0) += kx * cb;
        }
    }
    if ca != 0 {
        for (y, ky) in &mb {
            *m.entry(y.clone()).or_insert(0) += ca * ky;
        }
    }
    from_lin((m, ca * cb))
}

/// The variables a term mentions (not those inside the conditions of its `Ite`s), in order of
/// first appearance; each shared node is visited once.
pub fn vars_of(t: &Rc<T>) -> Vec<Rc<T>> {
    fn go(
        t: &Rc<T>,
        seen: &mut HashSet<*const T>,
        found: &mut BTreeSet<Rc<T>>,
        out: &mut Vec<Rc<T>>,
    ) {
        if !seen.insert(Rc::as_ptr(t)) {
            return;
        }
        match &**t {
            T::Var(..) => {
                if found.insert(t.clone()) {
                    out.push(t.clone());
                }
            }
            T::Const(_) => {}
            T::Add(a, b) | T::Sub(a, b) | T::Mul(a, b) => {
                go(a, seen, found, out);
                go(b, seen, found, out);
            }
            T::Neg(a) | T::Shl(a, _) | T::Shr(a, _) => go(a, seen, found, out),
            T::Ite(_, a, b) => {
                go(a, seen, found, out);
                go(b, seen, found, out);
            }
            T::Sum(terms, _) => {
                for (_, a) in terms {
                    go(a, seen, found, out);
                }
            }
        }
    }
    let mut out = Vec::new();
    go(t, &mut HashSet::new(), &mut BTreeSet::new(), &mut out);
    out
}

/// The names of every variable a condition mentions, those inside nested conditions
/// included; each shared node is visited once.
pub fn var_names(b: &Rc<B>) -> BTreeSet<String> {
    fn t_go(t: &Rc<T>, seen: &mut HashSet<usize>, out: &mut BTreeSet<String>) {
        if !seen.insert(Rc::as_ptr(t) as usize) {
            return;
        }
        match &**t {
            T::Var(n, ..) => {
                out.insert(n.clone());
            }
            T::Const(_) => {}
            T::Add(a, b) | T::Sub(a, b) | T::Mul(a, b) => {
                t_go(a, seen, out);
                t_go(b, seen, out);
            }
            T::Neg(a) | T::Shl(a, _) | T::Shr(a, _) => t_go(a, seen, out),
            T::Ite(c, a, b) => {
                b_go(c, seen, out);
                t_go(a, seen, out);
                t_go(b, seen, out);
            }
            T::Sum(terms, _) => {
                for (_, a) in terms {
                    t_go(a, seen, out);
                }
            }
        }
    }
    fn b_go(b: &Rc<B>, seen: &mut HashSet<usize>, out: &mut BTreeSet<String>) {
        if !seen.insert(Rc::as_ptr(b) as usize) {
            return;
        }
        match &**b {
            B::Cmp(_, x, y) => {
                t_go(x, seen, out);
                t_go(y, seen, out);
            }
            B::And(x, y) | B::Or(x, y) => {
                b_go(x, seen, out);
                b_go(y, seen, out);
            }
            B::Not(x) => b_go(x, seen, out),
        }
    }
    let mut out = BTreeSet::new();
    b_go(b, &mut HashSet::new(), &mut out);
    out
}

/// Whether `t` mentions a variable named in `names`.
pub fn mentions(t: &Rc<T>, names: &[String]) -> bool {
    vars_of(t)
        .iter()
        .any(|v| matches!(&**v, T::Var(n, ..) if names.contains(n)))
}

/// A product of the program ([`Op::Mul`]) or of a property read as the program reads it
/// (`PropTerms::distribute` off): [`mul`], distributed, where a factor is a sum with a product
/// among its terms, so that `a·(b·c − d·e)` (a determinant expanded by minors) is the
/// polynomial `a·b·c − a·d·e` that a property's expansion of the same determinant gives;
/// otherwise one [`product`] node.
pub fn program_product(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    fn polynomial(t: &T) -> bool {
        match t {
            T::Sum(terms, _) => terms.iter().any(|(_, x)| matches!(**x, T::Mul(..))),
            _ => false,
        }
    }
    if polynomial(&a) || polynomial(&b) {
        mul(a, b)
    } else {
        product(a, b)
    }
}

/// Product without distribution, in canonical operand order.
pub fn product(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    match (&*a, &*b) {
        (T::Const(x), T::Const(y)) => Rc::new(T::Const(x * y)),
        (T::Mul(..), _) | (_, T::Mul(..)) => {
            // A monomial of three or more factors: its factors sorted, multiplied left to
            // right, so that a monomial is one term whichever order its factors were
            // multiplied in (a determinant expanded by minors and one by Leibniz's formula
            // give the same polynomial).
            fn factors(t: &Rc<T>, out: &mut Vec<Rc<T>>) {
                match &**t {
                    T::Mul(x, y) => {
                        factors(x, out);
                        factors(y, out);
                    }
                    _ => out.push(t.clone()),
                }
            }
            let mut fs = Vec::new();
            factors(&a, &mut fs);
            factors(&b, &mut fs);
            fs.sort();
            let mut it = fs.into_iter();
            let first = it.next().unwrap_or(a);
            it.fold(first, |acc, f| Rc::new(T::Mul(acc, f)))
        }
        _ if a <= b => Rc::new(T::Mul(a, b)),
        _ => Rc::new(T::Mul(b, a)),
    }
}

/// `if c { a } else { b }`, collapsed when both arms are equal.
pub fn ite(c: Rc<B>, a: Rc<T>, b: Rc<T>) -> Rc<T> {
    if a == b {
        a
    } else {
        Rc::new(T::Ite(c, a, b))
    }
}

/// Exact terms of a plan: every value, and every state/output after the step.
pub struct Terms {
    /// Term of each value (booleans have none).
    pub vals: Vec<Option<Rc<T>>>,
    /// Boolean term of each boolean value.
    pub bools: Vec<Option<Rc<B>>>,
    /// Post-step term of each state and output.
    pub post: BTreeMap<SigId, Rc<T>>,
    /// Pre-step variable of each input and state.
    pub pre: BTreeMap<SigId, Rc<T>>,
    /// The variables standing for cut values ([`terms_cut`]), each with its value's interval.
    pub cuts: Vec<Rc<T>>,
}

/// Builds exact terms for the step. Inputs and states are variables ranging over
/// `ranges[id]` (raw).
pub fn terms(plan: &Plan, ranges: &dyn Fn(SigId) -> (i128, i128)) -> Terms {
    terms_cut(plan, ranges, &|_| false)
}

/// The variable that stands for a cut value in [`terms_cut`]: `cut_<id>`.
pub fn cut_var(id: ValId) -> String {
    format!("cut_{}", id.0)
}

/// Exact terms of the step in which each value that `cut` selects (other than booleans,
/// inputs, loads and constants) is a fresh variable ranging over the value's proved
/// interval, not its definition: a cut point.
///
/// Sound as an over-approximation: on a path that computes the value, its interval holds
/// (an overflow obligation of its own); on a path that does not, the value reaches no
/// post-state (structured branches merge only what they store), so any value of its
/// interval is as good as another. Every behaviour of the step is a behaviour of the cut
/// terms; the converse may fail, so a counterexample must be replayed. What it buys: a
/// product of two cut values stays one product of two variables, where the full terms
/// multiply out whole sub-computations (the determinant of a least-squares covariance after
/// its update) into polynomials beyond any solver, and beyond `i128` intervals.
pub fn terms_cut(
    plan: &Plan,
    ranges: &dyn Fn(SigId) -> (i128, i128),
    cut: &dyn Fn(ValId) -> bool,
) -> Terms {
    let prog = &plan.prog;
    let mut pre = BTreeMap::new();
    let mut env: BTreeMap<SigId, Rc<T>> = BTreeMap::new();
    for (i, s) in prog.signals.iter().enumerate() {
        let id = SigId(i);
        let q = plan.format(id);
        let (lo, hi) = ranges(id);
        match s.kind {
            SigKind::Input => {
                pre.insert(
                    id,
                    Rc::new(T::Var(input_var(prog, id), q.ty.bits, q.ty.signed, lo, hi)),
                );
            }
            // A state confined to one value (the initial state) is that constant: its
            // arithmetic folds here, not in a solver (cvc5 took 9 s to bit-blast the 73
            // products of an initial 5 × 5 determinant held as variables equal to constants).
            SigKind::State if lo == hi => {
                let v = Rc::new(T::Const(lo));
                pre.insert(id, v.clone());
                env.insert(id, v);
            }
            SigKind::State => {
                let v = Rc::new(T::Var(pre_var(prog, id), q.ty.bits, q.ty.signed, lo, hi));
                pre.insert(id, v.clone());
                env.insert(id, v);
            }
            SigKind::Output => {
                env.insert(id, Rc::new(T::Const(0)));
            }
            SigKind::Local => {}
        }
    }
    let mut t = Terms {
        vals: vec![None; plan.vals.len()],
        bools: vec![None; plan.vals.len()],
        post: BTreeMap::new(),
        pre,
        cuts: Vec::new(),
    };
    walk(plan, &plan.body, &mut env, &mut t, cut);
    t.post = env;
    t
}

fn walk(
    plan: &Plan,
    stmts: &[LStmt],
    env: &mut BTreeMap<SigId, Rc<T>>,
    t: &mut Terms,
    cut: &dyn Fn(ValId) -> bool,
) {
    for s in stmts {
        match s {
            LStmt::Def(id) => {
                let v = plan.val(*id);
                let cuttable =
                    !v.boolean && !matches!(v.op, Op::Input(_) | Op::Load(_) | Op::Const(_));
                if cuttable && cut(*id) {
                    let x = Rc::new(T::Var(cut_var(*id), v.ty.bits, v.ty.signed, v.lo, v.hi));
                    t.cuts.push(x.clone());
                    t.vals[id.0] = Some(x);
                } else {
                    def(plan, *id, env, t);
                }
            }
            LStmt::Store(sig, id) => {
                if let Some(v) = &t.vals[id.0] {
                    env.insert(*sig, v.clone());
                }
            }
            LStmt::If(c, a, b) => {
                let mut ea = env.clone();
                walk(plan, a, &mut ea, t, cut);
                let mut eb = env.clone();
                walk(plan, b, &mut eb, t, cut);
                let cond = t.bools[c.0]
                    .clone()
                    .unwrap_or_else(|| Rc::new(B::Not(Rc::new(B::Cmp(CmpOp::Eq, zero(), zero())))));
                for (sig, ta) in ea {
                    let tb = eb.get(&sig).cloned().unwrap_or_else(|| ta.clone());
                    env.insert(sig, ite(cond.clone(), ta, tb));
                }
            }
        }
    }
}

fn zero() -> Rc<T> {
    Rc::new(T::Const(0))
}

fn def(plan: &Plan, id: ValId, env: &BTreeMap<SigId, Rc<T>>, t: &mut Terms) {
    let v = plan.val(id);
    let g = |x: &ValId| t.vals[x.0].clone().unwrap_or_else(zero);
    let gb = |x: &ValId| {
        t.bools[x.0]
            .clone()
            .unwrap_or_else(|| Rc::new(B::Cmp(CmpOp::Eq, zero(), zero())))
    };
    if v.boolean {
        let b = match &v.op {
            Op::Cmp(op, a, b) => B::Cmp(*op, g(a), g(b)),
            Op::And(a, b) => B::And(gb(a), gb(b)),
            Op::Or(a, b) => B::Or(gb(a), gb(b)),
            Op::Not(a) => B::Not(gb(a)),
            _ => B::Cmp(CmpOp::Eq, zero(), zero()),
        };
        t.bools[id.0] = Some(Rc::new(b));
        return;
    }
    let e = match &v.op {
        Op::Input(s) => t.pre[s].clone(),
        Op::Load(s) => env[s].clone(),
        Op::Const(c) => Rc::new(T::Const(*c)),
        Op::Cast(a) => g(a),
        Op::Add(a, b) => add(g(a), g(b)),
        Op::Sub(a, b) => sub(g(a), g(b)),
        Op::Neg(a) => neg(g(a)),
        Op::Shl(a, k) => shl(g(a), *k),
        Op::Shr(a, k) => Rc::new(T::Shr(g(a), *k)),
        // The program's own products stay single terms (canonical order only): distributing
        // them hides simple arguments such as a product's sign. A factor that is itself a
        // sum of products (a minor of a `det` expanded by minors) is distributed over
        // ([`program_product`]), as a property's product is.
        Op::Mul(a, b) => program_product(g(a), g(b)),
        // `lower::lir::mul_hi`: h(x) = x >> 16, l(x) = x − (h(x) << 16).
        Op::MulHi(a, b) => {
            let h = |x: Rc<T>| Rc::new(T::Shr(x, 16));
            let l = |x: Rc<T>| sub(x.clone(), shl(h(x), 16));
            let (ha, hb) = (h(g(a)), h(g(b)));
            // Pieces as single products (never distributed: the halves of a sum of products
            // multiplied out would be polynomials of a degree the interval encodings cannot
            // size).
            let hl = Rc::new(T::Shr(product(ha.clone(), l(g(b))), 16));
            let lh = Rc::new(T::Shr(product(l(g(a)), hb.clone()), 16));
            add(add(product(ha, hb), hl), lh)
        }
        Op::Min(a, b) => ite(Rc::new(B::Cmp(CmpOp::Lt, g(a), g(b))), g(a), g(b)),
        Op::Max(a, b) => ite(Rc::new(B::Cmp(CmpOp::Lt, g(a), g(b))), g(b), g(a)),
        Op::Select(c, a, b) => ite(gb(c), g(a), g(b)),
        Op::Cmp(..) | Op::And(..) | Op::Or(..) | Op::Not(..) => zero(),
        // a mod 2^k for a ≥ 0: a − ((a >> k) << k).
        Op::Low(a, k) => sub(g(a), shl(Rc::new(T::Shr(g(a), *k)), *k)),
        Op::Lookup { table, delta, idx } => {
            let lt = &plan.tables[*table];
            let arr = if *delta { &lt.deltas } else { &lt.entries };
            let iv = plan.val(*idx);
            let lo = iv.lo.max(0) as usize;
            let hi = (iv.hi.max(0) as usize).min(arr.len() - 1);
            lookup_tree(&g(idx), arr, lo, hi)
        }
    };
    t.vals[id.0] = Some(e);
}

/// `arr[i]` for `i` in `lo..=hi` as a balanced tree of `ite(i < mid, .., ..)`.
fn lookup_tree(i: &Rc<T>, arr: &[i128], lo: usize, hi: usize) -> Rc<T> {
    if lo >= hi {
        return Rc::new(T::Const(arr[lo.min(arr.len() - 1)]));
    }
    let mid = (lo + hi).div_ceil(2);
    ite(
        Rc::new(B::Cmp(CmpOp::Lt, i.clone(), Rc::new(T::Const(mid as i128)))),
        lookup_tree(i, arr, lo, mid - 1),
        lookup_tree(i, arr, mid, hi),
    )
}

/// A property value: exact term at a binary point.
#[derive(Clone)]
pub struct Fx {
    t: Rc<T>,
    frac: i32,
}

fn align(a: Fx, f: i32) -> Rc<T> {
    shl(a.t, (f - a.frac).max(0) as u32)
}

/// Property expressions over exact terms.
pub struct PropTerms<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Step terms.
    pub terms: &'a Terms,
    /// Free parameters: variable terms and binary points.
    pub params: Vec<(Rc<T>, i32)>,
    /// Read states' pre values from the post-step terms (invariants after a step).
    pub pre_as_post: bool,
    /// Products distributed over sums and `ite`s ([`mul`]); otherwise a product of two
    /// non-constant terms stays one node ([`product`]), as the program's own products do, so
    /// that a property's product of two stored values and the program's product of the
    /// values it stores are one term (see [`case_split`]).
    pub distribute: bool,
}

impl PropTerms<'_> {
    /// The boolean term of a property condition.
    pub fn cond(&self, c: &PCond) -> Option<Rc<B>> {
        prop_eval::cond(&mut &*self, c).ok()
    }
}

/// Exact terms ([`T`], [`B`]), later written as SMT-LIB by `qloop`'s `prove::exact::Emitter` or as
/// Rust by the Kani step models.
impl ExactDomain for &PropTerms<'_> {
    type Value = Fx;
    type Bool = Rc<B>;
    type Error = ();

    fn frac(v: &Fx) -> i32 {
        v.frac
    }

    fn inexact(&self, _: f64) {}

    fn constant(&mut self, m: i128, frac: i32) -> Result<Fx, ()> {
        Ok(Fx {
            t: Rc::new(T::Const(m)),
            frac,
        })
    }

    fn signal(&mut self, id: SigId, when: When) -> Result<Fx, ()> {
        let q = self.plan.format(id);
        let kind = self.plan.prog.sig(id).kind;
        let t = match (kind, when) {
            (SigKind::Input, _) => self.terms.pre[&id].clone(),
            (SigKind::State, When::Pre) if !self.pre_as_post => self.terms.pre[&id].clone(),
            _ => self.terms.post[&id].clone(),
        };
        Ok(Fx { t, frac: q.frac })
    }

    fn param(&mut self, i: usize) -> Result<Fx, ()> {
        let (t, f) = self.params.get(i).ok_or(())?;
        Ok(Fx {
            t: t.clone(),
            frac: *f,
        })
    }

    fn neg(&mut self, a: Fx) -> Result<Fx, ()> {
        Ok(Fx {
            t: neg(a.t),
            frac: a.frac,
        })
    }

    fn abs(&mut self, a: Fx) -> Result<Fx, ()> {
        let c = Rc::new(B::Cmp(CmpOp::Lt, a.t.clone(), zero()));
        Ok(Fx {
            t: ite(c, neg(a.t.clone()), a.t),
            frac: a.frac,
        })
    }

    fn arith(&mut self, op: Arith, a: Fx, b: Fx, f: i32) -> Result<Fx, ()> {
        let (x, y) = (align(a, f), align(b, f));
        let t = match op {
            Arith::Add => add(x, y),
            Arith::Sub => sub(x, y),
            Arith::Min => ite(Rc::new(B::Cmp(CmpOp::Lt, x.clone(), y.clone())), x, y),
            Arith::Max => ite(Rc::new(B::Cmp(CmpOp::Lt, x.clone(), y.clone())), y, x),
        };
        Ok(Fx { t, frac: f })
    }

    fn mul(&mut self, a: Fx, b: Fx) -> Result<Fx, ()> {
        let constant = matches!(*a.t, T::Const(_)) || matches!(*b.t, T::Const(_));
        Ok(Fx {
            t: if self.distribute || constant {
                mul(a.t, b.t)
            } else {
                program_product(a.t, b.t)
            },
            frac: a.frac + b.frac,
        })
    }

    fn cmp(&mut self, op: CmpOp, a: Fx, b: Fx, f: i32) -> Result<Rc<B>, ()> {
        Ok(Rc::new(B::Cmp(op, align(a, f), align(b, f))))
    }

    fn and(&mut self, a: Rc<B>, b: Rc<B>) -> Result<Rc<B>, ()> {
        Ok(Rc::new(B::And(a, b)))
    }

    fn or(&mut self, a: Rc<B>, b: Rc<B>) -> Result<Rc<B>, ()> {
        Ok(Rc::new(B::Or(a, b)))
    }

    fn not(&mut self, a: Rc<B>) -> Result<Rc<B>, ()> {
        Ok(Rc::new(B::Not(a)))
    }
}

/// Interval arithmetic over terms, memoised: the raw interval of every term from its
/// variables' assumed ranges. Sound for exact integers: every value a term takes, for
/// variables inside their ranges, lies in its interval. Where a bound does not fit an `i128`
/// the interval is all of `i128` and [`Ranges::overflowed`] says so: an encoding sized from
/// these intervals must then not be used (its widths would wrap).
#[derive(Default)]
pub struct Ranges {
    memo: HashMap<Rc<T>, (i128, i128)>,
    overflow: bool,
}

impl Ranges {
    /// Whether some interval computed so far did not fit an `i128`.
    pub fn overflowed(&self) -> bool {
        self.overflow
    }

    /// The raw interval of a term.
    pub fn of(&mut self, t: &Rc<T>) -> (i128, i128) {
        if let Some(r) = self.memo.get(t) {
            return *r;
        }
        let r = self.compute(t).unwrap_or_else(|| {
            self.overflow = true;
            (i128::MIN, i128::MAX)
        });
        self.memo.insert(t.clone(), r);
        r
    }

    /// The interval of `t` from its operands' intervals, or `None` where a bound overflows.
    fn compute(&mut self, t: &Rc<T>) -> Option<(i128, i128)> {
        let shl = |v: i128, k: u32| v.checked_mul(1i128.checked_shl(k)?);
        Some(match &**t {
            T::Var(_, _, _, lo, hi) => (*lo, *hi),
            T::Const(c) => (*c, *c),
            T::Add(a, b) => {
                let (x, y) = (self.of(a), self.of(b));
                (x.0.checked_add(y.0)?, x.1.checked_add(y.1)?)
            }
            T::Sub(a, b) => {
                let (x, y) = (self.of(a), self.of(b));
                (x.0.checked_sub(y.1)?, x.1.checked_sub(y.0)?)
            }
            T::Neg(a) => {
                let x = self.of(a);
                (x.1.checked_neg()?, x.0.checked_neg()?)
            }
            T::Mul(a, b) => {
                let (x, y) = (self.of(a), self.of(b));
                let c = [
                    x.0.checked_mul(y.0)?,
                    x.0.checked_mul(y.1)?,
                    x.1.checked_mul(y.0)?,
                    x.1.checked_mul(y.1)?,
                ];
                (*c.iter().min()?, *c.iter().max()?)
            }
            T::Shl(a, k) => {
                let x = self.of(a);
                (shl(x.0, *k)?, shl(x.1, *k)?)
            }
            T::Shr(a, k) => {
                let x = self.of(a);
                (x.0 >> k.min(&127), x.1 >> k.min(&127))
            }
            T::Ite(_, a, b) => {
                let (x, y) = (self.of(a), self.of(b));
                (x.0.min(y.0), x.1.max(y.1))
            }
            T::Sum(terms, c) if low_bits(terms, *c).is_some() => {
                // `x − 2^s·⌊x/2^s⌋`, the low `s` bits of `x` (a table position, a high
                // product's low half): in `[0, 2^s)` whatever `x`, where its parts' intervals
                // would give twice `x`'s range.
                let s = low_bits(terms, *c).unwrap_or(0);
                (0, (1i128 << s) - 1)
            }
            T::Sum(terms, c) => {
                let (mut lo, mut hi) = (*c, *c);
                for (k, a) in terms {
                    let (x, y) = self.of(a);
                    let (p, q) = (k.checked_mul(x)?, k.checked_mul(y)?);
                    lo = lo.checked_add(p.min(q))?;
                    hi = hi.checked_add(p.max(q))?;
                }
                (lo, hi)
            }
        })
    }
}

/// How a free parameter on grid `g` compared with state `s` is rewritten as
/// `p = s·2^shift + D`: the shift and `D`'s raw range for `s` in `[slo, shi]`, or `None` when the
/// parameter's grid is coarser than the state's format (it stays a variable of its own).
pub fn param_shift(
    plan: &Plan,
    g: &crate::prop_eval::ParamGrid,
    s: SigId,
    (slo, shi): (i128, i128),
) -> Option<(u32, i128, i128)> {
    let shift = u32::try_from(g.frac - plan.format(s).frac).ok()?;
    Some((shift, g.lo - (shi << shift), g.hi - (slo << shift)))
}

/// Free parameters that a property compares with a pre-step state (`p - s` or `s - p`):
/// parameter index → state. Both encoders rewrite such a parameter as `p = s·2^shift + D`
/// with a fresh `D` (exact, both ways), after which the linear normal form cancels `s` and
/// shares `s`'s products with the step's own terms.
pub fn param_state_pairs(
    plan: &Plan,
    assumes: &[PCond],
    ensures: &[PCond],
) -> BTreeMap<usize, SigId> {
    let mut out = BTreeMap::new();
    for c in assumes.iter().chain(ensures) {
        c.walk(&mut |x| {
            if let PExpr::Sub(a, b) = x {
                if let (PExpr::Param(i), PExpr::Sig(s, When::Pre))
                | (PExpr::Sig(s, When::Pre), PExpr::Param(i)) = (&**a, &**b)
                {
                    if plan.prog.sig(*s).kind == SigKind::State {
                        out.entry(*i).or_insert(*s);
                    }
                }
            }
        });
    }
    out
}

/// The guards of a state's update: the conditions of the `Ite`s at the top of its post-step
/// term `t` that choose between an updated value and the value `pre` it had before the step
/// (`if c { s = v }` gives `ite(c, v, pre)`; nested `if`s, nested `ite`s), in order of first
/// appearance. An `Ite` inside an updated value (a clamp, a saturation) is no guard.
pub fn update_guards(t: &Rc<T>, pre: &Rc<T>, out: &mut Vec<Rc<B>>) {
    fn reaches(t: &Rc<T>, pre: &Rc<T>) -> bool {
        match &**t {
            T::Ite(_, a, b) => reaches(a, pre) || reaches(b, pre),
            _ => Rc::ptr_eq(t, pre) || **t == **pre,
        }
    }
    if let T::Ite(c, a, b) = &**t {
        if !reaches(t, pre) {
            return;
        }
        if !out.contains(c) {
            out.push(c.clone());
        }
        update_guards(a, pre, out);
        update_guards(b, pre, out);
    }
}

/// `b` with the conditions of `case` fixed: every `Ite` on one of them replaced by the arm
/// it selects, every occurrence of one as a Boolean by its value, and the terms rebuilt in
/// normal form. Under the assumption `case`, the result equals `b` (an exact rewriting).
pub fn assume(b: &Rc<B>, case: &[(Rc<B>, bool)]) -> Rc<B> {
    let mut s = Assume {
        case,
        t_memo: HashMap::new(),
        b_memo: HashMap::new(),
    };
    s.b(b)
}

/// The memoised rewriting of [`assume`].
struct Assume<'a> {
    case: &'a [(Rc<B>, bool)],
    t_memo: HashMap<*const T, Rc<T>>,
    b_memo: HashMap<*const B, Rc<B>>,
}

impl Assume<'_> {
    fn value(&self, c: &Rc<B>) -> Option<bool> {
        self.case
            .iter()
            .find(|(k, _)| Rc::ptr_eq(k, c) || **k == **c)
            .map(|(_, v)| *v)
    }

    fn t(&mut self, t: &Rc<T>) -> Rc<T> {
        if let Some(r) = self.t_memo.get(&Rc::as_ptr(t)) {
            return r.clone();
        }
        let r = match &**t {
            T::Var(..) | T::Const(_) => t.clone(),
            T::Add(a, b) => add(self.t(a), self.t(b)),
            T::Sub(a, b) => sub(self.t(a), self.t(b)),
            T::Neg(a) => neg(self.t(a)),
            T::Mul(a, b) => {
                let (x, y) = (self.t(a), self.t(b));
                // A product of two constants folds; otherwise it stays one product.
                product(x, y)
            }
            T::Shl(a, k) => shl(self.t(a), *k),
            T::Shr(a, k) => Rc::new(T::Shr(self.t(a), *k)),
            T::Ite(c, a, b) => match self.value(c) {
                Some(true) => self.t(a),
                Some(false) => self.t(b),
                None => {
                    let c = self.b(c);
                    ite(c, self.t(a), self.t(b))
                }
            },
            T::Sum(terms, c) => {
                let mut acc = Rc::new(T::Const(*c));
                for (k, a) in terms {
                    let x = self.t(a);
                    acc = add(acc, mul(Rc::new(T::Const(*k)), x));
                }
                acc
            }
        };
        self.t_memo.insert(Rc::as_ptr(t), r.clone());
        r
    }

    fn b(&mut self, b: &Rc<B>) -> Rc<B> {
        if let Some(r) = self.b_memo.get(&Rc::as_ptr(b)) {
            return r.clone();
        }
        let zero = || Rc::new(T::Const(0));
        let r = match self.value(b) {
            Some(v) => Rc::new(B::Cmp(
                if v { CmpOp::Eq } else { CmpOp::Ne },
                zero(),
                zero(),
            )),
            None => match &**b {
                B::Cmp(op, x, y) => Rc::new(B::Cmp(*op, self.t(x), self.t(y))),
                B::And(x, y) => Rc::new(B::And(self.b(x), self.b(y))),
                B::Or(x, y) => Rc::new(B::Or(self.b(x), self.b(y))),
                B::Not(x) => Rc::new(B::Not(self.b(x))),
            },
        };
        self.b_memo.insert(Rc::as_ptr(b), r.clone());
        r
    }
}

/// `g` as the conjunction, over every assignment σ of `guards`, of `σ ⇒ g[σ]`
/// ([`assume`]): equal to `g`, written so that in each case the guarded updates are resolved
/// (`ite(c, new, old)` becomes `new` or `old`). An invariant stored only when a run-time test
/// of the same condition passes then reads, case by case, as that test or as itself before
/// the step, with no `Ite` of products to distribute. `None` for more than `max` guards.
pub fn case_split(g: &Rc<B>, guards: &[Rc<B>], max: usize) -> Option<Rc<B>> {
    if guards.is_empty() || guards.len() > max {
        return None;
    }
    let mut out: Option<Rc<B>> = None;
    for bits in 0..1u32 << guards.len() {
        let case: Vec<(Rc<B>, bool)> = guards
            .iter()
            .enumerate()
            .map(|(i, c)| (c.clone(), bits >> i & 1 == 1))
            .collect();
        // σ ⇒ g[σ], as ¬σ₁ ∨ ¬σ₂ ∨ .. ∨ g[σ].
        let mut clause = assume(g, &case);
        for (c, v) in &case {
            let lit = if *v {
                Rc::new(B::Not(c.clone()))
            } else {
                c.clone()
            };
            clause = Rc::new(B::Or(lit, clause));
        }
        out = Some(match out {
            None => clause,
            Some(acc) => Rc::new(B::And(acc, clause)),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn var(n: &str) -> Rc<T> {
        Rc::new(T::Var(n.into(), 32, true, -1000, 1000))
    }
    fn lt(a: Rc<T>, k: i128) -> Rc<B> {
        Rc::new(B::Cmp(CmpOp::Lt, a, Rc::new(T::Const(k))))
    }

    /// The low bits of a sum, `x − 2^s·⌊x/2^s⌋`, have the interval `[0, 2^s)`, for a
    /// variable and for a sum of terms alike; a sum that is not of that form keeps its parts'.
    #[test]
    fn the_low_bits_of_a_term_are_in_their_range() {
        let wide = |n: &str| Rc::new(T::Var(n.into(), 40, true, -(1i128 << 38), 1i128 << 38));
        let x = add(mul(wide("a"), Rc::new(T::Const(3))), wide("b"));
        for t in [wide("c"), x] {
            let low = sub(t.clone(), shl(Rc::new(T::Shr(t.clone(), 16)), 16));
            assert_eq!(Ranges::default().of(&low), (0, 65535), "{low:?}");
            // One unit more of x is not the low bits: its parts' interval.
            let other = add(low, t.clone());
            assert!(Ranges::default().of(&other).1 > 1i128 << 38);
        }
    }

    /// `if outer { if inner { s = clamp(v) } }`: the two guards, not the clamp's test.
    #[test]
    fn update_guards_are_the_tests_that_hold_the_state() {
        let (s, v) = (var("pre_s"), var("v"));
        let clamp = ite(lt(v.clone(), -5), Rc::new(T::Const(-5)), v.clone());
        let (outer, inner) = (lt(var("a"), 0), lt(var("b"), 0));
        let post = ite(
            outer.clone(),
            ite(inner.clone(), clamp, s.clone()),
            s.clone(),
        );
        let mut g = Vec::new();
        update_guards(&post, &s, &mut g);
        assert_eq!(g, vec![outer, inner]);
        // A reset (`else { s = 0 }`) holds nothing: no guard.
        let reset = ite(lt(var("a"), 0), v, Rc::new(T::Const(0)));
        let mut g = Vec::new();
        update_guards(&reset, &s, &mut g);
        assert!(g.is_empty());
    }

    /// Fixing a guard resolves its `ite`s and rebuilds the terms in normal form: the case
    /// where the update runs reads as the product of the values stored, one node, as the
    /// program's own product of them is.
    #[test]
    fn assume_resolves_the_guarded_update() {
        let (x, y, px, py) = (var("x"), var("y"), var("pre_x"), var("pre_y"));
        let c = lt(var("a"), 0);
        let post_x = ite(c.clone(), x.clone(), px.clone());
        let post_y = ite(c.clone(), y.clone(), py.clone());
        let goal = Rc::new(B::Cmp(
            CmpOp::Le,
            add(product(post_x, post_y), Rc::new(T::Const(1))),
            Rc::new(T::Const(7)),
        ));
        let want = |a: Rc<T>, b: Rc<T>| {
            Rc::new(B::Cmp(
                CmpOp::Le,
                add(product(a, b), Rc::new(T::Const(1))),
                Rc::new(T::Const(7)),
            ))
        };
        assert_eq!(assume(&goal, &[(c.clone(), true)]), want(x, y));
        assert_eq!(assume(&goal, &[(c.clone(), false)]), want(px, py));
        // Two cases, each `σ ⇒ g[σ]`; more guards than allowed: no split.
        let split = case_split(&goal, std::slice::from_ref(&c), 3).expect("one guard");
        assert!(matches!(&*split, B::And(..)));
        assert!(case_split(&goal, &[c.clone(), c.clone(), c.clone(), c], 3).is_none());
        assert!(case_split(&goal, &[], 3).is_none());
    }
}
