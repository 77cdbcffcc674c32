//! The fast mechanical path's part of [`BatchState`] (`kernel/mech` runs it): a call
//! by steps, one by steps of a form whose coefficients depend on the time, a call by sample
//! points that writes the states at each, and the vector extension the lane loops run with.

use crate::mc::compile::eval::Simd;
use crate::mc::compile::impact::Barrier;
use crate::mc::compile::mech_form::{MechForm, TimedForm, TimedWork};
use crate::mc::compile::scheme::{Dynamics, Evaluator, Plan};
use crate::mc::kernel::mech::{self, Coefs, Columns, Rows, Slot, Table};
use crate::mc::kernel::rng::{three_point_value, Increments};
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
        let Some(tp) = self.inc.three_point_mut() else {
            return false;
        };
        let span = span.filter(|s| s.key == SpanKey::new(t0, steps, h, tp.a));
        let buffers = self
            .timed
            .get_or_insert_with(|| Box::new(TimedSteps::new(timed)));
        let mut done = 0;
        while done < steps {
            let n = (steps - done).min(TABLE_STEPS);
            let table = match span {
                Some(s) => s.table(done, n),
                None => {
                    buffers.fill(timed, t0, done, n, h, tp.a);
                    buffers.table()
                }
            };
            let columns = Columns {
                x: &mut self.x,
                v: &mut self.v,
                side: &mut self.side,
                impacts: &mut self.impacts,
                rng: self.rng.state_mut(),
                draws: tp.draws,
                rows: None,
            };
            mech::advance_table(table, bar, columns, tp.field, n, h, self.simd);
            done += n;
        }
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

/// Steps of a time-dependent form one kernel call takes (their coefficients' values are
/// computed before the call).
pub(in crate::mc) const TABLE_STEPS: u64 = 1024;

/// Working memory of [`BatchState::mech_fast_timed`], allocated by its first call.
pub(in crate::mc) struct TimedSteps {
    /// The form at a step's time.
    form: MechForm,
    work: TimedWork,
    /// The layout of every step's coefficients for the step size and three-point value
    /// (their bits), and its coefficients that change with the time.
    template: Option<(u64, u64, Coefs, Vec<Slot>)>,
    /// Each step's values of those coefficients.
    values: Vec<f64>,
}

impl TimedSteps {
    fn new(timed: &TimedForm) -> TimedSteps {
        TimedSteps {
            form: timed.shape().clone(),
            work: timed.work(),
            template: None,
            values: Vec::new(),
        }
    }

    /// The coefficients of steps `first..first + n` of a call from `t0` at step `h` with the
    /// three-point value `a`: the template for (h, a) (the shape prescaled: NaN where a
    /// coefficient changes with the time), then each step's values at its midpoint.
    fn fill(&mut self, timed: &TimedForm, t0: f64, first: u64, n: u64, h: f64, a: f64) {
        let key = (h.to_bits(), a.to_bits());
        if self.template.as_ref().map(|t| (t.0, t.1)) != Some(key) {
            let mut template = Coefs::new(timed.shape(), h, a);
            let slots: Vec<Slot> = template
                .slots()
                .into_iter()
                .filter(|(_, c)| c.is_nan())
                .map(|(s, _)| s)
                .collect();
            template.mark_step_values(&slots);
            self.template = Some((key.0, key.1, template, slots));
        }
        let (_, _, template, slots) = self.template.as_ref().expect("set above");
        self.values.clear();
        for k in first..first + n {
            timed.at(t0 + (k as f64 + 0.5) * h, &mut self.form, &mut self.work);
            let c = Coefs::shaped(&self.form, h, a, template);
            self.values.extend(slots.iter().map(|s| c.get(*s)));
        }
    }

    /// The table [`TimedSteps::fill`] made.
    fn table(&self) -> Table<'_> {
        let (_, _, template, slots) = self.template.as_ref().expect("filled");
        Table {
            template,
            width: slots.len(),
            values: &self.values,
        }
    }
}

/// What a [`SpanTable`] was made for: the start, the steps, their size and the three-point
/// value (the floats' bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct SpanKey([u64; 4]);

impl SpanKey {
    fn new(t0: f64, steps: u64, h: f64, a: f64) -> SpanKey {
        SpanKey([t0.to_bits(), steps, h.to_bits(), a.to_bits()])
    }
}

/// The coefficients of a time-dependent form at each of `steps` steps of size `h` from
/// `t0` ([`BatchState::mech_fast_timed`]'s), computed once for every batch that takes
/// those steps ([`BatchState::advance_with`]).
pub(crate) struct SpanTable {
    key: SpanKey,
    template: Coefs,
    width: usize,
    values: Vec<f64>,
}

impl SpanTable {
    /// The table of `plan`'s steps from `t0`; `None` when its form does not depend on the
    /// time (or is not run by the fast kernel), or the table would hold more than
    /// `max_values` values.
    pub(crate) fn of(
        plan: &Plan,
        t0: f64,
        steps: u64,
        h: f64,
        max_values: usize,
    ) -> Option<SpanTable> {
        let Dynamics::Mechanical {
            timed: Some(timed), ..
        } = &plan.dynamics
        else {
            return None;
        };
        let a = three_point_value();
        let mut w = TimedSteps::new(timed);
        w.fill(timed, t0, 0, 0, h, a);
        let width = w.template.as_ref().map_or(0, |t| t.3.len());
        if steps.saturating_mul(width as u64) > max_values as u64 {
            return None;
        }
        w.fill(timed, t0, 0, steps, h, a);
        let (_, _, template, slots) = w.template.take().expect("filled");
        Some(SpanTable {
            key: SpanKey::new(t0, steps, h, a),
            template,
            width: slots.len(),
            values: w.values,
        })
    }

    /// The number of values it holds.
    pub(crate) fn len(&self) -> usize {
        self.values.len()
    }

    /// The table of steps `first..first + n`.
    fn table(&self, first: u64, n: u64) -> Table<'_> {
        let m = self.width;
        Table {
            template: &self.template,
            width: m,
            values: &self.values[first as usize * m..(first + n) as usize * m],
        }
    }
}

/// Whether [`BatchState::advance_rows`] runs on `plan`: the mechanical form, at most one
/// barrier, and three-point increments (`three_point`).
pub(crate) fn fast_rows(plan: &Plan, three_point: bool) -> bool {
    matches!(&plan.dynamics, Dynamics::Mechanical { form: Some(_), .. })
        && plan.barriers.len() <= 1
        && three_point
}
