//! SDEtools' van der Pol vignette (`tests/models/vdp_vignette.sde`: an unstable origin, a limit
//! cycle), which the grid once refused at every cell count: its box now comes from the
//! density, holds it to 1e−9 of its peak, and its marginals match a 10⁹-sample Monte Carlo
//! (stored in `tests/data/vdp_vignette_mc/`, with the command that made it) within the
//! grid's own error estimate and the Monte Carlo's noise.

use std::path::Path;

use fpsolve::density::JointDensity;
use fpsolve::grid::GridSolver;
use fpsolve::model::load_model;

/// (bin centre, density, standard error) of a stored Monte Carlo histogram.
fn histogram(name: &str) -> Vec<[f64; 3]> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/vdp_vignette_mc")
        .join(name);
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|f| f.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[test]
fn the_vignette_solves_and_matches_monte_carlo() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/models/vdp_vignette.sde");
    let bound = load_model(&path).unwrap().bind(&[]).unwrap();
    let sol = GridSolver::new(&bound).solve().unwrap();
    let report = &sol.report;
    let est = report.discretisation_estimate.unwrap();
    // The box ends where the density is negligible, and not far beyond.
    let edges = report.edges;
    assert!(!edges.cuts_density, "{edges:?}");
    assert!(edges.beyond.iter().sum::<f64>() < 1e-9, "{edges:?}");
    let d = report.domain;
    assert!(
        d.x[1] < 4.0 && d.v[1] < 6.5,
        "box {d:?} wider than the density needs"
    );
    for (axis, file) in [(0, "mc_x.csv"), (1, "mc_v.csv")] {
        let mc = histogram(file);
        let w = mc[1][0] - mc[0][0];
        let (mut l1, mut noise) = (0.0, 0.0);
        for &[c, p, se] in &mc {
            // The bin average of the grid's curve (16 points).
            let grid: f64 = (0..16)
                .map(|k| {
                    let u = c + ((k as f64 + 0.5) / 16.0 - 0.5) * w;
                    JointDensity::line_integral(&sol, axis, u, [f64::NEG_INFINITY, f64::INFINITY])
                        .unwrap()
                })
                .sum::<f64>()
                / 16.0;
            l1 += (grid - p).abs() * w;
            noise += se * w;
        }
        let stated = if axis == 0 { est.x } else { est.v };
        println!("axis {axis}: L1 {l1:.2e} against Monte Carlo (noise {noise:.1e}), estimate {stated:.2e}");
        assert!(l1 <= stated + 3.0 * noise, "axis {axis}: L1 {l1:.2e}");
    }
}
