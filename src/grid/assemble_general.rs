//! The discrete stationary FPK operator of a general-form model ([`super::general`]).
//!
//! Every face carries the flux J·n of [`super::general`]: the advective part u p with the
//! same κ = 1/3 upwind-biased face values the mechanical form uses, now in both directions;
//! the normal diffusion −½ b_nn ∂n p by the two cells beside the face; the cross diffusion
//! −½ b₁₂ ∂t p (t along the face) by the four-cell corner average, the difference of the
//! two cells' mean one row up and one row down, over two rows (one-sided, over one row, on
//! the first and last rows). Each flux leaves one cell and enters the other, and the outer
//! faces carry none, so every column sums to zero and mass is conserved to rounding.
//!
//! The cross term and the κ = 1/3 values give negative off-diagonal entries (the matrix is
//! not an M-matrix); the negative cell values this leaves where the density falls steeply
//! are clipped and their mass reported and bounded, as on the mechanical path.

use faer::sparse::Triplet;

use super::assemble::{Discretise, Operator};
use super::error::GridError;
use super::general::General;
use super::mesh::{face_weights, wrapped_face_weights, Mesh};

fn push(out: &mut Vec<Triplet<usize, usize, f64>>, row: usize, col: usize, val: f64) {
    if val != 0.0 {
        out.push(Triplet { row, col, val });
    }
}

/// The cells whose combination (with weights) approximates h·∂p/∂t along a face between
/// cells `lo` and `lo + 1` of one axis, at index `k` of the other axis (n cells): the
/// corner average ((p[k+1] + p'[k+1]) − (p[k−1] + p'[k−1])) / 4 over the two cells beside
/// the face, one-sided on the first and last rows. Returns (offset along the other axis,
/// weight) pairs, the offset's cell taken on both sides of the face.
fn tangential(k: usize, n: usize, wrap: bool) -> [(usize, f64); 2] {
    if wrap {
        [((k + 1) % n, 0.25), ((k + n - 1) % n, -0.25)]
    } else if k == 0 {
        [(1, 0.5), (0, -0.5)]
    } else if k + 1 == n {
        [(n - 1, 0.5), (n - 2, -0.5)]
    } else {
        [(k + 1, 0.25), (k - 1, -0.25)]
    }
}

/// Builds the operator of `problem` on `mesh` (no walls: zero flux through every outer
/// face).
pub(crate) fn assemble(mesh: &Mesh, problem: &General) -> Result<Operator, GridError> {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let (hx, hv) = (mesh.hx, mesh.hv);
    let mut t = Vec::with_capacity(mesh.cells() * 24);
    // Faces normal to x at (x0 + (i+1)·hx, centre of row j).
    let (mut xs, mut vs) = (Vec::new(), Vec::new());
    let x_faces = mesh.x_faces();
    for i in 0..x_faces {
        for j in 0..nv {
            xs.push(mesh.x0 + (i + 1) as f64 * hx);
            vs.push(mesh.vc(j));
        }
    }
    let c = problem.eval(&xs, &vs)?;
    for i in 0..x_faces {
        let next = (i + 1) % nx;
        for j in 0..nv {
            let f = i * nv + j;
            let (lo, hi) = (mesh.index(i, j), mesh.index(next, j));
            let a = c.u[0][f] / hx;
            let weights = if mesh.wrap {
                wrapped_face_weights(i, nx, a)
            } else {
                face_weights(i, [0, nx], a)
            };
            for (cell, w) in weights {
                let col = mesh.index(cell, j);
                push(&mut t, lo, col, -a * w);
                push(&mut t, hi, col, a * w);
            }
            let d = 0.5 * c.b[0][f] / (hx * hx);
            push(&mut t, lo, hi, d);
            push(&mut t, lo, lo, -d);
            push(&mut t, hi, hi, -d);
            push(&mut t, hi, lo, d);
            // Flux −½ b₁₂ ∂v p through the face, ∂v p from the corner average.
            let e = -0.5 * c.b[1][f] / (hx * hv);
            for (k, w) in tangential(j, nv, false) {
                for side in [i, next] {
                    let col = mesh.index(side, k);
                    push(&mut t, lo, col, -e * w);
                    push(&mut t, hi, col, e * w);
                }
            }
        }
    }
    // Faces normal to v at (centre of column i, v0 + (j+1)·hv).
    let (mut xs, mut vs) = (Vec::new(), Vec::new());
    for i in 0..nx {
        for j in 0..nv - 1 {
            xs.push(mesh.xc(i));
            vs.push(mesh.v0 + (j + 1) as f64 * hv);
        }
    }
    let c = problem.eval(&xs, &vs)?;
    let faces = nv - 1;
    for i in 0..nx {
        for j in 0..faces {
            let f = i * faces + j;
            let (lo, hi) = (mesh.index(i, j), mesh.index(i, j + 1));
            let a = c.u[1][f] / hv;
            for (cell, w) in face_weights(j, [0, nv], a) {
                let col = mesh.index(i, cell);
                push(&mut t, lo, col, -a * w);
                push(&mut t, hi, col, a * w);
            }
            let d = 0.5 * c.b[2][f] / (hv * hv);
            push(&mut t, lo, hi, d);
            push(&mut t, lo, lo, -d);
            push(&mut t, hi, hi, -d);
            push(&mut t, hi, lo, d);
            let e = -0.5 * c.b[1][f] / (hv * hx);
            for (k, w) in tangential(i, nx, mesh.wrap) {
                for side in [j, j + 1] {
                    let col = mesh.index(k, side);
                    push(&mut t, lo, col, -e * w);
                    push(&mut t, hi, col, e * w);
                }
            }
        }
    }
    Ok(Operator {
        transport: t,
        outflow: Vec::new(),
        reinjection: Vec::new(),
    })
}

impl Discretise for General {
    fn operator(&self, mesh: &Mesh) -> Result<Operator, GridError> {
        assemble(mesh, self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{Dynamics, Form};
    use crate::grid::mesh::Domain;
    use crate::model::parse_model;

    fn operator(text: &str) -> (Mesh, Operator) {
        let bound = parse_model(text, None).unwrap().bind(&[]).unwrap();
        let dynamics = Dynamics::read(&bound);
        let Form::General { why } = dynamics.form() else {
            panic!("not general")
        };
        let problem = General::new(&bound, &dynamics, why).unwrap();
        let d = Domain {
            x: [-4.0, 5.0],
            v: [-3.0, 6.0],
        };
        let mesh = Mesh::general(d, 18, 22);
        (mesh.clone(), assemble(&mesh, &problem).unwrap())
    }

    /// Every column sums to zero (mass is conserved) with drift and correlated,
    /// state-dependent noise in both equations.
    #[test]
    fn columns_sum_to_zero() {
        let (mesh, op) = operator(
            "model m\nstate x, y\ndrift x: -x + 2*y\ndrift y: -y - x^3\n\
             noise a: intensity 1\nnoise b: intensity 0.5\ncorrelate a, b: 0.6\n\
             diffusion x: (1 + 0.1*y^2)*a\ndiffusion y: b + 0.3*x*a\n",
        );
        let mut total = vec![0.0; mesh.cells()];
        op.transport.iter().for_each(|t| total[t.col] += t.val);
        let scale = op.transport.iter().fold(0.0f64, |a, t| a.max(t.val.abs()));
        let worst = total.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(worst <= 1e-13 * scale, "column sum {worst:e} of {scale:e}");
    }

    /// On a periodic first state, with correlated noise in both equations, every column
    /// still sums to zero (the seam's faces, and the cross flux's corner averages around it).
    #[test]
    fn a_wrapped_mesh_conserves_mass() {
        let bound = parse_model(
            "model m\nstate x, y\ndrift x: 0.5 - sin(x) + 0.2*y\ndrift y: -y + cos(x)\n\
             noise a: intensity 1\nnoise b: intensity 0.5\ncorrelate a, b: 0.6\n\
             diffusion x: (1 + 0.3*cos(x))*a\ndiffusion y: b + 0.3*sin(x)*a\n\
             domain x periodic 2*pi\n",
            None,
        )
        .unwrap()
        .bind(&[])
        .unwrap();
        let dynamics = Dynamics::read(&bound);
        let Form::General { why } = dynamics.form() else {
            panic!("not general")
        };
        let problem = General::new(&bound, &dynamics, why).unwrap();
        let pi = std::f64::consts::PI;
        let d = Domain {
            x: [-pi, pi],
            v: [-4.0, 4.0],
        };
        let mesh = Mesh::general(d, 18, 22).wrapped();
        let op = assemble(&mesh, &problem).unwrap();
        let mut total = vec![0.0; mesh.cells()];
        op.transport.iter().for_each(|t| total[t.col] += t.val);
        let scale = op.transport.iter().fold(0.0f64, |a, t| a.max(t.val.abs()));
        let worst = total.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(worst <= 1e-13 * scale, "column sum {worst:e} of {scale:e}");
        // The seam couples the last column to the first.
        assert!(op
            .transport
            .iter()
            .any(|t| t.row == mesh.index(0, 5) && t.col == mesh.index(17, 5)));
    }

    /// The cross-diffusion flux is exact on a density linear in v: with b₁₂ = 2 (and no other
    /// term) the flux through an x face is −½·2·∂v p = −1 for p = v, so the operator applied
    /// to p = v gives −(J_right − J_left)/hx = 0 inside, and ±1/hx in the first and last
    /// columns (zero flux through the outer faces).
    #[test]
    fn the_cross_flux_is_exact_on_a_linear_density() {
        let (mesh, op) = operator(
            "model m\nstate x, y\ndrift x: -1e-300*x^3\ndrift y: -1e-300*y^3\n\
             noise a: intensity 1\ndiffusion x: a\ndiffusion y: 2*a\n",
        );
        // b = [[1, 2], [2, 4]] (a drift of 1e−300·x³ only makes the model admissible);
        // p = v has p_R = p_L across every x face, so the normal x diffusion carries nothing.
        let p: Vec<f64> = (0..mesh.cells()).map(|k| mesh.vc(k % mesh.nv)).collect();
        let mut out = vec![0.0; mesh.cells()];
        op.transport
            .iter()
            .for_each(|t| out[t.row] += t.val * p[t.col]);
        // Rows away from the v edges: the v faces carry −½·4·∂v p = −2 each, which cancels
        // inside; the x faces carry −1 each, which cancels inside.
        for i in 1..mesh.nx - 1 {
            for j in 1..mesh.nv - 1 {
                assert!(out[mesh.index(i, j)].abs() < 1e-12, "{i} {j}");
            }
        }
        let j = mesh.nv / 2;
        // First column: only its right face, flux −1 leaving → d p/dt = +1/hx.
        assert!((out[mesh.index(0, j)] - 1.0 / mesh.hx).abs() < 1e-10);
        assert!((out[mesh.index(mesh.nx - 1, j)] + 1.0 / mesh.hx).abs() < 1e-10);
    }
}
