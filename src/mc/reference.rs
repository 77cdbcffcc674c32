//! Reference models built in code, for tests, benchmarks and examples that should not depend
//! on the model-file parser: the linear oscillator, the Duffing oscillator and the paper's
//! vibro-impact Duffing oscillator in Zhuravlev coordinates (Eq. 10).
//!
//! Each returns an unbound [`Model`] whose numbers are parameters, so `--set`-style
//! overrides work as for a parsed model.

use crate::model::ImpactLaw;
use crate::model::{DeltaTreatment, Interpretation, Model, NoiseSource, Observable, Parameter};
use crate::symbolic::{Expr, Func};

fn param(name: &str, value: f64) -> Parameter {
    Parameter {
        name: name.into(),
        default: Expr::num(value),
    }
}

fn s(name: &str) -> Expr {
    Expr::sym(name)
}

fn oscillator(name: &str, params: Vec<Parameter>, force: Expr, noise: Expr) -> Model {
    Model {
        name: name.into(),
        description: String::new(),
        params,
        states: ["z".into(), "v".into()],
        drift: [s("v"), force],
        noises: vec![NoiseSource {
            name: "xi".into(),
            intensity: noise,
        }],
        correlations: vec![],
        noise_matrix: [vec![Expr::num(0.0)], vec![Expr::num(1.0)]],
        interpretation: Interpretation::Stratonovich,
        impacts: vec![],
        domain: None,
        observables: vec![],
        delta: DeltaTreatment::Exact,
        origin: None,
    }
}

/// `z'' + c z' + k z = ξ(t)`, E[ξ(t)ξ(t+τ)] = S δ(τ); parameters `c`, `k`, `S`. The
/// stationary displacement variance is S/(2ck) (= πK/(ck) with S = 2πK).
///
/// ```
/// let m = fpsolve::mc::reference::linear_oscillator(0.1, 1.0, 2.0);
/// assert_eq!(m.params().len(), 3);
/// ```
pub fn linear_oscillator(c: f64, k: f64, intensity: f64) -> Model {
    oscillator(
        "linear",
        vec![param("c", c), param("k", k), param("S", intensity)],
        -(s("c") * s("v")) - s("k") * s("z"),
        s("S"),
    )
}

/// The linear oscillator with a second, independent source of intensity 1 entering the
/// velocity as ½·v·ξ₁: `v' = −c v − k z + ξ₀ + ½ v ξ₁`, read as `interpretation`. The
/// stationary E[v²] is S/(2c − ¼) read as Itô and S/(2c − ½) read as Stratonovich (Wong–Zakai
/// adds ⅛·v to the drift).
///
/// ```
/// use fpsolve::model::Interpretation;
/// let m = fpsolve::mc::reference::linear_with_velocity_noise(1.0, 1.0, 1.0, Interpretation::Ito);
/// assert_eq!(m.bind(&[]).unwrap().noise_names().len(), 2);
/// ```
pub fn linear_with_velocity_noise(
    c: f64,
    k: f64,
    intensity: f64,
    interpretation: Interpretation,
) -> Model {
    let mut m = linear_oscillator(c, k, intensity);
    m.noises.push(NoiseSource {
        name: "xi1".into(),
        intensity: Expr::num(1.0),
    });
    m.noise_matrix = [
        vec![Expr::num(0.0), Expr::num(0.0)],
        vec![Expr::num(1.0), Expr::num(0.5) * s("v")],
    ];
    m.interpretation = interpretation;
    m
}

/// `z'' + c z' + k z + μ z³ = ξ(t)`, E[ξ(t)ξ(t+τ)] = S δ(τ); parameters `c`, `k`, `mu`, `S`.
/// The stationary density is ∝ exp(−(2c/S)(v²/2 + k z²/2 + μ z⁴/4)).
///
/// ```
/// let m = fpsolve::mc::reference::duffing(0.1, 1.0, 0.5, 2.0);
/// assert_eq!(m.states()[0].as_ref(), "z");
/// ```
pub fn duffing(c: f64, k: f64, mu: f64, intensity: f64) -> Model {
    oscillator(
        "duffing",
        vec![
            param("c", c),
            param("k", k),
            param("mu", mu),
            param("S", intensity),
        ],
        -(s("c") * s("v")) - s("k") * s("z") - s("mu") * Expr::pow(s("z"), Expr::num(3.0)),
        s("S"),
    )
}

/// Parameters of the paper's vibro-impact Duffing oscillator (Eqs. 1–4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VibroImpact {
    /// Damping c.
    pub c: f64,
    /// Linear stiffness k.
    pub k: f64,
    /// Cubic stiffness μ.
    pub mu: f64,
    /// Parametric excitation factor ε.
    pub eps: f64,
    /// Restitution factor r.
    pub r: f64,
    /// Excitation level K (intensity 2πK).
    pub big_k: f64,
}

/// The paper's vibro-impact oscillator in Zhuravlev coordinates (Eq. 10), with the impact law
/// `z = 0: v → r·v` (Eq. 6) and the observables `y = |z|`, `ydot = v·sgn(z)` (Eq. 5).
/// Parameters `c`, `k`, `mu`, `eps`, `r`, `K`.
///
/// ```
/// use fpsolve::mc::reference::{vibro_impact, VibroImpact};
/// let p = VibroImpact { c: 0.1, k: 1.0, mu: 0.5, eps: 0.1, r: 0.9, big_k: 0.1 };
/// assert_eq!(vibro_impact(p).observables().len(), 2);
/// ```
pub fn vibro_impact(p: VibroImpact) -> Model {
    let (z, v) = (s("z"), s("v"));
    let abs_v = Expr::call(Func::Abs, v.clone());
    let sgn_z = Expr::call(Func::Sgn, z.clone());
    let force = -(s("c") * v.clone())
        - s("k") * z.clone()
        - s("mu") * Expr::pow(z.clone(), Expr::num(3.0))
        - (Expr::num(1.0) - s("r")) * v.clone() * abs_v * Expr::call(Func::Delta, z.clone());
    let mut m = oscillator(
        "vibro-impact",
        vec![
            param("c", p.c),
            param("k", p.k),
            param("mu", p.mu),
            param("eps", p.eps),
            param("r", p.r),
            param("K", p.big_k),
        ],
        force,
        Expr::num(2.0 * std::f64::consts::PI) * s("K"),
    );
    m.noise_matrix[1] = vec![sgn_z.clone() + s("eps") * z.clone()];
    m.impacts = vec![ImpactLaw {
        state: 0,
        at: Expr::num(0.0),
        other: 1,
        map: s("r") * v.clone(),
    }];
    m.observables = vec![
        Observable {
            name: "y".into(),
            expr: Expr::call(Func::Abs, z.clone()),
        },
        Observable {
            name: "ydot".into(),
            expr: v * sgn_z,
        },
    ];
    m
}

/// The paper's oscillator in its original coordinates (Eqs. 1–2): `y'' + c y' + k y + μ y³ =
/// (1 + ε y) ξ(t)` for `y > 0`, with the reflecting impact law `y = 0: ẏ → −r·ẏ`. States `y`,
/// `ydot`. Simulated directly, it must give the same stationary law as [`vibro_impact`] does
/// through the Zhuravlev map, for any r (the transformation is exact for trajectories).
///
/// ```
/// use fpsolve::mc::reference::{reflecting_vibro_impact, VibroImpact};
/// let p = VibroImpact { c: 0.1, k: 1.0, mu: 0.5, eps: 0.1, r: 0.9, big_k: 0.1 };
/// assert_eq!(reflecting_vibro_impact(p).states()[0].as_ref(), "y");
/// ```
pub fn reflecting_vibro_impact(p: VibroImpact) -> Model {
    let (y, v) = (s("y"), s("ydot"));
    let force =
        -(s("c") * v.clone()) - s("k") * y.clone() - s("mu") * Expr::pow(y.clone(), Expr::num(3.0));
    let mut m = oscillator(
        "vibro-impact-reflecting",
        vec![
            param("c", p.c),
            param("k", p.k),
            param("mu", p.mu),
            param("eps", p.eps),
            param("r", p.r),
            param("K", p.big_k),
        ],
        force,
        Expr::num(2.0 * std::f64::consts::PI) * s("K"),
    );
    m.states = ["y".into(), "ydot".into()];
    m.drift[0] = v.clone();
    m.noise_matrix[1] = vec![Expr::num(1.0) + s("eps") * y];
    m.impacts = vec![ImpactLaw {
        state: 0,
        at: Expr::num(0.0),
        other: 1,
        map: -(s("r") * v),
    }];
    m.domain = Some(crate::model::Domain::above(0, Expr::num(0.0)));
    m
}
