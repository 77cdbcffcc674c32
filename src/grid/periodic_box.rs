//! The box of a model whose first state is periodic: its range is the period's window, fixed;
//! the second state's range starts from a pilot of the SDE (no linearisation: a pendulum's
//! origin may be unstable, a rotor has none), then coarse solves enlarge it where the density
//! is not negligible at an edge and cut it where it falls below `CUT` of its peak, on that
//! axis only, as [`super::general_box`] does on both.

use super::assemble::Discretise;
use super::domain::{peak, profiles, reach, solve_pinned, COARSE, CUT, EDGE, MAX_PASSES, SETTLED};
use super::error::GridError;
use super::mesh::{Domain, Mesh};

/// The sized box, the number of coarse passes and the peak (for pinning the main solve);
/// `cells` makes the problem's wrapped cells on a box.
pub(crate) fn size<P: Discretise>(
    problem: &P,
    cells: &dyn Fn(Domain, usize, usize) -> Mesh,
    window: [f64; 2],
    start: [f64; 2],
) -> Result<(Domain, usize, [f64; 2]), GridError> {
    let mut d = Domain {
        x: window,
        v: start,
    };
    let mut guess = [0.0, 0.5 * (start[0] + start[1])];
    let mut scale = 1;
    let mut worst = 0.0f64;
    let mut last_cut: Option<Domain> = None;
    for pass in 1..=MAX_PASSES {
        let mesh = cells(d, COARSE[0] * scale, COARSE[1] * scale);
        let p = match solve_pinned(&mesh, problem, guess) {
            Ok((p, _)) => p,
            Err(GridError::Degenerate { .. } | GridError::Singular { .. }) if scale < 4 => {
                scale *= 2;
                continue;
            }
            Err(e) => return Err(e),
        };
        guess = peak(&mesh, &p);
        let (_, pv, top) = profiles(&mesh, &p);
        let edges = [pv[0] / top, pv[pv.len() - 1] / top];
        worst = edges[0].max(edges[1]);
        let cur = mesh.domain();
        if let Some(bigger) = widened(cur, edges, 0.5) {
            d = bigger;
            last_cut = None;
            continue;
        }
        let cut = cut_from(&mesh, &pv, top);
        let w = cur.width()[1];
        let settled = (0..2).all(|side| (cut.v[side] - cur.v[side]).abs() <= SETTLED * w);
        if settled || pass == MAX_PASSES {
            return Ok((cut, pass, guess));
        }
        last_cut = Some(cut);
        d = cut;
    }
    match last_cut {
        Some(cut) => Ok((cut, MAX_PASSES, guess)),
        None => Err(GridError::DomainNotFound {
            tries: MAX_PASSES,
            edge: worst,
            width: d.width()[1],
        }),
    }
}

/// `d` with each end of the second state's range whose edge holds more than `EDGE` of the
/// peak moved out by `by` times its width; `None` when neither needs it.
fn widened(d: Domain, edges: [f64; 2], by: f64) -> Option<Domain> {
    let w = d.width()[1];
    let mut out = d;
    for (side, &e) in edges.iter().enumerate() {
        if e > EDGE {
            out.v[side] += if side == 0 { -by * w } else { by * w };
        }
    }
    (out != d).then_some(out)
}

/// The box with the second state's range cut where `mesh`'s density falls below `CUT` of
/// its peak, one more cell kept; the window unchanged.
fn cut_from(mesh: &Mesh, pv: &[f64], top: f64) -> Domain {
    let n = pv.len();
    let rev: Vec<f64> = pv.iter().rev().copied().collect();
    let below = n.saturating_sub(reach(&rev, top) + 1);
    let above = (reach(pv, top) + 1).min(n);
    Domain {
        x: mesh.domain().x,
        v: [
            mesh.v0 + below as f64 * mesh.hv,
            mesh.v0 + above as f64 * mesh.hv,
        ],
    }
}

/// The main solve's box enlarged where its density is not negligible at an end of the
/// second state's range (by 0.3 of the width); `None` when neither end needs it.
pub(crate) fn grow(mesh: &Mesh, p: &[f64]) -> Option<Domain> {
    let (_, pv, top) = profiles(mesh, p);
    widened(mesh.domain(), [pv[0] / top, pv[pv.len() - 1] / top], 0.3)
}

/// The main solve's box cut where the second state's tails end far inside it (an edge
/// below `CUT`² of the peak); `None` when neither end would move in by a tenth of the box.
pub(crate) fn recut(mesh: &Mesh, p: &[f64]) -> Option<Domain> {
    let (_, pv, top) = profiles(mesh, p);
    if pv[0] / top >= CUT * CUT && pv[pv.len() - 1] / top >= CUT * CUT {
        return None;
    }
    let cur = mesh.domain();
    let cut = cut_from(mesh, &pv, top);
    let w = cur.width()[1];
    (0..2)
        .any(|side| (cut.v[side] - cur.v[side]).abs() > 0.1 * w)
        .then_some(cut)
}
