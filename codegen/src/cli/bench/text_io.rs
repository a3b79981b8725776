//! The text protocol of the QEMU platforms' `bench_io.h`, shared by Cortex-M and RV32: hex
//! values on `qb calib`, `qb step` and `qb done` lines, the calibration brackets and the
//! table loader. Each platform's head defines `BENCH_TIMED`, `bench_ticks`, `bench_char`,
//! `bench_flush` and `bench_setup` before it.

/// `bench_io.h`: the platform's `head` (which opens the include guard), then the shared text.
pub(super) fn io_h(head: &str) -> String {
    format!("{head}{TEXT}#endif\n")
}

/// The shared part, in C.
const TEXT: &str = r#"static inline void bench_str(const char *s)
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
    bench_flush();
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

static inline void bench_record_end(void)
{
    bench_char('\n');
    bench_flush();
}

static inline void bench_done(void)
{
    bench_str("qb done\n");
    bench_flush();
}
"#;
