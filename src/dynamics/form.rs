//! The mechanical form x' = v, noise only in v's equation: whether a bound model has it, and
//! if not, why (one typed reason every method that needs the form refuses with).

use crate::model::BoundModel;
use crate::symbolic::{simplify, Expr};

/// Whether the model is a mechanical oscillator x' = v, v' = m(x, v) + noise.
#[derive(Clone, Debug, PartialEq)]
pub enum Form {
    /// The first state is the position, the second its velocity.
    Mechanical,
    /// Any other 2-D system.
    General {
        /// The first check that fails.
        why: NotMechanical,
    },
}

/// Why a model does not have the mechanical form.
///
/// ```
/// let text = "model m\nstate x, y\ndrift x: -x + y\ndrift y: -y\n\
///             noise xi: intensity 1\ndiffusion y: xi\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
/// use fpsolve::dynamics::{Form, NotMechanical};
/// assert!(matches!(dynamics.form(), Form::General { why: NotMechanical::Rate { .. } }));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum NotMechanical {
    /// The rate of the first state (its drift, δ terms left out) is not the second state.
    Rate {
        /// The first state.
        position: String,
        /// The second state.
        velocity: String,
        /// The rate, printed.
        rate: String,
    },
    /// A noise source with a non-zero intensity of its own drives the first state.
    NoiseInPosition {
        /// The first state.
        position: String,
        /// The noise source.
        noise: String,
    },
}

/// The form of `model`: the rate first, then the noise of the position.
pub(crate) fn read(model: &BoundModel) -> Form {
    let states = model.states();
    let (x, v) = (states[0].to_string(), states[1].to_string());
    let rate = simplify(&model.drift()[0].without_deltas());
    if rate != Expr::sym(&v) {
        return Form::General {
            why: NotMechanical::Rate {
                position: x,
                velocity: v,
                rate: format!("{rate:#}"),
            },
        };
    }
    let s = model.intensity();
    let g = model.noise_matrix();
    for (k, name) in model.noise_names().iter().enumerate() {
        if g[0][k].as_num() != Some(0.0) && s[k][k] != 0.0 {
            return Form::General {
                why: NotMechanical::NoiseInPosition {
                    position: x,
                    noise: name.to_string(),
                },
            };
        }
    }
    Form::Mechanical
}
