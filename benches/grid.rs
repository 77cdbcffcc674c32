//! Grid FPK solve time against the number of cells, 5k to 320k, on the paper's case 1 with
//! the wall in original coordinates (models/vibro_impact_duffing.sde): the solve alone (the
//! error estimate off, throughput in cells per second), and the default job of
//! `fpsolve solve MODEL --method grid` (200×400 cells and the error estimate's 100×200), on
//! rayon's default pool and on one thread (the factorisation splits the subtrees of the
//! elimination tree between threads, and the two solves run alongside; same bits either way).
//! Peak memory by cell count: `benches/grid_cells.sh`.
//!
//! `cargo bench --bench grid`

use std::path::Path;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fpsolve::grid::GridSolver;
use fpsolve::model::load_model;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
    let bound = load_model(&path).expect("model").bind(&[]).expect("binds");
    let mut group = c.benchmark_group("grid_solve_by_cells");
    group.sample_size(10);
    // n × 2n cells: 5k, 20k, 80k, 320k.
    for n in [50, 100, 200, 400] {
        let cells = 2 * n * n;
        group.throughput(Throughput::Elements(cells as u64));
        group.bench_with_input(BenchmarkId::from_parameter(cells), &n, |b, &n| {
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
    let mut group = c.benchmark_group("grid_default_job");
    group.sample_size(10);
    group.bench_function("200x400_with_estimate", |b| {
        b.iter(|| GridSolver::new(&bound).solve().expect("solves"))
    });
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool");
    group.bench_function("200x400_with_estimate_1_thread", |b| {
        b.iter(|| one.install(|| GridSolver::new(&bound).solve().expect("solves")))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
