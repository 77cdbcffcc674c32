//! Sweep points per second (issue 12, item 4): the 100-point ε sweep of the paper's
//! vibro-impact case 1 (models/vibro_duffing.sde, EPC degree 4, each point continued from
//! degree 2: target under 1 s on 2 cores, i.e. ≥ 100 points/s), and a grid-method sweep of
//! the vibro-impact Duffing oscillator (coarse cells, so that the bench runs in seconds; the
//! grid solver's own time by cell count is `benches/grid.rs`). Whole sweeps on all cores, as
//! `fpsolve sweep` runs them, writing no files.
//!
//! Run: `cargo bench --bench sweep` (about a minute). Criterion reports the time per sweep and
//! the throughput in points/s ("elem/s").

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fpsolve::grid::Cells;
use fpsolve::model::load_model;
use fpsolve::sweep::{Sweep, SweepSpec};

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut g = c.benchmark_group("sweep");
    g.sample_size(10);

    let model = load_model(&root.join("models/vibro_duffing.sde")).unwrap();
    let spec = SweepSpec::parse(&["eps=-0.3:0.3:100".to_string()]).unwrap();
    g.throughput(Throughput::Elements(spec.len() as u64));
    g.bench_function("epc_degree_4_vibro_duffing_100_points", |b| {
        b.iter(|| Sweep::new(&model, &spec).degree(4).run().converged())
    });

    let model = load_model(&root.join("models/vibro_impact_duffing.sde")).unwrap();
    let spec = SweepSpec::parse(&["eps=-0.2:0.2:4".to_string()]).unwrap();
    g.throughput(Throughput::Elements(spec.len() as u64));
    g.bench_function("grid_70x140_vibro_impact_duffing_4_points", |b| {
        b.iter(|| {
            Sweep::new(&model, &spec)
                .methods("grid".parse().unwrap())
                .cells(Cells([70, 140]))
                .run()
                .converged()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
