//! `recip_track(r, x, G);`: the reciprocal tracker, a state `r` that follows `1/x` without
//! dividing.
//!
//! Koren & Masory (1981) normalise the loop gain by the estimated process gain, `K_c = K/K_m`
//! (Koren & Masory 1981, eq. 3), with an integrating loop instead of a division:
//! `E_c = K − K_c·K_m`, `K_c ← K_c + C2·E_c` (eqs. 12-13). With `K = 1` that loop tracks the
//! reciprocal: `r ← r + G·(1 − x·r)`. Its error `e = 1 − x·r` obeys, for a constant `x`,
//! `e ← (1 − G·x)·e`, so it contracts by `ρ = max |1 − G·x|` over the range of `x` (`ρ < 1`
//! iff `0 < G < 2/x_max`), and `r` moves toward `1/x` from either side.
//!
//! The statement expands to that assignment. The checker refuses a gain that does not
//! contract (`ρ ≥ 1`) and a range of `r` that does not hold `1/x` for every `x` (saturation
//! would stop `r` short of it), and adds the step property
//!
//! ```text
//!     |1 − x·r'| ≤ ρ'·|1 − x·r| + ε
//! ```
//!
//! (`r'` the post-step value, `x` the value the update read: `next(x)` if the step assigns
//! `x` before the tracker, `x` if it assigns it after or not at all), with `ρ'` a binary
//! fraction just above `ρ` (for the quantised gain) and `ε` eight LSBs of `r` times `x_max`
//! (the rounding of the update). Inside an `if` the property assumes the branch's condition
//! (negated in `else`), which must then be one a property can state: inputs, and states the
//! step has not assigned before the `if`. The prover discharges it on the generated code,
//! saturation included; a wrong gain, a misdeclared range or a rounding larger than claimed is
//! a counterexample.

use super::{path_ident, Checker};
use crate::diag::{Diag, Result};
use crate::ir::{Expr, PExpr, SigId, SigKind, Stmt, Track, When};
use crate::lang::ast::PropItem;
use crate::qformat::{IntTy, QFormat};
use std::collections::BTreeSet;
use syn::spanned::Spanned;
use syn::{BinOp, Expr as SExpr, UnOp};

/// An `if` around the statement being checked: its condition as written (boolean `let`s
/// replaced by what they name), which branch, and the states assigned before the `if`.
#[derive(Clone)]
pub(super) struct Branch {
    cond: SExpr,
    taken: bool,
    written: BTreeSet<SigId>,
}

impl Branch {
    /// The `else` of the same `if`.
    pub(super) fn negated(self) -> Branch {
        Branch {
            taken: !self.taken,
            ..self
        }
    }
}

/// A `recip_track` as the checker met it, before its property is made.
pub(super) struct PendingTrack {
    r: SigId,
    x: SigId,
    /// How many assignments `x` had had when the tracker read it.
    x_writes: usize,
    /// The conditions of the branches it sits in, as its property assumes them.
    assumes: Vec<SExpr>,
    gain: f64,
    rho: f64,
    span: proc_macro2::Span,
}

const HELP: &str = "write `recip_track(r, x, G);`: `r` a state whose range holds 1/x, `x` an \
input or state with a positive range, `G` a constant with 0 < G < 2/x_max";

impl Checker {
    /// `recip_track(r, x, G);` in `step`: checks it, appends the update to `out`, and notes
    /// the tracker for its property (see the module docs).
    pub(super) fn recip_track(&mut self, call: &syn::ExprCall, out: &mut Vec<Stmt>) -> Result<()> {
        let span = call.span();
        let args: Vec<&SExpr> = call.args.iter().collect();
        let [r_e, x_e, g_e] = args.as_slice() else {
            return Err(Diag::new(span, "`recip_track` takes 3 arguments").help(HELP));
        };
        let r = self.target(r_e)?;
        if self.signals[r.0].kind != SigKind::State {
            return Err(Diag::new(r_e.span(), "the tracker `r` must be a state").help(HELP));
        }
        let x_ident = path_ident(x_e)
            .ok_or_else(|| Diag::new(x_e.span(), "expected an input or state name").help(HELP))?;
        let x = self
            .lookup(&x_ident.to_string())
            .filter(|id| matches!(self.signals[id.0].kind, SigKind::Input | SigKind::State))
            .ok_or_else(|| {
                Diag::new(x_e.span(), "`x` must be an input or a state").help(
                    "the tracker's property reads `x` before and after the step; bind an \
                     expression to a state first",
                )
            })?;
        let (xl, xh) = self.signals[x.0].range.unwrap_or((0.0, 0.0));
        if xl <= 0.0 {
            return Err(Diag::new(
                x_e.span(),
                format!(
                    "`recip_track` needs x > 0; `{}` ranges over [{xl}, {xh}]",
                    self.signals[x.0].label()
                ),
            )
            .help("for a negative x, track the reciprocal of its negation"));
        }
        let gain = self.const_eval(g_e)?;
        let rho = (1.0 - gain * xl).abs().max((1.0 - gain * xh).abs());
        if !(gain > 0.0 && rho < 1.0) {
            return Err(Diag::new(
                g_e.span(),
                format!(
                    "the tracker does not contract: |1 - G·x| reaches {} over x in [{xl}, {xh}]",
                    crate::text::g(rho)
                ),
            )
            .label("too large")
            .help(format!(
                "the error 1 - x·r is multiplied by 1 - G·x each step; choose 0 < G < 2/x_max = {} \
                 (G = 1/x_max contracts by 1 - x_min/x_max = {})",
                crate::text::g(2.0 / xh),
                crate::text::g(1.0 - xl / xh)
            )));
        }
        let (rl, rh) = self.signals[r.0].range.unwrap_or((0.0, 0.0));
        if rl > 1.0 / xh || rh < 1.0 / xl {
            return Err(Diag::new(
                r_e.span(),
                format!(
                    "the range [{rl}, {rh}] of `{}` does not hold 1/x for every x in [{xl}, {xh}], which is [{}, {}]",
                    self.signals[r.0].label(),
                    crate::text::g_down(1.0 / xh),
                    crate::text::g_up(1.0 / xl)
                ),
            )
            .help("saturation would stop the tracker short of 1/x: widen the state's range"));
        }
        let (ur, ux) = (self.sig_units[r.0].unit(), self.sig_units[x.0].unit());
        if !(ur * ux).same(&crate::units::Unit::ONE) {
            return Err(Diag::new(
                r_e.span(),
                format!(
                    "`{}` tracks 1/`{}`: its unit must be the reciprocal of {}",
                    self.signals[r.0].label(),
                    self.signals[x.0].label(),
                    self.signals[x.0].unit.as_deref().unwrap_or("dimensionless")
                ),
            ));
        }
        // G is in r's unit (G·(1 − x·r) updates r); a literal gain takes it.
        match self.unit_of(g_e, &super::units::ParamUnits::new())? {
            super::units::Ty::Of(u, t) if !u.same(&ur) => {
                return Err(Diag::new(
                    g_e.span(),
                    format!(
                        "the gain is in {t}, but it updates `{}`, in {}",
                        self.signals[r.0].label(),
                        self.signals[r.0].unit.as_deref().unwrap_or("dimensionless")
                    ),
                )
                .help("G·(1 − x·r) is added to r: give G the unit of r, or write a plain number"));
            }
            _ => {}
        }
        let x_writes = self.writes.get(&x).copied().unwrap_or(0);
        let assumes = self.branch_assumes(span)?;
        // r ← r + G·(1 − x·r), built directly (a literal G takes r's unit here).
        let var = |id: SigId| Box::new(Expr::Var(id, span));
        let one = Box::new(Expr::Const {
            value: 1.0,
            name: None,
            span,
        });
        let err = Box::new(Expr::Sub(one, Box::new(Expr::Mul(var(x), var(r), span))));
        let value = Expr::Add(
            var(r),
            Box::new(Expr::Mul(Box::new(self.expr(g_e)?), err, span)),
        );
        self.note_write(r);
        out.push(Stmt::Assign {
            target: r,
            value,
            span,
        });
        self.pending_tracks.push(PendingTrack {
            r,
            x,
            x_writes,
            assumes,
            gain,
            rho,
            span,
        });
        Ok(())
    }

    /// The `if` at the current point, for [`Checker::branches`].
    pub(super) fn branch(&self, cond: &SExpr) -> Branch {
        Branch {
            cond: self.branch_source(cond),
            taken: true,
            written: self
                .writes
                .iter()
                .filter(|(_, &n)| n > 0)
                .map(|(&id, _)| id)
                .collect(),
        }
    }

    /// `e` with each boolean `let` it names replaced by its condition, in parentheses.
    pub(super) fn branch_source(&self, e: &SExpr) -> SExpr {
        match e {
            SExpr::Paren(p) => {
                let inner = self.branch_source(&p.expr);
                syn::parse_quote_spanned!(p.span()=> (#inner))
            }
            SExpr::Unary(u) if matches!(u.op, UnOp::Not(_)) => {
                let inner = self.branch_source(&u.expr);
                syn::parse_quote_spanned!(u.span()=> !#inner)
            }
            SExpr::Binary(b) if matches!(b.op, BinOp::And(_) | BinOp::Or(_)) => {
                let mut b = b.clone();
                b.left = Box::new(self.branch_source(&b.left));
                b.right = Box::new(self.branch_source(&b.right));
                SExpr::Binary(b)
            }
            SExpr::Path(_) => {
                let src = path_ident(e).and_then(|i| {
                    let n = i.to_string();
                    self.bools.iter().rev().find_map(|s| s.get(&n))
                });
                match src {
                    Some(b) => {
                        let src = &b.src;
                        syn::parse_quote_spanned!(e.span()=> (#src))
                    }
                    None => e.clone(),
                }
            }
            _ => e.clone(),
        }
    }

    /// The conditions of the branches around a tracker at `span`, as its property's
    /// assumptions; refused where a property cannot state one.
    fn branch_assumes(&self, span: proc_macro2::Span) -> Result<Vec<SExpr>> {
        const BRANCH_HELP: &str = "the tracker's property holds where its branch runs, so it \
            assumes the branch's condition: test inputs, and states before the step assigns \
            them, in that `if` (or move the tracker out of it)";
        let mut out = Vec::new();
        for b in &self.branches {
            let pc = self.step_condition(&b.cond).map_err(|d| {
                Diag::new(
                    span,
                    format!(
                        "the tracker's property cannot state the condition of the `if` around it \
                         (line {}): {}",
                        b.cond.span().start().line,
                        d.message
                    ),
                )
                .help(BRANCH_HELP)
            })?;
            let mut read = Vec::new();
            pc.walk(&mut |x| {
                if let PExpr::Sig(id, w) = x {
                    read.push((*id, *w));
                }
            });
            for (id, w) in read {
                let s = &self.signals[id.0];
                let before = w == When::Pre && s.kind == SigKind::State && b.written.contains(&id);
                if before || s.kind == SigKind::Output {
                    return Err(Diag::new(
                        span,
                        format!(
                            "the tracker's property cannot state the condition of the `if` around \
                             it (line {}): it reads `{}` {}, a value the property cannot name",
                            b.cond.span().start().line,
                            s.label(),
                            if before {
                                "after the step has assigned it"
                            } else {
                                "during the step"
                            }
                        ),
                    )
                    .help(BRANCH_HELP));
                }
            }
            let c = &b.cond;
            out.push(if b.taken {
                c.clone()
            } else {
                syn::parse_quote_spanned!(span=> !(#c))
            });
        }
        Ok(out)
    }

    /// The trackers' properties and IR records, once the whole step is checked (an
    /// assignment to `x` after its tracker is refused here).
    pub(super) fn track_properties(&mut self) -> Result<(Vec<PropItem>, Vec<Track>)> {
        let mut props = Vec::new();
        let mut tracks = Vec::new();
        for t in std::mem::take(&mut self.pending_tracks) {
            let (r, x) = (&self.signals[t.r.0], &self.signals[t.x.0]);
            // Read before any assignment, `x` is the pre-step value; read after the last,
            // `next(x)`. In between, the property could name neither.
            let writes = self.writes.get(&t.x).copied().unwrap_or(0);
            if t.x_writes > 0 && writes != t.x_writes {
                return Err(Diag::new(
                    t.span,
                    format!(
                        "`{}` is assigned both before and after the tracker that reads it",
                        x.label()
                    ),
                )
                .help(
                    "the tracker's property names `x` before the step or after it, and the \
                     tracker would read neither: move `recip_track` before the first \
                     assignment or after the last",
                ));
            }
            let xh = x.range.map_or(0.0, |r| r.1);
            // ρ' = ρ + 2^-12 for the quantised gain, rounded up to 16 fraction bits.
            let rho = ((t.rho + 2f64.powi(-12)) * 65536.0).ceil() / 65536.0;
            let eps = upper_pow2(xh * 8.0 * self.storage_lsb(t.r));
            let (rn, xn) = (
                syn::Ident::new(&r.name, t.span),
                syn::Ident::new(&x.name, t.span),
            );
            let xv: SExpr = if t.x_writes > 0 {
                syn::parse_quote_spanned!(t.span=> next(#xn))
            } else {
                syn::parse_quote_spanned!(t.span=> #xn)
            };
            let lit = |v: f64| {
                let mut l = proc_macro2::Literal::f64_unsuffixed(v);
                l.set_span(t.span);
                l
            };
            let (rho_l, eps_l) = (lit(rho), lit(eps));
            let name = syn::Ident::new(&format!("recip_track_{}", r.name), t.span);
            let line = t.span.start().line;
            let doc = format!(
                "Generated by `recip_track` (line {line}): `{}` follows 1/`{}`; the error \
                 1 - x·r shrinks by at most {rho} per step (gain {}, rho = {} over x in the \
                 declared range), plus {eps:e} for rounding.",
                r.label(),
                x.label(),
                crate::text::g(t.gain),
                crate::text::g(t.rho),
            );
            props.push(PropItem::Property {
                docs: vec![doc],
                name: name.clone(),
                foralls: Vec::new(),
                assumes: t.assumes,
                ensures: vec![syn::parse_quote_spanned!(t.span=>
                    abs(1.0 - #xv * next(#rn)) <= #rho_l * abs(1.0 - #xv * #rn) + #eps_l
                )],
            });
            tracks.push(Track {
                r: t.r,
                x: t.x,
                gain: t.gain,
                rho: t.rho,
                claimed_rho: rho,
                eps,
                property: name.to_string(),
                span: t.span,
            });
        }
        Ok((props, tracks))
    }

    /// The LSB of a state's storage format as the lowering will choose it: its pin, its
    /// `#[lsb]` request (an upper bound), else the best format of the default word for the
    /// hull of its vector's ranges.
    fn storage_lsb(&self, id: SigId) -> f64 {
        let s = &self.signals[id.0];
        if let Some(p) = s.pin {
            return p.lsb();
        }
        if let Some(l) = s.lsb {
            return l;
        }
        let (mut lo, mut hi) = s.range.unwrap_or((0.0, 0.0));
        if let Some(e) = &s.elem {
            for o in &self.signals {
                if o.elem.as_ref().is_some_and(|f| f.group == e.group) {
                    if let Some((a, b)) = o.range {
                        (lo, hi) = (lo.min(a), hi.max(b));
                    }
                }
            }
        }
        QFormat::best_for(IntTy::signed(self.word), lo, hi).map_or(f64::NAN, |q| q.lsb())
    }
}

/// The smallest power of two at or above `v` (> 0).
fn upper_pow2(v: f64) -> f64 {
    2f64.powi(v.log2().ceil() as i32)
}
