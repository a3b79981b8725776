//! Table look-ups: `NAME(x)` of a `table NAME(x: [A, B]) = EXPR, step H;`.
//!
//! With `x` at `f` fraction bits (`f ≥ k` for the step `H = 2^-k`, else `x` is shifted up
//! first), the grid is every `2^s` raw values, `s = f − k`:
//!
//! ```text
//!     x' = clamp(x, A, B);   o = x' − A            (raw, in [0, N·2^s])
//!     i = o >> s;            t = o & (2^s − 1)     (segment, position inside it)
//!     y = T[i] + (D[i]·t >> s)                      (T the samples, D[i] = T[i+1] − T[i])
//! ```
//!
//! `T` holds the samples rounded to nearest in the result's format (the default word, best
//! for the samples' range), `D` their differences with `D[N] = 0`, so `x = B` reads `T[N]`
//! and no index is ever clamped. The result is clamped to `[min T, max T]`, where it always
//! lies (a no-op that gives the range analysis the interval). The value's error bound is set from the analysis, not
//! propagated through the index: the argument's error times the interpolant's largest slope,
//! half an LSB for the rounded samples (an interpolation of rounded samples is within half
//! an LSB of that of the exact ones), the rounding of `D[i]·t`, and the table's interpolation
//! error against its expression ([`crate::ir::Table::interp_err`]).

use super::lir::{LStmt, Op, ValId};
use super::{err_bound, Bin, Lowerer, NewVal, NO_CTX};
use crate::diag::{Diag, Result};
use crate::ir::Expr;
use crate::qformat::{pow2, IntTy, QFormat};
use proc_macro2::Span;

/// The integer arrays of one table at one result format: the samples and their differences.
#[derive(Clone, Debug, PartialEq)]
pub struct LTable {
    /// The table ([`crate::ir::Program::tables`]).
    pub table: usize,
    /// The entries' format.
    pub format: QFormat,
    /// The rounded samples `T[0..=N]`.
    pub entries: Vec<i128>,
    /// `D[i] = T[i+1] − T[i]`, and `D[N] = 0`.
    pub deltas: Vec<i128>,
    /// The type that holds the differences.
    pub delta_ty: IntTy,
}

impl LTable {
    /// The smallest and largest entry of the samples (`delta` false) or the differences.
    pub fn range(&self, delta: bool) -> (i128, i128) {
        let v = if delta { &self.deltas } else { &self.entries };
        (
            v.iter().copied().min().unwrap_or(0),
            v.iter().copied().max().unwrap_or(0),
        )
    }
}

impl Lowerer<'_> {
    /// Lowers `table(arg)` (see the module docs).
    pub(super) fn table(
        &mut self,
        t: usize,
        arg: &Expr,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let tab = self.prog.tables[t].clone();
        let k = -(tab.step.log2().round() as i32);
        let mut x0 = self.expr(arg, NO_CTX, out)?;
        // The offset from A and the clamp constants A and B, at the argument's precision, must
        // fit the widest working type, 64 bits: an argument with more fraction bits than that
        // (a narrow range in a 64-bit word) is rounded to the finest precision that fits, its
        // error counted.
        let (na, nb) = ((tab.lo / tab.step) as i128, (tab.hi / tab.step) as i128);
        let m = na.abs().max(nb.abs()).max(nb - na).max(1);
        let bitlen = 128 - m.leading_zeros() as i32;
        let s_max = 63 - bitlen;
        if s_max < 0 {
            return Err(Diag::new(
                span,
                format!(
                    "table `{}`: its grid of {} steps from {} does not fit 64-bit integers",
                    tab.name,
                    nb - na,
                    crate::text::g(tab.lo)
                ),
            )
            .help("use a coarser step, or a range nearer 0"));
        }
        let f_max = k + s_max;
        if self.v(x0).frac > f_max {
            let n = (self.v(x0).frac - f_max) as u32;
            x0 = self.round(x0, n, span, out)?;
        }
        let arg_err = self.v(x0).err;
        let mut x = x0;
        let f0 = self.v(x).frac;
        if f0 < k {
            x = self.shl(x, (k - f0) as u32, span, out)?;
        }
        let fa = self.v(x).frac;
        let s = (fa - k) as u32;
        let (ra, rb) = (na << s, nb << s);
        // Clamp to [A, B] where the argument reaches beyond.
        let xv = self.v(x).clone();
        let ka = self.constant(tab.lo, fa, span, out)?;
        if xv.lo < ra {
            x = self.binary_vals(x, ka, Bin::Max, out)?;
        }
        if xv.hi > rb {
            let kb = self.constant(tab.hi, fa, span, out)?;
            x = self.binary_vals(x, kb, Bin::Min, out)?;
        }
        let off = self.binary_vals(x, ka, Bin::Sub, out)?;
        let ov = self.v(off).clone();
        if ov.frac != fa || ov.lo < 0 || ov.hi > rb - ra {
            return Err(Diag::new(
                span,
                "internal: a table offset left its interval",
            ));
        }
        // The result format and the arrays.
        let q = tab.stored_format(self.prog.word).ok_or_else(|| {
            let (smin, smax) = tab.sample_hull(0, tab.samples.len());
            Diag::new(
                span,
                format!(
                    "the values of table `{}` span [{smin:e}, {smax:e}], too wide for {}-bit words",
                    tab.name, self.prog.word
                ),
            )
        })?;
        let entries: Vec<i128> = tab.samples.iter().map(|v| q.raw_nearest(*v)).collect();
        let mut deltas: Vec<i128> = entries.windows(2).map(|w| w[1] - w[0]).collect();
        deltas.push(0);
        let (dmin, dmax) = (
            deltas.iter().copied().min().unwrap_or(0),
            deltas.iter().copied().max().unwrap_or(0),
        );
        let delta_ty = self.working(dmin, dmax, span)?;
        let lt = LTable {
            table: t,
            format: q,
            entries,
            deltas,
            delta_ty,
        };
        let li = match self.tables.iter().position(|x| *x == lt) {
            Some(i) => i,
            None => {
                self.tables.push(lt);
                self.tables.len() - 1
            }
        };
        let (emin, emax) = self.tables[li].range(false);
        // The segment and the position inside it.
        let idx = if s == 0 {
            off
        } else {
            self.push(
                NewVal {
                    op: Op::Shr(off, s),
                    ty: ov.ty,
                    frac: fa - s as i32,
                    lo: ov.lo >> s,
                    hi: ov.hi >> s,
                    err: 0.0,
                },
                out,
            )
        };
        let ti = self.push(
            NewVal {
                op: Op::Lookup {
                    table: li,
                    delta: false,
                    idx,
                },
                ty: q.ty,
                frac: q.frac,
                lo: emin,
                hi: emax,
                err: 0.0,
            },
            out,
        );
        let (y, rounding) = if s == 0 {
            (ti, 0.0)
        } else {
            let pos = self.push(
                NewVal {
                    op: Op::Low(off, s),
                    ty: ov.ty,
                    frac: s as i32,
                    lo: 0,
                    hi: (1i128 << s) - 1,
                    err: 0.0,
                },
                out,
            );
            let di = self.push(
                NewVal {
                    op: Op::Lookup {
                        table: li,
                        delta: true,
                        idx,
                    },
                    ty: delta_ty,
                    frac: q.frac,
                    lo: dmin,
                    hi: dmax,
                    err: 0.0,
                },
                out,
            );
            let prod = self.mul(di, pos, span, out)?;
            let pf = self.v(prod).frac;
            let pr = self.round(prod, (pf - q.frac).max(0) as u32, span, out)?;
            let rounding = self.v(pr).err;
            let mut y = self.binary_vals(ti, pr, Bin::Add, out)?;
            // The value lies between two neighbouring samples (D[i]·t >> s is between D[i]
            // and 0), so within [min T, max T]; interval arithmetic on T[i] and D[i] cannot
            // see that, so a clamp (a no-op here and in real arithmetic) states it.
            let yv = self.v(y).clone();
            if yv.frac == q.frac && yv.lo < emin {
                let k = self.constant(q.value(emin), q.frac, span, out)?;
                y = self.binary_vals(y, k, Bin::Max, out)?;
            }
            if yv.frac == q.frac && yv.hi > emax {
                let k = self.constant(q.value(emax), q.frac, span, out)?;
                y = self.binary_vals(y, k, Bin::Min, out)?;
            }
            (y, rounding)
        };
        // The error bound (see the module docs).
        let slope = tab
            .samples
            .windows(2)
            .fold(0f64, |m, w| m.max((w[1] - w[0]).abs()))
            / tab.step;
        let quant = if q.frac >= 1 { pow2(-q.frac - 1) } else { 1.0 };
        let err = err_bound::add(
            err_bound::add(err_bound::mul(slope * (1.0 + 1e-12), arg_err), quant),
            err_bound::add(rounding, tab.interp_err),
        );
        self.vals[y.0].err = err;
        Ok(y)
    }
}
