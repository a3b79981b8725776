//! Target descriptions (`targets/*.toml`) and the cost model that picks, per constant
//! multiplication, a shift-add network or the hardware multiplier.
//!
//! A target gives its native word width, its multiplier (none, 8×8, 16×16, 32×32→32,
//! 32×32→64 or 64×64→64, with its cycles), whether it has a barrel shifter (or pays per bit),
//! the cost of add, load/store and a library call, and the widths of C's `int` and `long`.
//! The built-in targets are the files of the workspace's `targets/` folder, which the `qloop`
//! crate embeds and reads (its `targets` module, with the `serde` feature of this crate);
//! `--target FILE.toml` loads another one. This crate knows one target by heart, the default
//! (`rv32i`), for the `controller!` macro; a `qloop` test checks it equals `targets/rv32i.toml`.
//!
//! The model counts cycles of straight-line code, the way a compiler for the target would
//! emit it; it only has to rank the two ways to multiply by a constant, and the object-code
//! checks (`tests/tests/object_code.rs`) confirm on real compilers that the choice survives.
//! Choices never change results: a shift-add network and a multiply compute the same exact
//! product, so every target's code is bit-for-bit the same function.

use super::shift_add::{Operand, ShiftAddPlan};

/// A target's word sizes and operation costs (cycles).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Target {
    /// Name used on the command line.
    pub name: String,
    /// One-line description.
    pub about: String,
    /// Native register width in bits (8 on AVR, 32 on Cortex-M and RV32, 64 on the host).
    pub word_bits: u32,
    /// The hardware multiplier.
    pub multiplier: Multiplier,
    /// How constant shifts cost.
    pub shifter: Shifter,
    /// Cycle costs of the other operations.
    pub costs: Costs,
    /// C type widths.
    pub c: CTypes,
    /// Compilers, disassembler and simulator for this target (optional).
    #[cfg_attr(feature = "serde", serde(default))]
    pub toolchain: Toolchain,
    /// Use the multiplier for every constant that is not a power of two, whatever the costs
    /// (the `plain_mul` baseline of `qloop bench`); not settable from a target file.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub force_multiply: bool,
}

/// The multiplier: its operand/result shape and cycles per instruction.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Multiplier {
    /// Shape of the multiply instruction.
    pub kind: MulKind,
    /// Cycles of one multiply instruction (0 if there is none).
    pub cycles: u32,
    /// A product of two 32-bit values rounded to a 32-bit result drops its low×low piece:
    /// it is [`crate::lower::lir::Op::MulHi`], three 16×16→32-bit products, within 3 LSBs of
    /// the product's high word (then shifted to the result's format), instead of a 32×32→64
    /// product and 64-bit rounding. For a target whose 64-bit arithmetic is library calls
    /// (the AVR); off by default.
    #[cfg_attr(feature = "serde", serde(default))]
    pub high_product: bool,
}

/// Shape of a target's multiply instruction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
pub enum MulKind {
    /// No multiplier: products are a library shift-and-add loop.
    #[cfg_attr(feature = "serde", serde(rename = "none"))]
    None,
    /// 8×8→16 (AVR `MUL`).
    #[cfg_attr(feature = "serde", serde(rename = "8x8"))]
    M8x8,
    /// 16×16→32.
    #[cfg_attr(feature = "serde", serde(rename = "16x16"))]
    M16x16,
    /// 32×32→32, low half only (ARMv6-M `MULS`).
    #[cfg_attr(feature = "serde", serde(rename = "32x32->32"))]
    M32x32To32,
    /// 32×32→64 (ARMv7-M `SMULL`, RISC-V `MUL` + `MULH`).
    #[cfg_attr(feature = "serde", serde(rename = "32x32->64"))]
    M32x32To64,
    /// 64×64→64 (64-bit hosts).
    #[cfg_attr(feature = "serde", serde(rename = "64x64->64"))]
    M64x64To64,
}

impl MulKind {
    /// Operand width of one multiply instruction (0 for none).
    pub fn width(self) -> u32 {
        match self {
            MulKind::None => 0,
            MulKind::M8x8 => 8,
            MulKind::M16x16 => 16,
            MulKind::M32x32To32 | MulKind::M32x32To64 => 32,
            MulKind::M64x64To64 => 64,
        }
    }

    /// Whether one instruction (or an instruction pair) yields the double-width product.
    pub fn widening(self) -> bool {
        matches!(self, MulKind::M8x8 | MulKind::M16x16 | MulKind::M32x32To64)
    }

    /// The spelling used in target files.
    pub fn as_str(self) -> &'static str {
        match self {
            MulKind::None => "none",
            MulKind::M8x8 => "8x8",
            MulKind::M16x16 => "16x16",
            MulKind::M32x32To32 => "32x32->32",
            MulKind::M32x32To64 => "32x32->64",
            MulKind::M64x64To64 => "64x64->64",
        }
    }
}

/// Constant shifts: a barrel shifter (any distance in one instruction per word) or a per-bit
/// cost (AVR's one-bit `LSL`/`ROL`/`ASR`/`ROR`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Shifter {
    /// Any shift distance in one instruction.
    pub barrel: bool,
    /// Cycles per shift instruction (barrel), or per bit position per word (no barrel).
    pub cycles: u32,
    /// No barrel shifter: extra cycles per bit position when the compiler shifts in a loop
    /// (avr-gcc at `-Os` shifts a multi-byte value by more than one bit in a loop, with a
    /// `DEC` and a taken `BRNE` per bit, plus an `LDI` of the counter). 0: unrolled.
    #[cfg_attr(feature = "serde", serde(default))]
    pub loop_cycles: u32,
}

/// Cycle costs of add, load/store and a library call.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Costs {
    /// One add/subtract/compare of a native word.
    pub add: u32,
    /// One load of a native word.
    pub load: u32,
    /// One store of a native word.
    pub store: u32,
    /// Call and return of a library routine (a software multiply).
    pub call: u32,
    /// Adds and shifts of values at least this wide are library calls too (avr-gcc 5.4:
    /// `__adddi3`, `__ashldi3`, `__ashrdi3` for 64-bit values; a shift is then a loop over
    /// whole bytes and one over bits, each step touching every byte). 0: never.
    #[cfg_attr(feature = "serde", serde(default))]
    pub libcall_bits: u32,
    /// Cycles per native word of the temporary each shift-add step keeps live. On AVR, GCC
    /// gives a network's shifted terms call-saved registers, which `step` must save and
    /// restore (`PUSH` + `POP`, 4 cycles per byte); a multiply routine works in fixed
    /// call-clobbered registers instead. 0 where registers are plentiful.
    #[cfg_attr(feature = "serde", serde(default))]
    pub temp: u32,
    /// The ISA has no carry flag (RISC-V): a multi-word add or subtract takes, for each word
    /// after the first, the add itself, a compare that recovers the carry (`SLTU`) and the add
    /// of it, so a 64-bit add on RV32 is four instructions, not the two of `ADDS`/`ADC`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub no_carry: bool,
    /// Bytes of flash worth one cycle a step: a table's differences are read as
    /// `T[i + 1] − T[i]` instead of stored where that saves at least this many bytes per cycle
    /// it adds (one subtraction a read; [`crate::emit::table_layouts`]). 0: always stored (the
    /// fastest code). On a small AVR the firmware around the controller (grbl takes 30 of the
    /// ATmega328P's 32 KB) makes flash the scarcer of the two.
    #[cfg_attr(feature = "serde", serde(default))]
    pub flash_per_cycle: u32,
}

/// Widths of C's integer types on the target.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CTypes {
    /// Bits of `int` (16 on AVR): C computes in at least this width, so qloop's intermediates
    /// start there too.
    pub int_bits: u32,
    /// Bits of `long`.
    pub long_bits: u32,
}

/// Tools for building and running code for the target.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Toolchain {
    /// C compiler.
    pub cc: Option<String>,
    /// Its flags.
    #[cfg_attr(feature = "serde", serde(default))]
    pub cflags: Vec<String>,
    /// Disassembler for the object-code checks.
    pub objdump: Option<String>,
    /// Rust target triple.
    pub rust_target: Option<String>,
    /// Instruction-set simulator.
    pub simulator: Option<String>,
    /// QEMU machine.
    pub qemu_machine: Option<String>,
}

impl Toolchain {
    /// The AVR device the flags compile for (`-mmcu=NAME`), which is also simavr's core.
    pub fn mcu(&self) -> Option<&str> {
        self.cflags.iter().find_map(|f| f.strip_prefix("-mmcu="))
    }
}

impl Target {
    /// Checks a target description's values (what a target file may not say: word widths
    /// other than 8/16/32/64, a multiplier with cycles but no kind, free shifts or adds).
    pub fn validate(&self) -> Result<(), String> {
        let bad = |what: &str| Err(format!("target `{}`: {what}", self.name));
        if !matches!(self.word_bits, 8 | 16 | 32 | 64) {
            return bad("`word_bits` must be 8, 16, 32 or 64");
        }
        if !matches!(self.c.int_bits, 16 | 32) || !matches!(self.c.long_bits, 32 | 64) {
            return bad("`c.int_bits` must be 16 or 32 and `c.long_bits` 32 or 64");
        }
        if (self.multiplier.kind == MulKind::None) != (self.multiplier.cycles == 0) {
            return bad("`multiplier.cycles` must be 0 exactly when `multiplier.kind` is \"none\"");
        }
        if self.shifter.cycles == 0 || self.costs.add == 0 {
            return bad("`shifter.cycles` and `costs.add` must be at least 1");
        }
        Ok(())
    }

    /// This target with every non-power-of-two constant multiply on the multiplier: the
    /// "plain `*`" baseline that shift-add is measured against.
    pub fn always_multiply(&self) -> Target {
        Target {
            force_multiply: true,
            ..self.clone()
        }
    }

    /// The narrowest width intermediates get: C's `int`, since C promotes narrower operands to
    /// it anyway (16 bits on AVR, 32 elsewhere).
    pub fn min_work_bits(&self) -> u32 {
        self.c.int_bits
    }

    /// Native words needed for a `bits`-wide operation.
    fn words(&self, bits: u32) -> u32 {
        bits.div_ceil(self.word_bits).max(1)
    }

    /// Whether `bits`-wide adds and shifts are library calls (avr-gcc's `int64_t`): the cost
    /// model charges them as calls, and the C emitter writes some of them another way.
    pub fn libcall(&self, bits: u32) -> bool {
        self.costs.libcall_bits > 0 && bits >= self.costs.libcall_bits
    }

    /// Cost of an add/sub/compare of `bits` width (carry chain across words).
    pub fn add_cost(&self, bits: u32) -> u32 {
        let words = self.words(bits);
        let carries = if self.costs.no_carry {
            2 * (words - 1)
        } else {
            0
        };
        let chain = self.costs.add * (words + carries);
        chain
            + if self.libcall(bits) {
                self.costs.call
            } else {
                0
            }
    }

    /// Cost of a constant shift by `k` of a `bits`-wide value. A barrel shifter does one word
    /// per instruction (a multi-word shift needs about three per word to funnel the bits
    /// across); without one, each bit position costs one instruction per word, except that
    /// whole words just move.
    pub fn shift_cost(&self, bits: u32, k: u32, up_room: bool) -> u32 {
        if k == 0 {
            return 0;
        }
        let w = self.words(bits);
        if self.shifter.barrel {
            self.shifter.cycles * if w == 1 { 1 } else { 3 * w - 2 }
        } else if self.libcall(bits) {
            let steps = k / self.word_bits + k % self.word_bits;
            self.costs.call + (self.shifter.cycles * w + self.shifter.loop_cycles) * steps
        } else {
            // The C emitter writes the shift as whole-word moves and a shift by the rest
            // (`split_shift`, shared with `emit::c`), so only those bit positions loop.
            let (moves, r) = match self.split_shift(bits, k, up_room) {
                Some(sp) => (w, sp.bits),
                None => (if k >= self.word_bits { w } else { 0 }, k % self.word_bits),
            };
            let per_bit = self.shifter.cycles * w;
            let bits_cost = if r <= 1 || self.shifter.loop_cycles == 0 {
                per_bit * r
            } else {
                (per_bit + self.shifter.loop_cycles) * r + 1
            };
            bits_cost + moves
        }
    }

    /// How the C emitter writes a constant shift by `k` of a `bits`-wide value on a core
    /// without a barrel shifter, where the compiler would loop bit by bit over every word
    /// (`None`: as one plain shift, on barrel shifters, single-word values, whole-word
    /// shifts, and shifts under one word with no room to round up). With `k = w·q + r`: move
    /// `q` whole words, then shift `r` bits; or, if `w − r < r`, the value has room for one
    /// more word (`up_room`) and `q + 1` words are still narrower than the value, move
    /// `q + 1` words and shift `w − r` bits back. Exact either way. The cost model prices
    /// shifts with it, so the two never disagree.
    pub fn split_shift(&self, bits: u32, k: u32, up_room: bool) -> Option<SplitShift> {
        let word = self.word_bits;
        if self.shifter.barrel || bits <= word || k.is_multiple_of(word) {
            return None;
        }
        let (q, r) = (k / word, k % word);
        // The rounded-up form moves one word more than the shift, which must stay narrower
        // than the value (a C shift by its width is undefined).
        if word - r < r && up_room && word * (q + 1) < bits {
            return Some(SplitShift {
                words: q + 1,
                bits: word - r,
                up: true,
            });
        }
        (q > 0).then_some(SplitShift {
            words: q,
            bits: r,
            up: false,
        })
    }

    /// Cost of a multiply of two `bits`-wide operands keeping the low `bits` of the product
    /// (the only multiply the plan emits; operands are widened first).
    ///
    /// With a widening `m`-bit multiplier the product needs `n(n+1)/2` partial products for
    /// `n = ⌈bits/m⌉` limbs (the low `n` limbs of the schoolbook product). A multiplier that
    /// only returns the low half (ARMv6-M `MULS`) must split wider operands into `m/2`-bit
    /// limbs. Each partial product costs the multiply plus accumulating two limbs; more than two
    /// limbs make it a library call (`__mulsi3`, `__aeabi_lmul`). Without a
    /// multiplier the product is a shift-and-add loop over `bits` iterations.
    pub fn mul_cost(&self, bits: u32) -> u32 {
        self.widening_mul_cost(bits, bits)
    }

    /// Cost of a `bits`-wide product of two operands that each fit `operand_bits` (a
    /// sign-extended narrower value). A widening multiplier then needs only the operands'
    /// limbs: avr-gcc multiplies a 16-bit value widened to 32 bits by `__mulhisi3`, four
    /// `MUL`s, not `__mulsi3`'s ten.
    pub fn widening_mul_cost(&self, bits: u32, operand_bits: u32) -> u32 {
        let kind = self.multiplier.kind;
        if kind == MulKind::None {
            let per_iter = self.add_cost(bits) * 2 + self.shift_cost(bits, 1, false) * 2 + 2;
            return self.costs.call + bits * per_iter;
        }
        let m = kind.width();
        let n = if bits <= m {
            1
        } else if kind.widening() {
            bits.div_ceil(m)
        } else {
            bits.div_ceil(m / 2)
        };
        let na = if kind.widening() {
            operand_bits.min(bits).div_ceil(m).max(1)
        } else {
            n
        };
        let pp = (n * (n + 1) / 2).min(na * na);
        let limb_add = self.add_cost(m);
        let body = pp * (self.multiplier.cycles + if pp > 1 { 2 * limb_add } else { 0 });
        body + if n > 2 { self.costs.call } else { 0 }
    }

    /// Cost of multiplying a value of `x_bits` by a constant of `m_bits` (the narrowest C type
    /// at least `int` that holds it) on the multiplier, with a `bits`-wide product: the
    /// multiply and loading the constant (one immediate load per native word).
    ///
    /// On a widening 32×32→64 multiplier without library calls (Cortex-M4's `UMULL` and
    /// `MLA`, RV32IMC's `MUL`/`MULHU`), GCC multiplies a 64-bit value by a constant that fits
    /// 32 bits limb by limb: the low limb's double-width product and the high limb's low
    /// product, two multiplies and one add, not the three of a 64×64 product. Elsewhere the
    /// compiler sees both factors at the wider type (avr-gcc's `__muldi3`, `__aeabi_lmul`).
    pub fn const_mul_cost(&self, bits: u32, x_bits: u32, m_bits: u32) -> u32 {
        let limbwise = self.multiplier.kind == MulKind::M32x32To64
            && !self.libcall(bits)
            && bits == 64
            && x_bits == 64
            && m_bits <= 32;
        if limbwise {
            return 2 * self.multiplier.cycles + self.add_cost(32) + self.costs.add;
        }
        self.widening_mul_cost(bits, x_bits.max(m_bits)) + self.costs.add * self.words(bits)
    }

    /// Cost of a shift-add network computing `plan.m · x` on `bits`-wide values: one adder per
    /// step, the shifts of its operands, the final shift and negation. `up_room(c, k)`: whether
    /// the term `c·x` shifted by `k` has room for [`Target::split_shift`]'s rounded-up form.
    pub fn shift_add_cost(
        &self,
        plan: &ShiftAddPlan,
        bits: u32,
        up_room: &dyn Fn(i128, u32) -> bool,
    ) -> u32 {
        let add = self.add_cost(bits);
        let coefs = plan.step_coefficients();
        let coef = |o: Operand| match o {
            Operand::X => 1,
            Operand::Step(j) => coefs[j],
        };
        let shift = |c: i128, k: u32| self.shift_cost(bits, k, up_room(c, k));
        let mut c = 0;
        for s in &plan.steps {
            // A shift of the input `x` by the same amount is shared between steps in practice;
            // counting each keeps the model conservative.
            c += add + shift(coef(s.a), s.a_shift) + shift(coef(s.b), s.b_shift);
            c += self.costs.temp * self.words(bits);
            if s.negate_a {
                c += add;
            }
        }
        c + shift(coef(plan.result), plan.final_shift) + if plan.negate { add } else { 0 }
    }
}

/// A constant shift written as whole-word moves and a short shift ([`Target::split_shift`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitShift {
    /// Whole words moved.
    pub words: u32,
    /// Bit positions shifted after (or, for `up`, back from) the move.
    pub bits: u32,
    /// The rounded-up form: one word more than the shift, then `bits` back.
    pub up: bool,
}

impl Default for Target {
    /// `rv32i`: a 32-bit core without a multiplier, so every constant gain becomes shift-add.
    /// Written out here (the core reads no target files); `qloop`'s
    /// `targets::tests::the_default_target_is_rv32i_toml` checks it equals `targets/rv32i.toml`.
    fn default() -> Self {
        let s = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        Target {
            name: "rv32i".into(),
            about: "RV32I (no M extension): multiply is a __mulsi3 library loop, no divider".into(),
            word_bits: 32,
            multiplier: Multiplier {
                kind: MulKind::None,
                cycles: 0,
                high_product: false,
            },
            shifter: Shifter {
                barrel: true,
                cycles: 1,
                loop_cycles: 0,
            },
            costs: Costs {
                add: 1,
                load: 2,
                store: 1,
                call: 4,
                libcall_bits: 0,
                temp: 0,
                no_carry: true,
                flash_per_cycle: 0,
            },
            c: CTypes {
                int_bits: 32,
                long_bits: 32,
            },
            toolchain: Toolchain {
                cc: Some("riscv64-unknown-elf-gcc".into()),
                cflags: s(&["-march=rv32i", "-mabi=ilp32", "-Os", "-ffreestanding"]),
                objdump: Some("riscv64-unknown-elf-objdump".into()),
                rust_target: Some("riscv32i-unknown-none-elf".into()),
                simulator: None,
                qemu_machine: Some("virt".into()),
            },
            force_multiply: false,
        }
    }
}
