//! Compiler speed: the shift-add planner and the whole spec → plan → Rust pipeline.
//! Run with `cargo bench -p qloop`; figures are recorded in BENCHMARKS.md.

use criterion::{criterion_group, criterion_main, Criterion};
use qloop::lower::shift_add;
use qloop::Target;
use std::hint::black_box;

fn planner(c: &mut Criterion) {
    let _ = shift_add::best(3); // build the adder-graph table once, outside the timing
    c.bench_function("shift_add::best, all m in 1..4096", |b| {
        b.iter(|| {
            let mut adders = 0;
            for m in 1..4096i128 {
                adders += shift_add::best(black_box(m)).adders();
            }
            adders
        })
    });
}

fn pipeline(c: &mut Criterion) {
    let t = Target::default();
    c.bench_function("compile koren_masory_1981 (parse, check, lower)", |b| {
        b.iter(|| qloop::compile_str(black_box(qloop::DEMO_SPEC), &t).map(|p| p.vals.len()))
    });
    let plan = qloop::compile_str(qloop::DEMO_SPEC, &t).expect("demo spec compiles");
    c.bench_function("emit + format Rust for koren_masory_1981", |b| {
        b.iter(|| qloop::gen_rust(black_box(&plan)).len())
    });
}

criterion_group!(benches, planner, pipeline);
criterion_main!(benches);
