//! What the Monte Carlo transient and first passage refuse before any work, shared by both
//! (and kept apart from the stationary run's configuration, which runs a transient pilot).

use super::error::McError;
use crate::model::BoundModel;

/// [`McError::PeriodicState`] for a model with a periodic state: the Monte Carlo transient
/// and first passage refuse one before any work (the stationary run records the state
/// modulo its period, [`super::RunSettings::periodic`]).
pub(super) fn refuse_periodic(model: &BoundModel) -> Result<(), McError> {
    match model.periodic() {
        Some(p) => Err(McError::PeriodicState {
            state: model.states()[p.state].to_string(),
        }),
        None => Ok(()),
    }
}

/// [`McError::StartHeldStill`] for a point start where the drift and the noise both vanish
/// ([`crate::dynamics::Dynamics::holds_still`]): every path would stay there.
pub(super) fn refuse_held_still(
    dynamics: &crate::dynamics::Dynamics,
    [x, v]: [f64; 2],
) -> Result<(), McError> {
    if dynamics.holds_still([x, v]) {
        return Err(McError::StartHeldStill {
            x,
            v,
            beside: x + 1e-6,
        });
    }
    Ok(())
}
