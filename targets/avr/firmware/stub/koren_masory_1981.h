/* koren_masory_1981.h -- HAND-WRITTEN STAND-IN for the header that
 * `qloop gen verified/specs/koren_masory_1981.qloop --lang c --target atmega328p --out DIR`
 * will write. It follows the C API contract of the qloop C emitter (names, macros, struct
 * layout, function signatures); the arithmetic in koren_masory_1981.c is a hand port of the
 * Rust that `qloop gen --lang rust` emits for the same spec (target generic32), so the raw
 * outputs should match the generated code bit for bit, but this file is NOT generated:
 * replace it by building with `make GEN=<dir of the generated files>`.
 *
 * Signals (all Q(i16, 12): raw = value * 2^12):
 *   fc   input  [0, 5] kN
 *   km   state  [0.25, 6] kN/(mm/s)   initial 1.0
 *   kc   state  [0.2083, 5] (mm/s)/kN initial 1.25
 *   u    state  [0.05, 5] mm/s        initial 0.5
 *   feed output (range inferred, no saturation of its own) mm/s
 */
#ifndef KOREN_MASORY_1981_H
#define KOREN_MASORY_1981_H

#include <stdint.h>

#define KOREN_MASORY_1981_PERIOD_US 100000UL

#define KOREN_MASORY_1981_FC_FRAC 12
#define KOREN_MASORY_1981_FC_MIN 0
#define KOREN_MASORY_1981_FC_MAX 20480
#define KOREN_MASORY_1981_KM_FRAC 12
#define KOREN_MASORY_1981_KM_MIN 1024
#define KOREN_MASORY_1981_KM_MAX 24576
#define KOREN_MASORY_1981_KC_FRAC 12
#define KOREN_MASORY_1981_KC_MIN 854
#define KOREN_MASORY_1981_KC_MAX 20480
#define KOREN_MASORY_1981_U_FRAC 12
#define KOREN_MASORY_1981_U_MIN 205
#define KOREN_MASORY_1981_U_MAX 20480
#define KOREN_MASORY_1981_FEED_FRAC 12

typedef struct koren_masory_1981_inputs { int16_t fc; } koren_masory_1981_inputs;
typedef struct koren_masory_1981_outputs { int16_t feed; } koren_masory_1981_outputs;
typedef struct koren_masory_1981_state { int16_t km; int16_t kc; int16_t u; } koren_masory_1981_state;

void koren_masory_1981_init(koren_masory_1981_state *s);
void koren_masory_1981_step(koren_masory_1981_state *s, const koren_masory_1981_inputs *in,
                            koren_masory_1981_outputs *out);

#endif
