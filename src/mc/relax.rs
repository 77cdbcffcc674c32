//! The burn-in of a model whose drift linearised at the origin does not decay (an unstable
//! origin: van der Pol's limit cycle, a bistable Duffing oscillator's saddle), where no decay
//! rate can be read off the drift: a pilot ensemble is run from the stationary run's own
//! start and its moments are watched until they settle.
//!
//! The pilot ([`PILOT_TRAJECTORIES`] trajectories from the Gaussian start the stationary run
//! uses, no bias run) records the mean, variance and kurtosis of both states at
//! [`PILOT_TIMES`] times to a horizon H. It has settled when its last quarter agrees with the
//! quarter before within [`DRIFT_SE`] standard errors; else H doubles, up to a budget of
//! [`PILOT_STEP_BUDGET`] trajectory steps. The settled level of each statistic is its last
//! quarter's average; t* is the first time after which every later value stays within
//! [`SETTLED_SE`] standard errors of it. Between the start's gap G₀ (the first value's
//! distance from the level) and the noise G* = [`SETTLED_SE`]·SE, the gap has fallen by
//! ln(G₀/G*) e-folds in t*, so one decay time is τ = t* / max(1, ln(G₀/G*)) (the largest over
//! the statistics), and the burn-in is the asked number of decay times k·τ, never less than
//! t*. A burn-in still too short for the main run shows in that run's own stationarity
//! verdict (its first and last quarters compared).

use super::error::McError;
use super::transient::McTransient;
use crate::model::{BoundModel, InitialState};

/// Trajectories of the pilot.
pub const PILOT_TRAJECTORIES: u64 = 512;
/// Output times of the pilot (evenly spaced from 0 to the horizon).
pub const PILOT_TIMES: usize = 64;
/// At most this many trajectory steps for all of the pilot's attempts.
pub const PILOT_STEP_BUDGET: f64 = 4e8;
/// How far (in standard errors) the pilot's last two quarters may differ and be settled.
pub const DRIFT_SE: f64 = 4.0;
/// How close (in standard errors) a statistic must stay to its settled level.
pub const SETTLED_SE: f64 = 3.0;

/// The burn-in time: `decay_times` decay times of the pilot's relaxation, or why none was
/// found (`rate`: the origin's decay rate, ≤ 0 or not finite, for the error).
pub(super) fn pilot_burn_in(
    model: &BoundModel,
    start: [[f64; 2]; 2],
    dt: f64,
    seed: u64,
    decay_times: f64,
    rate: f64,
) -> Result<f64, McError> {
    // The start the stationary run draws from: N(0, L Lᵀ).
    let l = &start;
    let covariance = [
        [l[0][0] * l[0][0], l[0][0] * l[1][0]],
        [l[0][0] * l[1][0], l[1][0] * l[1][0] + l[1][1] * l[1][1]],
    ];
    let initial = InitialState::Gaussian {
        mean: [0.0, 0.0],
        covariance,
    };
    // A first horizon from the origin's growth rate (4 e-folds of it), else 1000 steps.
    let mut horizon = if rate.is_finite() && rate < 0.0 {
        (4.0 / -rate).max(100.0 * dt)
    } else {
        1000.0 * dt
    };
    let mut spent = 0.0;
    let no_relaxation = |horizon: f64, why: String| McError::NoRelaxation { rate, horizon, why };
    loop {
        let steps = PILOT_TRAJECTORIES as f64 * (horizon / dt).ceil();
        if spent + steps > PILOT_STEP_BUDGET {
            return Err(no_relaxation(
                horizon / 2.0,
                format!(
                    "the pilot's moments still drift at t = {} (the next doubling would pass \
                     {PILOT_STEP_BUDGET:e} trajectory steps)",
                    horizon / 2.0
                ),
            ));
        }
        spent += steps;
        let times: Vec<f64> = (0..=PILOT_TIMES)
            .map(|k| horizon * k as f64 / PILOT_TIMES as f64)
            .collect();
        let history = McTransient::new(model)
            .initial(initial)
            .times(times.clone())
            .dt(dt)
            .trajectories(PILOT_TRAJECTORIES)
            .seed(seed ^ RELAX_SALT)
            .bias(false)
            .run()
            .map_err(|e| no_relaxation(horizon, format!("the pilot failed: {e}")))?;
        let series = history.moment_series();
        if let Some(tau) = relaxation(&times, &series) {
            return Ok((decay_times * tau.decay).max(tau.settled));
        }
        horizon *= 2.0;
    }
}

/// Mixed into the seed so the pilot's trajectories are not the run's.
const RELAX_SALT: u64 = 0x5245_4C41_585F_504C;

/// What the pilot's moments show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Relaxation {
    /// t*: every statistic within [`SETTLED_SE`] of its level from then on.
    pub(super) settled: f64,
    /// One decay time τ.
    pub(super) decay: f64,
}

/// The relaxation of the statistics' `series` ((value, standard error) at each of `times`),
/// `None` while the last quarter still drifts from the one before. A statistic with no
/// finite value at some time (a kurtosis at a point start) is judged on its finite ones.
pub(super) fn relaxation(times: &[f64], series: &[Vec<(f64, f64)>]) -> Option<Relaxation> {
    let n = times.len();
    let q = n / 4;
    let mut settled: f64 = 0.0;
    let mut decay: f64 = 0.0;
    for s in series {
        let finite = |r: &[(f64, f64)]| -> Vec<(f64, f64)> {
            r.iter()
                .copied()
                .filter(|(v, e)| v.is_finite() && e.is_finite())
                .collect()
        };
        let (third, last) = (finite(&s[n - 2 * q..n - q]), finite(&s[n - q..]));
        if third.is_empty() || last.is_empty() {
            return None;
        }
        let mean = |r: &[(f64, f64)]| r.iter().map(|p| p.0).sum::<f64>() / r.len() as f64;
        let typical = |r: &[(f64, f64)]| r.iter().map(|p| p.1).sum::<f64>() / r.len() as f64;
        let (a, b) = (mean(&third), mean(&last));
        // Neighbouring times share trajectories: no credit for averaging over them.
        let se = typical(&third).max(typical(&last));
        if (a - b).abs() > DRIFT_SE * se {
            return None;
        }
        let level = b;
        // The first time after which every value stays near the level.
        let mut first = n;
        for k in (0..n).rev() {
            let (v, e) = s[k];
            if v.is_finite() && (v - level).abs() > SETTLED_SE * e.max(se) {
                break;
            }
            first = k;
        }
        let t_star = times[first.min(n - 1)];
        let gap0 = s
            .iter()
            .find(|(v, _)| v.is_finite())
            .map_or(0.0, |(v, _)| (v - level).abs());
        let noise = SETTLED_SE * se;
        let folds = if noise > 0.0 && gap0 > noise {
            (gap0 / noise).ln().max(1.0)
        } else {
            1.0
        };
        settled = settled.max(t_star);
        decay = decay.max(t_star / folds);
    }
    Some(Relaxation { settled, decay })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(n: usize) -> Vec<f64> {
        (0..n).map(|k| k as f64).collect()
    }

    #[test]
    fn an_exponential_approach_gives_its_decay_time() {
        // gap e^{−t/10} from 1, noise 1e-3: ln(1/3e-3) = 5.8 e-folds, settled near t = 58.
        let t = times(257);
        let s: Vec<(f64, f64)> = t.iter().map(|t| (2.0 - (-t / 10.0).exp(), 1e-3)).collect();
        let r = relaxation(&t, &[s]).unwrap();
        assert!((r.settled - 58.0).abs() <= 1.0, "{r:?}");
        assert!((r.decay - 10.0).abs() < 0.3, "{r:?}");
    }

    #[test]
    fn a_drifting_last_half_is_not_settled() {
        let t = times(65);
        let s: Vec<(f64, f64)> = t.iter().map(|t| (0.01 * t, 1e-3)).collect();
        assert_eq!(relaxation(&t, &[s]), None);
    }

    #[test]
    fn the_slowest_statistic_decides() {
        let t = times(257);
        let fast: Vec<(f64, f64)> = t.iter().map(|t| (1.0 - (-t).exp(), 1e-3)).collect();
        let slow: Vec<(f64, f64)> = t.iter().map(|t| (1.0 - (-t / 20.0).exp(), 1e-3)).collect();
        let r = relaxation(&t, &[fast, slow]).unwrap();
        assert!((r.decay - 20.0).abs() < 1.0, "{r:?}");
    }

    #[test]
    fn van_der_pol_gets_a_burn_in_of_its_relaxation() {
        // The bundled model: origin growing at rate 0.01, the rim relaxing at rate ~0.02
        // (50 time units): 10 decay times are several hundred.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/van_der_pol.sde");
        let model = crate::model::load_model(path.as_ref())
            .unwrap()
            .bind(&[])
            .unwrap();
        let b = pilot_burn_in(&model, [[1.0, 0.0], [0.0, 1.0]], 0.01, 1, 10.0, -0.01).unwrap();
        assert!((300.0..3000.0).contains(&b), "{b}");
    }
}
