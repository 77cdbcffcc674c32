//! The pieces a joint density splits a coordinate line into: analytic ones, which a fixed
//! polynomial rule integrates with a trustworthy doubling check, and a cutoff's transitions,
//! which are bounded instead.

/// A piece of a coordinate line on which a joint density is smooth
/// ([`JointDensity::smooth_pieces`](super::JointDensity::smooth_pieces)).
///
/// ```
/// use fpsolve::density::{LinePiece, PieceKind};
/// let p = LinePiece { range: [0.0, 2.0], kind: PieceKind::Transition { max: 1e-9 } };
/// assert_eq!(p.kind.bound(p.range), Some(2e-9));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinePiece {
    /// The interval of the line's free coordinate.
    pub range: [f64; 2],
    /// What the density is on it.
    pub kind: PieceKind,
}

/// What a joint density is on a [`LinePiece`].
///
/// ```
/// use fpsolve::density::PieceKind;
/// assert_eq!(PieceKind::Analytic.bound([0.0, 1.0]), None);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PieceKind {
    /// Analytic on the closed piece: a fixed polynomial rule converges geometrically and its
    /// doubling check can be trusted.
    Analytic,
    /// A cutoff's transition: C^∞ but not analytic, between 0 and `max`.
    Transition {
        /// The density's largest value on the piece (a bound).
        max: f64,
    },
}

impl PieceKind {
    /// For a transition over `range`, the bound max·length on its integral; `None` for an
    /// analytic piece.
    pub fn bound(&self, range: [f64; 2]) -> Option<f64> {
        match self {
            PieceKind::Analytic => None,
            PieceKind::Transition { max } => Some(max * (range[1] - range[0])),
        }
    }
}
