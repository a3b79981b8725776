//! Targets and the cost model that picks shift-add or the hardware multiplier.

/// A target's word size and operation costs (cycles, roughly).
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Name used on the command line.
    pub name: &'static str,
    /// One-line description.
    pub about: &'static str,
    /// Native register width; intermediates are at least this wide.
    pub native_bits: u32,
    /// Cost of one add/subtract/compare on a native word.
    pub add: u32,
    /// Cost of one constant shift on a native word.
    pub shift: u32,
    /// Cost of one multiply whose result fits a native word.
    pub mul_native: u32,
    /// Cost of one widening multiply (double-word result).
    pub mul_wide: u32,
}

impl Target {
    /// The default: a 32-bit core without a fast multiplier (RV32I-class: `mul` is a
    /// library call of a few dozen cycles), so constant gains always become shift-add.
    pub const GENERIC32: Target = Target {
        name: "generic32",
        about: "32-bit core, no fast multiplier (RV32I-class)",
        native_bits: 32,
        add: 1,
        shift: 1,
        mul_native: 32,
        mul_wide: 40,
    };

    /// A 32-bit core with a single-cycle multiplier and a multi-cycle widening multiply
    /// (Cortex-M3/M4-class): short shift-add chains still win, long ones lose.
    pub const FASTMUL32: Target = Target {
        name: "fastmul32",
        about: "32-bit core, single-cycle MUL, multi-cycle SMULL (Cortex-M3/M4-class)",
        native_bits: 32,
        add: 1,
        shift: 1,
        mul_native: 1,
        mul_wide: 3,
    };

    /// All built-in targets.
    pub const ALL: [Target; 2] = [Target::GENERIC32, Target::FASTMUL32];

    /// Looks a target up by name.
    pub fn by_name(name: &str) -> Option<Target> {
        Target::ALL.iter().find(|t| t.name == name).cloned()
    }

    /// Words needed for a `bits`-wide operation.
    fn words(&self, bits: u32) -> u32 {
        bits.div_ceil(self.native_bits).max(1)
    }

    /// Cost of an add/sub/compare of `bits` width (carry chain across words).
    pub fn add_cost(&self, bits: u32) -> u32 {
        self.add * self.words(bits)
    }

    /// Cost of a constant shift of `bits` width (double-word shifts need ~3 ops per word).
    pub fn shift_cost(&self, bits: u32) -> u32 {
        let w = self.words(bits);
        self.shift * if w == 1 { 1 } else { 3 * w - 2 }
    }

    /// Cost of a multiply with a `bits`-wide result.
    pub fn mul_cost(&self, bits: u32) -> u32 {
        if bits <= self.native_bits {
            self.mul_native
        } else {
            self.mul_wide * self.words(bits) / 2
        }
    }
}

impl Default for Target {
    fn default() -> Self {
        Target::GENERIC32
    }
}
