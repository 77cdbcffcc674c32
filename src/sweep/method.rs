//! The methods a sweep solves each point by: their settings, and whether each applies to the
//! model before any work.

use crate::grid::{check_cells, Cells, GridError};
use crate::model::BoundModel;
use crate::solve::{Method, MethodName, NotApplicable, Problem};

/// Why a method cannot solve the sweep's model: found before any work
/// ([`crate::sweep::Sweep::check`]) or, when that was skipped, recorded at every point.
#[derive(Clone, Debug, thiserror::Error)]
pub enum MethodRefusal {
    /// The method does not apply to the model.
    #[error(transparent)]
    NotApplicable(NotApplicable),
    /// The grid's cells are out of range.
    #[error(transparent)]
    Cells(GridError),
    /// The grid's box ([`crate::sweep::Sweep::grid_domain`]) is not one, or does not fit the
    /// model's walls at a point (the values named).
    #[error("the box at {at}: {error}")]
    Domain {
        /// The point's values, `name=value` comma-separated.
        at: String,
        /// Why.
        error: GridError,
    },
}

/// The method `name` with the sweep's settings: the one place a method name becomes a
/// [`Method`].
pub(crate) fn settle(name: MethodName, degree: usize, cells: Cells) -> Method {
    name.method().settle(degree, cells.0)
}

/// Whether `method` (named `name`) applies to `model` (bound at one point): the structural
/// refusals only (the model's form, the settings), as the main job decides them
/// ([`crate::solve::StationaryMethod::applies`]), not what depends on the parameter values (a point without a
/// stationary density fails at that point, as data).
pub(crate) fn applies(
    model: &BoundModel,
    name: MethodName,
    method: Method,
) -> Result<(), MethodRefusal> {
    if let Method::Grid { cells } = method {
        check_cells(cells).map_err(MethodRefusal::Cells)?;
    }
    // An operator that cannot be derived here fails at each point, as data.
    let Ok(problem) = Problem::new(model) else {
        return Ok(());
    };
    match name.method().applies(&problem) {
        Ok(Err(why)) => Err(MethodRefusal::NotApplicable(why)),
        _ => Ok(()),
    }
}
