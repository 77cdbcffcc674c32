//! [`Inadmissible`]: the reasons a model has no stationary density, as data.

use crate::model::number;

/// Why a model has no (non-degenerate) stationary density. `Display` says it in the user's
/// terms, starting with "no stationary density: ".
///
/// ```
/// use fpsolve::dynamics::{check, Inadmissible};
/// let text = "model m\nstate z, v\ndrift z: v\ndrift v: -0.1*v - z\nnoise xi: intensity 0\n\
///             diffusion v: xi\n";
/// let bound = fpsolve::model::parse_model(text, None).unwrap().bind(&[]).unwrap();
/// assert_eq!(check(&bound), Err(Inadmissible::NoNoise));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Inadmissible {
    /// A drift or diffusion line depends on the time `t`: the density changes in time and a
    /// stationary method has nothing to find.
    #[error(
        "no stationary density: the equations depend on the time `t` (in the {line}), so the \
         density changes in time; only a transient solution applies"
    )]
    TimeDependent {
        /// The first line that mentions `t` (`drift of `v``, `diffusion of `v``).
        line: String,
    },
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
    /// The force at rest pushes the position outwards far from the origin on a side no wall
    /// closes (a softening spring, μ < 0 in a Duffing oscillator): every trajectory escapes
    /// over the potential's barrier sooner or later, and no density stays.
    #[error(
        "no stationary density: far out on the {side} side of `{position}` the force pushes it \
         further out ({} at {position} = {}: a softening restoring force), and no wall closes \
         that side, so every trajectory escapes over the potential barrier in time; only a \
         restoring force that grows outwards (or a wall) keeps a stationary density",
        number(*force), number(*at)
    )]
    Escapes {
        /// The position state.
        position: String,
        /// `upper` or `lower`.
        side: &'static str,
        /// A probe position where the force points outwards.
        at: f64,
        /// The force there (at zero velocity).
        force: f64,
    },
    /// No force at rest anywhere on a side no wall closes: the position wanders without bound
    /// (a free particle under noise), and no density stays.
    #[error(
        "no stationary density: the drift of `{velocity}` has no restoring force (it is 0 at \
         rest for every {position} on the {side} side) and no wall closes that side, so \
         `{position}` wanders without bound"
    )]
    NoRestoringForce {
        /// The position state.
        position: String,
        /// The velocity state.
        velocity: String,
        /// `upper` or `lower`.
        side: &'static str,
    },
}
