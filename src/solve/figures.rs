//! Each method's own figures of a solution (iterations and residuals, the grid's error
//! estimate): its report as `sweep.json` holds it, and the named values `sweep.csv` tabulates
//! after a point's status, in the order
//! [`StationaryMethod::figure_names`](crate::solve::StationaryMethod::figure_names) gives.

use serde::Serialize;

use crate::epc::{EpcSolution, NormalisationKind};
use crate::epc_impact::EpcImpactReport;
use crate::grid::GridReport;

/// How an EPC solution was reached, in numbers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EpcFigures {
    /// Nonlinear-solver iterations at the target degree.
    pub iterations: usize,
    /// Final Galerkin residual ‖R‖ (scaled variables).
    pub residual: f64,
    /// The bound ‖R‖ had to reach.
    pub residual_threshold: f64,
    /// FPK residual indicator ∫|F|·p dx (0 for an exact solution).
    pub fpk_residual: f64,
    /// How the density was normalised.
    pub normalisation: EpcNormalisation,
}

/// Where an EPC density was normalised, without the normaliser's figures: written as
/// `plane` or `inside_ridge` in the sweep's CSV and JSON.
///
/// ```
/// use fpsolve::sweep::EpcNormalisation;
/// assert_eq!(EpcNormalisation::InsideRidge.to_string(), "inside_ridge");
/// assert_eq!(serde_json::to_string(&EpcNormalisation::Plane).unwrap(), "\"plane\"");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EpcNormalisation {
    /// exp(Q) is integrable on the whole plane.
    Plane,
    /// exp(Q) was normalised inside the ridge around the mode.
    InsideRidge,
}

impl From<&NormalisationKind> for EpcNormalisation {
    fn from(kind: &NormalisationKind) -> Self {
        match kind {
            NormalisationKind::Plane { .. } => EpcNormalisation::Plane,
            NormalisationKind::InsideRidge { .. } => EpcNormalisation::InsideRidge,
        }
    }
}

impl std::fmt::Display for EpcNormalisation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EpcNormalisation::Plane => "plane",
            EpcNormalisation::InsideRidge => "inside_ridge",
        })
    }
}

impl EpcFigures {
    /// The figures of an EPC solution.
    pub fn of(sol: &EpcSolution) -> EpcFigures {
        EpcFigures {
            iterations: sol.solve.iterations,
            residual: sol.solve.residual,
            residual_threshold: sol.solve.residual_threshold,
            fpk_residual: sol.fpk_residual,
            normalisation: EpcNormalisation::from(&sol.normalisation.kind),
        }
    }
}

/// The method's own figures of a solved point: its report, written untagged (the fields of
/// the report itself) in `sweep.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum SolverFigures {
    /// EPC (`epc`).
    Epc(EpcFigures),
    /// EPC with the exact impact condition (`epc-impact`).
    EpcImpact(EpcImpactReport),
    /// The grid solver: cells, domain, clipped negative mass, discretisation-error estimate,
    /// timings.
    Grid(Box<GridReport>),
}

/// One of a method's figures as a table cell holds it.
#[derive(Clone, Debug, PartialEq)]
pub enum Figure {
    /// A count or a word (`12`, `inside_ridge`), written as it is.
    Word(String),
    /// A number, written with every digit.
    Number(f64),
    /// A figure the method did not compute for this solution (an empty cell).
    Missing,
}

impl Figure {
    fn of(value: Option<f64>) -> Figure {
        value.map_or(Figure::Missing, Figure::Number)
    }
}

impl SolverFigures {
    /// The figures' values, in the order of the method's
    /// [`StationaryMethod::figure_names`](crate::solve::StationaryMethod::figure_names).
    ///
    /// ```
    /// use fpsolve::solve::{Figure, MethodName, Problem};
    /// let bound = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\n\
    ///     drift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?.bind(&[])?;
    /// let problem = Problem::new(&bound)?;
    /// let grid = MethodName::Grid.method();
    /// let run = fpsolve::base::run::RunControl::new();
    /// let solution = grid.solve(&problem, grid.settle(0, [40, 40]), &run)?;
    /// let values = solution.figures().values();
    /// assert_eq!(values.len(), grid.figure_names().len());
    /// assert!(matches!(values[0], Figure::Number(m) if m >= 0.0)); // the clipped mass
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn values(&self) -> Vec<Figure> {
        match self {
            SolverFigures::Epc(f) => vec![
                Figure::Word(f.iterations.to_string()),
                Figure::Number(f.residual),
                Figure::Number(f.residual_threshold),
                Figure::Number(f.fpk_residual),
                Figure::Word(f.normalisation.to_string()),
            ],
            SolverFigures::EpcImpact(r) => vec![
                Figure::Word(r.iterations.to_string()),
                Figure::Number(r.residual),
                Figure::Number(r.residual_threshold),
                Figure::of(r.fpk_residual),
                Figure::Number(r.quadrature_change),
                Figure::Word(r.normalisation.to_string()),
            ],
            SolverFigures::Grid(r) => {
                let e = r.discretisation_estimate.as_ref();
                vec![
                    Figure::Number(r.negative_mass),
                    Figure::of(e.map(|e| e.x)),
                    Figure::of(e.map(|e| e.v)),
                ]
            }
        }
    }
}
