//! Where a transient starts: the `initial` line. Read with the model (parameters still
//! symbolic); [`InitialSpec::bind`] gives the numbers ([`InitialState`]). The stationary
//! methods ignore it: a stationary density does not depend on where the process started.

use crate::symbolic::Expr;

use super::{number, BoundModel};

/// The `initial` line as a [`Model`](super::Model) holds it: values are constant
/// expressions (parameters allowed), in the order of the `state` line.
///
/// ```
/// let text = "model m\nparam c = 0.1, s = 0.5\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\n\
///             initial gaussian mean v = 0, z = 1 cov s^2, 0, 0, 1\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// let bound = model.bind(&[]).unwrap();
/// let start = model.initial().unwrap().bind(&bound).unwrap();
/// assert_eq!(
///     start,
///     fpsolve::model::InitialState::Gaussian { mean: [1.0, 0.0], covariance: [[0.25, 0.0], [0.0, 1.0]] }
/// );
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum InitialSpec {
    /// `initial rest` (also what a transient assumes without an `initial` line).
    Rest,
    /// `initial point z = .., v = ..`.
    Point([Expr; 2]),
    /// `initial gaussian mean z = .., v = .. cov xx, xv, vx, vv`.
    Gaussian {
        /// The mean of each state.
        mean: [Expr; 2],
        /// The covariance, row by row.
        covariance: [[Expr; 2]; 2],
        /// The line as written (for errors found when binding).
        text: String,
    },
}

/// A start with numbers: rest, a point, or a Gaussian with a symmetric positive definite
/// covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitialState {
    /// At rest (both states 0).
    Rest,
    /// At this point (state order).
    Point([f64; 2]),
    /// A Gaussian.
    Gaussian {
        /// The mean.
        mean: [f64; 2],
        /// The covariance, symmetric positive definite.
        covariance: [[f64; 2]; 2],
    },
}

/// Why an `initial` line cannot be bound at the given parameters.
///
/// ```
/// use fpsolve::model::InitialError;
/// let e = InitialError::NotFinite { value: f64::NAN };
/// assert!(e.to_string().contains("not a finite number"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InitialError {
    /// A value is not a finite number at the bound parameters.
    #[error("the initial state has a value {value}, not a finite number")]
    NotFinite {
        /// The value.
        value: f64,
    },
    /// The covariance is not symmetric positive definite at the bound parameters.
    #[error("initial `{text}`: {reason}")]
    Covariance {
        /// The line as written.
        text: String,
        /// What is wrong.
        reason: String,
    },
}

/// Why a 2×2 covariance is not symmetric positive definite, or `None` when it is.
pub(crate) fn covariance_problem(c: [[f64; 2]; 2]) -> Option<String> {
    let [[xx, xv], [vx, vv]] = c;
    if !c.iter().flatten().all(|u| u.is_finite()) {
        return Some("the covariance has an entry that is not a finite number".into());
    }
    if (xv - vx).abs() > 1e-12 * (xv.abs() + vx.abs()) {
        return Some(format!(
            "the covariance is not symmetric ({} above the diagonal, {} below)",
            number(xv),
            number(vx)
        ));
    }
    let det = xx * vv - xv * vx;
    if !(xx > 0.0 && vv > 0.0 && det > 0.0) {
        return Some(format!(
            "the covariance is not positive definite (variances {} and {}, determinant {})",
            number(xx),
            number(vv),
            number(det)
        ));
    }
    None
}

impl super::Model {
    /// The model's `initial` line, if any: where a transient starts (rest without one). The
    /// stationary methods ignore it.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// assert!(fpsolve::model::load_model(&path).unwrap().initial().is_none());
    /// ```
    pub fn initial(&self) -> Option<&InitialSpec> {
        self.initial.as_ref()
    }
}

impl InitialSpec {
    /// The start at the parameter values of `model`.
    ///
    /// # Errors
    /// [`InitialError::NotFinite`], [`InitialError::Covariance`].
    pub fn bind(&self, model: &BoundModel) -> Result<InitialState, InitialError> {
        let value = |e: &Expr| {
            let v = e.eval(&|s| model.param(s)).unwrap_or(f64::NAN);
            if v.is_finite() {
                Ok(v)
            } else {
                Err(InitialError::NotFinite { value: v })
            }
        };
        Ok(match self {
            InitialSpec::Rest => InitialState::Rest,
            InitialSpec::Point([x, v]) => InitialState::Point([value(x)?, value(v)?]),
            InitialSpec::Gaussian {
                mean,
                covariance,
                text,
            } => {
                let c = [
                    [value(&covariance[0][0])?, value(&covariance[0][1])?],
                    [value(&covariance[1][0])?, value(&covariance[1][1])?],
                ];
                if let Some(reason) = covariance_problem(c) {
                    return Err(InitialError::Covariance {
                        text: text.clone(),
                        reason,
                    });
                }
                InitialState::Gaussian {
                    mean: [value(&mean[0])?, value(&mean[1])?],
                    covariance: c,
                }
            }
        })
    }
}
