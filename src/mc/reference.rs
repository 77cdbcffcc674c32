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
        safe: None,
        initial: None,
        periodic: None,
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

/// An oscillator of the Caughey–Ma class, `ż = v`, `v̇ = −c(1 + a·H)v − k z − μ z³ + ξ(t)`,
/// H = v²/2 + k z²/2 + μ z⁴/4, ξ white noise of intensity `s` (E[ξ(t)ξ(t′)] = s δ(t − t′)),
/// with its exact stationary density p ∝ exp(−f(H + a H²/2)), f = 2c/s. An elastic wall
/// (r = 1) anywhere, or two bounding a strip, restricts that density to the domain: the
/// exact check of every impact method.
///
/// ```
/// use fpsolve::mc::reference::CaugheyMa;
/// let o = CaugheyMa { c: 0.2, a: 0.5, k: 1.0, mu: 0.5, s: 0.4 };
/// assert_eq!(o.model().states()[0].as_ref(), "z");
/// // Without damping growth (a = 0) and μ = 0 the velocity is N(0, s/2c) on any domain.
/// let g = CaugheyMa { a: 0.0, mu: 0.0, ..o };
/// let m = g.bin_masses(1, &[-1.0, 1.0], [-0.5, 0.3]);
/// assert!((m[0] - 0.6827).abs() < 1e-4);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaugheyMa {
    /// Damping at zero energy.
    pub c: f64,
    /// Growth of the damping with the energy.
    pub a: f64,
    /// Linear stiffness.
    pub k: f64,
    /// Cubic stiffness.
    pub mu: f64,
    /// Noise intensity.
    pub s: f64,
}

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points.
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

impl CaugheyMa {
    /// The model, states `z`, `v`, without impact law.
    pub fn model(&self) -> Model {
        let h = s("v") * s("v") * Expr::num(0.5)
            + Expr::num(0.5) * s("k") * s("z") * s("z")
            + Expr::num(0.25) * s("mu") * Expr::pow(s("z"), Expr::num(4.0));
        let force = -(s("c") * (Expr::num(1.0) + s("a") * h) * s("v"))
            - s("k") * s("z")
            - s("mu") * Expr::pow(s("z"), Expr::num(3.0));
        oscillator(
            "caughey-ma",
            vec![
                param("c", self.c),
                param("a", self.a),
                param("k", self.k),
                param("mu", self.mu),
                param("s", self.s),
            ],
            force,
            s("s"),
        )
    }

    /// The unnormalised exact density at (z, v).
    pub fn density(&self, z: f64, v: f64) -> f64 {
        let h = 0.5 * v * v + 0.5 * self.k * z * z + 0.25 * self.mu * z.powi(4);
        (-(2.0 * self.c / self.s) * (h + 0.5 * self.a * h * h)).exp()
    }

    /// Where the density has fallen below e^−50 of its peak, along z and along v.
    fn reach(&self) -> [f64; 2] {
        let f = 2.0 * self.c / self.s;
        let mut r = [1.0f64; 2];
        for (axis, r) in r.iter_mut().enumerate() {
            let at = |u: f64| {
                if axis == 0 {
                    self.density(u, 0.0)
                } else {
                    self.density(0.0, u)
                }
            };
            while at(*r) > (-50.0f64).exp() && *r < 1e6 / f.max(1e-12) {
                *r *= 1.2;
            }
        }
        r
    }

    /// ∫∫ of the unnormalised density over [z0, z1] × [v0, v1] (composite Gauss–Legendre).
    fn integral(&self, z: [f64; 2], v: [f64; 2]) -> f64 {
        // Pieces of at most 0.05 (the densities vary on scales of order one).
        let pieces = |w: f64| ((w / 0.05).ceil() as usize).max(4);
        let (nz, nv) = (pieces(z[1] - z[0]), pieces(v[1] - v[0]));
        let (hz, hv) = ((z[1] - z[0]) / nz as f64, (v[1] - v[0]) / nv as f64);
        let mut sum = 0.0;
        for i in 0..nz {
            let zm = z[0] + (i as f64 + 0.5) * hz;
            for (tz, wz) in GL4 {
                let zz = zm + 0.5 * hz * tz;
                for j in 0..nv {
                    let vm = v[0] + (j as f64 + 0.5) * hv;
                    for (tv, wv) in GL4 {
                        sum += wz * wv * self.density(zz, vm + 0.5 * hv * tv);
                    }
                }
            }
        }
        sum * 0.25 * hz * hv
    }

    /// The exact probabilities of the bins between consecutive `edges` of the marginal of
    /// `axis` (0: z, 1: v), for the density restricted to z in `domain` (ends may be
    /// infinite) and normalised there.
    pub fn bin_masses(&self, axis: usize, edges: &[f64], domain: [f64; 2]) -> Vec<f64> {
        let [rz, rv] = self.reach();
        let zd = [domain[0].max(-rz), domain[1].min(rz)];
        let vd = [-rv, rv];
        let total = self.integral(zd, vd);
        edges
            .windows(2)
            .map(|e| {
                let (a, b) = if axis == 0 {
                    (e[0].max(zd[0]), e[1].min(zd[1]))
                } else {
                    (e[0].max(vd[0]), e[1].min(vd[1]))
                };
                if b <= a {
                    return 0.0;
                }
                let m = if axis == 0 {
                    self.integral([a, b], vd)
                } else {
                    self.integral(zd, [a, b])
                };
                m / total
            })
            .collect()
    }
}

/// How far a density on bins is from the exact bin probabilities: the L1 distance
/// Σ |p·w − m| and the largest |log10 (p·w / m)| over the bins whose exact probability is
/// above `floor` times the largest (the tails' relative error, without the far tail's
/// noise: 1e−6 against an exact density, 1e−3 against a histogram).
///
/// ```
/// use fpsolve::mc::reference::bin_errors;
/// let (l1, log) = bin_errors(&[0.5, 0.5], &[1.0, 1.1], 0.5, 1e-6);
/// assert!((l1 - 0.05).abs() < 1e-12 && (log - 1.1f64.log10()).abs() < 1e-12);
/// ```
pub fn bin_errors(exact: &[f64], density: &[f64], width: f64, floor: f64) -> (f64, f64) {
    let top = exact.iter().cloned().fold(0.0, f64::max);
    let mut l1 = 0.0;
    let mut log = 0.0f64;
    for (&m, &p) in exact.iter().zip(density) {
        l1 += (p * width - m).abs();
        if m > floor * top {
            log = log.max((p * width / m).log10().abs());
        }
    }
    (l1, log)
}
