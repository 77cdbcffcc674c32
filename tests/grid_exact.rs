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
            let total = self.integral_x(lo, 60.0);
            let total = (0..600)
                .map(|k| {
                    let a = lo + (60.0 - lo) * k as f64 / 600.0;
                    self.integral_x(a, a + (60.0 - lo) / 600.0)
                })
                .sum::<f64>()
                .max(total * 0.0 + 0.0);
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

#[test]
fn explore() {
    let cases: Vec<(&str, Vec<(&str, f64)>, Energy)> = vec![
        ("models/linear.sde", vec![], Energy { f: 0.2, k: 1.0, mu: 0.0, floor: f64::NEG_INFINITY }),
        ("models/duffing.sde", vec![], Energy { f: 0.2, k: 1.0, mu: 0.1, floor: f64::NEG_INFINITY }),
        ("models/vibro_duffing.sde", vec![("r", 1.0), ("eps", 0.0)], Energy { f: 0.2, k: 1.0, mu: 0.1, floor: f64::NEG_INFINITY }),
        ("tests/models/grid_impact_duffing.sde", vec![("r", 1.0), ("eps", 0.0)], Energy { f: 0.2, k: 1.0, mu: 0.1, floor: 0.0 }),
        ("tests/models/grid_impact_linear.sde", vec![], Energy { f: 0.2, k: 1.0, mu: 0.0, floor: -0.5 }),
    ];
    for (file, set, exact) in cases {
        let b = bound(file, &set);
        for n in [50, 100, 200] {
            let sol = GridSolver::new(&b).cells(n, 2 * n).solve().unwrap();
            let l1 = exact.l1(&sol);
            println!("{file} {n}: L1 x {:.2e} v {:.2e}; {}", l1[0], l1[1], sol.report);
        }
    }
    let _ = Domain { x: [0.0, 1.0], v: [-1.0, 1.0] };
}
