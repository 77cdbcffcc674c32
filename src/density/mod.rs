//! The joint density of the two states: the one trait through which every method's solution
//! (EPC, EPC with the impact condition, the grid) is handed to the observables.
//! It sits below the methods in the stage order, so a method implements it without importing
//! the observables that use it.

mod joint;
mod piece;

pub use joint::JointDensity;
pub use piece::{LinePiece, PieceKind};
