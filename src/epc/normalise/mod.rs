//! Normalising C·exp(Q) honestly: on the plane when the top-degree part of Q is negative
//! definite; otherwise inside the ridge that separates the mode from where exp(Q) grows again,
//! if that ridge is deep enough; otherwise not at all.
//!
//! Inside a ridge the density is exp(Q) on the region (the connected component of
//! {Q > floor} holding the mode, the floor one e-fold above the pass) times a C^∞ cutoff that
//! falls from 1 to 0 across the last e-fold above the floor: the region's edge is the smooth
//! level set Q = floor and the density is continuous there, so that integrals of it (the
//! normalisation here, line integrals in `observe`) converge fast.
//!
//! Everything here works in scaled variables ξ; the integral uses the trapezoid rule on a
//! tensor grid reaching exp(Q − Qmax) < e^−40 on the plane, or the ridge region's edge
//! (spectrally accurate for a smooth, decaying integrand). The spacing starts at 0.2 and is
//! halved until the sums on spacings h and 2h agree to 1e−9 (inside a ridge, to the larger of
//! 1e−9 and e^-(depth−1), the share of the mass near the region's edge); |Z_h − Z_2h|/Z_h is
//! reported as the error estimate.
//!
//! What that states for the density, and so for everything taken from it
//! ([`NormalisationReport::stated_accuracy`]): its values, marginals and moments are relative
//! to Z, known to the tolerance the grid was accepted at; inside a ridge that is e^-(depth-1),
//! the order of the mass in the cutoff's transition (2.2e-7 of it for vibro_duffing at degree
//! 4, depth 16.2, against e^-15.2 = 2.4e-7). The observables' fixed rules are accepted at a
//! tenth of it (`observe`), and split each line where the density is not analytic
//! ([`line`]: mask runs, the cutoff's levels).
//!
//! The parts: [`poly`] (Q and its evaluations), [`region`] (mode, rays, passes), [`grid`]
//! (the trapezoid sum on the plane or a ridge's region), [`line`] (a ridge density along a
//! line, split where it is not analytic) and [`report`] (what is reported).

mod grid;
mod line;
mod poly;
mod region;
mod report;

pub(crate) use grid::DensityGrid;
pub(crate) use line::{Stretch, TRANSITION_CHUNK};
pub(crate) use poly::{horner, powers, Poly, MAX_POWER};
pub use report::{NormalisationKind, NormalisationReport, NotNormalisable, RidgeRegion};

use grid::trapezoid_on_region;
use rayon::prelude::*;
use region::{explore_ray, find_mode, saddle_near, RayEnd, RaySteps, TAIL_E_FOLDS};
/// Number of rays used to explore Q around the mode (half a degree apart).
const RAYS: usize = 720;
/// First trapezoid spacing tried (scaled units: the weights' σ are 1).
const START_SPACING: f64 = 0.2;
/// Fewest cells per axis of the normalisation grid (even).
const MIN_CELLS: usize = 48;
/// Most cells per axis: refinement stops there and reports its error estimate as it is.
const MAX_CELLS: usize = 1600;
/// Relative agreement of Z_h and Z_2h at which the grid is accepted.
const NORMALISATION_TOLERANCE: f64 = 1e-9;

impl NormalisationKind {
    /// The relative agreement of Z_h and Z_2h at which the normalisation grid is accepted:
    /// 1e−9 on the plane; inside a ridge of depth d the larger of 1e−9 and e^−(d−1). The mass
    /// near a ridge region's edge, where the cutoff makes the integrand vary on a short
    /// scale, is of order e^−(d−1) of the total (the density there is below e^−(d−1) of its
    /// peak): resolving it beyond that level would cost a much finer grid (8× per axis for
    /// Table 1 case 1) and buy nothing.
    pub(crate) fn tolerance(&self) -> f64 {
        match self {
            NormalisationKind::InsideRidge { depth, .. } => {
                NORMALISATION_TOLERANCE.max((1.0 - depth).exp())
            }
            NormalisationKind::Plane { .. } => NORMALISATION_TOLERANCE,
        }
    }
}

/// Normalises exp(Q) (Q in scaled variables). `threshold` is the least ridge depth accepted.
pub(crate) fn normalise(
    q: &Poly,
    sigma: [f64; 2],
    threshold: f64,
) -> Result<(DensityGrid, NormalisationReport), NotNormalisable> {
    let n = q.degree;
    let top = Poly {
        exps: q.exps.clone(),
        a: q.exps
            .iter()
            .zip(&q.a)
            .map(|(&(i, j), a)| if i + j == n { *a } else { 0.0 })
            .collect(),
        degree: n,
    };
    // Each ray's direction, computed once (the same expressions as before, so the same bits).
    let dirs: Vec<[f64; 2]> = (0..RAYS)
        .map(|k| {
            let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
            [th.cos(), th.sin()]
        })
        .collect();
    let top_max = dirs
        .iter()
        .map(|&u| top.eval(u))
        .fold(f64::NEG_INFINITY, f64::max);
    let mode = find_mode(q)?;
    let q_mode = q.eval(mode);
    let steps = RaySteps::get();
    // Q along each ray (explored, then scanned for the region's reach), the rays on their own
    // tasks: each ray's result is its own, and an error is the first in ray order, as in a
    // loop over the rays.
    let (rays, ends): (Vec<Vec<f64>>, Vec<Result<RayEnd, NotNormalisable>>) = dirs
        .par_iter()
        .enumerate()
        .map(|(k, &u)| {
            let c = q.along_ray(mode, u);
            let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
            let end = explore_ray(&c, steps, th, q_mode);
            (c, end)
        })
        .unzip();
    let ends: Vec<RayEnd> = ends.into_iter().collect::<Result<_, _>>()?;
    let plane = ends.iter().all(|e| matches!(e, RayEnd::Decays(_)));
    let mut cut = vec![0.0; RAYS];
    let kind;
    if plane {
        for (c, e) in cut.iter_mut().zip(&ends) {
            if let RayEnd::Decays(r) = e {
                *c = *r;
            }
        }
        kind = NormalisationKind::Plane {
            top_degree_max: top_max,
        };
    } else {
        let mut pass = (f64::NEG_INFINITY, [0.0; 2]);
        for (k, (c, e)) in cut.iter_mut().zip(&ends).enumerate() {
            let th = k as f64 / RAYS as f64 * std::f64::consts::TAU;
            match e {
                RayEnd::Decays(r) => *c = *r,
                RayEnd::Pass { r, value } => {
                    *c = *r;
                    if *value > pass.0 {
                        pass = (*value, [mode[0] + r * th.cos(), mode[1] + r * th.sin()]);
                    }
                }
            }
        }
        // Rays only bound the pass from below; the saddle point of Q near the best ray's
        // lowest point is the true pass when Newton finds it.
        if let Some((x, v)) = saddle_near(q, pass.1) {
            // The sampled ray minima are coarse (steps of 1% of r): a saddle next to the best
            // one is the exact pass.
            let near = (x[0] - pass.1[0]).hypot(x[1] - pass.1[1])
                < 0.05 * (1.0 + pass.1[0].hypot(pass.1[1]));
            if (v > pass.0 || near) && v < q_mode {
                pass = (v, x);
            }
        }
        let depth = q_mode - pass.0;
        if depth < threshold {
            return Err(NotNormalisable::ShallowRidge {
                degree: n,
                top_degree_max: top_max,
                depth,
                threshold,
            });
        }
        kind = NormalisationKind::InsideRidge {
            depth,
            threshold,
            pass_at: [pass.1[0] * sigma[0], pass.1[1] * sigma[1]],
            region: RidgeRegion::ModeComponent,
        };
    }
    // The region's reach along each ray: where Q last stands above the floor (the region's
    // edge inside a ridge; TAIL_E_FOLDS below the peak on the plane), up to the ray's cut.
    let floor = match &kind {
        NormalisationKind::InsideRidge { depth, .. } => q_mode - depth + 1.0,
        NormalisationKind::Plane { .. } => q_mode - TAIL_E_FOLDS,
    };
    let mut lo = mode;
    let mut hi = mode;
    for ((&limit, &u), c) in cut.iter().zip(&dirs).zip(&rays) {
        let reach = steps.last_at_or_above(c, limit, floor);
        for a in 0..2 {
            let p = mode[a] + (reach + 0.01 * (1.0 + reach)) * u[a];
            lo[a] = lo[a].min(p);
            hi[a] = hi[a].max(p);
        }
    }
    // Trapezoid sums on grids of halving spacing until Z_h and Z_2h agree to
    // NORMALISATION_TOLERANCE (spectral convergence on the plane; first order at a ridge's
    // edge, where the density is below e^-(depth-1) of the peak).
    let mut cells = [0, 1].map(|a| {
        let c = ((hi[a] - lo[a] + 0.4) / START_SPACING).ceil() as usize;
        (c + c % 2).max(MIN_CELLS)
    });
    loop {
        let (grid, z, z2) = trapezoid_on_region(q, &kind, mode, q_mode, floor, lo, hi, cells)?;
        let err = ((z - z2) / z).abs();
        let tolerance = kind.tolerance();
        let at_cap = cells.iter().any(|c| 2 * c > MAX_CELLS);
        if err <= tolerance || at_cap {
            let report = NormalisationReport {
                kind,
                mode: [mode[0] * sigma[0], mode[1] * sigma[1]],
                log_c: -grid.log_z - (sigma[0] * sigma[1]).ln(),
                grid: [grid.g1.len(), grid.g2.len()],
                spacing: grid.h,
                error_estimate: err,
            };
            return Ok((grid, report));
        }
        cells = cells.map(|c| 2 * c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn gaussian_normalises_on_the_plane() {
        // Q = −ξ1²/2 − ξ2²/2 + 0.3 ξ1: mode at (0.3, 0), Z = 2π e^{0.045}.
        let q = Poly {
            exps: vec![(1, 0), (0, 1), (2, 0), (1, 1), (0, 2)],
            a: vec![0.3, 0.0, -0.5, 0.0, -0.5],
            degree: 2,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 12.0) else {
            panic!("normalisable")
        };
        assert!(matches!(rep.kind, NormalisationKind::Plane { .. }));
        assert_relative_eq!(rep.mode[0], 0.3, epsilon = 1e-10);
        assert_relative_eq!(
            grid.log_z,
            (std::f64::consts::TAU).ln() + 0.045,
            epsilon = 1e-10
        );
    }

    #[test]
    fn growing_q_is_cut_at_its_ridge_or_refused() {
        // Q = −ξ1²/2 − ξ2²/2 + b ξ1³: unbounded along +ξ1 when b > 0; saddle at ξ1 = 1/(3b),
        // depth 1/(54 b²).
        for (b, ok) in [(0.02, true), (0.1, false)] {
            let q = Poly {
                exps: vec![(2, 0), (0, 2), (3, 0)],
                a: vec![-0.5, -0.5, b],
                degree: 3,
            };
            match normalise(&q, [1.0, 1.0], 12.0) {
                Ok((_, rep)) => {
                    assert!(ok);
                    let NormalisationKind::InsideRidge { depth, .. } = rep.kind else {
                        panic!("ridge expected")
                    };
                    assert_relative_eq!(depth, 1.0 / (54.0 * b * b), max_relative = 1e-9);
                }
                Err(e) => {
                    assert!(!ok, "{e}");
                    let NotNormalisable::ShallowRidge { depth, .. } = e else {
                        panic!("a shallow ridge expected: {e:?}")
                    };
                    assert_relative_eq!(depth, 1.0 / (54.0 * b * b), max_relative = 1e-9);
                }
            }
        }
    }

    #[test]
    fn purely_quartic_q_has_a_degenerate_mode_and_normalises() {
        // Q = −(ξ1² + ξ2²)²: zero Hessian at the mode; Z = ∫ e^{−r⁴} dξ = π^{3/2}/2.
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (4, 0), (2, 2), (0, 4)],
            a: vec![0.0, 0.0, -1.0, -2.0, -1.0],
            degree: 4,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 12.0) else {
            panic!("normalisable")
        };
        assert!(matches!(rep.kind, NormalisationKind::Plane { .. }));
        assert_relative_eq!(rep.mode[0], 0.0, epsilon = 1e-12);
        assert_relative_eq!(
            grid.log_z,
            (std::f64::consts::PI.powf(1.5) / 2.0).ln(),
            epsilon = 1e-8
        );
    }

    #[test]
    fn a_saddle_is_not_a_mode() {
        // Q = ξ1² − ξ2² − ξ1⁴ − ξ2⁴ has a saddle at the origin and modes at (±1/√2, 0).
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (4, 0), (0, 4)],
            a: vec![1.0, -1.0, -1.0, -1.0],
            degree: 4,
        };
        let mode = find_mode(&q).expect("a mode");
        assert_relative_eq!(mode[0].abs(), 0.5_f64.sqrt(), epsilon = 1e-8);
    }

    #[test]
    fn density_inside_a_ridge_integrates_to_one_and_vanishes_continuously_at_the_edge() {
        // Q = −ξ1²/2 − ξ2²/2 + b ξ1³ with a shallow ridge (depth 1/(54 b²) ≈ 3.8 e-folds, so
        // the density at the edge is a few % of the peak and any mismatch between the region
        // of the sum and the region of `weight` would show).
        let b = 0.07;
        let q = Poly {
            exps: vec![(2, 0), (0, 2), (3, 0)],
            a: vec![-0.5, -0.5, b],
            degree: 3,
        };
        let Ok((grid, rep)) = normalise(&q, [1.0, 1.0], 3.0) else {
            panic!("normalisable")
        };
        let NormalisationKind::InsideRidge { depth, .. } = rep.kind else {
            panic!("ridge expected")
        };
        let density = |x: [f64; 2]| {
            let v = q.eval(x);
            (v - grid.log_z).exp() * grid.weight(x, v)
        };
        // Midpoint rule on a grid unrelated to the normalisation grid.
        let (n, lo, hi) = (1500, [-5.0, -4.0], [6.0, 4.0]);
        let h = [(hi[0] - lo[0]) / n as f64, (hi[1] - lo[1]) / n as f64];
        let mut total = 0.0;
        for i in 0..n {
            for j in 0..n {
                total += density([
                    lo[0] + (i as f64 + 0.5) * h[0],
                    lo[1] + (j as f64 + 0.5) * h[1],
                ]);
            }
        }
        total *= h[0] * h[1];
        assert!(
            (total - 1.0).abs() < 1e-4,
            "∫ p = {total} (error estimate {:e})",
            rep.error_estimate
        );
        // Along ξ2 = 0 towards the pass the density falls continuously to 0: the last positive
        // value is far below the density at the floor, e^-(depth-1) of the peak.
        let peak = density([0.0, 0.0]);
        let at_floor = peak * (1.0 - depth).exp();
        let mut last = peak;
        let mut x = 0.0;
        while density([x, 0.0]) > 0.0 {
            last = density([x, 0.0]);
            x += 1e-4;
        }
        assert!(
            x < 1.0 / (3.0 * b),
            "the region stops before the pass at {x}"
        );
        assert!(
            last < 1e-3 * at_floor,
            "jump of {last:e} at the edge ({at_floor:e} at the floor)"
        );
    }
}
