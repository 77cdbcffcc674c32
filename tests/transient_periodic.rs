//! The periodic steady state by the period map (`GridTransient::periodic`) against exact
//! and independent answers:
//! - the linear oscillator x' = v, v' = −c v − k x + A cos(wt) + ξ (intensity S): its
//!   periodic state is Gaussian, the mean the deterministic harmonic response
//!   x_p(t) = A((k − w²) cos wt + c w sin wt)/((k − w²)² + (c w)²), the covariance the
//!   unforced stationary one (var x = S/(2ck), var v = S/(2c), uncorrelated);
//! - the Duffing oscillator under the same force against a Monte Carlo ensemble run for
//!   many periods and sampled at fixed phases, and against Monte Carlo's own periodic state
//!   (`McTransient::periodic`);
//! - the refusals before any work.

mod transient_exact;

use std::f64::consts::PI;

use fpsolve::grid::{Domain, GridTransient, PeriodicState, TransientError};
use fpsolve::mc::McTransient;
use fpsolve::model::{parse_model, BoundModel, InitialState, PeriodError};
use transient_exact::l1_gaussian;

/// c, k, A, w, S of the linear case.
const LINEAR: [f64; 5] = [0.2, 1.0, 1.0, 0.8, 0.2];

fn model(text: &str) -> BoundModel {
    parse_model(text, None).unwrap().bind(&[]).unwrap()
}

fn forced(cubic: f64) -> BoundModel {
    let [c, k, a, w, s] = LINEAR;
    model(&format!(
        "model forced\nparam c = {c}, k = {k}, A = {a}, w = {w}, eps = {cubic}\n\
         state x, v\ndrift x: v\ndrift v: -c*v - k*x - eps*x^3 + A*cos(w*t)\n\
         noise xi: intensity {s}\ndiffusion v: xi\n"
    ))
}

/// The periodic state of `m` at `phases` on `cells`² cells of the box ±7, the default
/// steps per period.
fn periodic(m: &BoundModel, cells: usize, phases: &[f64]) -> PeriodicState {
    let period = 2.0 * PI / LINEAR[3];
    let state = GridTransient::new(m)
        .cells(cells, cells)
        .domain(Domain {
            x: [-7.0, 7.0],
            v: [-7.0, 7.0],
        })
        .times(phases.to_vec())
        .estimate(false)
        .periodic(period)
        .run()
        .unwrap();
    let r = &state.report;
    eprintln!(
        "{cells}x{cells}: {} (residuals {:?}), {} stages kept, {} \
         factorisations, {:.0} ms",
        r.outcome,
        r.residuals
            .iter()
            .map(|r| format!("{r:.1e}"))
            .collect::<Vec<_>>(),
        r.cached_stages,
        state.history.report.factorizations,
        state.history.report.total_ms
    );
    assert!(r.outcome.converged(), "{}", r.outcome);
    state
}

/// The exact mean (x, v) of the linear case's periodic state at phase t.
fn harmonic(t: f64) -> [f64; 2] {
    let [c, k, a, w, _] = LINEAR;
    let d = (k - w * w).powi(2) + (c * w).powi(2);
    let (p, q) = (a * (k - w * w) / d, a * c * w / d);
    [
        p * (w * t).cos() + q * (w * t).sin(),
        w * (-p * (w * t).sin() + q * (w * t).cos()),
    ]
}

/// Amplitude and phase lag of the fundamental of `means` at `phases` evenly covering one
/// period (least squares on cos wt, sin wt, constant: here the discrete Fourier sums).
fn fundamental(phases: &[f64], means: &[f64]) -> (f64, f64) {
    let w = LINEAR[3];
    let n = phases.len() as f64;
    let a: f64 = phases
        .iter()
        .zip(means)
        .map(|(t, m)| m * (w * t).cos())
        .sum::<f64>()
        * 2.0
        / n;
    let b: f64 = phases
        .iter()
        .zip(means)
        .map(|(t, m)| m * (w * t).sin())
        .sum::<f64>()
        * 2.0
        / n;
    (a.hypot(b), b.atan2(a))
}

/// Eight phases over one period (the period's end left out: it is the start again).
fn phases() -> Vec<f64> {
    let period = 2.0 * PI / LINEAR[3];
    (0..8).map(|i| i as f64 * period / 8.0).collect()
}

/// The linear case at 64x64, the default 32 ESDIRK4 steps per period: both marginals against
/// the exact Gaussians at eight phases, the variances, the mean's amplitude and phase lag.
/// Measured: L1 ≤ 2.38e-2 (x) and 2.21e-2 (v) over the phases (the cells' error: 2.3e-2 with
/// 256 TR-BDF2 steps; 6.2e-2 with 16 ESDIRK4 steps, 5.2e-2 with 64 TR-BDF2 steps, so the bound
/// catches a time step twice as long); variances within 1.04e-3 of their value; amplitude
/// 2.53839 against 2.53837, lag 0.41823 against 0.41822 rad (TR-BDF2 at 32 steps: the mean
/// 1.3e-2 off). At 128x128 the L1 is 5.6e-3 and 5.2e-3. With the face-averaged fluxes the
/// worst L1 at 64x64 is 2.71e-2 (x) and 2.56e-2 (v): at 2.8 cells per standard deviation
/// their differences see an unresolved density (the stationary solves gain from them from
/// about 100 cells per axis).
#[test]
fn linear_periodic_state_is_the_exact_gaussian() {
    let [c, k, a, w, s] = LINEAR;
    let phases = phases();
    let state = periodic(&forced(0.0), 64, &phases);
    let (var_x, var_v) = (s / (2.0 * c * k), s / (2.0 * c));
    let mut worst = [0.0f64; 2];
    for snap in &state.history.snapshots {
        let exact = harmonic(snap.t);
        let l1 = [
            l1_gaussian(&snap.marginals[0], exact[0], var_x),
            l1_gaussian(&snap.marginals[1], exact[1], var_v),
        ];
        eprintln!(
            "phase {:.3}: mean x {:+.5} (exact {:+.5}), var x {:.5} ({var_x}), var v {:.5} \
             ({var_v}); L1 x {:.2e}, v {:.2e}; mass {:.2e} off, negative {:.1e}",
            snap.t,
            snap.moments[0].mean,
            exact[0],
            snap.moments[0].variance,
            snap.moments[1].variance,
            l1[0],
            l1[1],
            (snap.mass - 1.0).abs(),
            snap.negative_mass
        );
        worst = [worst[0].max(l1[0]), worst[1].max(l1[1])];
        assert!((snap.mass - 1.0).abs() < 1e-10);
        assert!((snap.moments[0].variance - var_x).abs() < 2e-3 * var_x);
        assert!((snap.moments[1].variance - var_v).abs() < 2e-3 * var_v);
    }
    assert!(worst[0] < 3e-2 && worst[1] < 3e-2, "{worst:?}");
    let means: Vec<f64> = state
        .history
        .snapshots
        .iter()
        .map(|s| s.moments[0].mean)
        .collect();
    let (amplitude, lag) = fundamental(&phases, &means);
    let d = (k - w * w).powi(2) + (c * w).powi(2);
    let (exact_amplitude, exact_lag) = (a / d.sqrt(), (c * w).atan2(k - w * w));
    eprintln!("amplitude {amplitude:.5} ({exact_amplitude:.5}), lag {lag:.5} ({exact_lag:.5})");
    assert!((amplitude - exact_amplitude).abs() < 1e-4 * exact_amplitude);
    assert!((lag - exact_lag).abs() < 1e-4, "{lag} vs {exact_lag}");
}

/// The Duffing oscillator (ε = 0.1) under the same force against Monte Carlo: 32 768
/// trajectories from rest run 20 periods (the start forgotten to e^{−cP·20/2} ≈ 1e−7 in the
/// linearisation), sampled at four phases of the 20th. Each grid mean and variance must lie
/// within 4 Monte Carlo standard errors plus its time-step bias estimate (with its own
/// standard error) plus the grid's own error at 64x64 (1.5 times its difference from 48x48).
/// Measured (seed 17): every mean and variance within 2.61 standard errors (se 2.6e-3 to
/// 5.0e-3, bias estimates 2.5e-3 to 1.3e-2).
#[test]
fn duffing_periodic_state_matches_monte_carlo_at_fixed_phases() {
    let m = forced(0.1);
    let period = 2.0 * PI / LINEAR[3];
    let phases: Vec<f64> = (0..4).map(|i| i as f64 * period / 4.0).collect();
    let fine = periodic(&m, 64, &phases);
    let coarse = periodic(&m, 48, &phases);
    let times: Vec<f64> = phases.iter().map(|p| 19.0 * period + p).collect();
    let mc = McTransient::new(&m)
        .initial(InitialState::Rest)
        .times(times)
        .trajectories(32_768)
        .dt(0.01)
        .seed(17)
        .run()
        .unwrap();
    for ((g, h), s) in fine
        .history
        .snapshots
        .iter()
        .zip(&coarse.history.snapshots)
        .zip(&mc.snapshots)
    {
        for axis in 0..2 {
            let mm = &s.moments[axis];
            let bias = |k: usize| mm.bias.map_or(0.0, |b| b[k].value.abs() + b[k].stderr);
            for (what, grid, grid_coarse, est, k) in [
                (
                    "mean",
                    g.moments[axis].mean,
                    h.moments[axis].mean,
                    mm.mean,
                    0,
                ),
                (
                    "var",
                    g.moments[axis].variance,
                    h.moments[axis].variance,
                    mm.variance,
                    1,
                ),
            ] {
                let grid_error = 1.5 * (grid - grid_coarse).abs();
                let off = grid - est.value;
                eprintln!(
                    "phase {:.3} {what}[{axis}]: grid {grid:+.5} (48x48 {grid_coarse:+.5}), mc \
                     {:+.5} ± {:.1e} (bias {:.1e}): {:+.2} se",
                    g.t,
                    est.value,
                    est.stderr,
                    bias(k),
                    off / est.stderr
                );
                assert!(
                    off.abs() <= 4.0 * est.stderr + bias(k) + grid_error,
                    "phase {} {what}[{axis}]",
                    g.t
                );
            }
        }
        assert_eq!(s.blown_up, 0);
    }
    // Monte Carlo's own periodic state (the pilot's discarded periods, 8 recorded periods
    // with batch-means errors) judged the same way.
    let state = McTransient::new(&m)
        .initial(InitialState::Rest)
        .times(phases.clone())
        .trajectories(16_384)
        .dt(0.01)
        .seed(17)
        .periodic(period)
        .run()
        .unwrap();
    eprintln!(
        "mc periodic: {:?}, {:.0} ms",
        state.report, state.history.settings.total_ms
    );
    for ((g, h), s) in fine
        .history
        .snapshots
        .iter()
        .zip(&coarse.history.snapshots)
        .zip(&state.history.snapshots)
    {
        assert_eq!(g.t, s.t);
        for axis in 0..2 {
            let mm = &s.moments[axis];
            let bias = |k: usize| mm.bias.map_or(0.0, |b| b[k].value.abs() + b[k].stderr);
            for (what, grid, grid_coarse, est, k) in [
                (
                    "mean",
                    g.moments[axis].mean,
                    h.moments[axis].mean,
                    mm.mean,
                    0,
                ),
                (
                    "var",
                    g.moments[axis].variance,
                    h.moments[axis].variance,
                    mm.variance,
                    1,
                ),
            ] {
                let grid_error = 1.5 * (grid - grid_coarse).abs();
                let off = grid - est.value;
                eprintln!(
                    "periodic mc, phase {:.3} {what}[{axis}]: grid {grid:+.5}, mc {:+.5} ± \
                     {:.1e} (bias {:.1e}): {:+.2} se",
                    g.t,
                    est.value,
                    est.stderr,
                    bias(k),
                    off / est.stderr
                );
                assert!(
                    off.abs() <= 4.0 * est.stderr + bias(k) + grid_error,
                    "periodic mc, phase {} {what}[{axis}]",
                    g.t
                );
            }
        }
        assert_eq!(s.blown_up, 0);
    }
}

/// Refusals before any work: a period that is not the coefficients' (naming the drift),
/// a model without t, a period that is not positive, phases beyond the period.
#[test]
fn wrong_periods_and_models_are_refused_before_work() {
    let m = forced(0.0);
    let run = GridTransient::new(&m)
        .cells(32, 32)
        .domain(Domain {
            x: [-7.0, 7.0],
            v: [-7.0, 7.0],
        })
        .times(vec![0.0, 1.0]);
    let period = 2.0 * PI / LINEAR[3];
    match run.clone().periodic(0.99 * period).check() {
        Err(TransientError::Period(PeriodError::NotPeriodic { coefficient, .. })) => {
            assert_eq!(coefficient, "the drift of `v`")
        }
        other => panic!("{other:?}"),
    }
    let noisy = model(
        "model modulated\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
         diffusion v: (1 + 0.5*sin(t))*xi\n",
    );
    let err = GridTransient::new(&noisy)
        .cells(32, 32)
        .domain(Domain {
            x: [-5.0, 5.0],
            v: [-5.0, 5.0],
        })
        .times(vec![0.0])
        .periodic(3.0)
        .check()
        .unwrap_err();
    assert!(
        matches!(&err, TransientError::Period(PeriodError::NotPeriodic { coefficient, .. }) if coefficient == "the diffusion of `v`"),
        "{err}"
    );
    let still = model(
        "model still\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
         diffusion v: xi\n",
    );
    let err = GridTransient::new(&still)
        .times(vec![0.0])
        .periodic(1.0)
        .check()
        .unwrap_err();
    assert!(matches!(
        err,
        TransientError::Period(PeriodError::NotTimeDependent { .. })
    ));
    assert!(err.to_string().contains("stationary"), "{err}");
    for p in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = run.clone().periodic(p).check().unwrap_err();
        assert!(
            matches!(
                err,
                TransientError::Setting {
                    setting: "period",
                    ..
                }
            ),
            "{err}"
        );
    }
    let err = run
        .times(vec![0.0, 1.1 * period])
        .periodic(period)
        .check()
        .unwrap_err();
    assert!(matches!(
        err,
        TransientError::Setting {
            setting: "times",
            ..
        }
    ));
}
