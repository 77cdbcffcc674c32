//! The reference point of a sweep's tail thresholds: the first point, in the sweep's order,
//! that the first method solved (for EPC: its degree-2 solution, the Gaussian closure, with
//! finite positive √E\[g²\] of every quantity).
//!
//! Found by walking the sweep's points in order from the first, whatever part of the sweep
//! this process solves: a shard finds the same point and the same values as the whole run,
//! so that the tails of merged shards are those of one run.

use std::ops::Range;

use crate::cancel::Cancel;
use crate::model::Model;
use crate::solve::Method;

use super::point::{by_method, epc_reference_rms, Raw};
use super::SweepSpec;

/// The reference point of the tail thresholds and √E\[g²\] of each quantity there.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Reference {
    /// Its index in [`SweepSpec::points`].
    pub(super) point: usize,
    /// √E\[g²\] per quantity (states, then observables).
    pub(super) rms: Vec<f64>,
}

/// The first point of `points` whose reference solution by `method` has finite positive
/// √E\[g²\] of every quantity. `solved`: points this process solved already (from the
/// sweep's index `range.start`), whose values are reused when `method` is not EPC (EPC's
/// reference, its degree-2 solution, is not kept by a point and is solved again here, as the
/// point's own ladder solves it). `None` when no point qualifies or when cancelled.
pub(super) fn reference(
    model: &Model,
    spec: &SweepSpec,
    points: &[Vec<f64>],
    method: Method,
    solved: Option<(&[Raw], Range<usize>)>,
    cancel: &Cancel,
) -> Option<Reference> {
    for (i, values) in points.iter().enumerate() {
        if cancel.is_cancelled() {
            return None;
        }
        let kept = match (&solved, method) {
            (Some((raw, range)), m) if range.contains(&i) && !matches!(m, Method::Epc { .. }) => {
                Some(raw[i - range.start].methods[0].rms.clone())
            }
            _ => None,
        };
        let rms = kept.unwrap_or_else(|| {
            let bound = model.bind(&spec.overrides_at(values)).ok()?;
            match method {
                Method::Epc { degree } => epc_reference_rms(&bound, degree),
                other => by_method(&bound, other).1,
            }
        });
        if let Some(rms) = rms {
            return Some(Reference { point: i, rms });
        }
    }
    None
}
