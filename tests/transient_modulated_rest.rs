//! The grid transient from rest under modulated white noise against the exact law
//! (`tests/models/linear_modulated.sde`: z'' + 0.2 z' + z = e(t) ξ, E[ξ(t)ξ(t+τ)] = δ(τ),
//! e(t) = 1 + e^{−t/4} − 2e^{−t}, zero at t = 0, back to 1 after a peak). From the point
//! start the law is Gaussian with the covariance of the Lyapunov differential equation from
//! Σ(0) = 0 (`transient_exact`), so every marginal is known at every t; it tends to the
//! stationary law of e = 1. The grid starts from a Gaussian two cells wide (a point is not a
//! cell density), so its early outputs are not the law's: at t = 0 a point and a density are
//! L1 = 2 apart, and the run's error estimate must say so (an estimate of
//! [`UNRESOLVED_L1`] or more is its "not resolved").
//!
//! The whole history (0 → 80, 161 outputs, box ±9, tolerance 1e−4), measured L1 of the worse
//! marginal against the law from the point: 80x80 2.9e−4 from t = 40 on, 9.2e−4 from
//! t = 20; 128x128 1.9e−4, 3.7e−4; 160x160 1.6e−4, 2.7e−4 (late values still falling by a
//! factor 1.25 per refinement of 1.25: the 1e−4 at every output from about t = 30
//! needs some 220 cells per axis). `a_fine_history_stays_near_the_law` runs 160x160
//! (`cargo test --release --test transient_modulated_rest -- --ignored`, about 5 min of CPU).

mod transient_exact;

use std::path::Path;

use fpsolve::grid::{
    Domain, GridSolver, GridTransient, Initial, TransientHistory, POINT_CELLS, UNRESOLVED_L1,
};
use fpsolve::model::{load_model, parse_model, BoundModel};
use transient_exact::{l1_gaussian, lyapunov};

const C: f64 = 0.2;
const K: f64 = 1.0;

fn modulated() -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/linear_modulated.sde");
    load_model(&path).unwrap().bind(&[]).unwrap()
}

fn envelope_squared(t: f64) -> f64 {
    (1.0 + (-t / 4.0).exp() - 2.0 * (-t).exp()).powi(2)
}

const BOX: Domain = Domain {
    x: [-9.0, 9.0],
    v: [-9.0, 9.0],
};

fn run(cells: usize, tolerance: f64, times: &[f64]) -> TransientHistory {
    GridTransient::new(&modulated())
        .cells(cells, cells)
        .domain(BOX)
        .initial(Initial::Rest)
        .tolerance(tolerance)
        .times(times.to_vec())
        .run()
        .unwrap()
}

/// L1 of each marginal to the law from the point start at each output (2 at t = 0: a point
/// and a density are mutually singular).
fn l1_to_law(h: &TransientHistory) -> Vec<[f64; 2]> {
    let times: Vec<f64> = h.snapshots.iter().map(|s| s.t).collect();
    let laws = lyapunov(C, K, envelope_squared, [0.0; 2], [[0.0; 2]; 2], &times);
    h.snapshots
        .iter()
        .zip(&laws)
        .map(|(s, (_, cov))| {
            std::array::from_fn(|axis| {
                let var = cov[axis][axis];
                if var > 0.0 {
                    l1_gaussian(&s.marginals[axis], 0.0, var)
                } else {
                    2.0
                }
            })
        })
        .collect()
}

/// At 48x48 cells to t = 20 (41 outputs): every output's stated L1 error covers its true L1
/// or says the marginal is not resolved (t = 0, where the law is a point, and the first
/// outputs, where it is narrower than the cells); the peak of the displacement's standard
/// deviation falls on the law's output time (9.5), its value within 2 %. Measured: true L1
/// (z) 2 at t = 0 (stated 0.75), 1.23 at 0.5 (0.75), 1.05 at 1 (0.72), then below the
/// statement (0.47 at 1.5 stated 0.59; 1.4e−2 at 9.5 stated 5.5e−2; 3.4e−3 at 20 stated
/// 2.7e−2); peak sd 1.7681 at t = 9.5 (law 1.7444 at 9.5); 269 steps.
#[test]
fn rest_under_modulated_noise_within_its_estimate() {
    let times: Vec<f64> = (0..=40).map(|i| 0.5 * i as f64).collect();
    let h = run(48, 1e-4, &times);
    let l1 = l1_to_law(&h);
    let exact = lyapunov(C, K, envelope_squared, [0.0; 2], [[0.0; 2]; 2], &times);
    for (s, l1) in h.snapshots.iter().zip(&l1) {
        let stated = s
            .estimate
            .as_ref()
            .expect("the estimate is on by default")
            .l1;
        eprintln!(
            "t={:4.1}: L1 z {:.2e} (stated {:.2e}), v {:.2e} (stated {:.2e})",
            s.t, l1[0], stated[0], l1[1], stated[1]
        );
        for axis in 0..2 {
            assert!(
                l1[axis] <= stated[axis] || stated[axis] >= UNRESOLVED_L1,
                "t={} axis {axis}: L1 {} stated {}",
                s.t,
                l1[axis],
                stated[axis]
            );
        }
        if s.t == 0.0 {
            assert!(stated.iter().all(|&e| e >= UNRESOLVED_L1), "{stated:?}");
        }
    }
    let peak = |it: &mut dyn Iterator<Item = (f64, f64)>| {
        it.fold((0.0, 0.0), |b, (t, sd)| if sd > b.1 { (t, sd) } else { b })
    };
    let grid = peak(
        &mut h
            .snapshots
            .iter()
            .map(|s| (s.t, s.moments[0].variance.sqrt())),
    );
    let law = peak(
        &mut times
            .iter()
            .zip(&exact)
            .map(|(t, (_, cov))| (*t, cov[0][0].sqrt())),
    );
    eprintln!("peak sd z: grid {grid:?}, law {law:?}; {:?}", h.report);
    assert_eq!(grid.0, law.0);
    assert!((grid.1 - law.1).abs() < 0.02 * law.1, "{grid:?} {law:?}");
}

/// Long after the envelope has settled (t = 200) the transient is the stationary solver's
/// density of e = 1 on the same cells (48x48): what remains is the time stepping's error.
/// Measured L1 6.5e−6 (tolerance 1e−6, 179 steps; at 1e−5, 83 steps of ESDIRK4 and
/// 6.5e−5: the stepper's error, in proportion to the tolerance).
#[test]
fn long_time_limit_under_modulated_noise_is_the_stationary_density() {
    let limit = parse_model(
        "model limit\nparam c = 0.2, k = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - k*z\n\
         noise xi: intensity 1\ndiffusion v: xi\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let n = 48;
    let h = GridTransient::new(&modulated())
        .cells(n, n)
        .domain(BOX)
        .tolerance(1e-6)
        .joint(true)
        .estimate(false)
        .times(vec![200.0])
        .run()
        .unwrap();
    let stationary = GridSolver::new(&limit)
        .cells(n, n)
        .domain(BOX)
        .estimate(false)
        .solve()
        .unwrap();
    let s = &h.snapshots[0];
    let p = s.joint.as_ref().unwrap();
    let area = (18.0 / n as f64).powi(2);
    let l1: f64 = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .map(|(i, j)| (p[i * n + j] - stationary.cell(i, j)).abs() * area)
        .sum();
    eprintln!(
        "t=200: L1 to the stationary solve {l1:.2e}, mass-1 {:+.1e}, {:?}",
        s.mass - 1.0,
        h.report
    );
    assert!((s.mass - 1.0).abs() < 1e-12);
    assert!(l1 < 1e-5, "{l1:e}");
}

/// The whole history at 160x160 (0 → 80, 161 outputs, tolerance 1e−4): the marginals within
/// 3e−4 of the law from t = 20 on and 2e−4 from t = 40 on (measured 2.7e−4 and 1.6e−4), the
/// peak standard deviation's time the law's (9.5). Slow: about 5 min of CPU.
#[test]
#[ignore]
fn a_fine_history_stays_near_the_law() {
    let times: Vec<f64> = (0..161).map(|i| 0.5 * i as f64).collect();
    let h = run(160, 1e-4, &times);
    let l1 = l1_to_law(&h);
    for (s, l1) in h.snapshots.iter().zip(&l1) {
        eprintln!("t={:4.1}: L1 z {:.2e}, v {:.2e}", s.t, l1[0], l1[1]);
        let worst = l1[0].max(l1[1]);
        if s.t >= 40.0 {
            assert!(worst < 2e-4, "t={}: {l1:?}", s.t);
        } else if s.t >= 20.0 {
            assert!(worst < 3e-4, "t={}: {l1:?}", s.t);
        }
    }
    let peak = h
        .snapshots
        .iter()
        .max_by(|a, b| a.moments[0].variance.total_cmp(&b.moments[0].variance))
        .unwrap();
    assert_eq!(peak.t, 9.5);
}

/// Issue 36's check at the resolution that meets it: the whole history (0 → 80, 161
/// outputs, tolerance 1e−4) at 208x208 cells on the box ±7.5 (4.3 standard deviations of
/// the displacement at its peak), each marginal against the exact law from the grid's own
/// start (the Gaussian of [`POINT_CELLS`] cells that stands for rest). L1 ≤ 1e−4 at every
/// output from t = 20 (measured at most 8.7e−5, at t = 21.5; 6.8e−5 from t = 40), and
/// ≤ 2e−4 from t = 5 (1.6e−4 at t = 5.5). Before t = 5 the law is a few cells wide and the
/// target is out of reach of a uniform grid: at t = 0.5 the displacement's standard
/// deviation is 0.05 from the point, 0.15 from the start, two cells (measured L1 6.2e−3).
/// The error is spatial: at tolerance 3e−5 the worst from t = 10 moves from 1.14e−4 to
/// 1.09e−4. About 45 s of CPU (`cargo test --release --test transient_modulated_rest --
/// --ignored`).
#[test]
#[ignore]
fn the_whole_history_within_1e_4_of_the_law() {
    let (n, half) = (208, 7.5);
    let times: Vec<f64> = (0..161).map(|i| 0.5 * i as f64).collect();
    let h = GridTransient::new(&modulated())
        .cells(n, n)
        .domain(Domain {
            x: [-half, half],
            v: [-half, half],
        })
        .initial(Initial::Rest)
        .tolerance(1e-4)
        .estimate(false)
        .times(times.clone())
        .run()
        .unwrap();
    let s0 = (POINT_CELLS * 2.0 * half / n as f64).powi(2);
    let laws = lyapunov(
        C,
        K,
        envelope_squared,
        [0.0; 2],
        [[s0, 0.0], [0.0, s0]],
        &times,
    );
    for (s, (_, cov)) in h.snapshots.iter().zip(&laws) {
        let l1: [f64; 2] =
            std::array::from_fn(|axis| l1_gaussian(&s.marginals[axis], 0.0, cov[axis][axis]));
        eprintln!("t={:4.1}: L1 z {:.2e}, v {:.2e}", s.t, l1[0], l1[1]);
        let bound = if s.t >= 20.0 {
            1e-4
        } else if s.t >= 5.0 {
            2e-4
        } else {
            continue;
        };
        assert!(l1[0].max(l1[1]) <= bound, "t={}: {l1:?}", s.t);
    }
    eprintln!("{:?}", h.report);
}
