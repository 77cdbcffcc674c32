//! What EPC makes of an impact law: the Zhuravlev form with its matching δ term in the drift
//! ([`ImpactForm::Zhuravlev`]), or why not ([`UnsupportedImpact`]).

use std::fmt;

use super::probe::{at, probe_points, rate_is, JUMP_PROBES, PROBE_MAGNITUDES};
use crate::model::{number, BoundImpact, BoundModel};
use crate::symbolic::{sift, Expr, Symbol};

/// Why EPC cannot use an impact law.
///
/// ```
/// use fpsolve::dynamics::{impact_form, ImpactForm, UnsupportedImpact};
/// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\nnoise xi: intensity 1\n\
///             diffusion v: xi\nimpact z = 0: v -> 0*v\n";
/// let bound = fpsolve::model::parse_model(text, None).unwrap().bind(&[]).unwrap();
/// let Some(ImpactForm::Unsupported { reason, .. }) = impact_form(&bound) else { panic!() };
/// assert_eq!(reason, UnsupportedImpact::Plastic);
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum UnsupportedImpact {
    /// `v -> -r*v`: the state stays on its side (the model in its original coordinates).
    /// The δ-term EPC solves such a model through its Zhuravlev transform
    /// (see [`crate::dynamics`]), which `fpsolve::solve` and `fpsolve check` apply; EPC
    /// given the original model directly refuses it, as it would solve it without the barrier.
    #[error(
        "it reflects the velocity (r = {}): the model is in its original coordinates; EPC \
         solves it through its Zhuravlev transform (`fpsolve solve` does this, `fpsolve check` \
         prints the transformed model)",
        number(*restitution)
    )]
    Reflecting {
        /// r in v⁺ = −r·v⁻.
        restitution: f64,
    },
    /// Two reflecting barriers bounding a strip: the δ-term EPC has no form for them.
    #[error(
        "two barriers bound a strip of `{position}` (at {} and {}): the δ-term EPC has no form \
         for a two-sided impact",
        number(*lower),
        number(*upper)
    )]
    TwoBarriers {
        /// The barrier state.
        position: String,
        /// The lower barrier.
        lower: f64,
        /// The upper barrier.
        upper: f64,
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
    /// Noise enters the equation of the barrier state: the position is not differentiable,
    /// so `ż|ż|δ(z)` (the Zhuravlev form's impact term) stands for no impact.
    #[error(
        "noise `{noise}` enters the equation of `{position}`, the barrier state: the impact \
         term stands for an impact only where `{position}` moves without noise"
    )]
    NoiseInPosition {
        /// The barrier state.
        position: String,
        /// The first noise source in its equation.
        noise: String,
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
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let form = fpsolve::dynamics::impact_form(&model.bind(&[]).unwrap()).unwrap();
/// assert_eq!(form.to_string(), "Zhuravlev (r = 0.95)");
/// ```
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

/// The ratio v⁺/v⁻ of a jump map at the probe velocities, when the map is `r*v` (None
/// otherwise), and the smallest |v⁺/v⁻| seen.
pub(super) fn jump_ratio(model: &BoundImpact, states: &[Symbol; 2]) -> (Option<f64>, f64) {
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
pub(super) fn jump_text(model: &BoundModel, law: &BoundImpact) -> String {
    format!("{} -> {:#}", model.states()[law.other], law.map)
}

/// The δ-line weights of the drift of `velocity` on the axis `position` (at `at_x`, or at any
/// position), as (line position, weight expression). `None` when the drift cannot be split.
pub(super) fn impact_terms(
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
pub(super) fn weight_at(
    w: &Expr,
    model: &BoundModel,
    position: usize,
    line_at: f64,
    v: f64,
) -> f64 {
    let mut x = [0.0; 2];
    x[position] = line_at;
    x[1 - position] = v;
    at(w, model.states(), x)
}

/// What EPC makes of the model's impact law (`None` when the model has none). See
/// [`ImpactForm`].
///
/// ```
/// use fpsolve::dynamics::{impact_form, ImpactForm, UnsupportedImpact};
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
    match model.impacts() {
        [] => None,
        [law] => one_barrier(model, law),
        [lower, upper, ..] => {
            let states = model.states();
            let text = |law: &BoundImpact| {
                format!(
                    "impact {} = {}: {}",
                    states[law.state],
                    number(law.at),
                    jump_text(model, law)
                )
            };
            Some(ImpactForm::Unsupported {
                law: format!("{}; {}", text(lower), text(upper)),
                reason: UnsupportedImpact::TwoBarriers {
                    position: states[lower.state].to_string(),
                    lower: lower.at,
                    upper: upper.at,
                },
            })
        }
    }
}

/// [`impact_form`] of a model with one impact law.
fn one_barrier(model: &BoundModel, law: &BoundImpact) -> Option<ImpactForm> {
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
    let (g, s) = (model.noise_matrix(), model.intensity());
    if let Some(k) = (0..s.len()).find(|&k| g[p][k].as_num() != Some(0.0) && s[k][k] != 0.0) {
        return unsupported(UnsupportedImpact::NoiseInPosition {
            position,
            noise: model.noise_names()[k].to_string(),
        });
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
