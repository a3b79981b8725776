//! Ivester & Danai's Table 2, "Summary of RCB₂ test results": one run with c = 0.5 on both constraints,
//! printed beside qloop's runs. The columns g_m1 and g_m2 are positive (3.85 and 1.87 at cycle
//! 1, against constraint values −2.15 and −2.13 in the text), so they are read as the measured
//! power (kW) and roughness (µm), with limits 6 and 4.

/// One row of Ivester & Danai's Table 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Cycle.
    pub cycle: usize,
    /// Cutting speed v.
    pub v: f64,
    /// Feed f.
    pub f: f64,
    /// g_m1, read as measured power (kW).
    pub power: f64,
    /// g_m2, read as measured roughness (µm).
    pub roughness: f64,
    /// Cycle time (s).
    pub time: f64,
}

const fn row(cycle: usize, v: f64, f: f64, power: f64, roughness: f64, time: f64) -> Row {
    Row {
        cycle,
        v,
        f,
        power,
        roughness,
        time,
    }
}

/// Ivester & Danai, Table 2, as printed.
pub const TABLE2: [Row; 10] = [
    row(1, 70.00, 0.100, 3.85, 1.87, 138.0),
    row(2, 88.64, 0.205, 5.28, 2.84, 108.8),
    row(3, 93.85, 0.258, 5.15, 3.17, 102.2),
    row(4, 95.78, 0.280, 4.70, 3.37, 98.5),
    row(5, 98.11, 0.290, 4.95, 3.01, 96.4),
    row(6, 98.18, 0.301, 5.38, 3.75, 95.6),
    row(7, 97.61, 0.303, 5.72, 3.37, 95.6),
    row(8, 98.83, 0.309, 4.85, 3.52, 95.6),
    row(9, 99.12, 0.310, 4.90, 3.53, 95.6),
    row(10, 99.35, 0.311, 5.65, 3.43, 95.6),
];
