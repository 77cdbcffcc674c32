//! The discrete stationary FPK operator (finite volumes) and its solution by sparse LU.
//!
//! Unknowns are cell averages p_ij of the density. Row c of the operator is d(p_c)/dt: the
//! fluxes through the cell's four faces, divided by its area, plus what the barrier
//! re-injects. Every flux is added to one cell and taken from another, and a re-injection
//! puts back into the destination cells exactly what left, so every column sums to zero:
//! mass is conserved to rounding.

use crate::numerics::sparse::faer_lu::{FaerLu, Ordering};
use crate::numerics::sparse::pattern_lu::PatternLu;
use crate::numerics::sparse::{Check, FactorError, Factorization};
use faer::sparse::{SparseColMat, SymbolicSparseColMat, Triplet};

use super::error::GridError;
use super::mesh::{face_weights, overlaps, wrapped_face_weights, Mesh};
use super::problem::Mechanical;
use crate::base::limits::memory_limit_bytes;

/// The operator as (row, column, value) entries, duplicates summed by the sparse matrix.
#[derive(Clone, Debug, Default)]
pub(crate) struct Operator {
    /// Advection in x and v, diffusion in v.
    pub(crate) transport: Vec<Triplet<usize, usize, f64>>,
    /// Outflow through the barrier, from the exit cells' rows.
    pub(crate) outflow: Vec<Triplet<usize, usize, f64>>,
    /// Its re-injection into the cells at the mapped velocity.
    pub(crate) reinjection: Vec<Triplet<usize, usize, f64>>,
}

fn push(out: &mut Vec<Triplet<usize, usize, f64>>, row: usize, col: usize, val: f64) {
    if val != 0.0 {
        out.push(Triplet { row, col, val });
    }
}

/// A problem the finite volumes discretise: its operator on a mesh.
pub(crate) trait Discretise {
    /// The operator on `mesh`.
    fn operator(&self, mesh: &Mesh) -> Result<Operator, GridError>;
}

impl Discretise for Mechanical {
    fn operator(&self, mesh: &Mesh) -> Result<Operator, GridError> {
        assemble(mesh, self)
    }
}

/// Builds the operator of `problem` on `mesh`.
pub(crate) fn assemble(mesh: &Mesh, problem: &Mechanical) -> Result<Operator, GridError> {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let mut t = Vec::with_capacity(mesh.cells() * 16);
    // x faces: velocity v_j (the face midpoint), third-order upwind-biased face values.
    if mesh.wrap {
        for i in 0..nx {
            for j in 0..nv {
                let a = mesh.vc(j) / mesh.hx;
                for (cell, w) in wrapped_face_weights(i, nx, a) {
                    let col = mesh.index(cell, j);
                    push(&mut t, mesh.index(i, j), col, -a * w);
                    push(&mut t, mesh.index((i + 1) % nx, j), col, a * w);
                }
            }
        }
    }
    for &seg in mesh.segments.iter().filter(|_| !mesh.wrap) {
        for i in seg[0]..seg[1] - 1 {
            for j in 0..nv {
                let a = mesh.vc(j) / mesh.hx;
                for (cell, w) in face_weights(i, seg, a) {
                    let col = mesh.index(cell, j);
                    push(&mut t, mesh.index(i, j), col, -a * w);
                    push(&mut t, mesh.index(i + 1, j), col, a * w);
                }
            }
        }
    }
    // v faces: flux m p − ½ ∂v(b p) = (m − ½ ∂v b) p − ½ b ∂v p, b and ∂v b at the face.
    let faces = nv - 1;
    let mut xs = Vec::with_capacity(nx * faces);
    let mut vs = Vec::with_capacity(nx * faces);
    for i in 0..nx {
        for j in 0..faces {
            xs.push(mesh.xc(i));
            vs.push(mesh.v0 + (j + 1) as f64 * mesh.hv);
        }
    }
    let coef = problem.eval(&xs, &vs)?;
    for i in 0..nx {
        for j in 0..faces {
            let f = i * faces + j;
            let a = (coef.m[f] - 0.5 * coef.db[f]) / mesh.hv;
            let d = 0.5 * coef.b[f] / (mesh.hv * mesh.hv);
            let (lo, hi) = (mesh.index(i, j), mesh.index(i, j + 1));
            for (cell, w) in face_weights(j, [0, nv], a) {
                let col = mesh.index(i, cell);
                push(&mut t, lo, col, -a * w);
                push(&mut t, hi, col, a * w);
            }
            // −D (p_hi − p_lo): leaves `lo` when p_hi < p_lo.
            push(&mut t, lo, hi, d);
            push(&mut t, lo, lo, -d);
            push(&mut t, hi, hi, -d);
            push(&mut t, hi, lo, d);
        }
    }
    let (mut outflow, mut reinjection) = (Vec::new(), Vec::new());
    for exit in &mesh.exits {
        let barrier = &problem.barriers[exit.barrier];
        for j in (0..nv).filter(|&j| mesh.vc(j) * exit.direction > 0.0) {
            // Outflow |v| p_face / hx, p_face extrapolated linearly from the two cells on
            // the outgoing side (the other side may have a jump).
            let rate = mesh.vc(j).abs() / mesh.hx;
            let (from, inner) = (mesh.index(exit.from, j), mesh.index(exit.inner, j));
            let (e0, e1) = (
                mesh.v0 + j as f64 * mesh.hv,
                mesh.v0 + (j + 1) as f64 * mesh.hv,
            );
            let (m0, m1) = (barrier.jump(e0), barrier.jump(e1));
            let targets = overlaps(mesh, m0.min(m1), m0.max(m1));
            for (col, w) in [(from, 1.5), (inner, -0.5)] {
                push(&mut outflow, from, col, -rate * w);
                for &(jd, share) in &targets {
                    let into = mesh.index(exit.into, jd);
                    push(&mut reinjection, into, col, rate * w * share);
                }
            }
        }
    }
    Ok(Operator {
        transport: t,
        outflow,
        reinjection,
    })
}

/// The matrix of operator · p = 0 with the equation of cell `pin` replaced by p_pin = 1, in
/// compressed columns: entries bucketed by column in assembly order, then sorted by row
/// within each column (stably, by insertion: a column holds a dozen entries) and
/// duplicates summed in assembly order. A general triplet sort costs several times the
/// assembly itself at 80k cells.
pub(crate) fn matrix(n: usize, op: &Operator, pin: usize) -> SparseColMat<usize, f64> {
    let parts = [&op.transport, &op.outflow, &op.reinjection];
    let kept = |t: &&Triplet<usize, usize, f64>| t.row != pin;
    let mut col_ptr = vec![0usize; n + 2];
    for t in parts.iter().flat_map(|p| p.iter()).filter(kept) {
        col_ptr[t.col + 2] += 1;
    }
    col_ptr[pin + 2] += 1;
    for c in 2..n + 2 {
        col_ptr[c] += col_ptr[c - 1];
    }
    // col_ptr[c + 1] is the next free slot of column c while scattering.
    let total = col_ptr[n + 1];
    let (mut rows, mut vals) = (vec![0usize; total], vec![0.0f64; total]);
    let mut place = |row: usize, col: usize, val: f64| {
        let at = col_ptr[col + 1];
        rows[at] = row;
        vals[at] = val;
        col_ptr[col + 1] += 1;
    };
    for t in parts.iter().flat_map(|p| p.iter()).filter(kept) {
        place(t.row, t.col, t.val);
    }
    place(pin, pin, 1.0);
    // Sort each column by row, merge duplicates, compact.
    let mut write = 0;
    let mut start = 0;
    let mut out_ptr = Vec::with_capacity(n + 1);
    out_ptr.push(0);
    for c in 0..n {
        let end = col_ptr[c + 1];
        for k in start + 1..end {
            let (r, v) = (rows[k], vals[k]);
            let mut m = k;
            while m > start && rows[m - 1] > r {
                rows[m] = rows[m - 1];
                vals[m] = vals[m - 1];
                m -= 1;
            }
            rows[m] = r;
            vals[m] = v;
        }
        let first = write;
        for k in start..end {
            if write > first && rows[write - 1] == rows[k] {
                vals[write - 1] += vals[k];
            } else {
                rows[write] = rows[k];
                vals[write] = vals[k];
                write += 1;
            }
        }
        out_ptr.push(write);
        start = end;
    }
    rows.truncate(write);
    vals.truncate(write);
    let symbolic = SymbolicSparseColMat::new_checked(n, n, out_ptr, None, rows);
    SparseColMat::new(symbolic, vals)
}

/// The generator G of d p/dt = G p: every entry of the operator (no pinned row), duplicates
/// summed, in compressed columns; its columns sum to zero. The transient's matrix
/// ([`crate::grid::GridTransient`]). `None` only when the entries cannot be allocated.
pub(crate) fn generator(n: usize, op: &Operator) -> Option<SparseColMat<usize, f64>> {
    let all: Vec<_> = [&op.transport, &op.outflow, &op.reinjection]
        .iter()
        .flat_map(|p| p.iter().copied())
        .collect();
    SparseColMat::try_new_from_triplets(n, n, &all).ok()
}

/// Solves operator · p = 0 with the equation of cell `pin` replaced by p_pin = 1 (the rows
/// are linearly dependent, since the columns sum to zero), then scales p to unit mass.
pub(crate) fn solve(mesh: &Mesh, op: &Operator, pin: usize) -> Result<Vec<f64>, GridError> {
    let n = mesh.cells();
    let singular = |detail: String| GridError::Singular {
        nx: mesh.nx,
        nv: mesh.nv,
        detail,
    };
    let a = matrix(n, op, pin);
    // Nested dissection of the cells on the graph of A + Aᵀ, separators one step wide,
    // the pin last (measured against AMD: docs/method.md section 8).
    let coords = super::nested::cell_coords(mesh.nx, mesh.nv, false);
    let mut order = super::nested::nested_dissection(a.symbolic(), &coords, 1);
    order.retain(|&c| c != pin);
    order.push(pin);
    let mut p = solve_system(&a, order, pin).map_err(|e| singular(e.to_string()))?;
    let mass: f64 = p.iter().sum::<f64>() * mesh.hx * mesh.hv;
    if !(mass.is_finite() && mass > 0.0) {
        return Err(GridError::Degenerate {
            nx: mesh.nx,
            nv: mesh.nv,
        });
    }
    p.iter_mut().for_each(|v| *v /= mass);
    Ok(p)
}

/// When a solve is accepted: one step of iterative refinement above a backward error
/// ‖A p − e_pin‖∞ / (‖A‖∞ ‖p‖∞ + 1) of 1e-14, refused above 1e-12.
const CHECK: Check = Check {
    refine_above: 1e-14,
    limit: 1e-12,
};

/// Why neither factorisation solved the system; `Display` is the detail of
/// [`GridError::Singular`].
#[derive(Debug, thiserror::Error)]
enum SystemError {
    /// The pattern LU's factors exceed the memory limit; faer's LU needs more still (the
    /// pattern of AᵀA), so it is not tried.
    #[error("{0}")]
    TooLarge(FactorError),
    /// The pattern LU failed, then faer's LU failed too.
    #[error("{pattern}; faer's LU: {faer}")]
    BothFailed {
        /// Why the pattern LU failed.
        pattern: FactorError,
        /// Why faer's LU failed.
        faer: FactorError,
    },
}

/// Solves A p = e_pin, A's columns eliminated in `order`: by the pattern LU, which pivots
/// only inside its supernodes, so its backward error is checked rather than assumed (1e-17 to
/// 1e-16 on the grid operators). When it fails (a zero pivot, or a backward error above the
/// limit after refinement), faer's LU with partial pivoting over whole columns (COLAMD order)
/// solves the same system and must pass the same check; a system neither solves to that
/// accuracy is refused (the error says why each failed).
fn solve_system(
    a: &SparseColMat<usize, f64>,
    order: Vec<usize>,
    pin: usize,
) -> Result<Vec<f64>, SystemError> {
    let limit = memory_limit_bytes();
    let mut b = vec![0.0; a.ncols()];
    b[pin] = 1.0;
    let patterned = match PatternLu::factor(a.as_ref(), order, limit) {
        Err(e @ FactorError::TooLarge { .. }) => return Err(SystemError::TooLarge(e)),
        other => other,
    };
    patterned
        .and_then(|factor| {
            let solved = factor.checked_solve(a.as_ref(), &b, CHECK);
            drop_beside(factor);
            solved
        })
        .or_else(|pattern| {
            FaerLu::factor(a.as_ref(), Ordering::Colamd, limit)
                .and_then(|factor| factor.checked_solve(a.as_ref(), &b, CHECK))
                .map_err(|faer| SystemError::BothFailed { pattern, faer })
        })
}

/// Frees `value` on a thread of its own. A factor of a fine grid is hundreds of MB, whose
/// release (unmapping its pages) took 13 ms on the solver's path at 200x400 cells; the solve
/// has no more use for it. Where no thread can be started it is freed here.
fn drop_beside<T: Send + 'static>(value: T) {
    // When no thread can be started, `spawn` drops the closure, and `value` with it, here.
    let _ = std::thread::Builder::new()
        .name("fpsolve-free".into())
        .spawn(move || drop(value));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::mesh::Domain;

    fn operator(file: &str, r: f64) -> (Mesh, Operator) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
        let set = [crate::model::Override::number("r", r)];
        let b = crate::model::load_model(&path).unwrap().bind(&set).unwrap();
        let problem = Mechanical::new(&crate::dynamics::Dynamics::read(&b)).unwrap();
        let d = Domain {
            x: [-6.0, 6.0],
            v: [-9.0, 9.0],
        };
        let mesh = Mesh::new(d, 24, 36, &problem.barriers, 4);
        let op = assemble(&mesh, &problem).unwrap();
        (mesh, op)
    }

    /// On a periodic position every column still sums to zero, and the seam is an ordinary
    /// face: the last column's flux at v > 0 enters the first column (and the converse),
    /// with the upwind-biased weights reaching around it.
    #[test]
    fn a_wrapped_mesh_conserves_mass_across_its_seam() {
        let b = crate::model::parse_model(
            "model p\nstate th, w\ndrift th: w\ndrift w: -0.5*w - sin(th)\n\
             noise xi: intensity 1\ndiffusion w: xi\ndomain th periodic 2*pi\n",
            None,
        )
        .unwrap()
        .bind(&[])
        .unwrap();
        let problem = Mechanical::new(&crate::dynamics::Dynamics::read(&b)).unwrap();
        let pi = std::f64::consts::PI;
        let d = Domain {
            x: [-pi, pi],
            v: [-5.0, 5.0],
        };
        let mesh = Mesh::new(d, 16, 20, &problem.barriers, 4).wrapped();
        let op = assemble(&mesh, &problem).unwrap();
        let mut total = vec![0.0; mesh.cells()];
        op.transport.iter().for_each(|t| total[t.col] += t.val);
        let scale = op.transport.iter().fold(0.0f64, |a, t| a.max(t.val.abs()));
        assert!(total.iter().all(|v| v.abs() <= 1e-13 * scale));
        // Cell (15, j) with v > 0 feeds cell (0, j); cell (0, j) with v < 0 feeds (15, j).
        let entry = |row: usize, col: usize| -> f64 {
            op.transport
                .iter()
                .filter(|t| t.row == row && t.col == col)
                .map(|t| t.val)
                .sum()
        };
        let (up, down) = (mesh.nv - 1, 0);
        assert!(entry(mesh.index(0, up), mesh.index(15, up)) > 0.0);
        assert!(entry(mesh.index(15, down), mesh.index(0, down)) > 0.0);
        // The upwind-upwind cell of the seam's face is cell 14 (weight −1/6).
        assert!(entry(mesh.index(0, up), mesh.index(14, up)) < 0.0);
    }

    /// Every column of the operator sums to zero (mass is conserved), and the barrier puts
    /// back exactly what leaves through it, for r < 1 in both coordinate systems.
    #[test]
    fn reinjection_conserves_mass() {
        for file in [
            "models/vibro_duffing.sde",
            "tests/models/grid_impact_duffing.sde",
        ] {
            for r in [0.8, 0.95] {
                let (mesh, op) = operator(file, r);
                let n = mesh.cells();
                let (mut total, mut out, mut back) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                let all = op
                    .transport
                    .iter()
                    .chain(&op.outflow)
                    .chain(&op.reinjection);
                all.for_each(|t| total[t.col] += t.val);
                op.outflow.iter().for_each(|t| out[t.col] += t.val);
                op.reinjection.iter().for_each(|t| back[t.col] += t.val);
                let scale = op.transport.iter().fold(0.0f64, |a, t| a.max(t.val.abs()));
                let worst = total.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                assert!(worst <= 1e-13 * scale, "{file} r={r}: column sum {worst:e}");
                let unbalanced = out
                    .iter()
                    .zip(&back)
                    .fold(0.0f64, |a, (o, b)| a.max((o + b).abs()));
                assert!(unbalanced <= 1e-14 * scale, "{file} r={r}: {unbalanced:e}");
                // The flux of a positive density leaves through the barrier.
                let p = vec![1.0; n];
                let leaving: f64 = op.outflow.iter().map(|t| t.val * p[t.col]).sum();
                let returning: f64 = op.reinjection.iter().map(|t| t.val * p[t.col]).sum();
                assert!(leaving < 0.0);
                assert!((leaving + returning).abs() <= 1e-13 * leaving.abs());
            }
        }
    }

    #[test]
    fn solves_are_checked_and_the_fallback_pivots_over_whole_columns() {
        use faer::sparse::Triplet;
        // A zero diagonal at column 0. Rows: p2 = 0; 2 p0 + p1 = 0; p0 + p2 = 1 (the pin).
        let t = [
            Triplet::new(0usize, 2usize, 1.0),
            Triplet::new(1, 1, 1.0),
            Triplet::new(1, 0, 2.0),
            Triplet::new(2, 0, 1.0),
            Triplet::new(2, 2, 1.0),
        ];
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(3, 3, &t).unwrap();
        let exact = [1.0, -2.0, 0.0];
        let close = |p: &[f64]| p.iter().zip(exact).all(|(x, e)| (x - e).abs() < 1e-14);
        let faer = FaerLu::factor(a.as_ref(), Ordering::Colamd, f64::INFINITY).unwrap();
        assert!(close(
            &faer
                .checked_solve(a.as_ref(), &[0.0, 0.0, 1.0], CHECK)
                .unwrap()
        ));
        assert!(close(&solve_system(&a, vec![0, 1, 2], 2).unwrap()));
    }
}
