//! Critical points of an observable g (∇g = 0) where the density is positive: found by
//! Newton from the bracketing grid, classified by the Hessian (minimum, maximum, saddle,
//! degenerate). An extremum's small closed level-set component is taken from its exact limit
//! p(x*)·2π/√det H (see `level.rs`).

use nalgebra::Matrix2;

use crate::density::JointDensity;
use crate::symbolic::Tape;

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Kind {
    Min,
    Max,
    Saddle,
    Degenerate,
}

#[derive(Clone, Debug)]
pub(super) struct Critical {
    pub(super) x: [f64; 2],
    pub(super) value: f64,
    pub(super) kind: Kind,
    /// H⁻¹ for an extremum (of −H for a maximum: positive definite either way).
    pub(super) hinv: Matrix2<f64>,
    /// p(x*)·2π/√|det H|: the density of g at the extremum's value (one-sided limit).
    pub(super) limit: f64,
}

/// What the search needs of a prepared level set: g and ∇g, the Hessian, the bracketing
/// grid's frame and the spread of g.
pub(super) struct CriticalSearch<'a> {
    /// Outputs g, ∂1 g, ∂2 g.
    pub(super) tape: &'a Tape,
    /// Outputs ∂11 g, ∂12 g, ∂22 g.
    pub(super) hess: &'a Tape,
    pub(super) ext: [[f64; 2]; 2],
    pub(super) lo: [f64; 2],
    pub(super) h: [f64; 2],
    pub(super) gscale: f64,
    /// Grid points per axis of the bracketing grid.
    pub(super) nodes: usize,
}

impl CriticalSearch<'_> {
    /// Critical points of g where the density is positive: Newton on ∇g = 0 from the grid
    /// points where |∇g| is a local minimum.
    pub(super) fn find(
        &self,
        density: &dyn JointDensity,
        grad2: &[f64],
        p: &[f64],
    ) -> Vec<Critical> {
        let hess = self.hess;
        let n = self.nodes;
        let pmax = p.iter().copied().fold(0.0, f64::max);
        let gradmax = grad2
            .iter()
            .zip(p)
            .filter(|(g, p)| **p > 0.0 && g.is_finite())
            .map(|(g, _)| *g)
            .fold(0.0, f64::max)
            .sqrt();
        let mut seeds: Vec<(f64, usize)> = Vec::new();
        for i in 1..n - 1 {
            for j in 1..n - 1 {
                let k = i * n + j;
                if p[k] <= 1e-300 * pmax || p[k].is_nan() || !grad2[k].is_finite() {
                    continue;
                }
                // Among the neighbours inside the support: a critical point on a wall (the
                // energy's minimum at a wall through the rest position) has its smallest
                // |∇g| outside, where the density is 0.
                let local_min = (i - 1..=i + 1).all(|a| {
                    (j - 1..=j + 1).all(|b| {
                        let q = grad2[a * n + b];
                        !q.is_finite() || p[a * n + b] <= 0.0 || grad2[k] <= q
                    })
                });
                if local_min {
                    seeds.push((grad2[k], k));
                }
            }
        }
        seeds.sort_by(|a, b| a.0.total_cmp(&b.0));
        seeds.truncate(256);
        let width = (self.ext[0][1] - self.ext[0][0]).max(self.ext[1][1] - self.ext[1][0]);
        let mut found: Vec<Critical> = Vec::new();
        let (mut scratch, mut out, mut hout) = (Vec::new(), [0.0; 3], [0.0; 3]);
        for &(_, k) in &seeds {
            let mut x = [
                self.lo[0] + (k / n) as f64 * self.h[0],
                self.lo[1] + (k % n) as f64 * self.h[1],
            ];
            let mut converged = false;
            for _ in 0..60 {
                self.tape.eval(&x, &mut scratch, &mut out);
                hess.eval(&x, &mut scratch, &mut hout);
                let (g1, g2) = (out[1], out[2]);
                if g1 == 0.0 && g2 == 0.0 {
                    converged = true;
                    break;
                }
                let [h11, h12, h22] = hout;
                let det = Matrix2::new(h11, h12, h12, h22).determinant();
                let norm2 = h11 * h11 + 2.0 * h12 * h12 + h22 * h22;
                let step = if det.abs() > 1e-10 * norm2 {
                    [(h22 * g1 - h12 * g2) / det, (-h12 * g1 + h11 * g2) / det]
                } else {
                    // Singular Hessian: Newton along the gradient.
                    let hg = [h11 * g1 + h12 * g2, h12 * g1 + h22 * g2];
                    let c = g1 * hg[0] + g2 * hg[1];
                    if c == 0.0 || !c.is_finite() {
                        break;
                    }
                    let t = (g1 * g1 + g2 * g2) / c;
                    [t * g1, t * g2]
                };
                if !(step[0].is_finite() && step[1].is_finite()) {
                    break;
                }
                x = [x[0] - step[0], x[1] - step[1]];
                if (0..2).any(|a| x[a] < self.ext[a][0] || x[a] > self.ext[a][1]) {
                    break;
                }
                if step[0].abs().max(step[1].abs()) < 1e-14 * width {
                    self.tape.eval(&x, &mut scratch, &mut out);
                    converged = true;
                    break;
                }
            }
            if !converged {
                continue;
            }
            let grad = out[1].hypot(out[2]);
            if grad.is_nan() || grad > 1e-9 * gradmax.max(1e-300) || !out[0].is_finite() {
                continue;
            }
            let px = density.pdf(x);
            if px.is_nan() || px <= 0.0 {
                continue;
            }
            hess.eval(&x, &mut scratch, &mut hout);
            let [h11, h12, h22] = hout;
            let hessian = Matrix2::new(h11, h12, h12, h22);
            let det = hessian.determinant();
            let norm2 = h11 * h11 + 2.0 * h12 * h12 + h22 * h22;
            let kind = if det.is_nan() || det.abs() <= 1e-8 * norm2 {
                Kind::Degenerate
            } else if det < 0.0 {
                Kind::Saddle
            } else if h11 + h22 > 0.0 {
                Kind::Min
            } else {
                Kind::Max
            };
            let value = out[0];
            let duplicate = found.iter().any(|c| {
                let near = (c.x[0] - x[0]).abs().max((c.x[1] - x[1]).abs()) < 1e-6 * width;
                let same_degenerate = c.kind == Kind::Degenerate
                    && kind == Kind::Degenerate
                    && (c.value - value).abs() <= 1e-12 * self.gscale;
                near || same_degenerate
            });
            if duplicate {
                continue;
            }
            let s = if kind == Kind::Max { -1.0 } else { 1.0 };
            // (s·H)⁻¹ entry by entry as adj/det (nalgebra's 2×2 inverse; det(s·H) = det H).
            // A singular H is degenerate, whose inverse is never used.
            let hinv = (hessian * s)
                .try_inverse()
                .unwrap_or_else(|| Matrix2::from_element(f64::NAN));
            // The small component around x* is an ellipse; a wall through x* leaves half of
            // it (a line through its centre halves an ellipse) and the density its limit
            // from inside.
            let share = if on_a_wall(density, x, width) {
                0.5
            } else {
                1.0
            };
            let limit = share * px * 2.0 * std::f64::consts::PI / det.abs().sqrt();
            found.push(Critical {
                x,
                value,
                kind,
                hinv,
                limit,
            });
        }
        found
    }
}

/// Whether the density's support ends at `x` along an axis (a wall through `x`): it is zero
/// on one side of `x` and positive on the other, 1e−9 of the extent away.
fn on_a_wall(density: &dyn JointDensity, x: [f64; 2], width: f64) -> bool {
    let step = 1e-9 * width;
    (0..2).any(|a| {
        let at = |d: f64| {
            let mut y = x;
            y[a] += d;
            density.pdf(y)
        };
        let (below, above) = (at(-step), at(step));
        (below <= 0.0) != (above <= 0.0)
    })
}

/// Whether `x` lies on the small component of {g = u} around extremum `c` (used when that
/// component is taken from its exact limit instead).
pub(super) fn in_component(c: &Critical, x: [f64; 2], u: f64) -> bool {
    let d = [x[0] - c.x[0], x[1] - c.x[1]];
    // (x − x*)ᵀ H (x − x*)/2 ≈ |u − u*| on the component; H from H⁻¹.
    let hi = c.hinv;
    let det = hi.determinant();
    let q = (hi[(1, 1)] * d[0] * d[0] - 2.0 * hi[(0, 1)] * d[0] * d[1] + hi[(0, 0)] * d[1] * d[1])
        / det
        / 2.0;
    q <= 4.0 * (u - c.value).abs() + 1e-300
}
