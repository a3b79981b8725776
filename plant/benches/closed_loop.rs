//! Closed-loop throughput on the turning plant: controller periods per second, with the
//! plant's 20 substeps per period, trace recorded. `single`: the compiled 1981 fixed-point
//! controller alone (one controller step and 20 plant substeps per period); `paired`: it and
//! its f64 reference side by side, as `qloop sim` runs them (two steps, 40 substeps).
//!
//! `cargo bench -p qloop-plant --bench closed_loop`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use qloop_plant::turning::{scenario_named, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, run_single, RunConfig};

fn closed_loop(c: &mut Criterion) {
    let sc = scenario_named("depth-steps").expect("scenario");
    let plant = Turning::new(TurningParams::default());
    let periods = (sc.duration_s / 0.1).round() as u64 + 1;
    let mut g = c.benchmark_group("turning");
    g.throughput(Throughput::Elements(periods));
    g.bench_function("single: depth-steps, fixed-point, 20 substeps", |b| {
        b.iter(|| {
            run_single(
                &plant,
                fixed_controller!(qloop_verified::koren_masory_1981),
                &sc,
                RunConfig::default(),
            )
            .expect("run")
        })
    });
    g.bench_function(
        "paired: depth-steps, fixed + f64 reference, 20 substeps",
        |b| {
            b.iter(|| {
                run(
                    &plant,
                    fixed_controller!(qloop_verified::koren_masory_1981),
                    reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
                    &sc,
                    RunConfig::default(),
                )
                .expect("run")
            })
        },
    );
    g.finish();
}

criterion_group!(benches, closed_loop);
criterion_main!(benches);
