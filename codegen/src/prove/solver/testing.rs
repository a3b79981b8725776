//! Scripts and settings shared by the solver modules' tests.

use super::{Config, Query, Solver};
use std::fs;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// x + y = 16, x < 5, y = 14: the only model is x = 2, y = 14.
pub(super) const SAT_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun x () (_ BitVec 8))
(declare-fun y () (_ BitVec 8))
(assert (= (bvadd x y) #x10))
(assert (bvult x #x05))
(assert (= y #x0e))";

/// 2x is never odd.
pub(super) const UNSAT_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun x () (_ BitVec 8))
(assert (= ((_ extract 0 0) (bvmul x #x02)) #b1))";

/// Factoring 3301746797 * 3356063771 (both prime): far beyond a few hundred milliseconds.
pub(super) const HARD_SCRIPT: &str = "(set-logic QF_BV)
(declare-fun p () (_ BitVec 32))
(declare-fun q () (_ BitVec 32))
(assert (= (bvmul ((_ zero_extend 32) p) ((_ zero_extend 32) q)) #x99c72b1bc45ddb7f))
(assert (bvugt p #x00000001))
(assert (bvugt q #x00000001))";

pub(super) fn query(script: &str, want: &[&str]) -> Query {
    Query {
        script: script.to_string(),
        want: want.iter().map(|s| s.to_string()).collect(),
    }
}

pub(super) fn both(timeout_ms: u64) -> Config {
    for s in Solver::ALL {
        assert!(
            s.available(),
            "{} must be installed for these tests",
            s.name()
        );
    }
    Config {
        solvers: Solver::ALL.to_vec(),
        timeout_ms,
        cache_dir: None,
        jobs: 4,
        deadline: None,
    }
}

pub(super) fn want(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

/// A fresh, empty directory under the system temp dir.
pub(super) fn temp_dir(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "qloop-solver-test-{tag}-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&dir);
    dir
}
