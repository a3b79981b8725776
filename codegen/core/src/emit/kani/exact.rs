//! Exact evaluation of property and invariant conditions as `i128` Rust expressions, each
//! with the interval of its raw value ([`crate::prop_eval::ExactDomain`]): a harness refuses a
//! condition it could not evaluate without overflow.

use super::abstraction::{Abstraction, Atom};
use super::show::i128_lit;
use super::LIMIT_BITS;
use crate::ir::{CmpOp, PCond, SigId, SigKind, When};
use crate::lower::Plan;
use crate::prop_eval::{self, Arith, ExactDomain, ParamGrid};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};
use std::cell::RefCell;

/// Where a property expression reads its values.
pub(super) struct Env<'a, 'p> {
    pub(super) plan: &'a Plan,
    /// Free parameters: grids and names.
    pub(super) grids: &'a [ParamGrid],
    pub(super) params: &'a [String],
    /// Pre-step states.
    pub(super) pre: Ident,
    /// Post-step states.
    pub(super) post: Ident,
    /// Under Kani's abstracted path: the products of two non-constant values go through
    /// these abstractions ([`Abstraction::product`]) instead of multiplying.
    pub(super) abs: Option<&'a RefCell<Abstraction<'p>>>,
}

/// An exactly evaluated `i128` expression: its tokens, its binary point and the bounds of its
/// raw value.
pub(super) struct Ev {
    pub(super) t: TokenStream,
    frac: i32,
    pub(super) lo: i128,
    pub(super) hi: i128,
    /// The raw value, if constant.
    konst: Option<i128>,
    /// The signal or parameter it reads, if it is one read as is.
    pub(super) atom: Option<Atom>,
}

fn limit() -> i128 {
    1i128 << LIMIT_BITS
}

fn checked(lo: Option<i128>, hi: Option<i128>, what: &str) -> Result<(i128, i128), String> {
    match (lo, hi) {
        (Some(lo), Some(hi)) if lo >= -limit() && hi <= limit() => Ok((lo, hi)),
        _ => Err(format!(
            "{what} can exceed 2^{LIMIT_BITS} in magnitude, too wide for exact i128 arithmetic"
        )),
    }
}

impl Ev {
    fn konst(v: i128, frac: i32) -> Ev {
        Ev {
            t: i128_lit(v),
            frac,
            lo: v,
            hi: v,
            konst: Some(v),
            atom: None,
        }
    }

    /// The same value with `f ≥ frac` fraction bits.
    fn at(self, f: i32) -> Result<Ev, String> {
        let k = (f - self.frac) as u32;
        if k == 0 {
            return Ok(self);
        }
        let scale = (k <= LIMIT_BITS).then(|| 1i128 << k);
        let (lo, hi) = checked(
            scale.and_then(|s| self.lo.checked_mul(s)),
            scale.and_then(|s| self.hi.checked_mul(s)),
            "a binary-point alignment",
        )?;
        if let Some(v) = self.konst {
            return Ok(Ev::konst(v << k, f));
        }
        let t = self.t;
        let k = Literal::u32_unsuffixed(k);
        Ok(Ev {
            t: quote! { (#t << #k) },
            frac: f,
            lo,
            hi,
            konst: None,
            atom: None,
        })
    }
}

impl<'a, 'p> Env<'a, 'p> {
    /// A property's environment: pre-step states in `pre`, post-step ones in `post`, the
    /// parameters `param_<name>` on their grids.
    pub(super) fn step(
        plan: &'a Plan,
        grids: &'a [ParamGrid],
        params: &'a [String],
        abs: Option<&'a RefCell<Abstraction<'p>>>,
    ) -> Self {
        Env {
            plan,
            grids,
            params,
            pre: format_ident!("pre"),
            post: format_ident!("post"),
            abs,
        }
    }

    /// An invariant's environment: the states in `states`, no parameters.
    pub(super) fn states(
        plan: &'a Plan,
        states: &str,
        abs: Option<&'a RefCell<Abstraction<'p>>>,
    ) -> Self {
        Env {
            plan,
            grids: &[],
            params: &[],
            pre: format_ident!("{states}"),
            post: format_ident!("{states}"),
            abs,
        }
    }

    /// The `bool` expression of `c`, or why it cannot be evaluated exactly.
    pub(super) fn cond(&self, c: &PCond) -> Result<TokenStream, String> {
        prop_eval::cond(&mut &*self, c)
    }
}

/// `i128` Rust expressions, each with the interval of its raw value: a harness refuses a
/// property it could not evaluate without overflow.
impl ExactDomain for &Env<'_, '_> {
    type Value = Ev;
    type Bool = TokenStream;
    type Error = String;

    fn frac(v: &Ev) -> i32 {
        v.frac
    }

    fn inexact(&self, c: f64) -> String {
        format!("the constant {c} has no exact binary value")
    }

    fn constant(&mut self, m: i128, frac: i32) -> Result<Ev, String> {
        Ok(Ev::konst(m, frac))
    }

    fn signal(&mut self, id: SigId, when: When) -> Result<Ev, String> {
        let plan = self.plan;
        let s = plan.prog.sig(id);
        let q = plan.format(id);
        let n = format_ident!("{}", s.name);
        let atom = match (s.kind, when) {
            (SigKind::Input, _) | (SigKind::State, When::Pre) => Some(Atom::Pre(id)),
            (SigKind::State, When::Post) => Some(Atom::Post(id)),
            _ => None,
        };
        let (t, (lo, hi)) = match (s.kind, when) {
            (SigKind::Input, _) => (quote! { inputs.#n }, plan.bounds(id)),
            (SigKind::State, When::Pre) => {
                let v = &self.pre;
                (quote! { #v.#n }, plan.bounds(id))
            }
            (SigKind::State, When::Post) => {
                let v = &self.post;
                let r = if s.unsaturated {
                    (q.ty.min(), q.ty.max())
                } else {
                    plan.bounds(id)
                };
                (quote! { #v.#n }, r)
            }
            _ => (quote! { outputs.#n }, (q.ty.min(), q.ty.max())),
        };
        Ok(Ev {
            t,
            frac: q.frac,
            lo,
            hi,
            konst: None,
            atom,
        })
    }

    fn param(&mut self, i: usize) -> Result<Ev, String> {
        let (g, name) = self
            .grids
            .get(i)
            .zip(self.params.get(i))
            .ok_or_else(|| format!("free parameter {i} is not declared"))?;
        let n = format_ident!("param_{name}");
        Ok(Ev {
            t: quote! { #n },
            frac: g.frac,
            lo: g.lo,
            hi: g.hi,
            konst: None,
            atom: Some(Atom::Param(i)),
        })
    }

    fn neg(&mut self, a: Ev) -> Result<Ev, String> {
        if let Some(v) = a.konst {
            return Ok(Ev::konst(-v, a.frac));
        }
        let t = a.t;
        Ok(Ev {
            t: quote! { (-#t) },
            frac: a.frac,
            lo: -a.hi,
            hi: -a.lo,
            konst: None,
            atom: None,
        })
    }

    fn abs(&mut self, a: Ev) -> Result<Ev, String> {
        if let Some(v) = a.konst {
            return Ok(Ev::konst(v.abs(), a.frac));
        }
        let (lo, hi) = if a.lo >= 0 {
            (a.lo, a.hi)
        } else if a.hi <= 0 {
            (-a.hi, -a.lo)
        } else {
            (0, a.hi.max(-a.lo))
        };
        let t = a.t;
        Ok(Ev {
            t: quote! { #t.abs() },
            frac: a.frac,
            lo,
            hi,
            konst: None,
            atom: None,
        })
    }

    fn arith(&mut self, op: Arith, a: Ev, b: Ev, f: i32) -> Result<Ev, String> {
        let (a, b) = (a.at(f)?, b.at(f)?);
        let (x, y) = (a.t, b.t);
        let (t, (lo, hi)) = match op {
            Arith::Add => (
                quote! { (#x + #y) },
                checked(a.lo.checked_add(b.lo), a.hi.checked_add(b.hi), "a sum")?,
            ),
            Arith::Sub => (
                quote! { (#x - #y) },
                checked(
                    a.lo.checked_sub(b.hi),
                    a.hi.checked_sub(b.lo),
                    "a difference",
                )?,
            ),
            Arith::Min => (
                quote! { ::core::cmp::min(#x, #y) },
                (a.lo.min(b.lo), a.hi.min(b.hi)),
            ),
            Arith::Max => (
                quote! { ::core::cmp::max(#x, #y) },
                (a.lo.max(b.lo), a.hi.max(b.hi)),
            ),
        };
        Ok(Ev {
            t,
            frac: f,
            lo,
            hi,
            konst: None,
            atom: None,
        })
    }

    fn mul(&mut self, a: Ev, b: Ev) -> Result<Ev, String> {
        let corners = [
            a.lo.checked_mul(b.lo),
            a.lo.checked_mul(b.hi),
            a.hi.checked_mul(b.lo),
            a.hi.checked_mul(b.hi),
        ];
        let all: Option<Vec<i128>> = corners.into_iter().collect();
        let (lo, hi) = checked(
            all.as_ref().and_then(|v| v.iter().min().copied()),
            all.as_ref().and_then(|v| v.iter().max().copied()),
            "a product",
        )?;
        let frac = a.frac + b.frac;
        if let (Some(x), Some(y)) = (a.konst, b.konst) {
            return Ok(Ev::konst(x * y, frac));
        }
        if let Some(abs) = self.abs {
            if a.konst.is_none() && b.konst.is_none() {
                let t = abs.borrow_mut().product(&a, &b)?;
                return Ok(Ev {
                    t,
                    frac,
                    lo,
                    hi,
                    konst: None,
                    atom: None,
                });
            }
        }
        let (x, y) = (a.t, b.t);
        Ok(Ev {
            t: quote! { (#x * #y) },
            frac,
            lo,
            hi,
            konst: None,
            atom: None,
        })
    }

    fn cmp(&mut self, op: CmpOp, a: Ev, b: Ev, f: i32) -> Result<TokenStream, String> {
        let (x, y) = (a.at(f)?.t, b.at(f)?.t);
        let op: TokenStream = op.symbol().parse().unwrap_or_default();
        Ok(quote! { #x #op #y })
    }

    fn and(&mut self, x: TokenStream, y: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { (#x && #y) })
    }

    fn or(&mut self, x: TokenStream, y: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { (#x || #y) })
    }

    fn not(&mut self, x: TokenStream) -> Result<TokenStream, String> {
        Ok(quote! { !(#x) })
    }
}
