/*
 * Koren & Masory (1981), direct-division formulation: the baseline the paper avoids.
 *
 * Hand-written benchmark baselines for `qloop bench` (not generated). The paper
 * (Koren & Masory 1981, an OCR extraction; equations read from its LaTeX, the figures
 * are lost) first states the obvious algorithm and then rejects it because "implementation
 * of the algorithm based upon eqs. (2) and (3) requires a direct division, which is a very
 * complicated and slow operation in assembly language":
 *
 *   K_p = F_c / U      (Koren & Masory 1981, eq. 2: the process gain K_h K_s a/n, at steady state)
 *   K_c = K / K_p      (Koren & Masory 1981, eq. 3: controller gain for the desired open-loop gain K)
 *   U(i) = U(i-1) + K_c E(i),  E = F_r - F_c     (Koren's survey, eq. 8, the ACC integral law)
 *
 * Eq. 2 holds only "at steady-state"; read as an estimator it is evaluated every period
 * from the current force F_c(i) and the command U(i-1) that produced it, exactly where the
 * division-free estimator of eqs. 8-9 uses the same pair. K_c then follows the new K_p at
 * once (eq. 3 has no dynamics), while the qloop spec's eqs. 12-13 integrate toward it.
 *
 * Everything else is verified/specs/koren_masory_1981.qloop: T = 0.1 s, F_r = 1.5 kN,
 * K = 1.25, air-cut threshold 0.15 kN (both gains freeze at or below it), the same limits:
 * K_p within the spec's K_m range [0.25, 6] kN/(mm/s), K_c within [0.2083, 5] (mm/s)/kN,
 * U within [0.05, 5] mm/s, and the same initial values (K_p = 1, K_c = 1.25, U = 0.5).
 * The input F_c is clamped to [0, 5] kN on entry.
 *
 * Two versions, same API shape as the generated controllers (NAME_init / NAME_step):
 *
 * - koren_masory_1981_divf_*: C `float`, physical units (koren_masory_1981_div_float.c).
 * - koren_masory_1981_divi_*: Q-format integers with real `/` divisions
 *   (koren_masory_1981_div_int32.c). Inputs, outputs and states are int16_t in Q12
 *   (raw = value * 2^12), the formats qloop gives the spec's fc, km, kc, u and feed; all
 *   arithmetic is int32_t, so the only difference from the qloop controller is the
 *   algorithm: two 32/32-bit divisions per step instead of the integrating loops.
 *
 * Precondition of both steps: the state was set by init and only changed by step (U is
 * then at least its lower limit, so the division by U never divides by zero).
 */
#ifndef QLOOP_KOREN_MASORY_1981_DIV_H
#define QLOOP_KOREN_MASORY_1981_DIV_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Parameters and limits (physical; verified/specs/koren_masory_1981.qloop) ---- */
#define KOREN_MASORY_1981_DIV_FR 1.5f        /* reference force F_r, kN */
#define KOREN_MASORY_1981_DIV_K_LOOP 1.25f   /* desired open-loop gain K (Koren & Masory 1981, eq. 3, 11) */
#define KOREN_MASORY_1981_DIV_F_AIR 0.15f    /* air-cut threshold, kN */
#define KOREN_MASORY_1981_DIV_FC_LO 0.0f     /* input range of F_c, kN */
#define KOREN_MASORY_1981_DIV_FC_HI 5.0f
#define KOREN_MASORY_1981_DIV_KP_LO 0.25f    /* K_p limits = the spec's K_m range, kN/(mm/s) */
#define KOREN_MASORY_1981_DIV_KP_HI 6.0f
#define KOREN_MASORY_1981_DIV_KC_LO 0.20833333f  /* K_c limits K/K_m,max, K/K_m,min (1.25/6, 1.25/0.25), (mm/s)/kN */
#define KOREN_MASORY_1981_DIV_KC_HI 5.0f
#define KOREN_MASORY_1981_DIV_U_LO 0.05f     /* feed limits, mm/s */
#define KOREN_MASORY_1981_DIV_U_HI 5.0f
#define KOREN_MASORY_1981_DIV_KP_INIT 1.0f   /* initial values (the spec's km, kc, u) */
#define KOREN_MASORY_1981_DIV_KC_INIT 1.25f
#define KOREN_MASORY_1981_DIV_U_INIT 0.5f

/* ---- float version ---- */

#define KOREN_MASORY_1981_DIVF_PERIOD_US 100000UL

typedef struct koren_masory_1981_divf_inputs {
    float fc; /* measured cutting force F_c, kN */
} koren_masory_1981_divf_inputs;

typedef struct koren_masory_1981_divf_outputs {
    float feed; /* feed command U, mm/s */
} koren_masory_1981_divf_outputs;

typedef struct koren_masory_1981_divf_state {
    float kp; /* process gain estimate K_p = F_c/U, kN/(mm/s) */
    float kc; /* controller gain K_c = K/K_p, (mm/s)/kN */
    float u;  /* feed command U, mm/s */
} koren_masory_1981_divf_state;

void koren_masory_1981_divf_init(koren_masory_1981_divf_state *self);
void koren_masory_1981_divf_step(koren_masory_1981_divf_state *self,
                                 const koren_masory_1981_divf_inputs *in,
                                 koren_masory_1981_divf_outputs *out);

/* ---- int32 Q-format version (raw = value * 2^FRAC) ---- */

#define KOREN_MASORY_1981_DIVI_PERIOD_US 100000UL
#define KOREN_MASORY_1981_DIVI_FC_FRAC 12
#define KOREN_MASORY_1981_DIVI_FC_MIN 0          /* [0, 5] kN */
#define KOREN_MASORY_1981_DIVI_FC_MAX 20480
#define KOREN_MASORY_1981_DIVI_KP_FRAC 12
#define KOREN_MASORY_1981_DIVI_KP_MIN 1024       /* [0.25, 6] */
#define KOREN_MASORY_1981_DIVI_KP_MAX 24576
#define KOREN_MASORY_1981_DIVI_KC_FRAC 12
#define KOREN_MASORY_1981_DIVI_KC_MIN 854        /* ceil(0.2083 * 4096) = ceil(853.2) */
#define KOREN_MASORY_1981_DIVI_KC_MAX 20480
#define KOREN_MASORY_1981_DIVI_U_FRAC 12
#define KOREN_MASORY_1981_DIVI_U_MIN 205         /* ceil(0.05 * 4096) = ceil(204.8) */
#define KOREN_MASORY_1981_DIVI_U_MAX 20480
#define KOREN_MASORY_1981_DIVI_FEED_FRAC 12
#define KOREN_MASORY_1981_DIVI_KP_INIT 4096      /* 1.0 */
#define KOREN_MASORY_1981_DIVI_KC_INIT 5120      /* 1.25 */
#define KOREN_MASORY_1981_DIVI_U_INIT 2048       /* 0.5 */
#define KOREN_MASORY_1981_DIVI_FR 6144           /* 1.5 kN */
#define KOREN_MASORY_1981_DIVI_K_LOOP 5120       /* 1.25 */
#define KOREN_MASORY_1981_DIVI_F_AIR 614         /* fc > 0.15 kN <=> raw > 614.4 <=> raw > 614 */

typedef struct koren_masory_1981_divi_inputs {
    int16_t fc; /* F_c, Q12 kN */
} koren_masory_1981_divi_inputs;

typedef struct koren_masory_1981_divi_outputs {
    int16_t feed; /* U, Q12 mm/s */
} koren_masory_1981_divi_outputs;

typedef struct koren_masory_1981_divi_state {
    int16_t kp; /* K_p, Q12 kN/(mm/s) */
    int16_t kc; /* K_c, Q12 (mm/s)/kN */
    int16_t u;  /* U, Q12 mm/s */
} koren_masory_1981_divi_state;

void koren_masory_1981_divi_init(koren_masory_1981_divi_state *self);
void koren_masory_1981_divi_step(koren_masory_1981_divi_state *self,
                                 const koren_masory_1981_divi_inputs *in,
                                 koren_masory_1981_divi_outputs *out);

#ifdef __cplusplus
}
#endif

#endif /* QLOOP_KOREN_MASORY_1981_DIV_H */
