//! The force sensor chain: gain, additive Gaussian noise (seeded), saturation, and ADC
//! quantisation, in that order (Koren & Masory 1981: "the gain H represents the force sensor electronics and
//! the ADC gain").

use crate::fault::{Fault, Faults};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Sensor parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorParams {
    /// Gain from the true value to the reading (1 = calibrated).
    pub gain: f64,
    /// Standard deviation of the additive noise, in reading units.
    pub noise_sigma: f64,
    /// Full-scale range of the ADC `[lo, hi]`; readings saturate there.
    pub range: (f64, f64),
    /// ADC resolution in bits.
    pub bits: u32,
}

/// A sensor with its own seeded noise stream.
#[derive(Clone, Debug)]
pub struct Sensor {
    p: SensorParams,
    rng: ChaCha8Rng,
    noise: Option<Normal<f64>>,
    /// ADC step and highest code.
    lsb: f64,
    top: f64,
    /// Injected faults, and the last reading (what a `stuck` fault holds).
    faults: Faults,
    last: f64,
}

impl Sensor {
    /// A sensor whose noise is drawn from a ChaCha8 stream seeded with `seed`.
    pub fn new(p: SensorParams, seed: u64) -> Sensor {
        let levels = 2f64.powi(p.bits as i32);
        Sensor {
            noise: Normal::new(0.0, p.noise_sigma)
                .ok()
                .filter(|_| p.noise_sigma > 0.0),
            lsb: (p.range.1 - p.range.0) / levels,
            top: levels - 1.0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            faults: Faults::new(&[], seed),
            last: 0.0,
            p,
        }
    }

    /// The sensor with the scenario's faults injected ([`crate::fault`]).
    pub fn with_faults(mut self, faults: &[Fault], seed: u64) -> Sensor {
        self.faults = Faults::new(faults, seed);
        self
    }

    /// One reading of the true value `x` at time `t`, faults applied. The noise is drawn on
    /// every reading, faulty or not, so that a fault does not shift the noise stream.
    pub fn read_at(&mut self, t: f64, x: f64) -> f64 {
        let noise = self.noise.map_or(0.0, |n| n.sample(&mut self.rng));
        let (lo, hi) = self.p.range;
        let r = match self
            .faults
            .apply(t, self.p.gain * x + noise, self.last, (lo, hi))
        {
            Err(held) => held,
            Ok(v) => lo + ((v.clamp(lo, hi) - lo) / self.lsb).round().min(self.top) * self.lsb,
        };
        self.last = r;
        r
    }

    /// One reading of the true value `x`.
    pub fn read(&mut self, x: f64) -> f64 {
        let noise = self.noise.map_or(0.0, |n| n.sample(&mut self.rng));
        let (lo, hi) = self.p.range;
        let v = (self.p.gain * x + noise).clamp(lo, hi);
        lo + ((v - lo) / self.lsb).round().min(self.top) * self.lsb
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(sigma: f64) -> SensorParams {
        SensorParams {
            gain: 1.0,
            noise_sigma: sigma,
            range: (0.0, 5.0),
            bits: 12,
        }
    }

    #[test]
    fn quantises_and_saturates() {
        let mut s = Sensor::new(p(0.0), 1);
        let lsb = 5.0 / 4096.0;
        // Exact arithmetic: 1.5 kN is 1228.8 LSB → 1229 LSB.
        assert_eq!(s.read(1.5), 1229.0 * lsb);
        assert_eq!(s.read(-3.0), 0.0);
        assert_eq!(s.read(9.0), 4095.0 * lsb);
    }

    #[test]
    fn noise_is_seeded_and_has_its_sigma() {
        let (mut a, mut b) = (Sensor::new(p(0.05), 7), Sensor::new(p(0.05), 7));
        let xs: Vec<f64> = (0..20_000).map(|_| a.read(2.5) - 2.5).collect();
        let ys: Vec<f64> = (0..20_000).map(|_| b.read(2.5) - 2.5).collect();
        assert_eq!(xs, ys, "same seed, same stream");
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        // Sample s.d. of 20 Koren & Masory (1981) draws: within 3% of σ (its standard error is 0.5%).
        assert!((sd - 0.05).abs() < 0.0015, "sd {sd}");
        assert!(mean.abs() < 0.002, "mean {mean}");
    }
}
