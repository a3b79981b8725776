//! Rubio & De la Sen's claim for its multi-model controller (Rubio & De la Sen, Rubio & De la Sen,
//! Sec. V): switching among estimators of seven β-FROH discretisations "reduces the large
//! overshoots" that a ZOH-only design shows after steps in the depth of cut. Three
//! *compiled* controllers run on the milling plant (Rubio & De la Sen, eqs. 1-3) through the depth profile of
//! Rubio & De la Sen, Fig. 1 (b = 3 → 5 → 3 → 2 mm at F_r = 1.2 kN, T = 0.0839 s), each beside the f64
//! reference compiled from the same spec:
//!
//! * `verified/specs/milling_multimodel.qloop` (`qloop_verified::milling_multimodel`): the full design (seven RLS estimators, seven
//!   pole-placement laws, the supervisor with N_R = 2), its active β driving the hold;
//! * `tests/milling_zoh.qloop`: the ZOH-only design (β = 0, one estimator, one law): model 0
//!   of the full design on its own, under a zero-order hold;
//! * `verified/specs/milling_acc.qloop`: the Koren & Masory (1981) law retuned for milling.
//!
//! Metrics per segment (`qloop_plant::metrics`): overshoot (largest excess of the measured
//! force over F_r, as a fraction of it), 5 % settling time and steady-state error. At a
//! deepening step the force jumps with the depth before any controller can act (Rubio & De la Sen, eq. 3:
//! F = K_p·f with K_p ∝ b), so after 3 → 5 mm every design starts from at least 5/3 − 1 = 67 %;
//! after a shallowing step (5 → 3, 3 → 2 mm) the force falls, and any overshoot is the
//! controller's own.
//!
//! `QLOOP_FIGURES=DIR` writes the figure (force, active β, feed, depth) and the summary
//! table to `DIR/milling-multimodel-comparison.{png,svg,txt}`; `docs/book/src/figures/regenerate.sh`
//! does so for `docs/book/src/figures`, and CI checks that the committed summary still matches.

use qloop_plant::milling::{scenario_named, Milling, MillingParams, FIG1_PROFILE};
use qloop_plant::plot::{self, write_png, write_svg, Figure, Line, Panel, Series};
use qloop_plant::{
    fixed_controller, metrics, reference_controller, run, Controller, Metrics, RunConfig, Scenario,
    Trace,
};
use std::fmt::Write;
use std::sync::OnceLock;

use qloop_verified::{milling_multimodel, milling_multimodel_ref};
qloop_macros::controller!("tests/milling_zoh.qloop");
qloop_macros::controller!("tests/milling_zoh.qloop", reference);

/// F_r (Rubio & De la Sen, Sec. V), kN.
const FR: f64 = 1.2;
/// T (Rubio & De la Sen, Sec. V), s.
const PERIOD: f64 = 0.0839;

/// One design's closed-loop run.
struct Design {
    name: &'static str,
    trace: Trace,
    metrics: Metrics,
}

fn scenario() -> Scenario {
    scenario_named("depth-profile").expect("Rubio & De la Sen, Fig. 1 profile")
}

fn run_design(
    name: &'static str,
    fixed: Box<dyn Controller + Send>,
    reference: Box<dyn Controller + Send>,
) -> Design {
    let sc = scenario();
    let plant = Milling::new(MillingParams::default());
    let trace = run(&plant, fixed, reference, &sc, RunConfig::default()).expect("run");
    let metrics = metrics(
        &trace,
        "fc",
        &|_| FR,
        &sc.breakpoints(),
        sc.duration_s,
        &["feed"],
    );
    Design {
        name,
        trace,
        metrics,
    }
}

/// The three designs, run once for every test of this file.
fn designs() -> &'static [Design; 3] {
    static D: OnceLock<[Design; 3]> = OnceLock::new();
    D.get_or_init(|| {
        [
            run_design(
                "multi-model (switching)",
                fixed_controller!(milling_multimodel),
                reference_controller!(milling_multimodel_ref, PERIOD),
            ),
            run_design(
                "ZOH only",
                fixed_controller!(milling_zoh),
                reference_controller!(milling_zoh_ref, PERIOD),
            ),
            run_design(
                "milling_acc (1981 law)",
                fixed_controller!(qloop_verified::milling_acc),
                reference_controller!(qloop_verified::milling_acc_ref, PERIOD),
            ),
        ]
    })
}

/// The full design with its supervisor held on model `m` (its state set to `active = m,
/// since = 0` before every step, so that it never switches): the same estimators and laws,
/// one law in the loop under its own hold. Separates what switching does from what each
/// model's law does.
struct Held(milling_multimodel::Controller, u8);

impl Controller for Held {
    fn signals(&self) -> qloop_plant::Signals {
        qloop_plant::module_signals!(milling_multimodel)
    }
    fn period(&self) -> f64 {
        qloop_plant::controller::period_s(milling_multimodel::Controller::PERIOD_US)
    }
    fn step(&mut self, inputs: &[f64], outputs: &mut [f64]) {
        let mut s = self.0.states();
        s.active = fixed::traits::Fixed::from_num(self.1);
        s.since = fixed::traits::Fixed::from_num(0);
        self.0.set_states(s);
        let raw = [qloop_plant::controller::to_bits(
            inputs[0],
            milling_multimodel::INPUT_FRAC[0],
        )];
        let o = self.0.step_bits(raw);
        for ((y, r), f) in outputs
            .iter_mut()
            .zip(o)
            .zip(milling_multimodel::OUTPUT_FRAC)
        {
            *y = qloop_plant::controller::from_bits(r, f);
        }
    }
    fn states(&self, out: &mut [f64]) {
        for ((y, r), f) in out
            .iter_mut()
            .zip(self.0.state_bits())
            .zip(milling_multimodel::STATE_FRAC)
        {
            *y = qloop_plant::controller::from_bits(r, f);
        }
    }
}

/// The β of model `m` of the full design.
const BETAS: [f64; 7] = [0.0, -0.5, -0.3, 0.3, 0.5, 0.8, 1.0];

/// The full design held on each of its seven models in turn (see [`Held`]).
fn held() -> &'static [Design] {
    static D: OnceLock<Vec<Design>> = OnceLock::new();
    D.get_or_init(|| {
        (0..7u8)
            .map(|m| {
                let name: &'static str =
                    Box::leak(format!("held on β = {}", BETAS[m as usize]).into_boxed_str());
                run_design(
                    name,
                    Box::new(Held(milling_multimodel::Controller::new(), m)),
                    Box::new(Held(milling_multimodel::Controller::new(), m)),
                )
            })
            .collect()
    })
}

/// The per-segment table of every design, and the multi-model design's switching record.
fn summary() -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Rubio & De la Sen, Fig. 1 depth profile on the milling plant, F_r = {FR} kN, T = {PERIOD} s \
         (compiled fixed-point loops)"
    );
    let _ = writeln!(
        s,
        "{:<26} {:>8} {:>10} {:>12} {:>12} {:>10}",
        "design", "b (mm)", "overshoot", "settling (s)", "ss error (N)", "oscillates"
    );
    for d in designs().iter().chain(held()) {
        for (seg, (b, _)) in d.metrics.fixed.segments.iter().zip(FIG1_PROFILE) {
            let settling = seg
                .settling_s
                .map_or("never".to_string(), |t| format!("{t:.2}"));
            let _ = writeln!(
                s,
                "{:<26} {:>8} {:>9.0}% {:>12} {:>12.1} {:>10}",
                d.name,
                b,
                seg.overshoot * 100.0,
                settling,
                seg.ss_error * 1000.0,
                if seg.oscillating { "yes" } else { "no" }
            );
        }
    }
    let model = designs()[0].trace.col("model").expect("model column");
    let switches = model.windows(2).filter(|w| w[0] != w[1]).count();
    let _ = write!(
        s,
        "multi-model: {switches} switches; periods per model 0..6:"
    );
    for m in 0..7 {
        let n = model.iter().filter(|v| **v == m as f64).count();
        let _ = write!(s, " {n}");
    }
    s.push('\n');
    s
}

/// The overshoot after each depth step (segments 2 to 4) of a design.
fn overshoots_after_steps(d: &Design) -> Vec<f64> {
    d.metrics.fixed.segments[1..]
        .iter()
        .map(|s| s.overshoot)
        .collect()
}

/// What the hold does on its own (the premise of Rubio & De la Sen's claim): the full design held on one
/// β > 0 model (never switching, its law in the loop under its own fractional-order hold)
/// settles in every segment, and after each shallowing step (5 → 3, 3 → 2 mm), where the
/// overshoot is the controller's alone, it overshoots less than the ZOH-only design. (After
/// the deepening step both start from the plant's own jump of 67 %; see the next test.)
#[test]
fn a_positive_beta_hold_reduces_the_overshoot_against_zoh_only() {
    eprintln!("{}", summary());
    let zoh = overshoots_after_steps(&designs()[1]);
    for d in &held()[3..] {
        let os = overshoots_after_steps(d);
        for s in &d.metrics.fixed.segments {
            assert!(
                s.settling_s.is_some() && !s.oscillating,
                "{}: does not settle in {:?}",
                d.name,
                s.span
            );
        }
        for k in [1, 2] {
            assert!(
                os[k] < zoh[k],
                "{}: overshoot {} after step {} not below ZOH only's {}",
                d.name,
                os[k],
                k + 1,
                zoh[k]
            );
        }
    }
}

/// Rubio & De la Sen's claim as built: does the *switching* design reduce the overshoot after the depth
/// steps against the ZOH-only design? Here it does not: its overshoot summed over the three
/// steps exceeds the ZOH-only one's (it is lower after one step only), and it fails to settle
/// in segments that the ZOH-only design settles. What the summary shows as the reason: the
/// supervisor ranks the models by their recent a-priori prediction errors (Rubio & De la Sen, Sec. IV.B),
/// and on this plant the models with the smallest errors are those with β < 0, whose laws do
/// not hold the loop (held on β = −0.5 or −0.3 the loop does not settle either), while every
/// β > 0 law does (the test above). Prediction error is not control performance: all seven
/// estimators see the data produced under the *active* hold, and the plant at T = 1/n is
/// first order in effect while the models are second and third order, so the best-fitting
/// model need not carry the best law (`plant/tests/multimodel_study.rs` shows the same for
/// the f64 oracle of the design). The test asserts the measured verdict, so that a change
/// of the design that changes it fails here and the book's account is revisited; nothing
/// was tuned to reach it.
#[test]
fn switching_on_prediction_error_does_not_reduce_the_overshoot() {
    eprintln!("{}", summary());
    let (mm, zoh) = (
        overshoots_after_steps(&designs()[0]),
        overshoots_after_steps(&designs()[1]),
    );
    let (sum_mm, sum_zoh) = (mm.iter().sum::<f64>(), zoh.iter().sum::<f64>());
    eprintln!("overshoot after the three steps: switching {mm:?} (sum {sum_mm:.2}), ZOH only {zoh:?} (sum {sum_zoh:.2})");
    assert!(
        sum_mm > sum_zoh,
        "switching now reduces the summed overshoot: revisit the verdict in docs/book/src/case-studies/rubio-de-la-sen.md"
    );
    let settled = |d: &Design| {
        d.metrics
            .fixed
            .segments
            .iter()
            .filter(|s| s.settling_s.is_some())
            .count()
    };
    assert!(settled(&designs()[0]) < settled(&designs()[1]));
    // The supervisor's choice: the β = −0.5 model (1) holds the loop longer than any other.
    let model = designs()[0].trace.col("model").unwrap();
    let periods = |m: f64| model.iter().filter(|v| **v == m).count();
    for m in [0.0, 2.0, 3.0, 4.0, 5.0, 6.0] {
        assert!(
            periods(1.0) > periods(m),
            "model {m}: {} periods against model 1's {}",
            periods(m),
            periods(1.0)
        );
    }
}

/// The plant's own share of the overshoot: right after the 3 → 5 mm step the force is the
/// pre-step force times 5/3 (Rubio & De la Sen, eq. 3, K_p ∝ b, feed unchanged within a period), for every
/// design: the overshoot measured after that step is at least what the pre-step force gives.
#[test]
fn the_deepening_step_overshoot_is_at_least_the_plants_jump() {
    let t_step = FIG1_PROFILE[0].1;
    for d in designs() {
        let (t, f) = (d.trace.col("t").unwrap(), d.trace.col("force_n").unwrap());
        let before = t.iter().rposition(|t| *t < t_step).expect("sample before");
        let jump = f[before] / 1000.0 * 5.0 / 3.0;
        let os = d.metrics.fixed.segments[1].overshoot;
        eprintln!(
            "{}: force before the step {:.3} kN, jump to {:.3} kN, overshoot {:.0} %",
            d.name,
            f[before] / 1000.0,
            jump,
            os * 100.0
        );
        // The metric reads the sensor (12-bit ADC, noise): allow one percent of F_r.
        assert!(
            (1.0 + os) * FR >= jump - 0.01 * FR,
            "{}: overshoot {os} below the plant's jump {jump} kN",
            d.name
        );
    }
}

/// A plant that also records the peak of its true output over the substeps of each period (the
/// continuous-time response between samples), as the column `peak_kn`.
struct Between {
    inner: Box<dyn qloop_plant::Plant>,
    peak: std::cell::Cell<f64>,
}

impl qloop_plant::Plant for Between {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn measured(&self) -> qloop_plant::Named {
        self.inner.measured()
    }
    fn command(&self) -> qloop_plant::Named {
        self.inner.command()
    }
    fn describe(&self) -> (&'static str, &'static str) {
        self.inner.describe()
    }
    fn channels(&self) -> Vec<qloop_plant::Channel> {
        self.inner.channels()
    }
    fn sensor(&self) -> qloop_plant::sensor::SensorParams {
        self.inner.sensor()
    }
    fn reference(&self, sc: &Scenario, t: f64) -> f64 {
        self.inner.reference(sc, t)
    }
    fn command_at(&mut self, t: f64, cmd: f64) {
        self.inner.command_at(t, cmd)
    }
    fn advance(&mut self, sc: &Scenario, t: f64, h: f64) {
        self.inner.advance(sc, t, h);
        let f = self.inner.output(sc, t + h);
        self.peak.set(self.peak.get().max(f));
    }
    fn output(&self, sc: &Scenario, t: f64) -> f64 {
        self.inner.output(sc, t)
    }
    fn columns(&self) -> Vec<&'static str> {
        let mut c = self.inner.columns();
        c.push("peak_kn");
        c
    }
    fn record(&self, sc: &Scenario, t: f64, out: &mut Vec<f64>) {
        self.inner.record(sc, t, out);
        // The peak since the last sample (the output now before the first period).
        let now = self.inner.output(sc, t);
        out.push(self.peak.replace(now).max(now));
    }
    fn fresh(&self) -> Box<dyn qloop_plant::Plant> {
        Box::new(Between {
            inner: self.inner.fresh(),
            peak: std::cell::Cell::new(f64::NEG_INFINITY),
        })
    }
    fn params(&self) -> Vec<qloop_plant::Param> {
        self.inner.params()
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), String> {
        self.inner.set_param(name, value)
    }
}

/// The largest force between samples over the first (3 mm) segment, over F_r, minus one.
fn startup_overshoot(c: Box<dyn Controller + Send>) -> f64 {
    let mut sc = scenario();
    sc.duration_s = FIG1_PROFILE[0].1;
    let plant = Between {
        inner: Box::new(Milling::new(MillingParams::default())),
        peak: std::cell::Cell::new(f64::NEG_INFINITY),
    };
    let tr = qloop_plant::run_single(&plant, c, &sc, RunConfig::default()).expect("run");
    let peak = tr
        .col("peak_kn")
        .unwrap()
        .into_iter()
        .fold(f64::MIN, f64::max);
    peak / FR - 1.0
}

/// The paper's own criterion (Sec. V, Figs. 4 and 6): the maximum overshoot of the
/// continuous-time force in the start-up transient, over several initial parameter vectors.
/// The paper claims that switching among the β-FROH models reduces it "in a broad range of
/// initial parameter vector". Here every estimator of both designs starts from the design's
/// initial estimate scaled by 0.5, 0.75, 1 and 1.5 (the laws and their models as designed), the
/// force is read between samples (the plant's 20 substeps a period), and the start-up segment
/// (3 mm, 5.87 s) is run. Measured: from the design's own estimate the two peaks are alike
/// (switching 96.8 % over F_r, ZOH only 98.0 %); from the other three the switching design's
/// peak is 1.5 to 3 times the ZOH-only one's (101-212 % against 67-100 %). The test asserts
/// that switching never lowers the start-up peak by more than 2 points of F_r and raises it
/// in sum: the paper's reduction does not reproduce from what it specifies (the book's case
/// study says what that leaves open).
#[test]
fn switching_does_not_reduce_the_startup_overshoot_over_initial_vectors() {
    let scale = |v: f64, s: f64| v * s;
    let mut rows = Vec::new();
    for s in [0.5, 0.75, 1.0, 1.5] {
        let mut full = milling_multimodel::Controller::new();
        let mut st = full.states();
        for x in st.thz.iter_mut() {
            *x = fixed::traits::Fixed::from_num(scale(x.to_num::<f64>(), s));
        }
        for row in st.thf.iter_mut() {
            for x in row.iter_mut() {
                *x = fixed::traits::Fixed::from_num(scale(x.to_num::<f64>(), s));
            }
        }
        full.set_states(st);
        let mut zoh = milling_zoh::Controller::new();
        let mut st = zoh.states();
        for x in st.thz.iter_mut() {
            *x = fixed::traits::Fixed::from_num(scale(x.to_num::<f64>(), s));
        }
        zoh.set_states(st);
        let mm = startup_overshoot(qloop_plant::fixed_controller!(milling_multimodel, full));
        let z = startup_overshoot(qloop_plant::fixed_controller!(milling_zoh, zoh));
        eprintln!(
            "initial estimate ×{s}: start-up overshoot between samples: switching {:.1} %, ZOH only {:.1} %",
            mm * 100.0,
            z * 100.0
        );
        rows.push((s, mm, z));
    }
    let revisit = "revisit the verdict in docs/book/src/case-studies/rubio-de-la-sen.md";
    for &(s, mm, z) in &rows {
        assert!(
            mm >= z - 0.02,
            "initial estimate ×{s}: switching {mm} is now below ZOH only {z}: {revisit}"
        );
    }
    let (sum_mm, sum_z) = rows
        .iter()
        .fold((0.0, 0.0), |(a, b), &(_, mm, z)| (a + mm, b + z));
    assert!(
        sum_mm > sum_z,
        "switching now lowers the start-up peaks in sum: {revisit}"
    );
}

/// The ZOH-only spec is model 0 of the full design line for line: with the full design's
/// supervisor held on model 0 (its state set to `active = 0, since = 0` before every step, so
/// that it cannot switch) and the same force sequence in, the two compute the same feed, and
/// their estimates, covariances, laws and law models agree bit for bit at every step.
#[test]
fn zoh_only_spec_is_model_0_of_the_full_design() {
    let mut full = milling_multimodel::Controller::new();
    let mut zoh = milling_zoh::Controller::new();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    for k in 0..400 {
        // A force that wanders over the input range, with jumps.
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let v = 4.0 * (x >> 11) as f64 / (1u64 << 53) as f64;
        let fc = fixed::traits::Fixed::from_num(v);
        // The same bits into both: the two `fc` declarations are alike, so are their types.
        let mut held = full.states();
        held.active = fixed::traits::Fixed::from_num(0);
        held.since = fixed::traits::Fixed::from_num(0);
        full.set_states(held);
        let z = zoh.step(milling_zoh::Inputs { fc });
        let f = full.step(milling_multimodel::Inputs { fc });
        assert_eq!(f.feed, z.feed, "feed at step {k}");
        assert_eq!(f.model.to_num::<u8>(), 0, "held on model 0");
        let (a, b) = (full.states(), zoh.states());
        assert_eq!(a.thz, b.thz, "θ at step {k}");
        assert_eq!(a.Pz, b.Pz, "P at step {k}");
        assert_eq!(a.lz, b.lz, "law at step {k}");
        assert_eq!(a.t0z, b.t0z, "t0 at step {k}");
        assert_eq!(a.mz, b.mz, "law model at step {k}");
    }
}

/// The figure and the summary, for `docs/book/src/figures` (see the module doc).
#[test]
fn figure() {
    let Some(dir) = std::env::var_os("QLOOP_FIGURES") else {
        return;
    };
    let dir = std::path::PathBuf::from(dir);
    let ds = designs();
    let t = ds[0].trace.col("t").unwrap();
    // The three designs, and the full design held on β = 0.5 (model 4): the hold on its own.
    let shown = [&ds[0], &ds[1], &ds[2], &held()[4]];
    let per_design = |col: &str| -> Vec<Series> {
        shown
            .iter()
            .enumerate()
            .map(|(i, d)| Series {
                label: d.name.to_string(),
                y: d.trace.col(col).unwrap(),
                line: Line::Design(i),
            })
            .collect()
    };
    let mut force = per_design("fc");
    force.push(Series {
        label: "F_r".into(),
        y: vec![FR; t.len()],
        line: Line::Setpoint,
    });
    let fig = Figure {
        title: "Rubio & De la Sen, milling, Fig. 1 depth profile: switching vs ZOH only vs a fixed β = 0.5 hold vs the 1981 law"
            .into(),
        t: t.clone(),
        x_label: plot::TIME_AXIS.into(),
        panels: vec![
            Panel {
                title: "measured force fc (kN)".into(),
                series: force,
            },
            Panel {
                title: "active β of the multi-model design (Rubio & De la Sen, Fig. 5)".into(),
                series: vec![Series {
                    label: "β".into(),
                    y: ds[0].trace.col("hold_beta").unwrap(),
                    line: Line::Design(0),
                }],
            },
            Panel {
                title: "feed command (mm/s)".into(),
                series: per_design("feed_cmd_mm_s"),
            },
            Panel {
                title: "depth of cut b (mm)".into(),
                series: vec![Series {
                    label: "b (scenario)".into(),
                    y: ds[0].trace.col("b_mm").unwrap(),
                    line: Line::Channel,
                }],
            },
        ],
    };
    let name = "milling-multimodel-comparison";
    write_png(&fig, &dir.join(format!("{name}.png"))).expect("png");
    write_svg(&fig, &dir.join(format!("{name}.svg"))).expect("svg");
    let tmp = dir.join(format!(".{name}.txt.tmp"));
    std::fs::write(&tmp, summary()).expect("summary");
    std::fs::rename(&tmp, dir.join(format!("{name}.txt"))).expect("summary");
}
