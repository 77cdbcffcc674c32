//! Time-stepping schemes, applied to a whole batch of trajectories at once.
//!
//! * **Mechanical form** (`dx = v dt`, noise only in the `v` equation, its coefficients
//!   functions of `x` only): Strang splitting of the generator into the free flight
//!   `A: dx = v dt` (solved exactly, impacts located exactly) and the velocity update
//!   `B: dv = f(x, v) dt + σ(x) dW` at frozen `x`, σ² = Σ_kl G_k S_kl G_l. With `x` frozen `B`
//!   has additive noise, for which the Heun-type predictor–corrector
//!   `v̄ = v + f(v)h + σΔW, v' = v + ½(f(v) + f(v̄))h + σΔW` is of weak order 2
//!   (Kloeden & Platen, §15.1); `A(h/2) B(h) A(h/2)` keeps order 2, and consecutive half
//!   flights are merged. Itô and Stratonovich coincide here, because σ does not depend on `v`.
//! * **General form** (any drift, state-dependent noise in both equations, several correlated
//!   sources): Platen's explicit weak order-2.0 scheme (Kloeden & Platen, *Numerical
//!   Solution of SDE*, Eq. 15.1.5) in Itô form. The correlated sources are made independent
//!   by the square root of the intensity matrix (columns b̃ = G·L, S = L·Lᵀ), and a
//!   Stratonovich model's drift gets the Wong–Zakai correction ½ Σ_j (b̃_j·∇) b̃_j, the same
//!   correction the FPK operator adds (`fpk.rs`). The scheme needs no derivatives: the noise
//!   columns are evaluated at supporting points Y + aΔ ± b̃_j√Δ and Y ± b̃_r√Δ.
//!   [`SchemeChoice::GeneralOrder1`] keeps the weak order-1 schemes (stochastic Heun for
//!   Stratonovich models, Euler–Maruyama for Itô models) as a contrast. A step that meets
//!   the barrier is cut at the linearly interpolated crossing, the jump applied, and the rest
//!   of the step taken with the Brownian-bridge remainder of its increment (so a step with
//!   an impact is of weak order 1 on every general scheme).

use crate::dynamics::Barrier as Wall;
use crate::dynamics::Dynamics as ModelDynamics;
use crate::mc::compile::eval::{compile, BatchKernel};
use crate::mc::compile::impact::{Barrier, Crossing};
use crate::mc::compile::mech_form::{MechForm, TimedForm};
use crate::mc::error::BarrierLayout;
use crate::mc::error::McError;
use crate::model::BarrierSide;
use crate::model::Interpretation;
use crate::symbolic::{diff, simplify, DeltaPolicy, Expr, Func};
use nalgebra::{Matrix2, Matrix3, Vector3};

/// Events per step beyond which the general scheme stops resolving impacts (a trajectory
/// chattering on the barrier); the rest of the step is then taken without further events.
pub(in crate::mc) const MAX_EVENTS_PER_STEP: usize = 8;

/// Which time-stepping scheme a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeKind {
    /// Strang splitting, exact free flight + Heun velocity update (weak order 2).
    MechanicalStrang,
    /// Stochastic Heun (Stratonovich models, weak order 1).
    Heun,
    /// Euler–Maruyama (Itô models, weak order 1).
    EulerMaruyama,
    /// Platen's explicit weak order-2.0 scheme on the Itô form (Wong–Zakai drift for
    /// Stratonovich models), for any 2-D model with several correlated sources.
    PlatenWeak2,
}

impl SchemeKind {
    /// The scheme's weak order p: the bias of a stationary statistic is O(dtᵖ).
    ///
    /// ```
    /// use fpsolve::mc::SchemeKind;
    /// assert_eq!(SchemeKind::PlatenWeak2.weak_order(), 2);
    /// assert_eq!(SchemeKind::Heun.weak_order(), 1);
    /// ```
    pub fn weak_order(self) -> u32 {
        match self {
            SchemeKind::MechanicalStrang | SchemeKind::PlatenWeak2 => 2,
            SchemeKind::Heun | SchemeKind::EulerMaruyama => 1,
        }
    }

    /// A conservative (low) throughput of one core, in trajectory steps per second, used by
    /// [`McConfig::preflight`](crate::mc::McConfig::preflight) to bound the run time. Measured
    /// with `fpsolve simulate` on the shared 2-core development machine (test profile):
    /// 1.3e8 steps/s per core for the mechanical splitting (`vibro_duffing.sde`), 2.3e7 for
    /// Platen's scheme with two sources (`cubic_damping_two_noises.sde`); the constants are
    /// 4–5 times lower, so the estimate errs towards refusing late rather than early.
    pub fn conservative_steps_per_second(self) -> f64 {
        match self {
            SchemeKind::MechanicalStrang => 3e7,
            SchemeKind::Heun | SchemeKind::EulerMaruyama => 1e7,
            SchemeKind::PlatenWeak2 => 5e6,
        }
    }
}

impl std::fmt::Display for SchemeKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            SchemeKind::MechanicalStrang => {
                "Strang splitting (exact flight + Heun velocity update)"
            }
            SchemeKind::Heun => "stochastic Heun",
            SchemeKind::EulerMaruyama => "Euler-Maruyama",
            SchemeKind::PlatenWeak2 => "Platen explicit weak order-2.0",
        };
        write!(f, "{name}, weak order {}", self.weak_order())
    }
}

/// What evaluates the model's drift and noise in the time-stepping loop, the main factor of
/// a run's speed after the scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Evaluator {
    /// The mechanical splitting with its force and noise recognised as polynomials in x,
    /// sgn(x) and v (at most one barrier, three-point increments): the vectorised kernel
    /// with the fused recording.
    PolynomialKernel,
    /// The compiled tape, evaluated over the lanes of a batch: any expression (`exp`,
    /// `abs(v)`, damping that depends on the energy, several noises), several times slower.
    Tape,
}

impl std::fmt::Display for Evaluator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Evaluator::PolynomialKernel => "the vectorised polynomial mechanical kernel",
            Evaluator::Tape => "the general tape evaluator",
        })
    }
}

/// How to choose the scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeChoice {
    /// The weak order-2 splitting when the model has the mechanical form, else the general
    /// scheme matching the interpretation.
    #[default]
    Auto,
    /// Always the general weak order-2 scheme ([`SchemeKind::PlatenWeak2`]), e.g. to
    /// cross-check the splitting.
    General,
    /// The general weak order-1 scheme matching the interpretation (Heun or
    /// Euler–Maruyama), for comparison.
    GeneralOrder1,
}

pub(crate) enum Dynamics {
    Mechanical {
        /// Outputs f(x, v), σ(x) = √(Σ_kl G_1k S_kl G_1l) and, when f is affine in v,
        /// ∂f/∂v(x): one tape, so shared subexpressions are computed once.
        step: Box<dyn BatchKernel>,
        /// f alone, for the corrector's second evaluation when f is not affine in v.
        force: Box<dyn BatchKernel>,
        /// Whether f is affine in v (then f(x, v̄) = f(x, v) + ∂f/∂v·(v̄ − v), exactly).
        affine: bool,
        /// `step` recognised as polynomials in z, sgn(z) and v: the fast kernel
        /// (`kernel/mech`) runs it; `None` keeps the lane evaluator.
        form: Option<MechForm>,
        /// The same for a step program whose coefficients depend on the time (`form` is
        /// then `None`): the fast kernel runs it with the coefficients of each step's time.
        timed: Option<Box<TimedForm>>,
    },
    General {
        /// Outputs: m_0, m_1, G_00..G_0(m−1), G_10..G_1(m−1).
        kernel: Box<dyn BatchKernel>,
        /// Lower-triangular square root L of S (S = L·Lᵀ), row-major m×m (the identity for
        /// Platen's scheme, whose columns are already independent).
        sqrt_s: Vec<f64>,
        noises: usize,
        stratonovich: bool,
        /// Platen's weak order-2 scheme, when chosen (then `kernel` gives the Itô drift and
        /// the independent columns b̃ = G·L, and `stratonovich` is false).
        platen: Option<PlatenKernels>,
    },
}

/// The extra kernels of Platen's scheme.
pub(crate) struct PlatenKernels {
    /// The Itô drift alone (2 outputs).
    pub(in crate::mc) drift: Box<dyn BatchKernel>,
    /// The noise columns alone: b̃_0j (j < m), then b̃_1j.
    pub(in crate::mc) noise: Box<dyn BatchKernel>,
    /// Column j alone, (b̃_0j, b̃_1j): the supporting values R±_j need only their own column,
    /// so they do not pay for evaluating all m.
    pub(in crate::mc) column: Vec<Box<dyn BatchKernel>>,
    /// Whether column j is state-independent (its supporting values then equal b̃_j).
    pub(in crate::mc) constant: Vec<bool>,
}

/// A bound model compiled for simulation.
pub(crate) struct Plan {
    pub(crate) kind: SchemeKind,
    pub(crate) dynamics: Dynamics,
    /// The impact laws: none, one, or two bounding a strip (lower first).
    pub(crate) barriers: Vec<Barrier>,
    pub(crate) observables: Box<dyn BatchKernel>,
    pub(crate) drift: Box<dyn BatchKernel>,
    /// The diffusion matrix b = G·S·Gᵀ next to the origin (averaged over x = ±ε, so that
    /// `sgn(x)` noise counts), for the initial spread of the trajectories.
    pub(in crate::mc) origin_diffusion: [[f64; 2]; 2],
}

fn is_zero(e: &Expr) -> bool {
    e.symbols().is_empty() && e.eval(&|_| None).map(|v| v == 0.0).unwrap_or(false)
}

/// Whether `e` is the state `v` itself (a symbolic check, tolerant of `1*v`).
fn is_state(e: &Expr, v: &str) -> bool {
    match e {
        Expr::Sym(s) => &**s == v,
        Expr::Mul(fs) => {
            let mut syms = fs.iter().filter(|f| f.as_num().is_none());
            let coef: f64 = fs.iter().filter_map(Expr::as_num).product();
            matches!((syms.next(), syms.next()), (Some(s), None) if is_state(s, v)) && coef == 1.0
        }
        _ => false,
    }
}

/// ∂f/∂v when the force `f` (deltas dropped) is affine in `v`, decided symbolically.
fn affine_slope(f: &Expr, v: &str) -> Option<Expr> {
    let smooth = simplify(&f.without_deltas());
    let slope = diff(&smooth, v).ok()?;
    let curvature = diff(&slope, v).ok()?;
    (curvature.as_num() == Some(0.0)).then_some(slope)
}

/// Lower-triangular L with L·Lᵀ = S for a positive semi-definite S; zero pivots (fully
/// correlated sources) give zero columns.
pub(crate) fn psd_sqrt(s: &[Vec<f64>]) -> Result<Vec<f64>, McError> {
    let m = s.len();
    let scale = (0..m)
        .map(|i| s[i][i].abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale;
    let mut l = vec![0.0; m * m];
    for j in 0..m {
        let d = s[j][j] - (0..j).map(|k| l[j * m + k] * l[j * m + k]).sum::<f64>();
        if d < -tol || !d.is_finite() {
            return Err(McError::IntensityNotPsd { pivot: j, value: d });
        }
        let ljj = if d > tol { d.sqrt() } else { 0.0 };
        l[j * m + j] = ljj;
        for i in j + 1..m {
            let r = s[i][j] - (0..j).map(|k| l[i * m + k] * l[j * m + k]).sum::<f64>();
            if ljj > 0.0 {
                l[i * m + j] = r / ljj;
            } else if r.abs() > 1e-9 * scale {
                return Err(McError::IntensityNotPsd { pivot: j, value: d });
            }
        }
    }
    Ok(l)
}

/// The model read once ([`ModelDynamics::read`]), its barriers checked to be readable (for
/// tests; a run reads it and takes its [`walls`], which check them, once).
#[cfg(test)]
pub(crate) fn read(model: &crate::model::BoundModel) -> Result<ModelDynamics, McError> {
    let dynamics = ModelDynamics::read(model);
    walls(&dynamics)?;
    Ok(dynamics)
}

/// The model's barriers as the simulation takes them, from its
/// [`Dynamics`](crate::dynamics::Dynamics).
#[cfg(test)]
pub(crate) fn impact_specs(model: &crate::model::BoundModel) -> Result<Vec<Wall>, McError> {
    walls(&read(model)?)
}

/// The barriers of `dynamics`, lower first; the reading's errors in the simulation's terms.
pub(crate) fn walls(dynamics: &ModelDynamics) -> Result<Vec<Wall>, McError> {
    use crate::dynamics::DynamicsError;
    match dynamics.barriers() {
        Ok(barriers) => Ok(barriers.iter().cloned().collect()),
        Err(DynamicsError::JumpMap { source }) => Err(McError::Compile(source)),
        Err(DynamicsError::TooManyBarriers { count }) => Err(McError::Barriers {
            layout: BarrierLayout::TooMany { count },
        }),
    }
}

/// Checks that `specs` is a layout the simulation handles: none, one, or two on the same
/// state bounding a strip (the lower one with the state above it, the upper one below);
/// returns them lower first.
fn check_layout(mut specs: Vec<Wall>) -> Result<Vec<Wall>, BarrierLayout> {
    match specs.len() {
        0 | 1 => Ok(specs),
        2 => {
            specs.sort_by(|a, b| a.at.total_cmp(&b.at));
            let (lo, hi) = (&specs[0], &specs[1]);
            if lo.state != hi.state || lo.other != hi.other {
                return Err(BarrierLayout::DifferentStates);
            }
            let strip = lo.at < hi.at
                && lo.side() == Some(BarrierSide::Above)
                && hi.side() == Some(BarrierSide::Below);
            if !strip {
                return Err(BarrierLayout::NotAStrip {
                    lower: lo.at,
                    upper: hi.at,
                });
            }
            Ok(specs)
        }
        count => Err(BarrierLayout::TooMany { count }),
    }
}

impl Plan {
    /// `model` read and compiled with the impact laws `specs`, as a run compiles it.
    #[cfg(test)]
    pub(crate) fn of_model(
        model: &crate::model::BoundModel,
        choice: SchemeChoice,
        specs: Vec<Wall>,
    ) -> Result<Plan, McError> {
        let observables: Vec<Expr> = model.observables.iter().map(|o| o.expr.clone()).collect();
        Plan::with_impacts(&read(model)?, &observables, choice, specs)
    }

    /// The equations of `dynamics` compiled with the impact laws `specs` (its own, or others
    /// in their place), recording the model's `observables`.
    pub(crate) fn with_impacts(
        dynamics: &ModelDynamics,
        observables: &[Expr],
        choice: SchemeChoice,
        specs: Vec<Wall>,
    ) -> Result<Plan, McError> {
        let specs = check_layout(specs).map_err(|layout| McError::Barriers { layout })?;
        let sde = dynamics.sde();
        let [x, v] = [&*dynamics.states()[0], &*dynamics.states()[1]];
        let states = [x, v];
        let g = sde.noise_matrix();
        let s = sde.intensity();
        let m = sde.noise_names().len();
        let drift = sde.drift();
        if let Some((b, k)) = specs.iter().find_map(|b| {
            (0..m)
                .find(|&k| !is_zero(&g[b.state][k]) && s[k][k] != 0.0)
                .map(|k| (b, k))
        }) {
            return Err(McError::Barriers {
                layout: BarrierLayout::NoisyState {
                    state: states[b.state].to_string(),
                    noise: sde.noise_names()[k].to_string(),
                },
            });
        }
        let mechanical_barrier = specs.iter().all(|b| b.state == 0 && b.other == 1);
        let mechanical = choice == SchemeChoice::Auto
            && is_state(&drift[0], v)
            && g[0].iter().all(is_zero)
            && g[1].iter().all(|e| !e.mentions(v))
            && mechanical_barrier;
        let mut coefficients = drift.iter().chain(g[0].iter()).chain(g[1].iter());
        if specs.is_empty() {
            if let Some(e) = coefficients.find(|e| e.contains_delta()) {
                return Err(McError::DeltaWithoutImpact {
                    expr: e.to_string(),
                });
            }
        }
        let sqrt_s = psd_sqrt(s)?;
        let (kind, dynamics) = if mechanical {
            // σ = √(Σ_kl G_1k S_kl G_1l), built symbolically so it compiles as one expression;
            // with one source it is √S·G_1 (the sign of σ does not change the law of σ·ΔW, the
            // increments being symmetric), which needs no square root per step.
            let sigma = if m == 1 {
                Expr::num(s[0][0].sqrt()) * g[1][0].clone()
            } else {
                let mut terms = Vec::new();
                for k in 0..m {
                    for l in 0..m {
                        if s[k][l] != 0.0 {
                            terms.push(Expr::num(s[k][l]) * g[1][k].clone() * g[1][l].clone());
                        }
                    }
                }
                Expr::call(Func::Sqrt, Expr::sum(terms))
            };
            let force = drift[1].clone();
            let slope = affine_slope(&force, v);
            let mut outputs = vec![force.clone(), sigma];
            outputs.extend(slope.iter().cloned());
            let step = compile(&outputs, states)?;
            let form = MechForm::recognise(step.program());
            let timed = match form {
                None => TimedForm::recognise(step.program()).map(Box::new),
                Some(_) => None,
            };
            (
                SchemeKind::MechanicalStrang,
                Dynamics::Mechanical {
                    step,
                    force: compile(&[force], states)?,
                    affine: slope.is_some(),
                    form,
                    timed,
                },
            )
        } else if choice == SchemeChoice::GeneralOrder1 {
            let mut exprs = vec![drift[0].clone(), drift[1].clone()];
            exprs.extend(g[0].iter().cloned());
            exprs.extend(g[1].iter().cloned());
            let stratonovich = sde.interpretation() == Interpretation::Stratonovich;
            (
                if stratonovich {
                    SchemeKind::Heun
                } else {
                    SchemeKind::EulerMaruyama
                },
                Dynamics::General {
                    kernel: compile(&exprs, states)?,
                    sqrt_s,
                    noises: m,
                    stratonovich,
                    platen: None,
                },
            )
        } else {
            let (drift, columns) = sde.unit_columns(dynamics.states(), &sqrt_s)?;
            let mut exprs = drift.to_vec();
            exprs.extend(columns[0].iter().cloned());
            exprs.extend(columns[1].iter().cloned());
            let noise: Vec<Expr> = columns.iter().flatten().cloned().collect();
            let constant = (0..m)
                .map(|j| columns.iter().all(|row| row[j].symbols().is_empty()))
                .collect();
            let mut identity = vec![0.0; m * m];
            for j in 0..m {
                identity[j * m + j] = 1.0;
            }
            (
                SchemeKind::PlatenWeak2,
                Dynamics::General {
                    kernel: compile(&exprs, states)?,
                    sqrt_s: identity,
                    noises: m,
                    stratonovich: false,
                    platen: Some(PlatenKernels {
                        drift: compile(&drift, states)?,
                        noise: compile(&noise, states)?,
                        column: (0..m)
                            .map(|j| {
                                compile(&[columns[0][j].clone(), columns[1][j].clone()], states)
                            })
                            .collect::<Result<_, _>>()?,
                        constant,
                    }),
                },
            )
        };
        let barriers = specs
            .iter()
            .map(|b| {
                Ok(Barrier {
                    state: b.state,
                    at: b.at,
                    other: b.other,
                    map: compile(std::slice::from_ref(b.law().map()), states)?,
                    expr: b.law().map().clone(),
                    side: match b.side() {
                        Some(BarrierSide::Above) => 1.0,
                        Some(BarrierSide::Below) => -1.0,
                        None => Barrier::side_of(b.at, 0.0),
                    },
                    crossing: match b.side() {
                        Some(_) => Crossing::Reflects,
                        None => Crossing::PassesThrough,
                    },
                })
            })
            .collect::<Result<Vec<_>, McError>>()?;
        let mut origin_diffusion = [[0.0; 2]; 2];
        for x0 in [-1e-9, 1e-9] {
            let at = |e: &Expr| {
                e.eval_with(&|n| Some(if n == x { x0 } else { 0.0 }), DeltaPolicy::Zero)
                    .unwrap_or(f64::NAN)
            };
            let gv: Vec<[f64; 2]> = (0..m).map(|k| [at(&g[0][k]), at(&g[1][k])]).collect();
            for i in 0..2 {
                for j in 0..2 {
                    for k in 0..m {
                        for l in 0..m {
                            origin_diffusion[i][j] += 0.5 * gv[k][i] * s[k][l] * gv[l][j];
                        }
                    }
                }
            }
        }
        Ok(Plan {
            origin_diffusion,
            kind,
            dynamics,
            barriers,
            observables: compile(observables, states)?,
            drift: compile(drift, states)?,
        })
    }

    /// The drift's Jacobian at the origin at time 0 (central differences, deltas as zero).
    fn jacobian(&self) -> [[f64; 2]; 2] {
        let h = 1e-6;
        let mut jac = [[0.0; 2]; 2];
        for (j, dir) in [[h, 0.0], [0.0, h]].iter().enumerate() {
            let mut p = [0.0; 2];
            let mut q = [0.0; 2];
            self.drift.eval_point(0.0, dir[0], dir[1], &mut p);
            self.drift.eval_point(0.0, -dir[0], -dir[1], &mut q);
            for i in 0..2 {
                jac[i][j] = (p[i] - q[i]) / (2.0 * h);
            }
        }
        jac
    }

    /// The slowest decay rate of the drift linearised at the origin: the real part of the
    /// Jacobian's least stable eigenvalue, negated.
    pub(crate) fn slowest_decay_rate(&self) -> f64 {
        let jac = self.jacobian();
        let tr = jac[0][0] + jac[1][1];
        let det = Matrix2::new(jac[0][0], jac[0][1], jac[1][0], jac[1][1]).determinant();
        let disc = 0.25 * tr * tr - det;
        let least_stable = if disc < 0.0 {
            0.5 * tr
        } else {
            0.5 * tr + disc.sqrt()
        };
        -least_stable
    }
}

impl Plan {
    /// A lower-triangular factor of the stationary covariance of the model linearised at the
    /// origin (J·P + P·Jᵀ + b = 0), from which trajectories start; the identity when the
    /// linearisation has no positive-definite stationary covariance.
    pub(crate) fn initial_spread(&self) -> [[f64; 2]; 2] {
        let j = self.jacobian();
        let b = self.origin_diffusion;
        // Unknowns (p00, p01, p11) of the symmetric 2×2 Lyapunov equation, by Cramer's rule
        // (nalgebra's 3×3 determinant is the cofactor expansion along the first row).
        let a = Matrix3::new(
            2.0 * j[0][0],
            2.0 * j[0][1],
            0.0,
            j[1][0],
            j[0][0] + j[1][1],
            j[0][1],
            0.0,
            2.0 * j[1][0],
            2.0 * j[1][1],
        );
        let rhs = Vector3::new(-b[0][0], -b[0][1], -b[1][1]);
        let d = a.determinant();
        let p: [f64; 3] = std::array::from_fn(|c| {
            let mut m = a;
            m.set_column(c, &rhs);
            m.determinant() / d
        });
        let (p00, p01, p11) = (p[0], p[1], p[2]);
        let schur = p11 - p01 * p01 / p00;
        if !(p00.is_finite() && p00 > 0.0 && schur.is_finite() && schur > 0.0) {
            return [[1.0, 0.0], [0.0, 1.0]];
        }
        let l00 = p00.sqrt();
        [[l00, 0.0], [p01 / l00, schur.sqrt()]]
    }
}
