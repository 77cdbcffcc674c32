//! The reliability statistics of a run from its batches: at each wall the impact rate, the
//! mean impact speed, the mean dissipated power and the flux-weighted impact-speed density
//! ([`WallStats`]); per quantity with levels the mean up-crossing rates ([`CrossingRates`]).
//! Every number carries its batch-means standard error (a ratio's by the batches' residuals
//! about it), and the time-step bias from the batches paired with the 2·dt run, as the
//! impact rate's (`judge::impact_rate_bias`).

use serde::{Deserialize, Serialize};

use crate::mc::record::batch::BatchSummary;
use crate::mc::record::histogram::Grid;
use crate::mc::settings::RunSettings;
use crate::mc::stats::pairs::{mean_se, paired};
use crate::stats::Estimate;

/// The impact statistics at one wall, per unit mass, as the grid's
/// ([`crate::observe::ImpactStatistics`]) define them: the speed is |v| before the impact,
/// the power the kinetic energy (v² − v′²)/2 the impacts take per unit time per trajectory.
///
/// A run with a wall reports one per wall in [`McResult::impacts`](crate::mc::McResult);
/// with [`McConfig::impact_speeds`](crate::mc::McConfig) it also histograms the speeds:
///
/// ```
/// use fpsolve::mc::{Grid, McConfig, Simulation};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/grid_impact_linear.sde");
/// let model = fpsolve::model::load_model(path.as_ref())?.bind(&[])?;
/// let config = McConfig {
///     trajectories: 256,
///     samples: 20_000,
///     impact_speeds: Some(Grid::new(0.0, 10.0, 10)?),
///     ..McConfig::default()
/// };
/// let res = Simulation::new(&model, &config)?.run()?;
/// let wall = &res.impacts.as_ref().unwrap().walls[0];
/// assert!(wall.above && wall.at == -0.5 && wall.count > 0);
/// // An elastic wall (r = 1) takes no energy.
/// assert_eq!(wall.mean_power.value, 0.0);
/// let speeds = wall.speeds.as_ref().unwrap();
/// let mass: f64 = speeds.density.iter().map(|d| d * speeds.grid.width()).sum();
/// assert!((mass - 1.0).abs() < 0.01);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallStats {
    /// The state that meets the wall.
    pub state: String,
    /// The wall's position.
    pub at: f64,
    /// Whether the state lives above the wall (else below).
    pub above: bool,
    /// Impacts at the wall over the recording.
    pub count: u64,
    /// Impacts per unit time per trajectory.
    pub rate: Estimate,
    /// The mean impact speed over the impacts.
    pub mean_speed: Estimate,
    /// The mean dissipated power.
    pub mean_power: Estimate,
    /// The time-step biases of `rate`, `mean_speed` and `mean_power` (S_dt − S), `None`
    /// without a 2·dt run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_step_bias: Option<[Estimate; 3]>,
    /// The flux-weighted impact-speed density, when the run had a speed grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speeds: Option<SpeedDensity>,
}

/// A histogram of impact speeds as a density over the impacts.
///
/// ```
/// use fpsolve::mc::{Grid, McConfig, Simulation};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/grid_impact_linear.sde");
/// let model = fpsolve::model::load_model(path.as_ref())?.bind(&[])?;
/// let speeds = Grid::new(0.0, 12.0, 6)?;
/// let config = McConfig {
///     trajectories: 256,
///     samples: 20_000,
///     impact_speeds: Some(speeds),
///     ..McConfig::default()
/// };
/// let res = Simulation::new(&model, &config)?.run()?;
/// let d = res.impacts.as_ref().unwrap().walls[0].speeds.clone().unwrap();
/// assert_eq!((d.grid, d.density.len(), d.stderr.len()), (speeds, 6, 6));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedDensity {
    /// The bins (a bin below 0 counts only its part at or above 0).
    pub grid: Grid,
    /// The density in each bin: its impacts over all impacts and its width at or above 0.
    pub density: Vec<f64>,
    /// Standard errors of `density`.
    pub stderr: Vec<f64>,
    /// Impacts faster than the grid.
    pub beyond: u64,
}

/// The mean up-crossing rates of one quantity's levels, counted from the trajectories (see
/// [`McConfig::levels`](crate::mc::McConfig)): at the level of a wall the state stands on,
/// one per impact (the rate at which paths leave a lower wall or reach an upper one, Rice's
/// flux there).
///
/// ```
/// use fpsolve::mc::{McConfig, Simulation};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/grid_impact_linear.sde");
/// let model = fpsolve::model::load_model(path.as_ref())?.bind(&[])?;
/// let config = McConfig {
///     trajectories: 256,
///     samples: 20_000,
///     levels: vec![("y".into(), vec![-0.5, 0.0, 1.0])],
///     ..McConfig::default()
/// };
/// let res = Simulation::new(&model, &config)?.run()?;
/// let c = &res.crossings[0];
/// assert_eq!((c.quantity.as_str(), c.rate.len()), ("y", 3));
/// // The wall's level is crossed once per impact (the counts span one sample interval
/// // fewer than the impacts').
/// let impacts = res.impacts.as_ref().unwrap().walls[0].rate.value;
/// assert!((c.rate[0].value - impacts).abs() <= 0.05 * impacts);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CrossingRates {
    /// The state or observable.
    pub quantity: String,
    /// The levels.
    pub levels: Vec<f64>,
    /// Up-crossings per unit time per trajectory at each level, counted between sample
    /// points.
    pub rate: Vec<Estimate>,
    /// The bias of counting at the sample points (crossing pairs within a spacing missed):
    /// rate − rate at twice the spacing, the first-order Richardson estimate of
    /// rate_Δ − rate_0 from the same trajectories.
    pub spacing_bias: Vec<Estimate>,
    /// The time-step bias of `rate`, `None` without a 2·dt run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_step_bias: Option<Vec<Estimate>>,
}

/// `Σ num / Σ den` over batches, with the batch-means standard error of a ratio.
fn ratio(num: &[f64], den: &[f64]) -> Estimate {
    let (n, d): (f64, f64) = (num.iter().sum(), den.iter().sum());
    let r = n / d;
    let k = num.len() as f64;
    let ss: f64 = num.iter().zip(den).map(|(a, b)| (a - r * b).powi(2)).sum();
    Estimate {
        value: r,
        stderr: if k > 1.0 {
            (k / (k - 1.0) * ss).sqrt() / d
        } else {
            f64::INFINITY
        },
    }
}

/// The Richardson factor 1/(2ᵖ − 1) of the run's scheme.
fn richardson(st: &RunSettings) -> f64 {
    1.0 / (2f64.powi(st.scheme.weak_order() as i32) - 1.0)
}

/// Per pair of a coarse batch and its fine one, `(stat(coarse) − stat(fine))·factor`.
fn pair_bias(
    st: &RunSettings,
    fine: &[&BatchSummary],
    coarse: &[&BatchSummary],
    stat: impl Fn(&BatchSummary, &RunSettings) -> f64,
) -> Option<Estimate> {
    if coarse.is_empty() {
        return None;
    }
    let c_st = st.coarse();
    let d: Vec<f64> = coarse
        .iter()
        .filter_map(|c| {
            let f = paired(fine, c)?;
            (f.recorded > 0 && c.recorded > 0)
                .then(|| (stat(c, &c_st) - stat(f, st)) * richardson(st))
        })
        .collect();
    Some(mean_se(&d))
}

/// The recording time of a trajectory.
fn recording(st: &RunSettings) -> f64 {
    st.samples_per_trajectory as f64 * st.spacing()
}

/// The statistics of every wall of the run (none when the batches carry none).
pub(crate) fn wall_stats(
    st: &RunSettings,
    batches: &[&BatchSummary],
    coarse: &[&BatchSummary],
) -> Vec<WallStats> {
    let walls = batches.first().map_or(0, |b| b.walls.len());
    // Every batch's or none (shards written before the walls were recorded have none).
    if batches.iter().chain(coarse).any(|b| b.walls.len() != walls) {
        return Vec::new();
    }
    (0..walls)
        .map(|w| {
            let time = |b: &BatchSummary, s: &RunSettings| b.recorded as f64 * recording(s);
            let of = |f: fn(&crate::mc::compile::tally::WallBatch) -> f64| -> Vec<f64> {
                batches.iter().map(|b| f(&b.walls[w])).collect()
            };
            let t: Vec<f64> = batches.iter().map(|b| time(b, st)).collect();
            let (n, speed, loss) = (
                of(|w| w.count as f64),
                of(|w| w.speed_sum),
                of(|w| w.loss_sum),
            );
            let bias = |stat: fn(&crate::mc::compile::tally::WallBatch, f64) -> f64| {
                pair_bias(st, batches, coarse, |b, s| stat(&b.walls[w], time(b, s)))
            };
            let biases = [
                bias(|w, t| w.count as f64 / t),
                bias(|w, _| w.speed_sum / w.count as f64),
                bias(|w, t| w.loss_sum / t),
            ];
            let time_step_bias = match biases {
                [Some(a), Some(b), Some(c)] => Some([a, b, c]),
                _ => None,
            };
            let speeds = st.impact_speeds.map(|grid| {
                let bins = grid.bins;
                let width = grid.width();
                let mut density = Vec::with_capacity(bins);
                let mut stderr = Vec::with_capacity(bins);
                for k in 0..bins {
                    let c: Vec<f64> = batches
                        .iter()
                        .map(|b| b.walls[w].speed_counts.get(k).copied().unwrap_or(0) as f64)
                        .collect();
                    let e = ratio(&c, &n);
                    let lo = (grid.lo + k as f64 * width).max(0.0);
                    let hi = grid.lo + (k + 1) as f64 * width;
                    let inside = (hi - lo).max(0.0);
                    let (d, s) = if inside > 0.0 {
                        (e.value / inside, e.stderr / inside)
                    } else {
                        (0.0, 0.0)
                    };
                    density.push(d);
                    stderr.push(s);
                }
                SpeedDensity {
                    grid,
                    density,
                    stderr,
                    beyond: batches
                        .iter()
                        .map(|b| b.walls[w].speed_counts.get(bins).copied().unwrap_or(0))
                        .fold(0u64, u64::saturating_add),
                }
            });
            let setting = st.barriers.get(w);
            WallStats {
                state: setting.map_or_else(String::new, |b| b.state.clone()),
                at: setting.map_or(f64::NAN, |b| b.at),
                above: setting.is_some_and(|b| b.above),
                count: batches
                    .iter()
                    .map(|b| b.walls[w].count)
                    .fold(0u64, u64::saturating_add),
                rate: ratio(&n, &t),
                mean_speed: ratio(&speed, &n),
                mean_power: ratio(&loss, &t),
                time_step_bias,
                speeds,
            }
        })
        .collect()
}

/// The crossing rates of every quantity the run counted crossings of.
pub(crate) fn crossing_rates(
    st: &RunSettings,
    batches: &[&BatchSummary],
    coarse: &[&BatchSummary],
) -> Vec<CrossingRates> {
    let Some(first) = batches.first() else {
        return Vec::new();
    };
    // Intervals between sample points, and between the even ones.
    let spans = |s: &RunSettings| {
        let n = s.samples_per_trajectory;
        let narrow = n.saturating_sub(1) as f64 * s.spacing();
        let wide = n.div_ceil(2).saturating_sub(1) as f64 * 2.0 * s.spacing();
        (narrow, wide)
    };
    let (narrow, wide) = spans(st);
    (0..first.crossings.len())
        .map(|c| {
            let q = first.crossings[c].quantity;
            let spec = &st.quantities[q];
            let levels = spec.levels.clone();
            let t: Vec<f64> = batches.iter().map(|b| b.recorded as f64 * narrow).collect();
            let mut rate = Vec::with_capacity(levels.len());
            let mut spacing_bias = Vec::with_capacity(levels.len());
            let mut time_step_bias = (!coarse.is_empty()).then(Vec::new);
            for k in 0..levels.len() {
                let up: Vec<f64> = batches
                    .iter()
                    .map(|b| b.crossings[c].up[k] as f64)
                    .collect();
                rate.push(ratio(&up, &t));
                let d: Vec<f64> = batches
                    .iter()
                    .filter(|b| b.recorded > 0)
                    .map(|b| {
                        let n = b.recorded as f64;
                        b.crossings[c].up_wide[k] as f64 / (n * wide)
                            - b.crossings[c].up[k] as f64 / (n * narrow)
                    })
                    .collect();
                spacing_bias.push(mean_se(&d));
                if let Some(tb) = time_step_bias.as_mut() {
                    let bias = pair_bias(st, batches, coarse, |b, s| {
                        b.crossings[c].up[k] as f64 / (b.recorded as f64 * spans(s).0)
                    });
                    tb.push(bias.expect("a 2·dt run"));
                }
            }
            CrossingRates {
                quantity: spec.name.clone(),
                levels,
                rate,
                spacing_bias,
                time_step_bias,
            }
        })
        .collect()
}
