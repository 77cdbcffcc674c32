//! Whether a model's equations depend on the time `t` ([`super::TIME`]).

use super::{BoundModel, Model, TIME};
use crate::symbolic::Expr;

/// Whether any of `exprs` mentions the time.
fn mentions_time<'e>(mut exprs: impl Iterator<Item = &'e Expr>) -> bool {
    exprs.any(|e| e.symbols().iter().any(|s| &**s == TIME))
}

impl Model {
    /// Whether a drift or diffusion line mentions the time `t`: such a model has no
    /// stationary density, and only a transient method can solve it.
    ///
    /// ```
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// assert!(!fpsolve::model::load_model(&path).unwrap().time_dependent());
    /// ```
    pub fn time_dependent(&self) -> bool {
        mentions_time(self.drift.iter().chain(self.noise_matrix.iter().flatten()))
    }
}

impl BoundModel {
    /// Whether a drift or diffusion line mentions the time `t` (as [`Model::time_dependent`]).
    ///
    /// ```
    /// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\n\
    ///             noise xi: intensity 1\ndiffusion v: exp(-t)*xi\n";
    /// let bound = fpsolve::model::parse_model(text, None).unwrap().bind(&[]).unwrap();
    /// assert!(bound.time_dependent());
    /// ```
    pub fn time_dependent(&self) -> bool {
        mentions_time(self.drift.iter().chain(self.noise_matrix.iter().flatten()))
    }
}

/// A finite period is refused unless positive, the coefficients must mention the time, and
/// must repeat after it at probe points: phases 0, 0.29, 0.61 and 0.88 of the period, at 3×3
/// points at fractions 0.19, 0.52, 0.83 of a box. They count as repeating when they differ
/// by at most this times their largest magnitude over the probes.
const PERIODICITY: f64 = 1e-9;

/// Why coefficients are not periodic with a given period ([`BoundModel::check_period`]):
/// shared by every method that looks for a periodic steady state.
///
/// ```
/// use fpsolve::model::PeriodError;
/// let e = PeriodError::NotPositive { period: -1.0 };
/// assert!(e.to_string().contains("-1"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PeriodError {
    /// The period is not finite and positive.
    #[error("the period {period} is not finite and positive")]
    NotPositive {
        /// The period given.
        period: f64,
    },
    /// No coefficient mentions the time: the long-time density is the stationary one.
    #[error(
        "the coefficients of `{model}` do not depend on t, so there is no periodic state \
         apart from the stationary density: the stationary solver applies (fpsolve solve)"
    )]
    NotTimeDependent {
        /// The model's name.
        model: String,
    },
    /// A coefficient differs at t and t + period.
    #[error(
        "{coefficient} is not periodic with period {period}: {at_t} at t = {t} but \
         {at_next} at t + {period} (x = {x}, v = {v}); give the period of the coefficients"
    )]
    NotPeriodic {
        /// Which coefficient (`the drift of `v``, `the diffusion of `v``, `the diffusion
        /// between `x` and `v``).
        coefficient: String,
        /// The period given.
        period: f64,
        /// The probe's time.
        t: f64,
        /// The probe's position.
        x: f64,
        /// The probe's velocity.
        v: f64,
        /// The coefficient at t.
        at_t: f64,
        /// The coefficient at t + period.
        at_next: f64,
    },
}

impl BoundModel {
    /// Whether the coefficients have period `period`: a finite positive period, a model
    /// whose drift or diffusion mentions t, and (with a box `[x range, v range]`) the drift
    /// of each state and the diffusion matrix b = G·S·Gᵀ equal at t and t + period at probe
    /// points of the box (a value undefined at a probe decides nothing). The check every
    /// method runs before it looks for a periodic state.
    ///
    /// ```
    /// use fpsolve::model::PeriodError;
    /// let text = "model f\nstate x, v\ndrift x: v\ndrift v: -v - x + cos(2*t)\n\
    ///     noise xi: intensity 1\ndiffusion v: xi\n";
    /// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// let square = Some([[-5.0, 5.0], [-5.0, 5.0]]);
    /// assert!(bound.check_period(std::f64::consts::PI, square).is_ok());
    /// let err = bound.check_period(3.0, square).unwrap_err();
    /// assert!(matches!(err, PeriodError::NotPeriodic { .. }), "{err}");
    /// assert!(matches!(bound.check_period(0.0, None), Err(PeriodError::NotPositive { .. })));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// The first [`PeriodError`] found, in the order of its variants.
    pub fn check_period(
        &self,
        period: f64,
        bounds: Option<[[f64; 2]; 2]>,
    ) -> Result<(), PeriodError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(PeriodError::NotPositive { period });
        }
        if !self.time_dependent() {
            return Err(PeriodError::NotTimeDependent {
                model: self.name().to_string(),
            });
        }
        let Some([xr, vr]) = bounds else {
            return Ok(());
        };
        let at = |r: [f64; 2], f: f64| r[0] + f * (r[1] - r[0]);
        let fractions = [0.19, 0.52, 0.83];
        let points: Vec<[f64; 2]> = fractions
            .iter()
            .flat_map(|&fx| fractions.iter().map(move |&fv| [at(xr, fx), at(vr, fv)]))
            .collect();
        let states = self.states();
        let names = [
            format!("the drift of `{}`", states[0]),
            format!("the drift of `{}`", states[1]),
            format!("the diffusion of `{}`", states[0]),
            format!("the diffusion between `{}` and `{}`", states[0], states[1]),
            format!("the diffusion of `{}`", states[1]),
        ];
        for phase in [0.0, 0.29, 0.61, 0.88] {
            let t = phase * period;
            let now: Vec<[f64; 5]> = points.iter().map(|p| self.coefficients_at(*p, t)).collect();
            let next: Vec<[f64; 5]> = points
                .iter()
                .map(|p| self.coefficients_at(*p, t + period))
                .collect();
            for (c, name) in names.iter().enumerate() {
                let scale = now
                    .iter()
                    .chain(&next)
                    .map(|v| v[c].abs())
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, f64::max);
                for (k, p) in points.iter().enumerate() {
                    let (a, b) = (now[k][c], next[k][c]);
                    if (a - b).abs() > PERIODICITY * scale {
                        return Err(PeriodError::NotPeriodic {
                            coefficient: name.clone(),
                            period,
                            t,
                            x: p[0],
                            v: p[1],
                            at_t: a,
                            at_next: b,
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// The drift of each state and b₀₀, b₀₁, b₁₁ of b = G·S·Gᵀ at `x` and time `t`, NaN
    /// where undefined (deltas as zero).
    fn coefficients_at(&self, x: [f64; 2], t: f64) -> [f64; 5] {
        let states = self.states();
        let lookup = |s: &str| {
            if s == &*states[0] {
                Some(x[0])
            } else if s == &*states[1] {
                Some(x[1])
            } else if s == TIME {
                Some(t)
            } else {
                None
            }
        };
        let eval = |e: &Expr| {
            e.eval_with(&lookup, crate::symbolic::DeltaPolicy::Zero)
                .unwrap_or(f64::NAN)
        };
        let g = self.noise_matrix();
        let s = self.intensity();
        let gv: Vec<[f64; 2]> = (0..s.len())
            .map(|k| [eval(&g[0][k]), eval(&g[1][k])])
            .collect();
        let b = |i: usize, j: usize| {
            let mut sum = 0.0;
            for (k, row) in s.iter().enumerate() {
                for (l, &skl) in row.iter().enumerate() {
                    if skl != 0.0 {
                        sum += gv[k][i] * skl * gv[l][j];
                    }
                }
            }
            sum
        };
        [
            eval(&self.drift()[0]),
            eval(&self.drift()[1]),
            b(0, 0),
            b(0, 1),
            b(1, 1),
        ]
    }
}
