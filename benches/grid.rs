//! Grid FPK solve time against the number of cells, 5k to 320k, on the paper's case 1 in
//! Zhuravlev form (models/vibro_duffing.sde), the error estimate off.

use std::path::Path;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use fpsolve::grid::GridSolver;
use fpsolve::model::load_model;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let bound = load_model(&path).expect("model").bind(&[]).expect("binds");
    let mut group = c.benchmark_group("grid_solve_case1");
    group.sample_size(10);
    // n × 2n cells: 5k, 20k, 80k, 320k.
    for n in [50, 100, 200, 400] {
        group.bench_with_input(BenchmarkId::from_parameter(2 * n * n), &n, |b, &n| {
            b.iter(|| {
                GridSolver::new(&bound)
                    .cells(n, 2 * n)
                    .estimate(false)
                    .solve()
                    .expect("solves")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
