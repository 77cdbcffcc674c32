//! PDFs and moments of the observables g(x1, x2) a model names, from any solved joint density
//! (the paper's Eqs. 23–28). It comes after the methods (EPC, EPC with the exact impact
//! condition, the grid), which hand it a [`JointDensity`], and before the study and the
//! reports, which ask it for every quantity's curve and moments.
//!
//! An observable that is ± a state on each quadrant — `abs(z)`, `v*sgn(z)`, `-v`, `z` — gets the
//! exact treatment: p_g(u) is a sum of line integrals of the joint density over half-lines
//! (Eq. 25: p_Y(y) = p_Z(y) + p_Z(−y); Eq. 28: p_Ẏ(v) = ∫_0^∞ p(z, v) dz + ∫_−∞^0 p(z, −v) dz),
//! each done by adaptive Gauss–Kronrod quadrature to a relative tolerance of 1e−10 — or, when
//! the density tells where it is smooth along the line ([`JointDensity::smooth_pieces`]: EPC
//! on the plane, one analytic piece; inside a ridge, the runs of the region's cells split at
//! the cutoff's levels), piece by piece by nested Clenshaw–Curtis rules whose doubling test
//! must pass at a tenth of the accuracy the density states ([`JointDensity::stated_accuracy`]:
//! 1e−10 on the plane, 2.4e−8 inside vibro_duffing's degree-4 ridge), adaptive where it does
//! not (see `lines.rs` for the transitions of a cutoff, which are not analytic).
//!
//! Any other observable gets the co-area (level-set) integral
//! p_g(u) = ∫∫ p δ(g − u) dx = ∮_{g=u} p / |∇g| ds, with g and ∇g compiled to a [`Tape`](crate::symbolic::Tape)
//! (see `level.rs` for the method): the level set is cut by the lines of both coordinate
//! families, its roots on each line found by bracketing on a grid and safeguarded Newton, and
//! the line sums integrated by adaptive Gauss–Kronrod quadrature to a relative tolerance of
//! 1e−10. Where p and g are smooth and u is not a critical value of g the result is accurate to
//! about 1e−8 relative (the tests check 1e−6 against exact answers: the energy of the linear
//! oscillator and of the double-well Duffing oscillator, v², z·v, z² − v, |z| + v, |z − v| + v,
//! v + sgn(z)). At the value of a minimum or maximum of g it is the exact one-sided limit
//! p(x*)·2π/√det H (e.g. p(0) of an energy); at a saddle value or a degenerate critical value
//! the density is infinite and +∞ is returned; near a saddle value (logarithmic singularity)
//! the accuracy is lower. Where g is undefined (`log(z)`, z ≤ 0) there is no density: p_g
//! integrates to 1 − [`ObservableMoments::undefined_mass`], which [`moments`] reports; nothing is
//! renormalised.
//!
//! Moments are taken from the joint density directly, E[g^k] = ∬ g^k p ([`moments`]), never
//! from a 1-D curve on a truncated grid; those of ± a state under an analytic density by a
//! tensor Clenshaw–Curtis rule on each quadrant checked against its half, under a density
//! smooth piecewise along lines by one family of those line integrals (with the line's
//! moments of the other state on the same values) under an outer Clenshaw–Curtis rule
//! (`line_moments.rs`), checked the same way at the density's rule tolerance.

mod critical;
mod crossing;
mod crossing_csv;
mod crossing_error;
mod epc;
mod fixed;
mod impacts;
mod level;
mod line_moments;
mod lines;
mod moment_sums;
mod moments;
pub(crate) mod quadrature;

use rayon::prelude::*;

use crate::density::JointDensity;
use crate::symbolic::{simplify, Expr, Func, Symbol, SymbolicError};

pub use crossing::{crossing_rate, CrossingCurve, LevelRate};
pub use crossing_csv::{crossings_csv, crossings_file_name};
pub use crossing_error::CrossingError;
pub use impacts::{impact_statistics, ImpactStatistics};
pub use moment_sums::{ObservableMoments, PointMass, POINT_MASS_FLOOR};
pub use moments::{moments, moments_of_all};
/// Adaptive Gauss–Kronrod quadrature, for this crate's own tests (not public API).
#[cfg(feature = "test-support")]
#[doc(hidden)]
pub use quadrature::integrate_adaptive;

/// Computes the quadrature tables the observables use (once per process), for a caller that
/// can do it beside other work: a study while it solves.
pub(crate) fn prepare() {
    fixed::prepare();
}

/// How an observable is computed from the states.
#[derive(Clone, Debug, PartialEq)]
pub enum ObservableMap {
    /// g = s(q)·x_state on each quadrant q = (sgn x1, sgn x2), s(q) = ±1: exact line integrals.
    SignedState {
        /// The state that g is ± of.
        state: usize,
        /// `sign[a][b]`: the sign of g/x_state where sgn(x1) is `[−, +][a]` and sgn(x2) is
        /// `[−, +][b]`.
        sign: [[f64; 2]; 2],
    },
    /// Anything else: the general co-area (level-set) method.
    General {
        /// The observable, an expression of the states.
        expr: Expr,
        /// The states' names, in order (x1, x2).
        states: [Symbol; 2],
    },
}

impl ObservableMap {
    /// Recognises observables that are ± a state on each quadrant (after simplification);
    /// everything else is [`ObservableMap::General`].
    ///
    /// ```
    /// use fpsolve::observe::ObservableMap;
    /// use fpsolve::symbolic::{Expr, Func};
    /// let states = ["z".into(), "v".into()];
    /// let ydot = Expr::sym("v") * Expr::call(Func::Sgn, Expr::sym("z"));
    /// let map = ObservableMap::classify(&ydot, &states);
    /// assert_eq!(
    ///     map,
    ///     ObservableMap::SignedState { state: 1, sign: [[-1.0, -1.0], [1.0, 1.0]] }
    /// );
    /// ```
    pub fn classify(expr: &Expr, states: &[Symbol; 2]) -> ObservableMap {
        let general = || ObservableMap::General {
            expr: expr.clone(),
            states: states.clone(),
        };
        let e = simplify(expr);
        let factors: Vec<Expr> = match &e {
            Expr::Mul(f) => f.clone(),
            other => vec![other.clone()],
        };
        let mut coefficient = 1.0;
        let mut state: Option<usize> = None;
        // Powers of sgn(x_a) for a = 0, 1.
        let mut sgn_powers = [0u32; 2];
        let index = |e: &Expr| match e {
            Expr::Sym(s) => states.iter().position(|t| t == s),
            _ => None,
        };
        for f in &factors {
            match f {
                Expr::Num(c) => coefficient *= c,
                Expr::Sym(_) => match (index(f), state) {
                    (Some(a), None) => state = Some(a),
                    _ => return general(),
                },
                Expr::Call(Func::Abs, args) => match (index(&args[0]), state) {
                    // |x_a| = x_a·sgn(x_a)
                    (Some(a), None) => {
                        state = Some(a);
                        sgn_powers[a] += 1;
                    }
                    _ => return general(),
                },
                Expr::Call(Func::Sgn, args) => match index(&args[0]) {
                    Some(a) => sgn_powers[a] += 1,
                    None => return general(),
                },
                _ => return general(),
            }
        }
        let Some(state) = state else {
            return general();
        };
        if coefficient.abs() != 1.0 {
            return general();
        }
        let s = |power: u32, negative: bool| {
            if negative && power % 2 == 1 {
                -1.0
            } else {
                1.0
            }
        };
        let mut sign = [[0.0; 2]; 2];
        for (a, row) in sign.iter_mut().enumerate() {
            for (b, entry) in row.iter_mut().enumerate() {
                *entry = coefficient * s(sgn_powers[0], a == 0) * s(sgn_powers[1], b == 0);
            }
        }
        ObservableMap::SignedState { state, sign }
    }
}

/// The PDF of an observable at the points `u`.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{observable_pdf, ObservableMap};
/// use fpsolve::symbolic::{Expr, Func};
/// /// A standard bivariate normal.
/// struct Normal;
/// impl JointDensity for Normal {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[-9.0, 9.0], [-9.0, 9.0]]
///     }
/// }
/// let states = ["z".into(), "v".into()];
/// let y = ObservableMap::classify(&Expr::call(Func::Abs, Expr::sym("z")), &states);
/// let p = observable_pdf(&Normal, &y, &[0.5]);
/// let exact = 2.0 * (-0.125f64).exp() / (2.0 * std::f64::consts::PI).sqrt();
/// assert!((p[0] - exact).abs() < 1e-10 * exact);
/// ```
pub fn observable_pdf(density: &dyn JointDensity, map: &ObservableMap, u: &[f64]) -> Vec<f64> {
    ObservableDensity::new(density, map).pdf(u)
}

/// The PDF of one observable under one joint density, prepared once for evaluation at many
/// points: the general method's tape, bracketing grid and critical points are built here, not
/// per call.
///
/// ```
/// use fpsolve::density::JointDensity;
/// use fpsolve::observe::{ObservableDensity, ObservableMap};
/// use fpsolve::symbolic::Expr;
/// struct Normal;
/// impl JointDensity for Normal {
///     fn pdf(&self, x: [f64; 2]) -> f64 {
///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
///     }
///     fn extent(&self) -> [[f64; 2]; 2] {
///         [[-9.0, 9.0], [-9.0, 9.0]]
///     }
/// }
/// let states = ["z".into(), "v".into()];
/// let sum = ObservableMap::classify(&(Expr::sym("z") + Expr::sym("v")), &states);
/// let p = ObservableDensity::new(&Normal, &sum).pdf(&[0.0, 1.0]);
/// let exact = |u: f64| (-u * u / 4.0).exp() / (4.0 * std::f64::consts::PI).sqrt();
/// assert!((p[0] - exact(0.0)).abs() < 1e-8 * exact(0.0));
/// assert!((p[1] - exact(1.0)).abs() < 1e-8 * exact(1.0));
/// ```
pub struct ObservableDensity<'a> {
    density: &'a dyn JointDensity,
    method: Method,
}

enum Method {
    /// g = `offset` + ± a state on each quadrant (Eqs. 25, 28, shifted): the exact line
    /// integrals. An offset comes from a wall away from 0 under the Zhuravlev transform
    /// (y = y_b ± |z|); the map keeps it [`ObservableMap::General`] for its moments.
    Signed {
        state: usize,
        sign: [[f64; 2]; 2],
        offset: f64,
    },
    Level(Box<level::LevelSet>),
    /// The observable could not be compiled (e.g. a constant `log(-1)`): NaN everywhere.
    Undefined(SymbolicError),
}

impl<'a> ObservableDensity<'a> {
    /// Prepares the PDF of `map` under `density`.
    pub fn new(density: &'a dyn JointDensity, map: &'a ObservableMap) -> ObservableDensity<'a> {
        let method = match map {
            ObservableMap::SignedState { state, sign } => Method::Signed {
                state: *state,
                sign: *sign,
                offset: 0.0,
            },
            ObservableMap::General { expr, states } => match shifted_state(expr, states) {
                Some((offset, ObservableMap::SignedState { state, sign })) => Method::Signed {
                    state,
                    sign,
                    offset,
                },
                _ => match level::LevelSet::new(density, expr, states) {
                    Ok(l) => Method::Level(Box::new(l)),
                    Err(e) => Method::Undefined(e),
                },
            },
        };
        ObservableDensity { density, method }
    }

    /// The PDF at the points `u` (independent points, evaluated in parallel). +∞ at a saddle
    /// or degenerate critical value of g (the density is infinite there); NaN everywhere if
    /// the observable could not be compiled ([`ObservableDensity::error`]).
    pub fn pdf(&self, u: &[f64]) -> Vec<f64> {
        match &self.method {
            Method::Signed {
                state,
                sign,
                offset,
            } => u
                .par_iter()
                .map(|&u| signed_state_pdf(self.density, *state, sign, u - offset))
                .collect(),
            Method::Level(l) => u.par_iter().map(|&u| l.pdf(self.density, u)).collect(),
            Method::Undefined(_) => vec![f64::NAN; u.len()],
        }
    }

    /// Whether the joint density is piecewise (it has [`JointDensity::breakpoints`], as the
    /// grid's interpolant has): its PDFs of maps then kink where level sets meet its pieces.
    pub(crate) fn piecewise(&self) -> bool {
        (0..2).any(|a| self.density.breakpoints(a).is_some())
    }

    /// The values where the density is infinite, sorted: the map's saddle and degenerate
    /// critical values (none for ± a state). Next to each the density has an integrable
    /// singularity (a log, or an inverse power such as u^(−1/2) for v² at 0) that a
    /// polynomial quadrature rule does not integrate.
    pub(crate) fn singular_values(&self) -> Vec<f64> {
        let mut v = match &self.method {
            Method::Level(l) => l.singular_values(),
            Method::Signed { .. } | Method::Undefined(_) => Vec::new(),
        };
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    }

    /// Why the observable has no density at all (it could not be compiled), if so.
    ///
    /// ```
    /// use fpsolve::density::JointDensity;
    /// use fpsolve::observe::{ObservableDensity, ObservableMap};
    /// use fpsolve::symbolic::{Expr, Func};
    /// struct Normal;
    /// impl JointDensity for Normal {
    ///     fn pdf(&self, x: [f64; 2]) -> f64 {
    ///         (-(x[0] * x[0] + x[1] * x[1]) / 2.0).exp() / (2.0 * std::f64::consts::PI)
    ///     }
    ///     fn extent(&self) -> [[f64; 2]; 2] {
    ///         [[-9.0, 9.0], [-9.0, 9.0]]
    ///     }
    /// }
    /// let states = ["z".into(), "v".into()];
    /// let fine = ObservableMap::classify(&(Expr::sym("z") * Expr::sym("v")), &states);
    /// assert!(ObservableDensity::new(&Normal, &fine).error().is_none());
    /// // A constant subexpression with no value: nothing to compute, NaN everywhere.
    /// let bad = Expr::sym("z") + Expr::call(Func::Log, Expr::num(-1.0));
    /// let bad = ObservableMap::classify(&bad, &states);
    /// let d = ObservableDensity::new(&Normal, &bad);
    /// assert!(d.error().is_some());
    /// assert!(d.pdf(&[0.0])[0].is_nan());
    /// ```
    pub fn error(&self) -> Option<&SymbolicError> {
        match &self.method {
            Method::Undefined(e) => Some(e),
            _ => None,
        }
    }
}

/// `c + g` with `c` a number and `g` ± a state on each quadrant (after simplification), as
/// (`c`, the map of `g`): the Zhuravlev transform's y = y_b ± |z| of a wall at y_b ≠ 0.
/// `None` for anything else.
fn shifted_state(expr: &Expr, states: &[Symbol; 2]) -> Option<(f64, ObservableMap)> {
    let Expr::Add(terms) = simplify(expr) else {
        return None;
    };
    let (mut offset, mut rest) = (0.0, Vec::new());
    for t in terms {
        match t {
            Expr::Num(c) => offset += c,
            other => rest.push(other),
        }
    }
    let [g] = <[Expr; 1]>::try_from(rest).ok()?;
    let map = ObservableMap::classify(&g, states);
    (offset.is_finite() && matches!(map, ObservableMap::SignedState { .. }))
        .then_some((offset, map))
}

/// Eqs. 25 and 28 in general: Σ over quadrants of ∫ p(x_state = s·u, x_other) over the
/// quadrant's half-line of x_other, where the quadrant admits x_state = s·u.
///
/// At u = 0, the end of the support of a folded map (|z|, −|z|: a wall under the Zhuravlev
/// transform), the value is the one-sided limit from the side the quantity lives on: the
/// limit u → 0+ (p_Y(0) = 2 p_Z(0), as Eq. 25 defines it), or u → 0− when no quadrant admits
/// positive values (y = y_b − |z| below an upper wall), never the 0 of the side outside.
fn signed_state_pdf(density: &dyn JointDensity, state: usize, sign: &[[f64; 2]; 2], u: f64) -> f64 {
    // g = s·x_state is positive on a quadrant where s has the sign of x_state there.
    let admits_above = (0..2).any(|a| {
        (0..2).any(|b| {
            let own = if state == 0 { a } else { b };
            (own == 1) == (sign[a][b] > 0.0)
        })
    });
    let approach = if u == 0.0 && !admits_above { -1.0 } else { 1.0 };
    signed_state_limit(density, state, sign, u, approach)
}

/// [`signed_state_pdf`] at u, at u = 0 the limit from the side `approach` (+1 or −1).
fn signed_state_limit(
    density: &dyn JointDensity,
    state: usize,
    sign: &[[f64; 2]; 2],
    u: f64,
    approach: f64,
) -> f64 {
    let other = 1 - state;
    let ext = density.extent();
    let tolerance = lines::rule_tolerance(density);
    let halves = [[ext[other][0].min(0.0), 0.0], [0.0, ext[other][1].max(0.0)]];
    // Each quadrant's half-line integral (0 where the quadrant does not admit x_state = s·u),
    // the two quadrants of one half of the state's axis taken together where they meet the
    // same line.
    let mut values = [[0.0; 2]; 2];
    for own in 0..2 {
        let quadrant = |half: usize| if state == 0 { [own, half] } else { [half, own] };
        let admitted = [0, 1].map(|half| {
            let [a, b] = quadrant(half);
            let s = sign[a][b];
            let xs = s * u;
            // x_state = s·u must lie in the quadrant's half-line. At u = 0 the density is
            // taken as its limit from the side `approach` (u → 0+: p_Y(0) = 2 p_Z(0), as
            // Eq. 25 defines it): the side is then the sign of s·approach.
            let side = if u != 0.0 { xs } else { s * approach };
            let inside = if own == 1 { side > 0.0 } else { side < 0.0 };
            let [lo, hi] = halves[half];
            (inside && hi > lo).then_some(xs)
        });
        match admitted {
            [Some(x0), Some(x1)] if x0.to_bits() == x1.to_bits() => {
                let both = lines::half_lines(density, state, x0, halves, tolerance);
                for (half, v) in both.into_iter().enumerate() {
                    let [a, b] = quadrant(half);
                    values[a][b] = v;
                }
            }
            _ => {
                for (half, xs) in admitted.into_iter().enumerate() {
                    if let Some(xs) = xs {
                        let [a, b] = quadrant(half);
                        values[a][b] =
                            lines::half_line(density, state, xs, halves[half], tolerance);
                    }
                }
            }
        }
    }
    // Summed in the quadrants' order (a quadrant not admitted adds +0, which changes no sum
    // that starts at +0).
    values.iter().flatten().fold(0.0, |total, v| total + v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A bivariate normal with means m, unit variances and correlation rho.
    struct Normal {
        m: [f64; 2],
        rho: f64,
    }

    impl JointDensity for Normal {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            let (a, b) = (x[0] - self.m[0], x[1] - self.m[1]);
            let d = 1.0 - self.rho * self.rho;
            (-(a * a - 2.0 * self.rho * a * b + b * b) / (2.0 * d)).exp() / (2.0 * PI * d.sqrt())
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            [
                [self.m[0] - 10.0, self.m[0] + 10.0],
                [self.m[1] - 10.0, self.m[1] + 10.0],
            ]
        }
    }

    fn phi(x: f64) -> f64 {
        (-0.5 * x * x).exp() / (2.0 * PI).sqrt()
    }

    /// Φ by integrating φ (kept independent of the code under test's quadrature).
    fn big_phi(x: f64) -> f64 {
        // Simpson on [-12, x] with many panels.
        quadrature::simpson(phi, -12.0, x, 20000)
    }

    fn states() -> [Symbol; 2] {
        ["z".into(), "v".into()]
    }

    #[test]
    fn folded_displacement_is_eq_25() {
        let d = Normal {
            m: [0.5, -0.3],
            rho: 0.4,
        };
        let y = ObservableMap::classify(&Expr::call(Func::Abs, Expr::sym("z")), &states());
        assert!(matches!(y, ObservableMap::SignedState { state: 0, .. }));
        let u = [0.0, 0.3, 1.0, 2.5, 6.0];
        let p = observable_pdf(&d, &y, &u);
        for (u, p) in u.iter().zip(&p) {
            let exact = phi(u - 0.5) + phi(-u - 0.5);
            assert!((p - exact).abs() <= 1e-9 * exact, "y={u}: {p} vs {exact}");
        }
    }

    /// y = y_b ± |z| (the Zhuravlev map of a wall at y_b ≠ 0, above or below it): Eq. 25
    /// shifted, p_Y(y) = p_Z(y − y_b) + p_Z(y_b − y) on the domain's side, and at the wall
    /// itself the limit from that side, 2·p_Z(0), not the 0 of the side outside.
    #[test]
    fn folded_displacement_of_an_offset_wall_has_its_limit_at_the_wall() {
        let d = Normal {
            m: [0.5, -0.3],
            rho: 0.4,
        };
        let abs = Expr::call(Func::Abs, Expr::sym("z"));
        for side in [1.0, -1.0] {
            let wall = -0.5 * side;
            let g = Expr::num(wall) + Expr::num(side) * abs.clone();
            let map = ObservableMap::classify(&g, &states());
            assert!(matches!(map, ObservableMap::General { .. }));
            let u: Vec<f64> = [0.0, 0.3, 1.0, 2.5]
                .iter()
                .map(|t| wall + side * t)
                .collect();
            let p = observable_pdf(&d, &map, &u);
            for (u, p) in u.iter().zip(&p) {
                let t = (u - wall) * side;
                let exact = phi(t - 0.5) + phi(-t - 0.5);
                assert!(
                    (p - exact).abs() <= 1e-9 * exact,
                    "{side}: y={u}: {p} vs {exact}"
                );
            }
            assert_eq!(observable_pdf(&d, &map, &[wall - side * 0.1])[0], 0.0);
        }
    }

    /// [`Normal`], declared analytic: its half-line integrals by the nested fixed rules.
    struct AnalyticNormal(Normal);

    impl JointDensity for AnalyticNormal {
        fn pdf(&self, x: [f64; 2]) -> f64 {
            self.0.pdf(x)
        }
        fn extent(&self) -> [[f64; 2]; 2] {
            self.0.extent()
        }
        fn analytic(&self) -> bool {
            true
        }
    }

    #[test]
    fn fixed_rules_agree_with_eqs_25_and_28() {
        let d = AnalyticNormal(Normal {
            m: [0.5, -0.3],
            rho: 0.4,
        });
        let y = ObservableMap::classify(&Expr::call(Func::Abs, Expr::sym("z")), &states());
        let u = [0.0, 0.3, 1.0, 2.5, 6.0];
        let p = observable_pdf(&d, &y, &u);
        for (u, p) in u.iter().zip(&p) {
            let exact = phi(u - 0.5) + phi(-u - 0.5);
            assert!((p - exact).abs() <= 1e-9 * exact, "y={u}: {p} vs {exact}");
        }
        // The same as the adaptive quadrature's values, to its tolerance.
        let adaptive = observable_pdf(&d.0, &y, &u);
        for (a, p) in adaptive.iter().zip(&p) {
            assert!((a - p).abs() <= 1e-10 * a, "{p} vs adaptive {a}");
        }
        let rho: f64 = 0.6;
        let d = AnalyticNormal(Normal { m: [0.0, 0.0], rho });
        assert_ydot_is_eq_28_skew_normal(&d, rho);
    }

    #[test]
    fn fixed_tensor_rule_moments_are_exact_and_agree_with_the_grid() {
        let d = AnalyticNormal(Normal {
            m: [0.5, -0.3],
            rho: 0.4,
        });
        let s = states();
        let z = ObservableMap::classify(&Expr::sym("z"), &s);
        let y = ObservableMap::classify(&Expr::call(Func::Abs, Expr::sym("z")), &s);
        let ydot = ObservableMap::classify(
            &(Expr::sym("v") * Expr::call(Func::Sgn, Expr::sym("z"))),
            &s,
        );
        let fixed = moments_of_all(&d, &[&z, &y, &ydot]);
        let grid = moments_of_all(&d.0, &[&z, &y, &ydot]);
        // z ~ N(0.5, 1): E z² = 1.25, E z⁴ = 3 + 6·0.25 + 0.0625; |z| has the even ones.
        for m in &fixed[..2] {
            assert!((m.moments.raw[1] - 1.25).abs() < 1e-12, "{m:?}");
            assert!((m.moments.raw[3] - 4.5625).abs() < 1e-12, "{m:?}");
        }
        assert!((fixed[0].moments.mean - 0.5).abs() < 1e-12);
        assert!((fixed[0].moments.variance - 1.0).abs() < 1e-12);
        assert!((fixed[0].moments.kurtosis - 3.0).abs() < 1e-12);
        // The tensor rule was used (its check passed), not the grid it falls back to.
        assert_ne!(fixed[0].moments.raw[1], grid[0].moments.raw[1]);
        for (f, g) in fixed.iter().zip(&grid) {
            let (f, g) = (&f.moments, &g.moments);
            for k in 0..4 {
                let scale = g.raw[3].powf((k + 1) as f64 / 4.0);
                assert!(
                    (f.raw[k] - g.raw[k]).abs() <= 1e-10 * scale,
                    "{f:?} vs {g:?}"
                );
            }
            assert!((f.variance - g.variance).abs() <= 1e-10 * g.variance);
            assert!((f.kurtosis - g.kurtosis).abs() <= 1e-10 * g.kurtosis);
        }
    }

    /// For a centred normal with correlation rho, Eq. 28 gives ydot = v·sgn(z) the density
    /// 2 φ(u) Φ(rho u / √(1−rho²)): `d` (that normal) must reproduce it to 1e-8.
    fn assert_ydot_is_eq_28_skew_normal(d: &impl JointDensity, rho: f64) {
        let ydot = Expr::sym("v") * Expr::call(Func::Sgn, Expr::sym("z"));
        let map = ObservableMap::classify(&ydot, &states());
        let u = [-3.0, -1.0, 0.0, 0.5, 2.0, 4.0];
        let p = observable_pdf(d, &map, &u);
        for (u, p) in u.iter().zip(&p) {
            let exact = 2.0 * phi(*u) * big_phi(rho * u / (1.0 - rho * rho).sqrt());
            assert!(
                (p - exact).abs() <= 1e-8 * exact,
                "ydot={u}: {p} vs {exact}"
            );
        }
    }

    #[test]
    fn velocity_times_sign_is_eq_28_a_skew_normal() {
        // For a centred normal with correlation rho, Eq. 28 gives 2 φ(u) Φ(rho u / √(1−rho²)).
        let rho: f64 = 0.6;
        let d = Normal { m: [0.0, 0.0], rho };
        assert_ydot_is_eq_28_skew_normal(&d, rho);
    }

    #[test]
    fn classification_of_common_observables() {
        let s = states();
        let z = || Expr::sym("z");
        let v = || Expr::sym("v");
        let sgn = |e: Expr| Expr::call(Func::Sgn, e);
        let abs = |e: Expr| Expr::call(Func::Abs, e);
        assert_eq!(
            ObservableMap::classify(&z(), &s),
            ObservableMap::SignedState {
                state: 0,
                sign: [[1.0; 2]; 2]
            }
        );
        assert_eq!(
            ObservableMap::classify(&-(v() * sgn(z()) * sgn(v())), &s),
            ObservableMap::SignedState {
                state: 1,
                sign: [[-1.0, 1.0], [1.0, -1.0]]
            }
        );
        assert!(matches!(
            ObservableMap::classify(&(z() + v()), &s),
            ObservableMap::General { .. }
        ));
        assert!(matches!(
            ObservableMap::classify(&(Expr::num(2.0) * abs(z())), &s),
            ObservableMap::General { .. }
        ));
        assert!(matches!(
            ObservableMap::classify(&(z() * v()), &s),
            ObservableMap::General { .. }
        ));
    }

    #[test]
    fn general_method_is_accurate_for_a_sum_of_correlated_normals() {
        // z + v ~ N(0, 2 + 2 rho).
        let rho = 0.3;
        let d = Normal { m: [0.0, 0.0], rho };
        let map = ObservableMap::classify(&(Expr::sym("z") + Expr::sym("v")), &states());
        let s = (2.0 + 2.0 * rho).sqrt();
        let u = [0.0, 1.0, 2.0, 3.0, 4.0];
        let p = observable_pdf(&d, &map, &u);
        for (u, p) in u.iter().zip(&p) {
            let exact = phi(u / s) / s;
            assert!((p - exact).abs() <= 1e-8 * exact, "z+v={u}: {p} vs {exact}");
        }
    }

    #[test]
    fn co_area_method_near_a_minimum_between_grid_points() {
        // g = (z² + v²)/2 under a shifted, correlated normal: the minimum of g at the origin
        // is not a grid point, and the level sets near u = 0 are circles far smaller than a
        // grid cell. Exact: p_g(u) = ∫_0^{2π} p(r cos θ, r sin θ) dθ with r = √(2u)
        // (|∇g| = r, ds = r dθ), by the trapezoid rule (spectral for a periodic integrand).
        let d = Normal {
            m: [0.37, -0.21],
            rho: 0.3,
        };
        let g =
            (Expr::sym("z") * Expr::sym("z") + Expr::sym("v") * Expr::sym("v")) / Expr::num(2.0);
        let map = ObservableMap::classify(&g, &states());
        let exact = |u: f64| {
            let r = (2.0 * u).sqrt();
            let n = 400;
            (0..n)
                .map(|k| {
                    let t = 2.0 * PI * k as f64 / n as f64;
                    d.pdf([r * t.cos(), r * t.sin()])
                })
                .sum::<f64>()
                * 2.0
                * PI
                / n as f64
        };
        let u = [0.0, 1e-12, 1e-6, 1e-3, 0.02, 0.3, 2.0, 8.0, 30.0];
        let p = observable_pdf(&d, &map, &u);
        for (u, p) in u.iter().zip(&p) {
            let e = exact(*u);
            assert!((p - e).abs() <= 1e-7 * e, "g={u}: {p} vs {e}");
        }
        // Below the minimum there is no level set.
        assert_eq!(observable_pdf(&d, &map, &[-0.1])[0], 0.0);
    }
}
