//! `qloop sim` against the plant contract (issue 15): the reference comes from the spec, a
//! percent override reaches the plant as a feed, further inputs read the plant's channels,
//! `--check` fails on an unstable loop, and a spec the plant cannot run is refused before
//! anything is compiled, with the contract in the message.

use crate::common::{qloop, text};
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("qloop-{name}-{}", std::process::id()))
}

fn first_day(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/fixtures/first_day")
        .join(name)
        .display()
        .to_string()
}

/// A trace column by name.
fn column(dir: &Path, name: &str) -> Vec<f64> {
    let s = std::fs::read_to_string(dir.join("trace.csv")).expect("trace.csv");
    let mut lines = s.lines();
    let cols: Vec<&str> = lines.next().expect("header").split(',').collect();
    let i = cols
        .iter()
        .position(|c| *c == name)
        .unwrap_or_else(|| panic!("no column {name}: {cols:?}"));
    lines
        .map(|l| l.split(',').nth(i).unwrap().parse().unwrap())
        .collect()
}

/// The mean of trace column `name` over `from <= t < to`.
fn mean_between(dir: &Path, name: &str, from: f64, to: f64) -> f64 {
    let v: Vec<f64> = column(dir, "t")
        .iter()
        .zip(column(dir, name))
        .filter(|(t, _)| **t >= from && **t < to)
        .map(|(_, x)| x)
        .collect();
    assert!(!v.is_empty(), "no rows of {name} in [{from}, {to})");
    v.iter().sum::<f64>() / v.len() as f64
}

fn sim(spec: &str, dir: &Path, extra: &[&str]) -> (Option<i32>, String, String) {
    let mut args = vec!["sim", spec, "--out", dir.to_str().unwrap()];
    args.extend(extra);
    let o = qloop(&args);
    (o.status.code(), text(&o.stdout), text(&o.stderr))
}

/// The PI override spec holds FR = 1.25 kN (not the plant's 1.5): the summary's steady-state
/// errors are against 1.25, checked against the trace itself (the mean force over each
/// segment's last 20 %), and the override reaches the plant as ovr/100 · 2 mm/s.
#[test]
fn sim_measures_against_the_specs_reference_and_runs_a_percent_override() {
    let dir = tmp("sim-override");
    let (code, out, err) = sim(&first_day("pi_override.qloop"), &dir, &["--check"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("reference: the spec's #[reference] param FR = 1.25 kN"),
        "{out}"
    );
    assert!(
        out.contains("is a feed override; 1 (= 100 %) is the nominal feed 2 mm/s"),
        "{out}"
    );
    // Independent of the metrics code: the settled force over the last 20 % of each cutting
    // segment (depth steps at 1, 16, 31 s; 46 s long) is the spec's reference.
    for (a, b) in [(1.0, 16.0), (16.0, 31.0), (31.0, 46.0)] {
        let mean = mean_between(&dir, "fc", b - 0.2 * (b - a), b);
        assert!(
            (mean - 1.25).abs() < 0.01,
            "segment {a}-{b}: mean force {mean}"
        );
        // The summary's error for this segment is that mean minus 1.25.
        let row = out
            .lines()
            .find(|l| l.starts_with(&format!("| {a:.1}–{b:.1} | fixed | yes")))
            .unwrap_or_else(|| panic!("no row for {a}: {out}"));
        let ss: f64 = row.split('|').nth(4).unwrap().trim().parse().unwrap();
        assert!((ss - (mean - 1.25)).abs() < 2e-3, "{row}: mean {mean}");
    }
    // The plant's applied command is the override times 2 mm/s / 100 %, two samples later
    // (one period of transport delay, applied at the first substep after the next sample).
    let (ovr, cmd) = (column(&dir, "ovr"), column(&dir, "feed_cmd_mm_s"));
    for k in 2..ovr.len() {
        assert!(
            (cmd[k] - ovr[k - 2] * 0.02).abs() <= 1e-12,
            "row {k}: command {} for override {}",
            cmd[k],
            ovr[k - 2]
        );
    }
}

/// The spec's second input `n_rpm` reads the plant's channel of that name; the spindle-speed
/// drop scenario changes it, and the filtered, scheduled loop follows.
#[test]
fn a_further_input_reads_the_plants_channel() {
    let dir = tmp("sim-channel");
    let (code, out, err) = sim(
        &first_day("lpf_schedule.qloop"),
        &dir,
        &["--scenario", "speed-drop", "--check"],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    // The plant records the channel as `n_rpm`; the controller's input of the same name is
    // recorded as `n_rpm_ctl`.
    let (n_in, n_plant) = (column(&dir, "n_rpm_ctl"), column(&dir, "n_rpm"));
    assert_eq!(n_in, n_plant);
    assert!(n_in.contains(&500.0) && n_in.contains(&300.0), "{n_in:?}");
}

/// A spec in newtons on the turning plant (which measures kN): the measurement is converted
/// to N for the controller, and the reference and the metrics are in N too (the force settles
/// at 1250 N, not at 1.25).
#[test]
fn a_spec_in_other_units_is_converted_and_measured_in_its_own() {
    let spec = tmp("newtons.qloop");
    std::fs::write(
        &spec,
        "controller in_newtons {\n    period 0.1 \"s\";\n    input fc: [0.0, 5000.0] \"N\";\n    \
         #[reference]\n    param FR: 1250.0 \"N\";\n    const KC: 0.00025 \"(mm/s)/N\";\n    \
         state u: [0.05, 5.0] \"mm/s\" = 0.5;\n    output feed \"mm/s\";\n    \
         step { u += KC * (FR - fc); feed = u; }\n}\n",
    )
    .unwrap();
    let dir = tmp("sim-newtons");
    let (code, out, err) = sim(spec.to_str().unwrap(), &dir, &["--check"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("reference: the spec's #[reference] param FR = 1250 N")
            && out.contains("the plant's kN is converted to the spec's N (×1000)"),
        "{out}"
    );
    let mean = mean_between(&dir, "fc", 13.0, 16.0);
    assert!((mean - 1250.0).abs() < 10.0, "mean force {mean} N");
    let row = out
        .lines()
        .find(|l| l.starts_with("| 1.0–16.0 | fixed | yes"))
        .unwrap_or_else(|| panic!("{out}"));
    let ss: f64 = row.split('|').nth(4).unwrap().trim().parse().unwrap();
    assert!((ss - (mean - 1250.0)).abs() < 2.0, "{row}: mean {mean}");
}

/// `--check` turns an unstable loop into exit status 1; without it the run reports UNSTABLE
/// and succeeds. The fixed gain 1 (mm/s)/kN gives K = 3.8 at 6 mm, far past the plant's 1.35.
#[test]
fn sim_check_fails_an_unstable_loop() {
    let spec = tmp("unstable.qloop");
    std::fs::write(
        &spec,
        "controller unstable {\n    period 0.1 \"s\";\n    input fc: [0.0, 5.0] \"kN\";\n    \
         param FR: 1.5 \"kN\";\n    const KC: 1.0 \"(mm/s)/kN\";\n    \
         state u: [0.05, 5.0] \"mm/s\" = 0.5;\n    output feed \"mm/s\";\n    \
         step { u += KC * (FR - fc); feed = u; }\n}\n",
    )
    .unwrap();
    let spec = spec.to_str().unwrap();
    let (code, out, err) = sim(spec, &tmp("sim-unstable"), &["--check"]);
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(
        out.contains("UNSTABLE") && err.contains("sim --check"),
        "{out}{err}"
    );
    let (code, out, _) = sim(spec, &tmp("sim-unstable2"), &[]);
    assert_eq!(code, Some(0), "{out}");
}

/// Specs the plant cannot run: refused before compiling, naming what the plant offers.
#[test]
fn specs_the_plant_cannot_run_are_refused_with_its_contract() {
    let cases = [
        // An input that is no channel: the error lists the plant's channels.
        (
            "input fc: [0.0, 5.0] \"kN\"; input depth: [0.0, 8.0] \"mm\"; output feed: [0.0, 5.0] \"mm/s\";",
            "feed = 1.0;",
            "channels: a_mm, n_rpm, fr",
        ),
        // An override without a nominal feed.
        (
            "input fc: [0.0, 5.0] \"kN\"; output ovr: [10.0, 200.0] \"%\";",
            "ovr = 100.0;",
            "--nominal-feed",
        ),
        // A measurement of the wrong dimension.
        (
            "input p: [0.0, 5.0] \"kW\"; output feed: [0.0, 5.0] \"mm/s\";",
            "feed = 1.0;",
            "measures force in kN (force), but the spec's first input `p` is in \"kW\" (power)",
        ),
        // A channel input in the wrong unit.
        (
            "input fc: [0.0, 5.0] \"kN\"; input n_rpm: [0.0, 50.0] \"Hz\"; output feed: [0.0, 5.0] \"mm/s\";",
            "feed = 1.0;",
            "the channel `n_rpm` is in rpm",
        ),
    ];
    for (i, (decls, body, want)) in cases.iter().enumerate() {
        let spec = tmp(&format!("contract-{i}.qloop"));
        std::fs::write(
            &spec,
            format!("controller c{i} {{\n    period 0.1 \"s\";\n    {decls}\n    step {{ {body} }}\n}}\n"),
        )
        .unwrap();
        let (code, out, err) = sim(spec.to_str().unwrap(), &tmp("contract-out"), &[]);
        assert_eq!(code, Some(2), "{out}{err}");
        assert!(err.contains(want), "case {i}: `{want}` not in {err}");
        assert!(err.contains("plant `turning`"), "{err}");
        assert!(!err.contains("compiling the generated"), "{err}");
    }
}

/// `qloop plants` prints every plant's contract: units, channels, reference, scenarios, and the
/// fault scenarios `--scenario` accepts (the turning plant's six).
#[test]
fn plants_prints_the_contracts() {
    let o = qloop(&["plants"]);
    let out = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0));
    for want in [
        "plant `turning`",
        "measures  force in kN",
        "command   feed in mm/s",
        "n_rpm       rpm",
        "plant `grinding`",
        "position in mm",
        "scenarios: depth-steps",
        "fault scenarios (sensor and process faults; not in a sweep's default set): adc-saturation (30 s), stuck-sensor",
    ] {
        assert!(out.contains(want), "`{want}` not in {out}");
    }
    let o = qloop(&["plants", "lathe"]);
    assert_eq!(o.status.code(), Some(2));
}
