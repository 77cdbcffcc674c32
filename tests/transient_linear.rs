//! The grid transient against the exact law of the linear oscillator
//! x' = v, v' = −c v − k x + ξ (E[ξ(t)ξ(t+τ)] = 2πK δ(τ), `models/linear.sde`): from a
//! Gaussian start the density stays Gaussian, its mean solving m' = A m and its covariance
//! the Lyapunov equation Σ' = AΣ + ΣAᵀ + B, B = diag(0, 2πK), both integrated here by RK4 on
//! a step (1e−3) whose error is far below what is compared. The marginals are compared by
//! L1 with the exact Gaussians' cell averages at several times and two resolutions; the
//! long-time limit with the stationary solver on the same cells; the mass to 1e−12.

use std::path::Path;

use fpsolve::grid::{Domain, GridSolver, GridTransient, Initial, Marginal, TransientHistory};
use fpsolve::model::{load_model, BoundModel};

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
    let a = [[0.0, 1.0], [-K, -C]];
    // State: m (2) and Σ's three distinct entries (xx, xv, vv).
    let rhs = |y: [f64; 5]| {
        let [m0, m1, sxx, sxv, svv] = y;
        [
            a[0][0] * m0 + a[0][1] * m1,
            a[1][0] * m0 + a[1][1] * m1,
            2.0 * (a[0][0] * sxx + a[0][1] * sxv),
            a[0][0] * sxv + a[0][1] * svv + a[1][0] * sxx + a[1][1] * sxv,
            2.0 * (a[1][0] * sxv + a[1][1] * svv) + INTENSITY,
        ]
    };
    let add = |y: [f64; 5], k: [f64; 5], s: f64| std::array::from_fn(|i| y[i] + s * k[i]);
    let mut y = [m0[0], m0[1], s0[0][0], s0[0][1], s0[1][1]];
    let (mut t, dt) = (0.0f64, 1e-3f64);
    let mut out = Vec::new();
    for &target in times {
        while t < target - 1e-12 {
            let h = dt.min(target - t);
            let k1 = rhs(y);
            let k2 = rhs(add(y, k1, h / 2.0));
            let k3 = rhs(add(y, k2, h / 2.0));
            let k4 = rhs(add(y, k3, h));
            y = std::array::from_fn(|i| {
                y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
            t += h;
        }
        out.push(([y[0], y[1]], [[y[2], y[3]], [y[3], y[4]]]));
    }
    out
}

/// L1 between a marginal's cell averages and the cell averages of N(mean, var) (8-point
/// Gauss–Legendre on each cell).
fn l1_gaussian(m: &Marginal, mean: f64, var: f64) -> f64 {
    const NODES: [(f64, f64); 4] = [
        (0.183_434_642_495_65, 0.362_683_783_378_362),
        (0.525_532_409_916_329, 0.313_706_645_877_887),
        (0.796_666_477_413_627, 0.222_381_034_453_374),
        (0.960_289_856_497_536, 0.101_228_536_290_376),
    ];
    let pdf = |u: f64| {
        (-(u - mean).powi(2) / (2.0 * var)).exp() / (2.0 * std::f64::consts::PI * var).sqrt()
    };
    let h = m.width;
    let cells: f64 = m
        .centres
        .iter()
        .zip(&m.density)
        .map(|(c, p)| {
            let avg: f64 = NODES
                .iter()
                .map(|(t, w)| w * (pdf(c + t * h / 2.0) + pdf(c - t * h / 2.0)))
                .sum::<f64>()
                / 2.0;
            (p - avg).abs() * h
        })
        .sum();
    // The exact mass outside the box counts as error too (it is below 1e−12 here).
    cells
}

const TIMES: [f64; 6] = [1.0, 2.5, 5.0, 10.0, 20.0, 40.0];

fn run(model: &BoundModel, cells: [usize; 2], domain: Domain, start: Initial) -> TransientHistory {
    GridTransient::new(model)
        .cells(cells[0], cells[1])
        .domain(domain)
        .initial(start)
        .tolerance(1e-5)
        .times(TIMES.to_vec())
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
    let laws = exact(m0, s0, &TIMES);
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

/// From a Gaussian off the origin (a free oscillation that spreads): the marginals follow
/// the exact Gaussians, and halving the cells cuts the error by at least 3 (the scheme is
/// third order in space where the density is smooth; the stepper's error is far below).
/// Measured worst L1 (x, v): 80x80 5.4e-2, 2.1e-2; 160x160 7.1e-3, 2.1e-3 (ratios 7.6 and
/// 10.4), the worst at t = 1-2.5 where the start (σ = 0.5, 2.5 cells) is sharpest; from
/// t = 10 on at 160x160 at most 3.5e-4. Mass within 3e-13.
#[test]
fn gaussian_start_follows_the_lyapunov_equation() {
    let model = linear();
    let m0 = [3.0, 0.0];
    let s0 = [[0.25, 0.05], [0.05, 0.25]];
    let start = Initial::Gaussian {
        mean: m0,
        covariance: s0,
    };
    let coarse = worst_l1(&run(&model, [80, 80], BOX, start.clone()), m0, s0, "80x80");
    let fine = worst_l1(&run(&model, [160, 160], BOX, start), m0, s0, "160x160");
    eprintln!("worst L1 (x, v): 80x80 {coarse:?}, 160x160 {fine:?}");
    for axis in 0..2 {
        assert!(fine[0][axis] < 1e-2, "{fine:?}");
        assert!(fine[1][axis] < 5e-4, "{fine:?}");
        assert!(coarse[0][axis] / fine[0][axis] > 3.0, "{coarse:?} {fine:?}");
    }
}

/// From rest (a Gaussian of two cells per axis: the narrowest start the cells resolve): the
/// exact evolution is that Gaussian's. Measured at 160x160: L1 6.8e-3 (x) at t = 1, falling
/// to 2.6e-4 by t = 10 and 1.1e-4 by t = 40; the variances within 2.3e-4 of the Lyapunov
/// solution at every time.
#[test]
fn rest_start_follows_the_lyapunov_equation() {
    let model = linear();
    let cells = [160, 160];
    let (hx, hv) = (32.0 / 160.0, 32.0 / 160.0);
    let s0 = [
        [(2.0 * hx) * (2.0f64 * hx), 0.0],
        [0.0, (2.0 * hv) * (2.0f64 * hv)],
    ];
    let h = run(&model, cells, BOX, Initial::Rest);
    let [worst, late] = worst_l1(&h, [0.0, 0.0], s0, "rest 160x160");
    assert!(worst[0] < 1e-2 && worst[1] < 1e-2, "{worst:?}");
    assert!(late[0] < 5e-4 && late[1] < 5e-4, "{late:?}");
}

/// Long after the start the transient is the stationary solver's density on the same cells
/// (both solve G p = 0 in the limit), and the mass stays 1 to rounding. Measured at 80x80:
/// L1 3.4e-7, mass − 1 = −2.8e-13.
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
