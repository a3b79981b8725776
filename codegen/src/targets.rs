//! The built-in target descriptions (`targets/*.toml`, embedded at build time) and the reader
//! of target files (`--target FILE.toml`). The types and the cost model are the core's
//! ([`crate::lower::target`]); this module only reads and checks the files.
//!
//! The files are embedded from `codegen/targets/`, links to the workspace's `targets/` folder,
//! so that the packaged crate carries them.

use crate::lower::target::Target;

/// The built-in target files, the default (`rv32i`) first.
const BUILTIN: [(&str, &str); 7] = [
    ("rv32i", include_str!("../targets/rv32i.toml")),
    ("rv32imc", include_str!("../targets/rv32imc.toml")),
    ("atmega328p", include_str!("../targets/atmega328p.toml")),
    ("cortex-m0", include_str!("../targets/cortex-m0.toml")),
    (
        "cortex-m0-slowmul",
        include_str!("../targets/cortex-m0-slowmul.toml"),
    ),
    ("cortex-m4", include_str!("../targets/cortex-m4.toml")),
    ("host", include_str!("../targets/host.toml")),
];

/// Parses a target description (the format of `targets/*.toml`), checking its values.
pub fn from_toml(text: &str) -> Result<Target, String> {
    let t: Target = toml::from_str(text).map_err(|e| e.to_string())?;
    t.validate()?;
    Ok(t)
}

/// All built-in targets, the default first.
pub fn builtin() -> Vec<Target> {
    BUILTIN
        .iter()
        .map(|(name, text)| {
            from_toml(text)
                .unwrap_or_else(|e| unreachable!("built-in target {name} is checked by tests: {e}"))
        })
        .collect()
}

/// Names of the built-in targets.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}

/// Looks a built-in target up by name.
pub fn by_name(name: &str) -> Option<Target> {
    BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .and_then(|(_, text)| from_toml(text).ok())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lower::shift_add;
    use crate::lower::target::SplitShift;

    /// One decision for the cost model and the C emitter: a shift by `8q + r` is `q` byte
    /// moves and `r` bits, or, with room and `r > 4`, `q + 1` moves and `8 − r` bits back,
    /// unless that move would be the value's whole width.
    #[test]
    fn shifts_split_alike_for_the_model_and_the_emitter() {
        let avr = by_name("atmega328p").unwrap();
        let s = |bits, k, room| avr.split_shift(bits, k, room);
        let sp = |words, bits, up| Some(SplitShift { words, bits, up });
        assert_eq!(s(32, 14, true), sp(2, 2, true));
        assert_eq!(s(32, 14, false), sp(1, 6, false));
        assert_eq!(s(32, 11, true), sp(1, 3, false)); // r = 3: not worth rounding up
        assert_eq!(s(32, 29, true), sp(3, 5, false)); // 4 moves would be the whole int32
        assert_eq!(s(32, 16, true), None); // whole bytes
        assert_eq!(s(32, 5, false), None); // under a byte, no room: one plain shift
        assert_eq!(s(8, 5, true), None); // single-word value
        assert!(by_name("cortex-m0")
            .unwrap()
            .split_shift(32, 14, true)
            .is_none());
        // The model prices what the emitter writes: with room, 14 bits cost 2 moves' worth
        // plus 2 bits instead of 1 move plus 6.
        assert!(avr.shift_cost(32, 14, true) < avr.shift_cost(32, 14, false));
    }

    #[test]
    fn every_builtin_target_parses_and_is_named_after_its_file() {
        for (name, text) in BUILTIN {
            let t = from_toml(text).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(t.name, name);
        }
    }

    /// The core's [`Target::default`] is written out by hand (it reads no files): it must be
    /// `targets/rv32i.toml`, field for field.
    #[test]
    fn the_default_target_is_rv32i_toml() {
        assert_eq!(Target::default(), by_name("rv32i").unwrap());
        assert_eq!(builtin()[0], Target::default());
    }

    #[test]
    fn bad_target_files_are_refused_with_the_field() {
        let good = BUILTIN[2].1;
        let e = from_toml(&good.replace("word_bits = 8", "word_bits = 12")).unwrap_err();
        assert!(e.contains("word_bits"), "{e}");
        let e = from_toml(&good.replace("kind = \"8x8\"", "kind = \"9x9\"")).unwrap_err();
        assert!(e.contains("9x9"), "{e}");
        let e = from_toml(&format!("{good}\nbogus = 1\n")).unwrap_err();
        assert!(e.contains("bogus"), "{e}");
    }

    /// The model's multiply costs against the instruction sequences compilers emit (counted
    /// by hand from avr-gcc 7.3 `-Os` output and the ARM/RISC-V manuals).
    #[test]
    fn multiply_costs_follow_the_instruction_sequences() {
        let t = |n: &str| by_name(n).unwrap();
        // AVR 16×16→16: three MULs and two 8-bit adds (≈ 10 cycles with moves).
        assert_eq!(t("atmega328p").mul_cost(16), 3 * (2 + 2));
        // AVR 32×32→32 is __mulsi3: 10 partial products and a call.
        assert!(t("atmega328p").mul_cost(32) > 40);
        // One MULS on Cortex-M0; UMULL + two MLA on M4 for a 64-bit product.
        assert_eq!(t("cortex-m0").mul_cost(32), 1);
        assert_eq!(t("cortex-m4").mul_cost(64), 3 * (1 + 2));
        // __aeabi_lmul on M0: 16-bit limbs, ten partial products and a call.
        assert!(t("cortex-m0").mul_cost(64) > 30);
        // __mulsi3 on RV32I: a 32-iteration loop.
        assert!(t("rv32i").mul_cost(32) > 100);
    }

    #[test]
    fn shift_costs_pay_per_bit_without_a_barrel_shifter() {
        let avr = by_name("atmega328p").unwrap();
        // 3 bits: a loop of 3 × (4 bytes + DEC + BRNE) plus the counter's LDI (avr-gcc -Os).
        assert_eq!(avr.shift_cost(32, 3, false), 3 * (4 + 3) + 1);
        assert_eq!(avr.shift_cost(32, 1, false), 4); // one bit: unrolled
        assert_eq!(avr.shift_cost(32, 17, false), 4 + 4); // two bytes move, then one bit
                                                          // 64-bit: __ashldi3, a loop per byte and per bit over 8 bytes.
        assert_eq!(avr.shift_cost(64, 17, false), 8 + (8 + 3) * (2 + 1));
        assert_eq!(avr.add_cost(64), 8 + 8); // __adddi3
        assert_eq!(avr.add_cost(32), 4);
        assert_eq!(avr.shift_cost(32, 8, false), 4); // byte moves
        assert_eq!(avr.shift_cost(16, 9, false), 2 + 2);
        let m0 = by_name("cortex-m0").unwrap();
        assert_eq!(m0.shift_cost(32, 17, false), 1);
        assert_eq!(m0.shift_cost(64, 17, false), 4);
    }

    #[test]
    fn a_widened_narrow_operand_needs_fewer_partial_products() {
        let avr = by_name("atmega328p").unwrap();
        // 16×16→32 (__mulhisi3): 4 MULs, each with two byte adds, and the call.
        assert_eq!(avr.widening_mul_cost(32, 16), 4 * (2 + 2) + 8);
        // 32×32→32 (__mulsi3): the low 10 partial products of 4×4 limbs.
        assert_eq!(avr.mul_cost(32), 10 * (2 + 2) + 8);
        let m4 = by_name("cortex-m4").unwrap();
        assert_eq!(m4.widening_mul_cost(32, 16), m4.mul_cost(32));
    }

    #[test]
    fn the_choice_depends_on_the_target() {
        // x · 0.9375 = (x << 4) − x, one adder: a 32-bit value.
        let p = shift_add::best(15);
        let cost = |n: &str| {
            let t = by_name(n).unwrap();
            (t.shift_add_cost(&p, 32, &|_, _| false), t.mul_cost(32))
        };
        // On AVR a 4-bit shift of 4 bytes is a loop, and the term costs saved registers: a
        // full 32-bit x · 15 goes to __mulsi3, but x · 257 = (x << 8) + x (a byte move) stays
        // shift-add.
        let (sa, mul) = cost("atmega328p");
        assert!(sa > mul, "AVR x·15: shift-add {sa} vs __mulsi3 {mul}");
        let avr = by_name("atmega328p").unwrap();
        let (sa, mul) = (
            avr.shift_add_cost(&shift_add::best(257), 32, &|_, _| false),
            avr.mul_cost(32),
        );
        assert!(sa < mul, "AVR x·257: shift-add {sa} vs __mulsi3 {mul}");
        let (sa, mul) = cost("cortex-m0");
        assert!(sa > mul, "M0: shift-add {sa} vs MULS {mul}");
        let (sa, mul) = cost("cortex-m0-slowmul");
        assert!(sa < mul, "slow M0: shift-add {sa} vs MULS {mul}");
        let (sa, mul) = cost("rv32i");
        assert!(sa < mul, "RV32I: shift-add {sa} vs __mulsi3 {mul}");
    }
}
