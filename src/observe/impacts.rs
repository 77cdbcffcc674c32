//! Impact statistics at a wall from a stationary density in the model's own coordinates (the
//! grid's, EPC with the exact impact condition's): the rate of impacts, the flux-weighted PDF
//! of the impact speed, the mean impact speed and the mean power the impacts dissipate.
//!
//! At a wall x = x_b with the state above it (x ≥ x_b) the oscillator arrives with v < 0 (below
//! it, with v > 0); the probability flux into the wall at speed w = |v| is w·p(x_b, v), with p
//! the density's one-sided limit at the wall. Hence, with A the approaching half of the line:
//! - the impact rate λ = ∫_A |v| p(x_b, v) dv (impacts per unit time);
//! - the PDF of the impact speed, the flux-weighted q(w) = w·p(x_b, ∓w)/λ;
//! - the mean impact speed E_q[w] = ∫_A v² p dv / λ;
//! - the mean power dissipated per unit mass: each impact v → φ(v) takes the kinetic energy
//!   (v² − φ(v)²)/2 per unit mass, so P = ∫_A |v|·(v² − φ(x_b, v)²)/2·p dv, which for
//!   Newton's law φ = −r·v is (1 − r²)/2·E_q[w²]·λ. The law is evaluated as written, so a
//!   velocity-dependent restitution is taken exactly.
//!
//! The statistics are those of the model as written: a pass-through law (the Zhuravlev form's
//! `v -> r*v`, whose z is not the user's position) is refused with
//! [`CrossingError::PassThrough`].

use serde::Serialize;

use super::lines::{half_line_moments, rule_tolerance};
use super::quadrature::integrate_panels_batch;
use super::CrossingError;
use crate::density::JointDensity;
use crate::model::{BarrierSide, BoundImpact, BoundModel};
use crate::symbolic::DeltaPolicy;

/// Impact statistics at one wall, per unit mass of the oscillator, in the model's own
/// coordinates.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImpactStatistics {
    /// The state that meets the wall.
    pub state: String,
    /// The wall's position.
    pub at: f64,
    /// The side of the wall the state lives on.
    pub side: BarrierSide,
    /// The impact law as written (the post-impact velocity).
    pub law: String,
    /// Impacts per unit time.
    pub rate: f64,
    /// The mean impact speed |v| before the impact, weighted by the flux.
    pub mean_speed: f64,
    /// The mean power the impacts take from the oscillator (energy per unit mass per unit
    /// time).
    pub mean_power: f64,
    /// The speeds at which [`ImpactStatistics::speed_pdf`] is given.
    pub speeds: Vec<f64>,
    /// The flux-weighted PDF of the impact speed, w·p(x_b, ∓w)/rate.
    pub speed_pdf: Vec<f64>,
    /// The relative accuracy of the integrals: the density's stated accuracy, or the line
    /// quadrature's tolerance where that is larger (not a method's discretisation error).
    pub accuracy: f64,
}

/// The impact statistics at `impact`'s wall from `density`, the speed PDF at `speeds`.
///
/// # Errors
/// [`CrossingError::PassThrough`] for a law without a wall side;
/// [`CrossingError::Speed`] for a negative or non-finite speed (before any work);
/// [`CrossingError::NotFinite`] where the law has no value; [`CrossingError::NoFlux`] when no
/// mass reaches the wall.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::impact_statistics;
/// use std::f64::consts::PI;
/// /// Unit normal velocity, uniform position on [0, 1]: the wall at 0 sees p(0, v) = φ(v).
/// struct Box01;
/// impl JointDensity for Box01 {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         if (0.0..=1.0).contains(&x[0]) { (-x[1] * x[1] / 2.0).exp() / (2.0 * PI).sqrt() } else { 0.0 }
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[0.0, 1.0], [-10.0, 10.0]]
///     }
/// }
/// let text = "model m\nstate x, v\ndrift x: v\ndrift v: -v - x\nnoise xi: intensity 1\n\
///             diffusion v: xi\nimpact x = 0: v -> -0.5*v\ndomain x >= 0\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let s = impact_statistics(&Box01, &bound, &bound.impacts()[0], &[1.0])?;
/// // λ = ∫_{v<0} |v| φ(v) dv = 1/√(2π); E_q[w] = ∫ v² φ / λ = √(π/2).
/// assert!((s.rate - 1.0 / (2.0 * PI).sqrt()).abs() < 1e-9);
/// assert!((s.mean_speed - (PI / 2.0).sqrt()).abs() < 1e-9);
/// // P = (1 − r²)/2·∫_{v<0} |v|³φ dv = 0.375·2/√(2π).
/// assert!((s.mean_power - 0.375 * 2.0 / (2.0 * PI).sqrt()).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn impact_statistics(
    density: &dyn JointDensity,
    model: &BoundModel,
    impact: &BoundImpact,
    speeds: &[f64],
) -> Result<ImpactStatistics, CrossingError> {
    let states = model.states();
    let name = states[impact.state].to_string();
    let Some(side) = impact.side else {
        return Err(CrossingError::PassThrough {
            state: name,
            at: impact.at,
        });
    };
    if let Some(&speed) = speeds.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
        return Err(CrossingError::Speed { speed });
    }
    let (axis, at) = (impact.state, impact.at);
    let tolerance = rule_tolerance(density);
    let [lo, hi] = density.extent()[1 - axis];
    let halves = [[lo.min(0.0), 0.0], [0.0, hi.max(0.0)]];
    let moments = half_line_moments::<3>(density, axis, at, halves, tolerance);
    // Above the wall the state arrives with v < 0: the lower half, |v| = −v.
    let (approach, sign) = match side {
        BarrierSide::Above => (0, -1.0),
        BarrierSide::Below => (1, 1.0),
    };
    let rate = sign * moments[approach][1];
    let second = moments[approach][2];
    if rate.is_nan() || rate <= 0.0 {
        return Err(CrossingError::NoFlux { state: name, at });
    }
    let point = |v: f64| {
        let mut x = [0.0; 2];
        x[axis] = at;
        x[impact.other] = v;
        x
    };
    let law = |v: f64| -> Result<f64, CrossingError> {
        let x = point(v);
        let not_finite = |why: String| CrossingError::NotFinite {
            expr: impact.map.to_string(),
            x1: x[0],
            x2: x[1],
            why,
        };
        let after = impact
            .map
            .eval_states(states, x, DeltaPolicy::Reject)
            .map_err(|e| not_finite(e.to_string()))?;
        if after.is_finite() {
            Ok(after)
        } else {
            Err(not_finite("not finite".into()))
        }
    };
    // Probe the law before integrating (the quadrature cannot carry its error out).
    let [a, b] = halves[approach];
    for k in 0..=16 {
        law(a + (b - a) * k as f64 / 16.0)?;
    }
    let integrand = |t: &[f64], out: &mut [f64]| {
        for (o, &v) in out.iter_mut().zip(t) {
            let after = law(v).unwrap_or(f64::NAN);
            *o = v.abs() * 0.5 * (v * v - after * after) * density.pdf(point(v));
        }
    };
    let mean_power = integrate_panels_batch(&integrand, &[a, b], tolerance);
    if !mean_power.is_finite() {
        return Err(CrossingError::NotFinite {
            expr: impact.map.to_string(),
            x1: at,
            x2: 0.5 * (a + b),
            why: "the dissipated power's integral did not converge".into(),
        });
    }
    let speed_pdf = speeds
        .iter()
        .map(|&w| w * density.pdf(point(sign * w)) / rate)
        .collect();
    Ok(ImpactStatistics {
        state: name,
        at,
        side,
        law: impact.map.to_string(),
        rate,
        mean_speed: second / rate,
        mean_power,
        speeds: speeds.to_vec(),
        speed_pdf,
        accuracy: density.stated_accuracy().max(tolerance),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_model;
    use std::f64::consts::PI;

    /// Unit normal velocity, position uniform on [−1, 1]: p(±1, v) = φ(v)/2 at either wall.
    struct Strip;

    impl JointDensity for Strip {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            if (-1.0..=1.0).contains(&x[0]) {
                0.5 * (-x[1] * x[1] / 2.0).exp() / (2.0 * PI).sqrt()
            } else {
                0.0
            }
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            [[-1.0, 1.0], [-12.0, 12.0]]
        }
    }

    fn model(impact: &str, domain: &str) -> BoundModel {
        let text = format!(
            "model m\nstate x, v\ndrift x: v\ndrift v: -v - x\nnoise xi: intensity 1\n\
             diffusion v: xi\n{impact}\n{domain}\n"
        );
        parse_model(&text, None).unwrap().bind(&[]).unwrap()
    }

    /// An upper wall is approached with v > 0; a speed-dependent restitution
    /// r(w) = 0.9/(1 + w) dissipates ∫_{v>0} v·(1 − r(v)²)·v²/2·p(1, v) dv (Simpson here).
    #[test]
    fn upper_wall_with_a_speed_dependent_law() {
        let b = model("impact x = 1: v -> -0.9*v/(1 + abs(v))", "domain x <= 1");
        let s = impact_statistics(&Strip, &b, &b.impacts()[0], &[0.5, 2.0]).unwrap();
        let phi = |v: f64| (-v * v / 2.0).exp() / (2.0 * PI).sqrt();
        let rate = 0.5 / (2.0 * PI).sqrt();
        assert!((s.rate - rate).abs() < 1e-10 * rate, "{}", s.rate);
        let f = |v: f64| {
            let r = 0.9 / (1.0 + v);
            v * (1.0 - r * r) * v * v / 2.0 * 0.5 * phi(v)
        };
        let power = crate::observe::quadrature::simpson(f, 0.0, 12.0, 20000);
        assert!(
            (s.mean_power - power).abs() < 1e-9 * power,
            "{} vs {power}",
            s.mean_power
        );
        // q(w) = w·p(1, w)/λ = w·φ(w)·√(2π) = w·exp(−w²/2).
        for (w, q) in s.speeds.iter().zip(&s.speed_pdf) {
            let exact = w * (-w * w / 2.0).exp();
            assert!((q - exact).abs() < 1e-10 * exact, "w={w}: {q}");
        }
    }

    #[test]
    fn pass_through_laws_and_bad_speeds_are_refused() {
        let b = model("impact x = 0: v -> 0.9*v", "");
        assert!(matches!(
            impact_statistics(&Strip, &b, &b.impacts()[0], &[]),
            Err(CrossingError::PassThrough { .. })
        ));
        let b = model("impact x = -1: v -> -v", "domain x >= -1");
        assert!(matches!(
            impact_statistics(&Strip, &b, &b.impacts()[0], &[-1.0]),
            Err(CrossingError::Speed { .. })
        ));
        // Elastic: no power, rate from the lower half.
        let s = impact_statistics(&Strip, &b, &b.impacts()[0], &[]).unwrap();
        assert_eq!(s.mean_power, 0.0);
        assert!((s.rate - 0.5 / (2.0 * PI).sqrt()).abs() < 1e-10);
    }
}
