//! Why a first-passage problem on the grid is refused or fails.

use super::super::{Domain, GridError};
use crate::numerics::timestep::StepError;

/// The errors of [`GridPassage::run`](super::GridPassage::run).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PassageError {
    /// A setting out of its range.
    #[error("{setting} = {value}: expected {expected}")]
    Setting {
        /// The setting.
        setting: &'static str,
        /// Its value as given.
        value: String,
        /// What it must be.
        expected: &'static str,
    },
    /// The start is not inside the safe set.
    #[error("the start ({x}, {v}) is not inside the safe set `{safe}`")]
    StartOutside {
        /// Position.
        x: f64,
        /// Velocity.
        v: f64,
        /// The safe set as written.
        safe: String,
    },
    /// The start lies outside the box the grid covers.
    #[error("the start ({x}, {v}) is outside the grid's box {domain:?}")]
    StartOutsideBox {
        /// Position.
        x: f64,
        /// Velocity.
        v: f64,
        /// The box.
        domain: Domain,
    },
    /// The safe set holds (almost) none of the stationary probability, or no cell of the grid.
    #[error(
        "the safe set `{safe}` holds {mass:e} of the stationary probability on the grid \
         ({cells} cells inside); a first passage from it is immediate or undefined"
    )]
    NoProbability {
        /// The safe set as written.
        safe: String,
        /// The stationary mass inside it.
        mass: f64,
        /// Cells whose centre is inside.
        cells: usize,
    },
    /// The grid could not be built or solved.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The backward (Pontryagin) system could not be solved to the accuracy checked.
    #[error("the mean first-passage system on {nx}x{nv} cells could not be solved: {detail}")]
    Singular {
        /// Cells along x.
        nx: usize,
        /// Cells along v.
        nv: usize,
        /// Why.
        detail: String,
    },
    /// The forward run with killing failed.
    #[error(transparent)]
    Step(#[from] StepError),
}
