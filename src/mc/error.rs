//! Why a Monte Carlo run could not be set up, run or merged.

/// Errors of the Monte Carlo stage.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum McError {
    /// A configuration value is out of range (`dt ≤ 0`, no trajectories, …).
    #[error("invalid Monte Carlo setting `{name}`: {reason}")]
    BadSetting {
        /// The setting.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A model expression could not be compiled for evaluation.
    #[error("cannot compile the model for simulation: {0}")]
    Compile(#[from] crate::symbolic::SymbolicError),
    /// The model has no stationary law to sample (see [`crate::physics::check`]).
    #[error(transparent)]
    Inadmissible(#[from] crate::physics::Inadmissible),
    /// A drift or noise coefficient has a `delta(...)` term but the model has no impact law:
    /// a time-stepping simulation never sees a delta (it is zero off a line the trajectories
    /// cross in no time), so the term would silently vanish.
    #[error(
        "`{expr}` contains delta(...) but the model has no impact law; a simulation needs the \
         impact as an event (`impact` line) to represent it"
    )]
    DeltaWithoutImpact {
        /// The expression with the delta, printed.
        expr: String,
    },
    /// The noise intensity matrix has no real square root (it is not positive semi-definite).
    #[error("the noise intensity matrix is not positive semi-definite (pivot {pivot} is {value})")]
    IntensityNotPsd {
        /// Index of the failing pivot.
        pivot: usize,
        /// Its value.
        value: f64,
    },
    /// The burn-in could not be estimated because the linearised drift at the origin has no
    /// decaying mode; set it explicitly.
    #[error(
        "cannot estimate the burn-in: the linearised drift at the origin decays at rate {rate} \
         (not > 0); set the burn-in time explicitly"
    )]
    NoDecay {
        /// The slowest decay rate found (≤ 0 or not finite).
        rate: f64,
    },
    /// A histogram grid refers to a quantity the model does not have.
    #[error("a grid is given for `{name}`, which is neither a state nor an observable")]
    UnknownQuantity {
        /// The name given.
        name: String,
    },
    /// The pilot run that chooses the histogram grids found no finite samples of a quantity.
    #[error("the pilot run found no finite values of `{name}`; give its grid explicitly")]
    NoPilotRange {
        /// The quantity.
        name: String,
    },
    /// Every trajectory of the run blew up: there is nothing to estimate from.
    #[error("all {blowups} trajectories blew up (non-finite state); see their list for where")]
    AllBlewUp {
        /// How many trajectories were run.
        blowups: usize,
    },
    /// Shards given to a merge do not belong to the same run or do not cover it exactly.
    #[error("cannot merge shards: {reason}")]
    ShardMismatch {
        /// What is inconsistent.
        reason: String,
    },
}
