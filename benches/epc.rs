//! Whole EPC solves (closure, assembly, Newton, normalisation, marginals) for the paper's
//! vibro-impact case 1 (models/vibro_duffing.sde: c = 0.1, k = 1, 2πK = 1, r = 0.95,
//! μ = 0.1, ε = 0.1). Targets on one core: degree 4 < 5 ms, 6 < 20 ms, 8 < 100 ms.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use fpsolve::epc::Epc;
use fpsolve::fpk::FpkOperator;
use fpsolve::model::load_model;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path).unwrap();
    let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
    let mut g = c.benchmark_group("epc_vibro_impact_case1");
    g.sample_size(20);
    for n in [4, 6, 8] {
        g.bench_function(format!("degree_{n}"), |b| {
            b.iter(|| {
                let r = Epc::new(&fpk).degree(n).solve();
                if let Ok(s) = &r {
                    std::hint::black_box(s.marginal(0));
                    std::hint::black_box(s.marginal(1));
                }
                r.is_ok()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
