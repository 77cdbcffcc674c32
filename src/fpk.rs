//! From drift, noise matrix and intensities to the stationary Fokker–Planck operator.
//!
//! For p = C·exp(Q) the stationary FPK equation divided by p is the residual
//! F = A0 + Σ_i A_i ∂_iQ + Σ_ij B_ij (∂_i∂_jQ + ∂_iQ ∂_jQ) (the paper's Eq. 18), with
//! A0 = −Σ_i ∂_i m_i + ½ Σ_ij ∂_i∂_j b_ij, A_i = −m_i + Σ_j ∂_j b_ij, B_ij = ½ b_ij,
//! where m is the Itô drift (Wong–Zakai corrected for a Stratonovich model) and b = G·S·Gᵀ.

use std::fmt;

use crate::dynamics::{Dynamics, ImpactForm, Inadmissible};
use crate::model::{BoundModel, DeltaTreatment, Diagnostic};
use crate::symbolic::{diff, sift, simplify, DeltaLine, DeltaSplit, Expr, Symbol, SymbolicError};

/// The derived stationary FPK operator of a bound model, ready for the EPC engine.
///
/// ```
/// use fpsolve::fpk::FpkOperator;
/// use fpsolve::model::{parse_model, DeltaTreatment};
/// let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
///     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// // Additive noise: no Wong–Zakai correction, b_vv = 1, no impact, δ terms sifted.
/// assert_eq!(fpk.wong_zakai[1].to_string(), "0");
/// assert_eq!(fpk.diffusion[1][1].to_string(), "1");
/// assert!(fpk.impact.is_none());
/// assert_eq!(fpk.delta_treatment, DeltaTreatment::Exact);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct FpkOperator {
    /// The two states' names (x1, x2).
    pub states: [Symbol; 2],
    /// The Itô drift m_i (Wong–Zakai correction included for Stratonovich models).
    pub drift: [Expr; 2],
    /// The Wong–Zakai drift correction that was added to the model's drift (zero for Itô
    /// models and for noise that does not depend on the state it multiplies).
    pub wong_zakai: [Expr; 2],
    /// The diffusion matrix b = G·S·Gᵀ (symmetric).
    pub diffusion: [[Expr; 2]; 2],
    /// A0 = −Σ_i ∂_i m_i + ½ Σ_ij ∂_i∂_j b_ij, split into its regular and delta parts.
    pub a0: DeltaSplit,
    /// A_i = −m_i + Σ_j ∂_j b_ij.
    pub a: [DeltaSplit; 2],
    /// B_ij = ½ b_ij (symmetric).
    pub b: [[DeltaSplit; 2]; 2],
    /// What EPC makes of the model's impact law (`None` without one): the operator above
    /// represents an impact only through a Zhuravlev term in the drift, so any other law is
    /// recorded here for EPC to refuse ([`crate::dynamics::impact_form`]).
    pub impact: Option<ImpactForm>,
    /// How the Galerkin integrals treat the operator's δ terms: the model's `delta:` line
    /// (sifting by default), recorded by [`FpkOperator::derive`] so that a solver needs
    /// nothing but the operator.
    pub delta_treatment: DeltaTreatment,
}

/// Which derived quantity a failure happened in.
///
/// ```
/// use fpsolve::fpk::{FpkError, FpkOperator};
/// use fpsolve::model::{parse_model, Override};
/// let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
///     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// let undamped = model.bind(&[Override::number("c", 0.0)]).unwrap();
/// assert!(matches!(FpkOperator::derive(&undamped), Err(FpkError::Inadmissible(_))));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FpkError {
    /// The symbolic layer refused an operation (a derivative of delta, a product with no
    /// meaning as a distribution, …) while deriving `what`.
    #[error("while deriving {what}: {source}")]
    Symbolic {
        /// The quantity being derived (`A0`, `A_v`, `b_vv`, …).
        what: String,
        /// The underlying failure.
        source: SymbolicError,
    },
    /// The noise matrix contains a delta: white noise times a delta has no meaning here.
    #[error("the noise matrix entry G[{state}][{noise}] = {expr} contains delta(...)")]
    DeltaInNoise {
        /// The state equation.
        state: String,
        /// The noise source.
        noise: String,
        /// The entry.
        expr: String,
    },
    /// The model has no stationary density (an impact that adds energy, no damping, no
    /// noise, …): refused before anything is derived, see [`crate::dynamics::check`].
    #[error(transparent)]
    Inadmissible(#[from] Inadmissible),
    /// One of the errors above, at the line of the model file that causes it (`Display`: the
    /// message, then file:line:col and the source line with a caret).
    #[error("{}", diagnostic.without_prefix())]
    Located {
        /// The error.
        error: Box<FpkError>,
        /// Where, rendered.
        diagnostic: Diagnostic,
    },
}

impl FpkError {
    /// Where in the model file the cause is, when the model was read from a file and the
    /// failure can be traced to one drift or diffusion line.
    ///
    /// ```
    /// use fpsolve::fpk::FpkOperator;
    /// let src = "model m\nstate z, v\ndrift z: v\ndrift v: -z - v - v*sgn(z)*delta(z)\n\
    ///            noise xi: intensity 1\ndiffusion v: xi\n";
    /// let bound = fpsolve::model::parse_model(src, None).unwrap().bind(&[]).unwrap();
    /// let err = FpkOperator::derive(&bound).unwrap_err();
    /// assert_eq!(err.diagnostic().map(|d| (d.line(), d.column())), Some((4, 10)));
    /// ```
    pub fn diagnostic(&self) -> Option<&Diagnostic> {
        match self {
            FpkError::Located { diagnostic, .. } => Some(diagnostic),
            _ => None,
        }
    }
}

/// Traces a derivation failure to the one line of the model file that causes it: the
/// derivation is repeated with only that line kept (the other drift and the other noise rows
/// set to zero); the first line that fails alone is the cause.
fn locate(model: &BoundModel, error: FpkError) -> FpkError {
    let Some(origin) = model.origin.clone() else {
        return error;
    };
    if matches!(error, FpkError::Inadmissible(_) | FpkError::Located { .. }) {
        return error;
    }
    let zero = Expr::num(0.0);
    let mut candidates = Vec::new();
    for i in 0..2 {
        if let Some(span) = origin.drifts[i] {
            let mut alone = model.clone();
            alone.drift[1 - i] = zero.clone();
            for row in alone.noise_matrix.iter_mut() {
                row.iter_mut().for_each(|g| *g = zero.clone());
            }
            candidates.push((span, alone));
        }
    }
    for i in 0..2 {
        if let Some(span) = origin.diffusions[i] {
            let mut alone = model.clone();
            alone.drift = [zero.clone(), zero.clone()];
            alone.noise_matrix[1 - i]
                .iter_mut()
                .for_each(|g| *g = zero.clone());
            candidates.push((span, alone));
        }
    }
    for (span, alone) in candidates {
        if FpkOperator::derive_unchecked(&alone).is_err() {
            let diagnostic = origin.diagnostic(span, error.to_string(), None);
            return FpkError::Located {
                error: Box::new(error),
                diagnostic,
            };
        }
    }
    error
}

impl From<crate::dynamics::DerivationError> for FpkError {
    fn from(e: crate::dynamics::DerivationError) -> FpkError {
        FpkError::Symbolic {
            what: e.what,
            source: e.source,
        }
    }
}

fn ctx<T>(what: impl Into<String>, r: Result<T, SymbolicError>) -> Result<T, FpkError> {
    r.map_err(|source| FpkError::Symbolic {
        what: what.into(),
        source,
    })
}

impl FpkOperator {
    /// Derives the operator of a bound model and checks that the model can have a
    /// stationary density at all ([`crate::dynamics::check`]): an operator exists only for models
    /// whose stationary FPK equation is worth solving.
    ///
    /// ```
    /// use fpsolve::fpk::{FpkError, FpkOperator};
    /// use fpsolve::model::{parse_model, Override};
    /// let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
    ///     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
    /// assert!(FpkOperator::derive(&model.bind(&[]).unwrap()).is_ok());
    /// let undamped = model.bind(&[Override::number("c", 0.0)]).unwrap();
    /// assert!(matches!(FpkOperator::derive(&undamped), Err(FpkError::Inadmissible(_))));
    /// ```
    pub fn derive(model: &BoundModel) -> Result<FpkOperator, FpkError> {
        FpkOperator::of(&Dynamics::read(model))
    }

    /// [`FpkOperator::derive`] from a model already read: the operator of
    /// `dynamics.model()`, from the reading every method shares.
    ///
    /// ```
    /// use fpsolve::fpk::FpkOperator;
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
    /// assert_eq!(FpkOperator::of(&dynamics)?, FpkOperator::derive(&bound)?);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// As [`FpkOperator::derive`].
    pub fn of(dynamics: &Dynamics) -> Result<FpkOperator, FpkError> {
        let model = dynamics.model();
        let states = model.states();
        let sde = dynamics.sde();
        for (i, row) in sde.noise_matrix().iter().enumerate() {
            for (k, e) in row.iter().enumerate() {
                if e.contains_delta() {
                    return Err(FpkError::DeltaInNoise {
                        state: states[i].to_string(),
                        noise: sde.noise_names()[k].to_string(),
                        expr: e.to_string(),
                    });
                }
            }
        }
        // The symbolic derivation first: a term with no meaning is the more specific error.
        let operator = FpkOperator::unchecked_of(dynamics).map_err(|e| locate(model, e))?;
        dynamics.admissible()?;
        Ok(operator)
    }

    /// The derivation without the admissibility check: for the members of a homotopy
    /// ([`crate::epc::Epc::branch`]), which may step a little outside the physical range
    /// (r = 1 + 5e-7 when a family starts at r = 1), and for tests of the formulas. Anything
    /// that solves or reports a density uses [`FpkOperator::derive`].
    ///
    /// ```
    /// use fpsolve::fpk::FpkOperator;
    /// use fpsolve::model::{load_model, Override};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let b = load_model(&path).unwrap().bind(&[Override::number("r", 1.0000005)]).unwrap();
    /// assert!(FpkOperator::derive(&b).is_err());
    /// assert!(FpkOperator::derive_unchecked(&b).is_ok());
    /// ```
    pub fn derive_unchecked(model: &BoundModel) -> Result<FpkOperator, FpkError> {
        FpkOperator::unchecked_of(&Dynamics::read(model))
    }

    /// [`FpkOperator::derive_unchecked`] from a model already read.
    fn unchecked_of(dynamics: &Dynamics) -> Result<FpkOperator, FpkError> {
        let model = dynamics.model();
        let states = model.states().clone();
        // b = G S Gᵀ
        let diffusion = dynamics.diffusion().clone();
        let drift = dynamics.ito_drift()?.clone();
        let wong_zakai = dynamics.wong_zakai()?.clone();
        let name = |i: usize| states[i].to_string();
        // A0 = −Σ_i ∂_i m_i + ½ Σ_ij ∂_i∂_j b_ij
        let mut a0_terms = Vec::new();
        for i in 0..2 {
            let dm = ctx(
                format!("d m_{} / d{}", name(i), name(i)),
                diff(&drift[i], &states[i]),
            )?;
            a0_terms.push(-dm);
            for j in 0..2 {
                let what = format!("d2 b_{}{} / d{} d{}", name(i), name(j), name(i), name(j));
                let d1 = ctx(what.clone(), diff(&diffusion[i][j], &states[j]))?;
                let d2 = ctx(what, diff(&d1, &states[i]))?;
                a0_terms.push(Expr::num(0.5) * d2);
            }
        }
        let a0 = simplify(&Expr::sum(a0_terms));
        // A_i = −m_i + Σ_j ∂_j b_ij
        let mut a: [Expr; 2] = [Expr::num(0.0), Expr::num(0.0)];
        for i in 0..2 {
            let mut terms = vec![-drift[i].clone()];
            for j in 0..2 {
                let what = format!("d b_{}{} / d{}", name(i), name(j), name(j));
                terms.push(ctx(what, diff(&diffusion[i][j], &states[j]))?);
            }
            a[i] = simplify(&Expr::sum(terms));
        }
        let split = |what: String, e: &Expr| ctx(what, sift(e, &states));
        let a0 = split("A0".into(), &a0)?;
        let a = [
            split(format!("A_{}", name(0)), &a[0])?,
            split(format!("A_{}", name(1)), &a[1])?,
        ];
        let b_row = |i: usize| -> Result<[DeltaSplit; 2], FpkError> {
            let entry = |j: usize| {
                let half = simplify(&(Expr::num(0.5) * diffusion[i][j].clone()));
                split(format!("B_{}{}", name(i), name(j)), &half)
            };
            Ok([entry(0)?, entry(1)?])
        };
        let b = [b_row(0)?, b_row(1)?];
        Ok(FpkOperator {
            states,
            drift,
            wong_zakai,
            diffusion,
            a0,
            a,
            b,
            impact: dynamics.impact_form().cloned(),
            delta_treatment: model.delta_treatment(),
        })
    }
}

impl FpkOperator {
    /// The same operator with its δ terms treated as `treatment` instead of as the model
    /// file says (e.g. to study a Gaussian regulariser's convergence to sifting).
    ///
    /// ```
    /// use fpsolve::fpk::FpkOperator;
    /// use fpsolve::model::{load_model, DeltaTreatment};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
    /// assert_eq!(fpk.delta_treatment, DeltaTreatment::Exact);
    /// let smooth = fpk.with_delta_treatment(DeltaTreatment::Gaussian { width: 0.1 });
    /// assert_eq!(smooth.delta_treatment, DeltaTreatment::Gaussian { width: 0.1 });
    /// ```
    pub fn with_delta_treatment(mut self, treatment: DeltaTreatment) -> FpkOperator {
        self.delta_treatment = treatment;
        self
    }
}

/// Prints a split coefficient as `regular + weight*delta(x - at) + …`.
fn fmt_split(s: &DeltaSplit, states: &[Symbol; 2], f: &mut fmt::Formatter<'_>) -> fmt::Result {
    let mut terms: Vec<Expr> = Vec::new();
    if s.regular.as_num() != Some(0.0) || s.lines.is_empty() {
        terms.push(s.regular.clone());
    }
    for DeltaLine { axis, at, weight } in &s.lines {
        let x = Expr::Sym(states[*axis].clone());
        let arg = if *at == 0.0 { x } else { x - Expr::num(*at) };
        terms.push(weight.clone() * Expr::call(crate::symbolic::Func::Delta, arg));
    }
    write!(f, "{:#}", Expr::sum(terms))
}

impl fmt::Display for FpkOperator {
    /// The operator in readable mathematical form, one coefficient per line; zero entries of
    /// the diffusion matrix and of B are left out.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x1, x2] = &self.states;
        let names = [x1, x2];
        writeln!(f, "Ito drift m (Wong-Zakai correction included):")?;
        for (x, m) in names.iter().zip(&self.drift) {
            writeln!(f, "  m_{x} = {m:#}")?;
        }
        let wz: Vec<usize> = (0..2)
            .filter(|&i| self.wong_zakai[i].as_num() != Some(0.0))
            .collect();
        if wz.is_empty() {
            writeln!(f, "  (no Wong-Zakai correction)")?;
        }
        for i in wz {
            writeln!(
                f,
                "  Wong-Zakai correction in m_{}: {:#}",
                names[i], self.wong_zakai[i]
            )?;
        }
        writeln!(f, "Diffusion b = G S G^T:")?;
        for i in 0..2 {
            for j in i..2 {
                if self.diffusion[i][j].as_num() != Some(0.0) {
                    writeln!(
                        f,
                        "  b_{}{} = {:#}",
                        names[i], names[j], self.diffusion[i][j]
                    )?;
                }
            }
        }
        writeln!(
            f,
            "FPK coefficients, F = A0 + sum_i A_i dQ/dx_i + sum_ij B_ij (d2Q/dx_i dx_j + dQ/dx_i dQ/dx_j):"
        )?;
        write!(f, "  A0 = ")?;
        fmt_split(&self.a0, &self.states, f)?;
        writeln!(f)?;
        for (x, a) in names.iter().zip(&self.a) {
            write!(f, "  A_{x} = ")?;
            fmt_split(a, &self.states, f)?;
            writeln!(f)?;
        }
        for i in 0..2 {
            for j in i..2 {
                let bij = &self.b[i][j];
                if bij.regular.as_num() != Some(0.0) || !bij.lines.is_empty() {
                    write!(f, "  B_{}{} = ", names[i], names[j])?;
                    fmt_split(bij, &self.states, f)?;
                    writeln!(f)?;
                }
            }
        }
        match &self.impact {
            Some(form @ ImpactForm::Zhuravlev { .. }) => writeln!(
                f,
                "Impact law: {form}, represented by the delta term of the drift"
            )?,
            Some(form @ ImpactForm::Unsupported { .. }) => writeln!(
                f,
                "Impact law {form}; EPC refuses it, Monte Carlo simulates it"
            )?,
            None => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{DeltaTreatment, Interpretation};
    use crate::symbolic::Func;

    fn sym(s: &str) -> Expr {
        Expr::sym(s)
    }

    /// The paper's Eq. 10 with numbers: c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95, 2πK = 1.
    fn vibro(interpretation: Interpretation) -> BoundModel {
        let (z, v) = (sym("z"), sym("v"));
        let drift_v = -(Expr::num(0.1) * v.clone())
            - z.clone()
            - Expr::num(0.1) * Expr::pow(z.clone(), Expr::num(3.0))
            - Expr::num(0.05)
                * v.clone()
                * Expr::call(Func::Abs, v.clone())
                * Expr::call(Func::Delta, z.clone());
        BoundModel {
            name: "vibro".into(),
            params: vec![],
            states: ["z".into(), "v".into()],
            drift: [v.clone(), drift_v],
            noise_names: vec!["xi".into()],
            intensity: vec![vec![1.0]],
            noise_matrix: [
                vec![Expr::num(0.0)],
                vec![Expr::call(Func::Sgn, z.clone()) + Expr::num(0.1) * z],
            ],
            interpretation,
            impacts: vec![],
            observables: vec![],
            delta: DeltaTreatment::Exact,
            periodic: None,
            origin: None,
        }
    }

    fn eval(e: &Expr, z: f64, v: f64) -> f64 {
        e.eval(&|s| match s {
            "z" => Some(z),
            "v" => Some(v),
            _ => None,
        })
        .unwrap()
    }

    #[test]
    fn vibro_impact_coefficients_match_eq_13() {
        let op = FpkOperator::derive(&vibro(Interpretation::Stratonovich)).unwrap();
        // Noise in the v-equation depends on z only: no Wong–Zakai correction.
        assert_eq!(op.wong_zakai[1], Expr::num(0.0));
        for (z, v) in [(0.7, -1.3), (-2.1, 0.4), (1e-3, 3.0)] {
            let b = 0.5 * (1.0 + 0.2 * f64::abs(z) + 0.01 * z * z);
            assert!((eval(&op.b[1][1].regular, z, v) - b).abs() < 1e-14);
            assert!((eval(&op.a[0].regular, z, v) + v).abs() < 1e-14);
            let av = 0.1 * v + z + 0.1 * z.powi(3);
            assert!((eval(&op.a[1].regular, z, v) - av).abs() < 1e-14);
            assert!((eval(&op.a0.regular, z, v) - 0.1).abs() < 1e-14);
        }
        assert_eq!(op.a0.lines.len(), 1);
        assert_eq!(op.a0.lines[0].axis, 0);
        let w = eval(&op.a0.lines[0].weight, 0.0, -2.0);
        assert!((w - 2.0 * 0.05 * 2.0).abs() < 1e-14, "2(1-r)|v|, got {w}");
        let w = eval(&op.a[1].lines[0].weight, 0.0, -2.0);
        assert!((w - 0.05 * -2.0 * 2.0).abs() < 1e-14, "(1-r)v|v|, got {w}");
        let text = op.to_string();
        assert!(text.contains("delta(z)"), "{text}");
    }

    #[test]
    fn wong_zakai_correction_appears_only_for_stratonovich_multiplicative_noise() {
        // dv = (−z − 0.2 v) dt + 0.5 v ∘ dB, S = 2: correction ½·S·G·∂_vG = 0.25 v.
        let mut m = vibro(Interpretation::Stratonovich);
        m.drift[1] = -sym("z") - Expr::num(0.2) * sym("v");
        m.noise_matrix[1] = vec![Expr::num(0.5) * sym("v")];
        m.intensity = vec![vec![2.0]];
        // Purely multiplicative noise has no stationary density (the origin absorbs): the
        // formulas are checked without the admissibility check.
        assert!(matches!(
            FpkOperator::derive(&m),
            Err(FpkError::Inadmissible(_))
        ));
        let strat = FpkOperator::derive_unchecked(&m).unwrap();
        assert!((eval(&strat.wong_zakai[1], 0.3, 1.7) - 0.25 * 1.7).abs() < 1e-14);
        assert!((eval(&strat.drift[1], 0.3, 1.7) - (-0.3 - 0.2 * 1.7 + 0.25 * 1.7)).abs() < 1e-14);
        m.interpretation = Interpretation::Ito;
        let ito = FpkOperator::derive_unchecked(&m).unwrap();
        assert_eq!(ito.wong_zakai[1], Expr::num(0.0));
        // b_vv = 2·0.25 v² = 0.5 v²: A_v = −m_v + ∂_v b_vv = z + 0.2 v + v, A0 = 0.2 + ½·1.
        assert!((eval(&ito.a[1].regular, 0.3, 1.7) - (0.3 + 1.2 * 1.7)).abs() < 1e-14);
        assert!((eval(&ito.a0.regular, 0.3, 1.7) - 0.7).abs() < 1e-14);
    }

    #[test]
    fn a_delta_in_the_noise_matrix_is_refused() {
        let mut m = vibro(Interpretation::Ito);
        m.noise_matrix[1] = vec![Expr::call(Func::Delta, sym("z"))];
        assert!(matches!(
            FpkOperator::derive(&m),
            Err(FpkError::DeltaInNoise { .. })
        ));
    }
}
