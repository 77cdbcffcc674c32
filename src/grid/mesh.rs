//! The rectangle of cells, its walls and the face reconstruction.

use serde::Serialize;

use super::BarrierSide;
use crate::dynamics::{Barrier, BarrierKind};

/// A marginal density on the cells of one axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Marginal {
    /// Cell centres.
    pub centres: Vec<f64>,
    /// Cell-average densities (they integrate to one).
    pub density: Vec<f64>,
    /// The cell width.
    pub width: f64,
}

/// The rectangle [x_lo, x_hi] × [v_lo, v_hi] the density is computed on.
///
/// ```
/// let d = fpsolve::grid::Domain { x: [-1.0, 1.0], v: [-2.0, 2.0] };
/// assert_eq!(d.width(), [2.0, 4.0]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Domain {
    /// The position's range.
    pub x: [f64; 2],
    /// The velocity's range.
    pub v: [f64; 2],
}

impl Domain {
    /// The side lengths (x, v).
    ///
    /// ```
    /// let d = fpsolve::grid::Domain { x: [0.0, 3.0], v: [-1.0, 1.0] };
    /// assert_eq!(d.width()[0], 3.0);
    /// ```
    pub fn width(&self) -> [f64; 2] {
        [self.x[1] - self.x[0], self.v[1] - self.v[0]]
    }
}

/// A place where flux leaves the domain through the barrier and comes back: cells in column
/// `from` whose velocity points along `direction` (±1) exit; what leaves re-enters column
/// `into` at the mapped velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Exit {
    pub(crate) from: usize,
    /// The next cell inward from `from` (for the one-sided face value).
    pub(crate) inner: usize,
    pub(crate) direction: f64,
    pub(crate) into: usize,
    /// Which of the problem's barriers (its index) the flux leaves through.
    pub(crate) barrier: usize,
}

/// Uniform cells; the velocity axis has a face at v = 0 (nv even, symmetric range) so that
/// every cell's velocity has one sign, and the barrier is a face.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Mesh {
    pub(crate) nx: usize,
    pub(crate) nv: usize,
    pub(crate) x0: f64,
    /// The upper end of the position range (x0 + nx·hx up to rounding; a strip's wall
    /// exactly).
    x1: f64,
    pub(crate) hx: f64,
    pub(crate) v0: f64,
    /// The upper end of the second state's range: −v0 for the mechanical form (its velocity
    /// range is symmetric), any end above v0 for a general model.
    v1: f64,
    pub(crate) hv: f64,
    /// Runs of x-cells [start, end) between walls; reconstruction never crosses a wall.
    pub(crate) segments: Vec<[usize; 2]>,
    pub(crate) exits: Vec<Exit>,
    /// The position is periodic: the last x-cell's upper face is the first one's lower
    /// face, and reconstruction runs around it.
    pub(crate) wrap: bool,
}

impl Mesh {
    /// Cells on `domain`, moved (by less than `align` cells) so that a pass-through barrier
    /// falls on a face with a multiple of `align` cells below it (with `align` = 4 the
    /// half-resolution mesh of the error estimate has the same face, on an even cell), and
    /// clipped to a reflecting barrier's side; between two walls (a strip), cut to the strip,
    /// the flux re-injected at each wall that is an end of the domain (a wall beyond the
    /// density's reach is left out of a domain cut before it).
    pub(crate) fn new(
        domain: Domain,
        nx: usize,
        nv: usize,
        barriers: &[Barrier],
        align: usize,
    ) -> Mesh {
        if let [lo, hi] = barriers {
            return Mesh::strip(domain, nx, nv, [lo.at, hi.at]);
        }
        let barrier = barriers.first();
        let vmax = domain.v[0].abs().max(domain.v[1].abs());
        let hv = 2.0 * vmax / nv as f64;
        let mut x = domain.x;
        let mut segments = vec![[0, nx]];
        let mut exits = Vec::new();
        match barrier.map(|b| (b.at, b.kind)) {
            Some((at, BarrierKind::Reflecting(BarrierSide::Above))) => {
                x[0] = at;
                exits.push(Exit {
                    from: 0,
                    inner: 1,
                    direction: -1.0,
                    into: 0,
                    barrier: 0,
                });
            }
            Some((at, BarrierKind::Reflecting(BarrierSide::Below))) => {
                x[1] = at;
                exits.push(Exit {
                    from: nx - 1,
                    inner: nx - 2,
                    direction: 1.0,
                    into: nx - 1,
                    barrier: 0,
                });
            }
            Some((at, BarrierKind::PassThrough)) => {
                let h = (x[1] - x[0]) / nx as f64;
                let a = align as f64;
                let k = (((at - x[0]) / h / a).round().max(0.0) as usize * align)
                    .clamp(align, nx - align);
                x[0] = at - k as f64 * h;
                x[1] = x[0] + nx as f64 * h;
                segments = vec![[0, k], [k, nx]];
                exits.push(Exit {
                    from: k - 1,
                    inner: k - 2,
                    direction: 1.0,
                    into: k,
                    barrier: 0,
                });
                exits.push(Exit {
                    from: k,
                    inner: k + 1,
                    direction: -1.0,
                    into: k - 1,
                    barrier: 0,
                });
            }
            None => {}
        }
        Mesh {
            nx,
            nv,
            x0: x[0],
            // The domain's own end, not x0 + nx·hx (an ulp off): a wall there is the end of
            // every report window.
            x1: x[1],
            hx: (x[1] - x[0]) / nx as f64,
            v0: -vmax,
            v1: vmax,
            hv,
            segments,
            exits,
            wrap: false,
        }
    }

    /// Cells on `domain` cut to the strip between the walls `[lo, hi]`, with exits at the
    /// walls the domain ends on: the lower one (barrier 0) takes the flux at v < 0, the
    /// upper one (barrier 1) at v > 0.
    fn strip(domain: Domain, nx: usize, nv: usize, [lo, hi]: [f64; 2]) -> Mesh {
        let vmax = domain.v[0].abs().max(domain.v[1].abs());
        let mut x = [domain.x[0].max(lo), domain.x[1].min(hi)];
        if x[0] >= x[1] || x[0].is_nan() || x[1].is_nan() {
            x = [lo, hi];
        }
        let mut exits = Vec::new();
        if x[0] == lo {
            exits.push(Exit {
                from: 0,
                inner: 1,
                direction: -1.0,
                into: 0,
                barrier: 0,
            });
        }
        if x[1] == hi {
            exits.push(Exit {
                from: nx - 1,
                inner: nx - 2,
                direction: 1.0,
                into: nx - 1,
                barrier: 1,
            });
        }
        Mesh {
            nx,
            nv,
            x0: x[0],
            x1: x[1],
            hx: (x[1] - x[0]) / nx as f64,
            v0: -vmax,
            v1: vmax,
            hv: 2.0 * vmax / nv as f64,
            segments: vec![[0, nx]],
            exits,
            wrap: false,
        }
    }

    /// Uniform cells on `domain` as given, for a model of general form: no walls, and no
    /// face at 0 in the second state (it is not a velocity whose sign decides a flux
    /// direction), so its range need not be symmetric.
    pub(crate) fn general(domain: Domain, nx: usize, nv: usize) -> Mesh {
        let [v0, v1] = domain.v;
        Mesh {
            nx,
            nv,
            x0: domain.x[0],
            x1: domain.x[1],
            hx: (domain.x[1] - domain.x[0]) / nx as f64,
            v0,
            v1,
            hv: (v1 - v0) / nv as f64,
            segments: vec![[0, nx]],
            exits: Vec::new(),
            wrap: false,
        }
    }

    /// The same cells with the position periodic: the x range is one period, its two ends
    /// one face (a mesh without walls).
    pub(crate) fn wrapped(self) -> Mesh {
        debug_assert!(self.exits.is_empty() && self.segments.len() == 1);
        Mesh { wrap: true, ..self }
    }

    /// The x-faces of the mesh, each as the cells below and above it: between neighbours,
    /// and on a periodic mesh also between the last cell and the first.
    pub(crate) fn x_faces(&self) -> usize {
        if self.wrap {
            self.nx
        } else {
            self.nx - 1
        }
    }

    /// Whether the domain's lower (`0`) or upper (`1`) end is a wall of the problem.
    pub(crate) fn ends_on_wall(&self, end: usize) -> bool {
        self.exits
            .iter()
            .any(|e| e.direction == if end == 0 { -1.0 } else { 1.0 } && e.from == e.into)
    }

    pub(crate) fn domain(&self) -> Domain {
        // The mechanical velocity range is symmetric by construction; v1 = −v0 rather than
        // v0 + nv·hv (an ulp off), so that a point-symmetric density's quadratures stay
        // symmetric.
        Domain {
            x: [self.x0, self.x1],
            v: [self.v0, self.v1],
        }
    }

    pub(crate) fn cells(&self) -> usize {
        self.nx * self.nv
    }

    /// Unknown index of cell (i, j): velocity fastest.
    pub(crate) fn index(&self, i: usize, j: usize) -> usize {
        i * self.nv + j
    }

    pub(crate) fn xc(&self, i: usize) -> f64 {
        self.x0 + (i as f64 + 0.5) * self.hx
    }

    pub(crate) fn vc(&self, j: usize) -> f64 {
        self.v0 + (j as f64 + 0.5) * self.hv
    }

    /// The marginal of `axis` (0 position, 1 velocity) of cell averages `p` (velocity
    /// fastest) on these cells.
    pub(crate) fn marginal(&self, p: &[f64], axis: usize) -> Marginal {
        let (nx, nv) = (self.nx, self.nv);
        let (density, centres, width) = match axis {
            0 => {
                let d = (0..nx).map(|i| p[i * nv..(i + 1) * nv].iter().sum::<f64>() * self.hv);
                (d.collect(), (0..nx).map(|i| self.xc(i)).collect(), self.hx)
            }
            1 => {
                let mut d = vec![0.0; nv];
                for row in p.chunks_exact(nv) {
                    d.iter_mut().zip(row).for_each(|(d, v)| *d += v);
                }
                d.iter_mut().for_each(|d| *d *= self.hx);
                (d, (0..nv).map(|j| self.vc(j)).collect(), self.hv)
            }
            _ => panic!("axis {axis} of a two-state model"),
        };
        Marginal {
            centres,
            density,
            width,
        }
    }

    /// The segment holding x-cell `i`.
    pub(crate) fn segment_of(&self, i: usize) -> [usize; 2] {
        *self
            .segments
            .iter()
            .find(|s| (s[0]..s[1]).contains(&i))
            .unwrap_or(&[0, self.nx])
    }
}

/// Weights of the κ = 1/3 upwind-biased face value between cells `i` and `i + 1` of the run
/// [start, end), for flow in the direction of `sign`: −1/6, 5/6, 1/3 on the upwind-upwind,
/// upwind and downwind cells (third order). Where the far upwind cell is missing (next to a
/// wall) the face value is the mean of the two cells (a linear ghost), still second order.
pub(crate) fn face_weights(i: usize, [start, end]: [usize; 2], sign: f64) -> [(usize, f64); 3] {
    const K: [f64; 3] = [-1.0 / 6.0, 5.0 / 6.0, 1.0 / 3.0];
    if sign >= 0.0 {
        if i > start {
            [(i - 1, K[0]), (i, K[1]), (i + 1, K[2])]
        } else {
            [(i, 0.5), (i + 1, 0.5), (i, 0.0)]
        }
    } else if i + 2 < end {
        [(i + 2, K[0]), (i + 1, K[1]), (i, K[2])]
    } else {
        [(i + 1, 0.5), (i, 0.5), (i, 0.0)]
    }
}

/// [`face_weights`] on a periodic run of `n` cells: the face between cell `i` and cell
/// `(i + 1) mod n`, the third-order values everywhere (the neighbours wrap around).
pub(crate) fn wrapped_face_weights(i: usize, n: usize, sign: f64) -> [(usize, f64); 3] {
    const K: [f64; 3] = [-1.0 / 6.0, 5.0 / 6.0, 1.0 / 3.0];
    let at = |k: usize| (i + k) % n;
    if sign >= 0.0 {
        [(at(n - 1), K[0]), (i, K[1]), (at(1), K[2])]
    } else {
        [(at(2), K[0]), (at(1), K[1]), (i, K[2])]
    }
}

/// Fraction of the interval [a, b] (a < b) that falls in each velocity cell, as (cell,
/// fraction); the parts outside the mesh go to the end cells, so the fractions sum to one.
pub(crate) fn overlaps(mesh: &Mesh, a: f64, b: f64) -> Vec<(usize, f64)> {
    let len = b - a;
    let cell = |v: f64| (((v - mesh.v0) / mesh.hv).floor().max(0.0) as usize).min(mesh.nv - 1);
    let (ja, jb) = (cell(a), cell(b));
    let mut out = Vec::with_capacity(jb - ja + 1);
    for j in ja..=jb {
        let lo = if j == 0 {
            f64::NEG_INFINITY
        } else {
            mesh.v0 + j as f64 * mesh.hv
        };
        let hi = if j == mesh.nv - 1 {
            f64::INFINITY
        } else {
            mesh.v0 + (j + 1) as f64 * mesh.hv
        };
        let part = (b.min(hi) - a.max(lo)).max(0.0) / len;
        if part > 0.0 {
            out.push((j, part));
        }
    }
    // The fractions sum to one up to rounding; the last takes the remainder exactly.
    let rest: f64 = out[..out.len().saturating_sub(1)].iter().map(|p| p.1).sum();
    if let Some(last) = out.last_mut() {
        last.1 = 1.0 - rest;
    }
    out
}
