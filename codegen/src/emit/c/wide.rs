//! 64-bit products and right shifts on targets whose C compiler makes them library calls.
//!
//! A product of two factors proved to fit `int32_t` whose result is 64 bits wide (every
//! variable product of an estimating controller) is `qloop_NAME_mul64(a, b)`: on an AVR core
//! with a hardware multiplier, sixteen 8×8 `MUL`s summed column by column into the eight result
//! bytes (product scanning), then the two's-complement correction of the high half (minus
//! `b·2^32` when `a < 0`, minus `a·2^32` when `b < 0`); see [`product_helper`]. Exact: the same
//! value as the plain C of the `#else` branch, which other compilers and Frama-C see. One
//! product, its operands loaded from memory and the result stored, takes 158 cycles against
//! 243 with avr-gcc's `__mulsidi3` (simavr; the loads and stores alone about 30). `tests/tests/c_output.rs` runs it in simavr on edge and random factors
//! against avr-gcc's `int64_t` product, and in three controllers against the interpreter.
//!
//! avr-gcc (5.4, Debian's) compiles every `int64_t` shift as a libgcc call that moves the value
//! one bit at a time over its eight bytes (`__ashrdi3`, `__lshrdi3`: about ten cycles a bit).
//! A right shift whose result is proved to fit 32 bits (the alignment of a 32×32→64 product,
//! the commonest shift of an estimating controller) is written instead as a read of the four
//! bytes that hold the result, and a few bits of the next (`qloop_NAME_sar64`), through a union
//! (GCC defines it; little-endian). Under other compilers, on big-endian targets and for Frama-C
//! it is the plain shift, the same function. `tests/tests/c_output.rs` runs it in simavr
//! against the interpreter.
//!
//! Tried and not kept (2026-12-01, `qloop bench` on atmega328p): the other 64-bit shifts
//! through the same union (whole bytes moved in a loop, then each half shifted by the `r < 8`
//! bits left) made GAC slower, 11,815 → 14,164 cycles for the right shifts and 13,016 for the
//! left ones, as avr-gcc keeps the union in the stack frame; casting a 64-bit product's factors
//! to `int32_t` where both are proved to fit changed nothing (avr-gcc already finds
//! `__mulsidi3`). After the product helper: a whole-byte left shift of a 32-bit value into a
//! 64-bit one written as its two words through the union (`x · 2^24`, `x · 2^32`) took GAC
//! 9,089 → 8,991 cycles and milling_zoh 30,507 → 29,671, but made every controller with one
//! larger (GAC +48 B, milling_zoh +356 B, the multi-model controller +1.8 KB); a whole-byte
//! right shift with a 64-bit result moved byte by byte through the union made GAC slower
//! (9,240).

use super::{c_ty, name};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;
use std::fmt::Write as _;

/// The helpers, prefixed `qloop_` (the emitter makes it `qloop_NAME_`).
pub(super) const HELPERS: &str = "/* floor(x / 2^k) of an int64_t whose result fits int32_t (proved), from the bytes of x:\n\
 * avr-gcc shifts an int64_t in libgcc, one bit at a time. Exact: the same as the plain C of\n\
 * the #else branch, which other compilers and Frama-C see. */\n\
#if defined(__GNUC__) && !defined(__FRAMAC__) && defined(__BYTE_ORDER__) && \\\n\
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__\n\
typedef union { int64_t v; int32_t w[2]; uint8_t b[8]; } qloop_i64_bytes;\n\
/* floor(x / 2^k), 0 < k < 64, whose result fits int32_t (proved): bits k .. k + 31 of x. */\n\
static inline __attribute__((always_inline)) int32_t qloop_sar64(int64_t x, unsigned k)\n\
{\n\
    qloop_i64_bytes u;\n\
    u.v = x;\n\
    if (k >= 32u) {\n\
        int32_t h = (int32_t)(u.w[1] >> ((k - 32u) & ~7u));\n\
        QLOOP_KEEP(h);\n\
        return (int32_t)(h >> ((k - 32u) & 7u));\n\
    }\n\
    const unsigned q = k >> 3, r = k & 7u;\n\
    uint32_t w = (uint32_t)u.b[q] | ((uint32_t)u.b[q + 1u] << 8) | ((uint32_t)u.b[q + 2u] << 16) |\n\
                 ((uint32_t)u.b[q + 3u] << 24);\n\
    if (r == 0u) {\n\
        return (int32_t)w;\n\
    }\n\
    w = (uint32_t)(w >> r) | ((uint32_t)(uint8_t)(u.b[q + 4u] << (8u - r)) << 24);\n\
    return (int32_t)w;\n\
}\n\
#else\n\
static inline int32_t qloop_sar64(int64_t x, unsigned k) { return (int32_t)(x >> k); }\n\
#endif\n\n";

/// The product helper's text, prefixed `qloop_` (the emitter makes it `qloop_NAME_`).
///
/// A `static noinline` C function around one `asm` block with the operands in avr-gcc's
/// argument registers: `a` in r22..r25, `b` in r18..r21, the product returned in r18..r25. The
/// block sums the byte products of each column k (bytes i + j = k) into the result bytes k,
/// k + 1 and k + 2: a column's sum, at most four products of 255·255 plus the carry of the
/// column before (< 2^16), is below 2^19, so nothing carries past byte k + 2, which is still
/// zero. While `a` and `b` are read, the low four bytes sit in r12..r15 and the high four in X
/// and Z, with r16 a zero; the block saves and restores r12..r16 itself, and leaves r1 zero.
/// One copy serves every product of the step, and GCC (`-fipa-ra`) knows which registers the
/// call clobbers. Measured on GAC and milling_zoh (`qloop bench` on atmega328p, 2026-12-01;
/// libgcc's products: 11,815 cycles and 9,664 B, 36,010 and 24,494 B): this form 9,089 and
/// 9,040 B, 30,507 and 24,376 B; inlined at every product 8,240 cycles but 14,046 B for GAC
/// and 44 KB, too large for the chip, for milling_zoh; a routine called from an `asm` with the
/// product pinned to r10..r17, 8,362 and 9,024 B but 31,029 and 28,248 B; an assembly
/// function called as an ordinary external one, 9,192 and 26,298 B; a fused
/// product-round-shift returning 32 bits, slower (8,500 inlined, 9,993 not).
pub(super) fn product_helper() -> String {
    let a = ["r22", "r23", "r24", "r25"];
    let b = ["r18", "r19", "r20", "r21"];
    // The product's bytes while a and b are still read: 0-3 in r12-r15, 4-7 in X and Z.
    let r = ["r12", "r13", "r14", "r15", "r26", "r27", "r30", "r31"];
    let zero = "r16";
    let saved = ["r12", "r13", "r14", "r15", "r16"];
    let mut asm: Vec<String> = saved.iter().map(|x| format!("push {x}")).collect();
    asm.push(format!("clr {zero}"));
    asm.push("/* column 0 */".to_string());
    asm.push(format!("mul {},{}", a[0], b[0]));
    asm.push(format!("movw {},r0", r[0]));
    asm.extend((2..8).map(|i| format!("clr {}", r[i])));
    for k in 1..=6usize {
        asm.push(format!("/* column {k} */"));
        for i in k.saturating_sub(3)..=k.min(3) {
            asm.push(format!("mul {},{}", a[i], b[k - i]));
            asm.push(format!("add {},r0", r[k]));
            asm.push(format!("adc {},r1", r[k + 1]));
            if k < 6 {
                asm.push(format!("adc {},{zero}", r[k + 2]));
            }
        }
    }
    asm.push("clr r1".to_string());
    asm.push("/* the signs: minus b * 2^32 if a < 0, minus a * 2^32 if b < 0 */".to_string());
    for (neg, sub) in [(&a, &b), (&b, &a)] {
        asm.push(format!("sbrs {},7", neg[3]));
        asm.push("rjmp 1f".to_string());
        asm.push(format!("sub {},{}", r[4], sub[0]));
        for i in 1..4 {
            asm.push(format!("sbc {},{}", r[4 + i], sub[i]));
        }
        asm.push("1:".to_string());
    }
    asm.push("/* the product into r18-r25 */".to_string());
    for (to, from) in [("r18", r[0]), ("r20", r[2]), ("r22", r[4]), ("r24", r[6])] {
        asm.push(format!("movw {to},{from}"));
    }
    asm.extend(saved.iter().rev().map(|x| format!("pop {x}")));
    let body = asm_template(&asm);
    format!(
        "/* a * b of int32_t factors, exactly. On an AVR core with MUL: the sixteen byte products\n\
         \x20* summed column by column into the eight result bytes (each column's sum fits three\n\
         \x20* bytes), then the high half corrected for the factors' signs (minus b * 2^32 if\n\
         \x20* a < 0, minus a * 2^32 if b < 0); 158 cycles against 243 for\n\
         \x20* avr-gcc's __mulsidi3 (simavr, operands from memory).\n\
         \x20* Elsewhere, and for Frama-C, the plain product. */\n\
         {AVR_MUL_ASM}\n\
         static __attribute__((noinline)) int64_t qloop_mul64(int32_t a, int32_t b)\n\
         {{\n\
         \x20   register int32_t ra __asm__(\"r22\") = a;\n\
         \x20   register int32_t rb __asm__(\"r18\") = b;\n\
         \x20   register int64_t rr __asm__(\"r18\");\n\
         \x20   __asm__(\n\
         {body}\x20       : \"=r\"(rr) : \"r\"(ra), \"r\"(rb) : \"r26\", \"r27\", \"r30\", \"r31\");\n\
         \x20   return rr;\n\
         }}\n\
         #else\n\
         static inline int64_t qloop_mul64(int32_t a, int32_t b) {{ return (int64_t)a * b; }}\n\
         #endif\n\n"
    )
}

/// The high-product helper ([`Op::MulHi`], `lower::lir::mul_hi`), prefixed `qloop_`.
///
/// On an AVR core with `MUL`: a `static noinline` function around one `asm` block, `a` in
/// r22..r25, `b` in r18..r21, the result in r22..r25. Each of the three pieces is an unsigned
/// 16×16 product of four `MUL`s into r26, r27, r30, r31, corrected for the signed halves
/// modulo 2^32 (`h(a)·l(b) = h(a)ᵤ·l(b) − 2^16·l(b)` when `a < 0`; `h(a)·h(b) = h(a)ᵤ·h(b)ᵤ
/// − 2^16·h(b) − 2^16·h(a)` for the negative ones), which is exact because each signed piece
/// fits 32 bits. The sum accumulates in r12..r15, r16 is a zero; the block saves and restores
/// them and leaves r1 zero. Twelve `MUL`s against the sixteen of the 64-bit product, and no
/// 64-bit shift or add after it. Elsewhere, and for Frama-C, the plain C of the same formula.
/// `tests/tests/c_output.rs` runs it in simavr against [`crate::lower::lir::mul_hi`].
pub(super) fn high_product_helper() -> String {
    let (a, b) = (["r22", "r23", "r24", "r25"], ["r18", "r19", "r20", "r21"]);
    let zero = "r16";
    let mut asm: Vec<String> = Vec::new();
    let saved = ["r12", "r13", "r14", "r15", "r16"];
    asm.extend(saved.iter().map(|r| format!("push {r}")));
    asm.push(format!("clr {zero}"));
    // x1:x0 times y1:y0, unsigned, into r31:r30:r27:r26.
    let mul16 = |asm: &mut Vec<String>, x: [&str; 2], y: [&str; 2]| {
        asm.push(format!("mul {},{}", x[0], y[0]));
        asm.push("movw r26,r0".to_string());
        asm.push(format!("mul {},{}", x[1], y[1]));
        asm.push("movw r30,r0".to_string());
        for (p, q) in [(x[0], y[1]), (x[1], y[0])] {
            asm.push(format!("mul {p},{q}"));
            asm.push("add r27,r0".to_string());
            asm.push("adc r30,r1".to_string());
            asm.push(format!("adc r31,{zero}"));
        }
    };
    // minus 2^16 * (y1:y0) when x is negative.
    let fix = |asm: &mut Vec<String>, sign: &str, y: [&str; 2]| {
        asm.push(format!("sbrs {sign},7"));
        asm.push("rjmp 1f".to_string());
        asm.push(format!("sub r30,{}", y[0]));
        asm.push(format!("sbc r31,{}", y[1]));
        asm.push("1:".to_string());
    };
    asm.push("/* h(a) * l(b) >> 16, sign-extended into r12..r15 */".to_string());
    mul16(&mut asm, [a[2], a[3]], [b[0], b[1]]);
    fix(&mut asm, a[3], [b[0], b[1]]);
    asm.push("movw r12,r30".to_string());
    asm.push("clr r14".to_string());
    asm.push("sbrc r13,7".to_string());
    asm.push("com r14".to_string());
    asm.push("mov r15,r14".to_string());
    asm.push("/* + l(a) * h(b) >> 16 */".to_string());
    mul16(&mut asm, [a[0], a[1]], [b[2], b[3]]);
    fix(&mut asm, b[3], [a[0], a[1]]);
    asm.push("clr r26".to_string());
    asm.push("sbrc r31,7".to_string());
    asm.push("com r26".to_string());
    asm.push("add r12,r30".to_string());
    asm.push("adc r13,r31".to_string());
    asm.push("adc r14,r26".to_string());
    asm.push("adc r15,r26".to_string());
    asm.push("/* + h(a) * h(b) */".to_string());
    mul16(&mut asm, [a[2], a[3]], [b[2], b[3]]);
    fix(&mut asm, a[3], [b[2], b[3]]);
    fix(&mut asm, b[3], [a[2], a[3]]);
    asm.push("add r12,r26".to_string());
    asm.push("adc r13,r27".to_string());
    asm.push("adc r14,r30".to_string());
    asm.push("adc r15,r31".to_string());
    asm.push("clr r1".to_string());
    asm.push("movw r22,r12".to_string());
    asm.push("movw r24,r14".to_string());
    asm.extend(saved.iter().rev().map(|r| format!("pop {r}")));
    let body = asm_template(&asm);
    format!(
        "/* The high word of a * b from three 16 x 16 -> 32-bit pieces, h(x) = x >> 16 and\n\
         \x20* l(x) = x & 0xFFFF: h(a)h(b) + (h(a)l(b) >> 16) + (l(a)h(b) >> 16), within 3 below\n\
         \x20* a * b / 2^32 (qloop's plan, lower::lir::mul_hi); every piece fits int32_t. On an\n\
         \x20* AVR core with MUL: twelve byte products, each piece corrected for the signs of the\n\
         \x20* halves. Elsewhere, and for Frama-C, the plain formula. */\n\
         {AVR_MUL_ASM}\n\
         static __attribute__((noinline)) int32_t qloop_mulhi(int32_t a, int32_t b)\n\
         {{\n\
         \x20   register int32_t ra __asm__(\"r22\") = a;\n\
         \x20   register int32_t rb __asm__(\"r18\") = b;\n\
         \x20   __asm__(\n\
         {body}\x20       : \"+r\"(ra) : \"r\"(rb) : \"r26\", \"r27\", \"r30\", \"r31\");\n\
         \x20   return ra;\n\
         }}\n\
         #else\n\
         static int32_t qloop_mulhi(int32_t a, int32_t b)\n\
         {{\n\
         \x20   const int32_t ha = a >> 16, hb = b >> 16;\n\
         \x20   return ha * hb + ((ha * (b & 0xFFFF)) >> 16) + (((a & 0xFFFF) * hb) >> 16);\n\
         }}\n\
         #endif\n\n"
    )
}

/// The preprocessor test under which a helper is its `asm` form: avr-gcc on a core with `MUL`,
/// and not Frama-C, which reads the plain C of the same function instead.
const AVR_MUL_ASM: &str =
    "#if defined(__GNUC__) && defined(__AVR__) && defined(__AVR_HAVE_MUL__) && !defined(__FRAMAC__)";

/// The lines of an `asm` block as the C string literals of its template, one instruction a
/// line (`"mul r22,r18\n"`), a `/* ... */` line kept as a C comment between them.
fn asm_template(asm: &[String]) -> String {
    let mut body = String::new();
    for l in asm {
        if l.starts_with("/*") {
            let _ = writeln!(body, "        {l}");
        } else {
            let _ = writeln!(body, "        \"{l}\\n\"");
        }
    }
    body
}

/// Whether the step has an [`Op::MulHi`].
pub(super) fn high_products(plan: &Plan) -> bool {
    plan.vals.iter().any(|v| matches!(v.op, Op::MulHi(..)))
}

/// The `qloop_NAME_mul64` call that value `id` is, if it is a 64-bit product of two values
/// proved to fit 32 bits, on a target whose 64-bit arithmetic is library calls.
pub(super) fn product(plan: &Plan, id: ValId) -> Option<String> {
    let v = plan.val(id);
    let Op::Mul(a, b) = v.op else {
        return None;
    };
    let fits = fits32(plan, a) && fits32(plan, b);
    (plan.target.libcall(64) && v.ty.bits == 64 && v.ty.signed && fits).then(|| {
        format!(
            "({})qloop_{}_mul64((int32_t){}, (int32_t){})",
            c_ty(v.ty),
            plan.prog.name,
            name(plan, a),
            name(plan, b)
        )
    })
}

/// Whether the step has a product that [`product`] writes.
pub(super) fn multiplies(plan: &Plan) -> bool {
    (0..plan.vals.len()).any(|i| product(plan, ValId(i)).is_some())
}

/// The `qloop_NAME_sar64` call that value `id` is, if it is a right shift of a 64-bit value
/// whose result fits 32 bits, on a target whose 64-bit shifts are library calls.
pub(super) fn shift(plan: &Plan, id: ValId) -> Option<String> {
    let v = plan.val(id);
    let Op::Shr(a, k) = v.op else {
        return None;
    };
    let wide = plan.val(a).ty.bits == 64;
    (plan.target.libcall(64) && wide && fits32(plan, id) && k > 0 && k < 64).then(|| {
        format!(
            "({})qloop_{}_sar64({}, {k}u)",
            c_ty(v.ty),
            plan.prog.name,
            name(plan, a)
        )
    })
}

/// Whether the step has a shift that [`shift`] writes.
pub(super) fn used(plan: &Plan) -> bool {
    (0..plan.vals.len()).any(|i| shift(plan, ValId(i)).is_some())
}

/// Whether value `id`'s proved interval fits `int32_t`.
fn fits32(plan: &Plan, id: ValId) -> bool {
    let v = plan.val(id);
    v.lo >= i128::from(i32::MIN) && v.hi <= i128::from(i32::MAX)
}
