//! The box of a general-form model, from where its density lives: a short Monte Carlo pilot
//! of the SDE itself for the first box (no linearisation, which may be unstable, and no
//! energy, which a general model does not have), then coarse solves enlarged on each side
//! where the density is not negligible at that edge and cut on each side where it falls
//! below `CUT` of its peak, until the cut settles. Every side of both axes moves on its own:
//! neither state is a velocity, so neither range is symmetric about 0. When the first state
//! is periodic (`fixed_x`), its range is its window and only the second axis moves; the same
//! passes then size that axis of a mechanical model too.

use super::assemble::Discretise;
use super::domain::{peak, profiles, reach, solve_pinned, COARSE, CUT, EDGE, MAX_PASSES, SETTLED};
use super::error::GridError;
use super::general::General;
use super::mesh::{Domain, Mesh};

/// The sized box, the number of coarse passes and the peak (for pinning the main solve).
pub(crate) fn size(problem: &General) -> Result<(Domain, usize, [f64; 2]), GridError> {
    let (d, guess) = pilot_box(problem)?;
    size_from(
        problem,
        &|d, nx, nv| Mesh::general(d, nx, nv),
        d,
        guess,
        false,
    )
}

/// The coarse passes from the box `start` pinned at `guess`, on the cells `cells` makes;
/// `fixed_x`: the first state's range stays as it is (a periodic state's window).
pub(crate) fn size_from<P: Discretise>(
    problem: &P,
    cells: &dyn Fn(Domain, usize, usize) -> Mesh,
    start: Domain,
    mut guess: [f64; 2],
    fixed_x: bool,
) -> Result<(Domain, usize, [f64; 2]), GridError> {
    let mut d = start;
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
        let (px, pv, top) = profiles(&mesh, &p);
        let edges = edge_levels(&px, &pv, top, fixed_x);
        worst = edges.iter().flatten().fold(0.0, |a, &b| a.max(b));
        let cur = mesh.domain();
        if let Some(bigger) = widened(cur, edges, 0.5) {
            d = bigger;
            last_cut = None;
            continue;
        }
        // A fixed range is cut to itself, so it is settled and never moves.
        let cut = cut_from(&mesh, &px, &pv, top, fixed_x);
        let w = cur.width();
        let settled = (0..2).all(|side| {
            (cut.x[side] - cur.x[side]).abs() <= SETTLED * w[0]
                && (cut.v[side] - cur.v[side]).abs() <= SETTLED * w[1]
        });
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
            width: if fixed_x {
                d.width()[1]
            } else {
                d.width()[0].max(d.width()[1])
            },
        }),
    }
}

/// The largest density on each outermost row (x low, x high, y low, y high), relative to
/// the peak; `None` for the sides of a fixed x range (`fixed_x`), which never move.
fn edge_levels(px: &[f64], pv: &[f64], top: f64, fixed_x: bool) -> [Option<f64>; 4] {
    let moves = |k: usize| k >= 2 || !fixed_x;
    let rows = [px[0], px[px.len() - 1], pv[0], pv[pv.len() - 1]];
    std::array::from_fn(|k| moves(k).then(|| rows[k] / top))
}

/// `d` with every side whose edge holds more than `EDGE` of the peak moved out by `by`
/// times the box's width along that axis; `None` when no side needs it.
fn widened(d: Domain, edges: [Option<f64>; 4], by: f64) -> Option<Domain> {
    let w = d.width();
    let mut out = d;
    let mut grown = false;
    for (k, e) in edges.iter().enumerate() {
        if e.is_some_and(|e| e > EDGE) {
            let (axis, side) = (k / 2, k % 2);
            let dir = if side == 0 { -1.0 } else { 1.0 };
            let range = if axis == 0 { &mut out.x } else { &mut out.v };
            range[side] += dir * by * w[axis];
            grown = true;
        }
    }
    grown.then_some(out)
}

/// The main solve's box enlarged where its density is not negligible at an edge (by 0.3
/// of the width on that side, as the mechanical form's); `None` when no side needs it.
/// `fixed_x`: the first state's range does not move.
pub(crate) fn grow(mesh: &Mesh, p: &[f64], fixed_x: bool) -> Option<Domain> {
    let (px, pv, top) = profiles(mesh, p);
    widened(mesh.domain(), edge_levels(&px, &pv, top, fixed_x), 0.3)
}

/// The box `mesh`'s density is cut to: each side where the density falls below `CUT` of
/// its peak ([`reach`] reads the tail's decay), one more cell kept; the x range as it is
/// when `fixed_x`.
fn cut_from(mesh: &Mesh, px: &[f64], pv: &[f64], top: f64, fixed_x: bool) -> Domain {
    let axis = |profile: &[f64], lo: f64, h: f64| {
        let n = profile.len();
        let rev: Vec<f64> = profile.iter().rev().copied().collect();
        let below = n.saturating_sub(reach(&rev, top) + 1);
        let above = (reach(profile, top) + 1).min(n);
        [lo + below as f64 * h, lo + above as f64 * h]
    };
    Domain {
        x: if fixed_x {
            mesh.domain().x
        } else {
            axis(px, mesh.x0, mesh.hx)
        },
        v: axis(pv, mesh.v0, mesh.hv),
    }
}

/// The box of a main solve whose tails end far inside it (an edge below `CUT`² of the peak
/// on some side), cut again from the resolved solution (the coarse passes' density is wider
/// than the true one where their cells add diffusion). `None` when no side would move in by
/// more than a tenth of the box. `fixed_x`: the first state's range does not move.
pub(crate) fn recut(mesh: &Mesh, p: &[f64], fixed_x: bool) -> Option<Domain> {
    let (px, pv, top) = profiles(mesh, p);
    let edges = edge_levels(&px, &pv, top, fixed_x);
    if !edges.iter().flatten().any(|&e| e < CUT * CUT) {
        return None;
    }
    let cur = mesh.domain();
    let cut = cut_from(mesh, &px, &pv, top, fixed_x);
    let w = cur.width();
    let moved = (0..2).any(|side| {
        (cut.x[side] - cur.x[side]).abs() > 0.1 * w[0]
            || (cut.v[side] - cur.v[side]).abs() > 0.1 * w[1]
    });
    moved.then_some(cut)
}

/// Trajectories of the pilot.
const PARTICLES: usize = 64;
/// Simulated time; the second half is recorded.
const TIME: f64 = 150.0;
/// Most steps taken (a stiff model gets a shorter pilot, not a slower one).
const MAX_STEPS: usize = 15_000;
/// Largest step; the step is also bounded by the drift's fastest rate: rate·dt ≤ 0.2.
const DT: f64 = 0.01;
/// A trajectory beyond this is a blow-up and is dropped.
const ESCAPE: f64 = 1e6;
/// Points the pilot may start from, the first where the coefficients are finite.
const STARTS: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 1.0], [-1.0, -1.0], [0.5, -0.5]];

/// The range an Euler–Maruyama pilot of the SDE visited over the second half of its run,
/// widened by half its width on each side, and the mean point visited (the first pin).
/// [`GridError::DomainNotFound`] when every trajectory escapes.
pub(super) fn pilot_box(problem: &General) -> Result<(Domain, [f64; 2]), GridError> {
    let not_found = || GridError::DomainNotFound {
        tries: 0,
        edge: f64::NAN,
        width: ESCAPE,
    };
    let start = STARTS
        .iter()
        .find(|s| {
            let c = problem.eval_raw(&[s[0]], &[s[1]]);
            c.a.iter().chain(&c.b).all(|col| col[0].is_finite())
        })
        .ok_or_else(not_found)?;
    // SplitMix64 and Box–Muller, as the mechanical pilot: a fixed, decent stream.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut normal = move || {
        let u: f64 = uniform().max(f64::MIN_POSITIVE);
        let w: f64 = uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * w).cos()
    };
    let mut x = vec![start[0]; PARTICLES];
    let mut y = vec![start[1]; PARTICLES];
    let mut alive = [true; PARTICLES];
    let mut range = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
    let (mut sum, mut count) = ([0.0f64; 2], 0usize);
    let (mut t, mut steps, mut dt) = (0.0, 0, DT);
    let h = 1e-6;
    while t < TIME && steps < MAX_STEPS {
        let c = problem.eval_raw(&x, &y);
        if steps % 16 == 0 {
            // The fastest rate of the drift, by differences in both states.
            let xp: Vec<f64> = x.iter().map(|v| v + h).collect();
            let yp: Vec<f64> = y.iter().map(|v| v + h).collect();
            let (cx, cy) = (problem.eval_raw(&xp, &y), problem.eval_raw(&x, &yp));
            let mut rate = 0.0f64;
            for k in (0..PARTICLES).filter(|&k| alive[k]) {
                for i in 0..2 {
                    for d in [cx.a[i][k] - c.a[i][k], cy.a[i][k] - c.a[i][k]] {
                        let r = (d / h).abs();
                        if r.is_finite() {
                            rate = rate.max(r);
                        }
                    }
                }
            }
            dt = DT.min(0.2 / rate.max(1e-300));
        }
        let sq = dt.sqrt();
        for k in 0..PARTICLES {
            if !alive[k] {
                continue;
            }
            // b = L·Lᵀ (Cholesky, with a zero first pivot handled: b₁₂ is 0 then).
            let (b11, b12, b22) = (c.b[0][k].max(0.0), c.b[1][k], c.b[2][k].max(0.0));
            let l11 = b11.sqrt();
            let l21 = if l11 > 0.0 { b12 / l11 } else { 0.0 };
            let l22 = (b22 - l21 * l21).max(0.0).sqrt();
            let (n1, n2) = (normal(), normal());
            let xn = x[k] + c.a[0][k] * dt + l11 * sq * n1;
            let yn = y[k] + c.a[1][k] * dt + (l21 * n1 + l22 * n2) * sq;
            if !(xn.is_finite() && yn.is_finite()) || xn.abs() > ESCAPE || yn.abs() > ESCAPE {
                alive[k] = false;
                continue;
            }
            x[k] = xn;
            y[k] = yn;
            if t >= 0.5 * TIME || steps >= MAX_STEPS / 2 {
                for (r, u) in range.iter_mut().zip([xn, yn]) {
                    *r = [r[0].min(u), r[1].max(u)];
                }
                sum = [sum[0] + xn, sum[1] + yn];
                count += 1;
            }
        }
        t += dt;
        steps += 1;
    }
    if count == 0 || range.iter().flatten().any(|u| !u.is_finite()) {
        return Err(not_found());
    }
    let scale = (range[0][1] - range[0][0]).max(range[1][1] - range[1][0]);
    let widen = |r: [f64; 2]| {
        let w = (r[1] - r[0]).max(1e-3 * scale).max(1e-12);
        [r[0] - 0.5 * w, r[1] + 0.5 * w]
    };
    let mean = [sum[0] / count as f64, sum[1] / count as f64];
    Ok((
        Domain {
            x: widen(range[0]),
            v: widen(range[1]),
        },
        mean,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{Dynamics, Form};
    use crate::model::parse_model;

    fn general(text: &str) -> General {
        let bound = parse_model(text, None).unwrap().bind(&[]).unwrap();
        let dynamics = Dynamics::read(&bound);
        let Form::General { why } = dynamics.form() else {
            panic!("not general")
        };
        General::new(&bound, &dynamics, why).unwrap()
    }

    /// An Ornstein–Uhlenbeck process centred at (3, −2) with standard deviations 1 and 0.5
    /// (independent coordinates): the box is cut where the Gaussian falls to about 1e−9 of
    /// its peak, 6.4 standard deviations, on each side on its own (not symmetric about 0).
    #[test]
    fn the_box_follows_an_off_centre_gaussian() {
        let g = general(
            "model m\nstate x, y\ndrift x: -(x - 3)\ndrift y: -(y + 2)\n\
             noise a: intensity 2\nnoise b: intensity 0.5\ndiffusion x: a\ndiffusion y: b\n",
        );
        let (d, _, guess) = size(&g).unwrap();
        let reach = 6.44;
        let near = |end: f64, want: f64, sd: f64| (end - want).abs() < 0.15 * reach * sd;
        assert!(
            near(d.x[0], 3.0 - reach, 1.0) && near(d.x[1], 3.0 + reach, 1.0),
            "{d:?}"
        );
        assert!(near(d.v[0], -2.0 - 0.5 * reach, 0.5), "{d:?}");
        assert!(near(d.v[1], -2.0 + 0.5 * reach, 0.5), "{d:?}");
        assert!(
            (guess[0] - 3.0).abs() < 0.3 && (guess[1] + 2.0).abs() < 0.2,
            "{guess:?}"
        );
    }
}
