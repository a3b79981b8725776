//! Exact integer terms for property and invariant obligations.
//!
//! The overflow obligations prove that no value of the step wraps, so on every execution
//! the machine arithmetic equals exact integer arithmetic. Properties are therefore encoded
//! over exact terms, which admit algebra that bit-level reasoning finds hard:
//!
//! * multiplication distributes over `+`, `-` and `ite` (`(kc + d)·km = kc·km + d·km`), so a
//!   post-state product shares its multipliers with the pre-state terms it came from;
//! * products are put in a canonical operand order, so equal products are one term;
//! * every node gets the narrowest width that holds its interval (computed from the
//!   premises' variable ranges), so nothing is wider than it must be.
//!
//! `floor` shifts (`>>`) are kept as they are: the rounding is part of what is proved.

use crate::ir::{CmpOp, PCond, PExpr, SigId, SigKind, When};
use crate::lower::lir::{LStmt, Op, ValId};
use crate::lower::Plan;
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;
use std::rc::Rc;

use super::smt::{lit, resize, signed_bits};

/// An exact integer term.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
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
}

/// An exact boolean term.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
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

fn add(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    match (&*a, &*b) {
        (T::Const(x), T::Const(y)) => Rc::new(T::Const(x + y)),
        (T::Const(0), _) => b,
        (_, T::Const(0)) => a,
        _ => Rc::new(T::Add(a, b)),
    }
}

fn sub(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    match (&*a, &*b) {
        (T::Const(x), T::Const(y)) => Rc::new(T::Const(x - y)),
        (_, T::Const(0)) => a,
        _ => Rc::new(T::Sub(a, b)),
    }
}

fn neg(a: Rc<T>) -> Rc<T> {
    match &*a {
        T::Const(x) => Rc::new(T::Const(-x)),
        T::Neg(x) => x.clone(),
        _ => Rc::new(T::Neg(a)),
    }
}

fn shl(a: Rc<T>, k: u32) -> Rc<T> {
    if k == 0 {
        return a;
    }
    match &*a {
        T::Const(x) => Rc::new(T::Const(x << k)),
        _ => Rc::new(T::Shl(a, k)),
    }
}

/// Product, distributed over `+`, `-`, negation and `ite`, with canonical operand order.
pub fn mul(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    match (&*a, &*b) {
        (T::Const(x), T::Const(y)) => return Rc::new(T::Const(x * y)),
        (T::Const(0), _) | (_, T::Const(0)) => return Rc::new(T::Const(0)),
        (T::Const(1), _) => return b,
        (_, T::Const(1)) => return a,
        _ => {}
    }
    match (&*a, &*b) {
        (T::Ite(c, x, y), _) => Rc::new(T::Ite(
            c.clone(),
            mul(x.clone(), b.clone()),
            mul(y.clone(), b),
        )),
        (_, T::Ite(c, x, y)) => Rc::new(T::Ite(
            c.clone(),
            mul(a.clone(), x.clone()),
            mul(a, y.clone()),
        )),
        (T::Add(x, y), _) => add(mul(x.clone(), b.clone()), mul(y.clone(), b)),
        (_, T::Add(x, y)) => add(mul(a.clone(), x.clone()), mul(a, y.clone())),
        (T::Sub(x, y), _) => sub(mul(x.clone(), b.clone()), mul(y.clone(), b)),
        (_, T::Sub(x, y)) => sub(mul(a.clone(), x.clone()), mul(a, y.clone())),
        (T::Neg(x), _) => neg(mul(x.clone(), b)),
        (_, T::Neg(y)) => neg(mul(a, y.clone())),
        (T::Shl(x, k), _) => shl(mul(x.clone(), b), *k),
        (_, T::Shl(y, k)) => shl(mul(a, y.clone()), *k),
        _ => {
            if a <= b {
                Rc::new(T::Mul(a, b))
            } else {
                Rc::new(T::Mul(b, a))
            }
        }
    }
}

/// Product without distribution, in canonical operand order.
pub fn product(a: Rc<T>, b: Rc<T>) -> Rc<T> {
    match (&*a, &*b) {
        (T::Const(x), T::Const(y)) => Rc::new(T::Const(x * y)),
        _ if a <= b => Rc::new(T::Mul(a, b)),
        _ => Rc::new(T::Mul(b, a)),
    }
}

fn ite(c: Rc<B>, a: Rc<T>, b: Rc<T>) -> Rc<T> {
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
}

/// Builds exact terms for the step. Inputs and states are variables ranging over
/// `ranges[id]` (raw).
pub fn terms(plan: &Plan, ranges: &dyn Fn(SigId) -> (i128, i128)) -> Terms {
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
                    Rc::new(T::Var(
                        super::smt::input_var(prog, id),
                        q.ty.bits,
                        q.ty.signed,
                        lo,
                        hi,
                    )),
                );
            }
            SigKind::State => {
                let v = Rc::new(T::Var(
                    super::smt::pre_var(prog, id),
                    q.ty.bits,
                    q.ty.signed,
                    lo,
                    hi,
                ));
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
    };
    walk(plan, &plan.body, &mut env, &mut t);
    t.post = env;
    t
}

fn walk(plan: &Plan, stmts: &[LStmt], env: &mut BTreeMap<SigId, Rc<T>>, t: &mut Terms) {
    for s in stmts {
        match s {
            LStmt::Def(id) => def(plan, *id, env, t),
            LStmt::Store(sig, id) => {
                if let Some(v) = &t.vals[id.0] {
                    env.insert(*sig, v.clone());
                }
            }
            LStmt::If(c, a, b) => {
                let mut ea = env.clone();
                walk(plan, a, &mut ea, t);
                let mut eb = env.clone();
                walk(plan, b, &mut eb, t);
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
        // them hides simple arguments such as a product's sign.
        Op::Mul(a, b) => product(g(a), g(b)),
        Op::Min(a, b) => ite(Rc::new(B::Cmp(CmpOp::Lt, g(a), g(b))), g(a), g(b)),
        Op::Max(a, b) => ite(Rc::new(B::Cmp(CmpOp::Lt, g(a), g(b))), g(b), g(a)),
        Op::Select(c, a, b) => ite(gb(c), g(a), g(b)),
        Op::Cmp(..) | Op::And(..) | Op::Or(..) | Op::Not(..) => zero(),
    };
    t.vals[id.0] = Some(e);
}

/// A property value: exact term at a binary point.
#[derive(Clone)]
struct Fx {
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
}

impl PropTerms<'_> {
    fn expr(&self, e: &PExpr) -> Option<Fx> {
        Some(match e {
            PExpr::Const(c) => {
                let (m, frac) = super::smt::exact_binary(*c)?;
                Fx {
                    t: Rc::new(T::Const(m)),
                    frac,
                }
            }
            PExpr::Sig(id, when) => {
                let q = self.plan.format(*id);
                let kind = self.plan.prog.sig(*id).kind;
                let t = match (kind, when) {
                    (SigKind::Input, _) => self.terms.pre[id].clone(),
                    (SigKind::State, When::Pre) if !self.pre_as_post => self.terms.pre[id].clone(),
                    _ => self.terms.post[id].clone(),
                };
                Fx { t, frac: q.frac }
            }
            PExpr::Param(i) => {
                let (t, f) = self.params.get(*i)?;
                Fx {
                    t: t.clone(),
                    frac: *f,
                }
            }
            PExpr::Neg(a) => {
                let a = self.expr(a)?;
                Fx {
                    t: neg(a.t),
                    frac: a.frac,
                }
            }
            PExpr::Abs(a) => {
                let a = self.expr(a)?;
                let c = Rc::new(B::Cmp(CmpOp::Lt, a.t.clone(), zero()));
                Fx {
                    t: ite(c, neg(a.t.clone()), a.t),
                    frac: a.frac,
                }
            }
            PExpr::Add(a, b) | PExpr::Sub(a, b) | PExpr::Min(a, b) | PExpr::Max(a, b) => {
                let (a2, b2) = (self.expr(a)?, self.expr(b)?);
                let f = a2.frac.max(b2.frac);
                let (x, y) = (align(a2, f), align(b2, f));
                let t = match e {
                    PExpr::Add(..) => add(x, y),
                    PExpr::Sub(..) => sub(x, y),
                    PExpr::Min(..) => ite(Rc::new(B::Cmp(CmpOp::Lt, x.clone(), y.clone())), x, y),
                    _ => ite(Rc::new(B::Cmp(CmpOp::Lt, x.clone(), y.clone())), y, x),
                };
                Fx { t, frac: f }
            }
            PExpr::Mul(a, b) => {
                let (a, b) = (self.expr(a)?, self.expr(b)?);
                Fx {
                    t: mul(a.t, b.t),
                    frac: a.frac + b.frac,
                }
            }
        })
    }

    /// The boolean term of a property condition.
    pub fn cond(&self, c: &PCond) -> Option<Rc<B>> {
        Some(Rc::new(match c {
            PCond::Cmp(op, a, b) => {
                let (a, b) = (self.expr(a)?, self.expr(b)?);
                let f = a.frac.max(b.frac);
                B::Cmp(*op, align(a, f), align(b, f))
            }
            PCond::And(a, b) => B::And(self.cond(a)?, self.cond(b)?),
            PCond::Or(a, b) => B::Or(self.cond(a)?, self.cond(b)?),
            PCond::Not(a) => B::Not(self.cond(a)?),
        }))
    }
}

/// Emits exact terms as SMT-LIB, each distinct subterm once (`define-fun`), each at the
/// narrowest width holding its interval.
#[derive(Default)]
pub struct Emitter {
    /// Definitions so far.
    pub text: String,
    names: HashMap<Rc<T>, (String, u32)>,
    bnames: HashMap<Rc<B>, String>,
    ranges: HashMap<Rc<T>, (i128, i128)>,
    declared: BTreeMap<String, String>,
}

impl Emitter {
    /// The raw interval of a term.
    pub fn range(&mut self, t: &Rc<T>) -> (i128, i128) {
        if let Some(r) = self.ranges.get(t) {
            return *r;
        }
        let r = match &**t {
            T::Var(_, _, _, lo, hi) => (*lo, *hi),
            T::Const(c) => (*c, *c),
            T::Add(a, b) => {
                let (x, y) = (self.range(a), self.range(b));
                (x.0 + y.0, x.1 + y.1)
            }
            T::Sub(a, b) => {
                let (x, y) = (self.range(a), self.range(b));
                (x.0 - y.1, x.1 - y.0)
            }
            T::Neg(a) => {
                let x = self.range(a);
                (-x.1, -x.0)
            }
            T::Mul(a, b) => {
                let (x, y) = (self.range(a), self.range(b));
                let c = [x.0 * y.0, x.0 * y.1, x.1 * y.0, x.1 * y.1];
                (*c.iter().min().unwrap_or(&0), *c.iter().max().unwrap_or(&0))
            }
            T::Shl(a, k) => {
                let x = self.range(a);
                (x.0 << k, x.1 << k)
            }
            T::Shr(a, k) => {
                let x = self.range(a);
                (x.0 >> k, x.1 >> k)
            }
            T::Ite(_, a, b) => {
                let (x, y) = (self.range(a), self.range(b));
                (x.0.min(y.0), x.1.max(y.1))
            }
        };
        self.ranges.insert(t.clone(), r);
        r
    }

    /// Declarations of the variables used so far.
    pub fn declarations(&self) -> String {
        self.declared.values().cloned().collect()
    }

    /// Name and width of a term's definition.
    pub fn term(&mut self, t: &Rc<T>) -> (String, u32) {
        if let Some(n) = self.names.get(t) {
            return n.clone();
        }
        let (lo, hi) = self.range(t);
        let own = signed_bits(lo, hi);
        let out = match &**t {
            T::Var(name, w, signed, _, _) => {
                self.declared
                    .entry(name.clone())
                    .or_insert_with(|| format!("(declare-fun {name} () (_ BitVec {w}))\n"));
                if *signed {
                    (name.clone(), *w)
                } else {
                    (resize(name, *w, w + 1, false), w + 1)
                }
            }
            T::Const(c) => (lit(*c, own), own),
            _ => {
                let (body, w) = self.body(t, own);
                let name = format!("e{}", self.names.len() + self.bnames.len());
                let _ = writeln!(self.text, "(define-fun {name} () (_ BitVec {w}) {body})");
                (name, w)
            }
        };
        self.names.insert(t.clone(), out.clone());
        out
    }

    fn at(&mut self, t: &Rc<T>, w: u32) -> String {
        let (n, tw) = self.term(t);
        resize(&n, tw, w, true)
    }

    fn body(&mut self, t: &Rc<T>, own: u32) -> (String, u32) {
        match &**t {
            T::Add(a, b) | T::Sub(a, b) | T::Mul(a, b) => {
                let w = own.max(self.term(a).1).max(self.term(b).1);
                let (x, y) = (self.at(a, w), self.at(b, w));
                let f = match &**t {
                    T::Add(..) => "bvadd",
                    T::Sub(..) => "bvsub",
                    _ => "bvmul",
                };
                (format!("({f} {x} {y})"), w)
            }
            T::Neg(a) => {
                let w = own.max(self.term(a).1);
                (format!("(bvneg {})", self.at(a, w)), w)
            }
            T::Shl(a, k) => {
                let w = own.max(self.term(a).1 + k);
                (
                    format!("(bvshl {} {})", self.at(a, w), lit(*k as i128, w)),
                    w,
                )
            }
            T::Shr(a, k) => {
                let w = self.term(a).1;
                (
                    format!("(bvashr {} {})", self.at(a, w), lit(*k as i128, w)),
                    w,
                )
            }
            T::Ite(c, a, b) => {
                let w = own.max(self.term(a).1).max(self.term(b).1);
                let c = self.boolean(c);
                let (x, y) = (self.at(a, w), self.at(b, w));
                (format!("(ite {c} {x} {y})"), w)
            }
            T::Var(..) | T::Const(_) => (String::new(), own),
        }
    }

    /// Name of a boolean term's definition.
    pub fn boolean(&mut self, b: &Rc<B>) -> String {
        if let Some(n) = self.bnames.get(b) {
            return n.clone();
        }
        let body = match &**b {
            B::Cmp(op, x, y) => {
                let w = self.term(x).1.max(self.term(y).1);
                let (x, y) = (self.at(x, w), self.at(y, w));
                match op {
                    CmpOp::Lt => format!("(bvslt {x} {y})"),
                    CmpOp::Le => format!("(bvsle {x} {y})"),
                    CmpOp::Gt => format!("(bvsgt {x} {y})"),
                    CmpOp::Ge => format!("(bvsge {x} {y})"),
                    CmpOp::Eq => format!("(= {x} {y})"),
                    CmpOp::Ne => format!("(not (= {x} {y}))"),
                }
            }
            B::And(x, y) => format!("(and {} {})", self.boolean(x), self.boolean(y)),
            B::Or(x, y) => format!("(or {} {})", self.boolean(x), self.boolean(y)),
            B::Not(x) => format!("(not {})", self.boolean(x)),
        };
        let name = format!("b{}", self.names.len() + self.bnames.len());
        let _ = writeln!(self.text, "(define-fun {name} () Bool {body})");
        self.bnames.insert(b.clone(), name.clone());
        name
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn var(n: &str) -> Rc<T> {
        Rc::new(T::Var(n.into(), 16, true, -100, 100))
    }

    #[test]
    fn products_distribute_and_share() {
        let (kc, km, d) = (var("kc"), var("km"), var("d"));
        // (kc + d)·km = kc·km + d·km, and kc·km is the same term as km·kc.
        let lhs = mul(add(kc.clone(), d.clone()), km.clone());
        let kckm = mul(km.clone(), kc.clone());
        match &*lhs {
            T::Add(a, b) => {
                assert_eq!(*a, kckm);
                assert_eq!(*b, mul(d, km));
            }
            other => panic!("not distributed: {other:?}"),
        }
    }

    #[test]
    fn widths_follow_intervals() {
        let mut e = Emitter::default();
        let (a, b) = (var("a"), var("b"));
        let p = mul(a, b);
        assert_eq!(e.range(&p), (-10000, 10000));
        let (_, w) = e.term(&p);
        assert_eq!(w, 16, "10000 needs 15 bits + sign");
    }
}
