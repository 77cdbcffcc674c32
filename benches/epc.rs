//! Whole EPC solves (closure, assembly, Newton, normalisation, marginals) for the paper's
//! vibro-impact case 1 (c = 0.1, k = 1, 2πK = 1, r = 0.95, μ = 0.1, ε = 0.1).

use criterion::{criterion_group, criterion_main, Criterion};
use fpsolve::epc::Epc;
use fpsolve::fpk::FpkOperator;
use fpsolve::model::DeltaTreatment;
use fpsolve::symbolic::{DeltaLine, DeltaSplit, Expr, Func};

pub fn vibro_impact(c: f64, k: f64, mu: f64, two_pi_k: f64, r: f64, eps: f64) -> FpkOperator {
    let n = Expr::num;
    let (z, v) = (Expr::sym("z"), Expr::sym("v"));
    let abs = |e: Expr| Expr::call(Func::Abs, e);
    let reg = |e: Expr| DeltaSplit {
        regular: e,
        lines: vec![],
    };
    let z3 = Expr::pow(z.clone(), n(3.0));
    let b_vv = n(0.5 * two_pi_k)
        * (n(1.0) + n(2.0 * eps) * abs(z.clone()) + n(eps * eps) * Expr::pow(z.clone(), n(2.0)));
    let line = |w: Expr| DeltaLine {
        axis: 0,
        at: 0.0,
        weight: w,
    };
    FpkOperator {
        states: ["z".into(), "v".into()],
        drift: [
            v.clone(),
            n(-c) * v.clone() - n(k) * z.clone() - n(mu) * z3.clone(),
        ],
        wong_zakai: [n(0.0), n(0.0)],
        diffusion: [[n(0.0), n(0.0)], [n(0.0), n(2.0) * b_vv.clone()]],
        a0: DeltaSplit {
            regular: n(c),
            lines: vec![line(n(2.0 * (1.0 - r)) * abs(v.clone()))],
        },
        a: [
            reg(-v.clone()),
            DeltaSplit {
                regular: n(c) * v.clone() + n(k) * z + n(mu) * z3,
                lines: vec![line(n(1.0 - r) * v.clone() * abs(v))],
            },
        ],
        b: [[reg(n(0.0)), reg(n(0.0))], [reg(n(0.0)), reg(b_vv)]],
    }
}

fn bench(c: &mut Criterion) {
    let fpk = vibro_impact(0.1, 1.0, 0.1, 1.0, 0.95, 0.1);
    let mut g = c.benchmark_group("epc_vibro_impact_case1");
    g.sample_size(10);
    for n in [4, 6, 8] {
        g.bench_function(format!("degree_{n}"), |b| {
            b.iter(|| {
                let r = Epc::new(&fpk, DeltaTreatment::Exact).degree(n).solve();
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
