//! The barriers of a bound model: one type for a barrier whichever method reads it, and the
//! layouts the model language can state (none, one, or two walls bounding a strip).

use super::jump::JumpLaw;
use crate::model::{BarrierSide, BoundImpact};
use crate::symbolic::SymbolicError;

/// What a barrier does to a trajectory that reaches it.
///
/// The enum is open for the kinds a later model language adds (an absorbing boundary ends a
/// trajectory, for first-passage questions): a method matches the kinds it solves and refuses
/// the rest by name.
///
/// ```
/// use fpsolve::dynamics::BarrierKind;
/// use fpsolve::model::BarrierSide;
/// assert_ne!(BarrierKind::Reflecting(BarrierSide::Above), BarrierKind::PassThrough);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BarrierKind {
    /// The jump reverses the velocity (`v -> -r*v`, original coordinates): the state stays
    /// on one side, the one the model's `domain` line (or its strip) gives.
    Reflecting(BarrierSide),
    /// The jump keeps the velocity's sign (`v -> r*v`, the Zhuravlev form): the state
    /// passes through and lives on both sides.
    PassThrough,
}

/// One impact law of a bound model: where its barrier is, what it does, and its jump.
#[derive(Clone, Debug)]
pub struct Barrier {
    pub(crate) state: usize,
    pub(crate) other: usize,
    pub(crate) at: f64,
    pub(crate) kind: BarrierKind,
    pub(crate) law: JumpLaw,
}

impl Barrier {
    /// Reads a bound impact law, its map compiled over `vars` (the model's states).
    pub(crate) fn read(law: &BoundImpact, vars: &[&str; 2]) -> Result<Barrier, SymbolicError> {
        Ok(Barrier {
            state: law.state,
            other: law.other,
            at: law.at,
            kind: match law.side {
                Some(side) => BarrierKind::Reflecting(side),
                None => BarrierKind::PassThrough,
            },
            law: JumpLaw::compile(&law.map, law.state, vars)?,
        })
    }

    /// A reflecting wall with the law `v -> -r*v` on the state pair (x, v), for tests of
    /// barrier sets no bundled model states.
    #[cfg(test)]
    pub(crate) fn restitution(at: f64, side: BarrierSide, r: f64) -> Barrier {
        use crate::symbolic::Expr;
        let map = Expr::num(-r) * Expr::sym("v");
        Barrier {
            state: 0,
            other: 1,
            at,
            kind: BarrierKind::Reflecting(side),
            law: JumpLaw::compile(&map, 0, &["x", "v"]).expect("a linear map compiles"),
        }
    }

    /// Index of the state that meets the barrier.
    pub fn state(&self) -> usize {
        self.state
    }

    /// Index of the state that jumps.
    pub fn other(&self) -> usize {
        self.other
    }

    /// Where the barrier is.
    pub fn at(&self) -> f64 {
        self.at
    }

    /// What the barrier does.
    pub fn kind(&self) -> BarrierKind {
        self.kind
    }

    /// The side the state lives on, for a reflecting wall.
    pub fn side(&self) -> Option<BarrierSide> {
        match self.kind {
            BarrierKind::Reflecting(side) => Some(side),
            BarrierKind::PassThrough => None,
        }
    }

    /// The compiled jump.
    pub fn law(&self) -> &JumpLaw {
        &self.law
    }

    /// The post-impact value of the jumping state `v` at this barrier.
    pub fn jump(&self, v: f64) -> f64 {
        self.law.apply(self.at, v)
    }
}

/// The barriers of a model, in the layouts binding admits.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
/// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
/// assert!(matches!(dynamics.barriers()?, fpsolve::dynamics::Barriers::None));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub enum Barriers {
    /// No impact law.
    None,
    /// One barrier, reflecting or pass-through.
    One(Barrier),
    /// Two reflecting walls on one state: the state lives between them.
    Strip {
        /// The lower wall (the state above it).
        lo: Barrier,
        /// The upper wall (the state below it).
        hi: Barrier,
    },
}

impl Barriers {
    /// The barriers lower first.
    pub fn iter(&self) -> impl Iterator<Item = &Barrier> {
        let (a, b) = match self {
            Barriers::None => (None, None),
            Barriers::One(b) => (Some(b), None),
            Barriers::Strip { lo, hi } => (Some(lo), Some(hi)),
        };
        a.into_iter().chain(b)
    }

    /// How many barriers.
    pub fn len(&self) -> usize {
        self.iter().count()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        matches!(self, Barriers::None)
    }
}
