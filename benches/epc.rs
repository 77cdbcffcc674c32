//! The EPC phases by degree (2, 4, 6, 8) for the paper's vibro-impact case 1
//! (models/vibro_duffing.sde: c = 0.1, k = 1, 2πK = 1, r = 0.95, μ = 0.1, ε = 0.1), in process.
//!
//! - `epc_solve/degree_N`: `Epc::new(&fpk).degree(N).solve()` whole (closure, quadrature
//!   tables, assembly and Newton at every even degree up to N by continuation, normalisation,
//!   FPK residual). Degree 6 has no root at case 1: its time is the time to that refusal.
//! - `epc_phase/{closure,assembly,newton,normalise}/degree_N`: the solver's own timers of
//!   each phase ([`fpsolve::epc::SolveReport`]), collected over criterion's iterations with
//!   `iter_custom`, so the medians are of the phase alone.
//! - `epc_marginals/degree_N`: both states' marginals from the normalisation grid.
//! - `epc_observables/degree_N`: PDFs of the observables y = |z| and ẏ = v·sgn(z) (Eqs. 25,
//!   28) on their 401-point report grids and the moments of all four quantities: what a study
//!   computes per degree after the solve. Degrees 4 and 8 are normalised inside a ridge
//!   (depths 16.2 and 37.7): their lines are split into the density's smooth pieces and taken
//!   by fixed rules at a tenth of its stated accuracy (`observe/lines.rs`).
//! - `epc_moments/degree_N`: the moments of the four quantities alone (degree 2: the tensor
//!   rule of an analytic density; 4 and 8: line integrals under an outer rule).
//!
//! Issue 12's targets: assembly + Newton under 2 ms at degree 4 and 20 ms at degree 8; the
//! whole `fpsolve solve MODEL --degree 4` under 10 ms as a process (`benches/job.rs`).
//!
//! Run: `cargo bench --bench epc` (one group: `cargo bench --bench epc -- epc_phase`).

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use fpsolve::epc::{Epc, SolveReport};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::load_model;
use fpsolve::Method;

const DEGREES: [usize; 4] = [2, 4, 6, 8];

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path).unwrap();
    let bound = model.bind(&[]).unwrap();
    let fpk = FpkOperator::derive(&bound).unwrap();

    let mut g = c.benchmark_group("epc_solve");
    g.sample_size(20);
    for n in DEGREES {
        g.bench_function(format!("degree_{n}"), |b| {
            b.iter(|| Epc::new(&fpk).degree(n).solve().is_ok())
        });
    }
    g.finish();

    type Phase = fn(&SolveReport) -> f64;
    let phases: [(&str, Phase); 4] = [
        ("closure", |r| r.closure_ms),
        ("assembly", |r| r.assembly_ms),
        ("newton", |r| r.solve_ms),
        ("normalise", |r| r.normalise_ms),
    ];
    let mut g = c.benchmark_group("epc_phase");
    g.sample_size(20);
    for (name, phase) in phases {
        // Degree 6 does not converge at case 1: it has no report to read.
        for n in DEGREES.into_iter().filter(|&n| n != 6) {
            g.bench_function(format!("{name}/degree_{n}"), |b| {
                b.iter_custom(|iters| {
                    let ms: f64 = (0..iters)
                        .map(|_| phase(&Epc::new(&fpk).degree(n).solve().unwrap().solve))
                        .sum();
                    Duration::from_secs_f64(ms * 1e-3)
                })
            });
        }
    }
    g.finish();

    let mut g = c.benchmark_group("epc_marginals");
    g.sample_size(20);
    for n in DEGREES.into_iter().filter(|&n| n != 6) {
        let s = Epc::new(&fpk).degree(n).solve().unwrap();
        g.bench_function(format!("degree_{n}"), |b| {
            b.iter(|| (s.marginal(0), s.marginal(1)))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("epc_observables");
    g.sample_size(10);
    for n in DEGREES.into_iter().filter(|&n| n != 6) {
        let solution = fpsolve::solve(&bound, Method::Epc { degree: n }).unwrap();
        g.bench_function(format!("degree_{n}"), |b| {
            b.iter(|| {
                (
                    solution.marginal("y").unwrap(),
                    solution.marginal("ydot").unwrap(),
                    solution.all_moments(),
                )
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("epc_moments");
    g.sample_size(10);
    for n in DEGREES.into_iter().filter(|&n| n != 6) {
        let solution = fpsolve::solve(&bound, Method::Epc { degree: n }).unwrap();
        g.bench_function(format!("degree_{n}"), |b| b.iter(|| solution.all_moments()));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
