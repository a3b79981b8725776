//! A new user's first day (issue 15): three controllers of the kind a CNC-retrofit engineer
//! writes (`tests/fixtures/first_day`: a PI feed override in percent with overload and
//! air-cut rules, a feed hold on overload with a floor and a counter, a filtered,
//! speed-scheduled minimum of a force and a power proposal) each go through `check`, `gen`
//! (Rust, C, LinuxCNC), `prove`, `sim` and `bench`, with the binary, as the user ran them.

use crate::common::{qloop, text};
use std::path::{Path, PathBuf};
use test_tools::{find, skip};

const SPECS: [&str; 3] = ["pi_override", "feed_hold", "lpf_schedule"];

fn spec(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/first_day")
        .join(format!("{name}.qloop"))
        .display()
        .to_string()
}

fn out_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("first-day")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn ok(args: &[&str]) -> String {
    let o = qloop(args);
    let out = text(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "qloop {}:\n{out}\n{}",
        args.join(" "),
        text(&o.stderr)
    );
    out
}

#[test]
fn check_warns_only_where_the_target_pays_for_it() {
    for name in SPECS {
        let out = ok(&["check", &spec(name), "--target", "atmega328p"]);
        let wide = out.contains("needs 64-bit arithmetic");
        // The power estimate ff·n·VC keeps 58 fraction bits: 64-bit on AVR, said so, with the
        // line and the `let`; the other two stay within 32 bits.
        assert_eq!(wide, name == "lpf_schedule", "{name}:\n{out}");
        if wide {
            assert!(
                out.contains("line 42") && out.contains("`p` Q(i64"),
                "{out}"
            );
        }
        // Units are shown for lets.
        if name == "pi_override" {
            assert!(
                out.lines().any(|l| l.starts_with("e ") && l.contains("kN")),
                "{out}"
            );
        }
    }
}

#[test]
fn gen_writes_rust_c_and_linuxcnc() {
    for name in SPECS {
        let dir = out_dir(&format!("gen-{name}"));
        let d = dir.to_str().unwrap();
        std::fs::create_dir_all(&dir).unwrap();
        let rs = dir.join(format!("{name}.rs"));
        ok(&[
            "gen",
            &spec(name),
            "--lang",
            "rust",
            "-o",
            rs.to_str().unwrap(),
        ]);
        for lang in ["c", "linuxcnc"] {
            ok(&["gen", &spec(name), "--lang", lang, "--out", d]);
        }
        let files: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        for want in [
            format!("{name}.rs"),
            format!("{name}.c"),
            format!("qloop_{name}.comp"),
        ] {
            assert!(files.contains(&want), "{name}: {want} not in {files:?}");
        }
    }
    // The override drives LinuxCNC's adaptive feed as an override: 100 % is 1.
    let comp =
        std::fs::read_to_string(out_dir_keep("gen-pi_override").join("qloop_pi_override.comp"))
            .unwrap();
    assert!(
        comp.contains("adaptive-feed\\\\fR = ovr * 0.01") && comp.contains("1 at 100 %"),
        "{comp}"
    );
}

fn out_dir_keep(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("first-day")
        .join(name)
}

#[test]
fn prove_proves_every_property() {
    if find("z3").is_none() && find("cvc5").is_none() {
        skip("no SMT solver (z3, cvc5)");
        return;
    }
    for name in SPECS {
        let out = ok(&["prove", &spec(name), "--no-cache", "--timeout", "600"]);
        assert!(out.contains(" 0 refuted, 0 unknown"), "{name}:\n{out}");
        assert!(out.contains("solver time: "), "{out}");
    }
}

#[test]
fn sim_runs_each_on_the_turning_plant_with_its_own_reference() {
    for (name, fr) in [
        ("pi_override", "1.25 kN"),
        ("feed_hold", "1.5 kN"),
        ("lpf_schedule", "1.5 kN"),
    ] {
        let dir = out_dir(&format!("sim-{name}"));
        let out = ok(&[
            "sim",
            &spec(name),
            "--out",
            dir.to_str().unwrap(),
            "--check",
        ]);
        assert!(
            out.contains(&format!(
                "reference: the spec's #[reference] param FR = {fr}"
            )),
            "{name}:\n{out}"
        );
        assert!(out.contains("fixed-point loop stable"), "{out}");
    }
}

#[test]
fn bench_runs_each_on_the_avr() {
    if find("avr-gcc").is_none() || !Path::new("/usr/include/simavr/sim_avr.h").is_file() {
        skip("missing avr-gcc or libsimavr-dev");
        return;
    }
    for name in SPECS {
        let out = ok(&[
            "bench",
            &spec(name),
            "--target",
            "atmega328p",
            "--steps",
            "200",
        ]);
        assert!(
            out.contains("inputs: every variant gets the same scripted sequence"),
            "{out}"
        );
        assert!(
            out.contains("plain_mul == qloop: identical raw outputs on all 200 steps"),
            "{name}:\n{out}"
        );
    }
}
