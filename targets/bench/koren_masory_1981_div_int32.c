/*
 * Koren & Masory (1981) with direct division, in Q-format integers: the fixed-point
 * baseline of the algorithm the paper avoids (000_b8cbacf29caa8fe2.txt eqs. 2-3: "requires
 * a direct division, which is a very complicated and slow operation"). Hand-written; see
 * koren_masory_1981_div.h for the derivation, parameters and limits.
 *
 * Formats: every signal is Q12 in an int16_t (the formats qloop gives the spec's fc, km,
 * kc, u, feed), the arithmetic is int32_t. Per step: two 32/32-bit signed divisions
 * (a library call on AVR and Cortex-M0, a 2-12 cycle SDIV on Cortex-M3/M4), one 16x16->32
 * multiply, shifts, adds and compares.
 *
 * Range of every intermediate (so nothing overflows int32_t; casts keep AVR's 16-bit int
 * out of the arithmetic):
 *   fc in [0, 20480], e = FR - fc in [-14336, 6144];
 *   fc << 12 <= 83886080 < 2^31, and u >= 205 > 0 (precondition), quotient <= 409600;
 *   K << 12 = 20971520, and kp >= 1024 after the clamp, quotient <= 20480;
 *   kc * e: |.| <= 20480 * 14336 = 293601280 < 2^31.
 * Divisions of non-negative values truncate, i.e. floor, like the spec's `rounding floor`.
 * The product kc * e is floored by an arithmetic right shift; C leaves >> of a negative
 * value implementation-defined, GCC and Clang define it as arithmetic (the file-scope
 * check below refuses to compile elsewhere), as qloop's generated C assumes too.
 *
 * C99, <stdint.h> only, no floating point, no library calls beyond what the compiler emits
 * for `/`.
 */
#include "koren_masory_1981_div.h"

typedef char koren_masory_1981_divi_arithmetic_shift_check[((-8) >> 1) == -4 ? 1 : -1];

static inline int32_t clamp32(int32_t x, int32_t lo, int32_t hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

void koren_masory_1981_divi_init(koren_masory_1981_divi_state *self)
{
    self->kp = (int16_t)KOREN_MASORY_1981_DIVI_KP_INIT;
    self->kc = (int16_t)KOREN_MASORY_1981_DIVI_KC_INIT;
    self->u = (int16_t)KOREN_MASORY_1981_DIVI_U_INIT;
}

void koren_masory_1981_divi_step(koren_masory_1981_divi_state *self,
                                 const koren_masory_1981_divi_inputs *in,
                                 koren_masory_1981_divi_outputs *out)
{
    const int32_t fc = clamp32((int32_t)in->fc, (int32_t)KOREN_MASORY_1981_DIVI_FC_MIN,
                               (int32_t)KOREN_MASORY_1981_DIVI_FC_MAX);
    /* Force error E(i) = F_r - F_c(i), Q12. */
    const int32_t e = (int32_t)KOREN_MASORY_1981_DIVI_FR - fc;
    int32_t u = (int32_t)self->u;
    if (fc > (int32_t)KOREN_MASORY_1981_DIVI_F_AIR) {
        /* K_p = F_c / U (000 eq. 2): (Q12 << 12) / Q12 = Q12. */
        const int32_t kp = clamp32((fc << 12) / u, (int32_t)KOREN_MASORY_1981_DIVI_KP_MIN,
                                   (int32_t)KOREN_MASORY_1981_DIVI_KP_MAX);
        /* K_c = K / K_p (000 eq. 3): (Q12 << 12) / Q12 = Q12. */
        const int32_t kc = clamp32(((int32_t)KOREN_MASORY_1981_DIVI_K_LOOP << 12) / kp,
                                   (int32_t)KOREN_MASORY_1981_DIVI_KC_MIN,
                                   (int32_t)KOREN_MASORY_1981_DIVI_KC_MAX);
        self->kp = (int16_t)kp;
        self->kc = (int16_t)kc;
    }
    /* U(i) = U(i-1) + K_c E(i) (002 eq. 8): Q12 * Q12 = Q24, floored to Q12. e fits an
     * int16_t, so this is the same 16x16->32 widening multiply the qloop controller uses. */
    u = clamp32(u + (((int32_t)self->kc * (int32_t)(int16_t)e) >> 12), (int32_t)KOREN_MASORY_1981_DIVI_U_MIN,
                (int32_t)KOREN_MASORY_1981_DIVI_U_MAX);
    self->u = (int16_t)u;
    out->feed = (int16_t)u;
}
