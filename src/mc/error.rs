//! Why a Monte Carlo run could not be set up, run or merged.

/// Why a set of impact laws is not one the simulation handles: it takes none, one, or two on
/// the same state bounding a strip.
///
/// ```
/// use fpsolve::mc::BarrierLayout;
/// let e = BarrierLayout::NotAStrip { lower: 1.0, upper: 1.0 };
/// assert!(e.to_string().contains("strip"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BarrierLayout {
    /// More than two laws.
    #[error("{count} barriers; at most two (a strip) are supported")]
    TooMany {
        /// How many.
        count: usize,
    },
    /// Two laws on different states (or jumping different states).
    #[error("two barriers on different states")]
    DifferentStates,
    /// Two laws that do not bound a strip (lower wall with the state above it, upper wall
    /// with the state below it).
    #[error("barriers at {lower} and {upper} do not bound a strip")]
    NotAStrip {
        /// The lower barrier's position.
        lower: f64,
        /// The upper one's.
        upper: f64,
    },
    /// Noise enters the equation of the barrier state. An impact law is an event at the
    /// instant the state reaches the barrier; a state driven by noise meets the barrier
    /// infinitely often in any time after it first does, so the law has no meaning there and
    /// a time-stepping simulation would give an answer that depends on its step.
    #[error(
        "noise `{noise}` enters the equation of `{state}`, the barrier state: an impact law \
         needs a barrier state that moves without noise (a diffusing state crosses its barrier \
         infinitely often once it reaches it)"
    )]
    NoisyState {
        /// The barrier state.
        state: String,
        /// The first noise source in its equation.
        noise: String,
    },
}

/// Errors of the Monte Carlo stage.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum McError {
    /// The model has a periodic state (`domain theta periodic 2*pi`), which the transient and
    /// first-passage runs do not take modulo the period (the stationary run does).
    #[error(
        "`{state}` is periodic, and Monte Carlo's transients and first passage do not yet \
         take its values modulo the period (their moments and safe set would see an angle \
         that has turned as one far away); its stationary density is solved by the grid and \
         by Monte Carlo"
    )]
    PeriodicState {
        /// The periodic state.
        state: String,
    },
    /// Every path would stay at its start: the drift and the noise both vanish there
    /// exactly ([`crate::dynamics::Dynamics::holds_still`]), as at rest in a Zhuravlev form
    /// (sgn(0) = 0 in its noise sgn(z)·ξ). The numbers would be a point mass's, not the
    /// limit of starts beside it that the grid answers for.
    #[error(
        "Monte Carlo from ({x}, {v}): the drift and the noise both vanish there (e.g. sgn(0) = \
         0 in a Zhuravlev form, whose noise is sgn(z)*xi), so every path would stay at its \
         start for ever and its numbers would not be the law's of starts beside it; start \
         beside it (e.g. position {beside} instead of {x}), or use the grid alone (its cell \
         around the start answers for the starts beside it)"
    )]
    StartHeldStill {
        /// The start's position.
        x: f64,
        /// The start's velocity.
        v: f64,
        /// A position beside it, suggested.
        beside: f64,
    },
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
    /// The model has no stationary law to sample (see [`crate::dynamics::check`]).
    #[error(transparent)]
    Inadmissible(#[from] crate::dynamics::Inadmissible),
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
    /// The model's impact laws are not a layout the simulation handles.
    #[error("cannot simulate these impact laws: {layout}")]
    Barriers {
        /// What is wrong with them.
        layout: BarrierLayout,
    },
    /// The noise intensity matrix has no real square root (it is not positive semi-definite).
    #[error(
        "the noise intensity matrix is not positive semi-definite (pivot {pivot} is {value:.6e})"
    )]
    IntensityNotPsd {
        /// Index of the failing pivot.
        pivot: usize,
        /// Its value.
        value: f64,
    },
    /// The burn-in could not be estimated: the linearised drift at the origin does not
    /// decay, and a pilot ensemble did not settle either (see `mc/relax.rs`).
    #[error(
        "cannot estimate the burn-in: the linearised drift at the origin decays at rate {rate:?} \
         (not > 0), and a pilot ensemble did not settle by t = {horizon}: {why}; set the \
         burn-in time explicitly"
    )]
    NoRelaxation {
        /// The origin's decay rate (≤ 0 or not finite).
        rate: f64,
        /// The pilot's last horizon.
        horizon: f64,
        /// What the pilot saw.
        why: String,
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
    /// The run was cancelled through its [`crate::base::cancel::Cancel`] flag before it finished;
    /// nothing of it is returned.
    #[error("the Monte Carlo run was cancelled before it finished")]
    Cancelled,
    /// Every trajectory of the run blew up: there is nothing to estimate from.
    #[error(
        "all {blowups} trajectories blew up (non-finite state): there is no stationary law to \
         estimate (it may not exist for these parameters)"
    )]
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
    /// A shard file is internally inconsistent (corrupt or edited).
    #[error("{shard} is not a valid shard: {defect}")]
    BadShard {
        /// The shard, as its file name (or `shard K of N`, counted from 1).
        shard: String,
        /// What is wrong with it.
        defect: ShardDefect,
    },
    /// Too many trajectories blew up for the survivors to represent the stationary law.
    #[error(
        "{count} of {trajectories} trajectories blew up (non-finite state), more than the tolerated fraction {tolerance}: the survivors do not represent a stationary law, which may not exist for these parameters"
    )]
    TooManyBlowUps {
        /// Trajectories that blew up.
        count: u64,
        /// Trajectories run.
        trajectories: u64,
        /// The tolerated fraction.
        tolerance: f64,
    },
    /// The recording drifts: its first and last quarters differ beyond their spread, so the
    /// histograms are not of the stationary law (no damping, a burn-in too short, …).
    #[error("the run is not stationary: {drift}; the histograms do not show a stationary law")]
    NotStationary {
        /// The largest drift found.
        drift: super::stats::verdict::Drift,
    },
    /// The run would take longer than the limit (estimated before starting).
    #[error(
        "the run{} would take about {} ({steps:.2e} trajectory steps at a conservative {rate:.1e} steps/s on {threads} threads), over the limit of {}; reduce the trajectories, samples, burn-in or spacing, or raise dt",
        one_of(*shards),
        human_seconds(*seconds),
        human_seconds(*limit_seconds)
    )]
    TooLong {
        /// Estimated seconds.
        seconds: f64,
        /// The limit.
        limit_seconds: f64,
        /// Estimated trajectory steps (pilot and bias runs included).
        steps: f64,
        /// Steps per second per thread assumed.
        rate: f64,
        /// Threads assumed.
        threads: usize,
        /// The run is split into this many shards; the estimate is for one.
        shards: u64,
    },
    /// The time step is beyond the stability limit of the explicit scheme for the model's
    /// drift (estimated before starting, see [`StepLimit`](super::StepLimit)): every
    /// trajectory would blow up.
    #[error("dt = {dt} is too large for this model: {limit}")]
    UnstableStep {
        /// The time step asked for.
        dt: f64,
        /// The fastest decay found and the largest stable step.
        limit: super::StepLimit,
    },
    /// The run would need more memory than the limit (estimated before starting).
    #[error(
        "the run{} would need about {:.3e} bytes of memory for its histograms ({bins} bins in all, kept per statistics batch), over the limit of {:.1e} bytes; use fewer bins or fewer trajectories per run (shards)",
        one_of(*shards),
        bytes,
        limit_bytes
    )]
    TooMuchMemory {
        /// Estimated bytes.
        bytes: f64,
        /// The limit.
        limit_bytes: f64,
        /// Histogram bins over all quantities.
        bins: f64,
        /// The run is split into this many shards; the estimate is for one.
        shards: u64,
    },
}

/// ` (one shard of N)` for a split run, nothing for a whole one.
fn one_of(shards: u64) -> String {
    if shards > 1 {
        format!(" (one shard of {shards})")
    } else {
        String::new()
    }
}

/// `3.2 h`, `45 s`, `2.1e9 years`: a duration for a message, never a 140-digit number.
pub(crate) fn human_seconds(s: f64) -> String {
    if !s.is_finite() {
        "forever".into()
    } else if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 2.0 * 86400.0 {
        format!("{:.1} h", s / 3600.0)
    } else if s < 3.2e9 {
        format!("{:.3} days", s / 86400.0)
    } else {
        format!("{:.1e} years", s / 3.156e7)
    }
}

/// What is wrong inside one shard file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShardDefect {
    /// A run setting is out of range (dt ≤ 0, no quantities, a bad grid, …).
    #[error("its setting `{name}` is invalid: {reason}")]
    Setting {
        /// The setting.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The shard index does not fit the split.
    #[error("it claims to be shard {index} of {count} (counted from 1)")]
    Index {
        /// The claimed index, from 1.
        index: u64,
        /// The claimed count.
        count: u64,
    },
    /// It holds other statistics batches than its index says.
    #[error("it should hold statistics batches {expected:?} but holds {found:?}")]
    Batches {
        /// The batch indices it must hold.
        expected: std::ops::Range<u64>,
        /// The ones it holds (first few).
        found: Vec<u64>,
    },
    /// It carries no digest (written by an fpsolve before shards had one): its numbers
    /// cannot be verified.
    #[error("it carries no digest (written by an older fpsolve), so its numbers cannot be verified: run the shard again")]
    NoDigest,
    /// Its contents are not what it was written with: edited or damaged.
    #[error(
        "its {part} do not match the digest it was written with: the file was edited or damaged"
    )]
    Digest {
        /// Which part disagrees.
        part: DigestPart,
    },
    /// Its file name says another shard than its contents.
    #[error("its name says shard {named_index} of {named_count}, its contents shard {index} of {count} (counted from 1): it was renamed")]
    Renamed {
        /// The index in the name, from 1.
        named_index: u64,
        /// The count in the name.
        named_count: u64,
        /// The index in the contents, from 1.
        index: u64,
        /// The count in the contents.
        count: u64,
    },
    /// A batch's numbers contradict each other or the settings.
    #[error("statistics batch {batch} (counted from 0){}: {what}", quantity.as_ref().map(|q| format!(", quantity `{q}`")).unwrap_or_default())]
    Batch {
        /// The batch index.
        batch: u64,
        /// The quantity, if the defect is in one.
        quantity: Option<String>,
        /// What is inconsistent.
        what: String,
    },
}

/// Which of a shard's two digests disagrees with its contents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DigestPart {
    /// The settings digest.
    Settings,
    /// The content digest.
    Content,
}

impl std::fmt::Display for DigestPart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DigestPart::Settings => "run settings",
            DigestPart::Content => "statistics",
        })
    }
}
