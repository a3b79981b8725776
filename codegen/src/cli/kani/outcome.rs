//! Reading Kani's output: the harness list (`cargo kani list --format json`) and one harness's
//! verdict from `--output-format terse` (Kani 0.67).

use std::fmt;

/// A harness's verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// `VERIFICATION:- SUCCESSFUL`.
    Successful,
    /// `VERIFICATION:- FAILED` with failed checks.
    Failed,
    /// CBMC stopped at the time limit ("CBMC timed out"), or the backstop killed the run.
    Timeout,
    /// No verdict: the harness did not compile or Kani stopped for another reason.
    Error,
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Verdict::Successful => "SUCCESSFUL",
            Verdict::Failed => "FAILED",
            Verdict::Timeout => "TIMEOUT",
            Verdict::Error => "ERROR",
        })
    }
}

/// What one `cargo kani --harness H` run reported.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The verdict.
    pub verdict: Verdict,
    /// `(failed, total)` from "** F of T failed".
    pub checks: Option<(u32, u32)>,
    /// "Verification Time: Xs".
    pub verification_s: Option<f64>,
    /// The descriptions after "Failed Checks:" (the harnesses' literal assertion messages).
    pub failed_checks: Vec<String>,
    /// Why, for a timeout or an error (set by the runner).
    pub detail: Option<String>,
}

/// Reads one harness's terse output.
pub fn parse_outcome(stdout: &str) -> Outcome {
    let mut o = Outcome {
        verdict: Verdict::Error,
        checks: None,
        verification_s: None,
        failed_checks: Vec::new(),
        detail: None,
    };
    let mut timed_out = false;
    for line in stdout.lines() {
        let l = line.trim();
        if let Some(v) = l.strip_prefix("VERIFICATION:-") {
            o.verdict = match v.trim() {
                "SUCCESSFUL" => Verdict::Successful,
                "FAILED" => Verdict::Failed,
                _ => Verdict::Error,
            };
        } else if l.starts_with("CBMC timed out") {
            timed_out = true;
        } else if let Some(rest) = l.strip_prefix("** ") {
            // "** 1 of 459 failed (2 unreachable)"; the cover line says "satisfied".
            let w: Vec<&str> = rest.split_whitespace().collect();
            if let [f, "of", t, "failed", ..] = w.as_slice() {
                if let (Ok(f), Ok(t)) = (f.parse(), t.parse()) {
                    o.checks = Some((f, t));
                }
            }
        } else if let Some(c) = l.strip_prefix("Failed Checks:") {
            o.failed_checks.push(c.trim().to_string());
        } else if let Some(t) = l.strip_prefix("Verification Time:") {
            o.verification_s = t.trim().trim_end_matches('s').parse().ok();
        }
    }
    if timed_out {
        o.verdict = Verdict::Timeout;
    }
    o
}

/// The harness names of `cargo kani list --format json` (standard and contract harnesses).
pub fn parse_list(json: &str) -> Result<Vec<String>, String> {
    let v: serde_json::Value =
        serde_json::from_str(json).map_err(|e| format!("kani-list.json: {e}"))?;
    let mut names = Vec::new();
    for key in ["standard-harnesses", "contract-harnesses"] {
        let Some(files) = v.get(key).and_then(|f| f.as_object()) else {
            return Err(format!("kani-list.json: no `{key}` object"));
        };
        for hs in files.values() {
            for h in hs.as_array().into_iter().flatten() {
                if let Some(s) = h.as_str() {
                    names.push(s.to_string());
                }
            }
        }
    }
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Kani 0.67 terse output of a failing harness, as printed.
    const FAILED: &str = "Checking harness m::property_p...\n\nVERIFICATION RESULT:\n \
        ** 1 of 459 failed (2 unreachable)\n\n ** 2 of 2 cover properties satisfied\n\n\
        Failed Checks: property `p`: `x <= 1` is false after the step\n \
        File: \"src/lib.rs\", line 3, in m::property_p::{closure#0}\n\n\
        VERIFICATION:- FAILED\nVerification Time: 6.5846124s\n";

    #[test]
    fn reads_a_failure_with_its_named_check() {
        let o = parse_outcome(FAILED);
        assert_eq!(o.verdict, Verdict::Failed);
        assert_eq!(o.checks, Some((1, 459)));
        assert_eq!(o.verification_s, Some(6.5846124));
        assert_eq!(
            o.failed_checks,
            ["property `p`: `x <= 1` is false after the step"]
        );
    }

    #[test]
    fn reads_success_timeout_and_nothing() {
        let ok = "VERIFICATION RESULT:\n ** 0 of 90 failed\n\nVERIFICATION:- SUCCESSFUL\n\
                  Verification Time: 0.12s\n";
        let o = parse_outcome(ok);
        assert_eq!((o.verdict, o.checks), (Verdict::Successful, Some((0, 90))));
        let to = "CBMC failed\nVERIFICATION:- FAILED\nCBMC timed out. You may want to rerun \
                  your proof with a larger timeout or use stubbing.\n";
        assert_eq!(parse_outcome(to).verdict, Verdict::Timeout);
        assert_eq!(parse_outcome("error[E0425]: ...\n").verdict, Verdict::Error);
    }

    #[test]
    fn lists_standard_and_contract_harnesses() {
        let j = r#"{"kani-version":"0.67.0","standard-harnesses":{"src/lib.rs":["a::x","a::y"]},
                    "contract-harnesses":{"src/lib.rs":["a::c"]},"contracts":[]}"#;
        assert_eq!(parse_list(j).unwrap(), ["a::x", "a::y", "a::c"]);
        assert!(parse_list("{}").is_err());
    }
}
