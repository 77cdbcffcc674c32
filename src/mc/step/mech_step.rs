//! The fast mechanical path's part of [`BatchState`] (`kernel/mech` runs it): a call
//! by steps, a call by sample points that writes the states at each, and the vector
//! extension the lane loops run with.

use crate::mc::compile::eval::Simd;
use crate::mc::compile::impact::Barrier;
use crate::mc::compile::mech_form::MechForm;
use crate::mc::compile::scheme::{Dynamics, Evaluator, Plan};
use crate::mc::kernel::mech::{self, Columns, Rows};
use crate::mc::kernel::rng::Increments;
use crate::mc::step::state::BatchState;

impl Evaluator {
    /// The evaluator a run of `plan` with `increments` gets (as the batch driver decides).
    pub(crate) fn of(plan: &Plan, increments: Increments) -> Evaluator {
        if fast_rows(plan, increments == Increments::ThreePoint) {
            Evaluator::PolynomialKernel
        } else {
            Evaluator::Tape
        }
    }
}

impl BatchState {
    /// The fast mechanical path (`kernel/mech`) for three-point increments, `steps` steps
    /// from the time `t0`; `false` (nothing done) for Gaussian ones, which keep the lane
    /// evaluator.
    #[inline(always)]
    pub(in crate::mc) fn mech_fast(
        &mut self,
        form: &MechForm,
        bar: Option<&Barrier>,
        t0: f64,
        steps: u64,
        h: f64,
    ) -> bool {
        let _ = t0;
        self.run_fast(form, bar, 1, steps, h, None)
    }

    /// `samples` times [`BatchState::advance`] by `steps` steps of size `h` on the fast
    /// mechanical path, lane i's state after the j-th going to `rows_x[j * lanes + i]`,
    /// `rows_v[j * lanes + i]`; `false` (nothing done) when the plan or the increments are
    /// not the fast path's (the caller then advances and reads the states itself).
    pub(crate) fn advance_rows(
        &mut self,
        plan: &Plan,
        samples: u64,
        steps: u64,
        h: f64,
        rows_x: &mut [f64],
        rows_v: &mut [f64],
    ) -> bool {
        let Dynamics::Mechanical {
            form: Some(form), ..
        } = &plan.dynamics
        else {
            return false;
        };
        let bar = match plan.barriers.as_slice() {
            [] => None,
            [bar] => Some(bar),
            _ => return false,
        };
        let stride = self.x.len();
        let rows = Rows {
            x: rows_x,
            v: rows_v,
            stride,
        };
        self.run_fast(form, bar, samples, steps, h, Some(rows))
    }

    /// Runs the fast mechanical path on the batch's columns, `samples` times `steps`
    /// steps, the states at each sample point going to `rows` when given; `false` (nothing
    /// done) for Gaussian increments.
    #[inline(always)]
    fn run_fast(
        &mut self,
        form: &MechForm,
        bar: Option<&Barrier>,
        samples: u64,
        steps: u64,
        h: f64,
        rows: Option<Rows<'_>>,
    ) -> bool {
        let Some(tp) = self.inc.three_point_mut() else {
            return false;
        };
        let columns = Columns {
            x: &mut self.x,
            v: &mut self.v,
            side: &mut self.side,
            impacts: &mut self.impacts,
            rng: self.rng.state_mut(),
            draws: tp.draws,
            rows,
        };
        mech::advance(
            form, bar, columns, tp.field, tp.a, samples, steps, h, self.simd,
        );
        true
    }

    /// The vector extension the lane loops run with.
    pub(crate) fn simd(&self) -> Simd {
        self.simd
    }

    /// Runs the lane loops with `simd` (detected on this CPU) instead of the widest.
    pub(crate) fn set_simd(&mut self, simd: Simd) {
        self.simd = simd;
    }

    /// Whether [`BatchState::advance_rows`] runs on `plan` with these increments.
    pub(crate) fn has_fast_rows(&mut self, plan: &Plan) -> bool {
        fast_rows(plan, self.inc.three_point_mut().is_some())
    }
}

/// Whether [`BatchState::advance_rows`] runs on `plan`: the mechanical form, at most one
/// barrier, and three-point increments (`three_point`).
pub(crate) fn fast_rows(plan: &Plan, three_point: bool) -> bool {
    matches!(&plan.dynamics, Dynamics::Mechanical { form: Some(_), .. })
        && plan.barriers.len() <= 1
        && three_point
}
