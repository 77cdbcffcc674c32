//! The grid transient's whole history on the linear oscillator from rest (models/linear.sde,
//! 0 → 80 at 161 output times, box ±16 on both axes): the time the speed target
//! (≤ 2 s at an L1 error of 1e−4) is measured by, at the two resolutions of
//! `tests/transient_linear.rs` and at the step tolerance whose time-stepping error stays
//! below 1e−4 in L1 at every output (2.5e−5: the stepper's error there is about 4 times its
//! per-unit-time tolerance, measured against a run at 1e−7).
//!
//! The same at 160x160 under Shinozuka–Sato modulated noise (`tests/transient_modulated.rs`'s
//! model, box ±5, 0 → 20 at 201 output times): a time-dependent operator, assembled and
//! factorised at every stage time.
//!
//! `cargo bench --bench transient`

use std::path::Path;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use fpsolve::grid::{Domain, GridTransient, Initial};
use fpsolve::model::load_model;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    let bound = load_model(&path).expect("model").bind(&[]).expect("binds");
    let times: Vec<f64> = (0..161).map(|i| 0.5 * i as f64).collect();
    let domain = Domain {
        x: [-16.0, 16.0],
        v: [-16.0, 16.0],
    };
    let mut group = c.benchmark_group("transient_linear_history_0_80");
    group.sample_size(10);
    for n in [80usize, 160] {
        group.bench_with_input(BenchmarkId::from_parameter(n * n), &n, |b, &n| {
            b.iter(|| {
                GridTransient::new(&bound)
                    .cells(n, n)
                    .domain(domain)
                    .initial(Initial::Rest)
                    .tolerance(2.5e-5)
                    .times(times.clone())
                    .run()
                    .expect("runs")
            })
        });
    }
    group.finish();
}

fn bench_modulated(c: &mut Criterion) {
    let text = "model modulated\nparam c = 0.5, k = 1, a = 4, b1 = 0.5, b2 = 1\n\
                state z, v\ndrift z: v\ndrift v: -c*v - k*z\nnoise xi: intensity 1\n\
                diffusion v: a*(exp(-b1*t) - exp(-b2*t))*xi\n";
    let bound = fpsolve::model::parse_model(text, None)
        .expect("model")
        .bind(&[])
        .expect("binds");
    let times: Vec<f64> = (0..201).map(|i| 0.1 * i as f64).collect();
    let domain = Domain {
        x: [-5.0, 5.0],
        v: [-5.0, 5.0],
    };
    let mut group = c.benchmark_group("transient_modulated_history_0_20");
    group.sample_size(10);
    group.bench_function("160x160", |b| {
        b.iter(|| {
            GridTransient::new(&bound)
                .cells(160, 160)
                .domain(domain)
                .initial(Initial::Gaussian {
                    mean: [0.0, 0.0],
                    covariance: [[0.09, 0.0], [0.0, 0.09]],
                })
                .tolerance(1e-4)
                .times(times.clone())
                .run()
                .expect("runs")
        })
    });
    group.finish();
}

criterion_group!(benches, bench, bench_modulated);
criterion_main!(benches);
