//! Binding a [`Model`]'s parameters to numbers.

use std::collections::HashMap;

use super::barrier::{bind_impacts, BoundImpact, DomainPart, Placed};
pub use super::bind_error::BindError;
use super::dependency::{walk, WalkError};
use super::periodic::{first_not_periodic, BoundPeriodic};
use super::{DeltaTreatment, Interpretation, Model, Observable, Origin};
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
    /// 0, 1 or 2 laws; two bound a strip on one state, sorted by position.
    pub(crate) impacts: Vec<BoundImpact>,
    pub(crate) observables: Vec<Observable>,
    pub(crate) delta: DeltaTreatment,
    /// The periodic state, if any.
    pub(crate) periodic: Option<BoundPeriodic>,
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
    /// Every drift and diffusion coefficient, each named as an error names it (`the drift
    /// of `v``).
    fn coefficients(&self) -> Vec<(String, &Expr)> {
        let mut exprs: Vec<(String, &Expr)> = Vec::new();
        for i in 0..2 {
            exprs.push((format!("the drift of `{}`", self.states[i]), &self.drift[i]));
            for g in &self.noise_matrix[i] {
                exprs.push((format!("the diffusion of `{}`", self.states[i]), g));
            }
        }
        exprs
    }

    /// Refuses a drift, diffusion or jump map with a non-finite constant part.
    fn check_constants(&self) -> Result<(), BindError> {
        let mut exprs = self.coefficients();
        for law in &self.impacts {
            exprs.push(("the impact map".to_string(), &law.map));
        }
        for (what, e) in exprs {
            if let Some((term, value)) = non_finite_constant(e) {
                return Err(BindError::NotFiniteTerm { what, term, value });
            }
        }
        Ok(())
    }

    /// Refuses a periodic state whose drift or diffusion does not repeat with its period.
    fn check_periodic(&self) -> Result<(), BindError> {
        let Some(p) = self.periodic else {
            return Ok(());
        };
        match first_not_periodic(&self.states, p, self.coefficients()) {
            Some((what, at)) => Err(BindError::NotPeriodic {
                what,
                state: self.states[p.state].to_string(),
                period: p.period,
                at,
            }),
            None => Ok(()),
        }
    }

    /// The periodic state and its period (`domain theta periodic 2*pi`), if any.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/duffing.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// assert!(bound.periodic().is_none());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn periodic(&self) -> Option<BoundPeriodic> {
        self.periodic
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
    /// The impact laws: none, one, or two on the same state bounding a strip (sorted by
    /// position, the lower one [`BarrierSide::Above`](super::BarrierSide::Above), the upper
    /// one [`BarrierSide::Below`](super::BarrierSide::Below)).
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let model = fpsolve::model::load_model(&path).unwrap();
    /// let bound = model.bind(&[]).unwrap();
    /// assert_eq!(bound.impacts().iter().map(|law| law.at).collect::<Vec<_>>(), [0.0]);
    /// ```
    pub fn impacts(&self) -> &[BoundImpact] {
        &self.impacts
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
            BindError::BadBarrier { .. } => (origin.barriers.first().copied(), None),
            BindError::BadPeriod { .. } => (origin.period.or(origin.domain), None),
            BindError::NotPeriodic { .. } => (origin.domain, None),
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
                    // The first map with a non-finite constant, in file order.
                    let table = self.param_values(overrides).unwrap_or_default();
                    let value =
                        |s: &Symbol| table.iter().find(|(n, _)| n == s).map(|p| Expr::num(p.1));
                    self.impacts
                        .iter()
                        .position(|l| non_finite_constant(&l.map.map_symbols(&value)).is_some())
                        .and_then(|i| origin.maps.get(i).copied())
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
        let impacts = bind_impacts(self, &number, &subst).map_err(|p| self.place(p))?;
        let periodic = match &self.periodic {
            Some(p) => {
                let period = number(&p.period);
                if !(period.is_finite() && period > 0.0) {
                    return Err(BindError::BadPeriod {
                        state: self.states[p.state].to_string(),
                        value: period,
                    });
                }
                Some(BoundPeriodic {
                    state: p.state,
                    period,
                })
            }
            None => None,
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
            impacts,
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
            periodic,
            origin: self.origin.clone(),
        };
        bound.check_constants()?;
        bound.check_periodic()?;
        Ok(bound)
    }

    /// A barrier error placed at its impact law or `domain` bound in the model file.
    fn place(&self, placed: Placed) -> BindError {
        let (span, error) = match (placed, &self.origin) {
            (Placed::Impact(i, e), Some(o)) => (o.barriers.get(i).copied(), e),
            (Placed::Domain(part, e), Some(o)) => (
                match part {
                    DomainPart::Line => o.domain,
                    DomainPart::Lower => o.domain_bounds[0].or(o.domain),
                    DomainPart::Upper => o.domain_bounds[1].or(o.domain),
                },
                e,
            ),
            (Placed::Impact(_, e) | Placed::Domain(_, e), None) => return e,
        };
        let (Some(span), Some(origin)) = (span, &self.origin) else {
            return error;
        };
        let help = match &error {
            BindError::ReflectingWithoutDomain { suggestion, .. } => {
                Some(format!("add the line `{suggestion}`"))
            }
            _ => None,
        };
        let diagnostic = origin.diagnostic(span, error.to_string(), help);
        BindError::Located {
            error: Box::new(error),
            diagnostic,
        }
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
            impacts: vec![],
            domain: None,
            observables: vec![],
            safe: None,
            initial: None,
            periodic: None,
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
