//! One error type for the whole pipeline, wrapping each stage's own typed error.

/// Any failure of fpsolve, by the stage it happened in.
///
/// ```
/// use fpsolve::model::parse_model;
/// fn load(text: &str) -> Result<fpsolve::model::Model, fpsolve::Error> {
///     Ok(parse_model(text, None)?)
/// }
/// let err = load("model m\nstate x\n").unwrap_err();
/// assert!(matches!(err, fpsolve::Error::Model(_)));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading, parsing or validating a model file.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// A `name=value` override that does not parse.
    #[error(transparent)]
    Set(#[from] crate::model::SetError),
    /// Binding parameters to values.
    #[error(transparent)]
    Bind(#[from] crate::model::BindError),
    /// A symbolic operation.
    #[error(transparent)]
    Symbolic(#[from] crate::symbolic::SymbolicError),
    /// Deriving the Fokker–Planck operator.
    #[error(transparent)]
    Fpk(#[from] crate::fpk::FpkError),
    /// The EPC engine.
    #[error(transparent)]
    Epc(#[from] crate::epc::EpcError),
    /// The Monte Carlo simulator.
    #[error(transparent)]
    Mc(#[from] crate::mc::McError),
    /// The front door: no solution, or a name that is no quantity.
    #[error(transparent)]
    Solve(#[from] crate::solve::SolveError),
    /// A sweep's description or its binding.
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
    /// A study.
    #[error(transparent)]
    Study(#[from] crate::study::StudyError),
    /// A job of the command line.
    #[error(transparent)]
    Job(#[from] crate::job::JobError),
    /// Writing results.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
}
