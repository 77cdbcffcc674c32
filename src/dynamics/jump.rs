//! An impact law's jump compiled for evaluation: the post-impact velocity at the barrier, the
//! one piece the grid solver and EPC with the exact impact condition both evaluate.

use crate::symbolic::{DeltaPolicy, Expr, SymbolicError, Tape};

/// The jump `v -> map(x, v)` of an impact law, compiled over (x, v).
#[derive(Clone, Debug)]
pub(crate) struct Jump {
    map: Tape,
}

impl Jump {
    /// Compiles `map` over the states `vars` (position, velocity).
    pub(crate) fn compile(map: &Expr, vars: &[&str; 2]) -> Result<Jump, SymbolicError> {
        let map = Tape::compile(std::slice::from_ref(map), vars, DeltaPolicy::Reject)?;
        Ok(Jump { map })
    }

    /// The post-impact velocity of `v` at the barrier `x = at`.
    pub(crate) fn map(&self, at: f64, v: f64) -> f64 {
        let mut out = [0.0];
        self.map.eval(&[at, v], &mut Vec::new(), &mut out);
        out[0]
    }
}
