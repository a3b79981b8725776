//! Variable × constant: the constant gains of every controller (the 1981 law's K_c·2^-n
//! steps, Koren & Masory (1981), eqs. 8–10, are shifts and adds by construction).
//!
//! Four steps, one method each: [`Lowerer::const_factor`] quantises the constant on the
//! variable's grid (dropping the fewest fraction bits of the variable that keep the product
//! in 64 bits), [`Lowerer::network_type`] sizes the working type from the largest partial
//! term, [`Lowerer::choose_multiplier`] prices the shift-add network against the target's
//! multiplier and records the choice, and [`Lowerer::emit_network`] emits the network (a
//! multiply is one operation). Either way the product is exactly `x · m`, relabelled as
//! `x · m · 2^-k`.

use super::lir::{LStmt, Op, Val, ValId};
use super::rounding::fits_i32;
use super::{err_bound, shift_add, shl_exact, Bin, Lowerer, MulNote, NewVal};
use crate::diag::{Diag, Result};
use crate::qformat::{pow2, IntTy, QFormat};
use proc_macro2::Span;

/// How much looser (relatively) a folded chain of constant factors' error bound may be than
/// the sequence's: 1 %, far below what either bound means for a controller, for a constant
/// multiplication with fewer adders and fraction bits.
pub const CHAIN_SLACK: f64 = 0.01;

/// The largest relative error with which a constant factor is applied: 2^-10 (about 0.1 %).
pub const CONST_REL: f64 = 1.0 / 1024.0;

/// How much finer than usual to quantise a constant (a folded chain of constants, see
/// [`Lowerer::mul_const_chain`]): extra fraction bits, and the constant's own distance from
/// the real product it stands for.
#[derive(Clone, Copy, Debug, Default)]
struct Fine {
    extra: i32,
    own: f64,
}

/// A constant factor quantised for one product: `c ≈ m · 2^-k`, the product's binary point
/// `frac`, and the product's one-step error bound.
struct ConstFactor {
    m: i128,
    k: i32,
    frac: i32,
    err: f64,
}

impl Lowerer<'_> {
    /// Variable × constant: shift-add network, or the multiplier if the cost model says so.
    pub(super) fn mul_const(
        &mut self,
        x: ValId,
        c: f64,
        name: Option<String>,
        claim: Option<(f64, f64)>,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        self.mul_const_fine(x, c, Fine::default(), name, claim, span, out)
    }

    /// `(y · c₁) · c₂` (a gain, then a unit conversion): one constant multiplication by
    /// `c₁·c₂` where that costs no more adders and its quantisation error is no larger than
    /// the two in sequence (estimated before emitting: the bounds printed are computed on
    /// what is emitted either way), else the two in sequence, as written.
    pub(super) fn mul_const_chain(
        &mut self,
        y: ValId,
        (c1, name1): (f64, Option<String>),
        (c2, name2): (f64, Option<String>),
        spans: (Span, Span),
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        if let Some(fine) = self.chain_pays(y, c1, c2) {
            // Named after both factors in `qloop check`: `VC·1.6667e-5`.
            let part = |n: &Option<String>, c: f64| n.clone().unwrap_or_else(|| crate::text::g(c));
            let name = format!("{}·{}", part(&name1, c1), part(&name2, c2));
            return self.mul_const_fine(y, c1 * c2, fine, Some(name), None, spans.1, out);
        }
        let t = self.mul_const(y, c1, name1, None, spans.0, out)?;
        self.mul_const(t, c2, name2, None, spans.1, out)
    }

    /// Whether folding `(y · c₁) · c₂` pays, and how finely to quantise the product constant:
    /// the fold must need no more adders and no more fraction bits than the sequence, and
    /// its one-step error bound must be within [`CHAIN_SLACK`] of the sequence's;
    /// `extra` fraction bits beyond `y`'s (so that its error, like the sequence's, scales with
    /// a small `c₂`), and the folded constant's own rounding `|c₁·c₂ − fl(c₁·c₂)|`.
    fn chain_pays(&self, y: ValId, c1: f64, c2: f64) -> Option<Fine> {
        let yv = self.v(y);
        let my = err_bound::magnitude(yv.lo.abs().max(yv.hi.abs()), yv.frac);
        let c = c1 * c2;
        // The fold is checked on y's grid (`factor_rounding`): it must not vanish there.
        if c1 == 0.0 || c2 == 0.0 || my == 0.0 || !c.is_finite() || c.abs() * my <= pow2(-yv.frac) {
            return None;
        }
        // The sequence, as `mul_const` would quantise it.
        let (m1, k1) = quantise(c1, yv.frac, my)?;
        let q1 = m1 as f64 * pow2(-k1);
        let (m2, k2) = quantise(c2, yv.frac + k1, my * q1.abs())?;
        let q2 = m2 as f64 * pow2(-k2);
        let seq_adders = shift_add::best(m1).adders() + shift_add::best(m2).adders();
        // The sequence's error bound (y's error scaled, and both quantisations; the
        // roundings it may need to stay within 64 bits only add to it).
        let seq_err = err_bound::add(
            err_bound::mul(err_bound::mul(q1.abs(), q2.abs()), yv.err),
            err_bound::add(
                err_bound::mul(err_bound::mul(err_bound::dist(q1, c1), my), q2.abs()),
                err_bound::mul(err_bound::mul(err_bound::dist(q2, c2), my), q1.abs()),
            ),
        );
        // The fold: the coarsest grid (at most as many bits finer than y's as c₂ is small)
        // on which its quantisation error is no larger than the sequence's.
        let own = c1.mul_add(c2, -c).abs();
        let most = (-c2.abs().log2()).ceil().max(0.0) as i32;
        let ym = yv.lo.abs().max(yv.hi.abs());
        (0..=most).find_map(|extra| {
            let (m, k) = quantise(c, yv.frac + extra, my)?;
            let q = m as f64 * pow2(-k);
            let fold_err = err_bound::add(
                err_bound::mul(q.abs(), yv.err),
                err_bound::mul(err_bound::add(err_bound::dist(q, c), own), my),
            );
            let fits = 128 - (ym * m.abs()).leading_zeros() + 2 <= 64;
            (fold_err <= seq_err * (1.0 + CHAIN_SLACK)
                && fits
                && k <= k1 + k2
                && shift_add::best(m).adders() <= seq_adders)
                .then_some(Fine { extra, own })
        })
    }

    /// [`Self::mul_const`] with the constant quantised `fine.extra` bits finer than `x`'s
    /// grid, and `fine.own` (the constant's distance from the real value it stands for)
    /// counted in the error bound.
    #[allow(clippy::too_many_arguments)]
    fn mul_const_fine(
        &mut self,
        x: ValId,
        c: f64,
        fine: Fine,
        name: Option<String>,
        claim: Option<(f64, f64)>,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<ValId> {
        let (x, f) = self.const_factor(x, c, fine, span, out)?;
        let xv = self.v(x).clone();
        if f.m == 0 {
            // c = 0, or x is identically 0: the product is exactly 0.
            let ty = IntTy::signed(self.target.min_work_bits());
            return Ok(self.push(NewVal::constant(0, ty, f.frac, f.err), out));
        }
        let net = shift_add::best(f.m);
        let ty = self.network_type(&xv, &f, &net, claim, span)?;
        let hw = self.choose_multiplier(&xv, c, name, &f, &net, ty);
        let xw = self.cast(x, ty, out);
        let (lo, hi) = Bin::Mul.range((xv.lo, xv.hi), (f.m, f.m));
        let product = |op| NewVal {
            op,
            ty,
            frac: f.frac,
            lo,
            hi,
            err: f.err,
        };
        let note = self.mults.len() - 1;
        let p = if hw {
            let cm = self.push(NewVal::constant(f.m, ty, 0, 0.0), out);
            self.push(product(Op::Mul(xw, cm)), out)
        } else {
            let r = self.emit_network(xw, &xv, f.m, &net, ty, out);
            // Re-label the binary point: the network computed x·m; the value is x·m·2^-k.
            self.push_fit(product(Op::Cast(r)), out)
        };
        self.const_products
            .insert(p, super::ConstProduct { x, m: f.m, note });
        Ok(p)
    }

    /// `round(x·m, n)` of an exact constant product that needs a word wider than 32 bits,
    /// computed in 32 bits: with `m = q·2^n + c` (`c` of `m`'s sign, `|c| < 2^n`),
    /// `⌊(x·m + h)/2^n⌋ = q·x + ⌊(c·x + h)/2^n⌋` for the program's rounding (`h` = 2^(n−1)
    /// for nearest, 0 for floor), since `q·x·2^n` is a multiple of 2^n: exact, the same
    /// integer, the same error bound. `q·x` and `c·x` have `m`'s sign in `x`, so interval
    /// arithmetic gives the sum the exact interval of the rounded product. On a target whose
    /// word is narrower than 64 bits, where `x`, `q·x`, `c·x + h` and the sum fit `i32`, and
    /// where the target's cost model prices the split below the wide product and its
    /// rounding (1.125·x rounded by 3 bits is `x + ⌊(x + 4)/8⌋`, not a 64-bit multiply, add
    /// and shift: on the AVR about 25 cycles against 200). `None` otherwise.
    pub(super) fn const_split(
        &mut self,
        v: ValId,
        n: u32,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<Option<ValId>> {
        let Some(&super::ConstProduct { x, m, note }) = self.const_products.get(&v) else {
            return Ok(None);
        };
        let pv = self.v(v).clone();
        if pv.ty.bits <= 32 || self.target.word_bits >= 64 || !(1..62).contains(&n) {
            return Ok(None);
        }
        let Some(x) = self.narrow32(x, 4, out) else {
            return Ok(None);
        };
        let xv = self.v(x).clone();
        let low = (1i128 << n) - 1;
        let (q, c) = if m >= 0 {
            (m >> n, m & low)
        } else {
            (-((-m) >> n), -((-m) & low))
        };
        let h = match self.prog.rounding {
            crate::qformat::Rounding::Nearest => 1i128 << (n - 1),
            crate::qformat::Rounding::Floor => 0,
        };
        let range = |k: i128| {
            let (a, b) = (xv.lo * k, xv.hi * k);
            (a.min(b), a.max(b))
        };
        let ((ql, qh), (cl, ch)) = (range(q), range(c));
        let (rl, rh) = self.rounded(cl, ch, n);
        // Every partial term of either network in 32 bits too (`23·x << 6` on the way to
        // `1449·x` can leave `i32` where `1449·x` does not).
        let xm = xv.lo.abs().max(xv.hi.abs());
        let terms_fit = |k: i128| {
            let t = xm * largest_term(k, &shift_add::best(k));
            fits_i32(-t, t)
        };
        if q == 0
            || !fits_i32(ql, qh)
            || !fits_i32(cl, ch + h)
            || !fits_i32(ql + rl, qh + rh)
            || !terms_fit(q)
            || !terms_fit(c)
        {
            return Ok(None);
        }
        // The cost model: the wide product as chosen, its rounding's add and shift, against
        // the two 32-bit products, the rounding and the sum.
        let t = self.target;
        let xbits = xv.ty.bits.min(32);
        let int_cost = |k: i128, bits: u32| {
            let (net, sa, hw) = self.int_product_costs(k, bits, xbits);
            if net.adders() == 0 {
                sa
            } else {
                sa.min(hw)
            }
        };
        let round_cost =
            |bits: u32| t.add_cost(bits) * u32::from(h != 0) + t.shift_cost(bits, n, false);
        let wide = int_cost(m, pv.ty.bits) + round_cost(pv.ty.bits);
        let narrow = int_cost(q, 32) + int_cost(c, 32) + round_cost(32) + t.add_cost(32);
        if narrow >= wide {
            return Ok(None);
        }
        let i32t = IntTy::signed(32);
        let xw = self.cast(x, i32t, out);
        let qx = self.int_product(xw, &xv, q, out);
        let cx = self.int_product(xw, &xv, c, out);
        // c·x at the product's binary point, rounded by n; q·x at the result's.
        let cxp = self.push(NewVal::exact(Op::Cast(cx), i32t, pv.frac, (cl, ch)), out);
        let rc = self.round(cxp, n, span, out)?;
        let rc = self.cast(rc, i32t, out);
        let frac = pv.frac - n as i32;
        let qxr = self.push(NewVal::exact(Op::Cast(qx), i32t, frac, (ql, qh)), out);
        let (al, ah) = (self.v(rc).lo, self.v(rc).hi);
        let added = self.rounding_added(pv.frac, n);
        let r = self.push(
            NewVal {
                op: Op::Add(qxr, rc),
                ty: i32t,
                frac,
                lo: ql + al,
                hi: qh + ah,
                err: err_bound::add(pv.err, added),
            },
            out,
        );
        self.splits.push(super::Split {
            note,
            val: r,
            qcn: (q, c, n),
        });
        Ok(Some(r))
    }

    /// `x · k` exactly in `x`'s 32-bit word (`xw`, with `xv`'s interval): a shift-add network,
    /// or the multiplier where the target's cost model prices it lower.
    fn int_product(&mut self, xw: ValId, xv: &Val, k: i128, out: &mut Vec<LStmt>) -> ValId {
        let i32t = IntTy::signed(32);
        let (net, sa, hw) = self.int_product_costs(k, 32, xv.ty.bits.min(32));
        if net.adders() > 0 && (hw < sa || self.target.force_multiply) {
            let (a, b) = (xv.lo * k, xv.hi * k);
            let cm = self.push(NewVal::constant(k, i32t, 0, 0.0), out);
            return self.push(
                NewVal::exact(Op::Mul(xw, cm), i32t, xv.frac, (a.min(b), a.max(b))),
                out,
            );
        }
        self.emit_network(xw, xv, k, &net, i32t, out)
    }

    /// `x · k` by a `bits`-wide shift-add network (`x` of `x_bits`): the network, its cost and
    /// the multiplier's in the target's model (as [`Self::choose_multiplier`] prices them,
    /// without the rounded-up shift split).
    fn int_product_costs(
        &self,
        k: i128,
        bits: u32,
        x_bits: u32,
    ) -> (shift_add::ShiftAddPlan, u32, u32) {
        let net = shift_add::best(k);
        let kb = (129 - k.unsigned_abs().leading_zeros()).max(self.target.min_work_bits());
        let sa = self.target.shift_add_cost(&net, bits, &|_, _| false);
        let hw = self
            .target
            .const_mul_cost(bits, x_bits, kb.next_power_of_two());
        (net, sa, hw)
    }

    /// Rounds `x` as [`Self::factor_rounding`] says, then quantises `c` on its grid
    /// ([`quantise`]); the error bound counts both `x`'s error scaled by the quantised
    /// factor and the factor's quantisation error over `x`'s range.
    fn const_factor(
        &mut self,
        x: ValId,
        c: f64,
        fine: Fine,
        span: Span,
        out: &mut Vec<LStmt>,
    ) -> Result<(ValId, ConstFactor)> {
        // If the exact product would exceed 64 bits, drop the fewest fraction bits of x that
        // make it fit (with the program's rounding; the error is counted).
        let n = self.factor_rounding(x, c, span)?;
        let x = self.round(x, n, span, out)?;
        let xv = self.v(x);
        let mx = err_bound::magnitude(xv.lo.abs().max(xv.hi.abs()), xv.frac);
        let (m, k) = if c == 0.0 || mx == 0.0 {
            (0, 0)
        } else {
            quantise(c, xv.frac + fine.extra, mx)
                .or_else(|| quantise(c, xv.frac, mx))
                .ok_or_else(|| too_wide_product(c, span))?
        };
        let q = m as f64 * pow2(-k);
        let err = err_bound::add(
            err_bound::mul(q.abs(), xv.err),
            err_bound::mul(
                err_bound::add(mx, xv.err),
                err_bound::add(err_bound::dist(q, c), fine.own),
            ),
        );
        let frac = xv.frac + k;
        Ok((x, ConstFactor { m, k, frac, err }))
    }

    /// The working type of the product and every partial term of its network: from the
    /// largest term, or from a `#[range]` claim on the product (partial sums the claim does
    /// not cover become proof obligations).
    fn network_type(
        &self,
        xv: &Val,
        f: &ConstFactor,
        net: &shift_add::ShiftAddPlan,
        claim: Option<(f64, f64)>,
        span: Span,
    ) -> Result<IntTy> {
        // Largest magnitude any partial term reaches, for the working type.
        let maxc = largest_term(f.m, net);
        let xm = xv.lo.abs().max(xv.hi.abs());
        match claim {
            Some((lo, hi)) => {
                let q = QFormat {
                    ty: xv.ty,
                    frac: f.frac,
                };
                self.working(q.raw_floor(lo).min(xv.lo), q.raw_ceil(hi).max(xv.hi), span)
            }
            None => self.working(-(xm * maxc), xm * maxc, span),
        }
    }

    /// Whether the multiplier computes the product (else the shift-add network): the target's
    /// cost model prices both (`Target::shift_add_cost`, `Target::const_mul_cost`); the choice
    /// is recorded as a [`MulNote`] for `qloop check`.
    fn choose_multiplier(
        &mut self,
        xv: &Val,
        c: f64,
        name: Option<String>,
        f: &ConstFactor,
        net: &shift_add::ShiftAddPlan,
        ty: IntTy,
    ) -> bool {
        let (m, bits) = (f.m, ty.bits);
        // Whether a term `c·x` has room for the rounded-up split of a shift by `k` (the test
        // the C emitter applies to the same term, `emit::c::byte_split`).
        let up_room = |c: i128, k: u32| {
            let n = self.target.word_bits * (k / self.target.word_bits + 1);
            let (a, b) = (xv.lo * c, xv.hi * c);
            n + 1 < ty.bits
                && shl_exact(a.min(b), n as i32)
                    .zip(shl_exact(a.max(b), n as i32))
                    .is_some_and(|(lo, hi)| ty.holds(lo, hi))
        };
        let sa_cost = self.target.shift_add_cost(net, bits, &up_room);
        // Both factors as the compiler sees them: x sign-extended from its own type, m as
        // a constant of the narrowest C type (at least `int`) that holds it.
        let m_bits = (129 - m.unsigned_abs().leading_zeros()).max(self.target.min_work_bits());
        let hw_cost = self
            .target
            .const_mul_cost(bits, xv.ty.bits, m_bits.next_power_of_two());
        let hw = net.adders() > 0 && (hw_cost < sa_cost || self.target.force_multiply);
        self.mults.push(MulNote {
            constant: c,
            name,
            m,
            k: f.k,
            adders: net.adders(),
            shifts: net.shifts(),
            hw_mul: hw,
            costs: (sa_cost, hw_cost),
            split: None,
        });
        hw
    }

    /// Emits the shift-add network computing `m · xw` (every partial value is `coef · x`,
    /// exact, in `ty`); returns the value `x · m` at `x`'s binary point.
    fn emit_network(
        &mut self,
        xw: ValId,
        xv: &Val,
        m: i128,
        net: &shift_add::ShiftAddPlan,
        ty: IntTy,
        out: &mut Vec<LStmt>,
    ) -> ValId {
        let coefs: Vec<i128> = net.step_coefficients();
        let range = |coef: i128| -> (i128, i128) {
            let (a, b) = (xv.lo * coef, xv.hi * coef);
            (a.min(b), a.max(b))
        };
        let exact = |op, coef| NewVal::exact(op, ty, xv.frac, range(coef));
        let mut step_vals: Vec<ValId> = Vec::new();
        for (s, st) in net.steps.iter().enumerate() {
            let operand = |o: shift_add::Operand, sv: &Vec<ValId>| match o {
                shift_add::Operand::X => (xw, 1i128),
                shift_add::Operand::Step(j) => (sv[j], coefs[j]),
            };
            let (av, ac) = operand(st.a, &step_vals);
            let (bv, bc) = operand(st.b, &step_vals);
            let term = |v: ValId, c: i128, sh: u32, lw: &mut Self, out: &mut Vec<LStmt>| -> ValId {
                if sh == 0 {
                    return v;
                }
                let t = lw.push_fit(exact(Op::Shl(v, sh), c << sh), out);
                lw.vals[t.0].network = true;
                t
            };
            let mut ta = term(av, ac, st.a_shift, self, out);
            let tb = term(bv, bc, st.b_shift, self, out);
            if st.negate_a {
                ta = self.push_fit(exact(Op::Neg(ta), -(ac << st.a_shift)), out);
            }
            let op = if st.subtract {
                Op::Sub(ta, tb)
            } else {
                Op::Add(ta, tb)
            };
            step_vals.push(self.push_fit(exact(op, coefs[s]), out));
        }
        let (mut r, mut coef) = match net.result {
            shift_add::Operand::X => (xw, 1),
            shift_add::Operand::Step(j) => (step_vals[j], coefs[j]),
        };
        if net.final_shift > 0 {
            coef <<= net.final_shift;
            r = self.push_fit(exact(Op::Shl(r, net.final_shift), coef), out);
        }
        if net.negate {
            coef = -coef;
            r = self.push_fit(exact(Op::Neg(r), coef), out);
        }
        debug_assert_eq!(coef, m, "shift-add plan computes {coef}·x, wanted {m}·x");
        r
    }

    /// How many fraction bits `x` must drop before `x · c` fits 64-bit arithmetic, with `c`
    /// quantised by [`quantise`] (error ≤ ½ LSB of the rounded `x`): the fewest, so that the
    /// product keeps every bit of precision the words allow. A factor whose product with `x`
    /// lies below half an LSB of `x` would quantise to 0, and is refused; so is one whose
    /// product leaves the f64 range.
    fn factor_rounding(&self, x: ValId, c: f64, span: Span) -> Result<u32> {
        let xv = self.v(x);
        let xm = xv.lo.abs().max(xv.hi.abs());
        if c == 0.0 || xm == 0 {
            return Ok(0);
        }
        let mx = xm as f64 * pow2(-xv.frac);
        if !(c.abs() * mx).is_finite() {
            return Err(Diag::new(
                span,
                format!(
                    "the product with {} overflows: its magnitude exceeds the f64 range \
                     (±1.8e308), so neither the reference nor the fixed-point code can hold it",
                    crate::text::g(c)
                ),
            )
            .label("overflows")
            .help("change units so that the constants and ranges are closer to 1"));
        }
        if c.abs() * mx <= pow2(-xv.frac - 1) {
            return Err(Diag::new(
                span,
                format!(
                    "the factor {} vanishes in this product: |{} · x| ≤ {:.3e} is below half the \
                     resolution of the other factor (LSB {:.3e}), so the product would be 0",
                    crate::text::g(c),
                    crate::text::g(c),
                    c.abs() * mx,
                    pow2(-xv.frac)
                ),
            )
            .label("quantises to 0")
            .help(
                "remove the term if it is negligible; otherwise give the other factor a finer \
                 format (`#[lsb(..)]` or `#[q(..)]` on a `let` or its declaration), or change \
                 units so that the constant is larger",
            ));
        }
        let bits = 128 - xm.leading_zeros();
        for n in 0..bits {
            let (lo, hi) = self.rounded(xv.lo, xv.hi, n);
            let xm = lo.abs().max(hi.abs()).max(1);
            let mx = xm as f64 * pow2(n as i32 - xv.frac);
            if let Some((m, _)) = quantise(c, xv.frac - n as i32, mx) {
                if 128 - (xm * m.abs()).leading_zeros() + 2 <= 64 {
                    return Ok(n);
                }
            }
        }
        Err(too_wide_product(c, span))
    }
}

/// The largest coefficient `|c|` of any partial term `c·x` of the network computing `m·x`
/// (the shifted operands of each step, each step's value, and `m`): the working type must hold
/// `x` times it.
fn largest_term(m: i128, net: &shift_add::ShiftAddPlan) -> i128 {
    let coefs: Vec<i128> = net.step_coefficients();
    let coef_of = |o: shift_add::Operand| match o {
        shift_add::Operand::X => 1i128,
        shift_add::Operand::Step(j) => coefs[j],
    };
    let mut maxc = m.abs();
    for (s, st) in net.steps.iter().enumerate() {
        maxc = maxc
            .max(coef_of(st.a).abs() << st.a_shift)
            .max(coef_of(st.b).abs() << st.b_shift)
            .max(coefs[s].abs());
    }
    maxc
}

/// Quantises a non-zero constant factor `c` for a product with a value of `frac` fraction bits
/// and magnitude up to `mx` as `m·2^-k` (`m` odd), fine enough that
/// |c − m·2^-k|·mx ≤ ½ LSB of that value and |c − m·2^-k| ≤ [`CONST_REL`]·|c|, with the
/// fewest significant bits; `None` if that needs `|m| ≥ 2^62`.
///
/// The second bound is for a small constant on a coarse value (a unit conversion `x * 0.001`
/// of a power in W to 2^-5 W): half an LSB of `x` is in `x`'s unit, not the product's, and
/// alone it let `0.001` become `33·2^-15`, 0.7 % high.
fn quantise(c: f64, frac: i32, mx: f64) -> Option<(i128, i32)> {
    let tol = pow2(-frac - 1).min(c.abs() * mx * CONST_REL);
    // c·2^-e ∈ [1, 2); from k = -e - 1 on, m = round(c·2^k) is at least 1.
    let e = c.abs().log2().floor() as i32;
    for kk in (-e - 1)..(-e + 62) {
        // c·2^kk in two steps, so that neither factor over- or underflows.
        let mm = (c * pow2(kk / 2) * pow2(kk - kk / 2)).round();
        if mm.abs() >= pow2(62) {
            return None;
        }
        let (mut m, mut k) = (mm as i128, kk);
        if (c - mm * pow2(-kk / 2) * pow2(-(kk - kk / 2))).abs() * mx <= tol {
            while m != 0 && m % 2 == 0 {
                m /= 2;
                k -= 1;
            }
            return Some((m, k));
        }
    }
    None
}

/// The error for a constant factor whose product cannot be held in 64-bit arithmetic.
fn too_wide_product(c: f64, span: Span) -> Diag {
    Diag::new(
        span,
        format!(
            "the product with {} cannot be computed in 64-bit arithmetic at the precision qloop \
             guarantees (the constant quantised within half an LSB of the other factor)",
            crate::text::g(c)
        ),
    )
    .help("narrow the other factor's range, or change units so that the constant is closer to 1")
}
