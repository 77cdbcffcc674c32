//! Points where a path of the SDE never moves: the drift and the noise both vanish there
//! exactly, as at rest in a Zhuravlev form (z = 0, v = 0: the noise sgn(z)·ξ has sgn(0) = 0
//! and the drift −k z − c v is 0), so a simulation started there stays for ever. The law of
//! such a start is a point mass at rest; what a user asks of it (a density spreading from
//! rest, a first passage) is the limit of starts beside it, which a simulation cannot give.

use super::probe::{at, diffusion};
use super::Dynamics;

impl Dynamics {
    /// Whether a path started at `x` stays there: the Itô drift (deltas as zero: the
    /// impact term a simulation replaces by its law, which keeps v = 0 at 0) and the
    /// diffusion matrix are exactly 0 at `x`. A model whose coefficients depend on the time
    /// is never held still here (its coefficients at one time do not decide), nor is one
    /// whose Itô drift has no meaning.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
    /// assert!(dynamics.holds_still([0.0, 0.0]));
    /// assert!(!dynamics.holds_still([1e-6, 0.0]));
    /// assert!(!dynamics.holds_still([0.0, 1e-6]));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn holds_still(&self, x: [f64; 2]) -> bool {
        let Ok(m) = self.ito_drift() else {
            return false;
        };
        let states = self.states();
        // NaN (a t, a value undefined there) is not 0: such a point is not held.
        let drift_zero = m.iter().all(|e| at(e, states, x) == 0.0);
        drift_zero && diffusion(self.model(), x).iter().all(|b| *b == 0.0)
    }
}

#[cfg(test)]
mod tests {
    use crate::dynamics::Dynamics;
    use crate::model::parse_model;

    fn read(text: &str) -> Dynamics {
        Dynamics::read(&parse_model(text, None).unwrap().bind(&[]).unwrap())
    }

    #[test]
    fn additive_noise_never_holds() {
        let d = read(
            "model m\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
             diffusion v: xi\n",
        );
        assert!(!d.holds_still([0.0, 0.0]));
    }

    #[test]
    fn multiplicative_noise_at_its_rest_point_holds() {
        let d = read(
            "model m\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
             diffusion v: x*xi\n",
        );
        assert!(d.holds_still([0.0, 0.0]));
        // Off the rest point the drift moves it though the noise vanishes (x = 0).
        assert!(!d.holds_still([0.0, 1.0]));
    }

    #[test]
    fn time_dependent_noise_is_not_decided() {
        let d = read(
            "model m\nstate x, v\ndrift x: v\ndrift v: -x - v\nnoise xi: intensity 1\n\
             diffusion v: x*exp(-t)*xi\n",
        );
        assert!(!d.holds_still([0.0, 0.0]));
    }
}
