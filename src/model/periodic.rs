//! A periodic state (`domain theta periodic 2*pi`): an angle, whose values are taken modulo
//! the period on the window [−L/2, L/2). Binding checks the period and that the model's
//! coefficients repeat with it.

use crate::symbolic::{DeltaPolicy, Expr, Symbol};

/// The `domain STATE periodic PERIOD` line: the state is an angle.
///
/// ```
/// let text = "model pendulum\nparam c = 0.2\nstate theta, w\ndrift theta: w\n\
///             drift w: -c*w - sin(theta)\nnoise xi: intensity 0.1\ndiffusion w: xi\n\
///             domain theta periodic 2*pi\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// assert_eq!(model.periodic().unwrap().state, 0);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Periodic {
    /// Index of the periodic state.
    pub state: usize,
    /// The period, an expression of parameters.
    pub period: Expr,
}

/// A periodic state with its period's value: the state lives on [−L/2, L/2), the two ends
/// one point.
///
/// ```
/// let text = "model pendulum\nstate theta, w\ndrift theta: w\ndrift w: -w - sin(theta)\n\
///             noise xi: intensity 0.1\ndiffusion w: xi\ndomain theta periodic 2*pi\n";
/// let bound = fpsolve::model::parse_model(text, None)?.bind(&[])?;
/// let p = bound.periodic().unwrap();
/// assert_eq!(p.window(), [-std::f64::consts::PI, std::f64::consts::PI]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundPeriodic {
    /// Index of the periodic state.
    pub state: usize,
    /// The period L > 0.
    pub period: f64,
}

impl BoundPeriodic {
    /// The window [−L/2, L/2) the state's values are taken in.
    pub fn window(&self) -> [f64; 2] {
        [-0.5 * self.period, 0.5 * self.period]
    }

    /// `x` taken into the window.
    ///
    /// ```
    /// let p = fpsolve::model::BoundPeriodic { state: 0, period: 2.0 };
    /// assert_eq!(p.wrap(2.5), 0.5);
    /// assert_eq!(p.wrap(-1.0), -1.0);
    /// ```
    pub fn wrap(&self, x: f64) -> f64 {
        let [lo, _] = self.window();
        x - self.period * ((x - lo) / self.period).floor()
    }
}

/// Probe points of the periodic state, in periods (irrational steps so that no probe lands
/// on a symmetry point of a trigonometric coefficient), and of the other state.
const PROBES: [(f64, f64); 6] = [
    (-0.4142, -1.7321),
    (-0.2718, 0.5),
    (-0.0707, 2.2361),
    (0.1234, -0.3162),
    (0.3271, 1.3894),
    (0.4472, -2.6458),
];

/// Relative size of a difference between a coefficient at x and at x + L that still counts
/// as equal (rounding in sin, cos of arguments of a few periods).
const SAME: f64 = 1e-9;

/// The first coefficient (named by `names`) that does not repeat with the period: its name
/// and the probe point (x, other) where f(x + L) ≠ f(x). Coefficients that cannot be
/// evaluated at a probe (a time-dependent one at t = 0 included) are compared wherever both
/// values are finite.
pub(crate) fn first_not_periodic<'a>(
    states: &[Symbol; 2],
    periodic: BoundPeriodic,
    coefficients: impl IntoIterator<Item = (String, &'a Expr)>,
) -> Option<(String, [f64; 2])> {
    let k = periodic.state;
    for (name, e) in coefficients {
        for &(a, b) in &PROBES {
            let mut x = [0.0; 2];
            x[k] = a * periodic.period;
            x[1 - k] = b;
            let mut shifted = x;
            shifted[k] += periodic.period;
            let at = |x| e.eval_states(states, x, DeltaPolicy::Zero);
            let (Ok(f0), Ok(f1)) = (at(x), at(shifted)) else {
                continue;
            };
            if !(f0.is_finite() && f1.is_finite()) {
                continue;
            }
            if (f1 - f0).abs() > SAME * (1.0 + f0.abs().max(f1.abs())) {
                return Some((name, x));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sym(s: &str) -> Symbol {
        Symbol::from(s)
    }

    #[test]
    fn wrapping_keeps_the_window_half_open() {
        let p = BoundPeriodic {
            state: 0,
            period: 2.0 * std::f64::consts::PI,
        };
        let pi = std::f64::consts::PI;
        assert_eq!(p.wrap(pi), -pi);
        assert_eq!(p.wrap(-pi), -pi);
        assert!((p.wrap(3.0 * pi + 0.5) - (-pi + 0.5)).abs() < 1e-12);
    }

    const PENDULUM: &str = "model p\nparam c = 0.5\nstate theta, w\ndrift theta: w\n\
                            drift w: -c*w - sin(theta)\nnoise xi: intensity 1\n\
                            diffusion w: xi\n";

    fn bind(extra: &str) -> Result<crate::model::BoundModel, String> {
        let model = crate::model::parse_model(&format!("{PENDULUM}{extra}"), None)
            .map_err(|e| format!("load: {e}"))?;
        model.bind(&[]).map_err(|e| format!("bind: {e}"))
    }

    #[test]
    fn the_line_is_read_bound_checked_and_printed_back() {
        let b = bind("domain theta periodic 2*pi\n").unwrap();
        assert_eq!(b.periodic().map(|p| p.state), Some(0));
        let model =
            crate::model::parse_model(&format!("{PENDULUM}domain theta periodic 2*pi\n"), None)
                .unwrap();
        let printed = model.to_string();
        assert!(printed.contains("domain theta periodic"), "{printed}");
        let again = crate::model::parse_model(&printed, None).unwrap();
        assert_eq!(again.periodic(), model.periodic());
        // A period that is not positive, coefficients that do not repeat, an impact law, a
        // second domain line: each refused with its reason.
        let e = bind("domain theta periodic -c\n").unwrap_err();
        assert!(e.starts_with("bind:") && e.contains("positive"), "{e}");
        let e = bind("domain theta periodic pi\n").unwrap_err();
        assert!(e.contains("does not repeat with the period"), "{e}");
        let e = bind("domain w periodic 2*pi\n").unwrap_err();
        assert!(e.contains("the drift of `theta`"), "{e}");
        let e = bind("impact theta = 1: w -> -0.5*w\ndomain theta periodic 2*pi\n").unwrap_err();
        assert!(e.starts_with("load:") && e.contains("impact law"), "{e}");
        let e = bind("domain theta periodic 2*pi\ndomain theta >= 0\n").unwrap_err();
        assert!(e.starts_with("load:") && e.contains("domain"), "{e}");
    }

    #[test]
    fn a_sine_repeats_and_a_linear_term_does_not() {
        let states = [sym("theta"), sym("w")];
        let p = BoundPeriodic {
            state: 0,
            period: 2.0 * std::f64::consts::PI,
        };
        let sine = crate::model::parse_expr("-w - sin(theta)").unwrap();
        assert_eq!(
            first_not_periodic(&states, p, [("drift".to_string(), &sine)]),
            None
        );
        let linear = crate::model::parse_expr("-w - theta").unwrap();
        let found = first_not_periodic(&states, p, [("drift".to_string(), &linear)]);
        assert_eq!(found.map(|f| f.0), Some("drift".to_string()));
        // Half the period is not the period of sin.
        let half = BoundPeriodic {
            state: 0,
            period: std::f64::consts::PI,
        };
        assert!(first_not_periodic(&states, half, [("drift".to_string(), &sine)]).is_some());
    }
}
