//! Two reflecting walls bounding a strip, set in code on a barrier-free oscillator so that
//! one model serves every strip and restitution these tests try: the domain is the strip exactly, the flux re-enters at both walls with mass
//! conserved, the elastic strip converges to the exact restricted density at order ≥ 2,
//! and an inelastic strip agrees with Monte Carlo.

use super::assemble::assemble;
use super::mesh::{Domain, Mesh};
use super::problem::Mechanical;
use super::{BarrierSide, GridSolution, GridSolver};
use crate::dynamics::{Barrier, Barriers, Dynamics};
use crate::mc::reference::bin_errors;
use crate::mc::strip_tests::{run_strip, OSCILLATOR};

const STRIP: [f64; 2] = [-0.6, 0.8];

fn walls(r: f64) -> Barriers {
    Barriers::Strip {
        lo: Barrier::restitution(STRIP[0], BarrierSide::Above, r),
        hi: Barrier::restitution(STRIP[1], BarrierSide::Below, r),
    }
}

/// The solution on `n`×2n cells, on the strip × [−4.5, 4.5] (the density down to e^−35;
/// the automatic box, sized for linear damping, is twice as wide in v) or sized itself.
fn solve(r: f64, n: usize, sized: bool) -> GridSolution {
    let model = OSCILLATOR.model().bind(&[]).unwrap();
    let solver = GridSolver::new(&model)
        .barriers(walls(r))
        .cells(n, 2 * n)
        .estimate(false);
    let solver = if sized {
        solver
    } else {
        solver.domain(Domain {
            x: STRIP,
            v: [-4.5, 4.5],
        })
    };
    solver.solve().unwrap()
}

/// Every column of the operator sums to zero and both walls put back what leaves them.
#[test]
fn both_walls_conserve_mass() {
    let model = OSCILLATOR.model().bind(&[]).unwrap();
    let dynamics = Dynamics::read(&model);
    let problem = Mechanical::with_barriers(&model, &dynamics, &walls(0.9)).unwrap();
    let d = Domain {
        x: [-3.0, 3.0],
        v: [-4.0, 4.0],
    };
    let mesh = Mesh::new(d, 24, 36, &problem.barriers, 4);
    assert_eq!(mesh.domain().x, STRIP);
    assert_eq!(mesh.exits.len(), 2);
    let op = assemble(&mesh, &problem).unwrap();
    let n = mesh.cells();
    let mut total = vec![0.0; n];
    for t in op
        .transport
        .iter()
        .chain(&op.outflow)
        .chain(&op.reinjection)
    {
        total[t.col] += t.val;
    }
    let scale = op.transport.iter().fold(0.0f64, |a, t| a.max(t.val.abs()));
    let worst = total.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    assert!(worst <= 1e-13 * scale, "column sum {worst:e}");
    // Flux leaves at both walls: through the lower one at v < 0, the upper one at v > 0.
    let rows: Vec<usize> = op.outflow.iter().map(|t| t.row / mesh.nv).collect();
    assert!(rows.contains(&0) && rows.contains(&(mesh.nx - 1)));
}

/// (L1, max |log10 ratio|) of both marginals against the exact restricted density.
fn errors(sol: &GridSolution) -> [(f64, f64); 2] {
    std::array::from_fn(|axis| {
        let m = sol.marginal(axis);
        let mut edges: Vec<f64> = m.centres.iter().map(|c| c - 0.5 * m.width).collect();
        edges.push(m.centres[m.centres.len() - 1] + 0.5 * m.width);
        let exact = OSCILLATOR.bin_masses(axis, &edges, STRIP);
        bin_errors(&exact, &m.density, m.width, 1e-6)
    })
}

#[test]
fn elastic_strip_converges_at_order_two() {
    let mut l1 = Vec::new();
    for n in [40, 80, 160] {
        let sol = solve(1.0, n, false);
        assert_eq!(sol.domain().x, STRIP);
        let e = errors(&sol);
        println!(
            "strip {n}x{}: L1 {:.2e} {:.2e}, max|log10| {:.2e} {:.2e}; {}",
            2 * n,
            e[0].0,
            e[1].0,
            e[0].1,
            e[1].1,
            sol.report
        );
        l1.push(e[0].0 + e[1].0);
    }
    // Measured 1.76 then 1.89, rising towards 2 (1.95 from 160×320 to 320×640 in the
    // release-mode `strip_r09_against_a_long_monte_carlo`).
    let last = (l1[1] / l1[2]).log2();
    println!("strip: orders {:.2} {last:.2}", (l1[0] / l1[1]).log2());
    assert!(last >= 1.8, "order {last:.2}, L1 {l1:?}");
    assert!(l1[2] < 1e-4, "L1 {:.2e}", l1[2]);
    // The automatic domain: v only (the strip is narrower than the density's reach).
    let sol = solve(1.0, 140, true);
    assert_eq!(sol.domain().x, STRIP);
    let e = errors(&sol);
    println!(
        "strip default: L1 {:.2e} {:.2e}, max|log10| {:.2e} {:.2e}; {}",
        e[0].0, e[1].0, e[0].1, e[1].1, sol.report
    );
    assert!(e[0].0 < 1e-3 && e[1].0 < 1e-3, "{e:?}");
}

/// (L1, max |log10 ratio|, Σ se·w) of the grid's marginal `axis` against a Monte Carlo
/// histogram, the grid's density averaged over the histogram's bins.
fn against_mc(sol: &GridSolution, q: &crate::mc::QuantityHistogram, axis: usize) -> [f64; 3] {
    let m = sol.marginal(axis);
    let g = q.grid;
    let lo = m.centres[0] - 0.5 * m.width;
    let grid_bins: Vec<f64> = (0..g.bins)
        .map(|j| {
            // The grid's mass in [a, b], cell by cell (the cells are uniform).
            let (a, b) = (
                g.lo + j as f64 * g.width(),
                g.lo + (j + 1) as f64 * g.width(),
            );
            m.density
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let (c0, c1) = (lo + i as f64 * m.width, lo + (i + 1) as f64 * m.width);
                    p * (b.min(c1) - a.max(c0)).max(0.0)
                })
                .sum::<f64>()
        })
        .collect();
    let (l1, log) = bin_errors(&grid_bins, &q.density, g.width(), 1e-3);
    [l1, log, q.stderr.iter().sum::<f64>() * g.width()]
}

/// r = 0.9 between the walls: the grid against a short Monte Carlo, within its noise (the
/// release-mode check with 1e8 samples is `strip_r09_against_a_long_monte_carlo`).
#[test]
fn inelastic_strip_agrees_with_monte_carlo() {
    let sol = solve(0.9, 140, true);
    let res = run_strip(STRIP, 0.9, [28, 28], 2048, 1000).unwrap();
    for (axis, name) in [(0, "z"), (1, "v")] {
        let [l1, log, noise] = against_mc(&sol, res.quantity(name).unwrap(), axis);
        println!(
            "r = 0.9 {name}: grid vs MC L1 {l1:.2e} (MC noise {noise:.1e}), max|log10| {log:.2e}"
        );
        assert!(l1 < 2.0 * noise, "{name}: L1 {l1:.2e}, noise {noise:.1e}");
    }
}

/// The release-mode check: `FPSOLVE_STRIP_SAMPLES=1e8 cargo test --release --lib
/// strip_r09 -- --ignored --nocapture`.
#[test]
#[ignore]
fn strip_r09_against_a_long_monte_carlo() {
    let samples: f64 = std::env::var("FPSOLVE_STRIP_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1e8);
    let l1: Vec<f64> = [160, 320]
        .iter()
        .map(|&n| {
            let e = errors(&solve(1.0, n, false));
            println!(
                "elastic strip {n}x{}: L1 {:.2e} {:.2e}, max|log10| {:.2e} {:.2e}",
                2 * n,
                e[0].0,
                e[1].0,
                e[0].1,
                e[1].1
            );
            e[0].0 + e[1].0
        })
        .collect();
    let order = (l1[0] / l1[1]).log2();
    println!("elastic strip: order {order:.2} from 160x320 to 320x640");
    let t = std::time::Instant::now();
    let sol = solve(0.9, 140, true);
    let grid_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = std::time::Instant::now();
    let per = (samples / 4096.0).ceil() as u64;
    let res = run_strip(STRIP, 0.9, [70, 70], 4096, per).unwrap();
    println!(
        "MC {:.2e} samples in {:.1} s; grid 140x280 in {grid_ms:.0} ms; {}",
        (4096 * per) as f64,
        t.elapsed().as_secs_f64(),
        sol.report
    );
    for (axis, name) in [(0, "z"), (1, "v")] {
        let [l1, log, noise] = against_mc(&sol, res.quantity(name).unwrap(), axis);
        println!(
            "r = 0.9 {name}: grid vs MC L1 {l1:.2e} (MC noise {noise:.1e}), max|log10| {log:.2e}"
        );
        assert!(l1 < 1e-3, "{name}: L1 {l1:.2e}");
    }
}
