//! The reference point of a sweep's tail thresholds: the first point, in the sweep's order,
//! that the first method solved — converged at the target degree with finite statistics, so
//! a point the sweep reports as failed or refused never sets them — with finite positive
//! √E\[g²\] of every quantity (for EPC under its degree-2 solution, the Gaussian closure).
//!
//! Found by walking the sweep's points in order from the first, whatever part of the sweep
//! this process solves: a shard finds the same point and the same values as the whole run,
//! so that the tails of merged shards are those of one run.
//!
//! The walk solves no point twice where it can help it. A point this process solves reports
//! its reference values ([`ReferenceRms`]) beside its results: always for a method whose
//! reference is its reported solution, and for EPC (whose reference is the degree-2 solution
//! of the point's own ladder) when the point is the first of its range not yet known to have
//! no reference (the [`Frontier`](super::frontier::Frontier)), so that √E\[g²\] under the degree-2 solution is computed
//! at that point alone and not at every point. Only a point the walk needs and nobody
//! computed — one before this process's range (a shard), or one that finished before the
//! points ahead of it were known to have failed — is solved by the walk, exactly as the
//! point's ladder solves it, so the values are bit for bit the same either way.

use std::ops::Range;

use crate::base::cancel::Cancel;
use crate::base::run::RunControl;
use crate::grid::Domain;
use crate::model::Model;
use crate::solve::{Method, Problem};

use super::frontier::ReferenceRms;
use super::point::{by_method, epc_reference_rms};
use super::SweepSpec;

/// The reference point of the tail thresholds and √E\[g²\] of each quantity there.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Reference {
    /// Its index in [`SweepSpec::points`].
    pub(super) point: usize,
    /// √E\[g²\] per quantity (states, then observables).
    pub(super) rms: Vec<f64>,
}

/// The reference values of point `values` by `method`, solved here: as the point's own
/// ladder (EPC) or the point's own solve (any other method) computes them.
/// The grid on the box `domain` when given.
fn solved_rms(
    model: &Model,
    spec: &SweepSpec,
    values: &[f64],
    (method, domain): (Method, Option<Domain>),
    cancel: &Cancel,
) -> Option<Vec<f64>> {
    let bound = model.bind(&spec.overrides_at(values)).ok()?;
    match method {
        Method::Epc { degree } => epc_reference_rms(&bound, degree),
        other => Problem::new(&bound).ok().and_then(|p| {
            let run = RunControl::new().cancelled_by(cancel.clone());
            by_method(&p.with_grid_domain(domain), other, &run).1
        }),
    }
}

/// The first point among `indices` of `points` whose reference solution by `method` has
/// finite positive √E\[g²\] of every quantity. `known(i)`: the values point `i`'s own solve
/// reported, when it computed them; any other point is solved here. `None` when no point of
/// `indices` qualifies or when cancelled.
pub(super) fn reference(
    model: &Model,
    spec: &SweepSpec,
    points: &[Vec<f64>],
    indices: Range<usize>,
    method: (Method, Option<Domain>),
    known: impl Fn(usize) -> ReferenceRms,
    cancel: &Cancel,
) -> Option<Reference> {
    for i in indices {
        if cancel.is_cancelled() {
            return None;
        }
        let rms = match known(i) {
            ReferenceRms::Known(rms) => rms,
            ReferenceRms::Unknown => solved_rms(model, spec, &points[i], method, cancel),
        };
        if let Some(rms) = rms {
            return Some(Reference { point: i, rms });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_model;

    /// A linear oscillator whose intensity S may be negative (a bind failure).
    fn linear() -> Model {
        parse_model(
            "model linear\nparam c = 0.2, S = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\n\
             noise xi: intensity S\ndiffusion v: xi\n",
            None,
        )
        .unwrap()
    }

    #[test]
    fn the_walk_solves_exactly_the_points_nobody_computed() {
        let model = linear();
        let spec = SweepSpec::parse(&["S=-1,-2,1,2".to_string()]).unwrap();
        let points = spec.points();
        let method = (Method::Epc { degree: 4 }, None);
        let solved = |i: usize| solved_rms(&model, &spec, &points[i], method, &Cancel::new());
        // Points 0 and 1 do not bind; point 2 is the reference (var z = S/(2c) = 2.5).
        let scratch = reference(
            &model,
            &spec,
            &points,
            0..4,
            method,
            |_| ReferenceRms::Unknown,
            &Cancel::new(),
        )
        .unwrap();
        assert_eq!(scratch.point, 2);
        assert!((scratch.rms[0] / 2.5f64.sqrt() - 1.0).abs() < 1e-9);
        // Told point 1 has none and point 2 is unknown: solves point 2, the same bits.
        let told = |i: usize| match i {
            0 | 1 => ReferenceRms::Known(None),
            _ => ReferenceRms::Unknown,
        };
        let cancel = Cancel::new();
        let walked = reference(&model, &spec, &points, 0..4, method, told, &cancel);
        assert_eq!(walked, Some(scratch.clone()));
        // Told values are taken as they are, never solved again.
        let fake = vec![7.0; 2];
        let told = |i: usize| match i {
            0 => ReferenceRms::Known(None),
            1 => ReferenceRms::Known(Some(fake.clone())),
            _ => ReferenceRms::Known(solved(i)),
        };
        let walked = reference(&model, &spec, &points, 0..4, method, told, &cancel).unwrap();
        assert_eq!((walked.point, walked.rms), (1, fake));
        // A range that starts after the reference finds the next qualifying point.
        let later = reference(
            &model,
            &spec,
            &points,
            3..4,
            method,
            |_| ReferenceRms::Unknown,
            &cancel,
        );
        assert_eq!(later.map(|r| r.point), Some(3));
        cancel.cancel();
        let told = |_| ReferenceRms::Unknown;
        assert_eq!(
            reference(&model, &spec, &points, 0..4, method, told, &cancel),
            None
        );
    }
}
