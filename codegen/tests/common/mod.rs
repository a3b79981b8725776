//! Helpers shared by the CLI integration tests: run the `qloop` binary, name a seed spec, read
//! its output.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `qloop` binary built for this test.
pub fn qloop(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_qloop"))
        .args(args)
        .output()
        .expect("run qloop")
}

/// The path of a seed spec in `verified/specs`.
pub fn spec(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../verified/specs")
        .join(name)
        .display()
        .to_string()
}

/// The stems of every seed spec in `verified/specs`, sorted.
pub fn seed_stems() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../verified/specs");
    let mut v: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "qloop"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Process output as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}
