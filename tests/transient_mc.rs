//! The Monte Carlo transient against exact laws. Linear models keep Gaussian marginals
//! whose means solve the deterministic ODE and whose covariances solve the Lyapunov
//! differential equation (`transient_exact`); each ensemble mean and variance must lie
//! within a few standard errors plus its time-step bias estimate (the bias's own standard
//! error included) of the exact value:
//! - the linear oscillator from rest under white noise (`models/linear.sde`);
//! - the same oscillator under white noise modulated by the Shinozuka–Sato envelope
//!   e(t) = a (e^{−b₁t} − e^{−b₂t}) (the mechanical splitting, its velocity update at each
//!   step's midpoint);
//! - the oscillator driven by a periodic force A cos(wt) from rest, whose mean is the
//!   deterministic response (transient beats included);
//! - a model with noise and a periodic force in both equations, on Platen's scheme.

mod transient_exact;

use std::path::Path;

use fpsolve::mc::{McTransient, McTransientHistory, SchemeKind};
use fpsolve::model::{load_model, parse_model, BoundModel, InitialState};
use transient_exact::{linear_law, lyapunov};

/// Mean and covariance at each output time.
type Law = Vec<([f64; 2], [[f64; 2]; 2])>;

/// Asserts that every snapshot's means and variances are within `sds` standard errors plus
/// the bias estimate (its value and standard error) of `exact`, printing the table.
fn assert_matches(h: &McTransientHistory, exact: &Law, sds: f64, label: &str) {
    for (s, (mean, cov)) in h.snapshots.iter().zip(exact) {
        for (axis, m) in s.moments.iter().enumerate() {
            let bias = |k: usize| m.bias.map_or(0.0, |b| b[k].value.abs() + b[k].stderr);
            for (what, got, want, k) in [
                ("mean", m.mean, mean[axis], 0),
                ("var", m.variance, cov[axis][axis], 1),
            ] {
                let off = got.value - want;
                eprintln!(
                    "{label} t = {:4.1} {what}[{axis}] {:+.5} ± {:.1e} (bias {:.1e}), exact \
                     {want:+.5}: {:+.1} se",
                    s.t,
                    got.value,
                    got.stderr,
                    bias(k),
                    off / got.stderr.max(f64::MIN_POSITIVE)
                );
                assert!(
                    off.abs() <= sds * got.stderr + bias(k) + 1e-12,
                    "{label} t = {} {what}[{axis}]: {} vs {want}",
                    s.t,
                    got.value
                );
            }
        }
        assert_eq!(s.blown_up, 0, "{label} t = {}", s.t);
    }
}

fn model(text: &str) -> BoundModel {
    parse_model(text, None).unwrap().bind(&[]).unwrap()
}

/// A run from rest to `times` with `n` trajectories at step `dt`, seeded with `seed`.
fn run(m: &BoundModel, times: &[f64], n: u64, dt: f64, seed: u64) -> McTransientHistory {
    McTransient::new(m)
        .initial(InitialState::Rest)
        .times(times.to_vec())
        .trajectories(n)
        .dt(dt)
        .seed(seed)
        .run()
        .unwrap()
}

#[test]
fn linear_oscillator_from_rest_matches_the_lyapunov_variances() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    let model = load_model(&path).unwrap().bind(&[]).unwrap();
    let times = vec![0.0, 1.0, 3.0, 6.0];
    let h = run(&model, &times, 16_384, 0.01, 7);
    let exact = lyapunov(0.1, 1.0, |_| 1.0, [0.0, 0.0], [[0.0; 2]; 2], &times);
    assert_matches(&h, &exact, 4.5, "linear");
}

/// x' = v, v' = −c v − k x + e(t) ξ (intensity 1), c = 0.5, k = 1, e(t) = 4(e^{−t/2} − e^{−t}):
/// zero at the start, peak at t* = 2 ln 2 = 1.39, the variance of x peaking near t = 3.
/// 32 768 trajectories from rest, dt = 0.01. Measured (seed 11): every mean and variance
/// within 2 standard errors.
#[test]
fn modulated_white_noise_matches_the_lyapunov_variances() {
    let (c, k, a, b1, b2) = (0.5, 1.0, 4.0, 0.5, 1.0);
    let m = model(&format!(
        "model modulated\nparam c = {c}, k = {k}, a = {a}, b1 = {b1}, b2 = {b2}\n\
         state z, v\ndrift z: v\ndrift v: -c*v - k*z\nnoise xi: intensity 1\n\
         diffusion v: a*(exp(-b1*t) - exp(-b2*t))*xi\n"
    ));
    assert!(m.time_dependent());
    let times = vec![0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0];
    let h = run(&m, &times, 32_768, 0.01, 11);
    assert_eq!(h.settings.scheme, SchemeKind::MechanicalStrang);
    let env2 = |t: f64| (a * ((-b1 * t).exp() - (-b2 * t).exp())).powi(2);
    let exact = lyapunov(c, k, env2, [0.0; 2], [[0.0; 2]; 2], &times);
    assert_matches(&h, &exact, 4.0, "modulated");
}

/// x' = v, v' = −2ζω v − ω² x + A cos(wt) + ξ (intensity 0.1), ζ = 0.05, ω = 1, A = 1,
/// w = 0.8, from rest: the mean is the deterministic response (the transient and the
/// steady state beating), the variance the unforced Lyapunov solution's. 16 384
/// trajectories, dt = 0.01. Measured (seed 3): within 2 standard errors.
#[test]
fn periodic_force_mean_follows_the_deterministic_response() {
    let (zeta, omega, amp, w, s) = (0.05, 1.0, 1.0, 0.8, 0.1);
    let m = model(&format!(
        "model forced\nparam zeta = {zeta}, omega = {omega}, A = {amp}, w = {w}\n\
         state x, v\ndrift x: v\ndrift v: -2*zeta*omega*v - omega^2*x + A*cos(w*t)\n\
         noise xi: intensity {s}\ndiffusion v: xi\n"
    ));
    let times = vec![0.0, 1.0, 2.5, 5.0, 10.0, 20.0];
    let h = run(&m, &times, 16_384, 0.01, 3);
    let exact = linear_law(
        [[0.0, 1.0], [-omega * omega, -2.0 * zeta * omega]],
        |t| [0.0, amp * (w * t).cos()],
        |_| [[0.0, 0.0], [0.0, s]],
        [0.0; 2],
        [[0.0; 2]; 2],
        &times,
    );
    // The response grows towards its steady amplitude A/√((ω² − w²)² + (2ζωw)²) = 2.7.
    assert!(exact[5].0[0].abs() > 1.0, "{:?}", exact[5]);
    assert_matches(&h, &exact, 4.0, "forced");
}

/// Noise in both equations (one modulated source) and a periodic force on the position's
/// equation: not the mechanical form, so Platen's scheme runs, its coefficients at both
/// ends of each step. x' = v − 0.2x + 0.5 sin(t) + 0.3 e(t) ξ, v' = −x − 0.3v + e(t) ξ,
/// e(t) = 2(e^{−t/2} − e^{−t}). 16 384 trajectories, dt = 0.02. Measured (seed 5): within 2
/// standard errors.
#[test]
fn platen_follows_a_time_dependent_linear_law() {
    let m = model(
        "model both\nstate x, v\ndrift x: v - 0.2*x + 0.5*sin(t)\ndrift v: -x - 0.3*v\n\
         noise xi: intensity 1\ndiffusion x: 0.3*2*(exp(-0.5*t) - exp(-t))*xi\n\
         diffusion v: 2*(exp(-0.5*t) - exp(-t))*xi\n",
    );
    let times = vec![0.0, 1.0, 2.0, 4.0, 8.0];
    let h = run(&m, &times, 16_384, 0.02, 5);
    assert_eq!(h.settings.scheme, SchemeKind::PlatenWeak2);
    let e = |t: f64| 2.0 * ((-0.5 * t).exp() - (-t).exp());
    let exact = linear_law(
        [[-0.2, 1.0], [-1.0, -0.3]],
        |t| [0.5 * t.sin(), 0.0],
        |t| {
            let g = [0.3 * e(t), e(t)];
            [[g[0] * g[0], g[0] * g[1]], [g[1] * g[0], g[1] * g[1]]]
        },
        [0.0; 2],
        [[0.0; 2]; 2],
        &times,
    );
    assert_matches(&h, &exact, 4.0, "platen");
}
