//! The safe set of a first-passage problem: `safe abs(z) < 2.5`, `safe energy < 3`,
//! `safe -2 < z < 3`. A quantity q(states) (observables already substituted, parameters
//! still symbolic in a [`Model`]) with a lower bound, an upper bound or both; the first
//! passage is the first time q leaves the open interval they bound. [`SafeSet::bind`] gives
//! the numbers and a compiled quantity ([`BoundSafe`]).

use crate::symbolic::{DeltaPolicy, Expr, Interval, Tape};

use super::{number, BoundModel, DomainBound};

/// The safe set as a [`Model`](super::Model) holds it (from its `safe` line or from
/// [`Model::with_safe`](super::Model::with_safe)).
///
/// ```
/// let text = "model m\nparam c = 0.1, u = 2.5\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nsafe abs(z) < u\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// let safe = model.safe().unwrap();
/// assert_eq!(safe.quantity.to_string(), "abs(z)");
/// assert!(safe.lower.is_none());
/// assert_eq!(safe.text, "abs(z) < u");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SafeSet {
    /// The quantity bounded, a function of the states (observables substituted).
    pub quantity: Expr,
    /// Its lower bound (parameters only), if any.
    pub lower: Option<DomainBound>,
    /// Its upper bound (parameters only), if any.
    pub upper: Option<DomainBound>,
    /// The set as written (for reports).
    pub text: String,
}

/// Why a safe set cannot be bound.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SafeError {
    /// A bound is not a finite number at the bound parameters.
    #[error("safe set `{text}`: its {which} bound is {value}, not a finite number")]
    NotFinite {
        /// The set as written.
        text: String,
        /// `lower` or `upper`.
        which: &'static str,
        /// The value.
        value: f64,
    },
    /// Both bounds given, the lower not below the upper: the set is empty.
    #[error(
        "safe set `{text}` is empty: its lower bound {lower} is not below its upper bound {upper}"
    )]
    Empty {
        /// The set as written.
        text: String,
        /// The lower bound.
        lower: String,
        /// The upper bound.
        upper: String,
    },
    /// The quantity could not be compiled over the states (a bug: validation admits only
    /// states, observables and parameters).
    #[error("safe set `{text}`: {detail}")]
    Compile {
        /// The set as written.
        text: String,
        /// The compiler's reason.
        detail: String,
    },
}

impl SafeSet {
    /// The set at the parameter values of `model` (the model this set was read with).
    ///
    /// ```
    /// let text = "model m\nparam c = 0.1, u = 2.5\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
    ///             noise xi: intensity 1\ndiffusion v: xi\nsafe -u < z < 2*u\n";
    /// let model = fpsolve::model::parse_model(text, None).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// assert_eq!((safe.lower, safe.upper), (Some(-2.5), Some(5.0)));
    /// assert!(safe.contains([4.9, 100.0]));
    /// assert!(!safe.contains([-2.5, 0.0]));
    /// ```
    ///
    /// # Errors
    /// [`SafeError::NotFinite`], [`SafeError::Empty`], [`SafeError::Compile`].
    pub fn bind(&self, model: &BoundModel) -> Result<BoundSafe, SafeError> {
        let value = |e: &Expr| e.eval(&|s| model.param(s)).unwrap_or(f64::NAN);
        let limit = |b: &Option<DomainBound>, which| match b {
            None => Ok(None),
            Some(b) => {
                let v = value(&b.at);
                if v.is_finite() {
                    Ok(Some(v))
                } else {
                    Err(SafeError::NotFinite {
                        text: self.text.clone(),
                        which,
                        value: v,
                    })
                }
            }
        };
        let lower = limit(&self.lower, "lower")?;
        let upper = limit(&self.upper, "upper")?;
        if let (Some(a), Some(b)) = (lower, upper) {
            if a >= b {
                return Err(SafeError::Empty {
                    text: self.text.clone(),
                    lower: number(a),
                    upper: number(b),
                });
            }
        }
        let quantity = self
            .quantity
            .map_symbols(&|s| model.param(s).map(Expr::num));
        let states = model.states();
        let tape = Tape::compile(
            std::slice::from_ref(&quantity),
            &[&states[0], &states[1]],
            DeltaPolicy::Reject,
        )
        .map_err(|e| SafeError::Compile {
            text: self.text.clone(),
            detail: e.to_string(),
        })?;
        Ok(BoundSafe {
            quantity,
            tape,
            lower,
            upper,
            text: self.text.clone(),
        })
    }
}

/// A safe set with numbers: the open interval (`lower`, `upper`) of the quantity. A point
/// where the quantity is not a number (outside where it is defined) is outside the set.
#[derive(Clone, Debug)]
pub struct BoundSafe {
    /// The quantity, parameters substituted.
    pub quantity: Expr,
    tape: Tape,
    /// The lower bound, if any.
    pub lower: Option<f64>,
    /// The upper bound, if any.
    pub upper: Option<f64>,
    /// The set as written.
    pub text: String,
}

impl BoundSafe {
    /// The quantity at the state `x`.
    ///
    /// ```
    /// # let text = "model m\nstate z, v\ndrift z: v\ndrift v: -z\nnoise xi: intensity 1\n\
    /// #             diffusion v: xi\nsafe z^2 + v^2 < 4\n";
    /// # let model = fpsolve::model::parse_model(text, None).unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// assert_eq!(safe.quantity_at([1.0, 1.0]), 2.0);
    /// ```
    pub fn quantity_at(&self, x: [f64; 2]) -> f64 {
        self.quantity_with(x, &mut Vec::new())
    }

    /// [`BoundSafe::quantity_at`] with working memory `scratch` reused between calls (the
    /// same number, without allocating).
    pub(crate) fn quantity_with(&self, x: [f64; 2], scratch: &mut Vec<f64>) -> f64 {
        let mut out = [0.0];
        self.tape.eval(&x, scratch, &mut out);
        out[0]
    }

    /// Whether every state of the box `x` × `v` is surely inside: its quantity, as
    /// [`BoundSafe::quantity_at`] computes it, a number strictly between the bounds
    /// (`false` also when the quantity's enclosure over the box is not cheap, see
    /// [`Tape::enclose`]). `scratch` is reused between calls.
    pub(crate) fn surely_inside(
        &self,
        x: Interval,
        v: Interval,
        scratch: &mut Vec<Interval>,
    ) -> bool {
        let mut q = [Interval { lo: 0.0, hi: 0.0 }];
        self.tape.enclose(&[x, v], scratch, &mut q)
            && self.lower.is_none_or(|a| q[0].lo > a)
            && self.upper.is_none_or(|b| q[0].hi < b)
    }

    /// Whether the state `x` is strictly inside the set (the boundary belongs to the
    /// outside: a path that reaches it has left).
    ///
    /// ```
    /// # let text = "model m\nstate z, v\ndrift z: v\ndrift v: -z\nnoise xi: intensity 1\n\
    /// #             diffusion v: xi\nsafe z > -1\n";
    /// # let model = fpsolve::model::parse_model(text, None).unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// assert!(safe.contains([0.0, 0.0]) && !safe.contains([-1.0, 0.0]));
    /// ```
    pub fn contains(&self, x: [f64; 2]) -> bool {
        self.inside(self.quantity_at(x))
    }

    /// Whether a value of the quantity is inside the bounds (NaN is not).
    ///
    /// ```
    /// # let text = "model m\nstate z, v\ndrift z: v\ndrift v: -z\nnoise xi: intensity 1\n\
    /// #             diffusion v: xi\nsafe z < 1\n";
    /// # let model = fpsolve::model::parse_model(text, None).unwrap();
    /// # let bound = model.bind(&[]).unwrap();
    /// let safe = model.safe().unwrap().bind(&bound).unwrap();
    /// assert!(safe.inside(0.5) && !safe.inside(f64::NAN));
    /// ```
    pub fn inside(&self, q: f64) -> bool {
        !q.is_nan() && self.lower.is_none_or(|a| q > a) && self.upper.is_none_or(|b| q < b)
    }
}
