//! The coefficients of a time-dependent mechanical form at each step, as the fast kernel
//! takes them (a [`Table`]): the template of the prescaled
//! coefficients for a step size (its changing coefficients marked) and each step's values of
//! those, at the step's midpoint. [`TimedSteps`] is a batch's working memory for them;
//! [`SpanTable`] holds them over a span of steps for every batch that takes it.

use crate::mc::compile::mech_form::{MechForm, TimedForm, TimedWork};
use crate::mc::compile::scheme::{Dynamics, Plan};
use crate::mc::kernel::mech::{Coefs, Slot, Table};
use crate::mc::kernel::rng::three_point_value;

/// Steps of a time-dependent form one kernel call takes (their coefficients' values are
/// computed before the call).
pub(in crate::mc) const TABLE_STEPS: u64 = 1024;

/// A batch's working memory for the coefficients of its steps (`BatchState::mech_fast_timed`),
/// allocated by the first call that needs it.
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
    pub(in crate::mc) fn new(timed: &TimedForm) -> TimedSteps {
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
    pub(in crate::mc) fn fill(
        &mut self,
        timed: &TimedForm,
        t0: f64,
        first: u64,
        n: u64,
        h: f64,
        a: f64,
    ) {
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
    pub(in crate::mc) fn table(&self) -> Table<'_> {
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
/// `t0` (those `BatchState::mech_fast_timed` computes), computed once for every batch that
/// takes those steps (`BatchState::advance_with`).
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

    /// Whether it was made for these steps and three-point value.
    pub(in crate::mc) fn made_for(&self, t0: f64, steps: u64, h: f64, a: f64) -> bool {
        self.key == SpanKey::new(t0, steps, h, a)
    }

    /// The table of steps `first..first + n`.
    pub(in crate::mc) fn table(&self, first: u64, n: u64) -> Table<'_> {
        let m = self.width;
        Table {
            template: &self.template,
            width: m,
            values: &self.values[first as usize * m..(first + n) as usize * m],
        }
    }
}
