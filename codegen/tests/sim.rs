//! End-to-end tests of `qloop sim` and `qloop sweep`: the controller compiled at run time from
//! the spec must behave bit for bit like the same spec compiled by `controller!` into
//! `qloop-verified`, and bad requests must fail with a clear message, never a panic.

use crate::common::{qloop, spec, text};
use qloop_plant::turning::{scenario_named, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, RunConfig};
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("qloop-{name}-{}", std::process::id()))
}

/// Parses a CSV written by `qloop sim`.
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let s = std::fs::read_to_string(path).expect("trace.csv");
    let mut lines = s.lines();
    let cols = lines
        .next()
        .expect("header")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    (cols, rows)
}

#[test]
fn sim_runs_the_compiled_routine_bit_for_bit() {
    let dir = tmp("sim");
    let o = qloop(&[
        "sim",
        &spec("koren_masory_1981.qloop"),
        "--plant",
        "turning",
        "--scenario",
        "depth-steps",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("verdict: fixed-point loop stable"), "{out}");

    let (cols, rows) = csv(&dir.join("trace.csv"));
    for c in [
        "t", "a_mm", "n_rpm", "force_n", "fc", "km", "kc", "u", "feed", "km_ref", "kc_ref",
        "feed_ref",
    ] {
        assert!(cols.iter().any(|x| x == c), "column {c} missing: {cols:?}");
    }
    // The same spec compiled by the proc-macro, run by the library: identical trace. (The CSV
    // prints shortest round-trip floats, so parsing gives back the exact values.)
    let sc = scenario_named("depth-steps").unwrap();
    let lib = run(
        &Turning::new(TurningParams::default()),
        fixed_controller!(qloop_verified::koren_masory_1981),
        reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
        &sc,
        RunConfig::default(),
    )
    .unwrap();
    assert_eq!(cols, lib.columns);
    assert_eq!(rows.len(), lib.rows.len());
    for (k, (a, b)) in rows.iter().zip(&lib.rows).enumerate() {
        assert_eq!(a, b, "row {k} differs");
    }

    let svg =
        std::fs::read_to_string(dir.join("koren_masory_1981-turning-depth-steps.svg")).unwrap();
    for panel in [
        "fc (kN)",
        "feed (mm/s)",
        "km (kN/(mm/s))",
        "kc ((mm/s)/kN)",
        "a_mm",
    ] {
        assert!(svg.contains(panel), "panel {panel} missing");
    }
    let png = std::fs::read(dir.join("koren_masory_1981-turning-depth-steps.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert!(dir.join("summary.txt").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sim_rejects_a_plant_whose_units_do_not_match() {
    let dir = tmp("sim-units");
    let o = qloop(&[
        "sim",
        &spec("koren_masory_1981.qloop"),
        "--plant",
        "grinding",
        "--scenario",
        "force-step",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // The measurement converts (kN → N); the command cannot (mm/s is not a position). The
    // error lists what the plant offers, and comes before the controller is compiled.
    assert!(
        err.contains("takes its position command in mm (length)")
            && err.contains("first output `feed` is in \"mm/s\" (velocity)")
            && err.contains("plant `grinding`")
            && err.contains("eta_factor"),
        "{err}"
    );
    assert!(!err.contains("compiling the generated controller"), "{err}");
    assert!(!dir.exists(), "nothing is written on error");
}

#[test]
fn sim_names_the_known_plants_and_scenarios() {
    let o = qloop(&["sim", &spec("koren_masory_1981.qloop"), "--plant", "lathe"]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("unknown plant `lathe`") && err.contains("turning"),
        "{err}"
    );
    let o = qloop(&[
        "sim",
        &spec("koren_masory_1981.qloop"),
        "--scenario",
        "no-such",
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("depth-ramp"), "{err}");
}

#[test]
fn scenario_files_report_their_errors_with_a_position() {
    let dir = tmp("sim-toml");
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.toml");
    std::fs::write(&f, "name = \"x\"\nduration_s = \"long\"\n").unwrap();
    let o = qloop(&[
        "sim",
        &spec("koren_masory_1981.qloop"),
        "--scenario",
        f.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("bad.toml") && err.contains("line 2"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn sweep_reports_worst_cases_and_replays_a_seed() {
    let o = qloop(&[
        "sweep",
        &spec("koren_masory_1981.qloop"),
        "--plant",
        "turning",
        "--draws",
        "40",
        "--seed",
        "3",
    ]);
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(out.contains("40 draws"), "{out}");
    // The worst steady-state error row names its seed; replaying it gives that value again.
    let row = out
        .lines()
        .find(|l| l.starts_with("| steady-state error, abs"))
        .unwrap_or_else(|| panic!("no steady-state row: {out}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let (worst, seed, scenario) = (cells[2], cells[3], cells[4]);
    let dir = tmp("replay");
    let o = qloop(&[
        "sweep",
        &spec("koren_masory_1981.qloop"),
        "--plant",
        "turning",
        "--replay",
        seed,
        "--out",
        dir.to_str().unwrap(),
    ]);
    let rep = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(rep.contains(&format!("scenario {scenario}")), "{rep}");
    // The replayed run's largest |ss error| over cutting segments, from its summary table.
    let replayed = rep
        .lines()
        .filter(|l| l.contains("| fixed | yes |"))
        .map(|l| {
            let c: Vec<&str> = l.split('|').map(str::trim).collect();
            c[4].parse::<f64>().unwrap().abs()
        })
        .fold(0.0, f64::max);
    assert_eq!(format!("{replayed:.4}"), worst, "{rep}");
    assert!(dir.join("trace.csv").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The estimating seed specs of issue 16 run in `sweep` on their plants: the GAC once a part on
/// the finishing plant, the adaptive pole-zero cancellation on the grinding plant; every draw
/// stable in both loops, and a dimensionless state (the covariance) reported without a unit.
#[test]
fn sweep_runs_the_estimating_specs_on_their_plants() {
    for (spec_file, plant, draws) in [
        ("gac_surface_finish.qloop", "finishing", "12"),
        ("grinding_adaptive_pzc.qloop", "grinding", "8"),
    ] {
        let o = qloop(&[
            "sweep",
            &spec(spec_file),
            "--plant",
            plant,
            "--draws",
            draws,
        ]);
        let out = text(&o.stdout);
        assert_eq!(o.status.code(), Some(0), "{spec_file}: {}", text(&o.stderr));
        assert!(out.contains(&format!("{draws} draws")), "{out}");
        assert!(
            out.contains(&format!(
                "fixed-point {draws}/{draws}, f64 reference {draws}/{draws}"
            )),
            "{spec_file}: not every draw stable:\n{out}"
        );
        assert!(!out.contains("max abs ()"), "{out}");
    }
}
