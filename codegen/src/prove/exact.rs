//! Exact integer terms ([`qloop_core::terms`]) written as SMT-LIB, for property and
//! invariant obligations.
//!
//! The overflow obligations prove that no value of the step wraps, so on every execution
//! the machine arithmetic equals exact integer arithmetic, and the core's term algebra
//! (products distributed and shared) applies. Here every node gets the narrowest width
//! that holds its interval (computed from the premises' variable ranges), so nothing is
//! wider than it must be, and products may be over-approximated ([`Products`]).

use crate::ir::CmpOp;
pub use qloop_core::terms::{
    case_split, mul, product, terms, terms_cut, update_guards, var_names, vars_of, PropTerms,
    Terms, B, T,
};
use qloop_core::terms::{mentions, Ranges};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;
use std::rc::Rc;

use super::smt::{lit, resize, signed_bits};

/// How an [`Emitter`] treats products of two non-constant terms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Products {
    /// Exact multiplication.
    #[default]
    Exact,
    /// Over-approximate: each product not mentioning a variable of [`Emitter::keep`]
    /// becomes a fresh variable bounded by its interval.
    Interval,
    /// Over-approximate, linear: every product becomes a fresh variable bounded by its
    /// interval, its McCormick envelope and, for a factor whose range spans zero, the
    /// sign-split bounds `x ≥ 0 ⇒ yₗ·x ≤ x·y ≤ yₕ·x` (and mirrored): facts of exact
    /// multiplication over the factors' intervals, all linear in the factors.
    Relaxed,
}

/// Which SMT sort the exact terms are written in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sort {
    /// Bit-vectors at the narrowest width holding each term's interval (QF_BV).
    #[default]
    BitVec,
    /// Mathematical integers (QF_LIA / QF_NIA). Equal to the machine arithmetic because the
    /// overflow obligations prove that no value wraps; `>> k` is `div` by `2^k` (floor).
    Int,
}

/// Emits exact terms as SMT-LIB, each distinct subterm once (`define-fun`), each at the
/// narrowest width holding its interval (bit-vectors) or as integers.
#[derive(Default)]
pub struct Emitter {
    /// Definitions so far.
    pub text: String,
    names: HashMap<Rc<T>, (String, u32)>,
    bnames: HashMap<Rc<B>, String>,
    ranges: Ranges,
    declared: BTreeMap<String, String>,
    /// The sort terms are written in.
    pub sort: Sort,
    /// How products are written.
    pub products: Products,
    /// Variables whose products stay exact under [`Products::Interval`] (free parameters).
    pub keep: Vec<String>,
    /// Premises of abstracted products (ranges, envelopes).
    pub premises: Vec<String>,
    /// Whether a product envelope's or a sum's bound did not fit an `i128` (see
    /// [`Emitter::overflowed`]).
    envelope_overflow: bool,
    /// Names handed out so far: each definition's name is `e`, `q` or `b` and this count,
    /// taken when the name is made (a product's name is made before its envelope's terms
    /// are written, so the count of names already stored would hand it out twice).
    fresh: usize,
}

impl Emitter {
    /// An emitter of `sort` treating products as `products`.
    pub fn new(sort: Sort, products: Products) -> Emitter {
        Emitter {
            sort,
            products,
            ..Default::default()
        }
    }

    /// A name not handed out before: `prefix` and a count.
    fn fresh(&mut self, prefix: &str) -> String {
        self.fresh += 1;
        format!("{prefix}{}", self.fresh - 1)
    }

    /// The raw interval of a term.
    pub fn range(&mut self, t: &Rc<T>) -> (i128, i128) {
        self.ranges.of(t)
    }

    /// Whether some term's interval (or a product envelope's bound) did not fit an `i128`:
    /// then the widths of this encoding may wrap, and it must not be used.
    pub fn overflowed(&self) -> bool {
        self.ranges.overflowed() || self.envelope_overflow
    }

    /// Declarations of the variables used so far.
    pub fn declarations(&self) -> String {
        self.declared.values().cloned().collect()
    }

    /// The `set-logic` line of the script.
    pub fn logic(&self) -> &'static str {
        match (self.sort, self.products) {
            (Sort::BitVec, _) => "QF_BV",
            (Sort::Int, Products::Relaxed) => "QF_LIA",
            // `ALL`: cvc5 picks its non-linear extensions (incremental linearisation) for
            // it, and answers in well under a second where `QF_NIA` times out.
            (Sort::Int, _) => "ALL",
        }
    }

    /// The SMT sort of a term `width` bits wide (bit-vectors) or of any integer.
    pub fn sort_name(&self, width: u32) -> String {
        match self.sort {
            Sort::BitVec => format!("(_ BitVec {width})"),
            Sort::Int => "Int".to_string(),
        }
    }

    /// An integer literal in the emitter's sort, `width` bits wide for bit-vectors.
    fn num(&self, v: i128, width: u32) -> String {
        match self.sort {
            Sort::BitVec => lit(v, width),
            Sort::Int if v < 0 => format!("(- {})", v.unsigned_abs()),
            Sort::Int => v.to_string(),
        }
    }

    /// `lo ≤ t ≤ hi`.
    pub fn in_range(&mut self, t: &Rc<T>, lo: i128, hi: i128) -> String {
        let (n, w) = self.term(t);
        self.name_in_range(&n, w, lo, hi)
    }

    fn name_in_range(&self, n: &str, w: u32, lo: i128, hi: i128) -> String {
        match self.sort {
            Sort::BitVec => super::smt::in_range(n, w, lo, hi),
            Sort::Int => format!(
                "(and (<= {} {n}) (<= {n} {}))",
                self.num(lo, 0),
                self.num(hi, 0)
            ),
        }
    }

    /// `a = b`.
    pub fn equal(&mut self, a: &Rc<T>, b: &Rc<T>) -> String {
        let w = self.term(a).1.max(self.term(b).1);
        format!("(= {} {})", self.at(a, w), self.at(b, w))
    }

    /// Name and width of a term's definition (width 0 for integers).
    pub fn term(&mut self, t: &Rc<T>) -> (String, u32) {
        if let Some(n) = self.names.get(t) {
            return n.clone();
        }
        let (lo, hi) = self.range(t);
        let own = match self.sort {
            Sort::BitVec => signed_bits(lo, hi),
            Sort::Int => 0,
        };
        let abstracted = match self.products {
            Products::Exact => false,
            Products::Interval => !mentions(t, &self.keep),
            Products::Relaxed => true,
        };
        let out = match &**t {
            T::Var(name, w, signed, _, _) => {
                let decl = format!("(declare-fun {name} () {})\n", self.sort_name(*w));
                self.declared.entry(name.clone()).or_insert(decl);
                match self.sort {
                    Sort::Int => (name.clone(), 0),
                    Sort::BitVec if *signed => (name.clone(), *w),
                    Sort::BitVec => (resize(name, *w, w + 1, false), w + 1),
                }
            }
            T::Const(c) => (self.num(*c, own), own),
            T::Mul(a, b) if abstracted => {
                let name = self.fresh("q");
                let decl = format!("(declare-fun {name} () {})\n", self.sort_name(own));
                self.declared.insert(name.clone(), decl);
                let range = self.name_in_range(&name, own, lo, hi);
                self.premises.push(range);
                if self.products == Products::Relaxed {
                    self.envelope(&name, own, a, b);
                }
                (name, own)
            }
            _ => {
                let (body, w) = self.body(t, own);
                let name = self.fresh("e");
                let sort = self.sort_name(w);
                let _ = writeln!(self.text, "(define-fun {name} () {sort} {body})");
                (name, w)
            }
        };
        self.names.insert(t.clone(), out.clone());
        out
    }

    /// Linear bounds of the abstracted product `p = a·b` (width `w` for bit-vectors): the
    /// McCormick envelope over the factors' intervals, and sign-split bounds for a factor
    /// whose interval spans zero. Each is a fact of exact multiplication, so adding them is
    /// sound.
    fn envelope(&mut self, p: &str, w: u32, a: &Rc<T>, b: &Rc<T>) {
        let ((al, ah), (bl, bh)) = (self.range(a), self.range(b));
        let big =
            |l: i128, h: i128| -> Option<i128> { Some(l.checked_abs()?.max(h.checked_abs()?)) };
        let m = big(al, ah)
            .zip(big(bl, bh))
            .and_then(|(x, y): (i128, i128)| x.checked_mul(y)?.checked_mul(3)?.checked_add(1));
        let Some(m) = m else {
            self.envelope_overflow = true;
            return;
        };
        let (pw, w) = (w, w.max(signed_bits(-m, m)));
        let p = match self.sort {
            Sort::BitVec => resize(p, pw, w, true),
            Sort::Int => p.to_string(),
        };
        let (x, y) = (self.at(a, w), self.at(b, w));
        let (le, ge, add, mul) = match self.sort {
            Sort::BitVec => ("bvsle", "bvsge", "bvadd", "bvmul"),
            Sort::Int => ("<=", ">=", "+", "*"),
        };
        // c1·x + c2·y + c0, as a term.
        let lin = |s: &Self, c1: i128, c2: i128, c0: i128| {
            format!(
                "({add} ({add} ({mul} {} {x}) ({mul} {} {y})) {})",
                s.num(c1, w),
                s.num(c2, w),
                s.num(c0, w)
            )
        };
        // (x − xl)(y − yl) ≥ 0, (xh − x)(yh − y) ≥ 0: lower bounds; the mixed two: upper.
        let mc = [
            (ge, lin(self, bl, al, -al * bl)),
            (ge, lin(self, bh, ah, -ah * bh)),
            (le, lin(self, bh, al, -al * bh)),
            (le, lin(self, bl, ah, -ah * bl)),
        ];
        for (op, bound) in mc {
            self.premises.push(format!("({op} {p} {bound})"));
        }
        let zero = self.num(0, w);
        for (f, (ol, oh), straddles) in [
            (&x, (bl, bh), al < 0 && ah > 0),
            (&y, (al, ah), bl < 0 && bh > 0),
        ] {
            if !straddles {
                continue;
            }
            let (lo, hi) = (self.num(ol, w), self.num(oh, w));
            self.premises.push(format!(
                "(=> ({ge} {f} {zero}) (and ({le} ({mul} {lo} {f}) {p}) ({le} {p} ({mul} {hi} {f}))))"
            ));
            self.premises.push(format!(
                "(=> ({le} {f} {zero}) (and ({le} ({mul} {hi} {f}) {p}) ({le} {p} ({mul} {lo} {f}))))"
            ));
        }
    }

    fn at(&mut self, t: &Rc<T>, w: u32) -> String {
        let (n, tw) = self.term(t);
        match self.sort {
            Sort::BitVec => resize(&n, tw, w, true),
            Sort::Int => n,
        }
    }

    fn body(&mut self, t: &Rc<T>, own: u32) -> (String, u32) {
        if self.sort == Sort::Int {
            return (self.int_body(t), 0);
        }
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
            T::Sum(terms, c) => {
                let mut w = own;
                for (k, a) in terms {
                    let (x, y) = self.range(a);
                    let (p, q) = match (k.checked_mul(x), k.checked_mul(y)) {
                        (Some(p), Some(q)) => (p, q),
                        _ => {
                            self.envelope_overflow = true;
                            (i128::MIN, i128::MAX)
                        }
                    };
                    w = w
                        .max(signed_bits(p.min(q), p.max(q)))
                        .max(self.term(a).1 + 1);
                }
                let mut acc = lit(*c, w);
                for (k, a) in terms {
                    let x = self.at(a, w);
                    let term = match *k {
                        1 => x,
                        -1 => format!("(bvneg {x})"),
                        k if k > 0 && k.count_ones() == 1 => {
                            format!("(bvshl {x} {})", lit(k.trailing_zeros() as i128, w))
                        }
                        k => format!("(bvmul {} {x})", lit(k, w)),
                    };
                    acc = format!("(bvadd {acc} {term})");
                }
                (acc, w)
            }
            T::Var(..) | T::Const(_) => (String::new(), own),
        }
    }

    /// The integer definition of a compound term.
    fn int_body(&mut self, t: &Rc<T>) -> String {
        match &**t {
            T::Add(a, b) => format!("(+ {} {})", self.at(a, 0), self.at(b, 0)),
            T::Sub(a, b) => format!("(- {} {})", self.at(a, 0), self.at(b, 0)),
            T::Mul(a, b) => format!("(* {} {})", self.at(a, 0), self.at(b, 0)),
            T::Neg(a) => format!("(- {})", self.at(a, 0)),
            T::Shl(a, k) => format!("(* {} {})", self.at(a, 0), 1i128 << k),
            // SMT-LIB `div` by a positive constant is floor division.
            T::Shr(a, k) => format!("(div {} {})", self.at(a, 0), 1i128 << k),
            T::Ite(c, a, b) => {
                let c = self.boolean(c);
                format!("(ite {c} {} {})", self.at(a, 0), self.at(b, 0))
            }
            T::Sum(terms, c) => {
                let mut parts = vec![self.num(*c, 0)];
                for (k, a) in terms {
                    let x = self.at(a, 0);
                    parts.push(match *k {
                        1 => x,
                        k => format!("(* {} {x})", self.num(k, 0)),
                    });
                }
                format!("(+ {})", parts.join(" "))
            }
            T::Var(..) | T::Const(_) => String::new(),
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
                match self.sort {
                    Sort::BitVec => super::smt::signed_cmp(*op, &x, &y),
                    Sort::Int => int_cmp(*op, &x, &y),
                }
            }
            B::And(x, y) => format!("(and {} {})", self.boolean(x), self.boolean(y)),
            B::Or(x, y) => format!("(or {} {})", self.boolean(x), self.boolean(y)),
            B::Not(x) => format!("(not {})", self.boolean(x)),
        };
        let name = self.fresh("b");
        let _ = writeln!(self.text, "(define-fun {name} () Bool {body})");
        self.bnames.insert(b.clone(), name.clone());
        name
    }
}

/// An integer comparison.
fn int_cmp(op: CmpOp, x: &str, y: &str) -> String {
    let f = match op {
        CmpOp::Lt => "<",
        CmpOp::Le => "<=",
        CmpOp::Gt => ">",
        CmpOp::Ge => ">=",
        CmpOp::Eq => "=",
        CmpOp::Ne => return format!("(not (= {x} {y}))"),
    };
    format!("({f} {x} {y})")
}

#[cfg(test)]
mod tests {
    use super::*;
    use qloop_core::terms::{add, shl, sub};

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
            T::Sum(terms, 0) => {
                assert!(terms.contains(&(1, kckm)), "{terms:?}");
                assert!(terms.contains(&(1, mul(d, km))), "{terms:?}");
                assert_eq!(terms.len(), 2);
            }
            other => panic!("not distributed: {other:?}"),
        }
        // Linear cancellation: (16·km + D) − 16·km = D.
        let dd = var("dd");
        assert_eq!(
            sub(add(shl(var("km"), 4), dd.clone()), shl(var("km"), 4)),
            dd
        );
    }

    /// A product whose factor holds another product not yet written gets a name of its own:
    /// the outer product's name is made before its envelope writes the inner one, and a name
    /// taken from the count of stored names handed both out as the same variable, so one
    /// variable carried both envelopes, and a false invariant was "proved" in the linear
    /// envelope (tests/fixtures/refute/determinant_bound_too_high.qloop).
    #[test]
    fn nested_abstracted_products_have_distinct_names() {
        for products in [Products::Relaxed, Products::Interval] {
            let mut em = Emitter::new(Sort::Int, products);
            // The variables written first (as a premise on their ranges would), so that the
            // inner product is the first new term the outer one's envelope writes.
            for v in ["a", "x", "d", "y"] {
                em.term(&var(v));
            }
            let inner = product(var("a"), var("x"));
            let outer = product(add(inner.clone(), var("d")), var("y"));
            let (o, _) = em.term(&outer);
            let (i, _) = em.term(&inner);
            assert_ne!(o, i, "{products:?}: both named {o}");
            let declared: Vec<&str> = em
                .declared
                .keys()
                .map(String::as_str)
                .filter(|n| n.starts_with('q'))
                .collect();
            assert_eq!(declared.len(), 2, "{products:?}: {declared:?}");
        }
    }

    /// The linear envelope of a product admits every true product over the factors'
    /// intervals (soundness), in both sorts; checked by z3 on a grid of factor values,
    /// including ranges that span zero.
    #[test]
    fn envelopes_admit_every_true_product() {
        use crate::prove::solver::{run_all, Answer, Config, Query, Solver};
        if !Solver::Z3.available() {
            eprintln!("z3 not installed: skipped");
            return;
        }
        let (a, b) = (
            Rc::new(T::Var("a".into(), 16, true, -300, 1000)),
            Rc::new(T::Var("b".into(), 16, true, 7, 90)),
        );
        let c = Rc::new(T::Var("c".into(), 16, true, -50, 40));
        let mut queries = Vec::new();
        for sort in [Sort::Int, Sort::BitVec] {
            let x = &a;
            let (xl, xh) = (-300, 1000);
            for (y, yl, yh) in [(&b, 7, 90), (&c, -50, 40)] {
                for (vx, vy) in [
                    (xl, yl),
                    (xl, yh),
                    (xh, yl),
                    (xh, yh),
                    (0, yh),
                    (-1, yl),
                    (37, 11),
                ] {
                    let mut em = Emitter::new(sort, Products::Relaxed);
                    let p = mul(x.clone(), y.clone());
                    let (q, _) = em.term(&p);
                    let mut s = format!(
                        "(set-logic {})\n{}{}",
                        em.logic(),
                        em.declarations(),
                        em.text
                    );
                    for prem in em.premises.clone() {
                        s.push_str(&format!("(assert {prem})\n"));
                    }
                    let pins = [
                        em.in_range(x, vx, vx),
                        em.in_range(y, vy, vy),
                        em.equal(&p, &Rc::new(T::Const(vx * vy))),
                    ];
                    assert!(q.starts_with('q'), "product not abstracted: {q}");
                    for pin in pins {
                        s.push_str(&format!("(assert {pin})\n"));
                    }
                    queries.push(Query {
                        script: s,
                        want: vec![],
                    });
                }
            }
        }
        let cfg = Config {
            solvers: vec![Solver::Z3],
            timeout_ms: 30_000,
            cache_dir: None,
            jobs: 2,
            deadline: None,
        };
        for (q, run) in queries.iter().zip(run_all(&queries, &cfg, &mut |_, _| {})) {
            assert_eq!(run[0].answer, Answer::Sat(vec![]), "{}", q.script);
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
