//! Physical admissibility of a bound model: whether it can have a stationary density at all,
//! and which impact laws the EPC operator represents.
//!
//! Both checks look only at the bound model (numbers substituted), before any solve:
//!
//! * [`check`] refuses models for which no non-degenerate stationary density exists, each
//!   for a reason that can be decided with certainty from the equations ([`Inadmissible`]):
//!   an impact that adds energy, no noise, no energy sink at all, a drift that only ever adds
//!   energy, noise that vanishes at a stable rest point, a linear drift with a mode that does
//!   not decay. What cannot be decided this way (negative linear damping that a nonlinear term
//!   may or may not contain, as in the Van der Pol oscillator) is accepted: the solvers then
//!   report what they find.
//! * [`impact_form`] says whether EPC can use the model's impact law. EPC's operator knows an
//!   impact only through the Zhuravlev term `-(1 - r)*v*abs(v)*delta(z)` in the drift (the
//!   paper's Eqs. 6–10); the `impact` line itself is what Monte Carlo uses. A reflecting law
//!   in the original coordinates (`impact x = 0: v -> -r*v`) has no such term: EPC would solve
//!   the model as if there were no barrier, so it is refused ([`UnsupportedImpact`]).
//!
//! Every decision is made on a fixed grid of probe points spanning 1e-3 to 1e4 in each state
//! (both signs, 45 values each), so the checks cost a few milliseconds.
//!
//! ```
//! use fpsolve::model::{parse_model, Override};
//! use fpsolve::physics::{check, Inadmissible};
//! let text = "model lin
//! param c = 0.1
//! state z, v
//! drift z: v
//! drift v: -c*v - z
//! noise xi: intensity 1
//! diffusion v: xi
//! ";
//! let model = parse_model(text, None).unwrap();
//! assert!(check(&model.bind(&[]).unwrap()).is_ok());
//! let undamped = model.bind(&[Override::number("c", 0.0)]).unwrap();
//! assert!(matches!(check(&undamped), Err(Inadmissible::NoDamping { .. })));
//! ```

use std::fmt;

use crate::model::{number, BoundImpact, BoundModel};
use crate::symbolic::{sift, DeltaPolicy, Expr, Symbol};

/// Why a model has no (non-degenerate) stationary density. `Display` says it in the user's
/// terms, starting with "no stationary density: ".
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Inadmissible {
    /// The diffusion matrix is zero everywhere: the response is deterministic and settles on
    /// a rest point or a cycle, which has no density.
    #[error(
        "no stationary density: the model has no noise (every diffusion term is zero), so the \
         response is deterministic and has no probability density"
    )]
    NoNoise,
    /// The impact law increases the speed at the barrier: every impact adds energy.
    #[error(
        "no stationary density: the impact law `{law}` adds energy at every impact \
         (|r| = {} > 1), so the response grows without bound",
        number(*restitution)
    )]
    EnergyAddingImpact {
        /// The jump map as written, bound (`v -> 1.001*v`).
        law: String,
        /// The smallest factor |v⁺/v⁻| found (> 1).
        restitution: f64,
    },
    /// The impact term `w(v)·δ(x)` of the drift adds energy at every crossing.
    #[error(
        "no stationary density: the impact term `{term}` in the drift of `{velocity}` adds \
         energy at every impact (it stands for |r| = {} > 1), so the response grows without \
         bound",
        number(*restitution)
    )]
    EnergyAddingImpactTerm {
        /// The term, printed.
        term: String,
        /// The state whose drift holds it.
        velocity: String,
        /// The restitution coefficient it represents, 1 + w(1).
        restitution: f64,
    },
    /// Nothing in the drift or at an impact takes energy out, while the noise adds some.
    #[error(
        "no stationary density: nothing takes energy out of the motion (the drift of \
         `{velocity}` has no damping term and no impact loses energy) while the noise keeps \
         adding it, so the response grows without bound"
    )]
    NoDamping {
        /// The velocity state.
        velocity: String,
    },
    /// The drift adds energy wherever it acts on the energy, and no impact takes any out.
    #[error(
        "no stationary density: the damping of `{velocity}` is negative (linear damping \
         coefficient {} at rest) and nothing in the drift or at an impact takes energy out, \
         so the response grows without bound",
        number(*linear_damping)
    )]
    NegativeDamping {
        /// The velocity state.
        velocity: String,
        /// −∂m_v/∂v at the origin (≤ 0).
        linear_damping: f64,
    },
    /// The diffusion vanishes at a rest point that is stable in mean square: every trajectory
    /// comes to rest there (purely parametric noise without an external part).
    #[error(
        "no stationary density: the noise vanishes at the rest point ({}) = ({}, {}) (every \
         diffusion term is proportional to the state: purely parametric noise), and the \
         linearised response decays in mean square (rate {}), so every trajectory comes to \
         rest there; add an external (additive) noise term",
        states.join(", "), number(point[0]), number(point[1]), number(*decay_rate)
    )]
    VanishingDiffusionAtRest {
        /// The two states' names.
        states: [String; 2],
        /// The rest point.
        point: [f64; 2],
        /// The slowest mean-square decay rate of the linearised response (> 0).
        decay_rate: f64,
    },
    /// A linear drift with additive noise whose slowest mode does not decay.
    #[error(
        "no stationary density: the drift is linear and one of its modes does not decay \
         (an eigenvalue of its matrix has real part {} ≥ 0), so the noise spreads the response \
         without bound",
        number(*real_part)
    )]
    UnstableLinearDrift {
        /// The largest real part of the drift matrix's eigenvalues.
        real_part: f64,
    },
}

/// Why EPC cannot use an impact law.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UnsupportedImpact {
    /// `v -> -r*v`: the state stays on its side (the model in its original coordinates).
    #[error(
        "it reflects the velocity (r = {}): the state stays on one side of the barrier, the \
         model in its original coordinates",
        number(*restitution)
    )]
    Reflecting {
        /// r in v⁺ = −r·v⁻.
        restitution: f64,
    },
    /// `v -> 0`: the motion stops at the barrier.
    #[error("it stops the motion at the barrier (a plastic impact, r = 0)")]
    Plastic,
    /// The jump is not `r*v` with a constant r.
    #[error("the jump is not `r*{velocity}` with a constant r")]
    NotLinear {
        /// The jumping state.
        velocity: String,
    },
    /// The rate of the barrier state is not the jumping state, so an impact term in the
    /// drift has no fixed meaning.
    #[error("the rate of `{position}` is not `{velocity}`")]
    NotMechanical {
        /// The barrier state.
        position: String,
        /// The jumping state.
        velocity: String,
    },
    /// A pass-through jump `v -> r*v`, r < 1, without the impact term in the drift.
    #[error(
        "the drift of `{velocity}` has no impact term `-(1 - r)*{velocity}*abs({velocity})*\
         delta({position})` for r = {}: without it EPC would solve the model as if there were \
         no barrier",
        number(*restitution)
    )]
    MissingImpactTerm {
        /// The restitution coefficient of the jump.
        restitution: f64,
        /// The barrier state.
        position: String,
        /// The jumping state.
        velocity: String,
    },
    /// The impact term of the drift does not stand for the jump of the impact line.
    #[error(
        "the impact term in the drift of `{velocity}` is not `-(1 - r)*{velocity}*abs({velocity})*\
         delta({position})` with the jump's r = {}",
        number(*restitution)
    )]
    MismatchedImpactTerm {
        /// The restitution coefficient of the jump.
        restitution: f64,
        /// The barrier state.
        position: String,
        /// The jumping state.
        velocity: String,
    },
}

/// What EPC makes of a model's impact law.
#[derive(Clone, Debug, PartialEq)]
pub enum ImpactForm {
    /// The Zhuravlev form EPC solves: a pass-through jump `v -> r*v` (0 < r ≤ 1) with the
    /// matching term `-(1 - r)*v*abs(v)*delta(z)` in the drift of `v`.
    Zhuravlev {
        /// The restitution coefficient r.
        restitution: f64,
    },
    /// A law EPC cannot use.
    Unsupported {
        /// The law, printed (`impact x = 0: v -> -0.95*v`).
        law: String,
        /// Why.
        reason: UnsupportedImpact,
    },
}

/// Probe values of each state: both signs, 1e-3 to 1e4, and 0. A sign decided on these
/// (no dissipation anywhere, say) could miss a region narrower than their spacing.
const PROBE_MAGNITUDES: [f64; 22] = [
    1e-3, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.3, 1.7, 2.2, 3.0, 4.0, 5.5, 7.0, 10.0, 20.0,
    30.0, 100.0, 1e3, 1e4,
];
/// How many of the smallest probe magnitudes test a jump map or an impact term (up to 1.7).
const JUMP_PROBES: usize = 11;

fn probe_values() -> Vec<f64> {
    let mut out = vec![0.0];
    for m in PROBE_MAGNITUDES {
        out.push(m);
        out.push(-m);
    }
    out
}

fn probe_points() -> Vec<[f64; 2]> {
    let vals = probe_values();
    let mut out = Vec::with_capacity(vals.len() * vals.len());
    for &a in &vals {
        for &b in &vals {
            out.push([a, b]);
        }
    }
    out
}

/// `e` at `x`, deltas as zero (their value off the lines), NaN where undefined.
fn at(e: &Expr, states: &[Symbol; 2], x: [f64; 2]) -> f64 {
    e.eval_states(states, x, DeltaPolicy::Zero)
        .unwrap_or(f64::NAN)
}

/// The diffusion matrix b = G·S·Gᵀ at `x`.
fn diffusion(model: &BoundModel, x: [f64; 2]) -> [[f64; 2]; 2] {
    let g = model.noise_matrix();
    let s = model.intensity();
    let m = s.len();
    let gv: Vec<[f64; 2]> = (0..m)
        .map(|k| {
            [
                at(&g[0][k], model.states(), x),
                at(&g[1][k], model.states(), x),
            ]
        })
        .collect();
    let mut b = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            for k in 0..m {
                for l in 0..m {
                    if s[k][l] != 0.0 {
                        b[i][j] += gv[k][i] * s[k][l] * gv[l][j];
                    }
                }
            }
        }
    }
    b
}

fn max_abs(b: &[[f64; 2]; 2]) -> f64 {
    b.iter().flatten().fold(0.0, |m, v| m.max(v.abs()))
}

/// Jacobian of `m` at `x` by central differences (deltas as zero).
fn jacobian(m: &[Expr; 2], states: &[Symbol; 2], x: [f64; 2]) -> [[f64; 2]; 2] {
    let h = 1e-6;
    let mut jac = [[0.0; 2]; 2];
    for j in 0..2 {
        let mut p = x;
        let mut q = x;
        p[j] += h;
        q[j] -= h;
        for i in 0..2 {
            jac[i][j] = (at(&m[i], states, p) - at(&m[i], states, q)) / (2.0 * h);
        }
    }
    jac
}

/// The largest real part of the eigenvalues of a 2×2 matrix.
fn max_real_part(j: &[[f64; 2]; 2]) -> f64 {
    let tr = j[0][0] + j[1][1];
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    let disc = 0.25 * tr * tr - det;
    if disc < 0.0 {
        0.5 * tr
    } else {
        0.5 * tr + disc.sqrt()
    }
}

/// (position, velocity) when the model has the mechanical form: the rate of the position is
/// the velocity and the noise enters only the velocity's equation.
fn mechanical(model: &BoundModel, m: &[Expr; 2]) -> Option<(usize, usize)> {
    let states = model.states();
    let points = probe_points();
    (0..2).map(|p| (p, 1 - p)).find(|&(p, q)| {
        let quiet = model.noise_matrix()[p]
            .iter()
            .all(|g| points.iter().all(|x| at(g, states, *x) == 0.0));
        quiet && rate_is(&m[p], q, states, &points)
    })
}

/// Whether the rate `rate` of a state equals state `q` at every probe point (to rounding).
fn rate_is(rate: &Expr, q: usize, states: &[Symbol; 2], points: &[[f64; 2]]) -> bool {
    points.iter().all(|x| {
        let r = at(rate, states, *x);
        (r - x[q]).abs() <= 1e-12 * (1.0 + x[q].abs())
    })
}

/// The ratio v⁺/v⁻ of a jump map at the probe velocities, when the map is `r*v` (None
/// otherwise), and the smallest |v⁺/v⁻| seen.
fn jump_ratio(model: &BoundImpact, states: &[Symbol; 2]) -> (Option<f64>, f64) {
    let point = |v: f64| {
        let mut x = [0.0; 2];
        x[model.state] = model.at;
        x[model.other] = v;
        x
    };
    let at_rest = at(&model.map, states, point(0.0));
    let mut ratios = Vec::new();
    for &m in &PROBE_MAGNITUDES[..JUMP_PROBES] {
        for v in [m, -m] {
            ratios.push(at(&model.map, states, point(v)) / v);
        }
    }
    let least = ratios.iter().fold(f64::INFINITY, |a, r| a.min(r.abs()));
    let r0 = ratios[0];
    let linear = at_rest == 0.0
        && ratios
            .iter()
            .all(|r| r.is_finite() && (r - r0).abs() <= 1e-9 * r0.abs().max(1e-300));
    (linear.then_some(r0), least)
}

/// `state -> map`, printed with readable numbers.
fn jump_text(model: &BoundModel, law: &BoundImpact) -> String {
    format!("{} -> {:#}", model.states()[law.other], law.map)
}

/// The δ-line weights of the drift of `velocity` on the axis `position` (at `at_x`, or at any
/// position), as (line position, weight expression). `None` when the drift cannot be split.
fn impact_terms(
    model: &BoundModel,
    position: usize,
    velocity: usize,
    at_x: Option<f64>,
) -> Option<Vec<(f64, Expr)>> {
    let split = sift(&model.drift()[velocity], model.states()).ok()?;
    Some(
        split
            .lines
            .into_iter()
            .filter(|line| line.axis == position && at_x.is_none_or(|a| line.at == a))
            .map(|line| (line.at, line.weight))
            .collect(),
    )
}

/// The weight of a δ-line at velocity `v` (the weight depends on the velocity only).
fn weight_at(w: &Expr, model: &BoundModel, position: usize, line_at: f64, v: f64) -> f64 {
    let mut x = [0.0; 2];
    x[position] = line_at;
    x[1 - position] = v;
    at(w, model.states(), x)
}

/// Checks that `model` can have a stationary density, in the order: noise, impacts, damping,
/// rest points, linear stability. See [`Inadmissible`] for each reason.
///
/// ```
/// use fpsolve::model::{parse_model, Override};
/// use fpsolve::physics::{check, Inadmissible};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// assert!(check(&model.bind(&[]).unwrap()).is_ok());
/// let r = model.bind(&[Override::number("r", 1.001)]).unwrap();
/// let err = check(&r).unwrap_err();
/// assert!(matches!(err, Inadmissible::EnergyAddingImpact { .. }));
/// assert!(err.to_string().contains("`v -> 1.001*v` adds energy at every impact"));
/// ```
pub fn check(model: &BoundModel) -> Result<(), Inadmissible> {
    let m = crate::fpk::ito_drift(model).ok().map(|(_, m)| m);
    check_with_drift(model, m.as_ref())
}

/// [`check`] with the model's Itô drift already derived (`None` when it cannot be: the
/// checks that need it are then skipped, as the derivation's own error will say why).
pub(crate) fn check_with_drift(
    model: &BoundModel,
    ito_drift: Option<&[Expr; 2]>,
) -> Result<(), Inadmissible> {
    let states = model.states();
    let points = probe_points();

    // No noise at all.
    let noisy = points.iter().any(|x| {
        let b = diffusion(model, *x);
        max_abs(&b) > 0.0 && b.iter().flatten().all(|v| v.is_finite())
    });
    if !noisy {
        return Err(Inadmissible::NoNoise);
    }

    // An impact map that increases |v|.
    let mut impact_dissipates = false;
    if let Some(law) = model.impact() {
        let (ratio, least) = jump_ratio(law, states);
        let restitution = ratio.map_or(least, f64::abs);
        if restitution > 1.0 + 1e-12 {
            return Err(Inadmissible::EnergyAddingImpact {
                law: jump_text(model, law),
                restitution,
            });
        }
        impact_dissipates = match ratio {
            Some(r) => r.abs() < 1.0 - 1e-12,
            None => least < 1.0,
        };
    }

    let Some(m) = ito_drift else {
        return Ok(());
    };
    let mech = mechanical(model, m);

    // Impact terms in the drift: energy change w(v)·sgn(v) at each crossing.
    if let Some((p, q)) = mech {
        if let Some(lines) = impact_terms(model, p, q, None) {
            for (line_at, w) in &lines {
                let change: Vec<f64> = PROBE_MAGNITUDES[..JUMP_PROBES]
                    .iter()
                    .flat_map(|&s| [s, -s])
                    .map(|v| weight_at(w, model, p, *line_at, v) * v.signum())
                    .collect();
                let scale = |v: f64| 1e-12 * v * v;
                if change.iter().all(|c| *c > 0.0) {
                    let w1 = weight_at(w, model, p, *line_at, 1.0);
                    let delta = if *line_at == 0.0 {
                        format!("delta({})", states[p])
                    } else {
                        format!("delta({} - {})", states[p], number(*line_at))
                    };
                    return Err(Inadmissible::EnergyAddingImpactTerm {
                        term: format!("{:#}*{delta}", w),
                        velocity: states[q].to_string(),
                        restitution: 1.0 + w1,
                    });
                }
                if PROBE_MAGNITUDES[..JUMP_PROBES]
                    .iter()
                    .zip(change.chunks(2))
                    .any(|(s, c)| c.iter().any(|c| *c < -scale(*s)))
                {
                    impact_dissipates = true;
                }
            }
        }
    }

    // Energy balance of the mechanical form: with H = v²/2 + U(x), the drift changes H at
    // the rate v·d(x, v), d = m_v(x, v) − m_v(x, 0); the noise only adds energy (½ b_vv ≥ 0).
    // If v·d ≥ 0 everywhere and no impact loses energy, E[H] can only grow.
    if let Some((_, q)) = mech {
        if !impact_dissipates {
            let mut dissipates = false;
            let mut energises = false;
            let mut finite = 0;
            for x in &points {
                let mut rest = *x;
                rest[q] = 0.0;
                let full = at(&m[q], states, *x);
                let zero = at(&m[q], states, rest);
                let power = x[q] * (full - zero);
                if !power.is_finite() {
                    continue;
                }
                finite += 1;
                let tol = 1e-9 * x[q].abs() * (full.abs() + zero.abs()) + 1e-300;
                dissipates |= power < -tol;
                energises |= power > tol;
            }
            // Decide only on a drift defined over most of the plane.
            if !dissipates && 2 * finite > points.len() {
                let velocity = states[q].to_string();
                if energises {
                    let jac = jacobian(m, states, [0.0, 0.0]);
                    return Err(Inadmissible::NegativeDamping {
                        velocity,
                        linear_damping: -jac[q][q],
                    });
                }
                return Err(Inadmissible::NoDamping { velocity });
            }
        }
    }

    // Noise that vanishes at a rest point which is stable in mean square.
    vanishing_diffusion_at_rest(model, m)?;

    // A linear drift with additive noise and a mode that does not decay.
    if model.impact().is_none() && !model.drift().iter().any(Expr::contains_delta) {
        let origin = [0.0, 0.0];
        let m0 = [at(&m[0], states, origin), at(&m[1], states, origin)];
        let jac = jacobian(m, states, origin);
        let b0 = diffusion(model, origin);
        let linear = points.iter().all(|x| {
            (0..2).all(|i| {
                let predicted = m0[i] + jac[i][0] * x[0] + jac[i][1] * x[1];
                let actual = at(&m[i], states, *x);
                (actual - predicted).abs() <= 1e-7 * (1.0 + actual.abs() + predicted.abs())
            })
        });
        let additive = points.iter().all(|x| {
            let b = diffusion(model, *x);
            (0..2).all(|i| {
                (0..2).all(|j| (b[i][j] - b0[i][j]).abs() <= 1e-12 * (1.0 + b0[i][j].abs()))
            })
        });
        if linear && additive {
            let re = max_real_part(&jac);
            let scale = jac.iter().flatten().fold(0.0, |a: f64, v| a.max(v.abs()));
            if re.is_finite() && re >= -1e-9 * scale {
                return Err(Inadmissible::UnstableLinearDrift { real_part: re });
            }
        }
    }
    Ok(())
}

/// Refuses noise that vanishes at a rest point of the drift where the linearised response
/// (drift Jacobian J, noise slopes B_k = ∂G_k/∂x) decays in mean square: there the second
/// moments P obey P' = J P + P Jᵀ + Σ_kl S_kl B_k P B_lᵀ, and when that operator is stable the
/// rest point attracts almost every trajectory (mean-square stability implies almost-sure
/// stability for a linear system). Only the origin is examined.
fn vanishing_diffusion_at_rest(model: &BoundModel, m: &[Expr; 2]) -> Result<(), Inadmissible> {
    let states = model.states();
    let origin = [0.0, 0.0];
    let rest = (0..2).all(|i| at(&m[i], states, origin).abs() <= 1e-12);
    if !rest {
        return Ok(());
    }
    // The diffusion next to the origin (8 directions), against its size at unit distance.
    let ring = |r: f64| {
        (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4 + 0.1;
                max_abs(&diffusion(model, [r * a.cos(), r * a.sin()]))
            })
            .fold(0.0, f64::max)
    };
    let near = ring(1e-6);
    let unit = ring(1.0);
    if !(near.is_finite() && unit.is_finite() && unit > 0.0 && near <= 1e-9 * unit) {
        return Ok(());
    }
    let jac = jacobian(m, states, origin);
    let g = model.noise_matrix();
    let s = model.intensity();
    let n = s.len();
    let slopes: Vec<[[f64; 2]; 2]> = (0..n)
        .map(|k| jacobian(&[g[0][k].clone(), g[1][k].clone()], states, origin))
        .collect();
    // The operator on symmetric P, in the basis (p00, p01, p11).
    let basis = [
        [[1.0, 0.0], [0.0, 0.0]],
        [[0.0, 1.0], [1.0, 0.0]],
        [[0.0, 0.0], [0.0, 1.0]],
    ];
    let mul = |a: &[[f64; 2]; 2], b: &[[f64; 2]; 2]| {
        let mut c = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        c
    };
    let transpose = |a: &[[f64; 2]; 2]| [[a[0][0], a[1][0]], [a[0][1], a[1][1]]];
    let mut op = [[0.0; 3]; 3];
    for (c, e) in basis.iter().enumerate() {
        let jp = mul(&jac, e);
        let mut r = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                r[i][j] = jp[i][j] + jp[j][i];
            }
        }
        for k in 0..n {
            for l in 0..n {
                if s[k][l] != 0.0 {
                    let t = mul(&mul(&slopes[k], e), &transpose(&slopes[l]));
                    for i in 0..2 {
                        for j in 0..2 {
                            r[i][j] += s[k][l] * t[i][j];
                        }
                    }
                }
            }
        }
        op[0][c] = r[0][0];
        op[1][c] = r[0][1];
        op[2][c] = r[1][1];
    }
    // Routh–Hurwitz for λ³ + a2 λ² + a1 λ + a0.
    let tr = op[0][0] + op[1][1] + op[2][2];
    let minors = op[0][0] * op[1][1] - op[0][1] * op[1][0] + op[0][0] * op[2][2]
        - op[0][2] * op[2][0]
        + op[1][1] * op[2][2]
        - op[1][2] * op[2][1];
    let det = op[0][0] * (op[1][1] * op[2][2] - op[1][2] * op[2][1])
        - op[0][1] * (op[1][0] * op[2][2] - op[1][2] * op[2][0])
        + op[0][2] * (op[1][0] * op[2][1] - op[1][1] * op[2][0]);
    let (a2, a1, a0) = (-tr, minors, -det);
    if a2 > 0.0 && a0 > 0.0 && a2 * a1 > a0 {
        let decay_rate = smallest_decay_rate(a2, a1, a0);
        return Err(Inadmissible::VanishingDiffusionAtRest {
            states: [states[0].to_string(), states[1].to_string()],
            point: origin,
            decay_rate,
        });
    }
    Ok(())
}

/// The slowest decay rate −max Re λ of a Hurwitz-stable cubic λ³ + a2 λ² + a1 λ + a0, found
/// as the largest σ with the shifted cubic (λ − σ) still stable, by bisection.
fn smallest_decay_rate(a2: f64, a1: f64, a0: f64) -> f64 {
    // p(λ) shifted by −σ: coefficients of p(μ − σ) in μ.
    let stable = |s: f64| {
        let b2 = a2 - 3.0 * s;
        let b1 = a1 - 2.0 * a2 * s + 3.0 * s * s;
        let b0 = a0 - a1 * s + a2 * s * s - s * s * s;
        b2 > 0.0 && b0 > 0.0 && b2 * b1 > b0
    };
    let (mut lo, mut hi) = (0.0, a2 / 3.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// What EPC makes of the model's impact law (`None` when the model has none). See
/// [`ImpactForm`].
///
/// ```
/// use fpsolve::physics::{impact_form, ImpactForm, UnsupportedImpact};
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let bound = fpsolve::model::load_model(&path).unwrap().bind(&[]).unwrap();
/// assert_eq!(impact_form(&bound), Some(ImpactForm::Zhuravlev { restitution: 0.95 }));
///
/// let original = fpsolve::mc::reference::reflecting_vibro_impact(fpsolve::mc::reference::VibroImpact {
///     c: 0.1, k: 1.0, mu: 0.1, eps: 0.1, r: 0.95, big_k: 0.1,
/// });
/// let Some(ImpactForm::Unsupported { reason, .. }) = impact_form(&original.bind(&[]).unwrap())
/// else { panic!("a reflecting law") };
/// assert_eq!(reason, UnsupportedImpact::Reflecting { restitution: 0.95 });
/// ```
pub fn impact_form(model: &BoundModel) -> Option<ImpactForm> {
    let law = model.impact()?;
    let states = model.states();
    let (p, q) = (law.state, law.other);
    let position = states[p].to_string();
    let velocity = states[q].to_string();
    let unsupported = |reason| {
        Some(ImpactForm::Unsupported {
            law: format!(
                "impact {} = {}: {}",
                states[p],
                number(law.at),
                jump_text(model, law)
            ),
            reason,
        })
    };
    let (ratio, _) = jump_ratio(law, states);
    let Some(r) = ratio else {
        return unsupported(UnsupportedImpact::NotLinear { velocity });
    };
    if r < 0.0 {
        return unsupported(UnsupportedImpact::Reflecting { restitution: -r });
    }
    if r == 0.0 {
        return unsupported(UnsupportedImpact::Plastic);
    }
    if !rate_is(&model.drift()[p], q, states, &probe_points()) {
        return unsupported(UnsupportedImpact::NotMechanical { position, velocity });
    }
    let Some(lines) = impact_terms(model, p, q, Some(law.at)) else {
        return unsupported(UnsupportedImpact::MismatchedImpactTerm {
            restitution: r,
            position,
            velocity,
        });
    };
    let matches = |w: &Expr| {
        PROBE_MAGNITUDES[..JUMP_PROBES]
            .iter()
            .flat_map(|&s| [s, -s])
            .all(|v| {
                let expected = -(1.0 - r) * v * v.abs();
                let got = weight_at(w, model, p, law.at, v);
                (got - expected).abs() <= 1e-9 * (v * v).max(1e-300)
            })
    };
    match lines.as_slice() {
        [] if r == 1.0 => Some(ImpactForm::Zhuravlev { restitution: r }),
        [] => unsupported(UnsupportedImpact::MissingImpactTerm {
            restitution: r,
            position,
            velocity,
        }),
        [(_, w)] if matches(w) => Some(ImpactForm::Zhuravlev { restitution: r }),
        _ => unsupported(UnsupportedImpact::MismatchedImpactTerm {
            restitution: r,
            position,
            velocity,
        }),
    }
}

impl fmt::Display for ImpactForm {
    /// `Zhuravlev (r = 0.95)` or the refusal.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImpactForm::Zhuravlev { restitution } => {
                write!(f, "Zhuravlev (r = {})", number(*restitution))
            }
            ImpactForm::Unsupported { law, reason } => write!(f, "`{law}`: {reason}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::epc::{Epc, EpcError};
    use crate::fpk::{FpkError, FpkOperator};
    use crate::mc::{BurnIn, Grid, McConfig, Simulation};
    use crate::model::{load_model, parse_model, Model, Override};
    use std::path::Path;

    fn model_file(name: &str) -> Model {
        load_model(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models")
                .join(name),
        )
        .unwrap()
    }

    fn bind(model: &Model, set: &[(&str, f64)]) -> BoundModel {
        let o: Vec<Override> = set.iter().map(|(n, v)| Override::number(n, *v)).collect();
        model.bind(&o).unwrap()
    }

    fn text(drift_v: &str, diffusion: &str, extra: &str) -> Model {
        let src = format!(
            "model m\nparam c = 0.1, k = 1, S = 1\nstate z, v\ndrift z: v\ndrift v: {drift_v}\n\
             noise xi: intensity S\ndiffusion v: {diffusion}\n{extra}"
        );
        parse_model(&src, None).unwrap()
    }

    /// The model in its original coordinates: x ≥ 0, reflecting law, no δ term.
    const ORIGINAL: &str = "model orig
param c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95
param K = 1/(2*pi)
state x, v
drift x: v
drift v: -c*v - k*x - mu*x^3
noise xi: intensity 2*pi*K
diffusion v: (1 + eps*x) * xi
impact x = 0: v -> -r*v
";

    #[test]
    fn every_bundled_model_and_the_table_1_cases_are_admissible() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        let mut n = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let bound = load_model(&path).unwrap().bind(&[]).unwrap();
            assert_eq!(check(&bound), Ok(()), "{}", path.display());
            let form = impact_form(&bound);
            assert!(
                matches!(form, None | Some(ImpactForm::Zhuravlev { .. })),
                "{}: {form:?}",
                path.display()
            );
            n += 1;
        }
        assert_eq!(n, 8);
        let vibro = model_file("vibro_duffing.sde");
        for (mu, eps) in [(0.1, 0.1), (0.1, -0.1), (1.0, 0.1), (1.0, -0.1)] {
            let b = bind(&vibro, &[("mu", mu), ("eps", eps)]);
            assert_eq!(check(&b), Ok(()), "mu = {mu}, eps = {eps}");
            assert_eq!(
                impact_form(&b),
                Some(ImpactForm::Zhuravlev { restitution: 0.95 })
            );
        }
        // Impact losses alone confine the motion: no viscous damping is needed.
        assert_eq!(check(&bind(&vibro, &[("c", 0.0)])), Ok(()));
        // Van der Pol: negative linear damping, contained by z^2 v; still accepted at any α.
        let vdp = model_file("van_der_pol.sde");
        assert_eq!(check(&bind(&vdp, &[("alpha", 0.5)])), Ok(()));
        // The original coordinates are physically fine: only EPC refuses them.
        let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
        assert_eq!(check(&orig), Ok(()));
    }

    #[test]
    fn an_impact_that_adds_energy_is_refused_in_plain_words() {
        let vibro = model_file("vibro_duffing.sde");
        let err = check(&bind(&vibro, &[("r", 1.001)])).unwrap_err();
        assert_eq!(
            err,
            Inadmissible::EnergyAddingImpact {
                law: "v -> 1.001*v".into(),
                restitution: 1.001
            }
        );
        assert_eq!(
            err.to_string(),
            "no stationary density: the impact law `v -> 1.001*v` adds energy at every impact \
             (|r| = 1.001 > 1), so the response grows without bound"
        );
        // Reflecting form in the original coordinates, r = 1.1.
        let orig = parse_model(ORIGINAL, None).unwrap();
        assert!(matches!(
            check(&bind(&orig, &[("r", 1.1)])),
            Err(Inadmissible::EnergyAddingImpact { restitution, .. }) if (restitution - 1.1).abs() < 1e-12
        ));
        // The δ term alone (no impact line), standing for r = 1.1.
        let m = text("-c*v - k*z + 0.1*v*abs(v)*delta(z)", "xi", "");
        match check(&m.bind(&[]).unwrap()) {
            Err(Inadmissible::EnergyAddingImpactTerm {
                restitution,
                velocity,
                ..
            }) => {
                assert!((restitution - 1.1).abs() < 1e-12);
                assert_eq!(velocity, "v");
            }
            other => panic!("{other:?}"),
        }
        // r = 1 exactly is elastic, and fine with damping.
        assert_eq!(check(&bind(&vibro, &[("r", 1.0)])), Ok(()));
    }

    #[test]
    fn no_damping_and_negative_damping() {
        let vibro = model_file("vibro_duffing.sde");
        let none = bind(&vibro, &[("c", 0.0), ("r", 1.0), ("eps", 0.0)]);
        assert_eq!(
            check(&none),
            Err(Inadmissible::NoDamping {
                velocity: "v".into()
            })
        );
        // Parametric noise does not change that.
        let none = bind(&vibro, &[("c", 0.0), ("r", 1.0)]);
        assert!(matches!(check(&none), Err(Inadmissible::NoDamping { .. })));
        let duffing = model_file("duffing.sde");
        match check(&bind(&duffing, &[("c", -0.1)])) {
            Err(Inadmissible::NegativeDamping {
                linear_damping,
                velocity,
            }) => {
                assert!((linear_damping + 0.1).abs() < 1e-8, "{linear_damping}");
                assert_eq!(velocity, "v");
            }
            other => panic!("{other:?}"),
        }
        // Negative linear damping contained by a cubic one is accepted.
        let m = text("0.1*v - 0.05*v^3 - k*z", "xi", "");
        assert_eq!(check(&m.bind(&[]).unwrap()), Ok(()));
        // Stratonovich velocity noise adds drift ½ S v: with c = 0 that is negative damping.
        let m = text("-c*v - k*z", "xi + v*xi", "");
        assert!(matches!(
            check(&bind(&m, &[("c", 0.0)])),
            Err(Inadmissible::NegativeDamping { .. })
        ));
    }

    #[test]
    fn no_noise_and_noise_vanishing_at_rest() {
        let m = text("-c*v - k*z", "c*xi", "");
        assert_eq!(check(&bind(&m, &[("S", 0.0)])), Err(Inadmissible::NoNoise));
        assert_eq!(check(&bind(&m, &[("c", 0.0)])), Err(Inadmissible::NoNoise));
        // Purely parametric noise z·ξ on a damped linear oscillator: the second moments decay
        // iff S < 2c k (here 0.2); below that every trajectory comes to rest at the origin.
        let m = text("-c*v - k*z", "z*xi", "");
        match check(&bind(&m, &[("S", 0.19)])) {
            Err(Inadmissible::VanishingDiffusionAtRest {
                point, decay_rate, ..
            }) => {
                assert_eq!(point, [0.0, 0.0]);
                assert!(decay_rate > 0.0 && decay_rate < 0.05, "{decay_rate}");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(check(&bind(&m, &[("S", 0.21)])), Ok(()));
        // An external part keeps it away from rest.
        let m = text("-c*v - k*z", "xi + z*xi", "");
        assert_eq!(check(&m.bind(&[]).unwrap()), Ok(()));
    }

    #[test]
    fn a_linear_drift_with_a_mode_that_does_not_decay() {
        let m = text("-c*v - k*z", "xi", "");
        let expected = -0.05 + (0.05f64 * 0.05 + 1.0).sqrt();
        match check(&bind(&m, &[("k", -1.0)])) {
            Err(Inadmissible::UnstableLinearDrift { real_part }) => {
                assert!((real_part - expected).abs() < 1e-6, "{real_part}")
            }
            other => panic!("{other:?}"),
        }
        // No restoring force: a zero eigenvalue, the position diffuses freely.
        assert!(matches!(
            check(&bind(&m, &[("k", 0.0)])),
            Err(Inadmissible::UnstableLinearDrift { .. })
        ));
        // A non-mechanical linear model.
        let src = "model m\nstate x, y\ndrift x: 0.1*x\ndrift y: -y\nnoise xi: intensity 1\n\
                   diffusion x: xi\ndiffusion y: xi\n";
        let m = parse_model(src, None).unwrap();
        assert!(matches!(
            check(&m.bind(&[]).unwrap()),
            Err(Inadmissible::UnstableLinearDrift { real_part }) if (real_part - 0.1).abs() < 1e-8
        ));
    }

    #[test]
    fn refusals_stop_the_fpk_derivation_and_monte_carlo() {
        let vibro = model_file("vibro_duffing.sde");
        let b = bind(&vibro, &[("r", 1.001)]);
        assert!(matches!(
            FpkOperator::derive(&b),
            Err(FpkError::Inadmissible(
                Inadmissible::EnergyAddingImpact { .. }
            ))
        ));
        assert!(matches!(
            Simulation::new(&b, &McConfig::default()),
            Err(crate::mc::McError::Inadmissible(_))
        ));
    }

    #[test]
    fn epc_refuses_an_impact_in_original_coordinates_before_any_work() {
        let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
        let fpk = FpkOperator::derive(&orig).unwrap();
        assert_eq!(
            fpk.impact,
            Some(ImpactForm::Unsupported {
                law: "impact x = 0: v -> -0.95*v".into(),
                reason: UnsupportedImpact::Reflecting { restitution: 0.95 },
            })
        );
        // An invalid weight would fail in the first step of the work: the refusal comes first.
        let epc = Epc::new(&fpk).degree(2).weights([Some(-1.0), None]);
        let err = epc.solve().unwrap_err();
        assert!(matches!(err, EpcError::UnsupportedImpact { .. }), "{err}");
        let text = err.to_string();
        for part in [
            "EPC cannot use the impact law `impact x = 0: v -> -0.95*v`",
            "it reflects the velocity",
            "Zhuravlev",
            "Monte Carlo",
        ] {
            assert!(text.contains(part), "`{part}` not in {text}");
        }
        let all = Epc::new(&fpk).solve_degrees(&[2, 4]);
        assert!(all
            .iter()
            .all(|r| matches!(r, Err(EpcError::UnsupportedImpact { .. }))));
    }

    #[test]
    fn zhuravlev_jumps_need_the_matching_delta_term() {
        let jump = "impact z = 0: v -> 0.9*v";
        let m = text("-c*v - k*z", "xi", jump);
        assert!(matches!(
            impact_form(&m.bind(&[]).unwrap()),
            Some(ImpactForm::Unsupported {
                reason: UnsupportedImpact::MissingImpactTerm { .. },
                ..
            })
        ));
        let m = text("-c*v - k*z - 0.2*v*abs(v)*delta(z)", "xi", jump);
        assert!(matches!(
            impact_form(&m.bind(&[]).unwrap()),
            Some(ImpactForm::Unsupported {
                reason: UnsupportedImpact::MismatchedImpactTerm { .. },
                ..
            })
        ));
        let m = text("-c*v - k*z - 0.1*v*abs(v)*delta(z)", "xi", jump);
        assert_eq!(
            impact_form(&m.bind(&[]).unwrap()),
            Some(ImpactForm::Zhuravlev { restitution: 0.9 })
        );
        let m = text("-c*v - k*z", "xi", "impact z = 0: v -> 0.9*v - 0.01*v^3");
        assert!(matches!(
            impact_form(&m.bind(&[]).unwrap()),
            Some(ImpactForm::Unsupported {
                reason: UnsupportedImpact::NotLinear { .. },
                ..
            })
        ));
        let m = text("-c*v - k*z", "xi", "impact z = 0: v -> 0*v");
        assert!(matches!(
            impact_form(&m.bind(&[]).unwrap()),
            Some(ImpactForm::Unsupported {
                reason: UnsupportedImpact::Plastic,
                ..
            })
        ));
    }

    #[test]
    fn monte_carlo_still_simulates_the_original_coordinates() {
        // A short run must see the barrier: x never negative, and a mean far from the 0 that
        // a barrier-free solve gives (the displacement's spread is about 1.7 here).
        let orig = parse_model(ORIGINAL, None).unwrap().bind(&[]).unwrap();
        let config = McConfig {
            trajectories: 256,
            samples: 100,
            seed: 3,
            burn_in: BurnIn::Time(50.0),
            grids: vec![
                ("x".into(), Grid::new(0.0, 8.0, 16).unwrap()),
                ("v".into(), Grid::new(-8.0, 8.0, 16).unwrap()),
            ],
            ..McConfig::default()
        };
        let result = Simulation::new(&orig, &config).unwrap().run().unwrap();
        let x = result.quantity("x").unwrap();
        assert_eq!(x.underflow, 0);
        assert!(x.moments.mean.value > 0.8, "E[x] = {:?}", x.moments.mean);
    }
}
