/* io_scale.h -- the I/O scaling between the ATmega328P's peripherals and the raw fixed-point
 * signals of the koren_masory_1981 controller. Shared, unchanged, by the firmware (avr-gcc,
 * 16-bit int) and by the host check (host cc, 32-bit int), so both apply the same integer
 * arithmetic. C99, <stdint.h> only, no division.
 *
 * Input (force sensor -> ADC0 -> fc):
 *   the force amplifier delivers 1 V per kN; the ADC uses AVCC = 5 V as reference, so the
 *   10-bit code covers 0..5 kN (code 1024 would be 5 kN, per the datasheet's
 *   ADC = Vin * 1024 / Vref). fc is Q(FC_FRAC): raw = adc * 5 * 2^FC_FRAC / 1024, done as a
 *   multiply and a shift, then clamped to the controller's declared fc range.
 *   With FC_FRAC = 12: raw = adc * 20, so code 1023 gives 20460 raw = 4.9951 kN.
 *
 * Output (feed -> Timer1 PWM on OC1A/PB1):
 *   fast PWM, mode 14, TOP = ICR1 = QL_PWM_TOP = 5 mm/s in units of 1/256 mm/s = 1280
 *   (16 MHz / 1281 = 12.49 kHz, prescaler 1). duty = feed raw >> (FEED_FRAC - 8), clamped
 *   to [0, QL_PWM_TOP]: 0 % at 0 mm/s, 100 % at 5 mm/s.
 */
#ifndef QLOOP_AVR_IO_SCALE_H
#define QLOOP_AVR_IO_SCALE_H

#include <stdint.h>
#include "koren_masory_1981.h"

/* Full-scale force at the ADC reference, kN (1 V/kN sensor, 5 V reference). */
#define QL_FC_FULL_SCALE_KN 5UL
/* Full-scale feed at 100 % PWM duty, mm/s (the controller's u ceiling). */
#define QL_FEED_FULL_SCALE_MM_S 5U
/* Timer1 TOP (ICR1): full-scale feed in 1/256 mm/s. */
#define QL_PWM_TOP ((uint16_t)(QL_FEED_FULL_SCALE_MM_S << 8))

#if KOREN_MASORY_1981_FEED_FRAC < 8
#error "io_scale.h assumes feed has at least 8 fractional bits"
#endif

/* 10-bit ADC code (0..1023) -> raw fc. */
static inline int16_t ql_adc_to_fc(uint16_t adc)
{
    uint32_t raw = ((uint32_t)(adc & 0x3FFu) * (QL_FC_FULL_SCALE_KN << KOREN_MASORY_1981_FC_FRAC)) >> 10;
#ifdef KOREN_MASORY_1981_FC_MAX
    if (raw > (uint32_t)KOREN_MASORY_1981_FC_MAX)
        raw = (uint32_t)KOREN_MASORY_1981_FC_MAX;
#endif
    return (int16_t)raw;
}

/* raw feed -> Timer1 compare value OCR1A in [0, QL_PWM_TOP]. */
static inline uint16_t ql_feed_to_duty(int32_t feed)
{
    int32_t d = feed >> (KOREN_MASORY_1981_FEED_FRAC - 8);
    if (d < 0)
        d = 0;
    if (d > (int32_t)QL_PWM_TOP)
        d = QL_PWM_TOP;
    return (uint16_t)d;
}

#endif
