//! The grid's generator A(t) for the time stepper when the model's coefficients depend on
//! the time: re-assembled at each time the stepper asks for.
//!
//! Why not the split A(t) = A₀ + Σ f_k(t) A_k: the finite volumes upwind the v-flux by the
//! sign of m − ½ ∂b/∂v at each face, so a drift term times cos(ωt) or a diffusion whose
//! v-derivative is scaled by env(t)² changes which neighbour a face takes its value from;
//! the assembled matrix is not linear in the factors, and a split would be exact only in
//! special cases. Assembly costs a few per cent of a factorisation, and each stage time has
//! its own matrix (the stepper keys its factorisations by step size *and* time), so no
//! factor is ever reused for a matrix it was not computed from.

use std::borrow::Cow;
use std::cell::RefCell;

use faer::sparse::SparseColMat;

use crate::grid::assemble::{assemble, generator};
use crate::grid::mesh::Mesh;
use crate::grid::problem::Mechanical;
use crate::numerics::timestep::{Generator, StepError};

/// How many assembled matrices are remembered: the stepper asks for the same stage time
/// twice in a row (to factorise, then to form A y), and the step's end is the next step's
/// start.
const MEMO: usize = 3;

/// A(t) of a time-dependent problem on a mesh.
pub(super) struct TimeOperator<'a> {
    mesh: &'a Mesh,
    problem: &'a Mechanical,
    memo: RefCell<Vec<(u64, SparseColMat<usize, f64>)>>,
    assembled: std::cell::Cell<usize>,
}

impl<'a> TimeOperator<'a> {
    pub(super) fn new(mesh: &'a Mesh, problem: &'a Mechanical) -> Self {
        TimeOperator {
            mesh,
            problem,
            memo: RefCell::new(Vec::with_capacity(MEMO)),
            assembled: std::cell::Cell::new(0),
        }
    }

    /// How many times the operator was assembled.
    pub(super) fn assemblies(&self) -> usize {
        self.assembled.get()
    }

    /// The generator at `t`, freshly assembled.
    pub(super) fn assemble(&self, t: f64) -> Result<SparseColMat<usize, f64>, StepError> {
        let failed = |detail: String| StepError::Operator { time: t, detail };
        let op =
            assemble(self.mesh, &self.problem.at_time(t)).map_err(|e| failed(e.to_string()))?;
        self.assembled.set(self.assembled.get() + 1);
        generator(self.mesh.cells(), &op)
            .ok_or_else(|| failed("the generator's entries could not be allocated".into()))
    }
}

impl Generator for TimeOperator<'_> {
    fn dim(&self) -> usize {
        self.mesh.cells()
    }

    fn time_invariant(&self) -> bool {
        false
    }

    fn at(&self, t: f64) -> Result<Cow<'_, SparseColMat<usize, f64>>, StepError> {
        let key = t.to_bits();
        if let Some((_, a)) = self.memo.borrow().iter().find(|(k, _)| *k == key) {
            return Ok(Cow::Owned(a.clone()));
        }
        let a = self.assemble(t)?;
        let mut memo = self.memo.borrow_mut();
        if memo.len() >= MEMO {
            memo.remove(0);
        }
        memo.push((key, a.clone()));
        Ok(Cow::Owned(a))
    }
}
