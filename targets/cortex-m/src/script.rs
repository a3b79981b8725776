//! The scripted stimulus, shared by the firmware and the host reference run.
//!
//! Each seed controller of `qloop-verified` is driven from its initial state through
//! [`STEPS`] steps of raw inputs (`step_bits`): an air cut, a closed loop on a tiny integer
//! plant whose gain steps (depth-of-cut steps as force levels), a ramp past the input range,
//! boundary and out-of-range raw values, and xorshift64 noise from a fixed seed. Every step
//! prints one line with its raw inputs, outputs and states; each controller ends with an
//! FNV-1a 64 checksum over all of them, and the run with one over all controllers.
//!
//! Integers only, so the lines are the same on every target: any difference between the
//! firmware and the host is a miscompilation or an emulation bug, not rounding.

use core::fmt::{self, Write};

use qloop_verified::{
    acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
    milling_acc,
};

/// Steps per controller.
pub const STEPS: usize = 360;
/// Seed of the xorshift64 generator (reset for every controller).
pub const SEED: u64 = 0x2545_f491_4f6c_dd1d;

/// Marsaglia's xorshift64.
struct XorShift64(u64);

impl XorShift64 {
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }

    /// Uniform in `0..n` (multiply-shift: no division on the M0).
    fn below(&mut self, n: u32) -> i64 {
        (((self.next() >> 32) * u64::from(n)) >> 32) as i64
    }

    /// Uniform in `-a..a`.
    fn noise(&mut self, a: u32) -> i64 {
        self.below(2 * a) - i64::from(a)
    }
}

/// FNV-1a, 64 bits, over the little-endian bytes of `i64` words.
#[derive(Clone, Copy)]
struct Fnv(u64);

impl Fnv {
    const fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn words(&mut self, ws: &[i64]) {
        for w in ws {
            for b in w.to_le_bytes() {
                self.0 ^= u64::from(b);
                self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
    }
}

/// Phases of the script, as step ranges.
const AIR_END: usize = 16; // air cut
const LOOP_END: usize = 136; // closed loop, three plant gains of 40 steps each
const RAMP_END: usize = 200; // ramp to 110 % of the input range
const EDGE_END: usize = 232; // boundary values, each held two steps
const SEGMENT: usize = (LOOP_END - AIR_END) / 3;

/// Force input of the ACC controllers (`fc`, Q(i16, 12), range [0, 5] kN = 0..=20480 raw).
fn force(k: usize, rng: &mut XorShift64, gains: &[i64; 3], out: i64, out_frac: u32) -> i64 {
    /// Boundary and out-of-range raw values; 614 is F_AIR = 0.15 kN, 6144 is F_R = 1.5 kN.
    const EDGES: [i64; 16] = [
        0,
        -1,
        1,
        613,
        614,
        615,
        6144,
        20479,
        20480,
        20481,
        i16::MAX as i64,
        i16::MIN as i64,
        32768,
        -32769,
        i64::MAX,
        i64::MIN,
    ];
    match k {
        // Tool in the air: sensor noise below F_AIR.
        _ if k < AIR_END => rng.below(410),
        // Cutting: F_c = gain · feed + noise, the gain stepping as the depth of cut does.
        _ if k < LOOP_END => {
            let g = gains[(k - AIR_END) / SEGMENT];
            ((g * out) >> out_frac) + rng.noise(40)
        }
        // Ramp 0 → 5.5 kN.
        _ if k < RAMP_END => (k - LOOP_END) as i64 * 22528 / 64,
        _ if k < EDGE_END => EDGES[(k - RAMP_END) / 2],
        // Noise: mostly in range, some any i16, some any i64.
        _ => match rng.below(8) {
            0 => rng.next() as i16 as i64,
            1 => rng.next() as i64,
            _ => rng.below(20481),
        },
    }
}

/// Inputs of the grinding controllers (`f`, `fr`: Q(i32, 16) newtons; f in [0, 100] N,
/// fr in [0, 50] N); `xd` (Q(i32, `xd_frac`) mm, `grinding_pi` 27) is their last output.
fn grinding(k: usize, rng: &mut XorShift64, xd: i64, xd_frac: i32) -> [i64; 2] {
    const N: i64 = 1 << 16;
    const EDGES: [[i64; 2]; 16] = [
        [0, 0],
        [-1, 0],
        [0, -1],
        [100 * N, 50 * N],
        [100 * N + 1, 50 * N + 1],
        [50 * N, 50 * N],
        [50 * N + 1, 50 * N],
        [50 * N - 1, 50 * N],
        [i32::MAX as i64, 0],
        [0, i32::MAX as i64],
        [i32::MIN as i64, i32::MAX as i64],
        [i32::MAX as i64 + 1, i32::MIN as i64 - 1],
        [i64::MAX, i64::MIN],
        [i64::MIN, i64::MAX],
        [0, 50 * N],
        [100 * N, 0],
    ];
    match k {
        // Wheel not in contact: force noise only.
        _ if k < AIR_END => [rng.below(N as u32 / 2), 20 * N],
        // Contact stiffness 100 N/mm beyond 0.5 mm; the reference steps 10 → 30 → 20 N.
        _ if k < LOOP_END => {
            let fr = [10 * N, 30 * N, 20 * N][(k - AIR_END) / SEGMENT];
            let contact = 1 << (xd_frac - 1); // 0.5 mm
            let f = (100 * (xd - contact)).max(0) >> (xd_frac - 16); // mm · N/mm → Q16 N
            [f + rng.noise(N as u32 / 4), fr]
        }
        _ if k < RAMP_END => [(k - LOOP_END) as i64 * 110 * N / 64, 25 * N],
        _ if k < EDGE_END => EDGES[(k - RAMP_END) / 2],
        _ => match rng.below(8) {
            0 => [rng.next() as i32 as i64, rng.next() as i32 as i64],
            1 => [rng.next() as i64, rng.next() as i64],
            _ => [rng.below(100 << 16), rng.below(50 << 16)],
        },
    }
}

/// Measures each `step_bits` call. The firmware counts SysTick ticks (instructions under QEMU's
/// `-icount`) and reports on semihosting stderr, outside the compared output; the host uses `()`.
pub trait Meter {
    /// Right before `step_bits`.
    fn start(&mut self) {}
    /// Right after `step_bits`.
    fn stop(&mut self) {}
    /// After a controller's last step.
    fn report(&mut self, _tag: &str) {}
}

impl Meter for () {}

/// The state of a run: where lines go, the meter, and the checksum over all controllers.
struct Run<'a, W, M> {
    w: &'a mut W,
    meter: &'a mut M,
    total: Fnv,
}

/// Runs one controller through the script: `$stimulus(k, rng, last_outputs)` gives the
/// raw inputs of step `k`.
macro_rules! drive {
    ($run:ident, $tag:literal, $module:ident, $stimulus:expr) => {{
        let mut c = $module::Controller::new();
        let mut rng = XorShift64(SEED);
        let mut fnv = Fnv::new();
        let mut out = [0i64; $module::OUTPUTS.len()];
        writeln!(
            $run.w,
            "{} begin inputs={:?} outputs={:?} states={:?} period_us={} s={:?}",
            $tag,
            $module::INPUTS,
            $module::OUTPUTS,
            $module::STATES,
            $module::Controller::PERIOD_US,
            c.state_bits()
        )?;
        for k in 0..STEPS {
            let i = $stimulus(k, &mut rng, out);
            $run.meter.start();
            out = c.step_bits(i);
            $run.meter.stop();
            let s = c.state_bits();
            fnv.words(&i);
            fnv.words(&out);
            fnv.words(&s);
            writeln!($run.w, "{} {:3} i={:?} o={:?} s={:?}", $tag, k, i, out, s)?;
        }
        writeln!(
            $run.w,
            "{} end fnv={:016x} s={:?}",
            $tag,
            fnv.0,
            c.state_bits()
        )?;
        $run.total.words(&[fnv.0 as i64]);
        $run.meter.report($tag);
    }};
}

/// Turning: plant gains K_m ≈ 0.83, 2.4, 3.8 kN/(mm/s) (the 1981 paper's), feed in Q12.
fn turning(k: usize, rng: &mut XorShift64, feed: [i64; 1]) -> [i64; 1] {
    [force(k, rng, &[3400, 9830, 15565], feed[0], 12)]
}

/// Milling: plant gains 0.05, 0.12, 0.2 kN/(mm/s), feed in Q9.
fn milling(k: usize, rng: &mut XorShift64, feed: [i64; 1]) -> [i64; 1] {
    [force(k, rng, &[205, 492, 819], feed[0], 9)]
}

/// Grinding: see [`grinding`].
fn grinding_pi(k: usize, rng: &mut XorShift64, xd: [i64; 1]) -> [i64; 2] {
    grinding(k, rng, xd[0], grinding_pi::OUTPUT_FRAC[0])
}

/// Grinding, the adaptive controller: see [`grinding`].
fn grinding_adaptive(k: usize, rng: &mut XorShift64, xd: [i64; 1]) -> [i64; 2] {
    grinding(k, rng, xd[0], grinding_adaptive_pzc::OUTPUT_FRAC[0])
}

/// `v·2^by`, by shifts.
fn shift(v: i64, by: i32) -> i64 {
    if by >= 0 {
        v << by
    } else {
        v >> -by
    }
}

/// Inputs of the surface-finish controller (`ra`, `ra_req`: µm in the module's `INPUT_FRAC`;
/// ra in [0, 8], ra_req in [0.5, 4]); `feed` (mm/rev in its `OUTPUT_FRAC`) is its last output,
/// the feed of the part whose roughness the next step reads.
fn finishing(k: usize, rng: &mut XorShift64, feed: [i64; 1]) -> [i64; 2] {
    let [fa, fb] = gac_surface_finish::INPUT_FRAC;
    // Values in sixteenths of a µm, in each input's format.
    let ra = |v: i64| shift(v, fa - 4);
    let req = |v: i64| shift(v, fb - 4);
    let below = |rng: &mut XorShift64, n: i64| rng.below(n.clamp(1, u32::MAX as i64) as u32);
    let edges: [[i64; 2]; 16] = [
        [0, 0],
        [-1, 0],
        [0, -1],
        [ra(1), req(24)],          // Ra at RA_VALID = 1/16 µm; Ra_req 1.5 µm
        [ra(1) + 1, req(24)],      // one LSB above it
        [ra(128), req(64)],        // 8 µm, 4 µm: the range ends
        [ra(128) + 1, req(8) - 1], // one LSB beyond both
        [ra(128), req(8)],
        [ra(24), req(24)], // on target
        [ra(24) + 1, req(24)],
        [i32::MAX as i64, 0],
        [0, i32::MAX as i64],
        [i32::MIN as i64, i32::MAX as i64],
        [i32::MAX as i64 + 1, i32::MIN as i64 - 1],
        [i64::MAX, i64::MIN],
        [i64::MIN, i64::MAX],
    ];
    match k {
        // No part finished yet: the profilometer reads below RA_VALID.
        _ if k < AIR_END => [below(rng, ra(1)), req(24)],
        // Parts cut at the controller's feed: Ra = g·(c1·f + c2·f²) (eq. 29 with the spec's
        // initial model, c1 = 2 µm/(mm/rev), c2 = 20 µm/(mm/rev)²), the tool's wear g stepping
        // 1 → 1.5 → 2, plus profilometer noise of 1/256 µm; Ra_req = 1.5 µm.
        _ if k < LOOP_END => {
            let g = [16, 24, 32][(k - AIR_END) / SEGMENT]; // Q4
            let f16 = shift(feed[0], 16 - gac_surface_finish::OUTPUT_FRAC[0]); // mm/rev, Q16
            let ra32 = ((2 * f16) << 16) + 20 * f16 * f16; // µm, Q32
            let noise = (ra(1) >> 4).clamp(1, i64::from(u32::MAX / 2)) as u32;
            [shift(g * ra32, fa - 36) + rng.noise(noise), req(24)]
        }
        // Ramp of Ra from 0 to 8.8 µm, Ra_req 2 µm.
        _ if k < RAMP_END => [shift((k - LOOP_END) as i64 * 141, fa - 10), req(32)],
        _ if k < EDGE_END => edges[(k - RAMP_END) / 2],
        _ => match rng.below(8) {
            0 => [rng.next() as i32 as i64, rng.next() as i32 as i64],
            1 => [rng.next() as i64, rng.next() as i64],
            _ => [
                below(rng, ra(128) + 1),
                req(8) + below(rng, req(64) - req(8) + 1),
            ],
        },
    }
}

/// Prints the whole script to `w`; `meter` times the steps.
pub fn run(w: &mut impl Write, meter: &mut impl Meter) -> fmt::Result {
    writeln!(w, "qloop-cortex-m script steps={STEPS} seed={SEED:#018x}")?;
    let mut run = Run {
        w,
        meter,
        total: Fnv::new(),
    };
    drive!(run, "km1981", koren_masory_1981, turning);
    drive!(run, "accfix", acc_fixed_gain, turning);
    drive!(run, "millacc", milling_acc, milling);
    drive!(run, "grindpi", grinding_pi, grinding_pi);
    drive!(run, "grindpzc", grinding_adaptive_pzc, grinding_adaptive);
    drive!(run, "gacfin", gac_surface_finish, finishing);
    writeln!(
        run.w,
        "qloop-cortex-m done controllers=6 fnv={:016x}",
        run.total.0
    )
}
