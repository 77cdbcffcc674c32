//! The statistics vocabulary shared by every method: moments of a scalar quantity and a Monte
//! Carlo estimate with its standard error.
//! It sits just above `base` in the stage order and knows nothing of models or methods.

mod estimate;
mod moments;

pub use estimate::Estimate;
pub use moments::Moments;
