//! The general schemes' barrier events: which lanes of a step met a barrier (a chunk of
//! lanes at a time) and the working memory of resolving one lane's events.

use crate::mc::compile::impact::meets;
use crate::mc::step::platen::PointWork;

/// Working memory of the events of one lane's step (the general schemes).
pub(in crate::mc) struct EventWork {
    /// The increment of the step (or of its remainder) and the remainder's, one per source.
    pub(in crate::mc) w: Vec<f64>,
    pub(in crate::mc) w_rest: Vec<f64>,
    /// Standard normals of the Brownian bridge and the remainder's pair signs.
    pub(in crate::mc) z: Vec<f64>,
    pub(in crate::mc) vpair: Vec<f64>,
    pub(in crate::mc) point: PointWork,
}

impl EventWork {
    pub(in crate::mc) fn new(m: usize) -> EventWork {
        EventWork {
            w: vec![0.0; m],
            w_rest: vec![0.0; m],
            z: vec![0.0; m],
            vpair: vec![0.0; m * m.saturating_sub(1) / 2],
            point: PointWork::new(m),
        }
    }
}

/// Empty (allocates nothing): the placeholder while the working memory is in use.
impl Default for EventWork {
    fn default() -> Self {
        EventWork {
            w: Vec::new(),
            w_rest: Vec::new(),
            z: Vec::new(),
            vpair: Vec::new(),
            point: PointWork::empty(),
        }
    }
}

/// Bit i set when lane i's move `s0[i] → s1[i]` (on side `side[i]`) meets the barrier at
/// `at` ([`meets`], lane-parallel).
#[inline(always)]
pub(in crate::mc) fn crossings<const W: usize>(
    at: f64,
    side: &[f64; W],
    s0: &[f64; W],
    s1: &[f64; W],
) -> u64 {
    let mut met = 0u64;
    for i in 0..W {
        met |= (meets(at, side[i], s0[i], s1[i]) as u64) << i;
    }
    met
}
