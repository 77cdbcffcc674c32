//! Moving the box so that a safe set that bounds the position alone has its bounds on cell
//! faces: the absorbing condition then sits where the set ends, not up to half a cell away.
//! A bound half a cell off is not a discretisation error that vanishes with the cells when
//! the meshes are nested: the same face is the last one at every count, and the half-cells
//! estimate, whose two solves share it, cannot see it (the Zhuravlev form of the paper's case
//! 1 had its bound |z| < 3 at 2.989 at every count, its mean passage time 1.2 % short).

use super::super::mesh::Domain;
use super::super::problem::Mechanical;
use crate::dynamics::BarrierKind;
use crate::model::{BoundModel, BoundSafe};

/// Points of the scan for the set's ends along x.
const SCAN: usize = 4096;

/// Cells below a pass-through barrier come in multiples of this ([`Mesh::new`]'s `align`).
///
/// [`Mesh::new`]: super::super::mesh::Mesh::new
pub(super) const MESH_ALIGN: usize = 4;

/// `box_` moved and stretched a little (by the fraction 1/(2k) at most, k the cells between
/// the faces it fixes; a pass-through barrier's box only grows, by 1/k at most) so that the
/// safe set's ends in x
/// fall on faces: both ends when the box is free, the end away from a wall when one end is
/// a wall (the wall is kept); with a pass-through barrier (the Zhuravlev form), the barrier
/// on a face as the mesh places it and the end farthest from it on a face too (both ends
/// when they are equally far from it, as a set |z| < B about the barrier at 0 of a Zhuravlev
/// form). Unchanged when the set depends on the velocity, has no end inside the box or more
/// than two, or the model has a strip (its faces are the walls).
pub(super) fn aligned(
    box_: Domain,
    nx: usize,
    problem: &Mechanical,
    safe: &BoundSafe,
    model: &BoundModel,
) -> Domain {
    if safe.quantity.mentions(&model.states()[1]) || problem.barriers.len() > 1 {
        return box_;
    }
    let (wall, pass_through) = match problem.barriers.first().map(|b| (b.kind, b.at)) {
        None => (None, None),
        Some((BarrierKind::Reflecting(side), _)) => (Some(side), None),
        Some((BarrierKind::PassThrough, at)) => (None, Some(at)),
    };
    let [x0, x1] = box_.x;
    let inside = |x: f64| safe.contains([x, 0.0]);
    let at = |k: usize| x0 + (x1 - x0) * k as f64 / SCAN as f64;
    let mut ends = Vec::new();
    for k in 0..SCAN {
        let (a, b) = (at(k), at(k + 1));
        if inside(a) != inside(b) {
            ends.push(bisect(&inside, a, b));
        }
    }
    let w = x1 - x0;
    let n = nx as f64;
    if let Some(at) = pass_through {
        return around(box_, n, &ends, at).unwrap_or(box_);
    }
    let mut out = box_;
    match (ends.as_slice(), wall) {
        ([lo, hi], None) => {
            let k = (n * (hi - lo) / w).round().clamp(1.0, n - 2.0);
            let h = (hi - lo) / k;
            let below = ((lo - x0) / h).round().clamp(1.0, n - k - 1.0);
            out.x = [lo - below * h, lo - below * h + n * h];
        }
        ([end], None) => {
            let k = (n * (end - x0) / w).round().clamp(1.0, n - 1.0);
            let h = (end - x0) / k;
            out.x = [x0, x0 + n * h];
        }
        (ends, Some(side)) if !ends.is_empty() => {
            use crate::model::BarrierSide;
            // The wall is the end the mesh keeps; align the set's end farthest from it.
            let (fixed, end) = match side {
                BarrierSide::Above => (x0, *ends.last().unwrap_or(&x1)),
                BarrierSide::Below => (x1, *ends.first().unwrap_or(&x0)),
            };
            let k = (n * (end - fixed).abs() / w).round().clamp(1.0, n - 1.0);
            let h = (end - fixed).abs() / k;
            out.x = match side {
                BarrierSide::Above => [x0, x0 + n * h],
                BarrierSide::Below => [x1 - n * h, x1],
            };
        }
        _ => {}
    }
    out
}

/// `box_` of `n` cells with the pass-through barrier at `at` on a face, [`MESH_ALIGN`] cells
/// aligned as the mesh puts it, and the cell width chosen so that the set's end farthest from
/// the barrier is on a face: widened, never narrowed (a box sized from the density must not
/// be cut); `None` without an end apart from the barrier.
fn around(box_: Domain, n: f64, ends: &[f64], at: f64) -> Option<Domain> {
    let far = ends
        .iter()
        .map(|e| (e - at).abs())
        .filter(|d| *d > 0.0)
        .reduce(f64::max)?;
    let [x0, x1] = box_.x;
    let k = (n * far / (x1 - x0)).floor().max(1.0);
    let h = far / k;
    let a = MESH_ALIGN as f64;
    let below = (((at - x0) / h / a).round() * a).clamp(a, n - a);
    let lo = at - below * h;
    Some(Domain {
        x: [lo, lo + n * h],
        ..box_
    })
}

/// The point in [a, b] where `inside` changes, to a few ulps.
fn bisect(inside: &dyn Fn(f64) -> bool, mut a: f64, mut b: f64) -> f64 {
    let left = inside(a);
    for _ in 0..80 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if inside(m) == left {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::mesh::Mesh;

    /// The Zhuravlev form's set |z| < 3 about its pass-through barrier at 0: after the
    /// alignment both ends and the barrier are faces of the mesh, at every count of cells
    /// (before, the box sized from the density put the last safe face at 2.989 at every
    /// count, the meshes being nested).
    #[test]
    fn a_pass_through_barrier_and_both_ends_of_the_set_are_faces() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
        let model = crate::model::load_model(&path)
            .unwrap()
            .with_safe("abs(z) < 3")
            .unwrap();
        let bound = model.bind(&[]).unwrap();
        let safe = model.safe().unwrap().bind(&bound).unwrap();
        let problem = Mechanical::new(&crate::dynamics::Dynamics::read(&bound)).unwrap();
        let box_ = Domain {
            x: [-9.96448, 9.96448],
            v: [-8.0, 8.0],
        };
        for nx in [50, 100, 200, 400, 800] {
            let mesh = Mesh::new(
                aligned(box_, nx, &problem, &safe, &bound),
                nx,
                16,
                &problem.barriers,
                MESH_ALIGN,
            );
            let face = |x: f64| {
                let k = (x - mesh.x0) / mesh.hx;
                (k - k.round()).abs() < 1e-9
            };
            assert!(
                face(0.0) && face(-3.0) && face(3.0),
                "{nx}: x0 {} hx {}",
                mesh.x0,
                mesh.hx
            );
            // The box grows, by the fraction 1/k at most (k = 3/hx cells up to the end).
            let (w, w0) = (mesh.domain().x[1] - mesh.domain().x[0], 2.0 * 9.96448);
            let k = 3.0 / mesh.hx;
            assert!(w >= w0 && w <= w0 * (1.0 + 1.0 / k), "{nx}: {w} vs {w0}");
        }
    }
}
