//! One method's run in a study: the settings it was asked for, its solution or why there is
//! none, the moments of every quantity and its time. Every method's run has this one shape, so
//! the study, the job and the sweep iterate runs instead of holding a slot per method.

use crate::epc::EpcSolution;
use crate::solve::{Method, MethodName, QuantityMoments, Solution, SolveError};

use super::Source;

/// One method at one setting (a degree of a ladder method, the grid's cells), as a study ran
/// it.
///
/// ```
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// # let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// use fpsolve::solve::{Method, MethodName};
/// let study = fpsolve::study::StudyRunner::new(&bound)
///     .degrees(&[2])
///     .methods(&[MethodName::Epc, MethodName::Grid])
///     .cells([40, 60])
///     .run()?;
/// let grid = study.run_of(MethodName::Grid).unwrap();
/// assert_eq!(grid.method, Method::Grid { cells: [40, 60] });
/// assert_eq!(grid.source().label(), "grid");
/// assert_eq!(study.runs[0].source().label(), "epc_n2");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct Run {
    /// The method and the settings it was asked to solve with.
    pub method: Method,
    /// The solution, or why there is none.
    pub outcome: Result<Solution, SolveError>,
    /// Moments of each state, then each observable (empty when the solve failed).
    pub stats: Vec<QuantityMoments>,
    /// Time of the solve in milliseconds: for a ladder method its degree's closure, assembly,
    /// solver and normalisation; for the others the solve and the moments.
    pub wall_ms: f64,
}

impl Run {
    /// The method's name.
    pub fn name(&self) -> MethodName {
        self.method.name()
    }

    /// The degree, for a ladder method.
    pub fn degree(&self) -> Option<usize> {
        self.method.degree()
    }

    /// Which column its curves fill.
    pub fn source(&self) -> Source {
        Source::of(self.method)
    }

    /// The solution, if it solved.
    pub fn solution(&self) -> Option<&Solution> {
        self.outcome.as_ref().ok()
    }

    /// The EPC solution, if this is an EPC run that converged.
    pub fn epc(&self) -> Option<&EpcSolution> {
        self.solution().and_then(Solution::epc)
    }
}
