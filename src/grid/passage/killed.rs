//! The killed generator: the grid's finite-volume operator on the cells whose centre is in
//! the safe set, what flows out of them lost. Its transpose is the backward (Pontryagin)
//! operator of the mean first-passage time on the same cells.
//!
//! Where the absorbing condition sits. In x there is no diffusion (x' = v), so a boundary
//! crossed along x absorbs only where the flow leaves: at an outflow face the face value is
//! extrapolated linearly from the two upwind safe cells (as the barrier's outflow is), which
//! puts the boundary on the face rather than at the next cell's centre; at an inflow face
//! nothing enters (the killed side holds no probability), so its flux is zero, whatever the
//! upwind-biased stencil would have read from the inside. In v the diffusion makes the
//! boundary a Dirichlet one (density and mean time 0 on it): the diffusive flux to a killed
//! cell uses the ghost −p (zero on the face); the advective v-flux keeps the stencil with the
//! killed cells at 0.

use faer::sparse::{SparseColMat, Triplet};

use super::super::assemble::Operator;
use super::super::mesh::{face_weights, Mesh};
use super::super::problem::Mechanical;
use super::super::GridError;

/// The killed generator on the safe cells, numbered in the mesh's order.
pub(crate) struct Killed {
    /// Safe cell k's index in the mesh.
    pub(crate) cells: Vec<usize>,
    /// The mesh index → safe index (`usize::MAX` outside).
    pub(crate) index: Vec<usize>,
    /// K (dp/dt = K p on the safe cells).
    pub(crate) forward: SparseColMat<usize, f64>,
    /// Kᵀ.
    pub(crate) backward: SparseColMat<usize, f64>,
}

pub(crate) fn killed(
    mesh: &Mesh,
    problem: &Mechanical,
    op: &Operator,
    safe: &[bool],
) -> Result<Killed, GridError> {
    let n = mesh.cells();
    let cells: Vec<usize> = (0..n).filter(|&c| safe[c]).collect();
    let mut index = vec![usize::MAX; n];
    cells.iter().enumerate().for_each(|(k, &c)| index[c] = k);
    let mut t: Vec<Triplet<usize, usize, f64>> = [&op.transport, &op.outflow, &op.reinjection]
        .iter()
        .flat_map(|p| p.iter())
        .filter(|e| safe[e.row] && safe[e.col])
        .copied()
        .collect();
    x_faces(mesh, safe, &mut t);
    v_faces(mesh, problem, safe, &mut t)?;
    let m = cells.len();
    let singular = |what: &str| GridError::Singular {
        nx: mesh.nx,
        nv: mesh.nv,
        detail: format!("the killed generator's {what} could not be allocated"),
    };
    let fwd: Vec<_> = t
        .iter()
        .map(|e| Triplet::new(index[e.row], index[e.col], e.val))
        .collect();
    let bwd: Vec<_> = t
        .iter()
        .map(|e| Triplet::new(index[e.col], index[e.row], e.val))
        .collect();
    let forward = SparseColMat::try_new_from_triplets(m, m, &fwd).map_err(|_| singular("K"))?;
    let backward = SparseColMat::try_new_from_triplets(m, m, &bwd).map_err(|_| singular("Kᵀ"))?;
    Ok(Killed {
        cells,
        index,
        forward,
        backward,
    })
}

/// Outflow faces extrapolate, inflow faces carry nothing (see the module's notes).
fn x_faces(mesh: &Mesh, safe: &[bool], t: &mut Vec<Triplet<usize, usize, f64>>) {
    for &seg in &mesh.segments {
        for i in seg[0]..seg[1] - 1 {
            for j in 0..mesh.nv {
                let a = mesh.vc(j) / mesh.hx;
                // Upwind and downwind cells (columns), and the sign each row's entry has.
                let (up, down, s_up, s_down) = if a > 0.0 {
                    (i, i + 1, -1.0, 1.0)
                } else {
                    (i + 1, i, 1.0, -1.0)
                };
                let (cu, cd) = (mesh.index(up, j), mesh.index(down, j));
                let stencil = face_weights(i, seg, a);
                let kept = |c: usize| safe[c];
                if safe[cu] && !safe[cd] {
                    // Row `up` kept a·Σ w p over the safe stencil cells; it should have
                    // a·(1.5 p_up − 0.5 p_upup), or a·p_up with no safe cell further up.
                    let upup = if a > 0.0 {
                        up.checked_sub(1).filter(|&u| u >= seg[0])
                    } else {
                        Some(up + 1).filter(|&u| u < seg[1])
                    }
                    .map(|u| mesh.index(u, j))
                    .filter(|&c| safe[c]);
                    for (cell, w) in stencil {
                        let c = mesh.index(cell, j);
                        if w != 0.0 && kept(c) {
                            t.push(Triplet::new(cu, c, -s_up * a * w));
                        }
                    }
                    match upup {
                        Some(c) => {
                            t.push(Triplet::new(cu, cu, s_up * a * 1.5));
                            t.push(Triplet::new(cu, c, -s_up * a * 0.5));
                        }
                        None => t.push(Triplet::new(cu, cu, s_up * a)),
                    }
                } else if !safe[cu] && safe[cd] {
                    for (cell, w) in stencil {
                        let c = mesh.index(cell, j);
                        if w != 0.0 && kept(c) {
                            t.push(Triplet::new(cd, c, -s_down * a * w));
                        }
                    }
                }
            }
        }
    }
}

/// The diffusive flux to a killed v-neighbour with the ghost −p: twice what the killed
/// cell's 0 gives.
fn v_faces(
    mesh: &Mesh,
    problem: &Mechanical,
    safe: &[bool],
    t: &mut Vec<Triplet<usize, usize, f64>>,
) -> Result<(), GridError> {
    let mut faces = Vec::new();
    for i in 0..mesh.nx {
        for j in 0..mesh.nv - 1 {
            let (lo, hi) = (mesh.index(i, j), mesh.index(i, j + 1));
            if safe[lo] != safe[hi] {
                faces.push((i, j, if safe[lo] { lo } else { hi }));
            }
        }
    }
    if faces.is_empty() {
        return Ok(());
    }
    let xs: Vec<f64> = faces.iter().map(|f| mesh.xc(f.0)).collect();
    let vs: Vec<f64> = faces
        .iter()
        .map(|f| mesh.v0 + (f.1 + 1) as f64 * mesh.hv)
        .collect();
    let coef = problem.eval(&xs, &vs)?;
    for (k, &(_, _, inside)) in faces.iter().enumerate() {
        let d = 0.5 * coef.b[k] / (mesh.hv * mesh.hv);
        t.push(Triplet::new(inside, inside, -d));
    }
    Ok(())
}
