//! The grid on a periodic state (`domain theta periodic 2*pi`) against exact stationary
//! densities: a pendulum under additive noise (an energy density, von Mises in the angle)
//! and an overdamped rotor driven past its potential barrier by a constant torque (a
//! density with a probability current around the circle, exact by Stratonovich's formula),
//! both at a requested tolerance; the estimate must cover the true error.

use fpsolve::grid::{GridSolution, GridSolver};
use fpsolve::model::{parse_model, BoundModel};
use std::f64::consts::PI;

fn bound(text: &str) -> BoundModel {
    parse_model(text, None).unwrap().bind(&[]).unwrap()
}

/// Cell masses of `density` on cells of `width` around `centres`, by Simpson's rule on 64
/// intervals per cell.
fn cell_masses(centres: &[f64], width: f64, density: &dyn Fn(f64) -> f64) -> Vec<f64> {
    const FINE: usize = 64;
    centres
        .iter()
        .map(|&c| {
            let (a, h) = (c - 0.5 * width, width / FINE as f64);
            // Simpson on FINE (even) intervals.
            let mut s = density(a) + density(a + width);
            for k in 1..FINE {
                s += density(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            s * h / 3.0
        })
        .collect()
}

/// L1 distance between the solution's marginal of `axis` and the exact cell masses.
fn l1(sol: &GridSolution, axis: usize, density: &dyn Fn(f64) -> f64) -> f64 {
    let m = sol.marginal(axis);
    let exact = cell_masses(&m.centres, m.width, density);
    m.density
        .iter()
        .zip(&exact)
        .map(|(p, e)| (p * m.width - e).abs())
        .sum()
}

fn gaussian(var: f64) -> impl Fn(f64) -> f64 {
    move |x: f64| (-x * x / (2.0 * var)).exp() / (2.0 * PI * var).sqrt()
}

/// Checks both marginals against `exact` at tolerance `tol`: the tolerance reached, the
/// true L1 under the stated estimate and under the tolerance, the x range one period.
fn check(model: &BoundModel, tol: f64, exact: [&dyn Fn(f64) -> f64; 2]) {
    let sol = GridSolver::new(model).tolerance(tol).solve().unwrap();
    let est = sol.report.discretisation_estimate.unwrap();
    assert_eq!(sol.report.domain.x, [-PI, PI]);
    for (axis, stated) in [(0, est.x), (1, est.v)] {
        let err = l1(&sol, axis, exact[axis]);
        eprintln!(
            "axis {axis}: cells {:?}, true L1 {err:.3e}, stated {stated:.3e}",
            sol.report.cells
        );
        assert!(
            err <= stated && stated <= tol,
            "axis {axis}: true L1 {err:.3e}, stated {stated:.3e}, tolerance {tol:e}, cells {:?}",
            sol.report.cells
        );
    }
}

/// θ' = w, w' = −c w − k sin θ + ξ, intensity S: p ∝ exp(−(2c/S)(w²/2 + k(1 − cos θ))),
/// von Mises in θ with κ = 2ck/S, Gaussian in w with variance S/(2c).
#[test]
fn a_pendulum_has_the_von_mises_angle() {
    let (c, k, s) = (0.5, 2.0, 0.5);
    let model = bound(&format!(
        "model pendulum\nparam c = {c}, k = {k}, S = {s}\nstate theta, w\ndrift theta: w\n\
         drift w: -c*w - k*sin(theta)\nnoise xi: intensity S\ndiffusion w: xi\n\
         domain theta periodic 2*pi\n"
    ));
    let kappa = 2.0 * c * k / s;
    // 2π I0(κ) by the trapezoid rule, spectrally accurate for a periodic integrand.
    let n = 4096;
    let norm: f64 = (0..n)
        .map(|i| (kappa * (-PI + 2.0 * PI * i as f64 / n as f64).cos()).exp())
        .sum::<f64>()
        * 2.0
        * PI
        / n as f64;
    let angle = move |t: f64| (kappa * t.cos()).exp() / norm;
    check(&model, 1e-3, [&angle, &gaussian(s / (2.0 * c))]);
}

/// x' = F − k sin x + ξ₁, y' = −y + ξ₂ (general form: drift and noise in both equations):
/// the torque F drives a current around the circle; with Φ = 2U/S₁, U = −F x − k cos x,
/// p(x) ∝ e^{−Φ(x)} ∫ₓ^{x+2π} e^{Φ(u)} du, and y is Gaussian with variance S₂/2.
#[test]
fn a_driven_rotor_carries_its_current_through_the_seam() {
    let (f, k, s1, s2) = (0.5, 1.0, 1.0, 1.0);
    let model = bound(&format!(
        "model rotor\nparam F = {f}, k = {k}, S1 = {s1}, S2 = {s2}\nstate x, y\n\
         drift x: F - k*sin(x)\ndrift y: -y\nnoise a: intensity S1\nnoise b: intensity S2\n\
         diffusion x: a\ndiffusion y: b\ndomain x periodic 2*pi\n"
    ));
    let phi = move |x: f64| 2.0 * (-f * x - k * x.cos()) / s1;
    // The inner integral by Simpson's rule on 2000 intervals of one period.
    let unnormalised = move |x: f64| {
        let m = 2000;
        let h = 2.0 * PI / m as f64;
        let mut s = (phi(x) - phi(x)).exp() + (phi(x + 2.0 * PI) - phi(x)).exp();
        for i in 1..m {
            let u = x + i as f64 * h;
            s += (phi(u) - phi(x)).exp() * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    };
    let m = 512;
    let norm: f64 = (0..m)
        .map(|i| unnormalised(-PI + 2.0 * PI * i as f64 / m as f64))
        .sum::<f64>()
        * 2.0
        * PI
        / m as f64;
    let angle = move |x: f64| unnormalised(x) / norm;
    check(&model, 1e-3, [&angle, &gaussian(s2 / 2.0)]);
}

/// Monte Carlo records a periodic state modulo its period (the trajectories run on the
/// line, the coefficients repeat), so the stationary run judges the grid on a periodic
/// model: the pendulum's angle histogram spans the window, and its variance and kurtosis are
/// von Mises' (κ = 4: 0.298228 and 3.68855, by the midpoint rule on 2·10⁵ points), the
/// velocity's variance S/(2c). The transient (which ran with the angle unwrapped and
/// reported a variance of 23.5 at t = 20 where the circle allows at most π²/3) and first
/// passage (whose safe set would see the unwrapped angle) refuse the model before any work.
#[test]
fn monte_carlo_takes_the_angle_modulo_its_period() {
    use fpsolve::mc::{
        Grid, McConfig, McError, McPassage, McTransient, McTransientError, Simulation,
    };
    let text = "model pendulum\nparam c = 0.5, k = 2, S = 0.5\nstate theta, w\n\
                drift theta: w\ndrift w: -c*w - k*sin(theta)\nnoise xi: intensity S\n\
                diffusion w: xi\ndomain theta periodic 2*pi\n";
    let model = bound(text);
    let config = McConfig {
        trajectories: 1024,
        samples: 4000,
        seed: 4,
        ..McConfig::default()
    };
    let res = Simulation::new(&model, &config).unwrap().run().unwrap();
    let theta = &res.quantities[0];
    assert_eq!(theta.grid, Grid::new(-PI, PI, config.bins).unwrap());
    assert_eq!(theta.underflow + theta.overflow, 0);
    for (what, got, exact) in [
        ("var theta", theta.moments.variance, 0.298228),
        ("kurtosis theta", theta.moments.kurtosis, 3.68855),
        ("var w", res.quantities[1].moments.variance, 0.5),
    ] {
        println!("{what}: {} ± {:.1e}, exact {exact}", got.value, got.stderr);
        assert!(
            (got.value - exact).abs() < 4.0 * got.stderr + 1e-3 * exact,
            "{what}"
        );
    }
    let periodic = |e: &McError| matches!(e, McError::PeriodicState { state } if state == "theta");
    let err = McTransient::new(&model)
        .times(vec![0.0, 20.0])
        .check()
        .unwrap_err();
    assert!(
        matches!(&err, McTransientError::Mc(e) if periodic(e)),
        "{err}"
    );
    let with_safe = parse_model(text, None)
        .unwrap()
        .with_safe("abs(w) < 2")
        .unwrap();
    let safe = with_safe.safe().unwrap().bind(&model).unwrap();
    let err = McPassage::new(&model, &safe).check().unwrap_err();
    assert!(periodic(&err), "{err}");
    // Its crossings are not counted (the recorded angle jumps at the seam).
    let levels = McConfig {
        levels: vec![("theta".into(), vec![0.0])],
        ..config
    };
    let err = Simulation::new(&model, &levels).err().unwrap();
    assert!(
        matches!(err, McError::BadSetting { name: "levels", .. }),
        "{err}"
    );
}
