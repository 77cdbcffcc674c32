//! The grid FPK solver against exact stationary densities (energy-type densities of the
//! linear and Duffing oscillators, with and without an elastic barrier), its convergence
//! order, and mass conservation of the impact re-injection.

use std::path::Path;

use fpsolve::grid::{Domain, GridSolution, GridSolver};
use fpsolve::model::{load_model, BoundModel, Override};

fn bound(path: &str, set: &[(&str, f64)]) -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let model = load_model(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let overrides: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
    model.bind(&overrides).unwrap()
}

/// The energy density exp(−f(v²/2 + k x²/2 + μ x⁴/4)) with f = c/(πK), restricted to
/// x > `floor` (x > −∞ without barrier) and normalised there.
struct Energy {
    f: f64,
    k: f64,
    mu: f64,
    floor: f64,
}

impl Energy {
    fn potential(&self, x: f64) -> f64 {
        (-self.f * (self.k * x * x / 2.0 + self.mu * x.powi(4) / 4.0)).exp()
    }

    /// ∫ over [a, b] of the unnormalised x density, Gauss–Legendre on 4 pieces.
    fn integral_x(&self, a: f64, b: f64) -> f64 {
        let (a, b) = (a.max(self.floor), b.max(self.floor));
        if b <= a {
            return 0.0;
        }
        let nodes = [
            (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
            (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
            (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
            (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        ];
        let pieces = 4;
        let h = (b - a) / pieces as f64;
        let mut s = 0.0;
        for p in 0..pieces {
            let m = a + (p as f64 + 0.5) * h;
            for (t, w) in nodes {
                s += w * self.potential(m + t * h / 2.0) * h / 2.0;
            }
        }
        s
    }

    /// Exact cell masses of the marginal of `axis` on the solution's cells.
    fn cell_masses(&self, sol: &GridSolution, axis: usize) -> Vec<f64> {
        let m = sol.marginal(axis);
        let edges = |c: f64| (c - m.width / 2.0, c + m.width / 2.0);
        if axis == 0 {
            let lo = self.floor.max(-60.0);
            let total = (0..600)
                .map(|k| {
                    let a = lo + (60.0 - lo) * k as f64 / 600.0;
                    self.integral_x(a, a + (60.0 - lo) / 600.0)
                })
                .sum::<f64>();
            m.centres
                .iter()
                .map(|&c| {
                    let (a, b) = edges(c);
                    self.integral_x(a, b) / total
                })
                .collect()
        } else {
            let s = (1.0 / self.f).sqrt();
            let cdf = |v: f64| 0.5 * (1.0 + erf(v / (s * std::f64::consts::SQRT_2)));
            m.centres
                .iter()
                .map(|&c| {
                    let (a, b) = edges(c);
                    cdf(b) - cdf(a)
                })
                .collect()
        }
    }

    /// L1 distance of the solution's marginals from the exact ones, (x, v).
    fn l1(&self, sol: &GridSolution) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (axis, o) in out.iter_mut().enumerate() {
            let m = sol.marginal(axis);
            let exact = self.cell_masses(sol, axis);
            *o = m
                .density
                .iter()
                .zip(&exact)
                .map(|(p, e)| (p * m.width - e).abs())
                .sum();
        }
        out
    }
}

/// erf by Abramowitz–Stegun 7.1.26 is too coarse here; use the continued series.
fn erf(x: f64) -> f64 {
    // erf(x) = 2/√π Σ (−1)^n x^(2n+1) / (n! (2n+1)) for |x| < 3, else 1 − erfc asymptotics.
    if x.abs() > 6.0 {
        return x.signum();
    }
    let mut sum = 0.0f64;
    let mut term = x;
    let mut n = 0.0f64;
    while term.abs() > 1e-17 * sum.abs().max(1e-300) || n < 5.0 {
        sum += term / (2.0 * n + 1.0);
        n += 1.0;
        term *= -x * x / n;
        if n > 400.0 {
            break;
        }
    }
    2.0 / std::f64::consts::PI.sqrt() * sum
}

/// p_y and p_ẏ (y = |z|, ẏ = v·sgn z) of a Zhuravlev-form solution, on its own cells above
/// the barrier at 0: (centres of y, p_y, centres of ẏ, p_ẏ).
fn folded(sol: &GridSolution) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let px = sol.marginal(0);
    let pv = sol.marginal(1);
    let k = px.centres.iter().position(|&c| c > 0.0).unwrap();
    let n = (px.centres.len() - k).min(k);
    let y: Vec<f64> = (0..n).map(|i| px.centres[k + i]).collect();
    let py: Vec<f64> = (0..n)
        .map(|i| px.density[k + i] + px.density[k - 1 - i])
        .collect();
    let nv = pv.centres.len();
    let mut pd = vec![0.0; nv];
    for i in 0..px.centres.len() {
        for (j, p) in pd.iter_mut().enumerate() {
            let jj = if i >= k { j } else { nv - 1 - j };
            *p += sol.cell(i, jj) * px.width;
        }
    }
    (y, py, pv.centres.clone(), pd)
}

/// L1 distance between two densities on different cells, the second interpolated linearly
/// onto the first's centres (constant for half a cell beyond its end centres, zero further out).
fn l1_between(xa: &[f64], pa: &[f64], wa: f64, xb: &[f64], pb: &[f64]) -> f64 {
    let interp = |x: f64| {
        let half = 0.5 * (xb[1] - xb[0]);
        if x < xb[0] - half || x > xb[xb.len() - 1] + half {
            return 0.0;
        }
        let x = x.clamp(xb[0], xb[xb.len() - 1]);
        let k = xb.partition_point(|&c| c <= x).clamp(1, xb.len() - 1);
        let t = (x - xb[k - 1]) / (xb[k] - xb[k - 1]);
        (1.0 - t) * pb[k - 1] + t * pb[k]
    };
    xa.iter()
        .zip(pa)
        .map(|(&x, &p)| (p - interp(x)).abs())
        .sum::<f64>()
        * wa
}

const NO_FLOOR: f64 = f64::NEG_INFINITY;

/// Energy densities with c = 0.1, 2πK = 1: f = c/(πK) = 0.2.
fn energy(mu: f64, floor: f64) -> Energy {
    Energy {
        f: 0.2,
        k: 1.0,
        mu,
        floor,
    }
}

fn solve(b: &BoundModel, n: usize) -> GridSolution {
    GridSolver::new(b)
        .cells(n, 2 * n)
        .estimate(false)
        .solve()
        .unwrap()
}

#[test]
fn linear_and_duffing_match_their_exact_densities() {
    for (file, mu, tol) in [
        ("models/linear.sde", 0.0, 2e-4),
        ("models/duffing.sde", 0.1, 1e-4),
    ] {
        let sol = solve(&bound(file, &[]), 200);
        let l1 = energy(mu, NO_FLOOR).l1(&sol);
        println!("{file}: L1 {:.2e} {:.2e}; {}", l1[0], l1[1], sol.report);
        assert!(l1[0] < tol && l1[1] < tol, "{file}: {l1:?}");
        assert!(sol.report.negative_mass < 1e-9);
    }
}

/// `impact z = 0: v -> v` with no δ term (r = 1) is transparent: the Duffing density.
#[test]
fn zhuravlev_form_with_r_1_is_the_duffing_density() {
    let sol = solve(
        &bound("models/vibro_duffing.sde", &[("r", 1.0), ("eps", 0.0)]),
        200,
    );
    let l1 = energy(0.1, NO_FLOOR).l1(&sol);
    println!("L1 {:.2e} {:.2e}; {}", l1[0], l1[1], sol.report);
    assert!(l1[0] < 1e-4 && l1[1] < 1e-4, "{l1:?}");
}

/// An elastic wall (r = 1) in original coordinates: the barrier-free density restricted to
/// the domain, at the rest position (Duffing, y > 0) and below it (linear, y > −0.5).
#[test]
fn elastic_wall_restricts_the_free_density() {
    let duffing = bound(
        "tests/models/grid_impact_duffing.sde",
        &[("r", 1.0), ("eps", 0.0)],
    );
    let linear = bound("tests/models/grid_impact_linear.sde", &[]);
    for (b, exact) in [(duffing, energy(0.1, 0.0)), (linear, energy(0.0, -0.5))] {
        let sol = solve(&b, 160);
        assert_eq!(sol.domain().x[0], exact.floor);
        let l1 = exact.l1(&sol);
        println!(
            "{}: L1 {:.2e} {:.2e}; {}",
            b.name(),
            l1[0],
            l1[1],
            sol.report
        );
        assert!(l1[0] < 1e-4 && l1[1] < 1e-4, "{}: {l1:?}", b.name());
    }
}

/// L1 of the Duffing marginals behind an elastic wall at 40×80, 80×160 and 160×320 cells:
/// the measured order is at least 2.7 (the face-averaged fluxes are third order: measured
/// 2.93 and 2.97, L1 3.1e−3, 4.1e−4, 5.3e−5; with midpoint fluxes it was about 2, and 1.5
/// to 1.8 at finer cells).
#[test]
fn convergence_order_is_third() {
    let b = bound(
        "tests/models/grid_impact_duffing.sde",
        &[("r", 1.0), ("eps", 0.0)],
    );
    let exact = energy(0.1, 0.0);
    let errors: Vec<f64> = [40, 80, 160]
        .iter()
        .map(|&n| {
            let l1 = exact.l1(&solve(&b, n));
            l1[0] + l1[1]
        })
        .collect();
    let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    let order = (errors[0] / errors[2]).log2() / 2.0;
    println!(
        "L1 {:?}, orders {orders:.2?}, overall {order:.2}",
        errors
            .iter()
            .map(|e| format!("{e:.2e}"))
            .collect::<Vec<_>>()
    );
    assert!(
        orders.iter().all(|&p| p >= 2.7),
        "orders {orders:?}: {errors:?}"
    );
}

/// The paper's case 1 (r = 0.95, eps = 0.1) solved in Zhuravlev form and in original
/// coordinates: p_y and p_ẏ agree (the two discretisations share no cells).
#[test]
fn zhuravlev_and_original_coordinates_agree() {
    let zs = solve(&bound("models/vibro_duffing.sde", &[]), 140);
    let ys = solve(&bound("tests/models/grid_impact_duffing.sde", &[]), 140);
    let (zy, zpy, zv, zpv) = folded(&zs);
    let (my, mv) = (ys.marginal(0), ys.marginal(1));
    let dy = l1_between(&my.centres, &my.density, my.width, &zy, &zpy);
    let dv = l1_between(&mv.centres, &mv.density, mv.width, &zv, &zpv);
    println!("L1(p_y) {dy:.2e}, L1(p_ydot) {dv:.2e}");
    // Measured 7.3e-4 and 1.4e-4 (part of it the interpolation between the two meshes).
    assert!(dy < 1e-3 && dv < 1e-3, "{dy:e} {dv:e}");
}

#[test]
fn unsupported_models_are_refused() {
    use fpsolve::grid::{GridError, Unsupported};
    use fpsolve::model::parse_model;
    // Noise in the position's equation is the general form, which takes no impact law.
    let noisy_position = parse_model(
        "model m\nstate x, v\ndrift x: v\ndrift v: -v - x\nnoise a: intensity 1\n\
         diffusion x: a\ndiffusion v: a\nimpact x = 0: v -> -0.9*v\ndomain x >= 0\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let err = GridSolver::new(&noisy_position).solve().unwrap_err();
    assert!(
        matches!(
            err,
            GridError::Unsupported {
                reason: Unsupported::ImpactOfGeneralForm { .. },
                ..
            }
        ),
        "{err:?}"
    );
    // The δ-term model without its impact law: the grid solver would drop the δ term and
    // solve a different model, so it refuses.
    let delta_only = parse_model(
        "model m\nparam r = 0.9\nstate z, v\ndrift z: v\n\
         drift v: -0.1*v - z - (1 - r)*v*abs(v)*delta(z)\nnoise a: intensity 1\n\
         diffusion v: a\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let err = GridSolver::new(&delta_only).solve().unwrap_err();
    assert!(
        matches!(
            err,
            GridError::Unsupported {
                reason: Unsupported::DeltaWithoutImpact { .. },
                ..
            }
        ),
        "{err:?}"
    );
    let d = Domain {
        x: [1.0, 2.0],
        v: [-1.0, 1.0],
    };
    let z = bound("models/vibro_duffing.sde", &[]);
    let err = GridSolver::new(&z).domain(d).solve().unwrap_err();
    assert!(
        matches!(
            err,
            GridError::Unsupported {
                reason: Unsupported::BarrierOutsideDomain { .. },
                ..
            }
        ),
        "{err:?}"
    );
}

/// The paper's case 1 at the default cells against a 400×800 solve: L1 of p_y and p_ẏ.
#[test]
#[ignore = "measurement: a 400x800 reference solve"]
fn case1_default_cells() {
    for file in [
        "models/vibro_duffing.sde",
        "tests/models/grid_impact_duffing.sde",
    ] {
        let b = bound(file, &[]);
        let reference = solve(&b, 400);
        let zhuravlev = file.contains("vibro");
        let marg = |s: &GridSolution| {
            if zhuravlev {
                folded(s)
            } else {
                let (m, v) = (s.marginal(0), s.marginal(1));
                (m.centres, m.density, v.centres, v.density)
            }
        };
        let (ry, rpy, rv, rpv) = marg(&reference);
        for n in [100, 120, 140] {
            let s = GridSolver::new(&b).cells(n, 2 * n).solve().unwrap();
            let (y, py, v, pv) = marg(&s);
            let dy = l1_between(&y, &py, y[1] - y[0], &ry, &rpy);
            let dv = l1_between(&v, &pv, v[1] - v[0], &rv, &rpv);
            println!(
                "{file} {n}: L1(p_y) {dy:.2e} L1(p_ydot) {dv:.2e}; {} {:?}",
                s.report, s.report.timings
            );
        }
    }
}

/// A cell-average density (cells of `width` centred at `centres`) averaged over [a, b).
fn bin_average(centres: &[f64], density: &[f64], width: f64, a: f64, b: f64) -> f64 {
    centres
        .iter()
        .zip(density)
        .map(|(&c, &p)| {
            let overlap = (b.min(c + width / 2.0) - a.max(c - width / 2.0)).max(0.0);
            p * overlap
        })
        .sum::<f64>()
        / (b - a)
}

/// The paper's case 1 (r = 0.95, eps = 0.1): p_y and p_ẏ of the grid, in Zhuravlev form and
/// in original coordinates, against a Monte Carlo of the original system (impacts located
/// exactly) with a fixed seed: per-bin differences within the Monte Carlo's standard error
/// (4σ) plus the grid's own discretisation estimate.
#[test]
fn case1_agrees_with_monte_carlo() {
    use fpsolve::mc::{Grid, McConfig, Simulation};
    let original = bound("tests/models/grid_impact_duffing.sde", &[]);
    let config = McConfig {
        trajectories: 10_240,
        samples: 1000,
        seed: 11,
        grids: vec![
            ("y".into(), Grid::new(0.0, 8.0, 32).unwrap()),
            ("v".into(), Grid::new(-12.0, 12.0, 48).unwrap()),
        ],
        bias_fraction: 0.0,
        ..McConfig::default()
    };
    let t = std::time::Instant::now();
    let mc = Simulation::new(&original, &config).unwrap().run().unwrap();
    println!(
        "Monte Carlo: {} samples in {:.1} s",
        mc.quantity("y").unwrap().samples,
        t.elapsed().as_secs_f64()
    );
    let ys = GridSolver::new(&original).solve().unwrap();
    let zs = GridSolver::new(&bound("models/vibro_duffing.sde", &[]))
        .solve()
        .unwrap();
    let (zy, zpy, zv, zpv) = folded(&zs);
    let (my, mv) = (ys.marginal(0), ys.marginal(1));
    let zw = [zy[1] - zy[0], zv[1] - zv[0]];
    let densities = [
        ("y", "original", my.centres, my.density, my.width),
        ("v", "original", mv.centres, mv.density, mv.width),
        ("y", "Zhuravlev", zy, zpy, zw[0]),
        ("v", "Zhuravlev", zv, zpv, zw[1]),
    ];
    for (name, form, centres, density, width) in densities {
        let q = mc.quantity(name).unwrap();
        let w = q.grid.width();
        let (mut l1, mut noise, mut worst) = (0.0, 0.0, 0.0f64);
        let peak = q.density.iter().fold(0.0f64, |a, &b| a.max(b));
        for (k, c) in q.grid.centers().iter().enumerate() {
            let g = bin_average(&centres, &density, width, c - w / 2.0, c + w / 2.0);
            let d = (g - q.density[k]).abs();
            l1 += d * w;
            noise += q.stderr[k] * w;
            // The grid's own error: about 1e-3 of the peak (its L1 against the converged answer).
            worst = worst.max(d / (q.stderr[k] + 1e-3 * peak));
        }
        println!("p_{name} ({form}): L1 vs MC {l1:.2e}, MC noise (sum of stderr) {noise:.2e}, worst bin {worst:.1} sigma");
        assert!(
            l1 < 2.0 * noise + 2e-3,
            "p_{name} ({form}): {l1:e} vs noise {noise:e}"
        );
        assert!(
            worst < 5.0,
            "p_{name} ({form}): a bin {worst} standard errors off"
        );
    }
}

/// The solution is a `JointDensity`: the observables' PDFs (here y = |z| by the exact line
/// integrals of `observe`) come out of it, and match the exact 2·p_z(y) at r = 1, eps = 0.
#[test]
fn observables_of_the_grid_density() {
    use fpsolve::observe::{observable_pdf, ObservableMap};
    let b = bound("models/vibro_duffing.sde", &[("r", 1.0), ("eps", 0.0)]);
    let sol = solve(&b, 120);
    let y = &b.observables()[0];
    let map = ObservableMap::classify(&y.expr, b.states());
    let u = [0.25, 1.0, 2.0, 4.0];
    let p = observable_pdf(&sol, &map, &u);
    let exact = energy(0.1, NO_FLOOR);
    let norm: f64 = (0..600)
        .map(|k| exact.integral_x(-60.0 + 0.2 * k as f64, -59.8 + 0.2 * k as f64))
        .sum();
    for (&y, &p) in u.iter().zip(&p) {
        let want = 2.0 * exact.potential(y) / norm;
        println!("p_y({y}) = {p:.6}, exact {want:.6}");
        // Measured within 2.5e-4 (the peak is 0.42): bilinear between cell averages.
        assert!((p - want).abs() < 5e-4, "p_y({y}) = {p}, exact {want}");
    }
}

/// Every bundled model either solves (unit mass, finite, no large clipped mass) or is
/// refused with a typed reason; none returns a wrong number silently.
#[test]
fn bundled_models_solve_or_are_refused() {
    use fpsolve::grid::GridError;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for path in files {
        let b = load_model(&path).unwrap().bind(&[]).unwrap();
        match GridSolver::new(&b).cells(60, 120).solve() {
            Ok(sol) => {
                let px = sol.marginal(0);
                let mass: f64 = px.density.iter().sum::<f64>() * px.width;
                println!("{}: {}", b.name(), sol.report);
                assert!((mass - 1.0).abs() < 1e-12 && px.density.iter().all(|p| p.is_finite()));
            }
            Err(e @ (GridError::Unsupported { .. } | GridError::DomainNotFound { .. })) => {
                println!("{}: refused: {e}", b.name());
            }
            Err(e) => panic!("{}: {e:?}", b.name()),
        }
    }
}
