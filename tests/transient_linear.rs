//! The grid transient against the exact law of the linear oscillator
//! x' = v, v' = −c v − k x + ξ (E[ξ(t)ξ(t+τ)] = 2πK δ(τ), `models/linear.sde`): from a
//! Gaussian start the density stays Gaussian, its mean solving m' = A m and its covariance
//! the Lyapunov equation Σ' = AΣ + ΣAᵀ + B, B = diag(0, 2πK), both integrated here by RK4 on
//! a step (1e−3) whose error is far below what is compared. The marginals are compared by
//! L1 with the exact Gaussians' cell averages at several times and two resolutions; the
//! long-time limit with the stationary solver on the same cells; the mass to 1e−12.

use std::path::Path;

mod transient_exact;

use fpsolve::grid::{Domain, GridSolver, GridTransient, Initial, TransientHistory, UNRESOLVED_L1};
use fpsolve::model::{load_model, BoundModel};
use transient_exact::{l1_gaussian, lyapunov};

fn linear() -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    load_model(&path).unwrap().bind(&[]).unwrap()
}

// The model's parameters: c = 0.1, k = 1, 2πK = 1 (stationary variances 5 and 5).
const C: f64 = 0.1;
const K: f64 = 1.0;
const INTENSITY: f64 = 1.0;

/// Mean and covariance at each of `times`, from (m0, s0) at t = 0.
fn exact(m0: [f64; 2], s0: [[f64; 2]; 2], times: &[f64]) -> Vec<([f64; 2], [[f64; 2]; 2])> {
    lyapunov(C, K, |_| INTENSITY, m0, s0, times)
}

/// The output times: the start's sharp layer (1, 2.5), two periods of the free oscillation
/// (5, 10) and twice the damping's time scale 1/c (20). The whole history to t = 80 at 161
/// output times is timed in `benches/transient.rs`.
const TIMES: [f64; 5] = [1.0, 2.5, 5.0, 10.0, 20.0];

/// A run at `tolerance`, the stepper's L1 error per unit time: the L1 error it leaves at an
/// output is about 4 times it (measured against a run at 1e−7 on 80x80 cells to t = 80), so
/// each run's tolerance is set well below the spatial error it is compared at. A tolerance
/// far below that error only buys steps: on a mesh that barely resolves the start the
/// stepper follows its grid-scale oscillations (80x80 from the σ = 0.5 Gaussian at 2.5e-5:
/// 3206 steps to t = 20, where the spatial L1 error is 5e-2).
fn run(
    model: &BoundModel,
    cells: [usize; 2],
    start: Initial,
    tolerance: f64,
    times: &[f64],
) -> TransientHistory {
    GridTransient::new(model)
        .cells(cells[0], cells[1])
        .domain(BOX)
        .initial(start)
        .tolerance(tolerance)
        .times(times.to_vec())
        .run()
        .unwrap()
}

/// Worst L1 of the two marginals over the output times (and over those from t = 10 on), with
/// the per-time table printed.
fn worst_l1(
    history: &TransientHistory,
    m0: [f64; 2],
    s0: [[f64; 2]; 2],
    label: &str,
) -> [[f64; 2]; 2] {
    let times: Vec<f64> = history.snapshots.iter().map(|s| s.t).collect();
    let laws = exact(m0, s0, &times);
    let (mut worst, mut late) = ([0.0f64; 2], [0.0f64; 2]);
    for (s, (m, cov)) in history.snapshots.iter().zip(&laws) {
        let l1 = [
            l1_gaussian(&s.marginals[0], m[0], cov[0][0]),
            l1_gaussian(&s.marginals[1], m[1], cov[1][1]),
        ];
        eprintln!(
            "{label} t={:5.1}: L1 x {:.2e} v {:.2e}; var x {:.5} (exact {:.5}) v {:.5} ({:.5}); \
             mean x {:+.5} ({:+.5}); kurtosis x {:.4}; mass-1 {:+.1e}; negative {:.1e}; edge {:.1e}",
            s.t, l1[0], l1[1], s.moments[0].variance, cov[0][0], s.moments[1].variance, cov[1][1],
            s.moments[0].mean, m[0], s.moments[0].kurtosis, s.mass - 1.0, s.negative_mass, s.edge_mass
        );
        assert!(
            (s.mass - 1.0).abs() < 1e-12,
            "{label} t={}: mass {}",
            s.t,
            s.mass
        );
        worst = [worst[0].max(l1[0]), worst[1].max(l1[1])];
        if s.t >= 10.0 {
            late = [late[0].max(l1[0]), late[1].max(l1[1])];
        }
    }
    eprintln!("{label}: {:?}", history.report);
    [worst, late]
}

const BOX: Domain = Domain {
    x: [-16.0, 16.0],
    v: [-16.0, 16.0],
};

/// From a Gaussian off the origin (a free oscillation that spreads), in its sharp first
/// layer: the marginals follow the exact Gaussians, and halving the cells cuts the error by
/// at least 3 (the scheme is third order in space where the density is smooth). The worst is
/// at t = 1, where the start (σ = 0.5: 1.25 cells at 80x80, 2.5 at 160x160) is sharpest.
/// Measured worst L1 (x, v): 80x80 5.4e-2, 2.2e-2; 160x160 7.1e-3, 2.1e-3 (at tolerance 1e-4
/// instead of 1e-3 the same to two digits, in 967 steps instead of 211: the sharp moving
/// start is what sets the step).
#[test]
fn gaussian_start_follows_the_lyapunov_equation() {
    let model = linear();
    let m0 = [3.0, 0.0];
    let s0 = [[0.25, 0.05], [0.05, 0.25]];
    let start = Initial::Gaussian {
        mean: m0,
        covariance: s0,
    };
    let times = [1.0, 2.5];
    let coarse = worst_l1(
        &run(&model, [80, 80], start.clone(), 1e-3, &times),
        m0,
        s0,
        "80x80",
    );
    let fine = worst_l1(
        &run(&model, [160, 160], start, 1e-3, &times),
        m0,
        s0,
        "160x160",
    );
    eprintln!("worst L1 (x, v): 80x80 {coarse:?}, 160x160 {fine:?}");
    for axis in 0..2 {
        assert!(fine[0][axis] < 1e-2, "{fine:?}");
        assert!(coarse[0][axis] / fine[0][axis] > 3.0, "{coarse:?} {fine:?}");
    }
}

/// From rest (a Gaussian of two cells per axis: the narrowest start the cells resolve): the
/// exact evolution is that Gaussian's, to t = 20 (twice the damping's time scale), at
/// 128x128 cells. Measured with the face-averaged fluxes: L1 (x, v) 5.8e-3, 1.1e-3 at t = 1,
/// 1.2e-3, 1.0e-3 at 10, 4.9e-4, 1.35e-3 at 20 (the same at a time tolerance of 1e-6: the
/// error is the space's); the variances within 1.1e-3 of the Lyapunov solution; 44 steps.
/// With midpoint fluxes it was 3.2e-4 at 10 and 2.1e-4 (v 3.6e-4) at 20: on a start two
/// cells wide the averages' differences see an unresolved density, and what they leave
/// decays only with the damping. The run's own estimate states it (below, at 40x40).
#[test]
fn rest_start_follows_the_lyapunov_equation() {
    let model = linear();
    let cells = [128, 128];
    let (hx, hv) = (32.0 / 128.0, 32.0 / 128.0);
    let s0 = [
        [(2.0 * hx) * (2.0f64 * hx), 0.0],
        [0.0, (2.0 * hv) * (2.0f64 * hv)],
    ];
    let h = run(&model, cells, Initial::Rest, 1e-4, &TIMES);
    let [worst, late] = worst_l1(&h, [0.0, 0.0], s0, "rest 128x128");
    assert!(worst[0] < 1e-2 && worst[1] < 1e-2, "{worst:?}");
    assert!(late[0] < 2e-3 && late[1] < 2e-3, "{late:?}");
}

/// Long after the start the transient is the stationary solver's density on the same cells
/// (both solve G p = 0 in the limit), and the mass stays 1 to rounding. Measured at 80x80:
/// L1 3.4e-7, mass − 1 = −2.8e-13 (at tolerance 1e-4: L1 1.8e-5, in 404 steps instead of
/// 4105).
#[test]
fn long_time_limit_is_the_stationary_density() {
    let model = linear();
    let (nx, nv) = (80, 80);
    let h = GridTransient::new(&model)
        .cells(nx, nv)
        .domain(BOX)
        .tolerance(1e-6)
        .joint(true)
        .times(vec![400.0])
        .run()
        .unwrap();
    let stationary = GridSolver::new(&model)
        .cells(nx, nv)
        .domain(BOX)
        .estimate(false)
        .solve()
        .unwrap();
    let s = &h.snapshots[0];
    let p = s.joint.as_ref().unwrap();
    let area = (32.0 / nx as f64) * (32.0 / nv as f64);
    let l1: f64 = (0..nx)
        .flat_map(|i| (0..nv).map(move |j| (i, j)))
        .map(|(i, j)| (p[i * nv + j] - stationary.cell(i, j)).abs() * area)
        .sum();
    eprintln!(
        "t=400: L1 to the stationary solve {l1:.2e}, mass-1 {:+.1e}, {:?}",
        s.mass - 1.0,
        h.report
    );
    assert!((s.mass - 1.0).abs() < 1e-12);
    assert!(l1 < 1e-6, "{l1:e}");
}

/// From a true point (rest) the grid starts from a Gaussian two cells wide: an error of the
/// method that its estimate (the run on half the cells, whose start is twice as wide) must
/// state. At 40x40 cells (h = 0.8: the start's variance is 2.56 where the law's is 0) every
/// output's variances and marginals are within their estimates of the exact law from the
/// point, the Lyapunov solution from a zero covariance.
#[test]
fn the_estimate_covers_a_point_start() {
    let model = linear();
    let h = run(&model, [40, 40], Initial::Rest, 1e-4, &TIMES);
    let times: Vec<f64> = h.snapshots.iter().map(|s| s.t).collect();
    let laws = exact([0.0, 0.0], [[0.0, 0.0], [0.0, 0.0]], &times);
    for (s, (m, cov)) in h.snapshots.iter().zip(&laws) {
        let e = s.estimate.as_ref().expect("the estimate is on by default");
        for axis in 0..2 {
            let var = cov[axis][axis];
            let error = (s.moments[axis].variance - var).abs();
            let l1 = l1_gaussian(&s.marginals[axis], m[axis], var);
            eprintln!(
                "t={:5.1} axis {axis}: var {:.4} (exact {var:.4}, error {error:.3e}, stated \
                 {:.3e}); L1 {l1:.3e} (stated {:.3e})",
                s.t, s.moments[axis].variance, e.moments[axis].variance, e.l1[axis]
            );
            assert!(error <= e.moments[axis].variance, "t={} axis {axis}", s.t);
            // An L1 estimate of a quarter or more says the curve is not resolved at all: L1
            // distances saturate at 2, so two unresolved runs' difference no longer scales
            // with the cells (at t = 1 the law's sd 0.5 is below a cell: true 1.03, stated
            // 0.71). Below that it bounds the error.
            assert!(
                l1 <= e.l1[axis] || e.l1[axis] >= UNRESOLVED_L1,
                "t={} axis {axis}",
                s.t
            );
        }
    }
}
