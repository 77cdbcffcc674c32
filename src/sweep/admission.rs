//! Which points of a sweep have a stationary density at all, decided for every point before
//! any point is solved, by the check a single run makes before any work
//! ([`crate::dynamics::check`], through [`Problem::new`]): a point in the escaping regime of
//! a softening spring, or without noise, is refused in milliseconds instead of being handed
//! to the solvers.

use rayon::prelude::*;

use crate::fpk::FpkError;
use crate::model::Model;
use crate::solve::{Problem, SolveError};

use super::{PointRefusal, SweepSpec};

/// Per point of `points` (in order): why it has no stationary density, or `None` when it
/// may be solved. A point whose parameters do not bind is not refused here: its bind error
/// is recorded at the point, as it always was.
pub(super) fn refusals(
    model: &Model,
    spec: &SweepSpec,
    points: &[Vec<f64>],
) -> Vec<Option<PointRefusal>> {
    points
        .par_iter()
        .map(|values| refusal_at(model, spec, values))
        .collect()
}

/// Why the point `values` has no stationary density, if it has none.
pub(super) fn refusal_at(model: &Model, spec: &SweepSpec, values: &[f64]) -> Option<PointRefusal> {
    let bound = model.bind(&spec.overrides_at(values)).ok()?;
    match Problem::new(&bound) {
        Err(SolveError::Fpk(FpkError::Inadmissible(why))) => Some(PointRefusal(why)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Inadmissible;

    #[test]
    fn softening_and_noiseless_points_are_refused_and_the_others_not() {
        let model = crate::model::parse_model(
            "model duffing\nparam c = 0.1, mu = 0.1, S = 1\nstate z, v\ndrift z: v\n\
             drift v: -c*v - z - mu*z^3\nnoise xi: intensity S\ndiffusion v: xi\n",
            None,
        )
        .unwrap();
        let spec = SweepSpec::parse(&["mu=-1,0.1".into(), "S=0,1".into()]).unwrap();
        let found: Vec<_> = refusals(&model, &spec, &spec.points())
            .into_iter()
            .map(|r| r.map(|r| r.0))
            .collect();
        // Points: (mu, S) = (-1, 0), (0.1, 0), (-1, 1), (0.1, 1).
        assert!(matches!(
            found[0],
            Some(Inadmissible::NoNoise | Inadmissible::Escapes { .. })
        ));
        assert_eq!(found[1], Some(Inadmissible::NoNoise));
        assert!(
            matches!(found[2], Some(Inadmissible::Escapes { .. })),
            "{:?}",
            found[2]
        );
        assert_eq!(found[3], None);
    }
}
