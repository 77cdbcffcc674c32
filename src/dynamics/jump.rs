//! An impact law's jump compiled for evaluation: the post-impact value of the jumping state
//! at the barrier, the one piece every method that resolves impacts evaluates.

use crate::symbolic::{DeltaPolicy, Expr, SymbolicError, Tape};

/// The jump `other -> map(states)` of an impact law, compiled over the model's states.
///
/// ```
/// let text = "model m\nparam c = 0.1\nstate y, v\ndrift y: v\ndrift v: -c*v - y\n\
///             noise xi: intensity 1\ndiffusion v: xi\nimpact y = 0: v -> -0.5*v\n\
///             domain y >= 0\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
/// let wall = dynamics.barriers()?.iter().next().unwrap();
/// assert_eq!(wall.law().apply(wall.at(), -2.0), 1.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct JumpLaw {
    map: Expr,
    tape: Tape,
    state: usize,
}

impl JumpLaw {
    /// Compiles `map`, the new value of one state when state `state` meets a barrier, over
    /// the states `vars`.
    pub(crate) fn compile(
        map: &Expr,
        state: usize,
        vars: &[&str; 2],
    ) -> Result<JumpLaw, SymbolicError> {
        let tape = Tape::compile(std::slice::from_ref(map), vars, DeltaPolicy::Reject)?;
        Ok(JumpLaw {
            map: map.clone(),
            tape,
            state,
        })
    }

    /// The post-impact value of the jumping state `v` when the barrier state is at `at`.
    pub fn apply(&self, at: f64, v: f64) -> f64 {
        let mut x = [v; 2];
        x[self.state] = at;
        let mut out = [0.0];
        self.tape.eval(&x, &mut Vec::new(), &mut out);
        out[0]
    }

    /// The map as the bound model states it.
    pub fn map(&self) -> &Expr {
        &self.map
    }
}
