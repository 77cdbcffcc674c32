//! A solution: a joint density, the method's typed report, and the quantities it knows.

use std::sync::Arc;

use serde::Serialize;

use crate::density::JointDensity;
use crate::epc::EpcSolution;
use crate::epc_impact::EpcImpactSolution;
use crate::grid::GridSolution;
use crate::observe::{moments_of_all, ObservableDensity, PointMass};
use crate::stats::Moments;

use super::{common_grid, printable, EpcFigures, Method, Quantity, SolveError, SolverFigures};

/// The joint density a method produced, with that method's own report (iterations,
/// residuals, normalisation, …). More methods are to come.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Density {
    /// An EPC solution (its density and its [`crate::epc::SolveReport`]).
    Epc(Box<EpcSolution>),
    /// A grid solution (cell densities and its [`crate::grid::GridReport`]).
    Grid(Box<GridSolution>),
    /// An EPC solution with the exact impact condition (its density and its
    /// [`crate::epc_impact::EpcImpactReport`]).
    EpcImpact(Box<EpcImpactSolution>),
}

/// A solved stationary density and every state and observable of the model, by name.
///
/// Built by [`crate::solve()`] or [`super::Problem`]; see the module documentation for the
/// five lines that get a PDF.
#[derive(Clone, Debug)]
pub struct Solution {
    density: Density,
    quantities: Arc<[Quantity]>,
    /// The names of the joint density's coordinates (see [`Solution::joint_states`]).
    joint_states: [String; 2],
}

/// The moments of one state or observable under a solution, from the joint density directly
/// (E\[g^k\] = ∬ g^k p, see [`crate::observe::moments`]), not from its PDF curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QuantityMoments {
    /// The quantity's name.
    pub name: String,
    /// Mean, variance, kurtosis and E\[g\] … E\[g⁴\] (given g defined); a moment that does
    /// not exist, and every statistic built on it, is NaN (`null` in JSON).
    #[serde(flatten)]
    pub moments: Moments,
    /// P(g has no finite value), e.g. P(z ≤ 0) for `log(z)`: 0 for an observable defined
    /// everywhere. When it is positive the observable's PDF integrates to 1 − this (it is not
    /// renormalised) and the moments are those of g given that it is defined.
    pub undefined_mass: f64,
    /// How many of the raw moments exist (0 to 4), never a number the quadrature happened to
    /// give for a divergent integral.
    pub existing_moments: usize,
    /// The values g takes with positive probability (g constant on a region: `max(z, 0)` is
    /// 0 on z < 0): there g has no density, and its PDF is that of the rest, integrating to
    /// 1 − their sum. Empty for almost every observable.
    pub point_masses: Vec<PointMass>,
    /// The method's own estimate of the discretisation errors of the mean, standard
    /// deviation and kurtosis (the grid's, from its half-resolution solve); absent for a
    /// method without one (EPC's closure error has no estimate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub errors: Option<MomentErrors>,
}

/// The relative rounding error of moments summed over a quadrature's nodes, added to a
/// method's estimate of their discretisation errors.
const ROUNDING: f64 = 1e-12;

/// Bounds on the discretisation errors of a quantity's moments, as a method estimates them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MomentErrors {
    /// Of the mean.
    pub mean: f64,
    /// Of the standard deviation.
    pub std_dev: f64,
    /// Of the kurtosis.
    pub kurtosis: f64,
}

impl QuantityMoments {
    /// √Var\[g\].
    pub fn std_dev(&self) -> f64 {
        self.moments.std_dev()
    }

    /// A warning in words when the quantity is undefined on part of the support (its
    /// `undefined_mass` is positive) or has fewer than four moments, for tables and logs;
    /// `None` otherwise.
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// let text = "model m
    /// param c = 0.1
    /// state z, v
    /// drift z: v
    /// drift v: -c*v - z
    /// noise xi: intensity 1
    /// diffusion v: xi
    /// observe l = log(z)
    /// ";
    /// let bound = parse_model(text, None)?.bind(&[])?;
    /// let solution = fpsolve::solve(&bound, fpsolve::Method::Epc { degree: 2 })?;
    /// let l = solution.moments("l")?;
    /// assert!((l.undefined_mass - 0.5).abs() < 1e-9);
    /// assert!(l.note().unwrap().contains("no finite value with probability 0.5"));
    /// assert!(solution.moments("z")?.note().is_none()); // z is defined everywhere
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn note(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.undefined_mass > 0.0 {
            parts.push(format!(
                "`{}` has no finite value with probability {:.3}: its PDF integrates to {:.3} \
                 (not renormalised) and its moments are conditional on it being defined",
                self.name,
                self.undefined_mass,
                1.0 - self.undefined_mass
            ));
        }
        if !self.point_masses.is_empty() {
            let atoms: Vec<String> = self
                .point_masses
                .iter()
                .map(|m| format!("{} with probability about {:.2}", m.value, m.probability))
                .collect();
            let rest = 1.0 - self.point_masses.iter().map(|m| m.probability).sum::<f64>();
            parts.push(format!(
                "`{}` is constant on part of the plane: it equals {} (point masses, which \
                 have no density), so its PDF is that of the rest and integrates to about {:.2}; \
                 its moments include them",
                self.name,
                atoms.join(" and "),
                rest
            ));
        }
        if self.existing_moments < 4 {
            let k = self.existing_moments + 1;
            parts.push(format!(
                "E[|{}|^{k}] is not established as finite (its integral diverges, or has a \
                 singularity the quadrature does not resolve): {} undefined",
                self.name,
                match k {
                    1 => "the mean, standard deviation and kurtosis are",
                    2 => "the standard deviation and kurtosis are",
                    _ => "the kurtosis is",
                }
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }
}

/// The exponents (i, j) and the coefficients a_ij of a polynomial Σ a_ij x1^i x2^j.
pub type Polynomial<'a> = (&'a [(usize, usize)], &'a [f64]);

impl Solution {
    pub(crate) fn new(density: Density, quantities: Arc<[Quantity]>) -> Solution {
        let mut states = quantities
            .iter()
            .filter(|q| q.is_state)
            .map(|q| q.name.clone());
        let joint_states = [
            states.next().unwrap_or_default(),
            states.next().unwrap_or_default(),
        ];
        Solution {
            density,
            quantities,
            joint_states,
        }
    }

    /// The same solution, its joint density over the states `names` (the Zhuravlev
    /// transform's, for the δ-term EPC of a model in its own coordinates).
    pub(crate) fn over(mut self, names: [String; 2]) -> Solution {
        self.joint_states = names;
        self
    }

    /// The names of [`Solution::joint`]'s two coordinates: the model's states, except for the
    /// δ-term EPC of a model with a wall in its own coordinates, which solves the Zhuravlev
    /// transform: its joint density is over the transform's states (z, v), and the model's
    /// states are quantities mapped through them (`y = |z|`), read with
    /// [`Solution::pdf`](Solution::pdf).
    ///
    /// ```
    /// use fpsolve::solve::{solve, Method};
    /// let bound = fpsolve::model::parse_model("model m\nparam c = 0.2\nstate y, w\n\
    ///     drift y: w\ndrift w: -c*w - y\nnoise xi: intensity 1\ndiffusion w: xi\n\
    ///     impact y = 0: w -> -0.9*w\ndomain y >= 0\n", None)?.bind(&[])?;
    /// let epc = solve(&bound, Method::Epc { degree: 2 })?;
    /// assert_eq!(epc.joint_states(), ["z", "v"]);
    /// let grid = solve(&bound, Method::Grid { cells: [40, 80] })?;
    /// assert_eq!(grid.joint_states(), ["y", "w"]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn joint_states(&self) -> [&str; 2] {
        [&self.joint_states[0], &self.joint_states[1]]
    }

    /// The method that produced the density.
    pub fn method(&self) -> Method {
        match &self.density {
            Density::Epc(s) => Method::Epc { degree: s.degree },
            Density::Grid(g) => Method::Grid {
                cells: g.report.cells,
            },
            Density::EpcImpact(s) => Method::EpcImpact { degree: s.degree },
        }
    }

    /// The density with its method's report.
    pub fn density(&self) -> &Density {
        &self.density
    }

    /// The EPC solution, when EPC produced the density.
    pub fn epc(&self) -> Option<&EpcSolution> {
        match &self.density {
            Density::Epc(s) => Some(s),
            Density::Grid(_) | Density::EpcImpact(_) => None,
        }
    }

    /// The EPC-impact solution behind this one, when it was solved by
    /// [`Method::EpcImpact`](crate::solve::Method::EpcImpact).
    pub fn epc_impact(&self) -> Option<&crate::epc_impact::EpcImpactSolution> {
        match &self.density {
            Density::EpcImpact(s) => Some(s),
            Density::Epc(_) | Density::Grid(_) => None,
        }
    }

    /// The time the method's own report gives for the solve, in milliseconds (EPC: closure,
    /// assembly, solver and normalisation of this degree; the grid: its whole solve).
    pub fn solve_ms(&self) -> f64 {
        match &self.density {
            Density::Epc(s) => {
                let r = &s.solve;
                r.closure_ms + r.assembly_ms + r.solve_ms + r.normalise_ms
            }
            Density::EpcImpact(s) => s.report.solve_ms,
            Density::Grid(g) => g.report.timings.total_ms,
        }
    }

    /// The method's own figures of the solution (its report as a sweep keeps it).
    pub fn figures(&self) -> SolverFigures {
        match &self.density {
            Density::Epc(s) => SolverFigures::Epc(EpcFigures::of(s)),
            Density::Grid(g) => SolverFigures::Grid(Box::new(g.report.clone())),
            Density::EpcImpact(s) => SolverFigures::EpcImpact(s.report.clone()),
        }
    }

    /// The grid solution (cell densities and the solver's report), when the grid produced
    /// the density.
    pub fn grid(&self) -> Option<&GridSolution> {
        match &self.density {
            Density::Grid(g) => Some(g),
            Density::Epc(_) | Density::EpcImpact(_) => None,
        }
    }

    /// The exponents (i, j) and coefficients a_ij of the exponent Q(x1, x2) = Σ a_ij x1^i x2^j
    /// of p = C·exp(Q), for a method whose density is one (EPC, EPC-impact); `None` for a
    /// density on cells.
    ///
    /// ```
    /// use fpsolve::solve::{solve, Method};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let epc = solve(&bound, Method::Epc { degree: 2 })?;
    /// let (exponents, coefficients) = epc.polynomial().unwrap();
    /// assert_eq!(exponents.len(), coefficients.len());
    /// assert!(solve(&bound, Method::Grid { cells: [40, 80] })?.polynomial().is_none());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn polynomial(&self) -> Option<Polynomial<'_>> {
        match &self.density {
            Density::Epc(s) => Some((&s.exponents, &s.coefficients)),
            Density::EpcImpact(s) => Some((&s.exponents, &s.coefficients)),
            Density::Grid(_) => None,
        }
    }

    /// The method's own account of the solve as JSON: the EPC solution (coefficients, σ,
    /// iterations, residual, normalisation, timings, moments), the EPC-impact solution, or
    /// the grid's report.
    ///
    /// # Errors
    /// When serialisation fails (it does not for the solutions the methods return).
    ///
    /// ```
    /// use fpsolve::solve::{solve, Method};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let json = solve(&bound, Method::Grid { cells: [40, 80] })?.report_json()?;
    /// assert!(json.contains("\"cells\""));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn report_json(&self) -> serde_json::Result<String> {
        match &self.density {
            Density::Epc(s) => serde_json::to_string(s.as_ref()),
            Density::EpcImpact(s) => serde_json::to_string(s.as_ref()),
            Density::Grid(g) => serde_json::to_string(&g.report),
        }
    }

    /// The joint density p(x1, x2) over the states [`Solution::joint_states`] names.
    pub fn joint(&self) -> &dyn JointDensity {
        match &self.density {
            Density::Epc(s) => s.as_ref(),
            Density::Grid(g) => g.as_ref(),
            Density::EpcImpact(s) => s.as_ref(),
        }
    }

    /// The states, then the observables.
    pub fn quantities(&self) -> &[Quantity] {
        &self.quantities
    }

    /// The state or observable called `name`.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`] naming the quantities there are.
    pub fn quantity(&self, name: &str) -> Result<&Quantity, SolveError> {
        self.quantities
            .iter()
            .find(|q| q.name == name)
            .ok_or_else(|| SolveError::UnknownQuantity {
                name: name.to_string(),
                known: self.quantities.iter().map(|q| q.name.clone()).collect(),
            })
    }

    /// The PDF of `name` at the points `x` (Eqs. 23–28 for observables): +∞ at a saddle or
    /// degenerate critical value of an observable, NaN everywhere when it cannot be computed.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`].
    pub fn pdf(&self, name: &str, x: &[f64]) -> Result<Vec<f64>, SolveError> {
        let q = self.quantity(name)?;
        Ok(ObservableDensity::new(self.joint(), &q.map).pdf(x))
    }

    /// The PDF of `name` on the grid the reports use (401 points reaching 1e−8 of its peak,
    /// starting at 0 for a quantity like |z|), NaN where the density is infinite; empty when
    /// the density has no such window.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`].
    pub fn marginal(&self, name: &str) -> Result<(Vec<f64>, Vec<f64>), SolveError> {
        let q = self.quantity(name)?;
        let density = ObservableDensity::new(self.joint(), &q.map);
        let x = common_grid(&[(self.joint(), &q.map, &density)]);
        let p = printable(density.pdf(&x));
        Ok((x, p))
    }

    /// P(g > a) for the quantity g = `name`, from its PDF on the [`marginal`](Self::marginal)
    /// grid (log-linear between grid points, the exponential decay of the last cell continued
    /// beyond the grid, normalised by the curve's own mass): 1 for `a` below every value,
    /// never more; `None` when `a` lies at or beyond the grid's upper end, where the curve
    /// does not resolve the tail. The crate's one tail routine (the sweep's two-sided
    /// P(|g| > a) columns use the same rule). Measured for a Gaussian on its 401-point report
    /// grid: relative error below 1e−6 out to 4σ, 5e−5 at 5σ.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`].
    ///
    /// ```
    /// use fpsolve::model::parse_model;
    /// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
    /// let solution = fpsolve::solve(&model.bind(&[])?, fpsolve::Method::Epc { degree: 2 })?;
    /// // z is standard normal: P(z > 2) = 0.02275, P(z > −2) = 0.97725.
    /// let p = solution.tail_probability("z", 2.0)?.unwrap();
    /// assert!((p - 0.02275).abs() < 1e-4);
    /// let q = solution.tail_probability("z", -2.0)?.unwrap();
    /// assert!((q - 0.97725).abs() < 1e-4);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn tail_probability(&self, name: &str, a: f64) -> Result<Option<f64>, SolveError> {
        let (x, p) = self.marginal(name)?;
        Ok(super::tail_probability(&x, &p, a))
    }

    /// The moments of `name`, from the joint density directly.
    ///
    /// # Errors
    /// [`SolveError::UnknownQuantity`].
    pub fn moments(&self, name: &str) -> Result<QuantityMoments, SolveError> {
        let q = self.quantity(name)?;
        Ok(self.moments_of(&[q]).remove(0))
    }

    /// The moments of every state, then every observable (the density evaluated once for all).
    pub fn all_moments(&self) -> Vec<QuantityMoments> {
        let all: Vec<&Quantity> = self.quantities.iter().collect();
        self.moments_of(&all)
    }

    fn moments_of(&self, quantities: &[&Quantity]) -> Vec<QuantityMoments> {
        let maps: Vec<_> = quantities.iter().map(|q| &q.map).collect();
        // Mean, std and kurtosis of every quantity, as the estimate takes them.
        let statistics = |all: &[crate::observe::ObservableMoments]| -> Vec<f64> {
            all.iter()
                .flat_map(|m| [m.moments.mean, m.moments.std_dev(), m.moments.kurtosis])
                .collect()
        };
        let all = moments_of_all(self.joint(), &maps);
        // The same statistics under the method's other solve (the grid's half resolution):
        // the estimate of their errors, as for the curves.
        let derive = |d: &dyn JointDensity| statistics(&moments_of_all(d, &maps));
        let values = statistics(&all);
        let estimates = self
            .method()
            .name()
            .method()
            .estimate_derived(self, &values, &derive);
        all.into_iter()
            .zip(quantities)
            .enumerate()
            .map(|(i, (m, q))| QuantityMoments {
                name: q.name.clone(),
                moments: m.moments,
                undefined_mass: m.undefined_mass,
                existing_moments: m.existing,
                point_masses: m.point_masses,
                // Plus the rounding of the sums (the quadrature is exact for the
                // interpolant): 1e−12 of each statistic's scale.
                errors: estimates.as_ref().map(|e| {
                    let (sd, kurt) = (m.moments.std_dev(), m.moments.kurtosis);
                    MomentErrors {
                        mean: e[3 * i] + ROUNDING * (m.moments.mean.abs() + sd),
                        std_dev: e[3 * i + 1] + ROUNDING * sd,
                        kurtosis: e[3 * i + 2] + ROUNDING * kurt.abs(),
                    }
                }),
            })
            .collect()
    }
}
