//! RV32 under `qemu-system-riscv32 -M virt`: the firmware's `bench_io.h`, startup code and
//! linker script.

/// The head of `bench_io.h` on RV32 under QEMU `virt`: `minstret` brackets, text lines on the
/// UART (the rest is [`super::text_io`]).
pub(super) const IO_HEAD: &str = r#"/* bench_io.h -- qloop bench on RV32 under QEMU -M virt -icount: minstret brackets,
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

/* Every character goes out at once: nothing to flush. */
static inline void bench_flush(void) {}

static inline void bench_setup(void) {}

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
