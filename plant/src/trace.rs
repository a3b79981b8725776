//! Recorded traces: named columns sampled once per controller period.

use std::fmt::Write;

/// A trace: column names and rows.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    /// Column names (`t`, plant columns with units, controller signals by spec name, and
    /// `NAME_ref` for the f64 reference loop).
    pub columns: Vec<String>,
    /// One row per sample.
    pub rows: Vec<Vec<f64>>,
}

impl Trace {
    /// The column named `name`.
    pub fn col(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[i]).collect())
    }

    /// |fixed − f64| of the controller signal `name` per sample: the column `name` against
    /// `name_ref` (see [`crate::run`]).
    pub fn fixed_vs_ref(&self, name: &str) -> Option<Vec<f64>> {
        let (a, b) = (self.col(name)?, self.col(&format!("{name}_ref"))?);
        Some(a.iter().zip(&b).map(|(x, y)| (x - y).abs()).collect())
    }

    /// CSV text (header line, then one line per row; shortest round-trip floats).
    pub fn to_csv(&self) -> String {
        let mut s = self.columns.join(",");
        s.push('\n');
        for r in &self.rows {
            for (i, v) in r.iter().enumerate() {
                if i > 0 {
                    s.push(',');
                }
                let _ = write!(s, "{v}");
            }
            s.push('\n');
        }
        s
    }
}
