//! Tree walking (`Expr::eval`) against the compiled tape, point by point and in batches, on the
//! vibro-impact oscillator's drift and diffusion coefficient (paper Eq. 10–11).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fpsolve::symbolic::{DeltaPolicy, Expr, Func, Tape, TapeScratch};

const POINTS: usize = 4096;

fn exprs() -> [Expr; 2] {
    let z = Expr::sym("z");
    let v = Expr::sym("v");
    let drift =
        Expr::num(-0.1) * v - z.clone() - Expr::num(0.1) * Expr::pow(z.clone(), Expr::num(3.0));
    let coefficient = Expr::num(0.5)
        * Expr::pow(
            Expr::call(Func::Sgn, z.clone()) + Expr::num(0.1) * z,
            Expr::num(2.0),
        );
    [drift, coefficient]
}

fn points() -> (Vec<f64>, Vec<f64>) {
    let z = (0..POINTS).map(|i| 3.0 * (i as f64 * 0.37).sin()).collect();
    let v = (0..POINTS).map(|i| 2.0 * (i as f64 * 0.11).cos()).collect();
    (z, v)
}

fn bench(c: &mut Criterion) {
    let exprs = exprs();
    let (zs, vs) = points();
    let tape = Tape::compile(&exprs, &["z", "v"], DeltaPolicy::Reject).expect("compiles");
    let mut group = c.benchmark_group("vibro_impact_drift_and_coefficient");
    group.throughput(Throughput::Elements(POINTS as u64));

    group.bench_function("expr_eval", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (&z, &v) in zs.iter().zip(&vs) {
                let lookup = |s: &str| match s {
                    "z" => Some(z),
                    "v" => Some(v),
                    _ => None,
                };
                for e in &exprs {
                    acc += e.eval(&lookup).expect("bound");
                }
            }
            black_box(acc)
        })
    });

    group.bench_function("tape_eval", |b| {
        let mut scratch = Vec::new();
        let mut out = [0.0; 2];
        b.iter(|| {
            let mut acc = 0.0;
            for (&z, &v) in zs.iter().zip(&vs) {
                tape.eval(&[z, v], &mut scratch, &mut out);
                acc += out[0] + out[1];
            }
            black_box(acc)
        })
    });

    group.bench_function("tape_eval_batch", |b| {
        let mut scratch = TapeScratch::new();
        let mut out = vec![vec![0.0; POINTS]; 2];
        b.iter(|| {
            tape.eval_batch(&[&zs, &vs], &mut out, &mut scratch);
            black_box(&out);
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
