/* sim_protocol.h -- how firmware talks to the simavr runner ../cycles.c (which holds the
 * other copy of these numbers). Only plain I/O-register writes: on real hardware GPIOR0..2
 * are general-purpose registers and writing them has no other effect.
 *
 *   GPIOR0 <- marker byte (MARK_*);
 *   GPIOR1 <- one byte of a value, least significant first;
 *   GPIOR2 <- commit the value: 0x80 | byte count for signed values. emit() sends int32_t.
 */
#ifndef QLOOP_AVR_SIM_PROTOCOL_H
#define QLOOP_AVR_SIM_PROTOCOL_H

#include <avr/io.h>
#include <stdint.h>

#define MARK_STEP_BEGIN 0x01
#define MARK_STEP_END 0x02
#define MARK_CAL_BEGIN 0x03
#define MARK_CAL_END 0x04
#define MARK_RECORD_END 0x05
#define MARK_DONE 0x0F

/* A marker is exactly `LDI rX, m` + `OUT GPIOR0, rX` (1 + 1 cycles), whatever the optimiser
 * would otherwise do with the constant (hoist it into a register, share it between markers),
 * so every pair of markers costs the same and the empty calibration pair measures it: the
 * simulator records the cycle at the start of each OUT, so a pair's count is the OUT of the
 * first marker, everything in between, and the LDI of the second one (= 2 for an empty pair).
 * The "memory" clobber keeps loads and stores from moving across a marker. */
#define MARK(m)                                                                                \
    do {                                                                                       \
        uint8_t mark_tmp_;                                                                     \
        __asm__ __volatile__("ldi %0, %1\n\tout %2, %0"                                         \
                             : "=&d"(mark_tmp_)                                                \
                             : "M"(m), "I"(_SFR_IO_ADDR(GPIOR0))                               \
                             : "memory");                                                      \
    } while (0)

static inline void emit(int32_t v)
{
    uint32_t u = (uint32_t)v;
    GPIOR1 = (uint8_t)u;
    GPIOR1 = (uint8_t)(u >> 8);
    GPIOR1 = (uint8_t)(u >> 16);
    GPIOR1 = (uint8_t)(u >> 24);
    GPIOR2 = 0x84;
}

#endif
