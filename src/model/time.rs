//! Whether a model's equations depend on the time `t` ([`super::TIME`]).

use super::{BoundModel, Model, TIME};
use crate::symbolic::Expr;

/// Whether any of `exprs` mentions the time.
fn mentions_time<'e>(mut exprs: impl Iterator<Item = &'e Expr>) -> bool {
    exprs.any(|e| e.symbols().iter().any(|s| &**s == TIME))
}

impl Model {
    /// Whether a drift or diffusion line mentions the time `t`: such a model has no
    /// stationary density, and only a transient method can solve it.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// assert!(!fpsolve::model::load_model(&path).unwrap().time_dependent());
    /// ```
    pub fn time_dependent(&self) -> bool {
        mentions_time(self.drift.iter().chain(self.noise_matrix.iter().flatten()))
    }
}

impl BoundModel {
    /// Whether a drift or diffusion line mentions the time `t` (as [`Model::time_dependent`]).
    ///
    /// ```
    /// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\n\
    ///             noise xi: intensity 1\ndiffusion v: exp(-t)*xi\n";
    /// let bound = fpsolve::model::parse_model(text, None).unwrap().bind(&[]).unwrap();
    /// assert!(bound.time_dependent());
    /// ```
    pub fn time_dependent(&self) -> bool {
        mentions_time(self.drift.iter().chain(self.noise_matrix.iter().flatten()))
    }
}
