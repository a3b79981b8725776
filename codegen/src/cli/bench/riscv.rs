//! RV32 under `qemu-system-riscv32 -M virt`: the firmware's `bench_io.h`, startup code and
//! linker script.

/// `bench_io.h` on RV32 under QEMU `virt`: `minstret` brackets, text lines on the UART.
pub(super) const IO_H: &str = r#"/* bench_io.h -- qloop bench on RV32 under QEMU -M virt -icount: minstret brackets,
 * results as text lines on the 16550 UART ("qb calib ...", "qb step ...", "qb done"). */
#ifndef QLOOP_BENCH_IO_H
#define QLOOP_BENCH_IO_H
#include <stdint.h>

#define BENCH_ROM

void bench_putc(char c); /* startup.c: UART */

/* csrr %0, minstret (CSR 0xB02), encoded with .insn: assemblers that want the Zicsr
 * extension named in -march accept it too. Under -icount it counts instructions exactly. */
#define BENCH_INSTRET(v) __asm__ __volatile__(".insn i 0x73, 2, %0, x0, -1278" : "=r"(v) : : "memory")

static uint32_t bench_ticks;

#define BENCH_TIMED(call)                                                                      \
    do {                                                                                       \
        uint32_t bench_t0_, bench_t1_;                                                         \
        BENCH_INSTRET(bench_t0_);                                                              \
        call;                                                                                  \
        BENCH_INSTRET(bench_t1_);                                                              \
        bench_ticks = bench_t1_ - bench_t0_;                                                   \
    } while (0)

static inline void bench_char(char c) { bench_putc(c); }

static inline void bench_str(const char *s)
{
    while (*s)
        bench_char(*s++);
}

static inline void bench_hex32(uint32_t v)
{
    int k;
    for (k = 28; k >= 0; k -= 4)
        bench_char("0123456789abcdef"[(v >> k) & 15u]);
}

/* " " and 16 hex digits. */
static inline void bench_value(int64_t v)
{
    uint64_t u = (uint64_t)v;
    bench_char(' ');
    bench_hex32((uint32_t)(u >> 32));
    bench_hex32((uint32_t)u);
}

static inline void bench_value_f(float f)
{
    union {
        float f;
        uint32_t u;
    } c;
    c.f = f;
    bench_value((int64_t)c.u);
}

static inline void bench_setup(void) {}

__attribute__((noinline)) static void bench_nop0(void) { __asm__ __volatile__(""); }
__attribute__((noinline)) static void bench_nop64(void)
{
    __asm__ __volatile__(".rept 64\n\tnop\n\t.endr");
}

/* Least counts of 8 runs each: the empty bracket, a call of an empty function and of one
 * with 64 nops (their difference is 64 instructions). */
static inline void bench_calibrate(void)
{
    uint32_t e = 0xFFFFFFFFu, a = 0xFFFFFFFFu, b = 0xFFFFFFFFu;
    int k;
    for (k = 0; k < 8; k++) {
        BENCH_TIMED((void)0);
        if (bench_ticks < e)
            e = bench_ticks;
        BENCH_TIMED(bench_nop0());
        if (bench_ticks < a)
            a = bench_ticks;
        BENCH_TIMED(bench_nop64());
        if (bench_ticks < b)
            b = bench_ticks;
    }
    bench_str("qb calib");
    bench_value((int64_t)e);
    bench_value((int64_t)a);
    bench_value((int64_t)b);
    bench_char('\n');
}

static inline void bench_load(void *dst, const void *src, uint32_t n)
{
    /* volatile: keeps GCC from turning the loop into a memcpy call. */
    unsigned char *d = (unsigned char *)dst;
    const volatile unsigned char *s = (const volatile unsigned char *)src;
    while (n--)
        *d++ = *s++;
}

static inline void bench_record_begin(uint32_t i)
{
    bench_str("qb step");
    bench_value((int64_t)i);
    bench_value((int64_t)bench_ticks);
}

static inline void bench_record_end(void) { bench_char('\n'); }

static inline void bench_done(void) { bench_str("qb done\n"); }
#endif
"#;

/// Entry, trap handler, UART, exit and the `mem*` routines GCC may call, for QEMU `virt`.
pub(super) const STARTUP_C: &str = r#"/* startup.c -- qloop bench on RV32 under QEMU -M virt -bios none: entry at the start of
 * RAM (gp, sp, mtvec), .bss zeroed, UART output, exit through the SiFive test device. */
#include <stddef.h>
#include <stdint.h>

extern uint32_t _sbss, _ebss;
int main(void);
void bench_reset(void);
void bench_fault(void);
void bench_putc(char c);

/* csrw mtvec, t0 (CSR 0x305) as .insn, see bench_io.h. */
__asm__(".section .text.start,\"ax\",@progbits\n"
        ".globl _start\n"
        "_start:\n"
        ".option push\n"
        ".option norelax\n"
        "\tla gp, __global_pointer$\n"
        ".option pop\n"
        "\tla sp, _estack\n"
        "\tla t0, bench_trap\n"
        "\t.insn i 0x73, 1, x0, t0, 0x305\n"
        "\tcall bench_reset\n"
        "1:\tj 1b\n"
        ".text\n"
        ".balign 4\n"
        "bench_trap:\n"
        "\tla sp, _estack\n"
        "\tj bench_fault\n");

#define BENCH_UART ((volatile uint8_t *)0x10000000u)
#define BENCH_TEST (*(volatile uint32_t *)0x00100000u)

void bench_putc(char c)
{
    while (!(BENCH_UART[5] & 0x20u)) /* LSR: transmitter holding register empty */
        ;
    BENCH_UART[0] = (uint8_t)c;
}

/* FINISHER_PASS (QEMU exits 0) or FINISHER_FAIL with code 1. */
static void bench_exit(int ok)
{
    BENCH_TEST = ok ? 0x5555u : 0x13333u;
    for (;;) {
    }
}

void bench_fault(void)
{
    const char *s = "\nqb fault\n";
    while (*s)
        bench_putc(*s++);
    bench_exit(0);
}

void bench_reset(void)
{
    uint32_t *d;
    for (d = &_sbss; d < &_ebss;)
        *d++ = 0;
    bench_exit(main() == 0);
}

/* GCC may call these for struct copies even when freestanding; volatile keeps it from
 * turning the loops back into calls. */
void *memcpy(void *dst, const void *src, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    const unsigned char *s = (const unsigned char *)src;
    while (n--)
        *d++ = *s++;
    return dst;
}

void *memmove(void *dst, const void *src, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    const unsigned char *s = (const unsigned char *)src;
    if (d < s) {
        while (n--)
            *d++ = *s++;
    } else {
        while (n--)
            d[n] = s[n];
    }
    return dst;
}

void *memset(void *dst, int c, size_t n)
{
    volatile unsigned char *d = (volatile unsigned char *)dst;
    while (n--)
        *d++ = (unsigned char)c;
    return dst;
}
"#;

/// Everything in the RAM of QEMU `virt` (from 0x80000000, where `-bios none` jumps); QEMU
/// loads the ELF, so `.data` needs no copy.
pub(super) const LINK_LD: &str = "/* qloop bench: QEMU virt, everything in RAM */\n\
MEMORY\n{\n  RAM (rwx) : ORIGIN = 0x80000000, LENGTH = 64M\n}\n\
ENTRY(_start)\n\
SECTIONS\n{\n  \
.text : { KEEP(*(.text.start)) *(.text*) } > RAM\n  \
.rodata : { *(.rodata*) *(.srodata*) . = ALIGN(4); } > RAM\n  \
.data : { __global_pointer$ = . + 0x800; *(.data*) *(.sdata*) . = ALIGN(4); } > RAM\n  \
.bss (NOLOAD) : { _sbss = .; *(.sbss*) *(.bss*) *(COMMON) . = ALIGN(4); _ebss = .; } > RAM\n  \
_estack = ORIGIN(RAM) + LENGTH(RAM);\n}\n";
