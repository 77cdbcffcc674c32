//! First passage on the grid (issue 35): the backward and forward solves agree, the
//! lightly damped linear oscillator of the issue against an independent Monte Carlo with an
//! exact transition, and the model language's `safe` line.

use fpsolve::grid::{DecayOutcome, Domain, GridPassage, PassageError, PassageSolution};
use fpsolve::model::{load_model, Override};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

fn linear(c: f64, safe: &str) -> (fpsolve::model::Model, Vec<Override>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    let model = load_model(&path).unwrap().with_safe(safe).unwrap();
    (model, vec![Override::number("c", c)])
}

fn passage(c: f64, safe: &str, cells: [usize; 2], times: Vec<f64>) -> PassageSolution {
    let (model, set) = linear(c, safe);
    let bound = model.bind(&set).unwrap();
    let s = model.safe().unwrap().bind(&bound).unwrap();
    GridPassage::new(&bound, &s)
        .cells(cells[0], cells[1])
        .times(times)
        .tolerance(1e-5)
        .run()
        .unwrap()
}

/// The forward run with killing and the backward solve use one matrix and its transpose, so
/// ∫₀^H R dt plus the tail beyond H equals the start cell's mean time; the tail is below
/// R(H)·(mean time) for a decay at least as fast as the exponential of that mean.
#[test]
fn forward_reliability_integrates_to_the_backward_mean() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let mean = passage(c, safe, [60, 80], vec![]).mean_from_start_cell;
    let horizon = 12.0 * mean;
    let times: Vec<f64> = (0..=600).map(|k| horizon * k as f64 / 600.0).collect();
    let p = passage(c, safe, [60, 80], times);
    let tail = p.reliability.last().unwrap() * mean;
    let integral = p.integral_of_reliability.expect("output times");
    let gap = (integral - p.mean_from_start_cell).abs();
    println!(
        "mean {mean:.6}, ∫R {integral:.6}, R(H) {:.2e}, gap {gap:.2e}",
        p.reliability.last().unwrap()
    );
    assert!(gap < tail + 2e-3 * mean, "gap {gap:e}, tail {tail:e}");
    // R falls from 1; the third-order scheme is not positivity-preserving, so from a point
    // start in one cell R rose by 1.4e-3 and its density dipped to -6.4e-3 (c = 1, 60x80).
    assert!((p.reliability[0] - 1.0).abs() < 1e-12);
    let rise = p
        .reliability
        .windows(2)
        .fold(0.0f64, |m, w| m.max(w[1] - w[0]));
    let dip = p.pdf.iter().fold(0.0f64, |m, f| m.max(-f));
    println!("largest rise of R {rise:.2e}, largest negative density {dip:.2e}");
    assert!(rise < 3e-3 && dip < 1.5e-2, "rise {rise:e}, dip {dip:e}");
    assert!(p.second_at_start > p.mean_at_start.powi(2));
}

/// The mean times' estimated errors (from the solve on half the cells) cover their distance
/// to a solve on four times the cells per axis.
#[test]
fn the_estimate_covers_the_mean_times_error() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let coarse = passage(c, safe, [60, 80], vec![]);
    let fine = passage(c, safe, [240, 320], vec![]);
    let e = coarse
        .errors
        .as_ref()
        .expect("the estimate is on by default");
    let pairs = [
        (coarse.mean_at_start, fine.mean_at_start, e.mean_at_start),
        (
            coarse.mean_stationary.unwrap(),
            fine.mean_stationary.unwrap(),
            e.mean_stationary.unwrap(),
        ),
        (
            coarse.second_at_start,
            fine.second_at_start,
            e.second_at_start,
        ),
    ];
    for (a, b, stated) in pairs {
        println!(
            "60x80 {a:.6}, 240x320 {b:.6}: error {:.2e}, stated {stated:.2e}",
            (a - b).abs()
        );
        assert!((a - b).abs() <= stated, "{a} vs {b}: stated {stated}");
    }
    assert_eq!(coarse.report.estimate_cells, Some([30, 40]));
}

/// The paper's case 1 in its own coordinates (a reflecting wall at y = 0, safe y < 3) and in
/// its Zhuravlev form (a pass-through barrier at z = 0, safe |z| < 3) is one first-passage
/// problem: the two grids agree to within their stated errors and to 0.2 %. (Before the
/// Zhuravlev form's bounds were put on faces its set ended at |z| = 2.989 at every count of
/// cells and its mean time was 1.2 % short: 29.85 against 30.21 at 100×200.)
#[test]
fn the_paper_case_is_one_problem_in_both_coordinates() {
    let run = |file: &str, safe: &str| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(file);
        let model = load_model(&path).unwrap().with_safe(safe).unwrap();
        let bound = model.bind(&[]).unwrap();
        let s = model.safe().unwrap().bind(&bound).unwrap();
        GridPassage::new(&bound, &s)
            .cells(100, 200)
            .start([1e-6, 0.0])
            .run()
            .unwrap()
    };
    let own = run("vibro_impact_duffing.sde", "y < 3");
    let zhuravlev = run("vibro_duffing.sde", "abs(z) < 3");
    let (a, b) = (own.mean_at_start, zhuravlev.mean_at_start);
    let stated = own.errors.as_ref().unwrap().mean_at_start
        + zhuravlev.errors.as_ref().unwrap().mean_at_start;
    println!("own {a:.5}, Zhuravlev {b:.5}, stated {stated:.3e}");
    assert!((a - b).abs() <= stated, "{a} vs {b}: stated {stated}");
    assert!((a / b - 1.0).abs() < 2e-3, "{a} vs {b}");
    let (a, b) = (
        own.mean_stationary.unwrap(),
        zhuravlev.mean_stationary.unwrap(),
    );
    assert!((a / b - 1.0).abs() < 2e-3, "stationary start: {a} vs {b}");
}

/// The slowest decay of the killed generator: the forward and backward iterations find one
/// λ, the mean passage time from the quasi-stationary law is 1/λ (exponential passage from
/// it), and the stepped R(t) at late times is A e^{−λt}, each to the accuracy of the
/// time-stepping (1e-5 per unit time); the quasi-stationary marginals have unit mass.
#[test]
fn late_reliability_is_the_slowest_decay() {
    let (c, safe) = (1.0, "abs(z) < 1.2");
    let mean = passage(c, safe, [60, 80], vec![]).mean_from_start_cell;
    let horizon = 8.0 * mean;
    let times: Vec<f64> = (0..=400).map(|k| horizon * k as f64 / 400.0).collect();
    let p = passage(c, safe, [60, 80], times.clone());
    let DecayOutcome::Found(d) = &p.decay else {
        panic!("{:?}", p.decay)
    };
    println!("{d:?}; mean time {mean:.6}");
    assert!((d.rate - d.rate_backward).abs() < 1e-9 * d.rate, "{d:?}");
    assert!(
        (d.mean_from_quasi_stationary * d.rate - 1.0).abs() < 1e-6,
        "{d:?}"
    );
    // From a point at rest R(t) is the exponential only after the start's transients; from
    // four mean times on they have decayed far below the stepping's error.
    for (t, r) in times
        .iter()
        .zip(&p.reliability)
        .filter(|(t, _)| **t >= 4.0 * mean)
    {
        let tail = d.amplitude * (-d.rate * t).exp();
        assert!(
            (r / tail - 1.0).abs() < 2e-3,
            "t {t}: R {r:e}, A e^-lt {tail:e}"
        );
    }
    let [qx, qv] = p.quasi_stationary.as_ref().unwrap();
    for q in [qx, qv] {
        let mass: f64 = q.density.iter().sum::<f64>() * q.width;
        assert!((mass - 1.0).abs() < 1e-12, "{mass}");
    }
}

/// The exact transition over a step h of the linear system x' = v, v' = −k x − c v + √q ξ
/// (E[ξ(t)ξ(t+τ)] = δ(τ)): (x, v) ↦ Φ (x, v) + a Gaussian of covariance P. Φ and
/// P = ∫₀^h e^{As} diag(0, q) e^{Aᵀs} ds come from many RK4 substeps of their ODEs, which
/// need no division by c or k (the free particle k = c = 0 included).
#[derive(Clone, Copy, Debug)]
struct Transition {
    phi: [[f64; 2]; 2],
    cov: [[f64; 2]; 2],
}

type M2 = [[f64; 2]; 2];

fn mul(m: M2, n: M2) -> M2 {
    let mut o = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            o[i][j] = m[i][0] * n[0][j] + m[i][1] * n[1][j];
        }
    }
    o
}

fn tr(m: M2) -> M2 {
    [[m[0][0], m[1][0]], [m[0][1], m[1][1]]]
}

fn add(m: M2, n: M2, s: f64) -> M2 {
    [
        [m[0][0] + s * n[0][0], m[0][1] + s * n[0][1]],
        [m[1][0] + s * n[1][0], m[1][1] + s * n[1][1]],
    ]
}

fn inverse(m: M2) -> M2 {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ]
}

fn apply2(m: M2, s: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * s[0] + m[0][1] * s[1],
        m[1][0] * s[0] + m[1][1] * s[1],
    ]
}

/// The lower Cholesky factor (l11, l21, l22) of a symmetric positive definite 2×2 matrix.
fn cholesky(p: M2) -> [f64; 3] {
    let l11 = p[0][0].sqrt();
    let l21 = p[1][0] / l11;
    let l22 = (p[1][1] - l21 * l21).sqrt();
    [l11, l21, l22]
}

fn transition(k: f64, c: f64, q: f64, h: f64) -> Transition {
    let a = [[0.0, 1.0], [-k, -c]];
    // Φ' = AΦ; P' = AP + PAᵀ + diag(0, q).
    let f_phi = |p: M2| mul(a, p);
    let f_p = |p: M2| {
        add(
            add(mul(a, p), mul(p, tr(a)), 1.0),
            [[0.0, 0.0], [0.0, q]],
            1.0,
        )
    };
    let rk4 = |y: M2, f: &dyn Fn(M2) -> M2, d: f64| {
        let k1 = f(y);
        let k2 = f(add(y, k1, d / 2.0));
        let k3 = f(add(y, k2, d / 2.0));
        let k4 = f(add(y, k3, d));
        let s = add(add(k1, k4, 1.0), add(k2, k3, 1.0), 2.0);
        add(y, s, d / 6.0)
    };
    let (mut phi, mut cov) = ([[1.0, 0.0], [0.0, 1.0]], [[0.0; 2]; 2]);
    let sub = 1000;
    for _ in 0..sub {
        phi = rk4(phi, &f_phi, h / sub as f64);
        cov = rk4(cov, &f_p, h / sub as f64);
    }
    Transition { phi, cov }
}

/// One step of the exact transition of x' = v, v' = −c v − x + ξ (2πK = 1): Φ and the
/// Cholesky factor of the step's covariance.
fn exact_step(c: f64, h: f64) -> ([[f64; 2]; 2], [[f64; 3]; 1]) {
    let t = transition(1.0, c, 1.0, h);
    (t.phi, [cholesky(t.cov)])
}

fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    // Box–Muller, one of the pair.
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Monte Carlo of the first exit from |x| < u from rest, on the exact Gaussian transition
/// over steps of h; between two steps the path is the cubic Hermite interpolant of (x, v) at
/// both ends (x is C¹), whose maximum of |x| decides a crossing inside the step, located by
/// bisection. Returns (mean, its standard error, E[T²]).
fn monte_carlo(c: f64, u: f64, h: f64, paths: usize, seed: u64) -> (f64, f64, f64) {
    let (phi, [[l11, l21, l22]]) = exact_step(c, h);
    let (mut s1, mut s2) = (0.0, 0.0);
    for path in 0..paths {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(
            seed ^ (path as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let (mut x, mut v, mut t) = (0.0f64, 0.0f64, 0.0f64);
        loop {
            let (z1, z2) = (normal(&mut rng), normal(&mut rng));
            let xn = phi[0][0] * x + phi[0][1] * v + l11 * z1;
            let vn = phi[1][0] * x + phi[1][1] * v + l21 * z1 + l22 * z2;
            let herm = |s: f64| {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * x
                    + (s3 - 2.0 * s2 + s) * h * v
                    + (-2.0 * s3 + 3.0 * s2) * xn
                    + (s3 - s2) * h * vn
            };
            let out = |s: f64| herm(s).abs() >= u;
            // The first sample (of 16) of the interpolant outside, then bisection.
            if let Some(k) = (1..=16).find(|k| out(*k as f64 / 16.0)) {
                let (mut a, mut b) = ((k - 1) as f64 / 16.0, k as f64 / 16.0);
                for _ in 0..40 {
                    let m = 0.5 * (a + b);
                    if out(m) {
                        b = m;
                    } else {
                        a = m;
                    }
                }
                let tau = t + b * h;
                s1 += tau;
                s2 += tau * tau;
                break;
            }
            x = xn;
            v = vn;
            t += h;
        }
    }
    let n = paths as f64;
    let mean = s1 / n;
    let var = s2 / n - mean * mean;
    (mean, (var / n).sqrt(), s2 / n)
}

/// The law of the midpoint of a step of `Transition` length given both ends: for a step of
/// length h from s₀ to s₁, the midpoint is Φ_m s₀ + G (s₁ − Φ_h s₀) plus a Gaussian of
/// covariance Q_m − G Φ_m Q_m, with G = Q_m Φ_mᵀ Q_h⁻¹ (Φ, Q of the half step m and the
/// step h): the Gaussian bridge of (x, v), exact for a linear system.
#[derive(Clone, Copy, Debug)]
struct Bridge {
    half: M2,
    whole: M2,
    gain: M2,
    chol: [f64; 3],
}

impl Bridge {
    fn new(k: f64, c: f64, q: f64, h: f64) -> Bridge {
        let (m, w) = (transition(k, c, q, h / 2.0), transition(k, c, q, h));
        let gain = mul(mul(m.cov, tr(m.phi)), inverse(w.cov));
        let mut cov = add(m.cov, mul(mul(gain, m.phi), m.cov), -1.0);
        let off = 0.5 * (cov[0][1] + cov[1][0]);
        cov[0][1] = off;
        cov[1][0] = off;
        Bridge {
            half: m.phi,
            whole: w.phi,
            gain,
            chol: cholesky(cov),
        }
    }

    /// The standard deviation of the midpoint's position given both ends.
    fn sd(&self) -> f64 {
        self.chol[0]
    }

    fn midpoint(&self, s0: [f64; 2], s1: [f64; 2], rng: &mut Xoshiro256PlusPlus) -> [f64; 2] {
        let base = apply2(self.half, s0);
        let ahead = apply2(self.whole, s0);
        let pull = apply2(self.gain, [s1[0] - ahead[0], s1[1] - ahead[1]]);
        let [l11, l21, l22] = self.chol;
        let (z1, z2) = (normal(rng), normal(rng));
        [
            base[0] + pull[0] + l11 * z1,
            base[1] + pull[1] + l21 * z1 + l22 * z2,
        ]
    }
}

/// An exit-time sampler for |x| < u of x' = v, v' = −k x − c v + √q ξ from a start point,
/// independent of fpsolve: exact Gaussian steps of length h, and within a step the path
/// refined by exact Gaussian-bridge midpoints wherever it may come within `K_SD` bridge
/// standard deviations of the boundary, down to steps of h/2^levels, where the cubic Hermite
/// interpolant of (x, v) at both ends (x is C¹) locates the crossing by bisection. Without
/// refinement (levels = 0) a crossing between two points inside is missed.
struct ExitSampler {
    u: f64,
    h: f64,
    step: Transition,
    step_chol: [f64; 3],
    bridges: Vec<Bridge>,
}

/// How many of the bridge's standard deviations from the boundary a step must stay for its
/// refinement to be skipped (the chance that a Gaussian bridge strays that far is below
/// 1e-14).
const K_SD: f64 = 8.0;

impl ExitSampler {
    fn new(k: f64, c: f64, q: f64, u: f64, h: f64, levels: usize) -> ExitSampler {
        let step = transition(k, c, q, h);
        ExitSampler {
            u,
            h,
            step,
            step_chol: cholesky(step.cov),
            bridges: (0..levels)
                .map(|j| Bridge::new(k, c, q, h / f64::powi(2.0, j as i32)))
                .collect(),
        }
    }

    /// The time within [0, len] at which the Hermite interpolant from s0 to s1 first reaches
    /// |x| = u, if it does (16 samples, then bisection).
    fn hermite_exit(&self, s0: [f64; 2], s1: [f64; 2], len: f64) -> Option<f64> {
        let herm = |s: f64| {
            let (s2, s3) = (s * s, s * s * s);
            (2.0 * s3 - 3.0 * s2 + 1.0) * s0[0]
                + (s3 - 2.0 * s2 + s) * len * s0[1]
                + (-2.0 * s3 + 3.0 * s2) * s1[0]
                + (s3 - s2) * len * s1[1]
        };
        let out = |s: f64| herm(s).abs() >= self.u;
        let k = (1..=16).find(|k| out(*k as f64 / 16.0))?;
        let (mut a, mut b) = ((k - 1) as f64 / 16.0, k as f64 / 16.0);
        for _ in 0..50 {
            let m = 0.5 * (a + b);
            if out(m) {
                b = m;
            } else {
                a = m;
            }
        }
        Some(b * len)
    }

    /// The least distance to the boundary of the Hermite interpolant (17 points).
    fn margin(&self, s0: [f64; 2], s1: [f64; 2], len: f64) -> f64 {
        (0..=16)
            .map(|k| {
                let s = k as f64 / 16.0;
                let (s2, s3) = (s * s, s * s * s);
                let x = (2.0 * s3 - 3.0 * s2 + 1.0) * s0[0]
                    + (s3 - 2.0 * s2 + s) * len * s0[1]
                    + (-2.0 * s3 + 3.0 * s2) * s1[0]
                    + (s3 - s2) * len * s1[1];
                self.u - x.abs()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The first exit within the step from s0 to s1 at refinement `level`, from its start.
    fn exit_within(
        &self,
        s0: [f64; 2],
        s1: [f64; 2],
        level: usize,
        rng: &mut Xoshiro256PlusPlus,
    ) -> Option<f64> {
        let len = self.h / f64::powi(2.0, level as i32);
        let Some(bridge) = self.bridges.get(level) else {
            return self.hermite_exit(s0, s1, len);
        };
        if self.margin(s0, s1, len) > K_SD * bridge.sd() {
            return None;
        }
        let mid = bridge.midpoint(s0, s1, rng);
        self.exit_within(s0, mid, level + 1, rng).or_else(|| {
            self.exit_within(mid, s1, level + 1, rng)
                .map(|t| t + 0.5 * len)
        })
    }

    /// One path's exit time from `start` (its own random stream).
    fn exit_time(&self, start: [f64; 2], seed: u64, path: u64) -> f64 {
        let mut rng =
            Xoshiro256PlusPlus::seed_from_u64(seed ^ path.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let [l11, l21, l22] = self.step_chol;
        let (mut s, mut t) = (start, 0.0);
        loop {
            let (z1, z2) = (normal(&mut rng), normal(&mut rng));
            let m = apply2(self.step.phi, s);
            let next = [m[0] + l11 * z1, m[1] + l21 * z1 + l22 * z2];
            if let Some(tau) = self.exit_within(s, next, 0, &mut rng) {
                return t + tau;
            }
            s = next;
            t += self.h;
            assert!(t < 1e6, "no exit by t = {t}");
        }
    }

    /// Exit times of `paths` paths (in parallel, in path order: the same numbers whatever
    /// the threads).
    fn exit_times(&self, start: [f64; 2], paths: u64, seed: u64) -> Vec<f64> {
        use rayon::prelude::*;
        (0..paths)
            .into_par_iter()
            .map(|p| self.exit_time(start, seed, p))
            .collect()
    }
}

/// Mean, its standard error, and R(t) = P(T > t) with its binomial standard error at `times`.
fn exit_statistics(exits: &[f64], times: &[f64]) -> (f64, f64, Vec<(f64, f64)>) {
    let n = exits.len() as f64;
    let mean = exits.iter().sum::<f64>() / n;
    let var = exits.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let r = times
        .iter()
        .map(|t| {
            let r = exits.iter().filter(|e| *e > t).count() as f64 / n;
            (r, (r * (1.0 - r) / n).sqrt())
        })
        .collect();
    (mean, (var / n).sqrt(), r)
}

/// The randomly accelerated particle x' = v, v' = ξ (σ = 1) between absorbing walls at
/// |x| = 1, from the centre at rest: its exit-time sampler (`ExitSampler`, k = c = 0).
fn random_acceleration_sampler(h: f64, levels: usize) -> ExitSampler {
    ExitSampler::new(0.0, 0.0, 1.0, 1.0, h, levels)
}

/// The times of R(t) checked for the randomly accelerated particle.
const RA_TIMES: [f64; 4] = [1.0, 2.0, 4.0, 6.0];

/// The reference for the randomly accelerated particle (σ = a = 1, centre at rest), from
/// `random_acceleration_reference` (ignored; it reproduces these numbers to the bit): 2^18
/// paths of `ExitSampler` at h = 0.01 refined to h/2^10, seed 2024. The mean exit time and
/// its standard error (0.12 %), R at `RA_TIMES` and their binomial standard errors. Steps of
/// 0.08, 0.02 and 0.005 (2^18 paths each, other seeds) agree within their standard errors:
/// 2.3107 ± 0.0028 at 0.02, 2.3110 ± 0.0028 at 0.005.
const RA_MEAN: (f64, f64) = (2.312577, 0.002819);
const RA_RELIABILITY: [(f64, f64); 4] = [
    (0.9172134399414063, 0.0005382018205959164),
    (0.45318603515625, 0.0009722727122040907),
    (0.11466598510742188, 0.0006223015997341411),
    (0.028385162353515625, 0.0003243566449019377),
];

/// The randomly accelerated particle's grid solve (box x in ±1.05, v in ±`vmax`), R(t) at
/// `times`.
fn random_acceleration_grid(
    cells: [usize; 2],
    vmax: f64,
    times: Vec<f64>,
) -> Result<PassageSolution, PassageError> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/models/random_acceleration.sde");
    let model = load_model(&path).unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    GridPassage::new(&bound, &safe)
        .cells(cells[0], cells[1])
        .domain(Domain {
            x: [-1.05, 1.05],
            v: [-vmax, vmax],
        })
        .times(times)
        .run()
}

/// The exact transition of the free particle (k = c = 0) by the RK4 substeps is the closed
/// form: Φ = [[1, h], [0, 1]], P = q [[h³/3, h²/2], [h²/2, h]]; its bridge's midpoint
/// variance of x given both ends is q h³/192.
#[test]
fn the_free_particle_transition_is_the_closed_form() {
    for h in [1e-4, 0.01, 0.3] {
        let t = transition(0.0, 0.0, 2.0, h);
        let exact = [[2.0 * h.powi(3) / 3.0, h * h], [h * h, 2.0 * h]];
        for (row, exact_row) in t.cov.iter().zip(&exact) {
            for (p, e) in row.iter().zip(exact_row) {
                assert!((p / e - 1.0).abs() < 1e-12, "{h}: {t:?}");
            }
        }
        assert!((t.phi[0][1] - h).abs() < 1e-14 && (t.phi[1][1] - 1.0).abs() < 1e-14);
        let b = Bridge::new(0.0, 0.0, 2.0, h);
        let var = b.sd().powi(2);
        assert!(
            (var / (2.0 * h.powi(3) / 192.0) - 1.0).abs() < 1e-9,
            "{h}: {var:e}"
        );
    }
}

/// The randomly accelerated particle x' = v, v' = ξ between absorbing walls |x| < 1 (the
/// issue's check case; no stationary density, so the box is given and the stationary
/// averages are `None`): the grid's mean exit time from the centre at rest at 100×200 and
/// 200×400 cells, and R(t) at four times at 60×120, against the independent reference
/// (`RA_MEAN`, `RA_RELIABILITY`) within the grid's stated error plus 3 of the reference's
/// standard errors. The box's velocity range, which the stated error does not see, is wide
/// enough: ±12 instead of ±8 (on cells of the same size) moves the mean by less than 1e−6
/// of it.
#[test]
fn the_randomly_accelerated_particle_against_its_reference() {
    let (mean, se) = RA_MEAN;
    for cells in [[100, 200], [200, 400]] {
        let g = random_acceleration_grid(cells, 8.0, vec![]).unwrap();
        let e = g.errors.as_ref().unwrap();
        println!(
            "{cells:?}: T {:.5} ± {:.2e} (reference {mean:.5} ± {se:.5}), {:.0} ms",
            g.mean_at_start, e.mean_at_start, g.report.total_ms
        );
        assert!(g.mean_stationary.is_none() && g.safe_mass.is_none());
        assert!(e.mean_stationary.is_none() && e.second_stationary.is_none());
        let gap = (g.mean_at_start - mean).abs();
        assert!(
            gap <= e.mean_at_start + 3.0 * se,
            "{cells:?}: grid {} ± {} vs reference {mean} ± {se}",
            g.mean_at_start,
            e.mean_at_start
        );
    }
    let wide = random_acceleration_grid([100, 300], 12.0, vec![]).unwrap();
    let narrow = random_acceleration_grid([100, 200], 8.0, vec![]).unwrap();
    println!(
        "v in ±12: T {:.8}, ±8: {:.8}",
        wide.mean_at_start, narrow.mean_at_start
    );
    assert!((wide.mean_at_start / narrow.mean_at_start - 1.0).abs() < 1e-6);
    let g = random_acceleration_grid([60, 120], 8.0, RA_TIMES.to_vec()).unwrap();
    let e = g.errors.as_ref().unwrap();
    for (k, (r, r_se)) in RA_RELIABILITY.iter().enumerate() {
        let (grid, stated) = (g.reliability[k], e.reliability[k]);
        println!(
            "t {}: R grid 60x120 {grid:.5} ± {stated:.1e}, reference {r:.5} ± {r_se:.1e}",
            RA_TIMES[k]
        );
        assert!(
            (grid - r).abs() <= stated + 3.0 * r_se,
            "t {}: grid {grid} ± {stated} vs reference {r} ± {r_se}",
            RA_TIMES[k]
        );
    }
}

/// Without a stationary density the grid needs its box, and a safe set that ends inside it
/// along x; paths that may rest inside the set for ever stay refused.
#[test]
fn a_model_without_a_stationary_density_needs_a_box_and_a_bounded_set() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/models/random_acceleration.sde");
    let model = load_model(&path).unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let err = GridPassage::new(&bound, &safe)
        .cells(40, 40)
        .run()
        .unwrap_err();
    assert!(matches!(err, PassageError::NoBox { .. }), "{err}");
    let open = model.with_safe("x < 1").unwrap();
    let open_safe = open.safe().unwrap().bind(&bound).unwrap();
    let err = GridPassage::new(&bound, &open_safe)
        .cells(40, 40)
        .domain(Domain {
            x: [-3.0, 1.05],
            v: [-8.0, 8.0],
        })
        .run()
        .unwrap_err();
    assert!(
        matches!(err, PassageError::NotBounded { edge, .. } if edge == -3.0),
        "{err}"
    );
    let still = fpsolve::model::parse_model(
        "model still\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
         diffusion v: x * xi\nsafe abs(x) < 1\n",
        None,
    )
    .unwrap();
    let bound = still.bind(&[]).unwrap();
    let safe = still.safe().unwrap().bind(&bound).unwrap();
    let err = GridPassage::new(&bound, &safe)
        .cells(40, 40)
        .domain(Domain {
            x: [-1.5, 1.5],
            v: [-3.0, 3.0],
        })
        .start([0.5, 0.0])
        .run()
        .unwrap_err();
    assert!(
        matches!(
            err,
            PassageError::Grid(fpsolve::grid::GridError::Inadmissible(
                fpsolve::dynamics::Inadmissible::VanishingDiffusionAtRest { .. }
            ))
        ),
        "{err}"
    );
}

/// Regenerates `RA_MEAN` and `RA_RELIABILITY` and shows the reference has no time-step trend:
/// steps h = 0.02, 0.01, 0.005 refined to about 1e-5; without refinement (the Hermite
/// interpolant between exact points only) the missed crossings bias the mean upwards.
#[test]
#[ignore = "about a minute on two cores: cargo test --release --test passage -- --ignored random_acceleration_reference"]
fn random_acceleration_reference() {
    let paths = 1 << 18;
    let mut at = Vec::new();
    for (h, levels, seed) in [
        (0.08, 13, 2022),
        (0.02, 11, 2023),
        (0.01, 10, 2024),
        (0.005, 9, 2025),
    ] {
        let exits = random_acceleration_sampler(h, levels).exit_times([0.0, 0.0], paths, seed);
        let (mean, se, r) = exit_statistics(&exits, &RA_TIMES);
        println!("h {h}, refined to h/2^{levels}, seed {seed}: T {mean:.6} ± {se:.6}, R {r:?}");
        at.push((h, mean, se, r));
    }
    for (h, levels) in [(0.08, 0), (0.01, 0), (0.0025, 0)] {
        let exits = random_acceleration_sampler(h, levels).exit_times([0.0, 0.0], paths, 7);
        let (mean, se, _) = exit_statistics(&exits, &RA_TIMES);
        println!("h {h}, not refined: T {mean:.6} ± {se:.6}");
    }
    // The constants are the h = 0.01 run's (the mean and its error to six decimals).
    let (_, mean, se, r) = &at[2];
    println!("const RA_MEAN: (f64, f64) = ({mean:.6}, {se:.6});");
    println!("const RA_RELIABILITY: [(f64, f64); 4] = {r:?};");
    let six = |x: f64| (x * 1e6).round() / 1e6;
    assert_eq!((six(*mean), six(*se)), RA_MEAN);
    assert_eq!(r.as_slice(), RA_RELIABILITY.as_slice());
    for (h, m, s, _) in &at {
        assert!(
            (m - mean).abs() < 3.0 * s.hypot(*se),
            "h {h}: {m} ± {s} vs {mean} ± {se}"
        );
    }
}

/// The exit sampler on the lightly damped oscillator (ζ = 0.05, |x| < 2.5σ, rest)
/// against the independent exact-transition Monte Carlo of the closing note (another
/// program: 175.10 ± 0.13 from 1.6e6 paths): a check of `ExitSampler` itself. Measured:
/// 174.86 ± 0.36 (2e5 paths, h = 0.05 refined to h/2^8, seed 5).
#[test]
#[ignore = "a few minutes: cargo test --release --test passage -- --ignored exit_sampler_on_the_linear"]
fn exit_sampler_on_the_linear_oscillator() {
    let u = 2.5 * 5f64.sqrt();
    let exits = ExitSampler::new(1.0, 0.1, 1.0, u, 0.05, 8).exit_times([0.0, 0.0], 200_000, 5);
    let (mean, se, _) = exit_statistics(&exits, &[]);
    println!("T {mean:.4} ± {se:.4} against 175.10 ± 0.13");
    assert!(
        (mean - 175.10).abs() < 3.0 * se.hypot(0.13),
        "{mean} ± {se}"
    );
}

/// The case: ζ = 0.05 (c = 0.1, k = 1), barrier |x| = 2.5σ with σ² = πK/(ck) = 5,
/// start at rest. The grid at two resolutions beside a Monte Carlo of 1e5 paths on the exact
/// transition: the finer grid within 3 standard errors plus its stated error.
#[test]
#[ignore = "about a minute: cargo test --release --test passage -- --ignored"]
fn lightly_damped_oscillator_against_monte_carlo() {
    let c = 0.1;
    let u = 2.5 * 5f64.sqrt();
    let safe = format!("abs(z) < {u}");
    let coarse = passage(c, &safe, [100, 200], vec![]);
    let fine = passage(c, &safe, [200, 400], vec![]);
    let (mc, se, mc2) = monte_carlo(c, u, 0.05, 100_000, 35);
    println!(
        "grid 100x200: T {:.4}, T2 {:.2}; 200x400: T {:.4}, T2 {:.2}, stationary-start T {:.4}; \
         MC 1e5: T {mc:.4} ± {se:.4}, T2 {mc2:.2}",
        coarse.mean_at_start,
        coarse.second_at_start,
        fine.mean_at_start,
        fine.second_at_start,
        fine.mean_stationary.unwrap()
    );
    // Within 3 standard errors plus the grid's own stated error (no allowance beyond: an
    // independent Monte Carlo of 1.6e6 paths gives 175.10 ± 0.13, the grid 175.24 at 400×800).
    let stated = fine.errors.as_ref().unwrap().mean_at_start;
    assert!(
        (fine.mean_at_start - mc).abs() < 3.0 * se + stated,
        "grid {} ± {stated} vs MC {mc} ± {se}",
        fine.mean_at_start
    );
}

/// A strongly damped case (c = 1) small enough to run always: grid at 80x160 against 2e4
/// Monte Carlo paths within 4 standard errors plus 2 %.
#[test]
fn damped_oscillator_against_monte_carlo() {
    let (c, u) = (1.0, 1.2);
    let g = passage(c, &format!("abs(z) < {u}"), [80, 160], vec![]);
    let (mc, se, _) = monte_carlo(c, u, 0.02, 20_000, 7);
    println!("grid T {:.4} vs MC {mc:.4} ± {se:.4}", g.mean_at_start);
    assert!((g.mean_at_start - mc).abs() < 4.0 * se + 0.02 * mc);
}

/// A `safe` line may name observables (their definitions are substituted) and parameters.
#[test]
fn the_safe_line_reads_observables_and_parameters() {
    let text = "model m\nparam c = 0.1, e0 = 3\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
                noise xi: intensity 1\ndiffusion v: xi\nobserve energy = v^2/2 + z^2/2\n\
                safe energy < e0\n";
    let model = fpsolve::model::parse_model(text, None).unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    assert_eq!(safe.upper, Some(3.0));
    assert_eq!(safe.quantity_at([1.0, 2.0]), 2.5);
    assert!(safe.contains([1.0, 2.0]) && !safe.contains([2.0, 2.0]));
    // `--safe` replaces it; its errors point into the flag's text.
    let err = model.with_safe("-1 < z < 2 +").unwrap_err();
    assert_eq!(err.line(), Some(1));
    assert!(err.to_string().contains("--safe"), "{err}");
    let empty = model.with_safe("2 < z < 1").unwrap();
    assert!(empty.safe().unwrap().bind(&bound).is_err());
}

fn fpsolve(args: &[&str]) -> (Option<i32>, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args(args)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    (out.status.code(), text)
}

/// `fpsolve reliability` refuses a start outside the set and a model without one (exit 2),
/// under its former name `passage` too, and writes R(t) from 1 down with the mean in
/// summary.json, into out/<model>_reliability by default.
#[test]
fn the_reliability_command_checks_then_writes() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    for command in ["reliability", "passage"] {
        let (code, text) = fpsolve(&[command, model, "--safe", "abs(z) < 2", "--start", "3,0"]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("not inside the safe set"), "{text}");
        let (code, text) = fpsolve(&[command, model]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("no safe set"), "{text}");
        let (code, text) = fpsolve(&[command, model, "--safe", "abs(w) < 2"]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains("--safe:1:5"), "{text}");
    }
    let cwd = std::env::temp_dir().join(format!("fpsolve_reliability_{}", std::process::id()));
    std::fs::create_dir_all(&cwd).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fpsolve"))
        .args([
            "reliability",
            model,
            "--safe",
            "abs(z) < 2",
            "--cells",
            "40,40",
            "--times",
            "0:20:5",
            "--method",
            "grid",
            "--quiet",
        ])
        .current_dir(&cwd)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let dir = cwd.join("out/linear_reliability");
    let csv = std::fs::read_to_string(dir.join("reliability.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 5);
    assert_eq!(rows[0][1], 1.0);
    assert!(rows[4][1] < rows[1][1]);
    assert!(!dir.join("passage.csv").exists() && !dir.join("first_passage_pdf.csv").exists());
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(summary.contains("\"mean_at_start\""), "{summary}");
    assert!(!summary.contains("\"unwritten\""), "{summary}");
    for stem in ["reliability", "first_passage_pdf"] {
        for ext in ["png", "svg"] {
            let size = std::fs::metadata(dir.join(format!("{stem}.{ext}")))
                .unwrap()
                .len();
            assert!(size > 1000, "{stem}.{ext}: {size} bytes");
        }
    }
    std::fs::remove_dir_all(&cwd).unwrap();
}

/// The files of a run, by name, but the run marker (the command line as typed) and
/// `summary.json` without what differs between two runs of one command line (its provenance,
/// the command, the wall times).
fn files_of(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut files = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name == fpsolve::report::MARKER {
            continue;
        }
        let mut bytes = std::fs::read(&path).unwrap();
        if name == "summary.json" {
            let mut json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            let map = json.as_object_mut().unwrap();
            map.remove("provenance");
            map.remove("command");
            if let Some(report) = map.get_mut("grid").and_then(|g| g.get_mut("report")) {
                report.as_object_mut().unwrap().remove("total_ms");
            }
            if let Some(s) = map.get_mut("stationary").and_then(|s| s.as_object_mut()) {
                s.remove("grid_ms");
                if let Some(mc) = s.get_mut("mc").and_then(|m| m.as_object_mut()) {
                    mc.remove("wall_ms");
                }
            }
            bytes = serde_json::to_vec(&json).unwrap();
        }
        files.insert(name, bytes);
    }
    files
}

/// Both methods: `reliability.csv`, Monte Carlo's histogram in `first_passage_pdf.csv`
/// (each bin's mass what R_mc loses over it), both figures; `fpsolve passage` writes the
/// same files, to the byte but for summary.json's provenance and command line.
#[test]
fn the_former_name_writes_the_same_files() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = std::env::temp_dir().join(format!("fpsolve_alias_{}", std::process::id()));
    let mut runs = Vec::new();
    for command in ["reliability", "passage"] {
        let dir = base.join(command);
        let (code, text) = fpsolve(&[
            command,
            model,
            "--safe",
            "abs(z) < 1.2",
            "--set",
            "c=1",
            "--cells",
            "40,60",
            "--times",
            "0:6:7",
            "--paths",
            "512",
            "--dt",
            "0.02",
            "--out",
            dir.to_str().unwrap(),
            "--quiet",
        ]);
        assert_eq!(code, Some(0), "{command}: {text}");
        runs.push(files_of(&dir));
    }
    let names: Vec<&str> = runs[0].keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "crossings_y.csv",
            "crossings_y.png",
            "crossings_y.svg",
            "crossings_z.csv",
            "crossings_z.png",
            "crossings_z.svg",
            "first_passage_pdf.csv",
            "first_passage_pdf.png",
            "first_passage_pdf.svg",
            "quasi_stationary_v.csv",
            "quasi_stationary_z.csv",
            "reliability.csv",
            "reliability.png",
            "reliability.svg",
            "summary.json",
        ]
    );
    for (name, bytes) in &runs[0] {
        assert!(bytes.len() > 100, "{name}: {} bytes", bytes.len());
        assert!(
            runs[1][name] == *bytes,
            "{name} differs between the two names"
        );
    }
    let table = |name: &str| -> Vec<Vec<f64>> {
        String::from_utf8(runs[0][name].clone())
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect()
    };
    let pdf = String::from_utf8(runs[0]["first_passage_pdf.csv"].clone()).unwrap();
    assert!(
        pdf.starts_with("t_lo,t_hi,t_mid,pdf_mc,pdf_mc_se\n"),
        "{pdf}"
    );
    let (r, bins) = (table("reliability.csv"), table("first_passage_pdf.csv"));
    assert_eq!((r.len(), bins.len()), (7, 6));
    // Columns t,R_grid,pdf_grid,R_grid_err,R_mc,...: bin k spans rows k and k + 1.
    for (k, b) in bins.iter().enumerate() {
        assert_eq!((b[0], b[1]), (r[k][0], r[k + 1][0]));
        let lost = r[k][4] - r[k + 1][4];
        assert!((b[3] * (b[1] - b[0]) - lost).abs() < 1e-12, "bin {k}");
        assert!(b[4] >= 0.0);
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// A run without output times gets R(t) at 101 times to 5 of the grid's mean times, and
/// draws it (before, it had nothing to draw and skipped the figures with a warning); Monte
/// Carlo alone draws both at its times.
#[test]
fn a_run_without_times_gets_r_to_five_mean_times() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = std::env::temp_dir().join(format!("fpsolve_nofig_{}", std::process::id()));
    let dir = base.join("grid");
    let (code, text) = fpsolve(&[
        "reliability",
        model,
        "--safe",
        "abs(z) < 2",
        "--cells",
        "40,40",
        "--method",
        "grid",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    assert!(!text.contains("was not written"), "{text}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert!(summary.get("unwritten").is_none(), "{summary}");
    let mean = summary["grid"]["mean_at_start"].as_f64().unwrap();
    let times = summary["grid"]["times"].as_array().unwrap();
    assert_eq!(times.len(), 101);
    assert_eq!(times[0].as_f64(), Some(0.0));
    assert!((times[100].as_f64().unwrap() - 5.0 * mean).abs() < 1e-9 * mean);
    let csv = std::fs::read_to_string(dir.join("reliability.csv")).unwrap();
    assert_eq!(csv.lines().count(), 102);
    for file in ["reliability.png", "first_passage_pdf.svg"] {
        assert!(
            std::fs::metadata(dir.join(file)).unwrap().len() > 100,
            "{file}"
        );
    }
    let dir = base.join("mc");
    let (code, text) = fpsolve(&[
        "reliability",
        model,
        "--safe",
        "abs(z) < 1.2",
        "--set",
        "c=1",
        "--method",
        "mc",
        "--times",
        "0:10:6",
        "--paths",
        "256",
        "--dt",
        "0.02",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    assert!(!text.contains("was not written"), "{text}");
    for file in [
        "reliability.png",
        "first_passage_pdf.svg",
        "first_passage_pdf.csv",
    ] {
        assert!(
            std::fs::metadata(dir.join(file)).unwrap().len() > 100,
            "{file}"
        );
    }
    std::fs::remove_dir_all(&base).unwrap();
}

/// fpsolve's own first-passage Monte Carlo (`McPassage`, the stationary kernel's steps with
/// the exit located in the step) against the independent exact-transition Monte Carlo above
/// and the grid, on the strongly damped case: the means within 4 combined standard errors
/// plus the estimated time-step bias, R(t) within its 95 % band (widened by the grid's
/// 2 %) at a few times, the seed reproducing the exit statistics bit for bit.
#[test]
fn passage_monte_carlo_agrees_with_the_exact_transition_and_the_grid() {
    let (c, u) = (1.0, 1.2);
    let (model, set) = linear(c, &format!("abs(z) < {u}"));
    let bound = model.bind(&set).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let times = vec![1.0, 3.0, 6.0, 10.0];
    let run = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(4096)
        .dt(0.02)
        .horizon(200.0)
        .times(times.clone())
        .seed(11);
    let r = run.run().unwrap();
    assert_eq!((r.censored, r.blowups), (0, 0));
    let m = r.mean.unwrap();
    let (exact, se, _) = monte_carlo(c, u, 0.02, 8_000, 7);
    let g = passage(c, &format!("abs(z) < {u}"), [80, 160], times.clone());
    println!(
        "McPassage T {:.4} ± {:.4} (bias {:.4} ± {:.4}), Var T {:.3} ± {:.3}; exact-transition MC \
         {exact:.4} ± {se:.4}; grid {:.4}",
        m.value,
        m.stderr,
        r.bias.value,
        r.bias.stderr,
        r.variance.unwrap().value,
        r.variance.unwrap().stderr,
        g.mean_at_start
    );
    let tol = 4.0 * m.stderr.hypot(se) + r.bias.value.abs() + 2.0 * r.bias.stderr;
    assert!((m.value - exact).abs() < tol, "{} vs {exact}", m.value);
    assert!((m.value - g.mean_at_start).abs() < 4.0 * m.stderr + 0.02 * g.mean_at_start);
    for (k, t) in times.iter().enumerate() {
        let (lo, hi, grid) = (r.reliability_lo[k], r.reliability_hi[k], g.reliability[k]);
        println!(
            "t {t}: MC R {:.4} [{lo:.4}, {hi:.4}], grid {grid:.4}",
            r.reliability[k]
        );
        assert!(lo - 0.02 <= grid && grid <= hi + 0.02, "t {t}: grid {grid}");
    }
    let again = run.run().unwrap();
    assert_eq!(again.mean, r.mean);
    assert_eq!(again.reliability, r.reliability);
}

/// The Monte Carlo paths carry the time: under the force cos(t) from rest (noise of
/// intensity 1e-12, so every path is the deterministic one) z(t) = 1 − cos t leaves
/// |z| < 1.5 at t = 2π/3, where a force frozen at t = 0 would give √3. Measured: 2.094403
/// at dt = 0.01 (2π/3 = 2.094395), bias estimate −2.2e−5.
#[test]
fn passage_monte_carlo_follows_a_time_dependent_force() {
    let model = fpsolve::model::parse_model(
        "model forced\nstate z, v\ndrift z: v\ndrift v: cos(t)\nnoise xi: intensity 1e-12\n\
         diffusion v: xi\nsafe abs(z) < 1.5\n",
        None,
    )
    .unwrap();
    let bound = model.bind(&[]).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let r = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(256)
        .dt(0.01)
        .horizon(5.0)
        .run()
        .unwrap();
    let m = r.mean.unwrap();
    let exact = 2.0 * std::f64::consts::PI / 3.0;
    println!(
        "T {:.6} ± {:.1e}, bias {:.1e}; exact {exact:.6}",
        m.value, m.stderr, r.bias.value
    );
    assert!((m.value - exact).abs() < 1e-4, "{} vs {exact}", m.value);
}

/// Censored paths: the mean is not reported, only its lower bound, and R at the horizon is
/// the censored fraction.
#[test]
fn passage_monte_carlo_flags_censoring() {
    let (model, set) = linear(1.0, "abs(z) < 1");
    let bound = model.bind(&set).unwrap();
    let safe = model.safe().unwrap().bind(&bound).unwrap();
    let r = fpsolve::mc::McPassage::new(&bound, &safe)
        .paths(256)
        .dt(0.02)
        .horizon(3.0)
        .times(vec![3.0])
        .run()
        .unwrap();
    println!(
        "censored {} of {}, min(T, 3) {:.4}",
        r.censored, r.paths, r.mean_lower_bound.value
    );
    assert!(r.censored > 0 && r.censored < r.paths);
    assert!(r.mean.is_none() && r.variance.is_none());
    assert_eq!(r.reliability[0], r.censored_fraction);
    assert!(r.mean_lower_bound.value < 3.0);
}

/// `--method mc`'s flags are checked before any work (exit 2, naming the flag); a run of both
/// methods writes the Monte Carlo's columns beside the grid's and the distance in standard
/// errors.
#[test]
fn the_reliability_command_runs_monte_carlo_beside_the_grid() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = [
        "reliability",
        model,
        "--safe",
        "abs(z) < 1.2",
        "--set",
        "c=1",
    ];
    for (flags, says) in [
        (&["--paths", "1"][..], "--paths"),
        (&["--dt=-1"][..], "--dt"),
        (&["--horizon", "nan"][..], "--horizon"),
        (&["--seed", "x"][..], "--seed"),
        (&["--method", "mc"][..], "--horizon"),
        (&["--method", "grid,pde"][..], "--method"),
    ] {
        let args: Vec<&str> = base.iter().chain(flags).copied().collect();
        let (code, text) = fpsolve(&args);
        assert_eq!(code, Some(2), "{flags:?}: {text}");
        assert!(text.contains(says), "{flags:?}: {text}");
    }
    let dir = std::env::temp_dir().join(format!("fpsolve_passage_mc_{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let args: Vec<&str> = base
        .iter()
        .chain(&[
            "--cells",
            "40,60",
            "--times",
            "0:6:4",
            "--paths",
            "512",
            "--dt",
            "0.02",
            "--horizon",
            "100",
            "--out",
            out,
            "--quiet",
        ])
        .copied()
        .collect();
    let (code, text) = fpsolve(&args);
    assert_eq!(code, Some(0), "{text}");
    let csv = std::fs::read_to_string(dir.join("reliability.csv")).unwrap();
    assert!(
        csv.starts_with("t,R_grid,pdf_grid,R_grid_err,R_mc,R_mc_lo95,R_mc_hi95\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 5);
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    // The provenance block opens it, as every result file (issue 37).
    assert!(
        summary.trim_start().starts_with("{\n  \"provenance\": {"),
        "{summary}"
    );
    for key in [
        "\"schema_version\"",
        "\"created\"",
        "\"threads\"",
        "\"text\"",
    ] {
        assert!(summary.contains(key), "{key}: {summary}");
    }
    for key in [
        "\"mc\"",
        "\"censored_fraction\"",
        "\"grid_vs_mc_se\"",
        "\"bias\"",
    ] {
        assert!(summary.contains(key), "{key}: {summary}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--mean-only`: the mean times alone, in `summary.json` (which says what was not computed
/// and why) and no other file; the grid's mean times and their errors are those of the full
/// run on the same cells to the bit (the same solves, without R(t), the decay and the
/// stationary study), and Monte Carlo's mean is the full run's (the same paths: the output
/// times do not draw from the streams).
#[test]
fn the_mean_times_alone() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    let base = std::env::temp_dir().join(format!("fpsolve_mean_only_{}", std::process::id()));
    let args = |dir: &std::path::Path| -> Vec<String> {
        [
            "reliability",
            model,
            "--safe",
            "abs(z) < 1.2",
            "--set",
            "c=1",
            "--cells",
            "40,60",
            "--paths",
            "256",
            "--dt",
            "0.02",
            "--horizon",
            "40",
            "--out",
            dir.to_str().unwrap(),
            "--quiet",
        ]
        .map(String::from)
        .to_vec()
    };
    let (means, full) = (base.join("means"), base.join("full"));
    let mut a = args(&means);
    a.push("--mean-only".into());
    let (code, text) = fpsolve(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("not computed (the run asked for the mean first-passage times only)"),
        "{text}"
    );
    let (code, text) = fpsolve(&args(&full).iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, Some(0), "{text}");
    let written = files_of(&means);
    assert_eq!(
        written.keys().map(String::as_str).collect::<Vec<_>>(),
        ["summary.json"]
    );
    let json = |dir: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
    };
    let (m, f) = (json(&means), json(&full));
    assert_eq!(m["scope"], "mean_times");
    assert_eq!(f["scope"], "full");
    assert!(f.get("not_computed").is_none(), "{f}");
    let parts: Vec<(&str, &str)> = m["not_computed"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| (n["what"].as_str().unwrap(), n["why"].as_str().unwrap()))
        .collect();
    assert_eq!(
        parts,
        [
            ("reliability", "mean_times_only"),
            ("decay", "mean_times_only"),
            ("stationary_statistics", "mean_times_only")
        ]
    );
    let g = &m["grid"];
    assert_eq!(g["decay"]["status"], "not_computed");
    assert!(g["integral_of_reliability"].is_null());
    assert_eq!(g["times"].as_array().unwrap().len(), 0);
    assert_eq!(m["stationary"]["status"], "not_computed");
    assert!(m.get("crossings").is_none() && m.get("impacts").is_none());
    for key in [
        "mean_at_start",
        "second_at_start",
        "mean_from_start_cell",
        "mean_stationary",
        "second_stationary",
        "safe_mass",
    ] {
        assert!(g[key].as_f64().unwrap() > 0.0, "{key}");
        assert_eq!(g[key], f["grid"][key], "{key}");
    }
    for key in [
        "mean_at_start",
        "second_at_start",
        "mean_stationary",
        "second_stationary",
    ] {
        assert_eq!(g["errors"][key], f["grid"]["errors"][key], "{key}");
    }
    assert!(g["errors"]["rate"].is_null() && f["grid"]["errors"]["rate"].as_f64().is_some());
    for key in ["mean", "variance", "mean_lower_bound", "bias", "censored"] {
        assert_eq!(m["mc"][key], f["mc"][key], "mc {key}");
    }
    assert_eq!(m["mc"]["times"].as_array().unwrap().len(), 0);
    let d = &m["method_distances"];
    assert_eq!(
        d["mean_at_start"]["distance"],
        f["method_distances"]["mean_at_start"]["distance"]
    );
    std::fs::remove_dir_all(&base).unwrap();
}
