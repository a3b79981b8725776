/* cycles.c -- exact AVR cycle counts per controller step, measured in simavr.
 *
 * Loads an AVR ELF into libsimavr (ATmega328P at 16 MHz by default), feeds ADC0 from a script
 * of millivolts (one value per conversion the firmware starts), and records the simulated
 * cycle counter avr->cycle whenever the firmware writes a marker to GPIOR0. It prints, on
 * stdout, machine-readable lines:
 *
 *   calib overhead <n>              cycles of an empty marker pair (subtracted from every step)
 *   step <i> cycles <n>             cycles of step i, overhead subtracted
 *   out <i> <v0> <v1> ...           raw values the firmware reported after step i
 *   end <reason> cycle <n>          why the run stopped, and the cycle counter then
 *   summary steps <N> min <A> max <B> mean <C>
 *
 * Everything libsimavr prints (it uses stdout) goes to stderr, so stdout carries only these.
 *
 * Firmware protocol (firmware/sim_protocol.h holds the other copy of these numbers):
 *   GPIOR0 (data address 0x3E) <- marker: 0x01 step begin, 0x02 step end, 0x03/0x04
 *          calibration begin/end (an empty pair), 0x05 end of the step's record, 0x0F done;
 *   GPIOR1 (0x4A) <- one byte of a value, least significant first;
 *   GPIOR2 (0x4B) <- commit the value: bit 7 = signed, bits 0..3 = number of bytes sent.
 * simavr calls an I/O write callback while it executes the OUT, before it adds that
 * instruction's cycles to avr->cycle, so each marker is timestamped at the start of its OUT.
 * The firmware writes each marker as `LDI r, m; OUT GPIOR0, r`, so the count between a begin
 * and an end marker is: the begin OUT (1) + everything between + the end LDI (1). The empty
 * calibration pair measures exactly those 2 cycles. For a step bracket
 *     MARK(begin); NAME_step(&s, &in, &out); MARK(end);
 * what remains after the subtraction is the argument set-up the compiler placed inside the
 * bracket (6 LDI for three constant addresses with avr-gcc -Os), the CALL (4 cycles on the
 * ATmega328P), the whole step body including its prologue/epilogue, and the RET (4).
 * The firmware runs the bracket with interrupts disabled, so no ISR is ever counted.
 *
 * Stops: done marker, or the firmware sleeping with interrupts off (simavr's graceful stop),
 * or the firmware starting an ADC conversion after the script is used up. Errors (exit 1,
 * message on stderr): unreadable or non-AVR ELF, cycle limit reached, simavr crash (PC past
 * the end of flash, access outside RAM, ...), errors logged by simavr, protocol violations.
 * (simavr 1.6 does not flag every invalid opcode: erased flash, 0xFFFF, executes silently, so
 * a jump into erased flash runs on to the end of flash, where simavr reports the crash, and a
 * run-away loop ends at the cycle limit.)
 * Usage errors exit 2.
 *
 * Build (one file; simavr headers live in include/simavr):
 *   cc -O2 -std=c99 -Wall -Wextra -I/usr/include/simavr cycles.c -o cycles -lsimavr -lelf
 * Debian ships only the static libsimavr.a plus the shared libsimavr.so.2; without libelf-dev
 * (no libelf.so link) link the shared one instead, which pulls libelf in itself:
 *   cc -O2 -std=c99 -Wall -Wextra -I/usr/include/simavr cycles.c -o cycles -l:libsimavr.so.2
 * (`pkg-config --cflags simavr` gives the -I.) Tested with simavr 1.6 (Debian 1.6+dfsg-3).
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "avr_adc.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_irq.h"

/* ATmega328P data-space addresses (I/O address + 0x20). */
#define ADDR_GPIOR0 0x3E
#define ADDR_GPIOR1 0x4A
#define ADDR_GPIOR2 0x4B

#define MARK_STEP_BEGIN 0x01
#define MARK_STEP_END 0x02
#define MARK_CAL_BEGIN 0x03
#define MARK_CAL_END 0x04
#define MARK_RECORD_END 0x05
#define MARK_DONE 0x0F

#define MAX_VALUES 1024

static FILE *out; /* the real stdout; fd 1 is pointed at stderr for libsimavr's chatter */
static const char *prog = "cycles";

typedef struct run_state {
    avr_t *avr;
    /* ADC script */
    uint32_t *mv;
    size_t n_mv, next_mv;
    avr_irq_t *adc_in; /* ADC_IRQ_ADC0 */
    /* markers */
    int cal_open, step_open;
    avr_cycle_count_t cal_t0, step_t0;
    int have_overhead;
    uint64_t overhead;
    uint64_t steps, min, max, sum;
    /* values */
    uint8_t bytes[8];
    unsigned n_bytes;
    int64_t values[MAX_VALUES];
    unsigned n_values;
    /* stop */
    int stop;
    const char *reason;
    int failed;
    char err[256];
    int sim_errors;
} run_state;

static run_state rs;

static void fail(const char *fmt, ...)
{
    if (rs.failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(rs.err, sizeof rs.err, fmt, ap);
    va_end(ap);
    rs.failed = 1;
    rs.stop = 1;
}

/* simavr log messages -> stderr; errors are counted and fail the run. */
static void logger(avr_t *avr, const int level, const char *fmt, va_list ap)
{
    (void)avr;
    if (level <= LOG_ERROR)
        rs.sim_errors++;
    if (level <= LOG_WARNING) {
        fputs("simavr: ", stderr);
        vfprintf(stderr, fmt, ap);
    }
}

/* Raw mode would usleep() through every SLEEP to keep real time; run as fast as possible. */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
    (void)avr;
    (void)how_long;
}

static void on_gpior0(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    avr->data[addr] = v;
    if (rs.stop)
        return;
    avr_cycle_count_t now = avr->cycle; /* start of the OUT that wrote v */
    switch (v) {
    case MARK_CAL_BEGIN:
        rs.cal_open = 1;
        rs.cal_t0 = now;
        break;
    case MARK_CAL_END: {
        if (!rs.cal_open) {
            fail("protocol: calibration end without begin at cycle %" PRIu64, (uint64_t)now);
            return;
        }
        rs.cal_open = 0;
        uint64_t c = (uint64_t)(now - rs.cal_t0);
        if (rs.have_overhead && c != rs.overhead) {
            fail("calibration pairs disagree: %" PRIu64 " vs %" PRIu64 " cycles", c, rs.overhead);
            return;
        }
        if (!rs.have_overhead)
            fprintf(out, "calib overhead %" PRIu64 "\n", c);
        rs.have_overhead = 1;
        rs.overhead = c;
        break;
    }
    case MARK_STEP_BEGIN:
        if (rs.step_open) {
            fail("protocol: step begin inside step %" PRIu64, rs.steps);
            return;
        }
        rs.step_open = 1;
        rs.step_t0 = now;
        rs.n_values = 0;
        rs.n_bytes = 0;
        break;
    case MARK_STEP_END: {
        if (!rs.step_open) {
            fail("protocol: step end without begin at cycle %" PRIu64, (uint64_t)now);
            return;
        }
        if (!rs.have_overhead) {
            fail("protocol: firmware ran a step before the calibration pair (0x03, 0x04)");
            return;
        }
        rs.step_open = 0;
        uint64_t raw = (uint64_t)(now - rs.step_t0);
        if (raw < rs.overhead) {
            fail("step %" PRIu64 " took %" PRIu64 " cycles, less than the marker overhead", rs.steps, raw);
            return;
        }
        uint64_t c = raw - rs.overhead;
        fprintf(out, "step %" PRIu64 " cycles %" PRIu64 "\n", rs.steps, c);
        if (rs.steps == 0 || c < rs.min)
            rs.min = c;
        if (rs.steps == 0 || c > rs.max)
            rs.max = c;
        rs.sum += c;
        rs.steps++;
        break;
    }
    case MARK_RECORD_END:
        if (rs.steps == 0 || rs.step_open) {
            fail("protocol: record end outside a completed step");
            return;
        }
        if (rs.n_bytes) {
            fail("protocol: %u uncommitted value bytes at record end", rs.n_bytes);
            return;
        }
        fprintf(out, "out %" PRIu64, rs.steps - 1);
        for (unsigned i = 0; i < rs.n_values; i++)
            fprintf(out, " %" PRId64, rs.values[i]);
        fputc('\n', out);
        rs.n_values = 0;
        break;
    case MARK_DONE:
        rs.stop = 1;
        rs.reason = "done-marker";
        break;
    default:
        fail("protocol: unknown marker 0x%02x at cycle %" PRIu64, v, (uint64_t)now);
    }
}

static void on_gpior1(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    avr->data[addr] = v;
    if (rs.stop)
        return;
    if (rs.n_bytes >= sizeof rs.bytes) {
        fail("protocol: more than %u bytes in one value", (unsigned)sizeof rs.bytes);
        return;
    }
    rs.bytes[rs.n_bytes++] = v;
}

static void on_gpior2(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    avr->data[addr] = v;
    if (rs.stop)
        return;
    unsigned n = v & 0x0F;
    int is_signed = (v & 0x80) != 0;
    if (n == 0 || n != rs.n_bytes) {
        fail("protocol: commit of %u bytes, %u sent", n, rs.n_bytes);
        return;
    }
    if (rs.n_values >= MAX_VALUES) {
        fail("protocol: more than %d values in one record", MAX_VALUES);
        return;
    }
    uint64_t u = 0;
    for (unsigned i = 0; i < n; i++)
        u |= (uint64_t)rs.bytes[i] << (8 * i);
    int64_t x;
    if (is_signed && n < 8 && (u >> (8 * n - 1)) & 1)
        x = (int64_t)(u | (~(uint64_t)0 << (8 * n)));
    else
        x = (int64_t)u;
    rs.values[rs.n_values++] = x;
    rs.n_bytes = 0;
}

/* A conversion is starting: put the next scripted voltage on its channel. simavr converts
 * when the firmware reads ADCL: code = min(1023, mV * 1023 / Vref). */
static void on_adc_trigger(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    if (rs.stop)
        return;
    union {
        avr_adc_mux_t mux;
        uint32_t v;
    } e = {.v = value};
    if (e.mux.kind != ADC_MUX_SINGLE || e.mux.src != 0) {
        fail("firmware converted mux kind %u source %u; the script drives ADC0 only", (unsigned)e.mux.kind,
             (unsigned)e.mux.src);
        return;
    }
    if (rs.next_mv >= rs.n_mv) {
        rs.stop = 1;
        rs.reason = "script-exhausted";
        return;
    }
    avr_raise_irq(rs.adc_in, rs.mv[rs.next_mv++]);
}

static int read_script(const char *path)
{
    FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
    if (!f) {
        fprintf(stderr, "%s: cannot open ADC script %s: %s\n", prog, path, strerror(errno));
        return -1;
    }
    size_t cap = 0;
    char line[256];
    unsigned lineno = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '#' || *p == '\n' || *p == '\0')
            continue;
        char *end;
        errno = 0;
        unsigned long v = strtoul(p, &end, 10);
        while (*end == ' ' || *end == '\t' || *end == '\r' || *end == '\n')
            end++;
        if (end == p || *end != '\0' || errno || v > 65535) {
            fprintf(stderr, "%s: %s:%u: expected millivolts 0..65535, got: %s", prog, path, lineno, line);
            if (f != stdin)
                fclose(f);
            return -1;
        }
        if (rs.n_mv == cap) {
            cap = cap ? 2 * cap : 256;
            rs.mv = realloc(rs.mv, cap * sizeof *rs.mv);
            if (!rs.mv) {
                fprintf(stderr, "%s: out of memory\n", prog);
                exit(1);
            }
        }
        rs.mv[rs.n_mv++] = (uint32_t)v;
    }
    if (f != stdin)
        fclose(f);
    return 0;
}

/* simavr 1.6 trusts the file: a host ELF makes elf_read_firmware() crash. Check the header
 * first: 32-bit little-endian ELF for machine EM_AVR (83). */
static int check_avr_elf(const char *path)
{
    unsigned char h[20];
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "%s: cannot read %s: %s\n", prog, path, strerror(errno));
        return -1;
    }
    size_t n = fread(h, 1, sizeof h, f);
    fclose(f);
    if (n < sizeof h || memcmp(h, "\177ELF", 4)) {
        fprintf(stderr, "%s: %s is not an ELF file\n", prog, path);
        return -1;
    }
    unsigned machine = (unsigned)h[18] | (unsigned)h[19] << 8;
    if (h[4] != 1 || h[5] != 1 || machine != 83) {
        fprintf(stderr, "%s: %s is an ELF file but not for the AVR (class %u, data %u, machine %u)\n", prog, path,
                h[4], h[5], machine);
        return -1;
    }
    return 0;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: %s [options] FIRMWARE.elf\n"
            "  --adc FILE      ADC0 input, millivolts, one per line per conversion ('#' comments; '-' = stdin)\n"
            "  --mcu NAME      simavr core (default atmega328p; the GPIOR addresses are the ATmega328P's)\n"
            "  --freq HZ       clock (default 16000000)\n"
            "  --vref MV       VCC = AVCC = AREF in millivolts (default 5000)\n"
            "  --limit CYCLES  fail if the run reaches this many cycles (default 2000000000)\n",
            prog);
}

int main(int argc, char **argv)
{
    const char *mcu = "atmega328p", *elf = NULL, *script = NULL;
    unsigned long freq = 16000000UL, vref = 5000;
    unsigned long long limit = 2000000000ULL;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int has_val = i + 1 < argc;
        if (!strcmp(a, "--adc") && has_val)
            script = argv[++i];
        else if (!strcmp(a, "--mcu") && has_val)
            mcu = argv[++i];
        else if (!strcmp(a, "--freq") && has_val)
            freq = strtoul(argv[++i], NULL, 0);
        else if (!strcmp(a, "--vref") && has_val)
            vref = strtoul(argv[++i], NULL, 0);
        else if (!strcmp(a, "--limit") && has_val)
            limit = strtoull(argv[++i], NULL, 0);
        else if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage();
            return 0;
        } else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "%s: unknown option or missing value: %s\n", prog, a);
            usage();
            return 2;
        } else if (!elf)
            elf = a;
        else {
            usage();
            return 2;
        }
    }
    if (!elf || !freq || !vref || !limit) {
        usage();
        return 2;
    }
    if (script && read_script(script))
        return 2;

    /* Keep the real stdout for our lines; send fd 1 (libsimavr's printf) to stderr. */
    fflush(stdout);
    int fd = dup(1);
    if (fd < 0 || !(out = fdopen(fd, "w")) || dup2(2, 1) < 0) {
        fprintf(stderr, "%s: cannot set up stdout: %s\n", prog, strerror(errno));
        return 1;
    }
    avr_global_logger_set(logger);

    if (check_avr_elf(elf))
        return 1;
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw) != 0 || fw.flashsize == 0) {
        fprintf(stderr, "%s: %s is not a loadable AVR ELF (no code found)\n", prog, elf);
        return 1;
    }
    if (fw.mmcu[0] && strcmp(fw.mmcu, mcu))
        fprintf(stderr, "%s: note: ELF .mmcu says %s, simulating %s\n", prog, fw.mmcu, mcu);
    avr_t *avr = avr_make_mcu_by_name(mcu);
    if (!avr) {
        fprintf(stderr, "%s: simavr does not know the MCU '%s'\n", prog, mcu);
        return 1;
    }
    rs.avr = avr;
    avr_init(avr);
    fw.frequency = (uint32_t)freq;
    fw.vcc = fw.avcc = fw.aref = (uint32_t)vref;
    avr_load_firmware(avr, &fw);
    avr->frequency = (uint32_t)freq;
    avr->vcc = avr->avcc = avr->aref = (uint32_t)vref;
    avr->sleep = no_sleep;
    avr->log = LOG_WARNING;

    avr_register_io_write(avr, ADDR_GPIOR0, on_gpior0, NULL);
    avr_register_io_write(avr, ADDR_GPIOR1, on_gpior1, NULL);
    avr_register_io_write(avr, ADDR_GPIOR2, on_gpior2, NULL);
    avr_irq_t *trig = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER);
    rs.adc_in = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0);
    if (!trig || !rs.adc_in) {
        fprintf(stderr, "%s: simavr's %s core has no ADC\n", prog, mcu);
        return 1;
    }
    avr_irq_register_notify(trig, on_adc_trigger, NULL);

    for (;;) {
        int state;
        state = avr_run(avr);
        if (rs.stop)
            break;
        if (state == cpu_Done) {
            rs.reason = "sleep-with-interrupts-off";
            break;
        }
        if (state == cpu_Crashed) {
            fail("simavr: firmware crashed at PC 0x%04x, cycle %" PRIu64, (unsigned)avr->pc, (uint64_t)avr->cycle);
            break;
        }
        if (rs.sim_errors) {
            fail("simavr reported an error (see above) at PC 0x%04x, cycle %" PRIu64, (unsigned)avr->pc,
                 (uint64_t)avr->cycle);
            break;
        }
        if (avr->cycle >= limit) {
            fail("cycle limit %llu reached (PC 0x%04x, %" PRIu64 " steps done); stuck firmware?", limit,
                 (unsigned)avr->pc, rs.steps);
            break;
        }
    }
    if (!rs.failed && rs.sim_errors)
        fail("simavr reported %d error(s) (see above)", rs.sim_errors);
    if (!rs.failed && rs.step_open)
        fail("run stopped inside step %" PRIu64, rs.steps);

    if (rs.failed) {
        fflush(out);
        fprintf(stderr, "%s: error: %s\n", prog, rs.err);
        return 1;
    }
    fprintf(out, "end %s cycle %" PRIu64 "\n", rs.reason, (uint64_t)avr->cycle);
    if (script && rs.next_mv < rs.n_mv)
        fprintf(stderr, "%s: note: %zu of %zu ADC samples used\n", prog, rs.next_mv, rs.n_mv);
    if (rs.steps == 0) {
        fprintf(stderr, "%s: error: no step markers seen\n", prog);
        return 1;
    }
    fprintf(out, "summary steps %" PRIu64 " min %" PRIu64 " max %" PRIu64 " mean %.2f\n", rs.steps, rs.min, rs.max,
            (double)rs.sum / (double)rs.steps);
    fclose(out);
    return 0;
}
