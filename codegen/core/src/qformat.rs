//! Q-formats: the binary fixed-point representation of one signal.
//!
//! A value `v` with format `Q(iW, f)` is stored as the integer `raw = v · 2^f` in a `W`-bit
//! two's-complement word (`uW` for unsigned). `f` may be negative (a coarse integer scale) or
//! larger than `W` (a small signal) inside the compiler; at the generated API boundary
//! (inputs, states, outputs) `0 ≤ f ≤ W` so that the `fixed` crate's types can carry it.

use std::fmt;

/// Machine integer types the emitted code uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct IntTy {
    /// Two's-complement signed (`iW`) or unsigned (`uW`).
    pub signed: bool,
    /// Word width in bits: 8, 16, 32 or 64.
    pub bits: u32,
}

/// The word widths qloop emits.
pub const WIDTHS: [u32; 4] = [8, 16, 32, 64];

impl IntTy {
    /// A signed type of `bits` bits.
    pub const fn signed(bits: u32) -> Self {
        IntTy { signed: true, bits }
    }

    /// An unsigned type of `bits` bits.
    pub const fn unsigned(bits: u32) -> Self {
        IntTy {
            signed: false,
            bits,
        }
    }

    /// Smallest representable raw value.
    pub fn min(self) -> i128 {
        if self.signed {
            // An arithmetic shift: also right for 128 bits, where −2^127 has no positive twin.
            i128::MIN >> (128 - self.bits)
        } else {
            0
        }
    }

    /// Largest representable raw value.
    pub fn max(self) -> i128 {
        if self.signed {
            i128::MAX >> (128 - self.bits)
        } else if self.bits >= 127 {
            // u128 and u127 saturate to the largest i128.
            i128::MAX
        } else {
            (1i128 << self.bits) - 1
        }
    }

    /// Whether every integer in `[lo, hi]` is representable.
    pub fn holds(self, lo: i128, hi: i128) -> bool {
        lo >= self.min() && hi <= self.max()
    }

    /// The narrowest signed type of at least `min_bits` bits that holds `[lo, hi]`.
    pub fn signed_for(lo: i128, hi: i128, min_bits: u32) -> Option<IntTy> {
        WIDTHS
            .iter()
            .copied()
            .filter(|&b| b >= min_bits)
            .map(IntTy::signed)
            .find(|t| t.holds(lo, hi))
    }

    /// The narrowest type that holds every value of `self` and of `other`: the wider of the
    /// two where they agree in sign, else the narrowest signed type that holds both.
    pub fn join(self, other: IntTy) -> IntTy {
        if self.signed == other.signed {
            return if self.bits >= other.bits { self } else { other };
        }
        let (lo, hi) = (self.min().min(other.min()), self.max().max(other.max()));
        IntTy::signed_for(lo, hi, 8).unwrap_or(IntTy::signed(128))
    }

    /// The Rust spelling, e.g. `i32`.
    pub fn rust_name(self) -> String {
        format!("{}{}", if self.signed { 'i' } else { 'u' }, self.bits)
    }
}

impl fmt::Display for IntTy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.rust_name())
    }
}

/// A fixed-point format: storage type and fraction bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct QFormat {
    /// Storage type.
    pub ty: IntTy,
    /// Fraction bits `f`: value = raw · 2^-f.
    pub frac: i32,
}

impl QFormat {
    /// The weight of one raw unit, 2^-frac, in physical units.
    pub fn lsb(self) -> f64 {
        pow2(-self.frac)
    }

    /// Raw value of the smallest representable value ≥ `v` (`ceil(v · 2^f)`).
    pub fn raw_ceil(self, v: f64) -> i128 {
        (v * pow2(self.frac)).ceil() as i128
    }

    /// Raw value of the largest representable value ≤ `v` (`floor(v · 2^f)`).
    pub fn raw_floor(self, v: f64) -> i128 {
        (v * pow2(self.frac)).floor() as i128
    }

    /// Raw value nearest to `v` (ties away from zero).
    pub fn raw_nearest(self, v: f64) -> i128 {
        (v * pow2(self.frac)).round() as i128
    }

    /// Physical value of a raw integer.
    pub fn value(self, raw: i128) -> f64 {
        raw as f64 * self.lsb()
    }

    /// Whether the `fixed` crate can represent this format (`0 ≤ f ≤ W`).
    pub fn fits_fixed_crate(self) -> bool {
        self.frac >= 0 && self.frac as u32 <= self.ty.bits
    }

    /// The largest `frac` in `[0, W]` for which `[lo, hi]` fits in `ty`, if any.
    pub fn best_for(ty: IntTy, lo: f64, hi: f64) -> Option<QFormat> {
        (0..=ty.bits as i32)
            .rev()
            .map(|frac| QFormat { ty, frac })
            .find(|q| ty.holds(q.raw_floor(lo), q.raw_ceil(hi)))
    }
}

impl fmt::Display for QFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Q({}, {})", self.ty, self.frac)
    }
}

/// A finite `v` as `(m, e)` with `v = m · 2^e` exactly (`m` the signed 53-bit significand).
pub fn significand_exponent(v: f64) -> (i128, i32) {
    let bits = v.to_bits();
    let be = ((bits >> 52) & 0x7ff) as i32;
    let frac = (bits & ((1u64 << 52) - 1)) as i128;
    let (m, e) = if be == 0 {
        (frac, -1074)
    } else {
        (frac | (1 << 52), be - 1075)
    };
    (if v < 0.0 { -m } else { m }, e)
}

/// 2^e as an `f64`, exact for |e| < 1000.
pub fn pow2(e: i32) -> f64 {
    2f64.powi(e)
}

/// How a right shift that drops fraction bits rounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Rounding {
    /// Arithmetic shift right: rounds toward −∞. Error in `[0, 1 LSB)`. One instruction.
    #[default]
    Floor,
    /// Add half an LSB, then shift: rounds to nearest, ties toward +∞. Error ≤ ½ LSB.
    Nearest,
}

impl fmt::Display for Rounding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Rounding::Floor => "floor",
            Rounding::Nearest => "nearest",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn best_format_uses_all_bits() {
        // [0, 5] in i32: needs 3 integer bits + sign, so 28 fraction bits: 5·2^28 < 2^31.
        let q = QFormat::best_for(IntTy::signed(32), 0.0, 5.0).unwrap();
        assert_eq!(q.frac, 28);
        // One more bit would overflow: 5·2^29 > 2^31 − 1.
        assert!(5.0 * pow2(29) > IntTy::signed(32).max() as f64);
        let q = QFormat::best_for(IntTy::unsigned(16), 0.0, 1.0).unwrap();
        assert_eq!(q.frac, 15);
    }

    #[test]
    fn join_holds_both_types() {
        let (i16_, i32_, u16_, u8_) = (
            IntTy::signed(16),
            IntTy::signed(32),
            IntTy::unsigned(16),
            IntTy::unsigned(8),
        );
        assert_eq!(i16_.join(i32_), i32_);
        assert_eq!(i32_.join(i16_), i32_);
        // u16's 65535 needs 17 signed bits.
        assert_eq!(u16_.join(i16_), i32_);
        assert_eq!(u8_.join(i16_), i16_);
        assert_eq!(u8_.join(u16_), u16_);
        for (a, b) in [(u16_, i16_), (u8_, i16_), (i16_, i32_)] {
            let j = a.join(b);
            assert!(j.holds(a.min(), a.max()) && j.holds(b.min(), b.max()));
        }
    }

    #[test]
    fn signed_for_picks_narrowest() {
        assert_eq!(IntTy::signed_for(-128, 127, 8), Some(IntTy::signed(8)));
        assert_eq!(IntTy::signed_for(-129, 127, 8), Some(IntTy::signed(16)));
        assert_eq!(IntTy::signed_for(0, 1, 32), Some(IntTy::signed(32)));
        assert_eq!(IntTy::signed_for(0, i64::MAX as i128 + 1, 8), None);
    }
}
