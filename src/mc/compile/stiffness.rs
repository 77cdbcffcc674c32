//! The largest time step the explicit schemes take stably: every scheme here (the Heun
//! velocity update of the splitting, stochastic Heun, Euler–Maruyama, Platen's scheme) damps
//! a decaying mode y' = −λy only while λ·dt ≤ 2 (amplification 1 − λdt, or 1 − λdt + (λdt)²/2,
//! of modulus at most 1 exactly there), so a drift that decays faster than 2/dt makes every
//! trajectory blow up, in a run that looks like a hang.

use crate::mc::compile::scheme::Plan;
use crate::mc::compile::step_limit::{StepLimit, REACH, STABLE_RATE_TIMES_DT};

/// Sample points per state and side of the origin; the points sit at half steps, never on
/// an axis, so that a kink there (`sgn(v)`, `abs(v)`) is not differenced across.
const POINTS: i32 = 8;

impl Plan {
    /// The fastest decay of the drift along a state's own axis over the states a run visits
    /// (see [`StepLimit`]) at time `t`; `None` when the drift decays nowhere there.
    pub(crate) fn step_limit(&self, states: [&str; 2], t: f64) -> Option<StepLimit> {
        let l = self.initial_spread();
        let sd = [l[0][0].abs(), l[1][0].hypot(l[1][1])];
        let mut out = [0.0; 2];
        let mut f = |p: [f64; 2], i: usize| {
            self.drift.eval_point(t, p[0], p[1], &mut out);
            out[i]
        };
        let mut worst: Option<StepLimit> = None;
        for a in -POINTS..POINTS {
            for b in -POINTS..POINTS {
                let step = REACH / POINTS as f64;
                let p = [
                    sd[0] * step * (a as f64 + 0.5),
                    sd[1] * step * (b as f64 + 0.5),
                ];
                for i in 0..2 {
                    let h = 1e-6 * sd[i].max(p[i].abs());
                    let (mut up, mut down) = (p, p);
                    up[i] += h;
                    down[i] -= h;
                    let rate = -(f(up, i) - f(down, i)) / (2.0 * h);
                    if rate.is_finite() && rate > worst.as_ref().map_or(0.0, |w| w.rate) {
                        worst = Some(StepLimit {
                            state: states[i].to_string(),
                            rate,
                            at: p,
                            largest_dt: STABLE_RATE_TIMES_DT / rate,
                        });
                    }
                }
            }
        }
        worst
    }
}
