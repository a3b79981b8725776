/*
 * Koren & Masory (1981) with direct division, in Q-format integers: the fixed-point
 * baseline of the algorithm the paper avoids (Koren & Masory 1981, eqs. 2-3: "requires
 * a direct division, which is a very complicated and slow operation"). Hand-written; see
 * koren_masory_1981_div.h for the derivation, parameters and limits.
 *
 * Formats: every signal is Q12 in an int16_t (the formats qloop gives the spec's fc, km,
 * kc, u, feed), the arithmetic is 32-bit. Per step: two 32/32-bit divisions (a library call
 * on AVR and Cortex-M0, a 2-12 cycle UDIV on Cortex-M3/M4), one 16x16->32 multiply, shifts,
 * adds and compares.
 *
 * Written as a competent engineer would for a small core, without changing the algorithm:
 * both divisions have non-negative operands (F_c > F_air > 0, U and K_p within positive
 * limits), so they are unsigned (__udivmodsi4 on AVR, without the sign handling of
 * __divmodsi4), and the clamps compare 16-bit values where the values are 16-bit. The
 * earlier signed-division version computed bit for bit the same outputs and states (checked
 * on 5 million random steps) in 1493 instead of 1428 cycles per step on the ATmega328P.
 *
 * Range of every intermediate (so nothing overflows; casts keep AVR's 16-bit int out of the
 * arithmetic):
 *   fc in [0, 20480], e = FR - fc in [-14336, 6144];
 *   fc << 12 <= 83886080 < 2^32, and u >= 205 > 0 (precondition), quotient <= 409600;
 *   K << 12 = 20971520, and kp >= 1024 after the clamp, quotient <= 20480;
 *   kc * e: |.| <= 20480 * 14336 = 293601280 < 2^31.
 * Unsigned division truncates, i.e. floors non-negative values, like the spec's
 * `rounding floor`. The product kc * e is floored by an arithmetic right shift; C leaves >>
 * of a negative value implementation-defined, GCC and Clang define it as arithmetic (the
 * file-scope check below refuses to compile elsewhere), as qloop's generated C assumes too.
 *
 * C99, <stdint.h> only, no floating point, no library calls beyond what the compiler emits
 * for `/`.
 */
#include "koren_masory_1981_div.h"

typedef char koren_masory_1981_divi_arithmetic_shift_check[((-8) >> 1) == -4 ? 1 : -1];

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
    /* F_c clamped to [0, 5] kN, in its own 16 bits. */
    int16_t fc = in->fc;
    if (fc < KOREN_MASORY_1981_DIVI_FC_MIN) {
        fc = KOREN_MASORY_1981_DIVI_FC_MIN;
    } else if (fc > KOREN_MASORY_1981_DIVI_FC_MAX) {
        fc = KOREN_MASORY_1981_DIVI_FC_MAX;
    }
    const int16_t u = self->u;
    if (fc > KOREN_MASORY_1981_DIVI_F_AIR) {
        /* K_p = F_c / U (Koren & Masory 1981, eq. 2): (Q12 << 12) / Q12 = Q12. Both are positive (U never
         * leaves its limits), so the division is unsigned: __udivmodsi4, without the sign
         * handling of the signed one. */
        uint32_t kp = ((uint32_t)(uint16_t)fc << 12) / (uint16_t)u;
        if (kp < KOREN_MASORY_1981_DIVI_KP_MIN) {
            kp = KOREN_MASORY_1981_DIVI_KP_MIN;
        } else if (kp > KOREN_MASORY_1981_DIVI_KP_MAX) {
            kp = KOREN_MASORY_1981_DIVI_KP_MAX;
        }
        /* K_c = K / K_p (Koren & Masory 1981, eq. 3): (Q12 << 12) / Q12 = Q12; K_p > 0 after the clamp. */
        uint16_t kc = (uint16_t)(((uint32_t)KOREN_MASORY_1981_DIVI_K_LOOP << 12) / (uint16_t)kp);
        if (kc < KOREN_MASORY_1981_DIVI_KC_MIN) {
            kc = KOREN_MASORY_1981_DIVI_KC_MIN;
        } else if (kc > KOREN_MASORY_1981_DIVI_KC_MAX) {
            kc = KOREN_MASORY_1981_DIVI_KC_MAX;
        }
        self->kp = (int16_t)kp;
        self->kc = (int16_t)kc;
    }
    /* Force error E(i) = F_r - F_c(i), Q12, within [-14336, 6144]. U(i) = U(i-1) + K_c E(i)
     * (Koren's survey, eq. 8): a 16x16->32 multiply, floored to Q12 by an arithmetic shift. */
    const int16_t e = (int16_t)(KOREN_MASORY_1981_DIVI_FR - fc);
    int32_t un = (int32_t)u + (((int32_t)self->kc * e) >> 12);
    if (un < KOREN_MASORY_1981_DIVI_U_MIN) {
        un = KOREN_MASORY_1981_DIVI_U_MIN;
    } else if (un > KOREN_MASORY_1981_DIVI_U_MAX) {
        un = KOREN_MASORY_1981_DIVI_U_MAX;
    }
    self->u = (int16_t)un;
    out->feed = (int16_t)un;
}
