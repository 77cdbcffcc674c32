//! What a sweep reports: per point, per method, the statistics of every quantity or the
//! reason there are none.

use serde::Serialize;

use crate::dynamics::Inadmissible;
use crate::grid::GridReport;
use crate::model::number;
use crate::report::Provenance;
use crate::solve::{EpcFigures, SolverFigures};
use crate::solve::{Method, MethodName, MethodSet, SolveError};
use crate::stats::Moments;

use super::MethodRefusal;

/// Statistics of one state or observable at one point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointStats {
    /// The quantity's name.
    pub name: String,
    /// Mean, variance, kurtosis and raw moments (all finite at a converged point).
    #[serde(flatten)]
    pub moments: Moments,
    /// P(|g| > a) for each threshold a of [`SweepResult::tail_thresholds`] (empty when no
    /// threshold could be set); `None` where a lies beyond the tabulated PDF on both sides
    /// (the density there is below about 1e−8 of its peak, so the tail is not resolved).
    /// Accurate to a few per mille while P ≳ 1e−7; smaller values lean on an exponential
    /// continuation of the curve beyond its last point and are good to a few per cent.
    pub tail: Vec<Option<f64>>,
}

/// A point that one method solved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointSolution {
    /// How the method got there.
    #[serde(flatten)]
    pub solver: SolverFigures,
    /// Statistics of each state, then each observable.
    pub stats: Vec<PointStats>,
}

impl PointSolution {
    /// The EPC figures, when EPC solved the point.
    pub fn epc(&self) -> Option<&EpcFigures> {
        match &self.solver {
            SolverFigures::Epc(f) => Some(f),
            _ => None,
        }
    }

    /// The grid solver's report, when the grid solver solved the point.
    pub fn grid(&self) -> Option<&GridReport> {
        match &self.solver {
            SolverFigures::Grid(r) => Some(r.as_ref()),
            _ => None,
        }
    }

    /// The statistics of the quantity `name`.
    pub fn stats_of(&self, name: &str) -> Option<&PointStats> {
        self.stats.iter().find(|s| s.name == name)
    }
}

/// What happened at one point with one method.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
// A sweep holds one outcome per point and method (hundreds at most), most of them solved:
// the grid's report inline costs less than a box per point would.
#[allow(clippy::large_enum_variant)]
pub enum PointOutcome {
    /// The method solved the point (EPC: converged at the target degree).
    Converged(PointSolution),
    /// The method has no answer at this point; the other methods and points are unaffected.
    Failed(PointFailure),
    /// The point has no stationary density (found before any point was solved, as a single
    /// run refuses such parameters): no method solved it; the other points are unaffected.
    Refused(PointRefusal),
}

/// Why a point was not solved by any method: its parameters leave the model without a
/// stationary density ([`crate::dynamics::check`], the check a single run makes before any
/// work). `Display` gives the message of `sweep.csv`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(transparent)]
pub struct PointRefusal(pub Inadmissible);

impl PointRefusal {
    /// The stage that refused the point, as `sweep.csv` names it: `admissibility`.
    pub fn stage(&self) -> &'static str {
        "admissibility"
    }
}

/// In `sweep.json` a refusal is its stage and its message.
impl Serialize for PointRefusal {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("PointRefusal", 2)?;
        st.serialize_field("stage", self.stage())?;
        st.serialize_field("message", &self.to_string())?;
        st.end()
    }
}

/// Why a method has no solution at a point, by the stage that failed. `Display` gives the
/// message of `sweep.csv`; [`PointFailure::stage`] its `stage` column; the method is that of
/// the [`MethodOutcome`] holding it.
#[derive(Clone, Debug, thiserror::Error)]
pub enum PointFailure {
    /// The parameters could not be bound at this point (e.g. a negative intensity).
    #[error(transparent)]
    Bind(crate::model::BindError),
    /// The FPK operator could not be derived.
    #[error(transparent)]
    Derive(crate::fpk::FpkError),
    /// A method failed (or found no stationary density at this point): `method` with the
    /// settings it failed at (for a ladder method, the first degree that failed: degree 2
    /// failing is why the target degree has no solution either).
    #[error("{}", method_failure(method, error))]
    Method {
        /// The method and the settings it failed at.
        method: Method,
        /// Why.
        #[source]
        error: Box<SolveError>,
    },
    /// The Zhuravlev transform EPC solves a reflecting barrier through could not be derived.
    #[error(transparent)]
    Zhuravlev(crate::transform::ZhuravlevError),
    /// The method does not apply to the model (when [`super::Sweep::check`] was not asked
    /// first; the command line refuses such a sweep before any work).
    #[error(transparent)]
    Refused(MethodRefusal),
    /// No PDF of a quantity could be tabulated (its density has no window above 1e−8 of its
    /// peak).
    #[error("no PDF of `{quantity}` could be tabulated")]
    NoCurve {
        /// The quantity.
        quantity: String,
    },
    /// A statistic of a quantity has no finite value.
    #[error(
        "statistics of `{quantity}` are not finite (mean {}, std dev {}, kurtosis {})",
        number(*mean),
        number(*std_dev),
        number(*kurtosis)
    )]
    NotFinite {
        /// The quantity.
        quantity: String,
        /// Its mean.
        mean: f64,
        /// Its standard deviation.
        std_dev: f64,
        /// Its kurtosis.
        kurtosis: f64,
    },
}

impl PointFailure {
    /// The stage that failed, as `sweep.csv` names it: `bind`, `fpk`, `epc`, `grid`,
    /// `method` or `statistics`.
    pub fn stage(&self) -> &'static str {
        match self {
            PointFailure::Bind(_) => "bind",
            PointFailure::Derive(_) => "fpk",
            PointFailure::Method { method, .. } => method.name().as_str(),
            PointFailure::Zhuravlev(_) => "fpk",
            PointFailure::Refused(_) => "method",
            PointFailure::NoCurve { .. } | PointFailure::NotFinite { .. } => "statistics",
        }
    }
}

/// A method's failure as `sweep.csv` words it: the degree first for a ladder method.
fn method_failure(method: &Method, error: &SolveError) -> String {
    match method.degree() {
        Some(degree) => format!("degree {degree}: {error}"),
        None => error.to_string(),
    }
}

/// In `sweep.json` a failure is its stage and its message.
impl Serialize for PointFailure {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("PointFailure", 2)?;
        st.serialize_field("stage", self.stage())?;
        st.serialize_field("message", &self.to_string())?;
        st.end()
    }
}

/// One method's outcome at one point.
#[derive(Clone, Debug, Serialize)]
pub struct MethodOutcome {
    /// The method.
    pub method: MethodName,
    /// Its statistics, or why there are none.
    #[serde(flatten)]
    pub outcome: PointOutcome,
    /// Wall time of this method at this point in milliseconds.
    pub wall_ms: f64,
}

/// One point of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepPoint {
    /// The swept parameters' values, in the order of [`SweepResult::parameters`].
    pub values: Vec<f64>,
    /// One outcome per method, in the order of [`SweepResult::methods`].
    pub outcomes: Vec<MethodOutcome>,
    /// Wall time of the whole point (every method) in milliseconds.
    pub wall_ms: f64,
}

impl SweepPoint {
    /// The outcome of `method` at this point (`None` when the sweep did not ask for it).
    pub fn outcome(&self, method: MethodName) -> Option<&PointOutcome> {
        self.outcomes
            .iter()
            .find(|o| o.method == method)
            .map(|o| &o.outcome)
    }

    /// The solution of `method` at this point, if it solved it.
    pub fn solution(&self, method: MethodName) -> Option<&PointSolution> {
        match self.outcome(method)? {
            PointOutcome::Converged(s) => Some(s),
            PointOutcome::Failed(_) | PointOutcome::Refused(_) => None,
        }
    }
}

/// The thresholds a of P(|g| > a) for one quantity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TailThresholds {
    /// The quantity's name.
    pub name: String,
    /// √E\[g²\] at the reference point ([`SweepResult::threshold_point`]) under the reference
    /// method ([`SweepResult::threshold_method`]; for EPC its degree-2 solution).
    pub rms: f64,
    /// [`super::TAIL_MULTIPLES`] × `rms`.
    pub thresholds: Vec<f64>,
}

/// A finished sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepResult {
    /// Where the result came from: version, schema, command, time, the model's text, threads
    /// (`None` inside a shard, whose file carries its own, and in a merge until the merge
    /// writes its own).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    /// The model's name.
    pub model: String,
    /// The methods every point was solved by.
    pub methods: MethodSet,
    /// The EPC degree every point was solved at (by `epc` and `epc-impact`).
    pub degree: usize,
    /// The grid solver's cells (position, velocity), when `grid` is among the methods.
    pub cells: Option<[usize; 2]>,
    /// The swept parameters' names.
    pub parameters: Vec<String>,
    /// The fixed overrides, as `name=expr`.
    pub fixed: Vec<String>,
    /// The states, then the observables: the order of [`PointSolution::stats`].
    pub quantities: Vec<String>,
    /// The observables (the states when the model declares none): what the figures show.
    pub figure_quantities: Vec<String>,
    /// The method whose solutions set the tail thresholds: the first of
    /// [`methods`](Self::methods) that solved any point (for EPC, its degree-2 solution,
    /// the Gaussian closure, gives the values); the first method when none did.
    pub threshold_method: MethodName,
    /// Index of the point whose solution set the tail thresholds: the first point, in the
    /// sweep's order, that the threshold method solved (for EPC: converged at the target
    /// degree). `None` when no method solved any point: then there are no thresholds, no
    /// tail columns and no tail figures.
    pub threshold_point: Option<usize>,
    /// Tail thresholds per quantity, fixed for the whole sweep and every method so that
    /// curves are comparable.
    pub tail_thresholds: Vec<TailThresholds>,
    /// One entry per point, in the order of [`super::SweepSpec::points`].
    pub points: Vec<SweepPoint>,
    /// Total wall time in milliseconds.
    pub wall_ms: f64,
}
