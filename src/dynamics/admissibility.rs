//! [`check`]: the admissibility checks in order (noise, impacts, damping, rest points, linear
//! stability, a restoring force far out), each refusal an [`Inadmissible`].

use super::impact::{impact_terms, jump_ratio, jump_text, weight_at};
use super::probe::{
    at, diffusion, jacobian, max_abs, max_real_part, mechanical, probe_points, JUMP_PROBES,
    PROBE_MAGNITUDES,
};
use super::rest::vanishing_diffusion_at_rest;
use super::Inadmissible;
use crate::model::{number, BoundModel};
use crate::symbolic::Expr;

/// Checks that `model` can have a stationary density, in the order: noise, impacts, damping,
/// rest points, linear stability. See [`Inadmissible`] for each reason.
///
/// ```
/// use fpsolve::model::{parse_model, Override};
/// use fpsolve::dynamics::{check, Inadmissible};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// assert!(check(&model.bind(&[]).unwrap()).is_ok());
/// let r = model.bind(&[Override::number("r", 1.001)]).unwrap();
/// let err = check(&r).unwrap_err();
/// assert!(matches!(err, Inadmissible::EnergyAddingImpact { .. }));
/// assert!(err.to_string().contains("`v -> 1.001*v` adds energy at every impact"));
/// ```
pub fn check(model: &BoundModel) -> Result<(), Inadmissible> {
    let m = super::ito::ito_drift(model).ok().map(|(_, m)| m);
    check_with_drift(model, m.as_ref())
}

/// [`check`] with the model's Itô drift already derived (`None` when it cannot be: the
/// checks that need it are then skipped, as the derivation's own error will say why).
pub(crate) fn check_with_drift(
    model: &BoundModel,
    ito_drift: Option<&[Expr; 2]>,
) -> Result<(), Inadmissible> {
    if let Some(line) = time_dependent_line(model) {
        return Err(Inadmissible::TimeDependent { line });
    }
    let states = model.states();
    let points = probe_points();

    // No noise at all.
    let noisy = points.iter().any(|x| {
        let b = diffusion(model, *x);
        max_abs(&b) > 0.0 && b.iter().all(|v| v.is_finite())
    });
    if !noisy {
        return Err(Inadmissible::NoNoise);
    }

    // An impact map that increases |v|.
    let mut impact_dissipates = false;
    for law in model.impacts() {
        let (ratio, least) = jump_ratio(law, states);
        let restitution = ratio.map_or(least, f64::abs);
        if restitution > 1.0 + 1e-12 {
            return Err(Inadmissible::EnergyAddingImpact {
                law: jump_text(model, law),
                restitution,
            });
        }
        impact_dissipates |= match ratio {
            Some(r) => r.abs() < 1.0 - 1e-12,
            None => least < 1.0,
        };
    }

    let Some(m) = ito_drift else {
        return Ok(());
    };
    let mech = mechanical(model, m);

    // Impact terms in the drift: energy change w(v)·sgn(v) at each crossing.
    if let Some((p, q)) = mech {
        if let Some(lines) = impact_terms(model, p, q, None) {
            for (line_at, w) in &lines {
                let change: Vec<f64> = PROBE_MAGNITUDES[..JUMP_PROBES]
                    .iter()
                    .flat_map(|&s| [s, -s])
                    .map(|v| weight_at(w, model, p, *line_at, v) * v.signum())
                    .collect();
                let scale = |v: f64| 1e-12 * v * v;
                if change.iter().all(|c| *c > 0.0) {
                    let w1 = weight_at(w, model, p, *line_at, 1.0);
                    let delta = if *line_at == 0.0 {
                        format!("delta({})", states[p])
                    } else {
                        format!("delta({} - {})", states[p], number(*line_at))
                    };
                    return Err(Inadmissible::EnergyAddingImpactTerm {
                        term: format!("{:#}*{delta}", w),
                        velocity: states[q].to_string(),
                        restitution: 1.0 + w1,
                    });
                }
                if PROBE_MAGNITUDES[..JUMP_PROBES]
                    .iter()
                    .zip(change.chunks(2))
                    .any(|(s, c)| c.iter().any(|c| *c < -scale(*s)))
                {
                    impact_dissipates = true;
                }
            }
        }
    }

    // Energy balance of the mechanical form: with H = v²/2 + U(x), the drift changes H at
    // the rate v·d(x, v), d = m_v(x, v) − m_v(x, 0); the noise only adds energy (½ b_vv ≥ 0).
    // If v·d ≥ 0 everywhere and no impact loses energy, E[H] can only grow.
    if let Some((_, q)) = mech {
        if !impact_dissipates {
            let mut dissipates = false;
            let mut energises = false;
            let mut finite = 0;
            for x in &points {
                let mut rest = *x;
                rest[q] = 0.0;
                let full = at(&m[q], states, *x);
                let zero = at(&m[q], states, rest);
                let power = x[q] * (full - zero);
                if !power.is_finite() {
                    continue;
                }
                finite += 1;
                let tol = 1e-9 * x[q].abs() * (full.abs() + zero.abs()) + 1e-300;
                dissipates |= power < -tol;
                energises |= power > tol;
            }
            // Decide only on a drift defined over most of the plane.
            if !dissipates && 2 * finite > points.len() {
                let velocity = states[q].to_string();
                if energises {
                    let jac = jacobian(m, states, [0.0, 0.0]);
                    return Err(Inadmissible::NegativeDamping {
                        velocity,
                        linear_damping: -jac[(q, q)],
                    });
                }
                return Err(Inadmissible::NoDamping { velocity });
            }
        }
    }

    // Noise that vanishes at a rest point which is stable in mean square.
    vanishing_diffusion_at_rest(model, m)?;

    // A linear drift with additive noise and a mode that does not decay.
    if model.impacts().is_empty() && !model.drift().iter().any(Expr::contains_delta) {
        let origin = [0.0, 0.0];
        let m0 = [at(&m[0], states, origin), at(&m[1], states, origin)];
        let jac = jacobian(m, states, origin);
        let b0 = diffusion(model, origin);
        let linear = points.iter().all(|x| {
            (0..2).all(|i| {
                let predicted = m0[i] + jac[(i, 0)] * x[0] + jac[(i, 1)] * x[1];
                let actual = at(&m[i], states, *x);
                (actual - predicted).abs() <= 1e-7 * (1.0 + actual.abs() + predicted.abs())
            })
        });
        let additive = points.iter().all(|x| {
            let b = diffusion(model, *x);
            (0..2).all(|i| {
                (0..2).all(|j| (b[(i, j)] - b0[(i, j)]).abs() <= 1e-12 * (1.0 + b0[(i, j)].abs()))
            })
        });
        if linear && additive {
            let re = max_real_part(&jac);
            let scale = jac.iter().fold(0.0, |a: f64, v| a.max(v.abs()));
            if re.is_finite() && re >= -1e-9 * scale {
                return Err(Inadmissible::UnstableLinearDrift { real_part: re });
            }
        }
    }

    // A position that escapes to infinity on a side no wall closes.
    if let Some((p, q)) = mech {
        restoring_force(model, m, p, q)?;
    }
    Ok(())
}

/// The force at rest, f(x) = m_v(x, 0), far out on each side of the position that no wall
/// closes: pointing outwards at every one of the farthest probe positions (10² to 10⁴) is a
/// softening spring ([`Inadmissible::Escapes`]); zero at every probe position of that side
/// is no spring at all ([`Inadmissible::NoRestoringForce`]). A restoring force however weak
/// passes (its density is wide, not absent).
fn restoring_force(
    model: &BoundModel,
    m: &[Expr; 2],
    p: usize,
    q: usize,
) -> Result<(), Inadmissible> {
    use crate::model::BarrierSide;
    let states = model.states();
    let walls = model.impacts().iter().filter(|law| law.state == p);
    let (mut lower_open, mut upper_open) = (true, true);
    for law in walls {
        match law.side {
            Some(BarrierSide::Above) => lower_open = false,
            Some(BarrierSide::Below) => upper_open = false,
            None => {}
        }
    }
    let force = |x: f64| {
        let mut point = [0.0; 2];
        point[p] = x;
        at(&m[q], states, point)
    };
    for (dir, open, side) in [(1.0, upper_open, "upper"), (-1.0, lower_open, "lower")] {
        if !open {
            continue;
        }
        let far: Vec<(f64, f64)> = PROBE_MAGNITUDES[PROBE_MAGNITUDES.len() - 3..]
            .iter()
            .map(|&s| (dir * s, force(dir * s)))
            .collect();
        if far.iter().all(|(_, f)| f.is_finite() && f * dir > 0.0) {
            let (at, force) = far[0];
            return Err(Inadmissible::Escapes {
                position: states[p].to_string(),
                side,
                at,
                force,
            });
        }
        if PROBE_MAGNITUDES.iter().all(|&s| force(dir * s) == 0.0) {
            return Err(Inadmissible::NoRestoringForce {
                position: states[p].to_string(),
                velocity: states[q].to_string(),
                side,
            });
        }
    }
    Ok(())
}

/// The first drift or diffusion line of `model` that mentions the time, named.
fn time_dependent_line(model: &BoundModel) -> Option<String> {
    if !model.time_dependent() {
        return None;
    }
    let time = |e: &Expr| e.symbols().iter().any(|s| &**s == crate::model::TIME);
    let states = model.states();
    (0..2)
        .find_map(|i| time(&model.drift()[i]).then(|| format!("drift of `{}`", states[i])))
        .or_else(|| {
            (0..2).find_map(|i| {
                model.noise_matrix()[i]
                    .iter()
                    .any(time)
                    .then(|| format!("diffusion of `{}`", states[i]))
            })
        })
}
