//! The mean up-crossing rate ν⁺(u) of a level u by Rice's formula, ν⁺(u) = ∫ (ġ)⁺ p over the
//! level set g = u, from any solved [`JointDensity`].
//!
//! Here in `observe` (not a stage of its own) because it is one more integral of the joint
//! density along the lines x_state = const that the PDFs of Eqs. 25–28 already take: it uses
//! the same line quadrature (`lines.rs`: exact line integrals, smooth pieces with checked fixed
//! rules, adaptive Gauss–Kronrod elsewhere) at the same tolerance, which is private to this
//! stage.
//!
//! - A state x_a whose rate is the other state (the position of the mechanical form,
//!   ẋ = v): ν⁺(u) = ∫_{v>0} v p(u, v) dv, the first moment of the line's upper half.
//! - A state whose rate f_a(x) is any drift without noise: ν⁺(u) = ∫ f_a(u, t)⁺ p(u, t) dt,
//!   the line split at the roots of f_a and integrated where f_a > 0 by adaptive quadrature.
//! - A state driven by white noise (the velocity of an oscillator): its paths are nowhere
//!   differentiable and cross a level infinitely often near each crossing; there is no finite
//!   rate, and [`CrossingError::NoiseDriven`] says so.
//! - An observable that is c ± a state on each half of that state's axis (`abs(z)`, `-z`,
//!   `yb + abs(z)`, the Zhuravlev transform's y): the sum over the branches x_a = s_h·(u − c)
//!   of each branch's rate, with the sign: an up-crossing of g on a branch with s_h = −1 is a
//!   down-crossing of x_a. Any other observable: [`CrossingError::NotAvailable`], or
//!   [`CrossingError::NoiseDriven`] when it depends on a noise-driven state.
//!
//! The rates are in the coordinates the density is in (its states and the model's
//! observables): the grid and EPC with the exact impact condition solve the model as written;
//! EPC of a vibro-impact model solves its Zhuravlev transform, whose observables (y = |z|)
//! carry the user's position.

use rayon::prelude::*;
use serde::Serialize;

use super::lines::{half_line_moments, rule_tolerance};
use super::quadrature::integrate_panels_batch;
use super::{shifted_state, CrossingError, ObservableMap};
use crate::density::JointDensity;
use crate::model::BoundModel;
use crate::symbolic::{DeltaPolicy, Expr, Symbol};

/// How the rate of change of a quantity is known, and the branches of its level sets: what
/// [`crossing_rate`] integrates. Built from a model by [`LevelRate::of_state`] or
/// [`LevelRate::of_observable`].
#[derive(Clone, Debug, PartialEq)]
pub struct LevelRate {
    quantity: String,
    /// The state g is c ± of.
    state: usize,
    /// c in g = c + s_h·x_state.
    offset: f64,
    /// s_h on the negative (0) and positive (1) half of the state's axis.
    sign: [f64; 2],
    rate: StateRate,
}

/// The rate of change of the state.
#[derive(Clone, Debug, PartialEq)]
enum StateRate {
    /// ẋ_state = x_other exactly (the position of the mechanical form).
    Velocity,
    /// ẋ_state = f(x1, x2), a drift without noise.
    Drift { expr: Expr, states: [Symbol; 2] },
}

impl LevelRate {
    /// The level crossings of state `state` of `model` (0 or 1).
    ///
    /// # Errors
    /// [`CrossingError::NoiseDriven`] when a white noise drives the state.
    ///
    /// # Panics
    /// If `state > 1`.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// use fpsolve::observe::{CrossingError, LevelRate};
    /// assert!(LevelRate::of_state(&bound, 0).is_ok());
    /// assert!(matches!(LevelRate::of_state(&bound, 1), Err(CrossingError::NoiseDriven { .. })));
    /// ```
    pub fn of_state(model: &BoundModel, state: usize) -> Result<LevelRate, CrossingError> {
        let name = model.states()[state].to_string();
        Ok(LevelRate {
            rate: state_rate(model, state, &name)?,
            quantity: name,
            state,
            offset: 0.0,
            sign: [1.0, 1.0],
        })
    }

    /// The level crossings of the observable `name` of `model`.
    ///
    /// # Errors
    /// [`CrossingError::NotAvailable`] for an unknown name or an observable that is not c ± a
    /// state on each half of its axis; [`CrossingError::NoiseDriven`] when the observable
    /// depends on a state driven by white noise.
    ///
    /// ```
    /// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\n\
    ///             noise xi: intensity 1\ndiffusion v: xi\n\
    ///             observe y = abs(z), en = v^2/2 + z^2/2, w = z^3\n";
    /// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
    /// use fpsolve::observe::{CrossingError, LevelRate};
    /// assert!(LevelRate::of_observable(&bound, "y").is_ok());
    /// let e = LevelRate::of_observable(&bound, "en");
    /// assert!(matches!(e, Err(CrossingError::NoiseDriven { .. })));
    /// let w = LevelRate::of_observable(&bound, "w");
    /// assert!(matches!(w, Err(CrossingError::NotAvailable { .. })));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn of_observable(model: &BoundModel, name: &str) -> Result<LevelRate, CrossingError> {
        let not_available = |why: &str| CrossingError::NotAvailable {
            quantity: name.to_string(),
            why: why.to_string(),
        };
        let observable = model
            .observables()
            .iter()
            .find(|o| &*o.name == name)
            .ok_or_else(|| not_available("the model has no such observable"))?;
        let states = model.states();
        let (offset, map) = match ObservableMap::classify(&observable.expr, states) {
            ObservableMap::General { expr, .. } => match shifted_state(&expr, states) {
                Some(shifted) => shifted,
                None => {
                    // Rice's formula on a general level set would need ∇g·f on it; where g
                    // depends on a noise-driven state that has no finite value at all.
                    let symbols = expr.symbols();
                    for (a, s) in states.iter().enumerate() {
                        if symbols.contains(s) {
                            if let Some(noise) = noise_of(model, a) {
                                return Err(CrossingError::NoiseDriven {
                                    quantity: name.to_string(),
                                    noise,
                                });
                            }
                        }
                    }
                    return Err(not_available(
                        "Rice's formula is built for the states and for observables that are \
                         c ± a state on each half of its axis (abs(z), yb + abs(z), -z)",
                    ));
                }
            },
            signed => (0.0, signed),
        };
        let ObservableMap::SignedState { state, sign } = map else {
            unreachable!("shifted_state gives a signed state");
        };
        // A noise-driven state first: that has no rate whatever the signs.
        let rate = state_rate(model, state, name)?;
        // sign[a][b] is indexed by (sgn x1, sgn x2); g must not change sign with the other
        // state, or it would jump (g = z·sgn(v)) and cross levels without passing them.
        let half = |h: usize| {
            if state == 0 {
                sign[h]
            } else {
                [sign[0][h], sign[1][h]]
            }
        };
        let [low, high] = [half(0), half(1)];
        if low[0] != low[1] || high[0] != high[1] {
            return Err(not_available(
                "it changes sign with the other state, so it jumps across its levels",
            ));
        }
        Ok(LevelRate {
            rate,
            quantity: name.to_string(),
            state,
            offset,
            sign: [low[0], high[0]],
        })
    }

    /// The quantity's name.
    ///
    /// ```
    /// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// # let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
    /// assert_eq!(fpsolve::observe::LevelRate::of_state(&bound, 0)?.quantity(), "z");
    /// # Ok::<(), fpsolve::observe::CrossingError>(())
    /// ```
    pub fn quantity(&self) -> &str {
        &self.quantity
    }
}

/// The name of a noise source with an intensity of its own that enters state `a`'s equation.
fn noise_of(model: &BoundModel, a: usize) -> Option<String> {
    let s = model.intensity();
    let g = model.noise_matrix();
    model
        .noise_names()
        .iter()
        .enumerate()
        .find(|(k, _)| g[a][*k].as_num() != Some(0.0) && s[*k][*k] != 0.0)
        .map(|(_, n)| n.to_string())
}

/// The rate of state `a`, or why it has no finite value.
fn state_rate(model: &BoundModel, a: usize, quantity: &str) -> Result<StateRate, CrossingError> {
    if let Some(noise) = noise_of(model, a) {
        return Err(CrossingError::NoiseDriven {
            quantity: quantity.to_string(),
            noise,
        });
    }
    let states = model.states();
    // δ terms (the Zhuravlev form's impact terms) act on the barrier line only, a set of
    // measure zero for the crossings of any other level.
    let expr = crate::symbolic::simplify(&model.drift()[a].without_deltas());
    if expr == Expr::sym(&states[1 - a]) {
        Ok(StateRate::Velocity)
    } else {
        Ok(StateRate::Drift {
            expr,
            states: states.clone(),
        })
    }
}

/// The up-crossing rates ν⁺(u) of a quantity at a set of levels, from one density.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossingCurve {
    /// The state or observable.
    pub quantity: String,
    /// The levels u.
    pub levels: Vec<f64>,
    /// ν⁺(u): mean up-crossings per unit time.
    pub rate: Vec<f64>,
    /// The relative accuracy of each rate's integral: the accuracy the density states for
    /// itself ([`JointDensity::stated_accuracy`]), or the line quadrature's tolerance where
    /// that is larger. It does not include a method's discretisation error.
    pub accuracy: f64,
    /// The method's own estimate of each rate's discretisation error (absolute, per level):
    /// the grid's, set by [`CrossingCurve::with_discretisation`]; `None` for a method without
    /// an estimate (EPC's closure error has none).
    pub discretisation: Option<Vec<f64>>,
}

impl CrossingCurve {
    /// The curve with the method's estimate of each rate's discretisation error (absolute,
    /// one per level; the grid's [`crate::grid::GridSolution::estimate_of_each`]).
    ///
    /// ```
    /// use fpsolve::observe::CrossingCurve;
    /// let curve = CrossingCurve {
    ///     quantity: "z".into(),
    ///     levels: vec![0.0],
    ///     rate: vec![0.1],
    ///     accuracy: 1e-9,
    ///     discretisation: None,
    /// };
    /// let curve = curve.with_discretisation(vec![2e-4]);
    /// assert_eq!(curve.error(), Some(vec![2e-4 + 1e-10]));
    /// ```
    pub fn with_discretisation(mut self, errors: Vec<f64>) -> CrossingCurve {
        self.discretisation = Some(errors);
        self
    }

    /// The bound on each rate's error (absolute): the discretisation estimate plus the
    /// integral's accuracy; `None` without a discretisation estimate.
    ///
    /// ```
    /// use fpsolve::observe::CrossingCurve;
    /// let curve = CrossingCurve {
    ///     quantity: "z".into(),
    ///     levels: vec![0.0],
    ///     rate: vec![0.1],
    ///     accuracy: 1e-9,
    ///     discretisation: None,
    /// };
    /// assert_eq!(curve.error(), None);
    /// ```
    pub fn error(&self) -> Option<Vec<f64>> {
        let d = self.discretisation.as_ref()?;
        Some(
            d.iter()
                .zip(&self.rate)
                .map(|(d, r)| d + self.accuracy * r.abs())
                .collect(),
        )
    }
}

/// The mean up-crossing rates ν⁺(u) of `rate`'s quantity at `levels`, by Rice's formula from
/// `density` (see the module documentation).
///
/// # Errors
/// [`CrossingError::Level`] for a level that is not finite (before any work);
/// [`CrossingError::NotFinite`] where the drift has no value on a line.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{crossing_rate, LevelRate};
/// use std::f64::consts::PI;
/// /// The linear oscillator's stationary density: z and v independent, unit variances.
/// struct Normal;
/// impl JointDensity for Normal {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * PI)
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[-9.0, 9.0], [-9.0, 9.0]]
///     }
/// }
/// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.5*v - z\n\
///             noise xi: intensity 1\ndiffusion v: xi\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let curve = crossing_rate(&Normal, &LevelRate::of_state(&bound, 0)?, &[0.0, 1.0])?;
/// // Rice: ν⁺(u) = σ_v/(2π σ_z)·exp(−u²/(2σ_z²)).
/// assert!((curve.rate[1] - (-0.5f64).exp() / (2.0 * PI)).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn crossing_rate(
    density: &dyn JointDensity,
    rate: &LevelRate,
    levels: &[f64],
) -> Result<CrossingCurve, CrossingError> {
    if let Some(&level) = levels.iter().find(|u| !u.is_finite()) {
        return Err(CrossingError::Level {
            quantity: rate.quantity.clone(),
            level,
        });
    }
    let tolerance = rule_tolerance(density);
    // Each level on its own task: a rate does not depend on the number of threads.
    let values = levels
        .par_iter()
        .map(|&u| level_rate(density, rate, u, tolerance))
        .collect::<Result<Vec<f64>, CrossingError>>()?;
    Ok(CrossingCurve {
        quantity: rate.quantity.clone(),
        levels: levels.to_vec(),
        rate: values,
        accuracy: density.stated_accuracy().max(tolerance),
        discretisation: None,
    })
}

/// ν⁺(u): the sum over the branches of the level set.
fn level_rate(
    density: &dyn JointDensity,
    rate: &LevelRate,
    u: f64,
    tolerance: f64,
) -> Result<f64, CrossingError> {
    let [s0, s1] = rate.sign;
    if s0 == s1 {
        // One branch: x = s·(u − c) wherever it lies.
        let x = s0 * (u - rate.offset);
        return branch_rate(density, rate, x, s0, tolerance);
    }
    // A fold at x = 0: the branch of half h is x = s_h·(u − c) where that lies in half h,
    // both at the fold itself (the limit from the side g lives on).
    let mut total = 0.0;
    for (h, s) in [s0, s1].into_iter().enumerate() {
        let x = s * (u - rate.offset);
        let inside = if h == 0 { x <= 0.0 } else { x >= 0.0 };
        if inside {
            total += branch_rate(density, rate, x, s, tolerance)?;
        }
    }
    Ok(total)
}

/// ∫ (s·ẋ_state)⁺ p(x_state = x, t) dt over the other state t.
fn branch_rate(
    density: &dyn JointDensity,
    rate: &LevelRate,
    x: f64,
    s: f64,
    tolerance: f64,
) -> Result<f64, CrossingError> {
    let axis = rate.state;
    let ext = density.extent();
    let [lo, hi] = ext[1 - axis];
    if !(ext[axis][0] <= x && x <= ext[axis][1]) {
        return Ok(0.0);
    }
    match &rate.rate {
        StateRate::Velocity => {
            let halves = [[lo.min(0.0), 0.0], [0.0, hi.max(0.0)]];
            let [low, high] = half_line_moments::<2>(density, axis, x, halves, tolerance);
            // s = +1: ∫_{t>0} t p; s = −1: ∫_{t<0} (−t) p.
            Ok(if s > 0.0 { high[1] } else { -low[1] })
        }
        StateRate::Drift { expr, states } => {
            let f = |t: f64| {
                let mut point = [0.0; 2];
                point[axis] = x;
                point[1 - axis] = t;
                expr.eval_states(states, point, DeltaPolicy::Zero)
                    .map(|v| s * v)
                    .map_err(|e| CrossingError::NotFinite {
                        expr: expr.to_string(),
                        x1: point[0],
                        x2: point[1],
                        why: e.to_string(),
                    })
                    .and_then(|v| {
                        if v.is_finite() {
                            Ok(v)
                        } else {
                            Err(CrossingError::NotFinite {
                                expr: expr.to_string(),
                                x1: point[0],
                                x2: point[1],
                                why: "not finite".into(),
                            })
                        }
                    })
            };
            positive_part_integral(density, axis, x, [lo, hi], &f, tolerance)
        }
    }
}

/// Scan points per line for the roots of the rate.
const SCAN: usize = 64;

/// ∫ f(t)⁺ p(x_axis = at, t) dt over `range`: the range split at the roots of f found on a
/// scan of [`SCAN`] intervals (refined by bisection), each piece where f > 0 by adaptive
/// quadrature to `tolerance`. A root pair inside one scan interval (f dipping below 0 and back
/// within 1/64 of the extent) is missed: its contribution is the integral of f⁺p over less
/// than that width where f is near 0.
fn positive_part_integral(
    density: &dyn JointDensity,
    axis: usize,
    at: f64,
    [lo, hi]: [f64; 2],
    f: &dyn Fn(f64) -> Result<f64, CrossingError>,
    tolerance: f64,
) -> Result<f64, CrossingError> {
    if hi <= lo {
        return Ok(0.0);
    }
    let ts: Vec<f64> = (0..=SCAN)
        .map(|k| lo + (hi - lo) * k as f64 / SCAN as f64)
        .collect();
    let fs = ts.iter().map(|&t| f(t)).collect::<Result<Vec<_>, _>>()?;
    let mut edges = vec![lo];
    for k in 0..SCAN {
        if (fs[k] > 0.0) != (fs[k + 1] > 0.0) {
            let (mut a, mut b, positive_at_a) = (ts[k], ts[k + 1], fs[k] > 0.0);
            for _ in 0..60 {
                let m = 0.5 * (a + b);
                if (f(m)? > 0.0) == positive_at_a {
                    a = m;
                } else {
                    b = m;
                }
            }
            edges.push(0.5 * (a + b));
        }
    }
    edges.push(hi);
    let mut total = 0.0;
    for w in edges.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a || f(0.5 * (a + b))? <= 0.0 {
            continue;
        }
        let mut failure = None;
        let integrand = |t: &[f64], out: &mut [f64]| {
            for (o, &t) in out.iter_mut().zip(t) {
                let mut point = [0.0; 2];
                point[axis] = at;
                point[1 - axis] = t;
                *o = match f(t) {
                    Ok(v) => v.max(0.0) * density.pdf(point),
                    Err(_) => f64::NAN,
                };
            }
        };
        let piece = integrate_panels_batch(&integrand, &[a, b], tolerance);
        if !piece.is_finite() {
            // Find the point that failed, for the message.
            for k in 0..=16 {
                if let Err(e) = f(a + (b - a) * k as f64 / 16.0) {
                    failure = Some(e);
                    break;
                }
            }
            return Err(failure.unwrap_or(CrossingError::NotFinite {
                expr: "the rate times the density".into(),
                x1: at,
                x2: 0.5 * (a + b),
                why: "its integral did not converge".into(),
            }));
        }
        total += piece;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_model;
    use std::f64::consts::PI;

    /// Independent centred normals with standard deviations `s`.
    struct Normal {
        s: [f64; 2],
    }

    impl JointDensity for Normal {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            let [a, b] = [x[0] / self.s[0], x[1] / self.s[1]];
            (-(a * a + b * b) / 2.0).exp() / (2.0 * PI * self.s[0] * self.s[1])
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            [
                [-12.0 * self.s[0], 12.0 * self.s[0]],
                [-12.0 * self.s[1], 12.0 * self.s[1]],
            ]
        }
    }

    fn model(drift_x: &str, observe: &str) -> BoundModel {
        let text = format!(
            "model m\nstate z, v\ndrift z: {drift_x}\ndrift v: -0.2*v - z\n\
             noise xi: intensity 1\ndiffusion v: xi\n{observe}\n"
        );
        parse_model(&text, None).unwrap().bind(&[]).unwrap()
    }

    fn phi(x: f64) -> f64 {
        (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
    }

    /// The linear oscillator's Gaussian: ν⁺(u) = σ_v/(2πσ_x)·exp(−u²/(2σ_x²)).
    #[test]
    fn rice_rate_of_a_gaussian_position() {
        let d = Normal { s: [1.7, 0.6] };
        let rate = LevelRate::of_state(&model("v", ""), 0).unwrap();
        let levels = [-4.0, -1.0, 0.0, 0.5, 2.0, 6.0];
        let curve = crossing_rate(&d, &rate, &levels).unwrap();
        for (u, r) in levels.iter().zip(&curve.rate) {
            let exact = 0.6 / (2.0 * PI * 1.7) * (-u * u / (2.0 * 1.7 * 1.7)).exp();
            assert!((r - exact).abs() <= 1e-9 * exact, "u={u}: {r} vs {exact}");
        }
        assert_eq!(curve.accuracy, 1e-9);
        assert_eq!(curve.error(), None);
    }

    /// A density separable as p_x(x)·N(0, σ_v²) (a Duffing oscillator's):
    /// ν⁺(u) = p_x(u)·σ_v/√(2π), p_x normalised here by a composite Simpson rule.
    #[test]
    fn rice_rate_of_a_separable_density() {
        struct Duffing {
            norm: f64,
            sv: f64,
        }
        fn potential(x: f64) -> f64 {
            (-0.2 * (x * x / 2.0 + 0.1 * x.powi(4) / 4.0)).exp()
        }
        impl JointDensity for Duffing {
            fn pdf(&self, x: [f64; 2]) -> f64 {
                potential(x[0]) / self.norm * phi(x[1] / self.sv) / self.sv
            }
            fn extent(&self) -> [[f64; 2]; 2] {
                [[-20.0, 20.0], [-12.0 * self.sv, 12.0 * self.sv]]
            }
        }
        let norm = crate::observe::quadrature::simpson(potential, -20.0, 20.0, 20000);
        let sv = 5f64.sqrt();
        let d = Duffing { norm, sv };
        let rate = LevelRate::of_state(&model("v", ""), 0).unwrap();
        let levels = [0.0, 1.0, 3.0, 5.0];
        let curve = crossing_rate(&d, &rate, &levels).unwrap();
        for (u, r) in levels.iter().zip(&curve.rate) {
            let exact = potential(*u) / norm * sv / (2.0 * PI).sqrt();
            assert!((r - exact).abs() <= 1e-9 * exact, "u={u}: {r} vs {exact}");
        }
    }

    /// A rate other than the velocity, ż = v − z/2: ν⁺(u) = φ(u)·(φ(a) − a(1 − Φ(a))), a = u/2,
    /// for unit normals (the positive part's integral ∫_a^∞ (v − a) φ(v) dv).
    #[test]
    fn general_rate_integrates_its_positive_part() {
        let d = Normal { s: [1.0, 1.0] };
        let rate = LevelRate::of_state(&model("v - z/2", ""), 0).unwrap();
        assert!(matches!(rate.rate, StateRate::Drift { .. }));
        let levels = [-2.0, 0.0, 1.0, 3.0];
        let curve = crossing_rate(&d, &rate, &levels).unwrap();
        for (u, r) in levels.iter().zip(&curve.rate) {
            let a = u / 2.0;
            // 1 − Φ(a) by Simpson on [a, a + 14].
            let tail = crate::observe::quadrature::simpson(phi, a, a + 14.0, 4000);
            let exact = phi(*u) * (phi(a) - a * tail);
            assert!((r - exact).abs() <= 1e-8 * exact, "u={u}: {r} vs {exact}");
        }
    }

    /// |z| folds the two branches: ν⁺_{|z|}(u) = ν⁺_z(u) + ν⁻_z(−u) = 2ν⁺_z(u) for the
    /// symmetric Gaussian, at u = 0 too (the limit from above); yb + |z| is the same shifted.
    #[test]
    fn folded_observable_sums_its_branches() {
        let d = Normal { s: [1.3, 0.8] };
        let b = model("v", "observe y = abs(z), w = 0.5 + abs(z), m = -z");
        let z = crossing_rate(&d, &LevelRate::of_state(&b, 0).unwrap(), &[0.0, 0.7]).unwrap();
        let y = LevelRate::of_observable(&b, "y").unwrap();
        let y = crossing_rate(&d, &y, &[0.0, 0.7]).unwrap();
        let w = LevelRate::of_observable(&b, "w").unwrap();
        let w = crossing_rate(&d, &w, &[0.5, 1.2, 0.2]).unwrap();
        for k in 0..2 {
            assert!((y.rate[k] - 2.0 * z.rate[k]).abs() <= 1e-12 * z.rate[k]);
            assert_eq!(w.rate[k], y.rate[k]);
        }
        // Below its floor the shifted observable has no level set.
        assert_eq!(w.rate[2], 0.0);
        // −z up-crosses u where z down-crosses −u: by symmetry ν⁺_z(−u) = ν⁺_z(u).
        let m = LevelRate::of_observable(&b, "m").unwrap();
        let m = crossing_rate(&d, &m, &[0.7]).unwrap();
        assert!((m.rate[0] - z.rate[1]).abs() <= 1e-12 * z.rate[1]);
    }

    #[test]
    fn noise_driven_and_unsupported_quantities_are_refused() {
        let b = model("v", "observe en = v^2/2 + z^2/2, s = z*sgn(v), c = z^3");
        let noise = |r: Result<LevelRate, CrossingError>| matches!(r, Err(CrossingError::NoiseDriven { ref noise, .. }) if noise == "xi");
        assert!(noise(LevelRate::of_state(&b, 1)));
        assert!(noise(LevelRate::of_observable(&b, "en")));
        for name in ["s", "c", "nothing"] {
            assert!(matches!(
                LevelRate::of_observable(&b, name),
                Err(CrossingError::NotAvailable { .. })
            ));
        }
        let d = Normal { s: [1.0, 1.0] };
        let rate = LevelRate::of_state(&b, 0).unwrap();
        assert!(matches!(
            crossing_rate(&d, &rate, &[0.0, f64::NAN]),
            Err(CrossingError::Level { .. })
        ));
    }
}
