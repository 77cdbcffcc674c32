//! The fast mechanical path's part of [`BatchState`] (`kernel/mech` runs it): a call
//! by steps, one by steps of a form whose coefficients depend on the time, a call by sample
//! points that writes the states at each, and the vector extension the lane loops run with.

use crate::mc::compile::eval::Simd;
use crate::mc::compile::impact::Barrier;
use crate::mc::compile::mech_form::{MechForm, TimedForm};
use crate::mc::compile::scheme::{Dynamics, Evaluator, Plan};
use crate::mc::compile::tally::ImpactSink;
use crate::mc::kernel::mech::{self, Coefs, Columns, Rows};
use crate::mc::kernel::rng::{three_point_value, Increments};
use crate::mc::step::state::BatchState;
use crate::mc::step::timed::{SpanTable, TimedSteps, TABLE_STEPS};

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
    /// The fast mechanical path (`kernel/mech`) for three-point increments; `false`
    /// (nothing done) for Gaussian ones, which keep the lane evaluator.
    #[inline(always)]
    pub(in crate::mc) fn mech_fast(
        &mut self,
        form: &MechForm,
        bar: Option<&Barrier>,
        steps: u64,
        h: f64,
    ) -> bool {
        self.run_fast(form, bar, 1, steps, h, None)
    }

    /// The fast mechanical path for a form whose coefficients depend on the time, `steps`
    /// steps from the time `t0`: step k's velocity update with the coefficients of the time
    /// t0 + (k + ½)h (the splitting's midpoint, as on the lane evaluator), computed once for
    /// all the lanes (or taken from `span` when it was made for these steps),
    /// [`TABLE_STEPS`] steps at a time (each one call of the kernel, whose flights at its
    /// ends are halves). `false` (nothing done) for Gaussian increments.
    pub(in crate::mc) fn mech_fast_timed(
        &mut self,
        timed: &TimedForm,
        bar: Option<&Barrier>,
        t0: f64,
        steps: u64,
        h: f64,
        span: Option<&SpanTable>,
    ) -> bool {
        if self.inc.three_point_mut().is_none() {
            return false;
        }
        let a = three_point_value();
        let span = span.filter(|s| s.made_for(t0, steps, h, a));
        let mut own = self
            .timed
            .take()
            .unwrap_or_else(|| Box::new(TimedSteps::new(timed)));
        let simd = self.simd;
        let mut done = 0;
        while done < steps {
            let n = (steps - done).min(TABLE_STEPS);
            let table = match span {
                Some(s) => s.table(done, n),
                None => {
                    own.fill(timed, t0, done, n, h, a);
                    own.table()
                }
            };
            self.with_columns(None, |c, field, _| {
                mech::advance(table, bar, c, field, 1, n, h, simd)
            });
            done += n;
        }
        self.timed = Some(own);
        true
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
        let simd = self.simd;
        self.with_columns(rows, |c, field, a| {
            let coefs = Coefs::new(form, h, a);
            mech::advance(coefs, bar, c, field, samples, steps, h, simd)
        })
    }

    /// `kernel` on the batch's columns (the states at the sample points going to `rows`),
    /// the three-point stream's next field and its value; `false` (nothing done) for
    /// Gaussian increments.
    #[inline(always)]
    fn with_columns(
        &mut self,
        rows: Option<Rows<'_>>,
        kernel: impl FnOnce(Columns<'_>, &mut u8, f64),
    ) -> bool {
        let Some(tp) = self.inc.three_point_mut() else {
            return false;
        };
        let columns = Columns {
            x: &mut self.x,
            v: &mut self.v,
            side: &mut self.side,
            impacts: ImpactSink::new(&mut self.impacts, self.tally.as_mut()),
            rng: self.rng.state_mut(),
            draws: tp.draws,
            rows,
        };
        kernel(columns, tp.field, tp.a);
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
