//! The catalogue of semantic errors: every way a model that parses can still be wrong, as
//! typed values ([`SemanticError`], [`DeltaMisuse`]) whose `Display` is the message.

use super::super::ast::Span;

/// Longest chain of parameters defined through one another (`a = b`, `b = c`, ...) accepted;
/// binding evaluates such chains recursively.
///
/// ```
/// use fpsolve::model::{parse_model, SemanticError, MAX_PARAMETER_CHAIN};
/// let mut text = String::from("model m\nparam p0 = 1\n");
/// for i in 1..=MAX_PARAMETER_CHAIN + 1 {
///     text.push_str(&format!("param p{i} = p{}\n", i - 1));
/// }
/// text.push_str("state z, v\ndrift z: v\ndrift v: -z\nnoise xi: intensity 1\ndiffusion v: xi\n");
/// let err = parse_model(&text, None).unwrap_err();
/// assert!(matches!(err.semantic(), Some(SemanticError::ParameterChainTooLong { .. })));
/// ```
pub const MAX_PARAMETER_CHAIN: usize = 256;

/// What is wrong with a model that parses. Each variant is one kind of mistake; the
/// [`crate::model::ModelError`] that carries it also says where.
///
/// ```
/// use fpsolve::model::{parse_model, SemanticError};
/// let err = parse_model("model m\nstate z\n", None).unwrap_err();
/// assert_eq!(err.semantic(), Some(&SemanticError::StateCount { found: 1 }));
/// ```
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SemanticError {
    /// The file has no `model` line.
    #[error("no `model` line: a model file starts with `model NAME \"description\"`")]
    MissingModelLine,
    /// Something comes before the `model` line.
    #[error("the `model` line must come first")]
    ModelNotFirst,
    /// A second `model` line.
    #[error("a second `model` line (the first is on line {previous_line})")]
    DuplicateModelLine {
        /// Line of the first `model` line.
        previous_line: usize,
    },
    /// A statement that may appear once appears again (`state`, `interpretation`, `impact`,
    /// `delta`).
    #[error("`{keyword}` may appear only once (first on line {previous_line})")]
    DuplicateStatement {
        /// The statement's keyword.
        keyword: &'static str,
        /// Line of the first one.
        previous_line: usize,
    },
    /// A name defined twice, or for two kinds of thing (a drift or diffusion given twice
    /// for one state counts too).
    #[error("{}", duplicate_message(name, kind, previous_kind, *previous_line))]
    DuplicateDefinition {
        /// The name.
        name: String,
        /// What this definition makes it.
        kind: &'static str,
        /// What it already was.
        previous_kind: &'static str,
        /// Line of the earlier definition.
        previous_line: usize,
    },
    /// A declared name that is reserved: the constants `pi`, `e` or a function name.
    #[error("`{name}` is reserved ({what}) and cannot be declared as a {kind}")]
    ReservedName {
        /// The name.
        name: String,
        /// What it is reserved for.
        what: &'static str,
        /// What the declaration tried to make it.
        kind: &'static str,
    },
    /// A name that is declared nowhere.
    #[error("unknown identifier `{name}`")]
    UnknownIdentifier {
        /// The name.
        name: String,
        /// A declared name that is close, if any.
        suggestion: Option<String>,
    },
    /// A call of a function the language does not have.
    #[error("unknown function `{name}`")]
    UnknownFunction {
        /// The name.
        name: String,
        /// A function with a close name, if any.
        suggestion: Option<String>,
    },
    /// A call with the wrong number of arguments.
    #[error("`{func}` takes {expected} argument{}, but {found} {} given",
        if *expected == 1 { "" } else { "s" }, if *found == 1 { "was" } else { "were" })]
    WrongArity {
        /// The function.
        func: &'static str,
        /// How many it takes.
        expected: usize,
        /// How many it was given.
        found: usize,
    },
    /// A literal that is not a number (`1e`, `2x`, `1.2.3`) or does not fit an f64.
    #[error("malformed number `{text}`")]
    MalformedNumber {
        /// The text as written.
        text: String,
    },
    /// The `state` line does not declare exactly two states (or is missing).
    #[error("a model has exactly two states, but {}", match found {
        0 => "none is declared (add `state x, v`)".to_string(),
        1 => "only one is declared".to_string(),
        n => format!("{n} are declared"),
    })]
    StateCount {
        /// How many were declared.
        found: usize,
    },
    /// A state without a `drift` line.
    #[error("state `{state}` has no `drift` line")]
    MissingDrift {
        /// The state.
        state: String,
    },
    /// A `drift` line for a name that is not a state.
    #[error("`drift {name}`: `{name}` is not a state")]
    DriftForUnknownState {
        /// The name.
        name: String,
        /// A state with a close name, if any.
        suggestion: Option<String>,
    },
    /// An impact, observable or diffusion that names something that is not a state.
    #[error("{context}: `{name}` is not a state")]
    UnknownState {
        /// The name.
        name: String,
        /// Where it was used (`impact`, `diffusion`, ...).
        context: &'static str,
        /// A state with a close name, if any.
        suggestion: Option<String>,
    },
    /// An impact law whose jumping state is the barrier state itself.
    #[error("the impact on `{state}` must make the other state jump, not `{state}` itself")]
    ImpactOnItself {
        /// The state.
        state: String,
    },
    /// A third `impact` line: two bound a strip, more have no meaning.
    #[error(
        "a third `impact` line (the others are on lines {} and {}): a state has at most two \
         barriers, bounding a strip",
        previous_lines.0,
        previous_lines.1
    )]
    TooManyImpacts {
        /// Lines of the first two.
        previous_lines: (usize, usize),
    },
    /// Two impact laws on different states.
    #[error(
        "the second impact law is on `{second}`, the first on `{first}`: two barriers bound a \
         strip of one state"
    )]
    ImpactsOnDifferentStates {
        /// The first law's barrier state.
        first: String,
        /// The second law's.
        second: String,
    },
    /// A `domain` line in a model without impact laws.
    #[error(
        "`domain` confines `{state}`, but the model has no `impact` line: a bound of the domain \
         is where an impact law puts a reflecting barrier"
    )]
    DomainWithoutImpact {
        /// The confined state.
        state: String,
    },
    /// A `domain` line on another state than the impact laws'.
    #[error(
        "`domain` confines `{domain_state}`, but the impact laws put their barriers on \
         `{impact_state}`"
    )]
    DomainOnOtherState {
        /// The state of the `domain` line.
        domain_state: String,
        /// The barrier state of the impact laws.
        impact_state: String,
    },
    /// An impact law in a model with a periodic state.
    #[error(
        "`{state}` is periodic, and an impact law cannot be combined with a periodic state \
         (a barrier on an angle, or impacts of the other state, are not handled): drop the \
         `domain ... periodic` line or the impact law"
    )]
    PeriodicWithImpact {
        /// The periodic state.
        state: String,
    },
    /// Parameters defined through one another in a cycle.
    #[error("parameter `{name}` is defined through itself: {chain}")]
    ParameterCycle {
        /// Where the cycle starts.
        name: String,
        /// The chain, `a -> b -> a`.
        chain: String,
    },
    /// A chain of parameter definitions longer than [`MAX_PARAMETER_CHAIN`].
    #[error("parameter `{name}` depends on a chain of more than {limit} parameters")]
    ParameterChainTooLong {
        /// The parameter at the end of the chain.
        name: String,
        /// The limit.
        limit: usize,
    },
    /// A noise source (or what must be one) that is not declared.
    #[error("noise source `{name}` is not declared (add `noise {name}: intensity ...`)")]
    UndeclaredNoise {
        /// The name.
        name: String,
    },
    /// A declared noise source that no `diffusion` line uses.
    #[error("noise source `{name}` enters no equation (no `diffusion` line uses it)")]
    UnusedNoise {
        /// The source.
        name: String,
    },
    /// A noise symbol outside a `diffusion` line.
    #[error("noise source `{name}` used in {context}; noise may only appear in `diffusion` lines")]
    NoiseOutsideDiffusion {
        /// The source.
        name: String,
        /// Where it was used.
        context: &'static str,
    },
    /// A state in an expression that must be a constant (parameters only).
    #[error("state `{name}` used in {context}, which may only depend on parameters")]
    StateInConstant {
        /// The state.
        name: String,
        /// Which expression (`a parameter default`, `a noise intensity`, ...).
        context: &'static str,
    },
    /// The time `t` where only drift and diffusion lines may use it.
    #[error(
        "the time `t` used in {context}; only drift and diffusion lines may depend on it (for \
         a modulated noise write the envelope in the diffusion line, `diffusion v: env(t)*xi`)"
    )]
    TimeOutsideEquations {
        /// Which expression (`a noise intensity`, `an observable`, ...).
        context: &'static str,
    },
    /// A `safe` quantity that depends on no state: the set would hold everything or nothing.
    #[error("the safe set's quantity `{text}` depends on no state")]
    SafeWithoutState {
        /// The quantity as written.
        text: String,
    },
    /// An `initial` line names something that is not a state.
    #[error("`{name}` is not a state: the initial state gives a value to each of `{first}` and `{second}`")]
    InitialNotAState {
        /// The name given.
        name: String,
        /// The first state.
        first: String,
        /// The second state.
        second: String,
    },
    /// An `initial` line gives a state twice, or not at all.
    #[error("the initial state gives {count} value(s) for state `{state}`; it needs exactly one")]
    InitialStateCount {
        /// The state.
        state: String,
        /// How many values were given.
        count: usize,
    },
    /// An initial covariance that does not have four entries, or is not symmetric positive
    /// definite.
    #[error("initial covariance: {reason}")]
    InitialCovariance {
        /// What is wrong.
        reason: String,
    },
    /// An observable's name used inside an expression.
    #[error("observable `{name}` used in {context}; observables are outputs, not inputs")]
    ObservableInExpression {
        /// The observable.
        name: String,
        /// Where it was used.
        context: &'static str,
    },
    /// An observable that has no probability density: a constant, a map taking only discrete
    /// values (`sgn(z)`), or one containing `delta(...)`.
    #[error("observable `{name} = {text}` {reason}")]
    ObservableWithoutDensity {
        /// The observable.
        name: String,
        /// Its definition as written.
        text: String,
        /// What is wrong, in words.
        reason: &'static str,
    },
    /// Noise entering a `diffusion` line other than linearly.
    #[error("noise must enter linearly: {reason}")]
    NonlinearNoise {
        /// What makes it nonlinear here.
        reason: &'static str,
    },
    /// A term of a `diffusion` line without any noise source (it belongs in the drift).
    #[error("this term of `diffusion {state}` contains no noise source (move it to the drift)")]
    NoiseFreeTerm {
        /// The state of the `diffusion` line.
        state: String,
    },
    /// `correlate xi, xi`.
    #[error("noise source `{name}` cannot be correlated with itself")]
    SelfCorrelation {
        /// The source.
        name: String,
    },
    /// The same pair correlated twice.
    #[error("the correlation of `{a}` and `{b}` is already given on line {previous_line}")]
    DuplicateCorrelation {
        /// First source.
        a: String,
        /// Second source.
        b: String,
        /// Line of the first.
        previous_line: usize,
    },
    /// `gaussian(width)` whose width is not a positive number.
    #[error("the gaussian width must be a positive number{}", detail)]
    BadGaussianWidth {
        /// What was wrong, with its leading separator (`, not -1`).
        detail: String,
    },
    /// A `delta(...)` written where a Dirac delta has no meaning.
    #[error("{}", misuse.describe(delta))]
    MisplacedDelta {
        /// The delta call as written (cut after 40 characters).
        delta: String,
        /// What is wrong with it there.
        misuse: DeltaMisuse,
    },
}

/// Where a `delta(...)` was written that has no meaning there. A Dirac delta is a
/// distribution: in a drift it may only multiply an ordinary function, with an argument
/// linear in one state (`-(1 - r)*v*abs(v)*delta(z)`); everywhere else it is refused.
///
/// ```
/// use fpsolve::model::{parse_model, DeltaMisuse, SemanticError};
/// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -z - abs(delta(z))\n\
///             noise xi: intensity 1\ndiffusion v: xi\n";
/// let err = parse_model(text, None).unwrap_err();
/// let Some(SemanticError::MisplacedDelta { misuse, .. }) = err.semantic() else { panic!() };
/// assert_eq!(misuse, &DeltaMisuse::InFunction { func: "abs".into() });
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeltaMisuse {
    /// Inside a function call: `abs(delta(z))`, `exp(delta(z))`.
    InFunction {
        /// The function.
        func: String,
    },
    /// Raised to a power: `delta(z)^2`.
    InPower,
    /// In an exponent: `2^delta(z)`.
    InExponent,
    /// Divided by: `v/delta(z)`.
    InDenominator,
    /// Multiplied by another delta: `delta(z)*delta(v)`.
    TimesDelta,
    /// In an impact's jump map.
    InImpactMap,
    /// In a diffusion line (white noise times a delta).
    InDiffusion,
    /// In an expression that must be a number (`a parameter default`, ...).
    InConstant {
        /// Which expression.
        context: &'static str,
    },
    /// Its argument depends on no state.
    NoState,
    /// Its argument depends on both states.
    BothStates,
    /// Its argument is not linear in its state.
    NonlinearArgument {
        /// The state.
        state: String,
    },
    /// In the drift of the state its argument depends on (the operator would need δ′).
    OwnDrift {
        /// The state.
        state: String,
    },
}

impl DeltaMisuse {
    /// The message for the delta call `delta` (as written).
    ///
    /// ```
    /// use fpsolve::model::DeltaMisuse;
    /// let m = DeltaMisuse::InFunction { func: "abs".into() };
    /// assert!(m.describe("delta(z)").starts_with("delta(z) inside abs(...) has no meaning"));
    /// ```
    pub fn describe(&self, delta: &str) -> String {
        const ONLY: &str =
            "a Dirac delta may only multiply an ordinary function, as in `-(1 - r)*v*abs(v)*delta(z)`";
        match self {
            DeltaMisuse::InFunction { func } => {
                format!("{delta} inside {func}(...) has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InPower => {
                format!("{delta} raised to a power has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InExponent => {
                format!("{delta} in an exponent has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::InDenominator => {
                format!("division by {delta} has no meaning as a distribution; {ONLY}")
            }
            DeltaMisuse::TimesDelta => format!(
                "{delta} multiplies another delta: a product of deltas is not a line term and \
                 has no meaning here"
            ),
            DeltaMisuse::InImpactMap => format!(
                "{delta} in an impact map: the jump must be an ordinary function of the states \
                 (the impact term belongs in the drift)"
            ),
            DeltaMisuse::InDiffusion => format!(
                "{delta} in a diffusion line: white noise times a Dirac delta has no meaning"
            ),
            DeltaMisuse::InConstant { context } => {
                format!("{delta} in {context}, which must be a number: a delta has no value")
            }
            DeltaMisuse::NoState => format!(
                "{delta}: its argument depends on no state, so it is not a line in the plane"
            ),
            DeltaMisuse::BothStates => format!(
                "{delta}: its argument depends on both states; only a line delta(x - a) in \
                 one state is supported"
            ),
            DeltaMisuse::NonlinearArgument { state } => {
                format!("{delta}: its argument must be linear in `{state}` (a*{state} + b)")
            }
            DeltaMisuse::OwnDrift { state } => format!(
                "{delta} in the drift of `{state}` itself: the Fokker-Planck operator would need \
                 its derivative, which has no meaning here"
            ),
        }
    }
}

fn duplicate_message(name: &str, kind: &str, previous_kind: &str, line: usize) -> String {
    if kind == previous_kind {
        format!("{kind} `{name}` is defined twice (first on line {line})")
    } else {
        format!("`{name}` is already a {previous_kind} (line {line}); it cannot also be a {kind}")
    }
}

impl SemanticError {
    /// A hint for fixing the mistake, where there is one.
    ///
    /// ```
    /// use fpsolve::model::SemanticError;
    /// let e = SemanticError::UnknownIdentifier { name: "mux".into(), suggestion: Some("mu".into()) };
    /// assert_eq!(e.help().as_deref(), Some("did you mean `mu`?"));
    /// ```
    pub fn help(&self) -> Option<String> {
        match self {
            SemanticError::UnknownIdentifier { suggestion, .. }
            | SemanticError::UnknownFunction { suggestion, .. }
            | SemanticError::DriftForUnknownState { suggestion, .. }
            | SemanticError::UnknownState { suggestion, .. } => {
                suggestion.as_ref().map(|s| format!("did you mean `{s}`?"))
            }
            SemanticError::NonlinearNoise { .. } => Some(
                "a diffusion term must read `coefficient * noise`, the coefficient free of noise"
                    .into(),
            ),
            _ => None,
        }
    }
}

/// A semantic error with the span it concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Located {
    pub(crate) error: SemanticError,
    pub(crate) span: Span,
}

pub(super) type Result<T> = std::result::Result<T, Box<Located>>;

pub(super) fn fail<T>(error: SemanticError, span: Span) -> Result<T> {
    Err(Box::new(Located { error, span }))
}
