//! Right shifts of 64-bit values on targets whose C compiler makes them library calls.
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
//! `__mulsidi3`).

use super::{c_ty, name};
use crate::lower::lir::{Op, ValId};
use crate::lower::Plan;

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

/// The `qloop_NAME_sar64` call that value `id` is, if it is a right shift of a 64-bit value
/// whose result fits 32 bits, on a target whose 64-bit shifts are library calls.
pub(super) fn shift(plan: &Plan, id: ValId) -> Option<String> {
    let v = plan.val(id);
    let Op::Shr(a, k) = v.op else {
        return None;
    };
    let fits32 = v.lo >= i128::from(i32::MIN) && v.hi <= i128::from(i32::MAX);
    let wide = plan.val(a).ty.bits == 64;
    (plan.target.libcall(64) && wide && fits32 && k > 0 && k < 64).then(|| {
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
