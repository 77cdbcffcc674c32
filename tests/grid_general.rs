//! The grid solver on models of general form (drift in both equations, correlated noise in
//! both, state-dependent diffusion) against exact stationary densities: a 2-D
//! Ornstein–Uhlenbeck process with a non-normal drift matrix (Gaussian, covariance from the
//! Lyapunov equation), and gradient systems with a correlated mobility, constant or
//! state-dependent, whose density is exp(−U) for a double well U. Each is solved at three
//! resolutions on one box: the error estimate must bound the true L1 error of both marginal
//! curves at each, and the error must fall at least at the order the estimate assumes.

use std::path::Path;

use fpsolve::density::JointDensity;
use fpsolve::grid::{Domain, GridError, GridSolution, GridSolver, Unsupported};
use fpsolve::model::{load_model, parse_model, BoundModel};

fn bound(file: &str) -> BoundModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/models")
        .join(file);
    load_model(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .bind(&[])
        .unwrap()
}

/// An exact stationary density: the joint and both marginals.
trait Exact {
    fn pdf(&self, x: f64, y: f64) -> f64;
    fn marginal(&self, axis: usize, u: f64) -> f64;
}

/// N(0, Σ) in the plane.
struct Gaussian {
    s: [[f64; 2]; 2],
}

impl Gaussian {
    /// The stationary law of dX = A X dt + noise of diffusion B: A Σ + Σ Aᵀ + B = 0, three
    /// linear equations in Σ₁₁, Σ₁₂, Σ₂₂ solved by Cramer's rule.
    fn lyapunov(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> Gaussian {
        let m = [
            [2.0 * a[0][0], 2.0 * a[0][1], 0.0],
            [a[1][0], a[0][0] + a[1][1], a[0][1]],
            [0.0, 2.0 * a[1][0], 2.0 * a[1][1]],
        ];
        let rhs = [-b[0][0], -b[0][1], -b[1][1]];
        let det = |m: &[[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let d = det(&m);
        let solve = |k: usize| {
            let mut c = m;
            for (row, r) in c.iter_mut().zip(rhs) {
                row[k] = r;
            }
            det(&c) / d
        };
        let (s11, s12, s22) = (solve(0), solve(1), solve(2));
        Gaussian {
            s: [[s11, s12], [s12, s22]],
        }
    }
}

impl Exact for Gaussian {
    fn pdf(&self, x: f64, y: f64) -> f64 {
        let s = self.s;
        let det = s[0][0] * s[1][1] - s[0][1] * s[0][1];
        let q = (s[1][1] * x * x - 2.0 * s[0][1] * x * y + s[0][0] * y * y) / det;
        (-0.5 * q).exp() / (std::f64::consts::TAU * det.sqrt())
    }

    fn marginal(&self, axis: usize, u: f64) -> f64 {
        let v = self.s[axis][axis];
        (-0.5 * u * u / v).exp() / (std::f64::consts::TAU * v).sqrt()
    }
}

/// p ∝ exp(−U), U = (x² − 1)² + y²/2 + g·x·y.
struct Gibbs {
    g: f64,
    /// The normaliser ∫∫ exp(−U).
    z: f64,
}

impl Gibbs {
    fn new(g: f64) -> Gibbs {
        let mut out = Gibbs { g, z: 1.0 };
        // ∫ exp(−U) dy = √(2π) exp(g²x²/2 − (x² − 1)²), then a fine trapezoid in x
        // (spectrally accurate for this smooth, fast-decaying integrand).
        let (n, lo, hi) = (20_000, -6.0, 6.0);
        let h = (hi - lo) / n as f64;
        out.z = (0..=n)
            .map(|k| out.unnormalised_x(lo + k as f64 * h))
            .sum::<f64>()
            * h;
        out
    }

    fn unnormalised_x(&self, x: f64) -> f64 {
        let w = x * x - 1.0;
        (std::f64::consts::TAU).sqrt() * (0.5 * self.g * self.g * x * x - w * w).exp()
    }

    fn u(&self, x: f64, y: f64) -> f64 {
        let w = x * x - 1.0;
        w * w + 0.5 * y * y + self.g * x * y
    }
}

impl Exact for Gibbs {
    fn pdf(&self, x: f64, y: f64) -> f64 {
        (-self.u(x, y)).exp() / self.z
    }

    fn marginal(&self, axis: usize, u: f64) -> f64 {
        if axis == 0 {
            return self.unnormalised_x(u) / self.z;
        }
        let (n, lo, hi) = (4000, -4.0, 4.0);
        let h = (hi - lo) / n as f64;
        (0..=n)
            .map(|k| (-self.u(lo + k as f64 * h, u)).exp())
            .sum::<f64>()
            * h
            / self.z
    }
}

/// The L1 distance of the solution's marginal curve of `axis` (what it writes: the line
/// integrals of its interpolant) from the exact one, by the midpoint rule at eight points per
/// cell, plus the exact mass outside the box on that axis.
fn curve_l1(sol: &GridSolution, exact: &dyn Exact, axis: usize) -> f64 {
    let d = sol.domain();
    let [lo, hi] = if axis == 0 { d.x } else { d.v };
    let n = 8 * sol.report.cells[axis];
    let h = (hi - lo) / n as f64;
    let whole = [f64::NEG_INFINITY, f64::INFINITY];
    let inside: f64 = (0..n)
        .map(|k| {
            let u = lo + (k as f64 + 0.5) * h;
            let p = JointDensity::line_integral(sol, axis, u, whole).unwrap();
            (p - exact.marginal(axis, u)).abs()
        })
        .sum::<f64>()
        * h;
    // The exact tails beyond the box, out to 3 box widths.
    let w = hi - lo;
    let tails: f64 = [(lo - 3.0 * w, lo), (hi, hi + 3.0 * w)]
        .iter()
        .map(|&(a, b)| {
            let m = 4000;
            let t = (b - a) / m as f64;
            (0..m)
                .map(|k| exact.marginal(axis, a + (k as f64 + 0.5) * t))
                .sum::<f64>()
                * t
        })
        .sum();
    inside + tails
}

/// Σ over cells of |cell average − exact density at its centre| times the cell's area.
fn joint_l1(sol: &GridSolution, exact: &dyn Exact) -> f64 {
    let (mx, mv) = (sol.marginal(0), sol.marginal(1));
    let mut s = 0.0;
    for (i, x) in mx.centres.iter().enumerate() {
        for (j, y) in mv.centres.iter().enumerate() {
            s += (sol.cell(i, j) - exact.pdf(*x, *y)).abs();
        }
    }
    s * mx.width * mv.width
}

/// The covariance matrix of the cell averages (centres as points).
fn covariance(sol: &GridSolution) -> [[f64; 2]; 2] {
    let (mx, mv) = (sol.marginal(0), sol.marginal(1));
    let area = mx.width * mv.width;
    let mut m = [0.0f64; 5];
    for (i, x) in mx.centres.iter().enumerate() {
        for (j, y) in mv.centres.iter().enumerate() {
            let p = sol.cell(i, j) * area;
            m = [
                m[0] + p * x,
                m[1] + p * y,
                m[2] + p * x * x,
                m[3] + p * x * y,
                m[4] + p * y * y,
            ];
        }
    }
    [
        [m[2] - m[0] * m[0], m[3] - m[0] * m[1]],
        [m[3] - m[0] * m[1], m[4] - m[1] * m[1]],
    ]
}

/// One resolution's errors: (cells, L1 of x, L1 of y, joint L1, estimate of x, estimate of y).
type Row = (usize, f64, f64, f64, f64, f64);

/// Solves `file` with a sized box, then on that box at `cells` per axis each: asserts that
/// the estimate bounds both marginals' true L1 errors at every resolution and that the
/// errors fall by at least `ratio` per doubling of the cells; returns the rows and the finest
/// solution.
fn converges(
    file: &str,
    exact: &dyn Exact,
    cells: &[usize],
    ratio: f64,
) -> (Vec<Row>, GridSolution) {
    let model = bound(file);
    let sized = GridSolver::new(&model).cells(100, 100).solve().unwrap();
    let d: Domain = sized.domain();
    let mut rows = Vec::new();
    let mut last = None;
    for &n in cells {
        let sol = GridSolver::new(&model)
            .cells(n, n)
            .domain(d)
            .solve()
            .unwrap();
        let e = sol.report.discretisation_estimate.unwrap();
        let row = (
            n,
            curve_l1(&sol, exact, 0),
            curve_l1(&sol, exact, 1),
            joint_l1(&sol, exact),
            e.x,
            e.v,
        );
        eprintln!(
            "{file} {n}x{n} on {d:?}: L1 x {:.2e} (estimate {:.2e}), y {:.2e} (estimate {:.2e}), \
             joint {:.2e}, clipped {:.1e}, {:.0} ms",
            row.1,
            row.4,
            row.2,
            row.5,
            row.3,
            sol.report.negative_mass,
            sol.report.timings.total_ms
        );
        assert!(
            row.1 <= row.4 && row.2 <= row.5,
            "{file} {n}: estimate below the error: {row:?}"
        );
        assert!(!sol.report.edges.cuts_density, "{file} {n}: {}", sol.report);
        rows.push(row);
        last = Some(sol);
    }
    for w in rows.windows(2) {
        let (a, b) = (w[0], w[1]);
        for (e0, e1, what) in [(a.1, b.1, "x"), (a.2, b.2, "y"), (a.3, b.3, "joint")] {
            assert!(
                e0 / e1 >= ratio,
                "{file}: L1 {what} {e0:.2e} -> {e1:.2e} from {} to {} cells",
                a.0,
                b.0
            );
        }
    }
    (rows, last.unwrap())
}

#[test]
fn ornstein_uhlenbeck_with_a_non_normal_drift_and_correlated_noise() {
    // G = [[1, 0.5], [−0.3, 0.7]], S = [[1, ρ√0.8], [ρ√0.8, 0.8]] with ρ = 0.4: B = G S Gᵀ.
    let g = [[1.0, 0.5], [-0.3, 0.7]];
    let c = 0.4 * 0.8f64.sqrt();
    let s = [[1.0, c], [c, 0.8]];
    let mut b = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            for k in 0..2 {
                for l in 0..2 {
                    b[i][j] += g[i][k] * s[k][l] * g[j][l];
                }
            }
        }
    }
    let exact = Gaussian::lyapunov([[-1.0, 3.0], [-0.5, -2.0]], b);
    let (_, fine) = converges("ou_nonnormal.sde", &exact, &[50, 100, 200], 2.5);
    let cov = covariance(&fine);
    for i in 0..2 {
        for j in 0..2 {
            let scale = (exact.s[i][i] * exact.s[j][j]).sqrt();
            assert!(
                (cov[i][j] - exact.s[i][j]).abs() < 5e-3 * scale,
                "covariance {cov:?} against {:?}",
                exact.s
            );
        }
    }
}

#[test]
fn gradient_system_with_a_correlated_constant_mobility() {
    converges(
        "gibbs_double_well.sde",
        &Gibbs::new(0.3),
        &[50, 100, 200],
        2.5,
    );
}

#[test]
fn gradient_system_with_a_state_dependent_mobility() {
    converges(
        "gibbs_state_diffusion.sde",
        &Gibbs::new(0.3),
        &[50, 100, 200],
        2.5,
    );
}

/// An impact law on a general form is refused before any work, naming what applies.
#[test]
fn an_impact_law_on_a_general_form_is_refused() {
    let bound = parse_model(
        "model m\nstate x, y\ndrift x: y - x\ndrift y: -x\nnoise xi: intensity 1\n\
         diffusion y: xi\nimpact x = 0: y -> -0.9*y\ndomain x >= 0\n",
        None,
    )
    .unwrap()
    .bind(&[])
    .unwrap();
    let err = GridSolver::new(&bound).check().unwrap_err();
    assert!(matches!(
        err,
        GridError::Unsupported {
            reason: Unsupported::ImpactOfGeneralForm { .. },
            ..
        }
    ));
}

/// A box given for a general model need not hold 0 in the second state, and one that cuts
/// the density is flagged with the mass at its edges (counted in the estimate).
#[test]
fn a_given_box_is_used_and_a_cut_is_flagged() {
    let model = bound("ou_nonnormal.sde");
    let d = Domain {
        x: [-6.0, 6.0],
        v: [0.1, 2.0],
    };
    let sol = GridSolver::new(&model)
        .cells(40, 40)
        .domain(d)
        .solve()
        .unwrap();
    assert_eq!(sol.domain(), d);
    assert!(sol.report.edges.cuts_density, "{}", sol.report);
}
