//! The grid's generator A(t) for the time stepper when the model's coefficients depend on
//! the time: re-assembled at each time the stepper asks for.
//!
//! Why not the split A(t) = A₀ + Σ f_k(t) A_k: the finite volumes upwind the v-flux by the
//! sign of m − ½ ∂b/∂v at each face, so a drift term times cos(ωt) or a diffusion whose
//! v-derivative is scaled by env(t)² changes which neighbour a face takes its value from;
//! the assembled matrix is not linear in the factors, and a split would be exact only in
//! special cases (modulated noise whose diffusion does not depend on v is one: there
//! A(t) = A_drift + e(t)² A_diff exactly). Nor would a split spare the factorisations, since
//! I − γh(A₀ + Σ f_k A_k) changes with t all the same; it would spare the assembly, about a
//! sixth of a run at 96x96. Each stage time has its own matrix, and every stage is solved
//! with it: the stepper (`reuse_across_times`) factorises some of them and iterates on the
//! others with a nearby time's factor as the preconditioner.
//!
//! The entries are the finite volumes' (row, column, value) triplets, duplicates summed. The
//! compressed-column pattern is the same at every time unless an entry that was zero becomes
//! non-zero, so the values are added into the pattern of the first assembly (a search in
//! each column, no sort), and the pattern is rebuilt from the triplets when an entry falls
//! outside it. Building the matrix from sorted triplets at every stage time took a quarter
//! of a time-dependent run (80x80 cells, modulated noise, `perf`).

use std::borrow::Cow;
use std::cell::RefCell;

use faer::sparse::{SparseColMat, SymbolicSparseColMat};

use crate::grid::assemble::{assemble, generator, Operator};
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
    /// The pattern the values are added into (the first assembly's, or the last rebuilt).
    pattern: RefCell<Option<SymbolicSparseColMat<usize>>>,
}

impl<'a> TimeOperator<'a> {
    pub(super) fn new(mesh: &'a Mesh, problem: &'a Mechanical) -> Self {
        TimeOperator {
            mesh,
            problem,
            memo: RefCell::new(Vec::with_capacity(MEMO)),
            assembled: std::cell::Cell::new(0),
            pattern: RefCell::new(None),
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
        if let Some(a) = self.pattern.borrow().as_ref().and_then(|p| fill(p, &op)) {
            return Ok(a);
        }
        let a = generator(self.mesh.cells(), &op)
            .ok_or_else(|| failed("the generator's entries could not be allocated".into()))?;
        *self.pattern.borrow_mut() = Some(
            a.symbolic()
                .to_owned()
                .map_err(|e| failed(format!("{e:?}")))?,
        );
        Ok(a)
    }
}

/// The operator's triplets added into `pattern` (its columns' rows sorted, as faer keeps
/// them), or `None` when one falls outside it.
fn fill(pattern: &SymbolicSparseColMat<usize>, op: &Operator) -> Option<SparseColMat<usize, f64>> {
    let (ptr, rows) = (pattern.col_ptr(), pattern.row_idx());
    let mut values = vec![0.0; rows.len()];
    for t in [&op.transport, &op.outflow, &op.reinjection]
        .into_iter()
        .flatten()
    {
        let (start, end) = (ptr[t.col], ptr[t.col + 1]);
        let at = rows[start..end].binary_search(&t.row).ok()?;
        values[start + at] += t.val;
    }
    Some(SparseColMat::new(pattern.clone(), values))
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
