/* koren_masory_1981.c -- HAND-WRITTEN STAND-IN for the qloop C emitter's output (see the
 * header). Integer-only C99: no division, no floats, no libc. Every product is formed in
 * int32_t explicitly, so the result is the same where `int` is 16 bits (AVR) and where it is
 * 32 bits (the host check). Right shifts of negative int32_t values are arithmetic (floor)
 * with avr-gcc and host gcc; the generated code is responsible for its own portability. */
#include "koren_masory_1981.h"

static int32_t clamp32(int32_t x, int32_t lo, int32_t hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

void koren_masory_1981_init(koren_masory_1981_state *s)
{
    s->km = 4096; /* 1.0  */
    s->kc = 5120; /* 1.25 */
    s->u = 2048;  /* 0.5  */
}

void koren_masory_1981_step(koren_masory_1981_state *s, const koren_masory_1981_inputs *in,
                            koren_masory_1981_outputs *out)
{
    int16_t km = s->km, kc = s->kc, u = s->u;
    /* input clamped to its declared range [0, 5] kN */
    int32_t fc = clamp32((int32_t)in->fc, 0, 20480);
    int32_t e = (int32_t)6144 - fc;                                   /* FR - fc, Q12  */
    int32_t em = (fc << 12) - (int32_t)u * (int32_t)km;               /* Q24 */
    int32_t ec = (int32_t)20971520 - (int32_t)kc * (int32_t)km;       /* K_LOOP - kc*km, Q24 */
    if (fc > 614) {                                                   /* fc > F_AIR */
        km = (int16_t)clamp32((int32_t)km + (em >> 14), 1024, 24576); /* km += em/4  */
        kc = (int16_t)clamp32((int32_t)kc + (ec >> 14), 854, 20480);  /* kc += ec/4  */
    }
    u = (int16_t)clamp32((int32_t)u + (((int32_t)kc * e) >> 12), 205, 20480); /* u += kc*e */
    s->km = km;
    s->kc = kc;
    s->u = u;
    out->feed = u;
}
