//! The methods a sweep solves each point by: their settings, and whether each applies to the
//! model before any work.

use std::fmt;
use std::str::FromStr;

use crate::epc::EpcError;
use crate::grid::{check_cells, GridError, GridSolver};
use crate::model::BoundModel;
use crate::physics::ImpactForm;
use crate::solve::{Method, MethodName, Problem};

/// Cells per axis of the grid method, as `--cells NX,NV` writes them.
///
/// ```
/// use fpsolve::sweep::Cells;
/// let cells: Cells = "100, 200".parse()?;
/// assert_eq!(cells.0, [100, 200]);
/// assert_eq!(cells.to_string(), "100,200");
/// assert!("100".parse::<Cells>().is_err());
/// assert!("100,199".parse::<Cells>().is_err()); // odd: the error estimate halves the cells
/// # Ok::<(), fpsolve::sweep::CellsError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cells(pub [usize; 2]);

impl Default for Cells {
    /// [`crate::grid::DEFAULT_CELLS`].
    fn default() -> Self {
        Cells(crate::grid::DEFAULT_CELLS)
    }
}

/// Why a `--cells` argument is not two cell counts the grid solver accepts.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CellsError {
    /// Not two comma-separated whole numbers.
    #[error("`{text}`: expected NX,NV (two whole numbers, e.g. 140,280)")]
    Format {
        /// The argument.
        text: String,
    },
    /// Two numbers the grid solver refuses (odd, or fewer than 8).
    #[error(transparent)]
    Refused(GridError),
}

impl FromStr for Cells {
    type Err = CellsError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let format = || CellsError::Format { text: s.into() };
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let [nx, nv] = parts.as_slice() else {
            return Err(format());
        };
        let cells = [
            nx.parse().map_err(|_| format())?,
            nv.parse().map_err(|_| format())?,
        ];
        check_cells(cells).map_err(CellsError::Refused)?;
        Ok(Cells(cells))
    }
}

impl fmt::Display for Cells {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.0[0], self.0[1])
    }
}

/// Why a method cannot solve the sweep's model: found before any work
/// ([`crate::sweep::Sweep::check`]) or, when that was skipped, recorded at every point.
#[derive(Clone, Debug, thiserror::Error)]
pub enum MethodRefusal {
    /// The method is named but not built into this version of fpsolve.
    #[error("`{method}` is not available in this version of fpsolve")]
    NotAvailable {
        /// The method.
        method: MethodName,
    },
    /// EPC cannot represent the model (an impact law it has no form for).
    #[error(transparent)]
    Epc(EpcError),
    /// The grid solver does not handle the model, or its cells are out of range.
    #[error(transparent)]
    Grid(GridError),
}

/// The method `name` with the sweep's settings: the one place a method name becomes a
/// [`Method`].
pub(crate) fn settle(
    name: MethodName,
    degree: usize,
    cells: Cells,
) -> Result<Method, MethodRefusal> {
    match name {
        MethodName::Epc => Ok(Method::Epc { degree }),
        MethodName::Grid => Ok(Method::Grid { cells: cells.0 }),
        // Until the front door has `Method::EpcImpact { degree }`: this arm becomes
        // `Ok(Method::EpcImpact { degree })`.
        MethodName::EpcImpact => Err(MethodRefusal::NotAvailable { method: name }),
    }
}

/// Whether `method` applies to `model` (bound at one point): the structural refusals only
/// (the model's form, the settings), not what depends on the parameter values (a point
/// without a stationary density fails at that point, as data).
pub(crate) fn applies(model: &BoundModel, method: Method) -> Result<(), MethodRefusal> {
    match method {
        Method::Epc { .. } => {
            // A model EPC cannot represent; an operator that cannot be derived here fails at
            // each point as before.
            let Ok(problem) = Problem::new(model) else {
                return Ok(());
            };
            match &problem.fpk().impact {
                Some(ImpactForm::Unsupported { law, reason }) => {
                    Err(MethodRefusal::Epc(EpcError::UnsupportedImpact {
                        law: law.clone(),
                        reason: reason.clone(),
                    }))
                }
                _ => Ok(()),
            }
        }
        Method::Grid { cells } => match GridSolver::new(model).cells(cells[0], cells[1]).check() {
            Err(
                e @ (GridError::Setting { .. }
                | GridError::Unsupported { .. }
                | GridError::Symbolic { .. }),
            ) => Err(MethodRefusal::Grid(e)),
            _ => Ok(()),
        },
    }
}
