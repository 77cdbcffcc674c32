//! Sizing the rectangle: coarse solves, enlarged while the density is not negligible at an
//! edge, then cut where it falls below `CUT` of its peak.

use super::assemble::{assemble, solve};
use super::error::GridError;
use super::mesh::{Domain, Mesh};
use super::problem::Mechanical;
use super::BarrierSide;
use crate::dynamics::BarrierKind;

/// Cells of a sizing pass.
const COARSE: [usize; 2] = [48, 64];
/// The density kept: the domain ends where the coarse density falls below this fraction of
/// its peak.
const CUT: f64 = 1e-9;
/// An edge holding more than this fraction of the peak is moved out.
const EDGE: f64 = 1e-6;
/// Passes before giving up.
const MAX_PASSES: usize = 12;
/// The first box: this many linearised standard deviations either side.
const SPAN: f64 = 8.0;

/// Solves on `mesh` pinned at the cell holding `guess`, again at the largest value when the
/// first pin falls where the density is negligible (the pin fixes the scale, so it must
/// not sit in the tail).
pub(crate) fn solve_pinned(
    mesh: &Mesh,
    problem: &Mechanical,
    guess: [f64; 2],
) -> Result<(Vec<f64>, f64), GridError> {
    let t = std::time::Instant::now();
    let op = assemble(mesh, problem)?;
    let assemble_ms = t.elapsed().as_secs_f64() * 1e3;
    let cell =
        |u: f64, lo: f64, h: f64, n: usize| ((((u - lo) / h).floor()).max(0.0) as usize).min(n - 1);
    let pin = mesh.index(
        cell(guess[0], mesh.x0, mesh.hx, mesh.nx),
        cell(guess[1], mesh.v0, mesh.hv, mesh.nv),
    );
    let p = solve(mesh, &op, pin)?;
    let (arg, max) = argmax(&p);
    if p[pin] >= 1e-3 * max {
        return Ok((p, assemble_ms));
    }
    Ok((solve(mesh, &op, arg)?, assemble_ms))
}

fn argmax(p: &[f64]) -> (usize, f64) {
    p.iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |acc, (k, &v)| {
            if v.abs() > acc.1 {
                (k, v.abs())
            } else {
                acc
            }
        })
}

/// The peak of the density, as (x, v), for pinning a solve on another mesh.
pub(crate) fn peak(mesh: &Mesh, p: &[f64]) -> [f64; 2] {
    let (k, _) = argmax(p);
    [mesh.xc(k / mesh.nv), mesh.vc(k % mesh.nv)]
}

/// ln(1/CUT): the energy-type density exp(−f E) falls to CUT of its peak at f E = LOG_CUT.
const LOG_CUT: f64 = 20.723_265_836_946_41;

/// The box of an energy-type density p ~ exp(−Φ(E)), E = v²/2 + U(x), U the potential of
/// the restoring force m(x, 0): the energy E* where Φ reaches ln(1/CUT), the positions of
/// that energy and the velocity √(2E*). Φ′(E) = 2c/b_eff(E) (stochastic averaging of a
/// lightly damped oscillator), c the damping at the origin and b_eff the diffusion averaged
/// over the orbit of energy E with weight |v| dx (v² per unit time), so that parametric noise
/// widens the tails by what the orbit sees, not by its value at the turning points.
/// `None` when the origin is not damped or the potential does not confine.
pub(crate) fn energy_box(problem: &Mechanical) -> Option<Domain> {
    let [sx, sv] = problem.linear_scale(0.0)?;
    let b0 = problem.eval(&[0.0], &[0.0]).ok()?.b[0];
    // 2c = b0/σv²: f(E) = 2c/b_eff(E).
    let two_c = b0 / (sv * sv);
    let (mut lo_wall, mut hi_wall) = (f64::NEG_INFINITY, f64::INFINITY);
    for b in &problem.barriers {
        match b.kind {
            BarrierKind::Reflecting(BarrierSide::Above) => lo_wall = b.at.min(0.0),
            BarrierKind::Reflecting(BarrierSide::Below) => hi_wall = b.at.max(0.0),
            BarrierKind::PassThrough => {}
        }
    }
    // U and b on both sides, out to where U is far beyond any energy the cut can need.
    let step = sx / 40.0;
    let mut sides: [Vec<(f64, f64, f64)>; 2] = [Vec::new(), Vec::new()];
    for (side, dir) in [-1.0, 1.0].into_iter().enumerate() {
        let (mut x, mut u) = (0.0f64, 0.0f64);
        let mut last = problem.eval(&[0.0], &[0.0]).ok()?;
        sides[side].push((0.0, 0.0, last.b[0]));
        for _ in 0..40_000 {
            let next = x + dir * step;
            if next < lo_wall || next > hi_wall {
                break;
            }
            let c = problem.eval(&[next], &[0.0]).ok()?;
            u += -0.5 * (c.m[0] + last.m[0]) * (next - x);
            x = next;
            last = c;
            sides[side].push((x, u, last.b[0].max(0.0)));
            if u * two_c / b0 > 40.0 * LOG_CUT {
                break;
            }
        }
    }
    // Φ(E) by the midpoint rule on energy steps of σv²/20, at most MAX_ENERGY_STEPS of them:
    // a diffusion that grows as fast as the potential (parametric noise on a spring of
    // k = 1e−8) keeps Φ from reaching the cut for ever, and the coarse passes size such a
    // domain instead.
    let de = sv * sv / 20.0;
    let (mut e, mut phi) = (0.0f64, 0.0f64);
    let mut steps = 0;
    while phi < LOG_CUT {
        steps += 1;
        if steps > MAX_ENERGY_STEPS {
            return None;
        }
        let mid = e + 0.5 * de;
        let (mut num, mut den) = (0.0, 0.0);
        for side in &sides {
            for &(_, u, b) in side.iter().skip(1) {
                if u < mid {
                    let w = (2.0 * (mid - u)).sqrt();
                    num += w * b;
                    den += w;
                }
            }
        }
        let b_eff = if den > 0.0 { num / den } else { b0 };
        if b_eff.is_nan() || b_eff <= 0.0 || e > 1e12 * sv * sv {
            return None;
        }
        phi += two_c / b_eff * de;
        e += de;
    }
    // The positions where U reaches E* (or the wall, or the end of the table).
    let reach =
        |side: &[(f64, f64, f64)]| side.iter().find(|p| p.1 >= e).or(side.last()).map(|p| p.0);
    let (lo, hi) = (reach(&sides[0])?, reach(&sides[1])?);
    if sides[0].last()?.1 < e && lo_wall.is_infinite()
        || sides[1].last()?.1 < e && hi_wall.is_infinite()
    {
        return None;
    }
    let v = (2.0 * e).sqrt();
    Some(Domain {
        x: [lo * MARGIN, hi * MARGIN],
        v: [-v * MARGIN, v * MARGIN],
    })
}

/// Energy steps of the energy box's Φ(E) before it gives up (a few hundred on the bundled
/// models).
const MAX_ENERGY_STEPS: usize = 20_000;

/// Room added to the energy box (the tails of a non-energy-type density differ).
const MARGIN: f64 = 1.15;

/// `domain` fitted to the model's barrier: a reflecting barrier replaces the end on its
/// side, a pass-through barrier is kept a few cells inside; two walls cut it to the strip
/// (the whole strip when the density's reach misses it).
pub(crate) fn fit_barrier(mut d: Domain, problem: &Mechanical) -> Domain {
    if let [lo, hi] = problem.barriers.as_slice() {
        let x = [d.x[0].max(lo.at), d.x[1].min(hi.at)];
        d.x = if x[0] < x[1] { x } else { [lo.at, hi.at] };
        return d;
    }
    if let Some(b) = problem.barriers.first() {
        let w = d.x[1] - d.x[0];
        match b.kind {
            BarrierKind::Reflecting(BarrierSide::Above) => {
                d.x = [b.at, d.x[1].max(b.at + 0.5 * w)];
            }
            BarrierKind::Reflecting(BarrierSide::Below) => {
                d.x = [d.x[0].min(b.at - 0.5 * w), b.at];
            }
            BarrierKind::PassThrough => {
                d.x = [d.x[0].min(b.at - 0.1 * w), d.x[1].max(b.at + 0.1 * w)];
            }
        }
    }
    d
}

/// The largest density of the outermost row of cells on each free side (x low, x high,
/// v ends), relative to the peak, and the domain grown by half its width on each side
/// where that exceeds `EDGE`; `None` when no side needs it.
pub(crate) fn grow(mesh: &Mesh, p: &[f64], problem: &Mechanical) -> Option<Domain> {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let top = p.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let mut edge = [0.0f64; 3];
    for j in 0..nv {
        edge[0] = edge[0].max(p[mesh.index(0, j)].abs());
        edge[1] = edge[1].max(p[mesh.index(nx - 1, j)].abs());
    }
    for i in 0..nx {
        edge[2] = edge[2].max(
            p[mesh.index(i, 0)]
                .abs()
                .max(p[mesh.index(i, nv - 1)].abs()),
        );
    }
    // Ends that are walls stay; a strip's free end grows up to its wall.
    let (fixed, limit) = match problem.barriers.as_slice() {
        [lo, hi] => ([mesh.ends_on_wall(0), mesh.ends_on_wall(1)], [lo.at, hi.at]),
        [b] => (
            match b.kind {
                BarrierKind::Reflecting(BarrierSide::Above) => [true, false],
                BarrierKind::Reflecting(BarrierSide::Below) => [false, true],
                BarrierKind::PassThrough => [false, false],
            },
            [f64::NEG_INFINITY, f64::INFINITY],
        ),
        _ => ([false, false], [f64::NEG_INFINITY, f64::INFINITY]),
    };
    let mut d = mesh.domain();
    let w = d.x[1] - d.x[0];
    let mut grown = false;
    for side in 0..2 {
        if !fixed[side] && edge[side] > EDGE * top {
            d.x[side] += if side == 0 { -0.3 } else { 0.3 } * w;
            d.x[side] = d.x[side].clamp(limit[0], limit[1]);
            grown = true;
        }
    }
    if edge[2] > EDGE * top {
        d.v = [d.v[0] * 1.3, d.v[1] * 1.3];
        grown = true;
    }
    grown.then_some(d)
}

/// The automatically sized domain, the number of passes and the peak location: coarse
/// passes, for models whose origin gives no energy box.
pub(crate) fn size(problem: &Mechanical) -> Result<(Domain, usize, [f64; 2]), GridError> {
    let barriers = problem.barriers.as_slice();
    let centre = 0.0;
    let [sx, sv] = problem.linear_scale(centre).unwrap_or([1.0, 1.0]);
    let mut x = [centre - SPAN * sx, centre + SPAN * sx];
    let mut vmax = SPAN * sv;
    // Which x edges are walls that stay where they are.
    let mut fixed = [false, false];
    if let [lo, hi] = barriers {
        // A strip: the walls are the ends; only the velocity range is sized.
        x = [lo.at, hi.at];
        fixed = [true, true];
    } else if let Some(b) = barriers.first() {
        match b.kind {
            BarrierKind::Reflecting(BarrierSide::Above) => {
                x = [b.at, x[1].max(b.at + SPAN * sx)];
                fixed[0] = true;
            }
            BarrierKind::Reflecting(BarrierSide::Below) => {
                x = [x[0].min(b.at - SPAN * sx), b.at];
                fixed[1] = true;
            }
            BarrierKind::PassThrough => {
                x = [x[0].min(b.at - sx), x[1].max(b.at + sx)];
            }
        }
    }
    let mut guess = [x[0].max(centre).min(x[1]), 0.0];
    let mut worst = 0.0;
    for pass in 1..=MAX_PASSES {
        let domain = Domain {
            x,
            v: [-vmax, vmax],
        };
        let mesh = Mesh::new(domain, COARSE[0], COARSE[1], barriers, 2);
        let (p, _) = solve_pinned(&mesh, problem, guess)?;
        guess = peak(&mesh, &p);
        let (nx, nv) = (mesh.nx, mesh.nv);
        let mut px = vec![0.0f64; nx];
        let mut pv = vec![0.0f64; nv];
        for i in 0..nx {
            for j in 0..nv {
                let a = p[mesh.index(i, j)].abs();
                px[i] = px[i].max(a);
                pv[j] = pv[j].max(a);
            }
        }
        let top = px.iter().fold(0.0f64, |a, &b| a.max(b));
        let edges = [px[0] / top, px[nx - 1] / top, pv[0].max(pv[nv - 1]) / top];
        let width = x[1] - x[0];
        let mut grown = false;
        for (side, &e) in edges[..2].iter().enumerate() {
            if e > EDGE && !fixed[side] {
                x[side] += if side == 0 { -0.5 } else { 0.5 } * width;
                grown = true;
            }
        }
        if edges[2] > EDGE {
            vmax *= 1.5;
            grown = true;
        }
        worst = edges
            .iter()
            .zip([fixed[0], fixed[1], false])
            .filter(|(_, f)| !f)
            .fold(0.0f64, |a, (e, _)| a.max(*e));
        if grown {
            continue;
        }
        // Cut: keep the cells above CUT·peak and one more on each free side.
        let mesh_x = |i: usize| mesh.x0 + i as f64 * mesh.hx;
        let first = px.iter().position(|&a| a >= CUT * top).unwrap_or(0);
        let last = px.iter().rposition(|&a| a >= CUT * top).unwrap_or(nx - 1);
        let lo = if fixed[0] {
            mesh.x0
        } else {
            mesh_x(first.saturating_sub(1))
        };
        let hi = if fixed[1] {
            mesh.domain().x[1]
        } else {
            mesh_x((last + 2).min(nx))
        };
        let keep = (0..nv).filter(|&j| pv[j] >= CUT * top);
        let vcut = keep
            .map(|j| mesh.vc(j).abs() + 1.5 * mesh.hv)
            .fold(0.0f64, f64::max);
        let mut xr = [lo, hi];
        if let Some(b) = barriers
            .first()
            .filter(|b| b.kind == BarrierKind::PassThrough)
        {
            // A pass-through barrier stays inside, a few cells from either end.
            xr = [
                xr[0].min(b.at - 4.0 * mesh.hx),
                xr[1].max(b.at + 4.0 * mesh.hx),
            ];
        }
        return Ok((
            Domain {
                x: xr,
                v: [-vcut.min(vmax), vcut.min(vmax)],
            },
            pass,
            guess,
        ));
    }
    Err(GridError::DomainNotFound {
        tries: MAX_PASSES,
        edge: worst,
        width: (x[1] - x[0]).max(2.0 * vmax),
    })
}
