/* selftest.c -- checks the cycle-measurement method itself. Each "step" is a short assembly
 * sequence with a known cost from the ATmega328P datasheet's instruction set summary,
 * bracketed by the same markers as the controller step; the firmware reports the expected
 * count after each step (out <i> <expected>), and run.sh requires `step <i> cycles <n>` to
 * equal it. Ends with the done marker, then cli + sleep. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "sim_protocol.h"

__asm__(".text\n"
        "selftest_ret:\n\t"
        "ret\n");

static const uint8_t table[2] = {1, 2};
static volatile uint8_t cell;

#define CASE(expected, ...)                                                                    \
    do {                                                                                       \
        MARK(MARK_STEP_BEGIN);                                                                 \
        __asm__ __volatile__(__VA_ARGS__);                                                     \
        MARK(MARK_STEP_END);                                                                   \
        emit(expected);                                                                        \
        MARK(MARK_RECORD_END);                                                                 \
    } while (0)

int main(void)
{
    cli();
    MARK(MARK_CAL_BEGIN);
    MARK(MARK_CAL_END);

    CASE(0, "" ::: "memory");
    CASE(10, "nop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop\n\tnop" ::: "memory");
    CASE(7, "rcall selftest_ret" ::: "memory");                                 /* RCALL 3 + RET 4 */
    CASE(8, "call selftest_ret" ::: "memory");                                  /* CALL 4 + RET 4 */
    CASE(7, "mul r18, r19\n\tmuls r18, r19\n\tfmul r18, r19\n\tclr r1"          /* 3 x 2, CLR 1 */
            "" ::: "r0", "r1", "r18", "r19", "memory");
    CASE(11, "push r0\n\tpop r0\n\tlds r24, %0\n\tsts %0, r24\n\tadiw r24, 1"   /* 2+2+2+2+2, +1: */
             "\n\tnop" ::"m"(cell) : "r24", "r25", "memory");
    CASE(15, "ldi r24, 5\n1:\n\tdec r24\n\tbrne 1b" ::: "r24", "memory");       /* 1 + 5 + 4*2 + 1 */
    CASE(5, "ldi r30, lo8(%0)\n\tldi r31, hi8(%0)\n\tlpm r0, Z" ::"i"(table) : "r0", "r30", "r31", "memory");
    CASE(3, "ldi r24, 1\n\tsbrs r24, 0\n\tnop" ::: "r24", "memory");            /* 1 + skip 2 */
    CASE(4, "ldi r26, lo8(%0)\n\tldi r27, hi8(%0)\n\tld r0, X" ::"i"(&cell) : "r0", "r26", "r27", "memory");
    CASE(2, "rjmp .+0" ::: "memory");

    MARK(MARK_DONE);
    sleep_enable();
    for (;;)
        sleep_cpu();
}
