//! Cortex-M under `qemu-system-arm`: the firmware's `bench_io.h`, startup code and linker
//! script for the QEMU machine's memory map.

/// The head of `bench_io.h` on Cortex-M under QEMU: SysTick timing, semihosting text lines
/// (the rest is [`super::text_io`]).
pub(super) const IO_HEAD: &str = r#"/* bench_io.h -- qloop bench on Cortex-M under QEMU -icount: SysTick brackets, results as
 * text lines over semihosting ("qb calib ...", "qb step ...", "qb done"). */
#ifndef QLOOP_BENCH_IO_H
#define QLOOP_BENCH_IO_H
#include <stdint.h>

#define BENCH_ROM

#define BENCH_SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define BENCH_SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define BENCH_SYST_CVR (*(volatile uint32_t *)0xE000E018u)

void bench_write(const char *s); /* startup.c: semihosting SYS_WRITE0 */

static uint32_t bench_ticks;

/* SysTick counts down, 24 bits. Under -icount it advances the same per instruction. */
#define BENCH_TIMED(call)                                                                      \
    do {                                                                                       \
        uint32_t bench_t0_, bench_t1_;                                                         \
        __asm__ __volatile__("" ::: "memory");                                                 \
        bench_t0_ = BENCH_SYST_CVR;                                                            \
        call;                                                                                  \
        bench_t1_ = BENCH_SYST_CVR;                                                            \
        __asm__ __volatile__("" ::: "memory");                                                 \
        bench_ticks = (bench_t0_ - bench_t1_) & 0xFFFFFFu;                                     \
    } while (0)

static char bench_line[512];
static unsigned bench_len;

static inline void bench_flush(void)
{
    bench_line[bench_len] = 0;
    bench_write(bench_line);
    bench_len = 0;
}

static inline void bench_char(char c)
{
    if (bench_len + 2 > sizeof bench_line)
        bench_flush();
    bench_line[bench_len++] = c;
}

static inline void bench_setup(void)
{
    BENCH_SYST_RVR = 0xFFFFFFu;
    BENCH_SYST_CVR = 0;
    BENCH_SYST_CSR = 5u; /* enable, core clock, no interrupt */
    (void)BENCH_SYST_CVR;
}

"#;

/// Reset handler, vector table and semihosting for the QEMU machines.
pub(super) const STARTUP_C: &str = r#"/* startup.c -- qloop bench on Cortex-M under QEMU: vector table, reset (copy .data, zero
 * .bss, enable the FPU if the code uses it), semihosting write and exit. */
#include <stdint.h>

extern uint32_t _estack, _sidata, _sdata, _edata, _sbss, _ebss;
int main(void);
void bench_reset(void);
void bench_fault(void);
void bench_write(const char *s);

static void bench_semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ __volatile__("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
}

void bench_write(const char *s) { bench_semihost(0x04u, s); }

/* SYS_EXIT: ADP_Stopped_ApplicationExit (QEMU exits 0) or RunTimeErrorUnknown (exits 1). */
static void bench_exit(int ok)
{
    bench_semihost(0x18u, (const void *)(uintptr_t)(ok ? 0x20026u : 0x20023u));
    for (;;) {
    }
}

void bench_fault(void)
{
    bench_write("qb fault\n");
    bench_exit(0);
}

void bench_reset(void)
{
    uint32_t *s = &_sidata, *d = &_sdata;
    while (d < &_edata)
        *d++ = *s++;
    for (d = &_sbss; d < &_ebss;)
        *d++ = 0;
#if defined(__ARM_FP)
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* CPACR: CP10, CP11 full access */
    __asm__ __volatile__("dsb\n\tisb" ::: "memory");
#endif
    bench_exit(main() == 0);
}

__attribute__((section(".vectors"), used)) const uintptr_t bench_vectors[16] = {
    (uintptr_t)&_estack, (uintptr_t)bench_reset, (uintptr_t)bench_fault,
    (uintptr_t)bench_fault, (uintptr_t)bench_fault, (uintptr_t)bench_fault,
    (uintptr_t)bench_fault, 0, 0, 0, 0, (uintptr_t)bench_fault, (uintptr_t)bench_fault, 0,
    (uintptr_t)bench_fault, (uintptr_t)bench_fault,
};
"#;

/// The linker script for a QEMU machine with `flash` and `ram` (`256K`, `16K`).
pub(super) fn link_ld(flash: &str, ram: &str) -> String {
    format!(
        "/* qloop bench: QEMU machine memory map */\n\
         MEMORY\n{{\n  FLASH (rx) : ORIGIN = 0x00000000, LENGTH = {flash}\n  \
         RAM (rwx) : ORIGIN = 0x20000000, LENGTH = {ram}\n}}\n\
         ENTRY(bench_reset)\n\
         SECTIONS\n{{\n  \
         .text : {{ KEEP(*(.vectors)) *(.text*) *(.rodata*) . = ALIGN(4); }} > FLASH\n  \
         .ARM.exidx : {{ *(.ARM.exidx*) }} > FLASH\n  \
         .data : {{ _sdata = .; *(.data*) . = ALIGN(4); _edata = .; }} > RAM AT > FLASH\n  \
         _sidata = LOADADDR(.data);\n  \
         .bss (NOLOAD) : {{ _sbss = .; *(.bss*) *(COMMON) . = ALIGN(4); _ebss = .; }} > RAM\n  \
         _estack = ORIGIN(RAM) + LENGTH(RAM);\n}}\n"
    )
}
