//! Sizing the rectangle from where the density lives: a first guess (the energy box, the
//! linearised scale, or a Monte Carlo pilot), then coarse solves, enlarged while the density
//! is not negligible at an edge, cut where it falls below `CUT` of its peak, until the cut
//! settles.

use super::assemble::{solve, Discretise, Operator};
use super::error::GridError;
use super::mesh::{Domain, Mesh};
use super::problem::Mechanical;
use super::BarrierSide;
use crate::dynamics::BarrierKind;

/// Cells of a sizing pass.
pub(super) const COARSE: [usize; 2] = [64, 96];
/// The density kept: the domain ends where the coarse density falls below this fraction of
/// its peak.
pub(super) const CUT: f64 = 1e-9;
/// An edge holding more than this fraction of the peak is moved out.
pub(super) const EDGE: f64 = 1e-6;
/// Passes before giving up.
pub(super) const MAX_PASSES: usize = 12;
/// The first box: this many linearised standard deviations either side.
const SPAN: f64 = 8.0;

/// Solves on `mesh` pinned at the cell holding `guess`, again at the largest value when the
/// first pin falls where the density is negligible (the pin fixes the scale, so it must
/// not sit in the tail).
pub(crate) fn solve_pinned<P: Discretise>(
    mesh: &Mesh,
    problem: &P,
    guess: [f64; 2],
) -> Result<(Vec<f64>, f64), GridError> {
    let t = std::time::Instant::now();
    let op = problem.operator(mesh)?;
    let assemble_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok((solve_pinned_op(mesh, &op, guess)?, assemble_ms))
}

/// [`solve_pinned`] with the operator `op` of the problem on `mesh` already assembled.
pub(crate) fn solve_pinned_op(
    mesh: &Mesh,
    op: &Operator,
    guess: [f64; 2],
) -> Result<Vec<f64>, GridError> {
    let cell =
        |u: f64, lo: f64, h: f64, n: usize| ((((u - lo) / h).floor()).max(0.0) as usize).min(n - 1);
    let pin = mesh.index(
        cell(guess[0], mesh.x0, mesh.hx, mesh.nx),
        cell(guess[1], mesh.v0, mesh.hv, mesh.nv),
    );
    let p = solve(mesh, op, pin)?;
    let (arg, max) = argmax(&p);
    if p[pin] >= 1e-3 * max {
        return Ok(p);
    }
    solve(mesh, op, arg)
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

/// Which ends of the position range are walls that stay where they are (a single reflecting
/// barrier's side), and how far a free end may move (a strip's walls).
fn ends(problem: &Mechanical) -> ([bool; 2], [f64; 2]) {
    match problem.barriers.as_slice() {
        [lo, hi] => ([false, false], [lo.at, hi.at]),
        [b] => (
            match b.kind {
                BarrierKind::Reflecting(BarrierSide::Above) => [true, false],
                BarrierKind::Reflecting(BarrierSide::Below) => [false, true],
                BarrierKind::PassThrough => [false, false],
            },
            [f64::NEG_INFINITY, f64::INFINITY],
        ),
        _ => ([false, false], [f64::NEG_INFINITY, f64::INFINITY]),
    }
}

/// The first box of the sizing passes: the energy box where the origin is a damped rest point
/// of a confining potential, else the linearised Gaussian scale there, else (an unstable or
/// undamped origin, a saddle) where a short Monte Carlo pilot goes.
fn first_guess(problem: &Mechanical) -> Result<(Domain, bool), GridError> {
    if let Some(d) = energy_box(problem) {
        return Ok((fit_barrier(d, problem), true));
    }
    if let Some([sx, sv]) = problem.linear_scale(0.0) {
        let d = Domain {
            x: [-SPAN * sx, SPAN * sx],
            v: [-SPAN * sv, SPAN * sv],
        };
        return Ok((fit_barrier(d, problem), false));
    }
    Ok((
        fit_barrier(super::pilot::pilot_box(problem)?, problem),
        false,
    ))
}

/// The automatically sized domain, the number of passes and the peak location. From a first
/// guess ([`first_guess`]), coarse solves, each enlarging the box where its density is not
/// negligible at a free edge, else cutting each free side (x low, x high, and the velocity
/// range) where the density falls below `CUT` of its peak; done when a cut moves no side by
/// more than `SETTLED` of the box, or at the first cut inside an energy box. Walls stay where they are; a strip's free end moves only
/// inside the strip. A coarse solve that does not resolve the density (a thin ring in a wide
/// box) is repeated on twice the cells, twice at most.
pub(crate) fn size(problem: &Mechanical) -> Result<(Domain, usize, [f64; 2]), GridError> {
    let barriers = problem.barriers.as_slice();
    let (fixed, limit) = ends(problem);
    // An energy box holds an energy-type density with room to spare (see `MARGIN`): the
    // cut of its first coarse solve is final unless that solve asks for more room, which
    // keeps the sizing of the paper's cases to one coarse solve.
    let (mut d, trusted) = first_guess(problem)?;
    let mut guess = [0.5 * (d.x[0] + d.x[1]), 0.0];
    let mut scale = 1;
    let mut worst = 0.0;
    let mut last_cut: Option<Domain> = None;
    for pass in 1..=MAX_PASSES {
        let mesh = Mesh::new(d, COARSE[0] * scale, COARSE[1] * scale, barriers, 2);
        let p = match solve_pinned(&mesh, problem, guess) {
            Ok((p, _)) => p,
            Err(GridError::Degenerate { .. } | GridError::Singular { .. }) if scale < 4 => {
                scale *= 2;
                continue;
            }
            Err(e) => return Err(e),
        };
        guess = peak(&mesh, &p);
        let (nx, nv) = (mesh.nx, mesh.nv);
        let (px, pv, top) = profiles(&mesh, &p);
        let on_wall = [
            fixed[0] || mesh.ends_on_wall(0),
            fixed[1] || mesh.ends_on_wall(1),
        ];
        let edges = [px[0] / top, px[nx - 1] / top, pv[0].max(pv[nv - 1]) / top];
        let cur = mesh.domain();
        let width = cur.x[1] - cur.x[0];
        let mut grown = false;
        for side in 0..2 {
            if edges[side] > EDGE && !on_wall[side] {
                let moved = cur.x[side] + if side == 0 { -0.5 } else { 0.5 } * width;
                d.x[side] = moved.clamp(limit[0], limit[1]);
                grown = true;
            }
        }
        if edges[2] > EDGE {
            d.v = [cur.v[0] * 1.5, cur.v[1] * 1.5];
            grown = true;
        }
        worst = edges
            .iter()
            .zip([on_wall[0], on_wall[1], false])
            .filter(|(_, f)| !f)
            .fold(0.0f64, |a, (e, _)| a.max(*e));
        if grown {
            last_cut = None;
            continue;
        }
        let cut = cut_from(&mesh, (&px, &pv, top), problem, on_wall);
        let settled = (cut.x[0] - cur.x[0]).abs().max((cut.x[1] - cur.x[1]).abs())
            <= SETTLED * width
            && (cut.v[1] - cur.v[1]).abs() <= SETTLED * cur.v[1];
        if settled || pass == MAX_PASSES || (trusted && pass == 1) {
            return Ok((symmetrised(cut, problem), pass, guess));
        }
        last_cut = Some(cut);
        d = cut;
    }
    match last_cut {
        Some(cut) => Ok((symmetrised(cut, problem), MAX_PASSES, guess)),
        None => Err(GridError::DomainNotFound {
            tries: MAX_PASSES,
            edge: worst,
            width: (d.x[1] - d.x[0]).max(d.v[1] - d.v[0]),
        }),
    }
}

/// The largest |density| of each position row and each velocity row of `p` on `mesh`, and
/// the peak.
pub(super) fn profiles(mesh: &Mesh, p: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
    let mut px = vec![0.0f64; mesh.nx];
    let mut pv = vec![0.0f64; mesh.nv];
    for (i, row) in px.iter_mut().enumerate() {
        for (j, col) in pv.iter_mut().enumerate() {
            let a = p[mesh.index(i, j)].abs();
            *row = row.max(a);
            *col = col.max(a);
        }
    }
    let top = px.iter().fold(0.0f64, |a, &b| a.max(b));
    (px, pv, top)
}

/// The box `mesh`'s density (its row profiles, [`profiles`]) is cut to: each free side (not
/// `on_wall`) where the density falls below `CUT` of its peak (see `reach`), one more cell
/// kept; a strip's free end stays inside it, a pass-through barrier a few cells inside.
fn cut_from(
    mesh: &Mesh,
    (px, pv, top): (&[f64], &[f64], f64),
    problem: &Mechanical,
    on_wall: [bool; 2],
) -> Domain {
    let (nx, nv) = (mesh.nx, mesh.nv);
    let (_, limit) = ends(problem);
    let barriers = problem.barriers.as_slice();
    let cur = mesh.domain();
    // Cut each free side where the density falls below CUT of its peak (one more cell
    // kept), as the coarse solve's tail decay says (see `reach`).
    let face = |i: usize| mesh.x0 + i as f64 * mesh.hx;
    let mut x = [cur.x[0], cur.x[1]];
    if !on_wall[0] {
        let rev: Vec<f64> = px.iter().rev().copied().collect();
        let k = reach(&rev, top);
        x[0] = face(nx.saturating_sub(k + 1));
        if x[0] - limit[0] < mesh.hx {
            x[0] = limit[0];
        }
    }
    if !on_wall[1] {
        x[1] = face((reach(px, top) + 1).min(nx));
        if limit[1] - x[1] < mesh.hx {
            x[1] = limit[1];
        }
    }
    if let Some(b) = barriers
        .first()
        .filter(|b| b.kind == BarrierKind::PassThrough)
    {
        // A pass-through barrier stays inside, a few cells from either end.
        x = [
            x[0].min(b.at - 4.0 * mesh.hx),
            x[1].max(b.at + 4.0 * mesh.hx),
        ];
    }
    // The velocity range is symmetric (the mesh has a face at v = 0): the farther side.
    let half = nv / 2;
    let upper: Vec<f64> = pv[half..].to_vec();
    let lower: Vec<f64> = pv[..half].iter().rev().copied().collect();
    let vcut = ((reach(&upper, top).max(reach(&lower, top)) + 1) as f64 * mesh.hv).min(cur.v[1]);
    Domain {
        x,
        v: [-vcut, vcut],
    }
}

/// The box of a main solve whose tails end far inside its box (an edge below `CUT`² of the
/// peak on some free side): the coarse passes' density of a weakly excited limit cycle is
/// wider than the true one (their cells add diffusion the noise does not have), so its box
/// is cut again from the resolved solution. `None` when no side would move in by more than
/// a tenth of the box.
pub(crate) fn recut(mesh: &Mesh, p: &[f64], problem: &Mechanical) -> Option<Domain> {
    let (fixed, _) = ends(problem);
    let on_wall = [
        fixed[0] || mesh.ends_on_wall(0),
        fixed[1] || mesh.ends_on_wall(1),
    ];
    let (px, pv, top) = profiles(mesh, p);
    let (nx, nv) = (mesh.nx, mesh.nv);
    let far_inside = (!on_wall[0] && px[0] < CUT * CUT * top)
        || (!on_wall[1] && px[nx - 1] < CUT * CUT * top)
        || pv[0].max(pv[nv - 1]) < CUT * CUT * top;
    if !far_inside {
        return None;
    }
    let cur = mesh.domain();
    let cut = symmetrised(cut_from(mesh, (&px, &pv, top), problem, on_wall), problem);
    let w = cur.width();
    let moved = (cut.x[0] - cur.x[0]).abs().max((cur.x[1] - cut.x[1]).abs()) > 0.1 * w[0]
        || cur.v[1] - cut.v[1] > 0.1 * cur.v[1];
    moved.then_some(cut)
}

/// `d` made symmetric about x = 0 (the farther end on both sides, inside a strip's walls)
/// when the problem is point-symmetric on it ([`Mechanical::point_symmetric`]): its density is
/// then point-symmetric, and a symmetric box keeps the discrete solution and every
/// quadrature of it symmetric, where a box an ulp off flips the choices of an adaptive rule
/// on one side only (the linear oscillator's mean moved by 1.1e−5 with the box's ends 2
/// ulps apart).
pub(crate) fn symmetrised(d: Domain, problem: &Mechanical) -> Domain {
    let half = d.x[0].abs().max(d.x[1].abs());
    if !problem.point_symmetric([half, d.v[0].abs().max(d.v[1].abs())]) {
        return d;
    }
    let mut x = [-half, half];
    if let [lo, hi] = problem.barriers.as_slice() {
        x = [x[0].max(lo.at), x[1].min(hi.at)];
    }
    Domain { x, v: d.v }
}

/// How many cells of `profile` (the largest density of each row, outward from the box's
/// middle or its lower end) a cut at `CUT`·`top` keeps: where the profile's tail, extrapolated
/// log-linearly from its last crossing of `TRUSTED` and the first crossing of `TRUSTED`² after
/// it, reaches the cut, but no further than the last cell above the cut. A coarse solve's
/// values a millionth of the peak down are a few per cent off; further down, its third-order
/// scheme leaves oscillations all over the tails of a thin ring (the last row above 1e−6 of
/// the peak kept van der Pol's α = 0.02 ring in x ∈ ±6.2, its edge at 4e−25 of the peak), so
/// it is the decay rate where the tail leaves the density, not the values beyond, that
/// places the cut. Exact for an exponential tail, 8 % wide for a Gaussian one.
pub(super) fn reach(profile: &[f64], top: f64) -> usize {
    let n = profile.len();
    let last_above = |level: f64| profile.iter().rposition(|&a| a >= level * top);
    let Some(near) = last_above(TRUSTED) else {
        return n;
    };
    let Some(far) = profile[near..]
        .iter()
        .position(|&a| a < TRUSTED * TRUSTED * top)
        .map(|k| near + k)
    else {
        // The tail never falls to TRUSTED² inside the box.
        return n;
    };
    // Decades per cell between the two crossings; CUT is this many decades further.
    let rate = TRUSTED.log10().abs() / (far - near).max(1) as f64;
    let more = (CUT.log10() - (TRUSTED * TRUSTED).log10()).abs() / rate;
    let extrapolated = far + more.ceil() as usize;
    let cap = last_above(CUT).map_or(n, |k| k + 1);
    extrapolated.min(cap).clamp(far + 1, n)
}

/// The levels below the peak (this and its square) whose crossings give a coarse tail's
/// decay rate.
const TRUSTED: f64 = 1e-3;

/// A cut that moves no side by more than this fraction of the box ends the sizing passes.
pub(super) const SETTLED: f64 = 0.05;
