//! The bin averages every distance to Monte Carlo is computed from are exact where the
//! density has an integrable singularity. On the linear oscillator EPC n = 2 is exact (z and
//! v independent Gaussians), so `vsq = v^2` is the scaled χ²₁ law (u^(−1/2) at 0) and
//! `zv = z*v` the product law (a log singularity at 0, the saddle value of z·v): each bin
//! mean the study reports must be the exact law's mass in the bin over its width, from a
//! smooth integral of the Gaussians.

use std::f64::consts::PI;

use fpsolve::mc::Grid;
use fpsolve::model::parse_model;
use fpsolve::observe::integrate_adaptive;
use fpsolve::solve::{MethodName, Problem, Quantity};
use fpsolve::study::StudyRunner;

/// Var v = I/(2c) = 2.5 and Var z = Var v / k = 2.5 for c = 0.2, k = 1, I = 1.
const VARIANCE: f64 = 2.5;

const MODEL: &str = "model linear\nparam c = 0.2, k = 1\nstate z, v\ndrift z: v\n\
                     drift v: -c*v - k*z\nnoise xi: intensity 1\ndiffusion v: xi\n\
                     observe vsq = v^2\nobserve zv = z*v\n";

fn phi(t: f64) -> f64 {
    (-t * t / (2.0 * VARIANCE)).exp() / (2.0 * PI * VARIANCE).sqrt()
}

/// P(a < v² < b) = 2 ∫_{√a}^{√b} φ.
fn chi2_mass(a: f64, b: f64) -> f64 {
    if b <= 0.0 {
        return 0.0;
    }
    2.0 * integrate_adaptive(&phi, a.max(0.0).sqrt(), b.sqrt(), 1e-12)
}

/// P(a < z·v < b) = 2 ∫₀^∞ φ(z) P(a/z < v < b/z) dz (z < 0 gives the same by symmetry).
fn product_mass(a: f64, b: f64) -> f64 {
    let inner = |z: f64| {
        if z <= 0.0 {
            return if a < 0.0 && b > 0.0 { phi(0.0) } else { 0.0 };
        }
        let (lo, hi) = ((a / z).max(-60.0), (b / z).min(60.0));
        if lo >= hi {
            return 0.0;
        }
        phi(z) * integrate_adaptive(&phi, lo, hi, 1e-12)
    };
    let s = VARIANCE.sqrt();
    2.0 * integrate_adaptive(&inner, 0.0, 40.0 * s, 1e-12)
}

#[test]
fn bin_means_of_singular_observables_are_their_exact_bin_masses() {
    let bound = parse_model(MODEL, None).unwrap().bind(&[]).unwrap();
    let problem = Problem::new(&bound).unwrap();
    let choose = |_: &Quantity, x: &[f64]| Grid::new(x[0], x[x.len() - 1], 100).ok();
    let study = StudyRunner::of(&problem)
        .curves_of(&["vsq".to_string(), "zv".to_string()])
        .degrees(&[2])
        .methods(&[MethodName::Epc])
        .bins(&choose)
        .run()
        .unwrap();
    let mut failures = Vec::new();
    for curve in &study.curves {
        let exact: &dyn Fn(f64, f64) -> f64 = match curve.name.as_str() {
            "vsq" => &chi2_mass,
            "zv" => &product_mass,
            _ => continue,
        };
        let grid = curve.bins.expect("bins were asked for");
        let means = &curve.columns[0].bin_means;
        let w = grid.width();
        let mut l1 = 0.0;
        for (b, m) in means.iter().enumerate() {
            let (lo, hi) = (grid.lo + b as f64 * w, grid.lo + (b + 1) as f64 * w);
            let want = exact(lo, hi) / w;
            l1 += (m - want).abs() * w;
            if (m - want).abs() > 1e-9 * want.max(1e-3) {
                failures.push(format!(
                    "{} bin {b} [{lo}, {hi}]: {m} against {want}",
                    curve.name
                ));
            }
        }
        eprintln!(
            "{}: grid [{}, {}], L1 of the bin means to the exact law {l1:.2e}",
            curve.name, grid.lo, grid.hi
        );
        if l1 > 1e-9 {
            failures.push(format!("{}: L1 {l1}", curve.name));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
