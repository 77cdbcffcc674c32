//! A model of general form (drift in both equations, noise in both, correlated), as the grid
//! solver discretises it: the Itô drift a, the diffusion b = G·S·Gᵀ and the advective
//! velocity of the flux form, compiled to one tape.
//!
//! The FPK equation ∂t p = −∂x(a₁p) − ∂y(a₂p) + ½∂x²(b₁₁p) + ∂x∂y(b₁₂p) + ½∂y²(b₂₂p) is
//! written as −∇·J with
//!
//! J₁ = u₁ p − ½ b₁₁ ∂x p − ½ b₁₂ ∂y p,  u₁ = a₁ − ½(∂x b₁₁ + ∂y b₁₂),
//! J₂ = u₂ p − ½ b₂₂ ∂y p − ½ b₁₂ ∂x p,  u₂ = a₂ − ½(∂y b₂₂ + ∂x b₁₂),
//!
//! so that the finite volumes take u as an advection (upwind-biased face values) and b as a
//! diffusion (central differences), as the mechanical form does with its velocity equation.

use super::error::{GridError, Unsupported};
use crate::dynamics::{Dynamics, NotMechanical};
use crate::model::BoundModel;
use crate::symbolic::{diff, simplify, DeltaPolicy, Expr, Tape, TapeScratch};

/// The compiled coefficients of a general-form model without barriers.
#[derive(Clone, Debug)]
pub(crate) struct General {
    /// Outputs u₁, u₂, b₁₁, b₁₂, b₂₂, a₁, a₂ over (x, y).
    coefficients: Tape,
    /// The first state's window when it is periodic.
    pub(crate) window: Option<[f64; 2]>,
}

/// The coefficients at a batch of points.
pub(crate) struct GeneralCoefficients {
    /// The advective velocity of the flux form, per axis.
    pub(crate) u: [Vec<f64>; 2],
    /// b₁₁, b₁₂, b₂₂.
    pub(crate) b: [Vec<f64>; 3],
    /// The Itô drift, per axis.
    pub(crate) a: [Vec<f64>; 2],
}

impl General {
    /// Reads the general form of `model` from its `dynamics` (whose form is not mechanical):
    /// refused with a typed reason when it has an impact law (the re-injection at a wall
    /// needs x' = v to know where the flux leaves and with which velocity) or δ terms (which
    /// only an impact law accounts for).
    pub(crate) fn new(
        model: &BoundModel,
        dynamics: &Dynamics,
        why: &NotMechanical,
    ) -> Result<Self, GridError> {
        let refuse = |reason| GridError::Unsupported {
            model: model.name().to_string(),
            reason,
        };
        if dynamics.barriers().map_or(true, |b| !b.is_empty()) {
            return Err(refuse(Unsupported::ImpactOfGeneralForm {
                form: match why {
                    NotMechanical::Rate { position, rate, .. } => {
                        format!("the drift of `{position}` is `{rate}`")
                    }
                    NotMechanical::NoiseInPosition { position, noise } => {
                        format!("noise `{noise}` enters the equation of `{position}`")
                    }
                },
            }));
        }
        let states = dynamics.states();
        let (x, y) = (states[0].to_string(), states[1].to_string());
        let sde = dynamics.sde();
        for (k, name) in [&x, &y].into_iter().enumerate() {
            let noisy_delta = sde.noise_matrix()[k].iter().any(Expr::contains_delta);
            if sde.drift()[k].contains_delta() || noisy_delta {
                return Err(refuse(Unsupported::DeltaWithoutImpact {
                    velocity: name.clone(),
                    coefficient: if noisy_delta { "diffusion" } else { "drift" },
                }));
            }
        }
        crate::dynamics::check_with_drift(model, dynamics.ito_drift().ok())?;
        let a = dynamics.ito_drift().map_err(crate::fpk::FpkError::from)?;
        let b = dynamics.diffusion();
        let d = |e: &Expr, var: &str, what: &str| {
            diff(e, var).map_err(|source| GridError::Symbolic {
                what: what.to_string(),
                source,
            })
        };
        let half = Expr::num(0.5);
        let u1 = simplify(
            &(a[0].clone()
                - half.clone()
                    * (d(&b[0][0], &x, &format!("d b_{x}{x} / d{x}"))?
                        + d(&b[0][1], &y, &format!("d b_{x}{y} / d{y}"))?)),
        );
        let u2 = simplify(
            &(a[1].clone()
                - half
                    * (d(&b[1][1], &y, &format!("d b_{y}{y} / d{y}"))?
                        + d(&b[0][1], &x, &format!("d b_{x}{y} / d{x}"))?)),
        );
        let outputs = [
            u1,
            u2,
            b[0][0].clone(),
            b[0][1].clone(),
            b[1][1].clone(),
            a[0].clone(),
            a[1].clone(),
        ];
        let coefficients = Tape::compile(&outputs, &[x.as_str(), y.as_str()], DeltaPolicy::Zero)
            .map_err(|source| GridError::Symbolic {
                what: format!("the drift and diffusion of `{x}` and `{y}`"),
                source,
            })?;
        Ok(General {
            coefficients,
            window: super::problem::periodic_window(model)?,
        })
    }

    /// The coefficients at the points (x[p], y[p]), NaN and infinite values included.
    pub(crate) fn eval_raw(&self, x: &[f64], y: &[f64]) -> GeneralCoefficients {
        let mut out = vec![vec![0.0; x.len()]; 7];
        self.coefficients
            .eval_batch(&[x, y], &mut out, &mut TapeScratch::new());
        let mut it = out.into_iter();
        let mut next = || it.next().unwrap_or_default();
        let u = [next(), next()];
        let b = [next(), next(), next()];
        let a = [next(), next()];
        GeneralCoefficients { u, b, a }
    }

    /// [`General::eval_raw`], refused where a coefficient is not finite.
    pub(crate) fn eval(&self, x: &[f64], y: &[f64]) -> Result<GeneralCoefficients, GridError> {
        let c = self.eval_raw(x, y);
        let names = [
            "the drift of the first state (flux form)",
            "the drift of the second state (flux form)",
            "b_11",
            "b_12",
            "b_22",
        ];
        let cols = [&c.u[0], &c.u[1], &c.b[0], &c.b[1], &c.b[2]];
        for (what, col) in names.iter().zip(cols) {
            if let Some(p) = col.iter().position(|c| !c.is_finite()) {
                return Err(GridError::NotFinite {
                    what,
                    x: x[p],
                    v: y[p],
                });
            }
        }
        Ok(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Form;
    use crate::model::parse_model;

    fn general(text: &str) -> Result<General, GridError> {
        let bound = parse_model(text, None).unwrap().bind(&[]).unwrap();
        let dynamics = Dynamics::read(&bound);
        let Form::General { why } = dynamics.form() else {
            panic!("not general")
        };
        General::new(&bound, &dynamics, why)
    }

    /// The flux-form velocity subtracts ½ of the divergence of the diffusion's rows: one
    /// noise with G = (1 + x, 2 + y) gives b₁₁ = (1 + x)², b₁₂ = (1 + x)(2 + y),
    /// b₂₂ = (2 + y)², so with a = (−x, −y) in Itô form u₁ = −x − 3(1 + x)/2 and
    /// u₂ = −y − 3(2 + y)/2.
    #[test]
    fn the_flux_form_velocity_takes_the_divergence_of_b() {
        let g = general(
            "model m\nstate x, y\ndrift x: -x\ndrift y: -y\nnoise xi: intensity 1\n\
             diffusion x: (1 + x)*xi\ndiffusion y: (2 + y)*xi\ninterpretation: ito\n",
        )
        .unwrap();
        let c = g.eval(&[0.7], &[-0.3]).unwrap();
        assert!((c.u[0][0] - (-0.7 - 1.5 * 1.7)).abs() < 1e-14);
        assert!((c.u[1][0] - (0.3 - 1.5 * 1.7)).abs() < 1e-14);
        assert!((c.b[1][0] - 1.7 * 1.7).abs() < 1e-14);
        assert!((c.a[0][0] + 0.7).abs() < 1e-14);
    }

    /// An impact law on a general-form model is refused, naming the form.
    #[test]
    fn an_impact_law_on_a_general_form_is_refused() {
        let err = general(
            "model m\nstate x, y\ndrift x: y - x\ndrift y: -x\nnoise xi: intensity 1\n\
             diffusion y: xi\nimpact x = 0: y -> -0.9*y\ndomain x >= 0\n",
        )
        .err()
        .unwrap();
        assert!(matches!(
            err,
            GridError::Unsupported {
                reason: Unsupported::ImpactOfGeneralForm { .. },
                ..
            }
        ));
        let text = err.to_string();
        assert!(
            text.contains("Monte Carlo") && text.contains("EPC"),
            "{text}"
        );
    }
}
