//! Why a first-passage problem on the grid is refused or fails.

use super::super::{Domain, GridError};
use crate::dynamics::Inadmissible;
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
    /// The model has no stationary density and no box was given: the grid's box is sized
    /// from that density ([`GridPassage::domain`](super::GridPassage::domain) gives one).
    #[error(
        "{reason}; a first passage out of a set bounded in the position still has a mean \
         time, but the grid sizes its box from the stationary density: give the box (`--domain \
         x=LO:HI,v=LO:HI`, Python's `domain=`, the library's `GridPassage::domain`), or run \
         Monte Carlo alone (`--method mc --horizon T`)"
    )]
    NoBox {
        /// Why the model has no stationary density.
        reason: Inadmissible,
    },
    /// A model without a stationary density whose safe set does not end inside the box
    /// along the position: the box, not the model, would bound the passage time.
    #[error(
        "the model has no stationary density and the safe set `{safe}` reaches the grid's box \
         at x = {edge}: without one the set must end inside the box along the position on both \
         sides (out of a set open along it the mean passage time may be infinite)"
    )]
    NotBounded {
        /// The safe set as written.
        safe: String,
        /// The box's end in x the set reaches.
        edge: f64,
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
