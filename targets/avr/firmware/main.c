/* main.c -- minimal grbl-style ACC firmware for the ATmega328P at 16 MHz, running the qloop
 * controller koren_masory_1981 (generated C, or the hand-written stand-in in stub/).
 *
 * Loop, once per control period (KOREN_MASORY_1981_PERIOD_US, paced by a 1 kHz Timer0 tick):
 *   1. sample ADC0 (force sensor, AVCC reference), scale the 10-bit code to raw fc (io_scale.h);
 *   2. run koren_masory_1981_step() between two markers, interrupts off;
 *   3. feed -> Timer1 fast-PWM duty on OC1A/PB1 (OCR1A, TOP = ICR1, io_scale.h);
 *   4. report the step's raw values to the simulator.
 *
 * The simulator protocol (markers around the step, values reported after it) is in
 * sim_protocol.h: plain writes to the general-purpose registers GPIOR0..2, harmless on real
 * hardware. The empty marker pair at start-up gives cycles.c the marker overhead.
 *
 * Build options (-D, see ../Makefile): PACED=1 (default) waits for the timer tick between
 * steps, sleeping in idle mode; PACED=0 runs the steps back to back. STEPS=n > 0 stops after
 * n steps (done marker, then cli + sleep, which simavr reports as a graceful stop); STEPS=0
 * (default) loops for ever and the simulator stops when its ADC script runs out.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "io_scale.h"
#include "koren_masory_1981.h"
#include "sim_protocol.h"

#ifndef PACED
#define PACED 1
#endif
#ifndef STEPS
#define STEPS 0
#endif

/* Control period in 1 ms Timer0 ticks (rounded; compile-time constant). */
#define TICKS_PER_PERIOD ((KOREN_MASORY_1981_PERIOD_US + 500UL) / 1000UL)
#if TICKS_PER_PERIOD < 1 || TICKS_PER_PERIOD > 65535
#error "control period must be 1 ms .. 65.535 s"
#endif

/* Controller data are statics, so the step's arguments are constant addresses. */
static koren_masory_1981_state st;
static koren_masory_1981_inputs in;
static koren_masory_1981_outputs out;

static volatile uint8_t period_due;

ISR(TIMER0_COMPA_vect)
{
    static uint16_t ticks;
    if (++ticks >= TICKS_PER_PERIOD) {
        ticks = 0;
        period_due = 1;
    }
}

static void adc_init(void)
{
    ADMUX = (1 << REFS0);                                              /* AVCC reference, ADC0, right-adjusted */
    DIDR0 = (1 << ADC0D);                                              /* no digital input buffer on ADC0 */
    ADCSRA = (1 << ADEN) | (1 << ADPS2) | (1 << ADPS1) | (1 << ADPS0); /* 16 MHz / 128 = 125 kHz */
}

static uint16_t adc_read(void)
{
    ADCSRA |= (1 << ADSC);
    while (ADCSRA & (1 << ADSC))
        ;
    return ADC; /* ADCL, then ADCH */
}

static void pwm_init(void)
{
    DDRB |= (1 << PB1); /* OC1A */
    /* mode first: simavr warns about TOP/compare writes while the timer has no mode */
    TCCR1A = (1 << COM1A1) | (1 << WGM11);             /* non-inverting; mode 14 = fast PWM, TOP = ICR1 */
    TCCR1B = (1 << WGM13) | (1 << WGM12) | (1 << CS10); /* prescaler 1 */
    ICR1 = QL_PWM_TOP;
    OCR1A = 0;
}

static void tick_init(void)
{
    TCCR0A = (1 << WGM01);              /* CTC */
    TCCR0B = (1 << CS01) | (1 << CS00); /* prescaler 64 */
    OCR0A = 249;                        /* 16 MHz / 64 / 250 = 1 kHz */
    TIMSK0 = (1 << OCIE0A);
}

static void wait_period(void)
{
#if PACED
    for (;;) {
        cli();
        if (period_due) {
            period_due = 0;
            sei();
            return;
        }
        sleep_enable();
        sei();
        sleep_cpu(); /* SEI's one-instruction delay: no tick can slip in before the SLEEP */
        sleep_disable();
    }
#endif
}

int main(void)
{
    adc_init();
    pwm_init();
    koren_masory_1981_init(&st);

    /* Marker overhead: an empty pair, written exactly like the pair around the step. */
    MARK(MARK_CAL_BEGIN);
    MARK(MARK_CAL_END);

    set_sleep_mode(SLEEP_MODE_IDLE);
    tick_init();
    sei();

#if STEPS > 0
    for (uint16_t n = 0; n < (uint16_t)STEPS; n++) {
#else
    for (;;) {
#endif
        wait_period();
        uint16_t adc = adc_read();
        in.fc = ql_adc_to_fc(adc);

        uint8_t sreg = SREG;
        cli();
        MARK(MARK_STEP_BEGIN);
        koren_masory_1981_step(&st, &in, &out);
        MARK(MARK_STEP_END);
        SREG = sreg;

        OCR1A = ql_feed_to_duty(out.feed);

        emit(adc);
        emit(in.fc);
        emit(out.feed);
        emit(OCR1A);
        emit(st.km);
        emit(st.kc);
        emit(st.u);
        MARK(MARK_RECORD_END);
    }

    MARK(MARK_DONE);
    cli();
    sleep_enable();
    for (;;)
        sleep_cpu();
}
