/*
 * Koren & Masory (1981) with direct division, in C `float`: the floating-point baseline
 * of the algorithm the paper avoids (Koren & Masory 1981, eqs. 2-3). Hand-written; see
 * koren_masory_1981_div.h for the derivation, parameters and limits.
 *
 * C99, no library calls (min/max inline, no libm), no double: compiles with
 * gcc -std=c99 -Wall -Wextra -Werror -Wdouble-promotion.
 */
#include "koren_masory_1981_div.h"

static inline float clampf(float x, float lo, float hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

void koren_masory_1981_divf_init(koren_masory_1981_divf_state *self)
{
    self->kp = KOREN_MASORY_1981_DIV_KP_INIT;
    self->kc = KOREN_MASORY_1981_DIV_KC_INIT;
    self->u = KOREN_MASORY_1981_DIV_U_INIT;
}

void koren_masory_1981_divf_step(koren_masory_1981_divf_state *self,
                                 const koren_masory_1981_divf_inputs *in,
                                 koren_masory_1981_divf_outputs *out)
{
    const float fc = clampf(in->fc, KOREN_MASORY_1981_DIV_FC_LO, KOREN_MASORY_1981_DIV_FC_HI);
    /* Force error E(i) = F_r - F_c(i). */
    const float e = KOREN_MASORY_1981_DIV_FR - fc;
    /* Both gains freeze in air cuts, as in the spec. */
    if (fc > KOREN_MASORY_1981_DIV_F_AIR) {
        /* K_p = F_c / U (Koren & Masory 1981, eq. 2), from the force and the command U(i-1) behind it. */
        const float kp = clampf(fc / self->u, KOREN_MASORY_1981_DIV_KP_LO,
                                KOREN_MASORY_1981_DIV_KP_HI);
        self->kp = kp;
        /* K_c = K / K_p (Koren & Masory 1981, eq. 3). */
        self->kc = clampf(KOREN_MASORY_1981_DIV_K_LOOP / kp, KOREN_MASORY_1981_DIV_KC_LO,
                          KOREN_MASORY_1981_DIV_KC_HI);
    }
    /* U(i) = U(i-1) + K_c E(i) (Koren's survey, eq. 8), saturated to the feed limits. */
    self->u = clampf(self->u + self->kc * e, KOREN_MASORY_1981_DIV_U_LO,
                     KOREN_MASORY_1981_DIV_U_HI);
    out->feed = self->u;
}
