//! `epc-impact` ladder time (degrees 2 to n, box refits and quadrature checks included) on
//! the paper's case 1 in original coordinates (tests/models/grid_impact_duffing.sde).

use std::path::Path;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use fpsolve::epc_impact::EpcImpact;
use fpsolve::model::load_model;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/grid_impact_duffing.sde");
    let bound = load_model(&path).expect("model").bind(&[]).expect("binds");
    let mut group = c.benchmark_group("epc_impact_ladder_case1");
    group.sample_size(10);
    for n in [4, 6, 8] {
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| EpcImpact::new(&bound).solve(n).expect("solves"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
