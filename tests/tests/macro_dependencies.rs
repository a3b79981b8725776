//! The `controller!` macro builds the compiler core and nothing of the prover: no solver
//! runner, serialisation, hashing or TOML in `cargo tree -p qloop-macros` (issue 13). A
//! firmware crate that uses the macro compiles only what expansion needs. Big rationals
//! (`num-bigint`, `num-rational`) are part of that since issue 35: a table's samples are
//! computed in exact arithmetic (`check::enclose`), in the macro as in the CLI.

use std::process::Command;

#[test]
fn the_macro_depends_on_the_core_alone() {
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "-p",
            "qloop-macros",
            "-e",
            "normal,build",
            "--prefix",
            "none",
        ])
        .args(["--offline", "--locked"])
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .output()
        .expect("run cargo tree");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let crates: Vec<&str> = text
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(crates.contains(&"qloop-core"), "{text}");
    for banned in [
        "qloop",
        "serde",
        "serde_json",
        "sha2",
        "toml",
        "clap",
        "miette",
        "rayon",
    ] {
        assert!(
            !crates.contains(&banned),
            "qloop-macros pulls in {banned}:\n{text}"
        );
    }
}
