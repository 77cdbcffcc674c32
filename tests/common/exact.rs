//! The one registry of models with a known stationary density, as test data: every solver's
//! tests (EPC today, Monte Carlo and the grid solver as they adopt it) loop over
//! [`cases`] and check what they compute against [`ExactCase::pdf`],
//! [`ExactCase::marginal`] and [`ExactCase::variance`], each with its own tolerances
//! ([`ExactCase::epc`], [`ExactCase::grid`], [`ExactCase::mc`]; `None` = the method is not
//! checked on that case).
//!
//! Every exact density here is p(z, v) ∝ exp(Q(z, v)) with Q a polynomial without z–v cross
//! terms (energy form), so the normalising constant and the marginals are one-dimensional
//! integrals, done here by trapezoid sums (spectrally accurate for these smooth, fast-decaying
//! integrands) out to e^−60 of the peak.

use std::path::{Path, PathBuf};

use fpsolve::model::{load_model, parse_model, BoundModel, Model, Override};

/// Where a case's model comes from.
#[derive(Clone, Copy, Debug)]
pub enum ModelSource {
    /// A file under `models/`.
    File(&'static str),
    /// Model text written in the test.
    Text(&'static str),
}

/// Tolerances for EPC on one case.
#[derive(Clone, Debug)]
pub struct EpcTolerance {
    /// Degrees at which EPC must reproduce the exact Q (each at least deg Q). The study solves
    /// every even degree from 2 up to the largest of them.
    pub degrees: Vec<usize>,
    /// |a − a_exact| ≤ this·(1 + |a_exact|) for every coefficient of Q (original variables).
    pub coefficient: f64,
    /// |ln C − ln C_exact| ≤ this.
    pub log_c: f64,
    /// Relative error of p at the check points ([`ExactCase::check_points`]).
    pub pdf: f64,
    /// Relative error of each state's variance.
    pub variance: f64,
    /// ∫|F|·p dx must stay below this (0 for an exact solution).
    pub fpk_residual: f64,
}

impl EpcTolerance {
    /// The tolerances every exact case of EPC meets, at `degrees`.
    pub fn at(degrees: &[usize]) -> EpcTolerance {
        EpcTolerance {
            degrees: degrees.to_vec(),
            coefficient: 1e-7,
            log_c: 1e-6,
            pdf: 1e-6,
            variance: 1e-6,
            fpk_residual: 1e-6,
        }
    }
}

/// Tolerances for a grid (finite-volume / finite-difference) solver on one case.
#[derive(Clone, Debug)]
pub struct GridTolerance {
    /// Relative error of each state's marginal at its peak.
    pub marginal: f64,
    /// Relative error of each state's variance.
    pub variance: f64,
}

/// Tolerances for `epc-impact` (EPC with the exact impact condition) on one case.
#[derive(Clone, Debug)]
pub struct EpcImpactTolerance {
    /// Degrees at which it must reproduce the exact Q.
    pub degrees: Vec<usize>,
    /// |a − a_exact| ≤ this·(1 + |a_exact|) for every coefficient of Q (original variables).
    pub coefficient: f64,
    /// Relative error of each state's variance.
    pub variance: f64,
}

/// Tolerances for Monte Carlo on one case, in the run's own standard errors.
#[derive(Clone, Debug)]
pub struct McTolerance {
    /// |estimate − exact| < this many standard errors (histogram bins and moments).
    pub standard_errors: f64,
}

/// One model with its exact stationary density.
#[derive(Clone, Debug)]
pub struct ExactCase {
    /// A short name for messages.
    pub name: &'static str,
    /// The model.
    pub model: ModelSource,
    /// Parameter overrides (`--set` style) applied when binding.
    pub overrides: Vec<(&'static str, f64)>,
    /// The exact log-density up to its constant, Q(z, v) = Σ q_ij z^i v^j (original
    /// variables, no z–v cross terms).
    pub q: Vec<((usize, usize), f64)>,
    /// EPC's tolerances, `None` if EPC is not checked on this case.
    pub epc: Option<EpcTolerance>,
    /// A grid solver's tolerances, `None` until one is checked on this case.
    pub grid: Option<GridTolerance>,
    /// `epc-impact`'s tolerances, `None` if it is not checked on this case.
    pub epc_impact: Option<EpcImpactTolerance>,
    /// Monte Carlo's tolerances, `None` if Monte Carlo is not checked on this case.
    pub mc: Option<McTolerance>,
}

/// Q = −f·(v²/2 + k z²/2 + μ z⁴/4): every case of the registry has this energy form.
pub fn energy(f: f64, k: f64, mu: f64) -> Vec<((usize, usize), f64)> {
    let mut q = vec![((0, 2), -f / 2.0), ((2, 0), -f * k / 2.0)];
    if mu != 0.0 {
        q.push(((4, 0), -f * mu / 4.0));
    }
    q
}

/// The cases Monte Carlo is checked on (`tests/mc_exact.rs`): additive and parametric noise,
/// two sources read as Stratonovich (Platen's scheme), and elastic impacts.
const MONTE_CARLO: &[&str] = &[
    "linear c = 0.3, k = 2",
    "duffing mu = 1",
    "parametric",
    "vibro-impact r = 1, eps = 0",
    "cubic damping, two noises",
];

/// The cases `epc-impact` refuses (with a typed reason its tests check).
pub const EPC_IMPACT_REFUSES: &[&str] = &["vibro-impact r = 1, eps = 0"];

/// The registry. 2πK = 1 in every bundled file (πK = 1/2), so f = damping/(πK).
pub fn cases() -> Vec<ExactCase> {
    let case = |name, file, overrides: &[(&'static str, f64)], q, degrees: &[usize]| ExactCase {
        name,
        model: ModelSource::File(file),
        overrides: overrides.to_vec(),
        q,
        epc: Some(EpcTolerance::at(degrees)),
        grid: None,
        // The Zhuravlev form (δ terms) is refused by epc-impact, which takes impacts in the
        // original coordinates; every other case has no barrier (the plane).
        epc_impact: (!EPC_IMPACT_REFUSES.contains(&name)).then(|| EpcImpactTolerance {
            degrees: degrees.to_vec(),
            coefficient: 1e-8,
            variance: 1e-8,
        }),
        mc: MONTE_CARLO.contains(&name).then_some(McTolerance {
            standard_errors: 4.5,
        }),
    };
    vec![
        case(
            "linear",
            "linear.sde",
            &[],
            energy(0.1 / 0.5, 1.0, 0.0),
            &[2, 4, 6],
        ),
        case(
            "linear c = 0.3, k = 2",
            "linear.sde",
            &[("c", 0.3), ("k", 2.0)],
            energy(0.3 / 0.5, 2.0, 0.0),
            &[2, 4],
        ),
        case(
            "linear c = 0.4, k = 2.5",
            "linear.sde",
            &[("c", 0.4), ("k", 2.5)],
            energy(0.4 / 0.5, 2.5, 0.0),
            &[2, 4, 6],
        ),
        case(
            "duffing",
            "duffing.sde",
            &[],
            energy(0.1 / 0.5, 1.0, 0.1),
            &[4, 6],
        ),
        case(
            "duffing mu = 1",
            "duffing.sde",
            &[("mu", 1.0)],
            energy(0.1 / 0.5, 1.0, 1.0),
            &[4],
        ),
        // (1 + εx)² damping with (1 + εx) noise: β/(πK) = 0.4; ε does not enter p.
        case(
            "parametric",
            "parametric.sde",
            &[],
            energy(0.2 / 0.5, 1.0, 0.5),
            &[4, 6],
        ),
        case(
            "parametric eps = 0.6, mu = 0.2",
            "parametric.sde",
            &[("eps", 0.6), ("mu", 0.2)],
            energy(0.4, 1.0, 0.2),
            &[4, 6],
        ),
        // The vibro-impact model without impacts (r = 1) or parametric noise (ε = 0) is the
        // Duffing oscillator: the Stratonovich reading and sgn(z)² = 1 must both come out right.
        case(
            "vibro-impact r = 1, eps = 0",
            "vibro_duffing.sde",
            &[("r", 1.0), ("eps", 0.0)],
            energy(0.1 / 0.5, 1.0, 0.1),
            &[4, 6],
        ),
        // c/(πK) = 4; stiffness −α = −1, β = 1: bimodal in z.
        case(
            "bistable duffing",
            "bistable_duffing.sde",
            &[],
            energy(4.0, -1.0, 1.0),
            &[4, 6],
        ),
        // s1 = 1, s3 = 0.2, κ = 0.1, μ = 0.5: λ = 2κ/s3 = 1, exact only through the
        // Wong–Zakai correction.
        case(
            "cubic damping, two noises",
            "cubic_damping_two_noises.sde",
            &[],
            energy(1.0, 1.0, 0.5),
            &[4, 6],
        ),
        // s1 = 2, s3 = 0.5, κ = 0.5: λ = 2.
        case(
            "cubic damping, two noises, s1 = 2",
            "cubic_damping_two_noises.sde",
            &[("s1", 2.0), ("s3", 0.5), ("kappa", 0.5), ("mu", 1.0)],
            energy(2.0, 1.0, 1.0),
            &[4, 6],
        ),
    ]
}

/// The directory of the bundled models.
pub fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models")
}

impl ExactCase {
    /// The parsed model.
    pub fn load(&self) -> Model {
        match self.model {
            ModelSource::File(f) => {
                load_model(&models_dir().join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))
            }
            ModelSource::Text(t) => {
                parse_model(t, None).unwrap_or_else(|e| panic!("{}: {e}", self.name))
            }
        }
    }

    /// The model bound with the case's overrides.
    pub fn bind(&self) -> BoundModel {
        let overrides: Vec<Override> = self
            .overrides
            .iter()
            .map(|(n, v)| Override::number(n, *v))
            .collect();
        self.load()
            .bind(&overrides)
            .unwrap_or_else(|e| panic!("{}: {e}", self.name))
    }

    /// The exact Q's coefficient of z^i v^j (0 if absent).
    pub fn coefficient(&self, i: usize, j: usize) -> f64 {
        self.q
            .iter()
            .find(|(e, _)| *e == (i, j))
            .map_or(0.0, |(_, a)| *a)
    }

    /// Q(z, v), without the normalising constant.
    pub fn log_density(&self, z: f64, v: f64) -> f64 {
        self.q
            .iter()
            .map(|((i, j), a)| a * z.powi(*i as i32) * v.powi(*j as i32))
            .sum()
    }

    /// The one-variable part of Q along `axis` (0: z, 1: v).
    fn part(&self, axis: usize, t: f64) -> f64 {
        if axis == 0 {
            self.log_density(t, 0.0)
        } else {
            self.log_density(0.0, t)
        }
    }

    /// The nodes and spacing of a trapezoid rule over `axis` reaching e^−60 of the peak.
    fn nodes(&self, axis: usize) -> (Vec<f64>, f64) {
        let mut half = 1.0;
        while self.part(axis, half) > -60.0 || self.part(axis, -half) > -60.0 {
            half *= 1.5;
        }
        let n = 6000;
        let h = 2.0 * half / n as f64;
        ((0..=n).map(|i| -half + i as f64 * h).collect(), h)
    }

    /// ∫ t^k exp(Q_axis(t)) dt.
    fn raw_integral(&self, axis: usize, k: i32) -> f64 {
        let (t, h) = self.nodes(axis);
        t.iter()
            .map(|&t| t.powi(k) * self.part(axis, t).exp())
            .sum::<f64>()
            * h
    }

    /// ln ∫∫ exp(Q) dz dv.
    pub fn log_normaliser(&self) -> f64 {
        (self.raw_integral(0, 0) * self.raw_integral(1, 0)).ln()
    }

    /// The exact joint density p(z, v).
    pub fn pdf(&self, z: f64, v: f64) -> f64 {
        (self.log_density(z, v) - self.log_normaliser()).exp()
    }

    /// The exact marginal density of state `axis` (0: z, 1: v) at `x`.
    pub fn marginal(&self, axis: usize, x: f64) -> f64 {
        self.part(axis, x).exp() / self.raw_integral(axis, 0)
    }

    /// The exact variance of state `axis` (every case is symmetric: E x = 0).
    pub fn variance(&self, axis: usize) -> f64 {
        self.raw_integral(axis, 2) / self.raw_integral(axis, 0)
    }

    /// Points where a joint density is compared: a 9 × 9 grid over ±3 standard deviations.
    pub fn check_points(&self) -> Vec<(f64, f64)> {
        let (sz, sv) = (self.variance(0).sqrt(), self.variance(1).sqrt());
        let mut pts = Vec::new();
        for i in -4..=4 {
            for j in -4..=4 {
                pts.push((0.75 * i as f64 * sz, 0.75 * j as f64 * sv));
            }
        }
        pts
    }
}
