//! Helpers shared by the workspace integration tests.

use qloop::ir::SigId;
use qloop::{Plan, Target};
use std::path::PathBuf;

/// `verified/specs`.
pub fn specs_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../verified/specs")
}

/// Every seed spec, as (file stem, source text), sorted by name.
pub fn all_specs() -> Vec<(String, String)> {
    let mut v: Vec<_> = std::fs::read_dir(specs_dir())
        .expect("verified/specs")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "qloop"))
        .map(|p| {
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            (stem, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    v.sort();
    v
}

/// The compiled plan of a seed spec, for the default target.
pub fn plan(stem: &str) -> Plan {
    let src = std::fs::read_to_string(specs_dir().join(format!("{stem}.qloop"))).unwrap();
    qloop::compile_str(&src, &Target::default()).unwrap_or_else(|e| panic!("{stem}: {e}"))
}

/// The id of the signal called `name`.
pub fn sig(plan: &Plan, name: &str) -> SigId {
    SigId(
        plan.prog
            .signals
            .iter()
            .position(|s| s.name == name)
            .unwrap_or_else(|| panic!("no signal {name}")),
    )
}
