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
use super::problem::{Fluxes, Mechanical};
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
    let averaged = problem.fluxes() == Fluxes::Averaged;
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
                if averaged {
                    x_face_moment(&mut t, mesh, [i, (i + 1) % nx], j);
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
                if averaged {
                    x_face_moment(&mut t, mesh, [i, i + 1], j);
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
            // −D ∂v p·hv: leaves `lo` when p_hi < p_lo; the face derivative to fourth order
            // from four cells where they exist.
            for (cell, w) in derivative_weights(j, nv, averaged) {
                let col = mesh.index(i, cell);
                push(&mut t, lo, col, d * w);
                push(&mut t, hi, col, -d * w);
            }
        }
    }
    if averaged {
        v_face_averages(&mut t, mesh, &coef)?;
    }
    let (mut outflow, mut reinjection) = (Vec::new(), Vec::new());
    for exit in &mesh.exits {
        let barrier = &problem.barriers[exit.barrier];
        let columns = exit_columns(mesh, exit, averaged);
        let rows: Vec<usize> = (0..nv)
            .filter(|&j| mesh.vc(j) * exit.direction > 0.0)
            .collect();
        let fluxes: Vec<Vec<(usize, f64)>> = (0..rows.len())
            .map(|k| exit_flux(mesh, &columns, &rows, k, averaged))
            .collect();
        for (k, &j) in rows.iter().enumerate() {
            let from = mesh.index(exit.from, j);
            let (e0, e1) = (
                mesh.v0 + j as f64 * mesh.hv,
                mesh.v0 + (j + 1) as f64 * mesh.hv,
            );
            let (m0, m1) = (barrier.jump(e0), barrier.jump(e1));
            let targets = overlaps(mesh, m0.min(m1), m0.max(m1));
            for &(col, w) in &fluxes[k] {
                push(&mut outflow, from, col, -w);
                for &(jd, share) in &targets {
                    let into = mesh.index(exit.into, jd);
                    push(&mut reinjection, into, col, w * share);
                }
            }
            remap_slope(
                &mut reinjection,
                mesh,
                exit.into,
                &fluxes,
                k,
                [m0, m1],
                &targets,
            );
        }
    }
    Ok(Operator {
        transport: t,
        outflow,
        reinjection,
    })
}

/// The part of the re-injected flux that a row's slope moves between its targets: the flux
/// density over row `k` is F_k + D_k (s − ½) (s from 0 to 1 across the row, D_k the centred
/// difference of the neighbouring rows' rates, one-sided at the ends), not the constant
/// F_k, so a target covering the part [α, β] of the row's image receives
/// D_k (β − α)((α + β)/2 − ½) more. These parts sum to zero over a row (mass is
/// conserved) and vanish where the image is whole cells (elastic and pass-through walls); an
/// inelastic wall's image cuts cells, and without them its re-injected flux has an O(h)
/// error at each target that shifts energy by O(h²) over the whole density.
/// `targets` are the cells the row's image covers ([`overlaps`] of it).
fn remap_slope(
    out: &mut Vec<Triplet<usize, usize, f64>>,
    mesh: &Mesh,
    into: usize,
    fluxes: &[Vec<(usize, f64)>],
    k: usize,
    [m0, m1]: [f64; 2],
    targets: &[(usize, f64)],
) {
    let n = fluxes.len();
    if n < 2 || m1 == m0 {
        return;
    }
    let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
    let span = (b - a) as f64;
    let (lo, hi) = (m0.min(m1), m0.max(m1));
    let s = |u: f64| (u - m0) / (m1 - m0);
    for &(jd, _) in targets {
        // The target's piece of the image; the box's edge rows take what lands beyond it.
        let c0 = if jd == 0 {
            f64::NEG_INFINITY
        } else {
            mesh.v0 + jd as f64 * mesh.hv
        };
        let c1 = if jd + 1 == mesh.nv {
            f64::INFINITY
        } else {
            mesh.v0 + (jd + 1) as f64 * mesh.hv
        };
        let (pa, pb) = (lo.max(c0), hi.min(c1));
        let (sa, sb) = (s(pa), s(pb));
        let (al, be) = (sa.min(sb), sa.max(sb));
        let c = (be - al) * (0.5 * (al + be) - 0.5) / span;
        // An image of whole cells (elastic and pass-through walls) leaves only rounding.
        if c.abs() <= 1e-12 {
            continue;
        }
        let row = mesh.index(into, jd);
        for (from, sign) in [(b, 1.0), (a, -1.0)] {
            for &(col, w) in &fluxes[from] {
                push(out, row, col, sign * c * w);
            }
        }
    }
}

/// The wall's face value from the cells of one row on the outgoing side, nearest first: with
/// `averaged` fluxes the quadratic through three cell averages, (11, −7, 2)/6 (third order),
/// where the run has three cells, else the line through two, (3, −1)/2 (the other side of
/// the wall may have a jump, so no cell beyond it is used).
fn exit_columns(mesh: &Mesh, exit: &super::mesh::Exit, averaged: bool) -> Vec<(usize, f64)> {
    let step = exit.inner as isize - exit.from as isize;
    let third = exit.inner as isize + step;
    let [s, e] = mesh.segment_of(exit.from);
    if averaged && third >= s as isize && third < e as isize {
        vec![
            (exit.from, 11.0 / 6.0),
            (exit.inner, -7.0 / 6.0),
            (third as usize, 2.0 / 6.0),
        ]
    } else {
        vec![(exit.from, 1.5), (exit.inner, -0.5)]
    }
}

/// The rate at which row `rows[k]` leaves through the wall, as weights on cells:
/// (1/hv)∫ |v| p dv over the row, per hx, which is |v_j| p̄ + (hv²/12) ∂|v| p at the wall
/// (the second term with `averaged` fluxes only); p̄ and the face values of the neighbouring
/// rows from `columns`, ∂v p by their centred difference inside the outgoing rows
/// (one-sided at v = 0, where the density at a wall may jump, and at the box's edge).
fn exit_flux(
    mesh: &Mesh,
    columns: &[(usize, f64)],
    rows: &[usize],
    k: usize,
    averaged: bool,
) -> Vec<(usize, f64)> {
    let j = rows[k];
    let (hx, hv) = (mesh.hx, mesh.hv);
    let mut out: Vec<(usize, f64)> = columns
        .iter()
        .map(|&(i, w)| (mesh.index(i, j), mesh.vc(j).abs() / hx * w))
        .collect();
    if averaged && rows.len() >= 2 {
        let (a, b) = (k.saturating_sub(1), (k + 1).min(rows.len() - 1));
        // d|v| = sign(v)·dv; rows are in increasing v.
        let sign = mesh.vc(j).signum();
        let g = sign * hv / (12.0 * (b - a) as f64 * hx);
        for (row, s) in [(rows[b], g), (rows[a], -g)] {
            for &(i, w) in columns {
                out.push((mesh.index(i, row), s * w));
            }
        }
    }
    out
}

/// Weights of hv·∂v p at the face between cells `j` and `j + 1` of `n` from the cell
/// averages: with `averaged` fluxes (1, −15, 15, −1)/12 on cells j − 1 … j + 2 (fourth
/// order) where all four exist, else the difference of the two (second order).
fn derivative_weights(j: usize, n: usize, averaged: bool) -> Vec<(usize, f64)> {
    if averaged && j >= 1 && j + 2 < n {
        vec![
            (j - 1, 1.0 / 12.0),
            (j, -15.0 / 12.0),
            (j + 1, 15.0 / 12.0),
            (j + 2, -1.0 / 12.0),
        ]
    } else {
        vec![(j, -1.0), (j + 1, 1.0)]
    }
}

/// The x-flux through a face of row j is (1/hv)∫ v p dv over the row, which is
/// v_j p̄ + (hv²/12) ∂v p: the second term, ∂v p at the face from the face values
/// (the mean of the two cells) of the rows above and below (one-sided at the box's edge).
fn x_face_moment(
    t: &mut Vec<Triplet<usize, usize, f64>>,
    mesh: &Mesh,
    [left, right]: [usize; 2],
    j: usize,
) {
    let nv = mesh.nv;
    let (below, above) = (j.saturating_sub(1), (j + 1).min(nv - 1));
    // (hv²/12)·(q_above − q_below)/((above − below)·hv), per hx of the cell.
    let g = mesh.hv / (12.0 * (above - below) as f64 * mesh.hx);
    let (lo, hi) = (mesh.index(left, j), mesh.index(right, j));
    for (row, w) in [(above, 0.5 * g), (below, -0.5 * g)] {
        for side in [left, right] {
            let col = mesh.index(side, row);
            push(t, lo, col, -w);
            push(t, hi, col, w);
        }
    }
}

/// The v-flux through a face of column i is the x-average over the column of
/// a p − ½ b ∂v p (a = m − ½ ∂v b), which is a(x_i) p̄ − ½ b(x_i) ∂v p̄ plus
/// (hx²/12)(a′ p′ − ½ b′ ∂v p′) + (hx²/24)(a″ p − ½ b″ ∂v p) (′ = ∂x): those terms, with
/// a′, a″, b′, b″ from the coefficients at the neighbouring columns' faces and p, p′ from
/// the cells beside the face (differences inside the column's run of cells between walls,
/// one-sided at its ends).
fn v_face_averages(
    t: &mut Vec<Triplet<usize, usize, f64>>,
    mesh: &Mesh,
    coef: &super::problem::Coefficients,
) -> Result<(), GridError> {
    let (nx, nv, hx, hv) = (mesh.nx, mesh.nv, mesh.hx, mesh.hv);
    let faces = nv - 1;
    for i in 0..nx {
        let (l, r) = if mesh.wrap {
            ((i + nx - 1) % nx, (i + 1) % nx)
        } else {
            let [s, e] = mesh.segment_of(i);
            if e - s < 3 {
                continue;
            }
            if i == s {
                (i, i + 1)
            } else if i + 1 == e {
                (i - 1, i)
            } else {
                (i - 1, i + 1)
            }
        };
        let span = if mesh.wrap { 2.0 } else { (r - l) as f64 };
        // The second difference's three columns (shifted inwards at the ends of the run).
        let (c0, c1, c2) = if mesh.wrap || span == 2.0 {
            (l, i, r)
        } else if l == i {
            (i, i + 1, i + 2)
        } else {
            (i - 2, i - 1, i)
        };
        for j in 0..faces {
            let at = |c: usize| c * faces + j;
            let a = |c: usize| coef.m[at(c)] - 0.5 * coef.db[at(c)];
            let b = |c: usize| coef.b[at(c)];
            let da = (a(r) - a(l)) / (span * hx);
            let db = (b(r) - b(l)) / (span * hx);
            let dda = (a(c0) - 2.0 * a(c1) + a(c2)) / (hx * hx);
            let ddb = (b(c0) - 2.0 * b(c1) + b(c2)) / (hx * hx);
            if da == 0.0 && db == 0.0 && dda == 0.0 && ddb == 0.0 {
                continue;
            }
            let (lo, hi) = (mesh.index(i, j), mesh.index(i, j + 1));
            let k = hx * hx / hv;
            let mut add = |col: usize, w: f64| {
                push(t, lo, col, -w);
                push(t, hi, col, w);
            };
            // p and p′ at the face: the two rows' mean; ∂v p: their difference / hv.
            for row in [j, j + 1] {
                add(mesh.index(i, row), k * dda / 48.0);
                add(mesh.index(r, row), k * da / (24.0 * span * hx));
                add(mesh.index(l, row), -k * da / (24.0 * span * hx));
            }
            for (row, s) in [(j + 1, 1.0), (j, -1.0)] {
                add(mesh.index(i, row), -s * 0.5 * k * ddb / (24.0 * hv));
                add(
                    mesh.index(r, row),
                    -s * 0.5 * k * db / (12.0 * span * hx * hv),
                );
                add(
                    mesh.index(l, row),
                    s * 0.5 * k * db / (12.0 * span * hx * hv),
                );
            }
        }
    }
    Ok(())
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

    /// An impact's re-injection is exact for a leaving flux linear in the velocity: each
    /// target cell receives the integral of the mapped line over its piece of the image,
    /// for a reflecting map (v → −r v, reversed) and a pass-through one (v → r v), where
    /// the uniform spread alone is off by O(h) at each target.
    #[test]
    fn remapped_flux_is_exact_for_a_linear_flux() {
        let (mesh, _) = operator("tests/models/grid_impact_duffing.sde", 0.8);
        let rows: Vec<usize> = (mesh.nv / 2..mesh.nv).collect();
        let n = rows.len();
        // Row k's rate is the mean of g(u) = a + b u over u in [k, k + 1].
        let (a, b) = (2.0, 0.7);
        let rate: Vec<f64> = (0..n).map(|k| a + b * (k as f64 + 0.5)).collect();
        // Weights on "cells" 0..n standing for the rows' rates.
        let fluxes: Vec<Vec<(usize, f64)>> = (0..n).map(|k| vec![(k, 1.0)]).collect();
        for map in [-0.8, 0.8] {
            let (mut got, mut exact, mut uniform) = (
                vec![0.0; mesh.cells()],
                vec![0.0; mesh.cells()],
                vec![0.0; mesh.cells()],
            );
            let mut t = Vec::new();
            for (k, &j) in rows.iter().enumerate() {
                let (e0, e1) = (
                    mesh.v0 + j as f64 * mesh.hv,
                    mesh.v0 + (j + 1) as f64 * mesh.hv,
                );
                let (m0, m1) = (map * e0, map * e1);
                let (lo, hi) = (m0.min(m1), m0.max(m1));
                let targets = overlaps(&mesh, lo, hi);
                for &(jd, share) in &targets {
                    let row = mesh.index(0, jd);
                    got[row] += share * rate[k];
                    uniform[row] += share * rate[k];
                    let (c0, c1) = (
                        mesh.v0 + jd as f64 * mesh.hv,
                        mesh.v0 + (jd + 1) as f64 * mesh.hv,
                    );
                    let s = |u: f64| (u - m0) / (m1 - m0);
                    let (sa, sb) = (s(lo.max(c0)), s(hi.min(c1)));
                    let (al, be) = (sa.min(sb), sa.max(sb));
                    exact[row] += (be - al) * (a + b * k as f64) + b * (be * be - al * al) / 2.0;
                }
                remap_slope(&mut t, &mesh, 0, &fluxes, k, [m0, m1], &targets);
            }
            for tr in &t {
                got[tr.row] += tr.val * rate[tr.col];
            }
            let worst = got
                .iter()
                .zip(&exact)
                .fold(0.0f64, |w, (g, e)| w.max((g - e).abs()));
            let off = uniform
                .iter()
                .zip(&exact)
                .fold(0.0f64, |w, (g, e)| w.max((g - e).abs()));
            assert!(worst <= 1e-12, "map {map}: {worst:e}");
            assert!(off > 1e-3, "map {map}: the uniform spread is {off:e} off");
            let total: f64 = got.iter().sum();
            assert!((total - rate.iter().sum::<f64>()).abs() <= 1e-12);
        }
    }

    /// The face derivative is exact on cell averages of a cubic (fourth order), and the
    /// difference of the two cells at the edges of the box exact on a quadratic's.
    #[test]
    fn face_derivatives_are_exact_on_cubics() {
        let h = 0.3;
        let (lo, n) = (-1.2, 8);
        // Cell averages of p(v) = 2 − v + 0.5 v² + 0.7 v³ (its antiderivative P).
        let big_p = |v: f64| 2.0 * v - v * v / 2.0 + v.powi(3) / 6.0 + 0.7 * v.powi(4) / 4.0;
        let avg: Vec<f64> = (0..n)
            .map(|k| {
                let a = lo + k as f64 * h;
                (big_p(a + h) - big_p(a)) / h
            })
            .collect();
        let dp = |v: f64| -1.0 + v + 2.1 * v * v;
        for j in 1..n - 2 {
            let face = lo + (j + 1) as f64 * h;
            let got: f64 = derivative_weights(j, n, true)
                .iter()
                .map(|&(c, w)| w * avg[c])
                .sum();
            assert!(
                (got - h * dp(face)).abs() < 1e-13,
                "face {j}: {got} vs {}",
                h * dp(face)
            );
        }
        let quadratic: Vec<f64> = (0..n)
            .map(|k| {
                let a = lo + k as f64 * h;
                let q = |v: f64| 2.0 * v - v * v / 2.0 + v.powi(3) / 6.0;
                (q(a + h) - q(a)) / h
            })
            .collect();
        for j in [0, n - 2] {
            let face = lo + (j + 1) as f64 * h;
            let w = derivative_weights(j, n, true);
            assert_eq!(w.len(), 2);
            let got: f64 = w.iter().map(|&(c, w)| w * quadratic[c]).sum();
            assert!((got - h * (-1.0 + face)).abs() < 1e-13);
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
