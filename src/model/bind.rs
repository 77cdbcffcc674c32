//! Binding a [`Model`]'s parameters to numbers.

use std::collections::HashMap;

use super::dependency::{walk, WalkError};
use super::{number, DeltaTreatment, Diagnostic, Interpretation, Model, Observable, Origin};
use crate::symbolic::{Expr, Func, Symbol};

/// A parameter override, `--set name=value`; the value may mention other parameters.
///
/// ```
/// use fpsolve::model::Override;
/// let o = Override::number("c", 0.5);
/// assert_eq!(o.name, "c");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Override {
    /// The parameter to set.
    pub name: String,
    /// Its new definition.
    pub value: Expr,
}

impl Override {
    /// An override to a plain number.
    ///
    /// ```
    /// let o = fpsolve::model::Override::number("mu", 1.0);
    /// assert_eq!(o.value.to_string(), "1");
    /// ```
    pub fn number(name: &str, value: f64) -> Override {
        Override {
            name: name.to_string(),
            value: Expr::num(value),
        }
    }
}

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
    /// A barrier position that is not a finite number.
    #[error("the impact barrier evaluates to {}", number(*value))]
    BadBarrier {
        /// The value found.
        value: f64,
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

/// An impact law with its barrier at a number.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let bound = model.bind(&[]).unwrap();
/// assert_eq!(bound.impact().unwrap().map.to_string(), "0.95*v");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BoundImpact {
    /// Index of the state that meets the barrier.
    pub state: usize,
    /// The barrier's position.
    pub at: f64,
    /// Index of the state that jumps.
    pub other: usize,
    /// The post-impact value of `other`, an expression of the states only.
    pub map: Expr,
}

/// A model whose parameters are numbers: every expression in it mentions only the states
/// (and, in the noise matrix, nothing else). What the FPK, EPC and Monte Carlo stages consume.
///
/// ```
/// let text = "model lin\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\nobserve y = abs(z)\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// let bound = model.bind(&[fpsolve::model::Override::number("c", 0.2)]).unwrap();
/// assert_eq!(bound.param("c"), Some(0.2));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BoundModel {
    pub(crate) name: String,
    pub(crate) params: Vec<(Symbol, f64)>,
    pub(crate) states: [Symbol; 2],
    pub(crate) drift: [Expr; 2],
    pub(crate) noise_names: Vec<Symbol>,
    /// S (m×m, row-major): E[ξ_k(t) ξ_l(t+τ)] = S_kl δ(τ).
    pub(crate) intensity: Vec<Vec<f64>>,
    pub(crate) noise_matrix: [Vec<Expr>; 2],
    pub(crate) interpretation: Interpretation,
    pub(crate) impact: Option<BoundImpact>,
    pub(crate) observables: Vec<Observable>,
    pub(crate) delta: DeltaTreatment,
    /// Where the model was read from (for locating errors of later stages).
    pub(crate) origin: Option<std::sync::Arc<Origin>>,
}

/// The first subexpression of `e` made of numbers only whose value is not finite.
fn non_finite_constant(e: &Expr) -> Option<(String, f64)> {
    // Numbers only (no symbol, no delta), tested without building a symbol set per node.
    let mut numbers_only = true;
    e.walk(&mut |n| {
        if matches!(n, Expr::Sym(_) | Expr::Call(Func::Delta, _)) {
            numbers_only = false;
        }
    });
    if numbers_only {
        return match e.eval(&|_| None) {
            Ok(v) if !v.is_finite() => Some((format!("{e:#}"), v)),
            _ => None,
        };
    }
    match e {
        Expr::Num(_) | Expr::Sym(_) => None,
        Expr::Add(v) | Expr::Mul(v) | Expr::Call(_, v) => v.iter().find_map(non_finite_constant),
        Expr::Pow(b, x) => non_finite_constant(b).or_else(|| non_finite_constant(x)),
    }
}

impl BoundModel {
    /// Refuses a drift, diffusion or jump map with a non-finite constant part.
    fn check_constants(&self) -> Result<(), BindError> {
        let mut exprs: Vec<(String, &Expr)> = Vec::new();
        for i in 0..2 {
            exprs.push((format!("the drift of `{}`", self.states[i]), &self.drift[i]));
            for g in &self.noise_matrix[i] {
                exprs.push((format!("the diffusion of `{}`", self.states[i]), g));
            }
        }
        if let Some(law) = &self.impact {
            exprs.push(("the impact map".to_string(), &law.map));
        }
        for (what, e) in exprs {
            if let Some((term, value)) = non_finite_constant(e) {
                return Err(BindError::NotFiniteTerm { what, term, value });
            }
        }
        Ok(())
    }

    /// The model's name.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.name(), "vibro_duffing");
    /// ```
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Parameter values, in declaration order.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.params()[4].1, 0.95);
    /// ```
    pub fn params(&self) -> &[(Symbol, f64)] {
        &self.params
    }
    /// The value of one parameter.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.param("r"), Some(0.95));
    /// ```
    pub fn param(&self, name: &str) -> Option<f64> {
        self.params.iter().find(|(n, _)| &**n == name).map(|p| p.1)
    }
    /// The two state variables' names.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(&*bound.states()[1], "v");
    /// ```
    pub fn states(&self) -> &[Symbol; 2] {
        &self.states
    }
    /// The drift of each state, as written (before any Wong–Zakai correction).
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.drift()[0].to_string(), "v");
    /// ```
    pub fn drift(&self) -> &[Expr; 2] {
        &self.drift
    }
    /// The noise sources' names.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.noise_names()[0].as_ref(), "xi");
    /// ```
    pub fn noise_names(&self) -> &[Symbol] {
        &self.noise_names
    }
    /// The intensity matrix S, E[ξ_k(t) ξ_l(t+τ)] = S_kl δ(τ).
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert!((bound.intensity()[0][0] - 1.0).abs() < 1e-15);
    /// ```
    pub fn intensity(&self) -> &[Vec<f64>] {
        &self.intensity
    }
    /// G_ik: how source k enters the equation of state i.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.noise_matrix()[1].len(), 1);
    /// ```
    pub fn noise_matrix(&self) -> &[Vec<Expr>; 2] {
        &self.noise_matrix
    }
    /// Itô or Stratonovich.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.interpretation(), fpsolve::model::Interpretation::Stratonovich);
    /// ```
    pub fn interpretation(&self) -> Interpretation {
        self.interpretation
    }
    /// The impact law, if any.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.impact().map(|law| law.at), Some(0.0));
    /// ```
    pub fn impact(&self) -> Option<&BoundImpact> {
        self.impact.as_ref()
    }
    /// The observables, parameters substituted.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.observables()[0].name.as_ref(), "y");
    /// ```
    pub fn observables(&self) -> &[Observable] {
        &self.observables
    }
    /// How `delta(·)` is treated in integrals.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.delta_treatment(), fpsolve::model::DeltaTreatment::Exact);
    /// ```
    pub fn delta_treatment(&self) -> DeltaTreatment {
        self.delta
    }
}

impl Model {
    /// Gives every parameter a number (its default, or the override) and substitutes them.
    ///
    /// Overrides may be expressions of other parameters; cycles, unknown names, non-finite
    /// values, negative intensities and correlations outside [−1, 1] are errors.
    pub fn bind(&self, overrides: &[Override]) -> Result<BoundModel, BindError> {
        self.bind_values(overrides)
            .map_err(|e| self.locate(e, overrides))
    }

    /// Places an error at the expression of the model file that produced the bad value;
    /// errors about values given by overrides stay unlocated.
    fn locate(&self, error: BindError, overrides: &[Override]) -> BindError {
        let Some(origin) = &self.origin else {
            return error;
        };
        let overridden = |name: &str| overrides.iter().any(|o| o.name == name);
        let (span, help) = match &error {
            BindError::NotFinite { name, .. } if !overridden(name) => {
                let Some(i) = self.params.iter().position(|p| &*p.name == name) else {
                    return error;
                };
                let set: Vec<String> = self.params[i]
                    .default
                    .symbols()
                    .iter()
                    .filter(|s| overridden(s))
                    .map(|s| format!("`{s}`"))
                    .collect();
                let help = (!set.is_empty())
                    .then(|| format!("`{name}` depends on {}, set by an override", set.join(", ")));
                (origin.params.get(i).copied(), help)
            }
            BindError::NegativeIntensity { noise, .. } => {
                let i = self.noises.iter().position(|n| &*n.name == noise);
                (i.and_then(|i| origin.intensities.get(i).copied()), None)
            }
            BindError::BadCorrelation { a, b, .. } => {
                let i = self
                    .correlations
                    .iter()
                    .position(|c| *self.noises[c.a].name == **a && *self.noises[c.b].name == **b);
                (i.and_then(|i| origin.correlations.get(i).copied()), None)
            }
            BindError::BadBarrier { .. } => (origin.barrier, None),
            BindError::NotFiniteTerm { what, .. } => {
                let state = |i: usize| format!("`{}`", self.states[i]);
                let span = if what.starts_with("the drift") {
                    (0..2)
                        .find(|i| what.ends_with(&state(*i)))
                        .and_then(|i| origin.drifts[i])
                } else if what.starts_with("the diffusion") {
                    (0..2)
                        .find(|i| what.ends_with(&state(*i)))
                        .and_then(|i| origin.diffusions[i])
                } else {
                    origin.map
                };
                (span, None)
            }
            _ => (None, None),
        };
        let Some(span) = span else {
            return error;
        };
        let diagnostic = origin.diagnostic(span, error.to_string(), help);
        BindError::Located {
            error: Box::new(error),
            diagnostic,
        }
    }

    fn bind_values(&self, overrides: &[Override]) -> Result<BoundModel, BindError> {
        let values = self.param_values(overrides)?;
        let table: HashMap<&str, f64> = values.iter().map(|(n, v)| (&**n, *v)).collect();
        let subst = |e: &Expr| e.map_symbols(&|s| table.get(&**s).map(|v| Expr::num(*v)));
        let number = |e: &Expr| e.eval(&|s| table.get(s).copied()).unwrap_or(f64::NAN);

        let m = self.noises.len();
        let mut intensity = vec![vec![0.0; m]; m];
        for (k, src) in self.noises.iter().enumerate() {
            let v = number(&src.intensity);
            if !(v.is_finite() && v >= 0.0) {
                return Err(BindError::NegativeIntensity {
                    noise: src.name.to_string(),
                    value: v,
                });
            }
            intensity[k][k] = v;
        }
        for c in &self.correlations {
            let rho = number(&c.coefficient);
            if !(rho.is_finite() && (-1.0..=1.0).contains(&rho)) {
                return Err(BindError::BadCorrelation {
                    a: self.noises[c.a].name.to_string(),
                    b: self.noises[c.b].name.to_string(),
                    value: rho,
                });
            }
            let s = rho * (intensity[c.a][c.a] * intensity[c.b][c.b]).sqrt();
            intensity[c.a][c.b] = s;
            intensity[c.b][c.a] = s;
        }
        let impact = match &self.impact {
            None => None,
            Some(law) => {
                let at = number(&law.at);
                if !at.is_finite() {
                    return Err(BindError::BadBarrier { value: at });
                }
                Some(BoundImpact {
                    state: law.state,
                    at,
                    other: law.other,
                    map: subst(&law.map),
                })
            }
        };
        let bound = BoundModel {
            name: self.name.clone(),
            states: self.states.clone(),
            drift: [subst(&self.drift[0]), subst(&self.drift[1])],
            noise_names: self.noises.iter().map(|n| n.name.clone()).collect(),
            intensity,
            noise_matrix: [
                self.noise_matrix[0].iter().map(subst).collect(),
                self.noise_matrix[1].iter().map(subst).collect(),
            ],
            interpretation: self.interpretation,
            impact,
            observables: self
                .observables
                .iter()
                .map(|o| Observable {
                    name: o.name.clone(),
                    expr: subst(&o.expr),
                })
                .collect(),
            delta: self.delta,
            params: values,
            origin: self.origin.clone(),
        };
        bound.check_constants()?;
        Ok(bound)
    }

    /// Evaluates every parameter, overrides first, in declaration order.
    fn param_values(&self, overrides: &[Override]) -> Result<Vec<(Symbol, f64)>, BindError> {
        let mut defs: HashMap<&str, &Expr> =
            self.params.iter().map(|p| (&*p.name, &p.default)).collect();
        let mut seen = std::collections::HashSet::new();
        for o in overrides {
            if !defs.contains_key(o.name.as_str()) {
                return Err(BindError::UnknownParameter {
                    name: o.name.clone(),
                    known: self
                        .params
                        .iter()
                        .map(|p| p.name.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
            if !seen.insert(o.name.as_str()) {
                return Err(BindError::DuplicateOverride {
                    name: o.name.clone(),
                });
            }
            defs.insert(o.name.as_str(), &o.value);
        }
        // Every parameter after those its definition mentions, without recursion; the order
        // of visits (and so which of several problems is reported) is that of evaluating
        // each parameter's symbols in turn, depth first.
        let index: HashMap<&str, usize> = self
            .params
            .iter()
            .enumerate()
            .map(|(i, p)| (&*p.name, i))
            .collect();
        let definition = |i: usize| defs[&*self.params[i].name];
        let edges = |i: usize| -> Vec<Result<usize, BindError>> {
            definition(i)
                .symbols()
                .iter()
                .map(|s| {
                    index
                        .get(&**s)
                        .copied()
                        .ok_or_else(|| BindError::NotAParameter {
                            name: self.params[i].name.to_string(),
                            symbol: s.to_string(),
                        })
                })
                .collect()
        };
        let mut values: Vec<f64> = vec![f64::NAN; self.params.len()];
        let finish = |i: usize| -> Result<(), BindError> {
            let v = definition(i)
                .eval(&|s| index.get(s).map(|j| values[*j]))
                .unwrap_or(f64::NAN);
            if !v.is_finite() {
                return Err(BindError::NotFinite {
                    name: self.params[i].name.to_string(),
                    value: v,
                });
            }
            values[i] = v;
            Ok(())
        };
        match walk(self.params.len(), edges, None, finish) {
            Ok(()) => {}
            Err(WalkError::Stopped(e)) => return Err(e),
            Err(WalkError::Cycle { chain }) => {
                let repeated = *chain.last().expect("a cycle has nodes");
                let names: Vec<&str> = chain.iter().map(|i| &*self.params[*i].name).collect();
                return Err(BindError::Cycle {
                    name: self.params[repeated].name.to_string(),
                    chain: names.join(" -> "),
                });
            }
            Err(WalkError::TooLong { .. }) => unreachable!("the walk was given no limit"),
        }
        Ok(self
            .params
            .iter()
            .zip(values)
            .map(|(p, v)| (p.name.clone(), v))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{NoiseSource, Parameter};

    fn tiny() -> Model {
        let p = |n: &str, e: Expr| Parameter {
            name: n.into(),
            default: e,
        };
        Model {
            name: "tiny".into(),
            description: String::new(),
            params: vec![
                p("c", Expr::num(0.1)),
                p("K", Expr::num(1.0) / Expr::sym("two_pi")),
                p("two_pi", Expr::num(2.0 * std::f64::consts::PI)),
            ],
            states: ["x".into(), "v".into()],
            drift: [Expr::sym("v"), -(Expr::sym("c") * Expr::sym("v"))],
            noises: vec![NoiseSource {
                name: "xi".into(),
                intensity: Expr::sym("two_pi") * Expr::sym("K"),
            }],
            correlations: vec![],
            noise_matrix: [vec![Expr::num(0.0)], vec![Expr::num(1.0)]],
            interpretation: Interpretation::Stratonovich,
            impact: None,
            observables: vec![],
            delta: DeltaTreatment::Exact,
            origin: None,
        }
    }

    #[test]
    fn a_non_finite_constant_in_an_expression_is_located() {
        let src = "model m\nparam c = 0.1\nstate z, v\ndrift z: v\ndrift v: -c*v/0 - z\n\
                   noise xi: intensity 1\ndiffusion v: xi\n";
        let m = crate::model::parse_model(src, Some(std::path::Path::new("m.sde"))).unwrap();
        let err = m.bind(&[]).unwrap_err();
        assert!(
            matches!(err.cause(), BindError::NotFiniteTerm { what, .. } if what == "the drift of `v`"),
            "{err:?}"
        );
        let d = err.diagnostic().unwrap();
        assert_eq!((d.line(), d.column()), (5, 10));
        assert!(err.to_string().contains(" --> m.sde:5:10"), "{err}");
        // A --set that makes a default non-finite is located at the default, and says so.
        let src = "model m\nparam c = 0.1, a = 1/c\nstate z, v\ndrift z: v\ndrift v: -a*v - z\n\
                   noise xi: intensity 1\ndiffusion v: xi\n";
        let m = crate::model::parse_model(src, None).unwrap();
        let err = m.bind(&[Override::number("c", 0.0)]).unwrap_err();
        let d = err.diagnostic().unwrap();
        assert_eq!((d.line(), d.column()), (2, 20));
        assert_eq!(d.help(), Some("`a` depends on `c`, set by an override"));
        assert_eq!(
            err.to_string().lines().next(),
            Some("parameter `a` evaluates to inf")
        );
        // The override's own value has no place in the file: it names the parameter.
        let err = m
            .bind(&[Override {
                name: "c".into(),
                value: Expr::num(1e308) * Expr::num(10.0),
            }])
            .unwrap_err();
        assert!(err.diagnostic().is_none());
        assert_eq!(err.to_string(), "parameter `c` evaluates to inf");
        // Numbers in messages never run to hundreds of digits (`{}` of -1e140 has 141).
        let src = "model m\nparam S = 1\nstate z, v\ndrift z: v\ndrift v: -v - z\n\
                   noise xi: intensity S\ndiffusion v: xi\n";
        let m = crate::model::parse_model(src, None).unwrap();
        let err = m.bind(&[Override::number("S", -1e140)]).unwrap_err();
        let text = err.to_string();
        assert!(
            text.starts_with("noise `xi` has intensity -1e140; "),
            "{text}"
        );
        assert!(text.len() < 400, "{text}");
    }

    #[test]
    fn binds_defaults_in_any_order() {
        let b = tiny().bind(&[]).unwrap();
        assert!((b.intensity()[0][0] - 1.0).abs() < 1e-15);
        assert_eq!(b.drift()[1].to_string(), "-0.1*v");
    }

    #[test]
    fn overrides_may_mention_other_parameters() {
        let o = Override {
            name: "c".into(),
            value: Expr::num(2.0) * Expr::sym("K"),
        };
        let b = tiny().bind(&[o]).unwrap();
        assert!((b.param("c").unwrap() - 1.0 / std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn override_cycles_and_unknown_names_are_errors() {
        let o = Override {
            name: "two_pi".into(),
            value: Expr::sym("K"),
        };
        assert!(matches!(tiny().bind(&[o]), Err(BindError::Cycle { .. })));
        let o = Override::number("nope", 1.0);
        assert!(matches!(
            tiny().bind(&[o]),
            Err(BindError::UnknownParameter { .. })
        ));
        let o = Override::number("K", -1.0);
        assert!(matches!(
            tiny().bind(&[o]),
            Err(BindError::NegativeIntensity { .. })
        ));
    }
}
