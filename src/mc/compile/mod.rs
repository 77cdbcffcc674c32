//! From a bound model to what the time steps run: the scheme chosen for the model, its
//! drift and noise compiled to lane programs, the mechanical form's polynomials, the barriers'
//! compiled impact laws and the stiffness limit on the time step.
//! Nothing here steps a trajectory; `step/` and `kernel/` run what this folder compiles.

pub(crate) mod eval;
pub(crate) mod impact;
pub(crate) mod lanes;
pub(crate) mod mech_form;
pub(crate) mod scheme;
pub(crate) mod step_limit;
pub(crate) mod stiffness;
pub(crate) mod tally;
