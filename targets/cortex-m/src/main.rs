//! qloop's seed controllers on a Cortex-M, run in QEMU; the same program on the host is the
//! reference. Both print [`script::run`]: on `target_os = "none"` over semihosting, ending
//! with a semihosting exit (status 0, or 1 on error or panic); elsewhere on stdout.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

mod script;

#[cfg(not(target_os = "none"))]
fn main() {
    use std::io::Write as _;

    let mut s = String::new();
    script::run(&mut s, &mut ()).expect("formatting into a String");
    std::io::stdout().write_all(s.as_bytes()).expect("stdout");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::fmt::{self, Write};

    use cortex_m::peripheral::{syst::SystClkSource, SYST};
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::{
        debug::{self, EXIT_FAILURE, EXIT_SUCCESS},
        hio::{self, HostStream},
    };

    use super::script::{self, Meter};

    /// Semihosting stdout, one `SYS_WRITE` per line rather than per formatting fragment.
    struct Lines {
        out: HostStream,
        buf: [u8; 256],
        len: usize,
    }

    impl Lines {
        fn flush(&mut self) -> fmt::Result {
            let r = self.out.write_all(&self.buf[..self.len]);
            self.len = 0;
            r.map_err(|()| fmt::Error)
        }
    }

    impl Write for Lines {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            for &b in s.as_bytes() {
                if self.len == self.buf.len() {
                    self.flush()?;
                }
                self.buf[self.len] = b;
                self.len += 1;
                if b == b'\n' {
                    self.flush()?;
                }
            }
            Ok(())
        }
    }

    /// SysTick, free-running from the core clock, as a step meter. Under QEMU's `-icount` the
    /// virtual clock advances by a fixed time per instruction, so ticks are proportional to
    /// instructions; [`Ticks::calibrate`] measures the ratio on a function of 64 `nop`s and the
    /// meter's own overhead, and [`Meter::report`] prints instructions per `step_bits` call
    /// (call and argument copies included) on semihosting stderr. Without `-icount` the
    /// ticks follow the host's clock and nothing is reported.
    struct Ticks {
        t0: u32,
        /// Ticks of an empty `start`/`stop` pair.
        overhead: u32,
        /// Ticks of 64 instructions; 0 if uncalibrated.
        per_64: u32,
        n: u32,
        sum: u64,
        min: u32,
        max: u32,
    }

    impl Ticks {
        fn new(mut syst: SYST) -> Self {
            syst.set_clock_source(SystClkSource::Core);
            syst.set_reload(0x00ff_ffff);
            syst.clear_current();
            syst.enable_counter();
            let mut t = Ticks {
                t0: 0,
                overhead: 0,
                per_64: 0,
                n: 0,
                sum: 0,
                min: u32::MAX,
                max: 0,
            };
            t.calibrate();
            t
        }

        /// Ticks of `f()`, the least of 8 runs.
        fn time(&mut self, f: fn()) -> u32 {
            let mut least = u32::MAX;
            for _ in 0..8 {
                self.start();
                f();
                self.stop();
                least = least.min(self.max);
                self.max = 0;
            }
            least
        }

        fn calibrate(&mut self) {
            self.overhead = self.time(|| {});
            // Calls of the same shape, 64 instructions apart.
            let (call, nops) = (self.time(nops_0), self.time(nops_64));
            // At least one tick per instruction, or the numbers mean nothing.
            self.per_64 = if nops >= call + 64 { nops - call } else { 0 };
            self.reset();
        }

        fn reset(&mut self) {
            (self.n, self.sum, self.min, self.max) = (0, 0, u32::MAX, 0);
        }

        /// Instructions in `ticks` (rounded), the meter's overhead taken off.
        fn instructions(&self, ticks: u64, calls: u64) -> u64 {
            let net = ticks.saturating_sub(calls * u64::from(self.overhead));
            let per = calls * u64::from(self.per_64);
            (net * 64 + per / 2) / per
        }
    }

    #[inline(never)]
    fn nops_0() {
        // SAFETY: no instructions.
        unsafe { core::arch::asm!("", options(nomem, nostack)) };
    }

    #[inline(never)]
    fn nops_64() {
        // SAFETY: 64 `nop`s: no memory, stack or register effects.
        unsafe { core::arch::asm!(".rept 64", "nop", ".endr", options(nomem, nostack)) };
    }

    impl Meter for Ticks {
        #[inline(always)]
        fn start(&mut self) {
            self.t0 = SYST::get_current();
        }

        #[inline(always)]
        fn stop(&mut self) {
            // SysTick counts down, 24 bits.
            let dt = self.t0.wrapping_sub(SYST::get_current()) & 0x00ff_ffff;
            self.n += 1;
            self.sum += u64::from(dt);
            self.min = self.min.min(dt);
            self.max = self.max.max(dt);
        }

        fn report(&mut self, tag: &str) {
            if let (Ok(mut err), true) = (hio::hstderr(), self.per_64 > 0 && self.n > 0) {
                let _ = writeln!(
                    err,
                    "cost {tag}: step_bits min/mean/max = {}/{}/{} instructions over {} steps",
                    self.instructions(self.min.into(), 1),
                    self.instructions(self.sum, self.n.into()),
                    self.instructions(self.max.into(), 1),
                    self.n
                );
            }
            self.reset();
        }
    }

    #[entry]
    fn main() -> ! {
        let Some(p) = cortex_m::Peripherals::take() else {
            fail(format_args!("peripherals taken twice\n"))
        };
        let mut meter = Ticks::new(p.SYST);
        let ok = match hio::hstdout() {
            Ok(out) => {
                let mut w = Lines {
                    out,
                    buf: [0; 256],
                    len: 0,
                };
                script::run(&mut w, &mut meter)
                    .and_then(|()| w.flush())
                    .is_ok()
            }
            Err(()) => false,
        };
        debug::exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
        #[allow(clippy::empty_loop)]
        loop {}
    }

    /// Reports on the host's stderr and exits QEMU with status 1.
    fn fail(args: fmt::Arguments) -> ! {
        if let Ok(mut err) = hio::hstderr() {
            let _ = err.write_fmt(args);
        }
        debug::exit(EXIT_FAILURE);
        #[allow(clippy::empty_loop)]
        loop {}
    }

    #[panic_handler]
    fn panic(info: &core::panic::PanicInfo) -> ! {
        fail(format_args!("firmware panic: {info}\n"))
    }

    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        fail(format_args!("firmware hard fault: {frame:?}\n"))
    }
}
