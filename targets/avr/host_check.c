/* host_check.c -- the host-side reference for run.sh: the same controller C file and the same
 * I/O scaling (firmware/io_scale.h), compiled with the host cc (32-bit int, UBSan in the
 * Makefile), run over the same ADC script. Prints the `out` lines the firmware should report
 * through cycles.c, so `diff` of the two must be empty:
 *
 *   out <i> <adc> <fc> <feed> <ocr1a> <km> <kc> <u>
 *
 * The ADC model is simavr's (1.6): code = min(1023, mV * 1023 / Vref), truncated. (A real
 * ATmega328P gives floor(mV * 1024 / Vref) up to 1023; the firmware reports the code it read,
 * so a different simulator model shows up in the diff's first column.)
 *
 * usage: host_check [--vref MV] SCRIPT    (millivolts per line, '#' comments, '-' = stdin)
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io_scale.h"
#include "koren_masory_1981.h"

int main(int argc, char **argv)
{
    unsigned long vref = 5000;
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--vref") && i + 1 < argc)
            vref = strtoul(argv[++i], NULL, 0);
        else if (!path)
            path = argv[i];
        else
            path = NULL, i = argc;
    }
    if (!path || !vref) {
        fprintf(stderr, "usage: host_check [--vref MV] SCRIPT\n");
        return 2;
    }
    FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
    if (!f) {
        fprintf(stderr, "host_check: cannot open %s: %s\n", path, strerror(errno));
        return 2;
    }

    koren_masory_1981_state st;
    koren_masory_1981_inputs in;
    koren_masory_1981_outputs out;
    koren_masory_1981_init(&st);

    char line[256];
    unsigned long i = 0, lineno = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '#' || *p == '\n' || *p == '\0')
            continue;
        char *end;
        errno = 0;
        unsigned long mv = strtoul(p, &end, 10);
        while (*end == ' ' || *end == '\t' || *end == '\r' || *end == '\n')
            end++;
        if (end == p || *end != '\0' || errno || mv > 65535) {
            fprintf(stderr, "host_check: %s:%lu: expected millivolts 0..65535\n", path, lineno);
            return 2;
        }
        unsigned long code = mv * 1023UL / vref;
        if (code > 1023)
            code = 1023;
        uint16_t adc = (uint16_t)code;
        in.fc = ql_adc_to_fc(adc);
        koren_masory_1981_step(&st, &in, &out);
        uint16_t duty = ql_feed_to_duty(out.feed);
        printf("out %lu %ld %ld %ld %ld %ld %ld %ld\n", i, (long)adc, (long)in.fc, (long)out.feed, (long)duty,
               (long)st.km, (long)st.kc, (long)st.u);
        i++;
    }
    if (f != stdin)
        fclose(f);
    return 0;
}
