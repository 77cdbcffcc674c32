//! Model text → syntax tree → validated [`Model`] → [`BoundModel`] (numbers for parameters).
//!
//! A [`Model`] keeps its parameters symbolic, so that `--set` overrides and sweeps can bind
//! it to new values cheaply; [`Model::bind`] evaluates the parameters and substitutes them,
//! giving the [`BoundModel`] that the Fokker–Planck, EPC and Monte Carlo stages consume.

pub(crate) mod ast;
mod barrier;
mod bind;
mod bind_error;
mod dependency;
mod diagnostic;
mod error;
mod initial;
mod load;
mod parse;
mod periodic;
mod print;
mod provenance;
mod safe;
pub(crate) mod set;
mod syntax;
mod time;
mod validate;

pub use barrier::{BarrierSide, BoundImpact, Domain, DomainBound};
pub use bind::{BindError, BoundModel, Override};
pub use diagnostic::Diagnostic;
pub use error::ModelError;
pub use initial::{InitialError, InitialSpec, InitialState};
pub use load::{load_model, parse_expr, parse_model};
pub use parse::{MAX_LINE_BYTES, MAX_NESTING, MAX_SOURCE_BYTES};
pub use periodic::{BoundPeriodic, Periodic};
pub use provenance::{set_command, ModelSource, Provenance, SCHEMA_VERSION};
pub use safe::{BoundSafe, SafeError, SafeSet};
pub use set::SetError;
pub use time::PeriodError;
pub use validate::{DeltaMisuse, SemanticError, MAX_PARAMETER_CHAIN};

use crate::symbolic::{Expr, Symbol};

/// The name of time in a model file: usable in drift and diffusion lines (a periodic force
/// `A*cos(w*t)`, a modulated noise `env(t)*xi`), reserved everywhere else, and never a
/// parameter, state, noise or observable name. A model that mentions it is time-dependent
/// ([`BoundModel::time_dependent`]) and has no stationary density.
///
/// ```
/// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z + cos(t)\n\
///             noise xi: intensity 1\ndiffusion v: xi\n";
/// let bound = fpsolve::model::parse_model(text, None).unwrap().bind(&[]).unwrap();
/// assert!(bound.time_dependent());
/// assert_eq!(fpsolve::model::TIME, "t");
/// ```
pub const TIME: &str = "t";

/// A number as messages print it: the shortest text that reads back to the same value, in
/// exponent form outside 1e-4 ≤ |v| < 1e6, so that 1e300 is never written with 300 digits.
///
/// ```
/// use fpsolve::model::number;
/// assert_eq!(number(0.95), "0.95");
/// assert_eq!(number(-1e140), "-1e140");
/// assert_eq!(number(2.5e-7), "2.5e-7");
/// assert_eq!(number(f64::INFINITY), "inf");
/// assert_eq!(number(12.0), "12");
/// ```
pub fn number(v: f64) -> String {
    if !v.is_finite() || v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// How products of state-dependent noise with white noise are read.
///
/// ```
/// use fpsolve::model::Interpretation;
/// assert_eq!(Interpretation::default(), Interpretation::Stratonovich);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpretation {
    /// Stratonovich: the limit of smooth, wide-band noise (Wong–Zakai), the physical default.
    #[default]
    Stratonovich,
    /// Itô: the noise multiplies the state just before the increment.
    Ito,
}

/// How `delta(·)` terms are treated inside the Galerkin integrals.
///
/// ```
/// use fpsolve::model::DeltaTreatment;
/// assert_eq!(DeltaTreatment::default(), DeltaTreatment::Exact);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum DeltaTreatment {
    /// Sifting: a `delta(x)` term becomes a line integral over `x = 0`.
    #[default]
    Exact,
    /// A Gaussian of standard deviation `width` stands in for the delta.
    Gaussian {
        /// The regulariser's standard deviation (> 0), in the state's own units.
        width: f64,
    },
}

/// A parameter with its default value, an expression of constants and other parameters.
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// assert_eq!(model.params()[0].default.to_string(), "0.1");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// The parameter's name.
    pub name: Symbol,
    /// Its default, as written in the model file (`pi` and `e` already replaced by numbers).
    pub default: Expr,
}

/// A Gaussian white-noise source ξ with E[ξ(t) ξ(t+τ)] = `intensity` · δ(τ).
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// assert_eq!(model.noises()[0].intensity, fpsolve::symbolic::Expr::num(1.0));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseSource {
    /// The source's name, as used in `diffusion` lines.
    pub name: Symbol,
    /// Its intensity 2πK (an expression of parameters).
    pub intensity: Expr,
}

/// A correlation coefficient ρ between two noise sources: their cross intensity is
/// ρ·√(S_aa·S_bb).
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vdp_vibro_impact.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let rho = &model.correlations()[0];
/// assert_eq!((rho.a, rho.b), (0, 1));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Correlation {
    /// Index of the first source in [`Model::noises`].
    pub a: usize,
    /// Index of the second source.
    pub b: usize,
    /// ρ, an expression of parameters; binding checks −1 ≤ ρ ≤ 1.
    pub coefficient: Expr,
}

/// An impact law: when state `state` reaches `at`, state `other` jumps to `map`.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let law = &model.impacts()[0];
/// assert_eq!(law.map.to_string(), "r*v");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ImpactLaw {
    /// Index of the state that meets the barrier.
    pub state: usize,
    /// Where the barrier is (an expression of parameters).
    pub at: Expr,
    /// Index of the state that jumps.
    pub other: usize,
    /// The value after the impact, an expression of the states and parameters (`r*v`).
    pub map: Expr,
}

/// A named quantity computed from the state, whose PDF fpsolve reports.
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// assert_eq!(model.observables()[0].expr.to_string(), "abs(z)");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Observable {
    /// The observable's name (`y`, `ydot`).
    pub name: Symbol,
    /// Its definition in terms of the states (and parameters).
    pub expr: Expr,
}

/// A validated model: two states, their drifts, noise sources, how the noise enters, and what
/// to report. Built by [`crate::model::parse_model`]; every name in it is known, parameters
/// are acyclic, and the noise matrix has one entry per state and source.
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// assert_eq!(model.name(), "lin");
/// assert_eq!(model.drift()[1].to_string(), "-c*v - z");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    pub(crate) name: String,
    pub(crate) description: String,
    pub(crate) params: Vec<Parameter>,
    pub(crate) states: [Symbol; 2],
    pub(crate) drift: [Expr; 2],
    pub(crate) noises: Vec<NoiseSource>,
    pub(crate) correlations: Vec<Correlation>,
    /// `noise_matrix[i][k]`: how source k enters the equation of state i (G_ik).
    pub(crate) noise_matrix: [Vec<Expr>; 2],
    pub(crate) interpretation: Interpretation,
    /// 0, 1 or 2 laws (two on the same state, in file order).
    pub(crate) impacts: Vec<ImpactLaw>,
    /// The `domain` line, if any.
    pub(crate) domain: Option<Domain>,
    /// The `domain ... periodic` line, if any.
    pub(crate) periodic: Option<Periodic>,
    pub(crate) observables: Vec<Observable>,
    pub(crate) delta: DeltaTreatment,
    /// The `safe` line (or a `--safe` value), if any.
    pub(crate) safe: Option<SafeSet>,
    /// The `initial` line, if any (transients only; the stationary methods ignore it).
    pub(crate) initial: Option<InitialSpec>,
    /// Where the model was read from, for locating errors found when it is bound (`None` for
    /// models built in code).
    pub(crate) origin: Option<std::sync::Arc<Origin>>,
}

/// The source text of a parsed model and the spans of the expressions that binding
/// evaluates, so that a value found wrong then is reported at file:line:col.
#[derive(Clone, Debug)]
pub(crate) struct Origin {
    pub(crate) source: String,
    pub(crate) path: Option<String>,
    /// The default value of each parameter, in declaration order.
    pub(crate) params: Vec<ast::Span>,
    /// The intensity of each noise source.
    pub(crate) intensities: Vec<ast::Span>,
    /// The coefficient of each correlation.
    pub(crate) correlations: Vec<ast::Span>,
    /// The barrier position of each impact law.
    pub(crate) barriers: Vec<ast::Span>,
    /// The jump map of each impact law.
    pub(crate) maps: Vec<ast::Span>,
    /// The `domain` line.
    pub(crate) domain: Option<ast::Span>,
    /// Its lower and upper bound.
    pub(crate) domain_bounds: [Option<ast::Span>; 2],
    /// The period of a `domain ... periodic` line.
    pub(crate) period: Option<ast::Span>,
    /// The drift of each state.
    pub(crate) drifts: [Option<ast::Span>; 2],
    /// The diffusion line of each state.
    pub(crate) diffusions: [Option<ast::Span>; 2],
}

impl Origin {
    /// `message` rendered at `span`, like every other diagnostic of the file.
    pub(crate) fn diagnostic(
        &self,
        span: ast::Span,
        message: String,
        help: Option<String>,
    ) -> Diagnostic {
        Diagnostic::new(&self.source, self.path.as_deref(), span, message, help)
    }
}

/// Where a model was read from is not part of what it says: a model printed and parsed
/// again is the same model.
impl PartialEq for Origin {
    fn eq(&self, _: &Origin) -> bool {
        true
    }
}

impl Model {
    /// The model's name.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.name(), "vibro_duffing");
    /// ```
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The one-line description.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert!(model.description().starts_with("Vibro-impact Duffing"));
    /// ```
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The parameters in the order they were declared.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.params()[0].name.as_ref(), "c");
    /// ```
    pub fn params(&self) -> &[Parameter] {
        &self.params
    }

    /// The two state variables' names.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(&*model.states()[1], "v");
    /// ```
    pub fn states(&self) -> &[Symbol; 2] {
        &self.states
    }

    /// The drift of each state.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.drift()[0].to_string(), "v");
    /// ```
    pub fn drift(&self) -> &[Expr; 2] {
        &self.drift
    }

    /// The noise sources.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.noises()[0].name.as_ref(), "xi");
    /// ```
    pub fn noises(&self) -> &[NoiseSource] {
        &self.noises
    }

    /// The correlations declared between noise sources (absent pairs are independent).
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert!(model.correlations().is_empty());
    /// ```
    pub fn correlations(&self) -> &[Correlation] {
        &self.correlations
    }

    /// G_ik: how source k enters the equation of state i.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.noise_matrix()[0][0], fpsolve::symbolic::Expr::num(0.0));
    /// ```
    pub fn noise_matrix(&self) -> &[Vec<Expr>; 2] {
        &self.noise_matrix
    }

    /// Itô or Stratonovich.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.interpretation(), fpsolve::model::Interpretation::Stratonovich);
    /// ```
    pub fn interpretation(&self) -> Interpretation {
        self.interpretation
    }

    /// The impact laws, in file order: none, one, or two on the same state (a strip; which
    /// side each bounds is decided when the model is bound, see [`BoundModel::impacts`]).
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let laws: Vec<_> = model.impacts().iter().map(|law| (law.state, law.other)).collect();
    /// assert_eq!(laws, [(0, 1)]);
    /// ```
    pub fn impacts(&self) -> &[ImpactLaw] {
        &self.impacts
    }

    /// The `domain` line: which side of its reflecting barrier(s) the state lives on.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert!(model.domain().is_none());
    /// ```
    pub fn domain(&self) -> Option<&Domain> {
        self.domain.as_ref()
    }

    /// The `domain STATE periodic PERIOD` line: the state that is an angle.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert!(model.periodic().is_none());
    /// ```
    pub fn periodic(&self) -> Option<&Periodic> {
        self.periodic.as_ref()
    }

    /// The observables, in the order declared.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.observables()[1].name.as_ref(), "ydot");
    /// ```
    pub fn observables(&self) -> &[Observable] {
        &self.observables
    }

    /// How `delta(·)` is treated in integrals.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.delta_treatment(), fpsolve::model::DeltaTreatment::Exact);
    /// ```
    pub fn delta_treatment(&self) -> DeltaTreatment {
        self.delta
    }

    /// Index of a state by name.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// assert_eq!(model.state_index("v"), Some(1));
    /// ```
    pub fn state_index(&self, name: &str) -> Option<usize> {
        self.states.iter().position(|s| &**s == name)
    }
}
