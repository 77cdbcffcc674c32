//! The vectorised inner loops: the random increments of each trajectory's own stream, the
//! fused mechanical step of one chunk of lanes and the register-resident mechanical kernel.
//! These are the hot loops; they take what `compile/` built and know nothing of batches.

pub(crate) mod fused;
pub(crate) mod mech;
pub(crate) mod rng;
