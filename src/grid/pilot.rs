//! A short Monte Carlo pilot: where the state goes when nothing at the origin says (an
//! unstable or undamped origin, a saddle between two wells). Its range is only the first box
//! of the sizing passes ([`super::domain::size`]), which cut the final box from a solved
//! density; a pilot's few thousand samples could never place a 1e−9 cut themselves.

use super::error::GridError;
use super::mesh::Domain;
use super::problem::Mechanical;
use super::BarrierSide;
use crate::dynamics::BarrierKind;

/// Trajectories of the pilot.
const PARTICLES: usize = 64;
/// Simulated time; the second half is recorded. Long enough for a lightly damped ring
/// (relaxation 1/α = 10–50) to fill from the origin.
const TIME: f64 = 150.0;
/// Most steps taken (a stiff model gets a shorter pilot, not a slower one).
const MAX_STEPS: usize = 15_000;
/// Largest step, and the step's bound from the fastest velocity rate seen: rate·dt ≤ 0.2.
const DT: f64 = 0.01;
/// A trajectory beyond this is a blow-up and is dropped.
const ESCAPE: f64 = 1e6;

/// The range the pilot's trajectories visited, widened by half its width on each side (by
/// half of it in v), fitted to the walls; [`GridError::DomainNotFound`] when every
/// trajectory escapes.
pub(crate) fn pilot_box(problem: &Mechanical) -> Result<Domain, GridError> {
    let barriers = &problem.barriers;
    // Start inside the state's side of any wall, at rest.
    let mut start = 0.0f64;
    let (mut lo_wall, mut hi_wall) = (f64::NEG_INFINITY, f64::INFINITY);
    for b in barriers {
        match b.kind {
            BarrierKind::Reflecting(BarrierSide::Above) => lo_wall = b.at,
            BarrierKind::Reflecting(BarrierSide::Below) => hi_wall = b.at,
            BarrierKind::PassThrough => {}
        }
    }
    if lo_wall.is_finite() && hi_wall.is_finite() {
        start = 0.5 * (lo_wall + hi_wall);
    } else if start <= lo_wall {
        start = lo_wall + 1e-3 * lo_wall.abs().max(1.0);
    } else if start >= hi_wall {
        start = hi_wall - 1e-3 * hi_wall.abs().max(1.0);
    }
    // SplitMix64 (the random crates are Monte Carlo's, behind its feature): a pilot needs
    // a fixed, decent stream, not a cryptographic one.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut normal = move || {
        // Box–Muller: one normal per call is plenty for a pilot.
        let u: f64 = uniform().max(f64::MIN_POSITIVE);
        let w: f64 = uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * w).cos()
    };
    let mut x = vec![start; PARTICLES];
    let mut v = vec![0.0; PARTICLES];
    let mut alive = [true; PARTICLES];
    let (mut xr, mut vr) = ([f64::INFINITY, f64::NEG_INFINITY], 0.0f64);
    let (mut t, mut steps) = (0.0, 0);
    let dv = 1e-6;
    let mut dt = DT;
    while t < TIME && steps < MAX_STEPS {
        let here = problem.eval_raw(&x, &v);
        // The step follows the fastest velocity rate, checked every 16 steps.
        if steps % 16 == 0 {
            let vp: Vec<f64> = v.iter().map(|v| v + dv).collect();
            let ahead = problem.eval_raw(&x, &vp);
            let rate = (0..PARTICLES)
                .filter(|&k| alive[k])
                .map(|k| ((ahead.m[k] - here.m[k]) / dv).abs())
                .filter(|r| r.is_finite())
                .fold(0.0f64, f64::max);
            dt = DT.min(0.2 / rate.max(1e-300));
        }
        let sq = dt.sqrt();
        for k in 0..PARTICLES {
            if !alive[k] {
                continue;
            }
            let (m, b) = (here.m[k], here.b[k].max(0.0));
            let xn = x[k] + v[k] * dt;
            let mut vn = v[k] + m * dt + (b.sqrt() * sq) * normal();
            let mut xn2 = xn;
            for bar in barriers {
                let crossed = (x[k] - bar.at) * (xn - bar.at) < 0.0;
                if crossed {
                    vn = bar.jump(vn);
                    if matches!(bar.kind, BarrierKind::Reflecting(_)) {
                        xn2 = 2.0 * bar.at - xn;
                    }
                }
            }
            if !(xn2.is_finite() && vn.is_finite()) || xn2.abs() > ESCAPE || vn.abs() > ESCAPE {
                alive[k] = false;
                continue;
            }
            x[k] = xn2.clamp(lo_wall, hi_wall);
            v[k] = vn;
            if t >= 0.5 * TIME || steps >= MAX_STEPS / 2 {
                xr = [xr[0].min(x[k]), xr[1].max(x[k])];
                vr = vr.max(v[k].abs());
            }
        }
        t += dt;
        steps += 1;
    }
    if !alive.iter().any(|a| *a) || !xr[0].is_finite() || xr[0] > xr[1] || vr <= 0.0 {
        return Err(GridError::DomainNotFound {
            tries: 0,
            edge: f64::NAN,
            width: ESCAPE,
        });
    }
    let w = (xr[1] - xr[0]).max(1e-3 * vr);
    Ok(Domain {
        x: [
            (xr[0] - 0.5 * w).max(lo_wall),
            (xr[1] + 0.5 * w).min(hi_wall),
        ],
        v: [-1.5 * vr, 1.5 * vr],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_model;

    /// The vignette's ring (amplitude about 2 in x, 2.7 in v) is inside the pilot's box, and
    /// the box is not many times wider.
    #[test]
    fn pilot_finds_the_van_der_pol_ring() {
        let bound = parse_model(
            "model m\nstate x, v\ndrift x: v\ndrift v: v*(1 - x^2) - x\n\
             noise xi: intensity 0.25\ndiffusion v: xi\n",
            None,
        )
        .unwrap()
        .bind(&[])
        .unwrap();
        let p = Mechanical::new(&crate::dynamics::Dynamics::read(&bound)).unwrap();
        let d = pilot_box(&p).unwrap();
        assert!(d.x[0] < -2.0 && d.x[1] > 2.0 && d.v[1] > 2.7, "{d:?}");
        assert!(d.x[1] < 8.0 && d.v[1] < 10.0, "{d:?}");
    }
}
