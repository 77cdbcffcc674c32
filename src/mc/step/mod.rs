//! A batch of trajectories in flight and the time steps of every scheme: the general
//! schemes' lane loops, Platen's scheme, the fast mechanical path and the barrier events.
//! A step advances states; what is recorded from them is `record/`'s job.

pub(crate) mod events;
pub(crate) mod mech_step;
pub(crate) mod platen;
pub(crate) mod state;
pub(crate) mod timed;

#[cfg(test)]
mod time_tests;
