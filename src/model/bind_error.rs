//! [`BindError`]: why a model could not be bound to parameter values.

use super::{number, Diagnostic};

/// Why a model could not be bound to parameter values.
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// let err = model.bind(&[fpsolve::model::Override::number("nope", 1.0)]).unwrap_err();
/// assert!(matches!(err, fpsolve::model::BindError::UnknownParameter { .. }));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BindError {
    /// `--set` named a parameter the model does not declare.
    #[error("unknown parameter `{name}` (the model declares: {known})")]
    UnknownParameter {
        /// The name given.
        name: String,
        /// The declared parameters, comma-separated.
        known: String,
    },
    /// The same parameter was overridden twice.
    #[error("parameter `{name}` is set more than once")]
    DuplicateOverride {
        /// The parameter.
        name: String,
    },
    /// Parameters are defined through each other.
    #[error("parameter `{name}` is defined through itself: {chain}")]
    Cycle {
        /// The parameter where the cycle was found.
        name: String,
        /// The cycle, `a -> b -> a`.
        chain: String,
    },
    /// A parameter's value mentions something that is not a parameter.
    #[error("the value of `{name}` mentions `{symbol}`, which is not a parameter")]
    NotAParameter {
        /// The parameter being evaluated.
        name: String,
        /// The stray symbol.
        symbol: String,
    },
    /// A parameter evaluated to NaN or ±∞.
    #[error("parameter `{name}` evaluates to {}", number(*value))]
    NotFinite {
        /// The parameter.
        name: String,
        /// Its value.
        value: f64,
    },
    /// A noise intensity is negative (or not finite).
    #[error("noise `{noise}` has intensity {}; an intensity must be ≥ 0", number(*value))]
    NegativeIntensity {
        /// The noise source.
        noise: String,
        /// The value found.
        value: f64,
    },
    /// A correlation coefficient outside [−1, 1].
    #[error("correlation of `{a}` and `{b}` is {}; it must lie in [-1, 1]", number(*value))]
    BadCorrelation {
        /// First source.
        a: String,
        /// Second source.
        b: String,
        /// The value found.
        value: f64,
    },
    /// A period that is not a positive finite number.
    #[error("the period of `{state}` evaluates to {}; it must be a positive number", number(*value))]
    BadPeriod {
        /// The periodic state.
        state: String,
        /// The value found.
        value: f64,
    },
    /// A coefficient that does not repeat with the period of a periodic state.
    #[error(
        "{what} does not repeat with the period {period:.6} of `{state}`: its values at \
         {state} = {:.4} and at {state} = {:.4} + {period:.6} differ (the other state at \
         {:.4}); a periodic state needs coefficients periodic in it",
        at[0],
        at[0],
        at[1]
    )]
    NotPeriodic {
        /// The coefficient (`the drift of `w``, `the diffusion of `w``).
        what: String,
        /// The periodic state.
        state: String,
        /// The period.
        period: f64,
        /// The probe: the periodic state's value, then the other state's.
        at: [f64; 2],
    },
    /// A barrier position that is not a finite number.
    #[error("the impact barrier evaluates to {}", number(*value))]
    BadBarrier {
        /// The value found.
        value: f64,
    },
    /// A reflecting law (`v -> -r*v`) on one barrier without a `domain` line saying which
    /// side of it the state lives on.
    #[error(
        "the impact at `{state} = {}` reverses the velocity, so `{state}` stays on one side of \
         the barrier: say which with a `domain` line, e.g. `{suggestion}`",
        number(*at)
    )]
    ReflectingWithoutDomain {
        /// The barrier state.
        state: String,
        /// The barrier's position.
        at: f64,
        /// The `domain` line suggested (the side holding the origin).
        suggestion: String,
    },
    /// A `domain` line with a law that does not reverse the velocity (`v -> r*v`, the
    /// Zhuravlev form, lets the state pass through the barrier).
    #[error(
        "the `domain` line confines `{state}`, but the impact at `{state} = {}` does not \
         reverse the velocity (`{jump}`): the state passes through it; remove the `domain` \
         line, or write a reflecting law `v -> -r*v`",
        number(*at)
    )]
    DomainWithoutReflection {
        /// The barrier state.
        state: String,
        /// The barrier's position.
        at: f64,
        /// The jump, printed.
        jump: String,
    },
    /// A `domain` line with a law that stops the velocity (`v -> 0*v`): a plastic wall, which
    /// no method solves (EPC and epc-impact need a restitution r > 0, the grid and Monte
    /// Carlo's walls a law that reverses the velocity).
    #[error(
        "the impact at `{state} = {}` stops the velocity (`{jump}`): a plastic impact (r = 0), \
         which holds `{state}` at the barrier rather than letting it pass through; no method \
         solves a plastic wall (EPC and epc-impact need a restitution 0 < r <= 1, the grid \
         and Monte Carlo's walls a law that reverses the velocity): for a nearly plastic wall \
         write `v -> -r*v` with a small r > 0, e.g. `v -> -0.05*v`, which every method solves",
        number(*at)
    )]
    PlasticWall {
        /// The barrier state.
        state: String,
        /// The barrier's position.
        at: f64,
        /// The jump, printed.
        jump: String,
    },
    /// A bound of the `domain` line where no impact law is.
    #[error(
        "the domain bound `{state} = {}` has no impact law at it: a bound of the domain is \
         where an `impact` line puts a barrier",
        number(*bound)
    )]
    DomainBoundWithoutImpact {
        /// The confined state.
        state: String,
        /// The bound's value.
        bound: f64,
    },
    /// Two impact laws, one of which does not reverse the velocity.
    #[error(
        "two impact laws bound a strip, but the one at `{state} = {}` does not reverse the \
         velocity (`{jump}`): both laws of a strip must reflect (`v -> -r*v`)",
        number(*at)
    )]
    StripNeedsReflecting {
        /// The barrier state.
        state: String,
        /// The barrier's position.
        at: f64,
        /// The jump, printed.
        jump: String,
    },
    /// Two impact laws at the same position.
    #[error("both impact laws are at `{state} = {}`: a strip needs two positions", number(*at))]
    SameBarrier {
        /// The barrier state.
        state: String,
        /// The common position.
        at: f64,
    },
    /// A `domain` line that is not the strip the two impact laws bound.
    #[error(
        "the two impact laws bound the strip `{implied}`, but the `domain` line says `{declared}`"
    )]
    DomainDisagrees {
        /// The domain as declared (bounds evaluated).
        declared: String,
        /// The strip between the barriers.
        implied: String,
    },
    /// One of the errors above, at the place in the model file where the offending value is
    /// written (`Display`: the message, then file:line:col and the source line with a caret).
    /// An expression of the model whose constant part, once the parameters are numbers, is
    /// not finite (`-c*v/0`, `1e300*1e10*z`).
    #[error(
        "{what} contains `{term}`, which evaluates to {} with the parameter values bound",
        number(*value)
    )]
    NotFiniteTerm {
        /// Which expression (`the drift of `v``).
        what: String,
        /// The constant subexpression, printed.
        term: String,
        /// Its value.
        value: f64,
    },
    /// An error placed at the expression of the model file that produced the bad value.
    #[error("{}", diagnostic.without_prefix())]
    Located {
        /// The error.
        error: Box<BindError>,
        /// Where, rendered.
        diagnostic: Diagnostic,
    },
}

impl BindError {
    /// The error itself, whether located or not.
    ///
    /// ```
    /// use fpsolve::model::{parse_model, BindError};
    /// let m = parse_model("model m\nparam bad = 1/0\nstate z, v\ndrift z: v\ndrift v: -z - v\n\
    ///     noise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let err = m.bind(&[]).unwrap_err();
    /// assert!(matches!(err.cause(), BindError::NotFinite { .. }));
    /// ```
    pub fn cause(&self) -> &BindError {
        match self {
            BindError::Located { error, .. } => error.cause(),
            other => other,
        }
    }

    /// Where in the model file the offending value is written, when it is in the file (not
    /// for values given by overrides).
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// let m = parse_model("model m\nparam bad = 1/0\nstate z, v\ndrift z: v\ndrift v: -z - v\n\
    ///     noise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// let d = m.bind(&[]).unwrap_err().diagnostic().cloned().unwrap();
    /// assert_eq!((d.line(), d.column()), (2, 13));
    /// ```
    pub fn diagnostic(&self) -> Option<&Diagnostic> {
        match self {
            BindError::Located { diagnostic, .. } => Some(diagnostic),
            _ => None,
        }
    }
}
