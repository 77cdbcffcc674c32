//! Monte Carlo throughput at dt = 0.01 in steps per second (criterion's elements/s): each
//! weak order-2 scheme on 1 and 2 threads (`mc_step_rate`), and on one thread the
//! alternatives and a straightforward scalar loop (`mc_vibro_impact`).
//! Run: `cargo bench --bench mc` (or `-- mc_step_rate` for the rates alone).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fpsolve::mc::reference::{vibro_impact, VibroImpact};
use fpsolve::mc::{BurnIn, Grid, Increments, McConfig, SchemeChoice, Simulation};
use fpsolve::model::load_model;
use rand::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

const P: VibroImpact = VibroImpact {
    c: 0.1,
    k: 1.0,
    mu: 0.5,
    eps: 0.2,
    r: 0.8,
    big_k: 0.05,
};
const DT: f64 = 0.01;
const TRAJECTORIES: u64 = 512;
const SAMPLES: u64 = 200;
const STEPS_PER_SAMPLE: u64 = 10;

fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    let u1 = ((rng.next_u64() >> 11) as f64 + 0.5) / 9_007_199_254_740_992.0;
    let u2 = ((rng.next_u64() >> 11) as f64 + 0.5) / 9_007_199_254_740_992.0;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The same scheme written the obvious way: one trajectory at a time, hand-coded model,
/// a Gaussian per step, impacts checked in the flight; returns a histogram checksum.
fn scalar_baseline() -> u64 {
    let s = 2.0 * std::f64::consts::PI * P.big_k;
    let force = |z: f64, v: f64| -P.c * v - P.k * z - P.mu * z * z * z;
    let mut hist = [0u64; 64];
    for t in 0..TRAJECTORIES {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(t);
        let (mut z, mut v) = (0.1, 0.0);
        let flight = |z: &mut f64, v: &mut f64, tau: f64| {
            let zn = *z + *v * tau;
            if *z != 0.0 && zn * z.signum() <= 0.0 {
                let hit = -*z / *v;
                *v *= P.r;
                *z = *v * (tau - hit);
            } else {
                *z = zn;
            }
        };
        for _ in 0..SAMPLES {
            for _ in 0..STEPS_PER_SAMPLE {
                flight(&mut z, &mut v, 0.5 * DT);
                let g = z.signum() * (z != 0.0) as i32 as f64 + P.eps * z;
                let dw = (s * g * g * DT).sqrt() * normal(&mut rng);
                let f0 = force(z, v);
                let vb = v + f0 * DT + dw;
                v += 0.5 * (f0 + force(z, vb)) * DT + dw;
                flight(&mut z, &mut v, 0.5 * DT);
            }
            let y = z.abs();
            hist[((y * 20.0) as usize).min(63)] += 1;
        }
    }
    hist.iter().enumerate().map(|(i, c)| i as u64 * c).sum()
}

fn config(increments: Increments, scheme: SchemeChoice, names: &[&str]) -> McConfig {
    let grid = Grid::new(-3.0, 3.0, 100).unwrap();
    McConfig {
        dt: DT,
        spacing: DT * STEPS_PER_SAMPLE as f64,
        trajectories: TRAJECTORIES,
        samples: SAMPLES,
        burn_in: BurnIn::Time(0.0),
        increments,
        scheme,
        // The throughput counts the main run's steps only.
        bias_fraction: 0.0,
        grids: names.iter().map(|n| (n.to_string(), grid)).collect(),
        ..McConfig::default()
    }
}

fn simulation(increments: Increments, scheme: SchemeChoice) -> Simulation {
    let model = vibro_impact(P).bind(&[]).unwrap();
    let config = config(increments, scheme, &["z", "v", "y", "ydot"]);
    Simulation::new(&model, &config).unwrap()
}

/// `models/cubic_damping_two_noises.sde`: not of the mechanical form (the noise of v depends
/// on v, two sources), so the general weak order-2 scheme (Platen's) is what runs.
fn two_noises() -> Simulation {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/cubic_damping_two_noises.sde"
    );
    let model = load_model(path.as_ref()).unwrap().bind(&[]).unwrap();
    let config = config(
        Increments::ThreePoint,
        SchemeChoice::Auto,
        &["z", "v", "y", "ydot"],
    );
    Simulation::new(&model, &config).unwrap()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// Steps per second by scheme, one thread, with the alternatives (Gaussian increments,
/// the weak order-1 general scheme) and the scalar loop for contrast.
fn bench(c: &mut Criterion) {
    let steps = TRAJECTORIES * SAMPLES * STEPS_PER_SAMPLE;
    let mut g = c.benchmark_group("mc_vibro_impact");
    g.throughput(Throughput::Elements(steps));
    g.sample_size(10);
    g.bench_function("scalar_baseline", |b| b.iter(scalar_baseline));
    let one = pool(1);
    for (name, inc, scheme) in [
        ("batched_gaussian", Increments::Gaussian, SchemeChoice::Auto),
        (
            "batched_general_heun",
            Increments::ThreePoint,
            SchemeChoice::GeneralOrder1,
        ),
    ] {
        let sim = simulation(inc, scheme);
        g.bench_function(name, |b| b.iter(|| one.install(|| sim.run().unwrap())));
    }
    g.finish();
}

/// The step rate of each weak order-2 scheme on 1 and 2 threads (issue 12, item 1):
/// `mechanical_impact` is the splitting with exact impact location on the paper's
/// vibro-impact model, `general_weak2` Platen's scheme on the same model, and
/// `general_weak2_two_noises` Platen's scheme on a model that needs it.
fn step_rate(c: &mut Criterion) {
    let steps = TRAJECTORIES * SAMPLES * STEPS_PER_SAMPLE;
    let mut g = c.benchmark_group("mc_step_rate");
    g.throughput(Throughput::Elements(steps));
    g.sample_size(10);
    let sims = [
        (
            "mechanical_impact",
            simulation(Increments::ThreePoint, SchemeChoice::Auto),
        ),
        (
            "general_weak2",
            simulation(Increments::ThreePoint, SchemeChoice::General),
        ),
        ("general_weak2_two_noises", two_noises()),
    ];
    for threads in [1, 2] {
        let pool = pool(threads);
        for (name, sim) in &sims {
            g.bench_function(format!("{name}/{threads}_threads"), |b| {
                b.iter(|| pool.install(|| sim.run().unwrap()))
            });
        }
    }
    // The AVX2 kernel where the CPU has AVX-512 too (otherwise the widest runs): its
    // step rate is what a workstation without AVX-512 gets. The cap is read when a batch
    // starts; the pool's threads are idle while it is set.
    if std::env::var_os(fpsolve::base::simd::SIMD_VAR).is_none() && has_avx512() {
        let one = pool(1);
        let (name, sim) = &sims[0];
        std::env::set_var(fpsolve::base::simd::SIMD_VAR, "avx2");
        g.bench_function(format!("{name}/1_threads/avx2"), |b| {
            b.iter(|| one.install(|| sim.run().unwrap()))
        });
        std::env::remove_var(fpsolve::base::simd::SIMD_VAR);
    }
    g.finish();
}

/// Whether this CPU has AVX-512F.
fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

criterion_group!(benches, step_rate, bench);
criterion_main!(benches);
