/* Host reference for targets/linuxcnc/run.sh: the controller and glue of a qloop LinuxCNC
 * component (the lines from `qloop:controller:begin` to `qloop:glue:end` of the .comp,
 * extracted by run.sh into QLOOP_CONTROLLER_INC), compiled for the host and driven from stdin.
 *
 *   host_ref          one controller step per input line: QLOOP_N_IN raw integers in, one
 *                     line of QLOOP_N_OUT raw integers out (the REFERENCE_CMD protocol)
 *   host_ref --meta   the conversion constants the checker needs, one `key value...` per line
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include QLOOP_CONTROLLER_INC

int main(int argc, char **argv)
{
    qloop_state s;
    int32_t in_raw[QLOOP_N_IN], out_raw[QLOOP_N_OUT];
    int i;
    long line = 0;

    if (argc > 1 && strcmp(argv[1], "--meta") == 0) {
        printf("period_us %lu\n", (unsigned long)QLOOP_PERIOD_US);
        printf("n_in %d\nn_out %d\n", QLOOP_N_IN, QLOOP_N_OUT);
        printf("round_nearest %d\n", QLOOP_ROUND_NEAREST);
        for (i = 0; i < QLOOP_N_IN; i++)
            printf("in %d %a %ld %ld\n", i, qloop_in_scale[i], (long)qloop_in_min[i],
                   (long)qloop_in_max[i]);
        for (i = 0; i < QLOOP_N_OUT; i++)
            printf("out %d %a\n", i, qloop_out_scale[i]);
        printf("override %a\n", qloop_override_scale);
        return 0;
    }

    qloop_init(&s);
    for (;;) {
        for (i = 0; i < QLOOP_N_IN; i++) {
            long v;
            int r = scanf("%ld", &v);
            if (r == EOF && i == 0) return 0;
            if (r != 1) {
                fprintf(stderr, "host_ref: bad input at step %ld\n", line);
                return 2;
            }
            in_raw[i] = (int32_t)v;
        }
        qloop_step_raw(&s, in_raw, out_raw);
        for (i = 0; i < QLOOP_N_OUT; i++)
            printf(i ? " %ld" : "%ld", (long)out_raw[i]);
        putchar('\n');
        line++;
    }
}
