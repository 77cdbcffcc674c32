//! Monte Carlo on the general schemes (Platen's weak order 2, Heun) with reflecting walls and
//! noise that depends on the velocity, against the exact stationary density.
//!
//! The oscillator z'' + ζ z' + κ z'³ + z + μ z³ = ξ(t) + z' η(t) (Stratonovich) has, with
//! ζ = κ s₁/s₃ − s₃/2, the exact density p ∝ exp(−(v²/2 + z²/2 + μ z⁴/4))
//! (`models/cubic_damping_two_noises.sde`). An elastic wall (r = 1) keeps it, restricted to the
//! wall's side: z has the restricted quartic law, v stays standard normal. The same Itô
//! diffusion s₁ + s₃ v² comes from one source entering as √(s₁ + s₃ v²)·ξ, which the
//! automatic scheme runs by Heun's scheme instead of Platen's.
//!
//! A velocity that changes sign within a step at the wall once put the trajectory on the far
//! side of it (1.8 % of the samples of the lower-wall case, E[z] 10 standard errors off):
//! here no sample is outside the domain, and every bin and moment meets the exact law.

mod common;

use common::simpson;
use fpsolve::mc::{Grid, McConfig, SchemeChoice, Simulation};
use fpsolve::model::{parse_model, BoundModel};

const MU: f64 = 0.5;

/// The two-noise model (Platen's scheme) with the walls `domain`.
fn two_noises(domain: &str) -> BoundModel {
    model("diffusion v: xi + v*eta\nnoise eta: intensity s3", domain)
}

/// The one-source model of the same Itô diffusion (Heun's scheme) with the walls `domain`.
fn one_source(domain: &str) -> BoundModel {
    model("diffusion v: sqrt(s1 + s3*v^2)*xi", domain)
}

fn model(noise: &str, walls: &str) -> BoundModel {
    let text = format!(
        "model walls \"cubic damping, velocity-dependent noise, elastic walls\"\n\
         param mu = {MU}, kappa = 0.1, s1 = 1, s3 = 0.2, r = 1\n\
         param zeta = kappa*s1/s3 - s3/2\n\
         state z, v\n\
         drift z: v\n\
         drift v: -z - mu*z^3 - zeta*v - kappa*v^3\n\
         noise xi: intensity s1\n\
         {noise}\n\
         interpretation: stratonovich\n\
         {walls}\n"
    );
    parse_model(&text, None).unwrap().bind(&[]).unwrap()
}

/// The exact law of z on `[lo, hi]`: its mass on each bin of `edges`, its mean and variance
/// (composite Simpson on a fine grid; the integrand is smooth and bounded).
fn exact_z(lo: f64, hi: f64, edges: &[f64]) -> (Vec<f64>, f64, f64) {
    let f = |z: f64| (-(z * z / 2.0 + MU * z.powi(4) / 4.0)).exp();
    let integrate = |a: f64, b: f64, g: &dyn Fn(f64) -> f64| simpson(g, a, b, 2000);
    let (a, b) = (lo.max(-8.0), hi.min(8.0));
    let norm = integrate(a, b, &f);
    let mean = integrate(a, b, &|z| z * f(z)) / norm;
    let var = integrate(a, b, &|z| (z - mean).powi(2) * f(z)) / norm;
    let masses = edges
        .windows(2)
        .map(|e| integrate(e[0].max(a), e[1].min(b), &f) / norm)
        .collect();
    (masses, mean, var)
}

/// Runs `bound` by `scheme` and checks the samples against the exact law on `[lo, hi]`.
fn check(label: &str, bound: &BoundModel, scheme: SchemeChoice, lo: f64, hi: f64) {
    let (a, b) = (lo.max(-3.0), hi.min(3.0));
    let zg = Grid::new(a, b, 24).unwrap();
    let vg = Grid::new(-4.0, 4.0, 32).unwrap();
    let config = McConfig {
        trajectories: 2048,
        samples: 600,
        seed: 5,
        scheme,
        grids: vec![("z".into(), zg), ("v".into(), vg)],
        ..McConfig::default()
    };
    let res = Simulation::new(bound, &config).unwrap().run().unwrap();
    let impacts = res.impacts.as_ref().unwrap();
    assert!(impacts.rate.value > 0.05, "{label}: {impacts:?}");
    let z = res.quantity("z").unwrap();
    // Not one sample outside the domain (the histogram's window is the domain where it is
    // finite), and none on the far side of a wall.
    assert!(
        z.min >= lo && z.max <= hi,
        "{label}: z in [{}, {}]",
        z.min,
        z.max
    );
    if lo.is_finite() {
        assert_eq!(z.underflow, 0, "{label}");
    }
    if hi.is_finite() {
        assert_eq!(z.overflow, 0, "{label}");
    }
    let edges: Vec<f64> = (0..=zg.bins).map(|j| a + j as f64 * zg.width()).collect();
    let (masses, mean, var) = exact_z(lo, hi, &edges);
    let mut worst = 0.0f64;
    for (j, &m) in masses.iter().enumerate() {
        if m > 1e-3 {
            let t = (z.density[j] - m / zg.width()) / z.stderr[j];
            worst = worst.max(t.abs());
        }
    }
    let tm = (z.moments.mean.value - mean) / z.moments.mean.stderr;
    let tv = (z.moments.variance.value - var) / z.moments.variance.stderr;
    let v = res.quantity("v").unwrap();
    let tvm = v.moments.mean.value / v.moments.mean.stderr;
    let tvv = (v.moments.variance.value - 1.0) / v.moments.variance.stderr;
    println!(
        "{label}: E[z] {:.5} (exact {mean:.5}, {tm:+.1} se), Var z {:.5} (exact {var:.5}, \
         {tv:+.1} se), E[v] {tvm:+.1} se, Var v {tvv:+.1} se, worst bin {worst:.1} se, folded {}",
        z.moments.mean.value, z.moments.variance.value, impacts.folded
    );
    for (what, t) in [
        ("E[z]", tm),
        ("Var z", tv),
        ("E[v]", tvm),
        ("Var v", tvv),
        ("worst bin", worst),
    ] {
        assert!(t.abs() < 5.0, "{label}: {what} {t:.1} standard errors");
    }
}

#[test]
fn platen_keeps_every_sample_behind_a_lower_wall() {
    let m = two_noises("impact z = -0.4: v -> -r*v\ndomain z >= -0.4");
    check("platen, lower", &m, SchemeChoice::Auto, -0.4, f64::INFINITY);
}

#[test]
fn platen_keeps_every_sample_behind_an_upper_wall() {
    let m = two_noises("impact z = 0.4: v -> -r*v\ndomain z <= 0.4");
    check(
        "platen, upper",
        &m,
        SchemeChoice::Auto,
        f64::NEG_INFINITY,
        0.4,
    );
}

#[test]
fn platen_keeps_every_sample_inside_a_strip() {
    let m = two_noises(
        "impact z = -0.4: v -> -r*v\nimpact z = 0.6: v -> -r*v\ndomain -0.4 <= z <= 0.6",
    );
    check("platen, strip", &m, SchemeChoice::Auto, -0.4, 0.6);
}

#[test]
fn heun_keeps_every_sample_behind_its_walls() {
    let lower = one_source("impact z = -0.4: v -> -r*v\ndomain z >= -0.4");
    check(
        "heun, lower",
        &lower,
        SchemeChoice::Auto,
        -0.4,
        f64::INFINITY,
    );
    let strip = one_source(
        "impact z = -0.4: v -> -r*v\nimpact z = 0.6: v -> -r*v\ndomain -0.4 <= z <= 0.6",
    );
    check("heun, strip", &strip, SchemeChoice::Auto, -0.4, 0.6);
}
