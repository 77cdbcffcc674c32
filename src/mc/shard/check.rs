//! The invariants a shard file's contents must satisfy before they are merged: settings in
//! range, and in every batch counts, extremes and power sums consistent with each other and
//! with the grid. A corrupt or edited file is a [`ShardDefect`], never a panic.

use crate::mc::error::ShardDefect;
use crate::mc::record::batch::BatchSummary;
use crate::mc::record::histogram::{Grid, QuantityBatch};
use crate::mc::settings::RunSettings;

fn defect_setting(name: &'static str, reason: String) -> ShardDefect {
    ShardDefect::Setting { name, reason }
}

impl RunSettings {
    /// Checks every invariant of resolved settings (they may come from a file).
    pub(crate) fn check(&self) -> Result<(), ShardDefect> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(defect_setting(
                "dt",
                format!("{:?} is not a positive number", self.dt),
            ));
        }
        if self.steps_per_sample == 0 || self.samples_per_trajectory == 0 {
            return Err(defect_setting(
                "samples",
                "steps per sample and samples per trajectory must be at least 1".into(),
            ));
        }
        if self.lanes == 0 || self.lanes > crate::mc::MAX_LANES {
            return Err(defect_setting(
                "lanes",
                format!("{} is not in 1..=65536", self.lanes),
            ));
        }
        if self.batches < 2 || self.batches.checked_mul(self.lanes as u64).is_none() {
            return Err(defect_setting(
                "batches",
                format!("{} batches of {} lanes", self.batches, self.lanes),
            ));
        }
        // Every count of the run (samples, steps) must fit in 64 bits.
        let samples =
            (self.lanes as u128) * self.batches as u128 * self.samples_per_trajectory as u128;
        let steps = self.burn_in_steps as u128
            + self.samples_per_trajectory as u128 * self.steps_per_sample as u128;
        if samples > u64::MAX as u128 || steps > u64::MAX as u128 / 4 {
            return Err(defect_setting(
                "samples",
                format!(
                    "{samples:e} samples in all or {steps:e} steps per trajectory do not fit \
                     a run"
                ),
            ));
        }
        if self.bias_batches > self.batches {
            return Err(defect_setting(
                "bias_batches",
                format!("{} of {} batches", self.bias_batches, self.batches),
            ));
        }
        // Files written before the barriers were recorded have none (and may have a barrier).
        if self.barriers.len() > 2 || (!self.barriers.is_empty() && !self.has_barrier) {
            return Err(defect_setting(
                "barriers",
                format!(
                    "{} barriers recorded, has_barrier = {}",
                    self.barriers.len(),
                    self.has_barrier
                ),
            ));
        }
        let states = self.quantities.iter().take_while(|q| q.is_state).count();
        if self.quantities.len() < 2 || states != 2 {
            return Err(defect_setting(
                "quantities",
                format!(
                    "need the two states first, then observables; got {} quantities ({} states)",
                    self.quantities.len(),
                    states
                ),
            ));
        }
        if let Some(g) = self.impact_speeds {
            if !g.well_formed() || g.bins > crate::mc::record::histogram::MAX_BINS {
                return Err(defect_setting(
                    "impact_speeds",
                    format!("[{:?}, {:?}) with {} bins", g.lo, g.hi, g.bins),
                ));
            }
        }
        for q in &self.quantities {
            if !q.levels.iter().all(|u| u.is_finite())
                || !q.levels.windows(2).all(|w| w[0] < w[1])
                || q.levels.len() > crate::mc::record::histogram::MAX_BINS
            {
                return Err(defect_setting(
                    "levels",
                    format!("{}: levels must be finite and ascending", q.name),
                ));
            }
            let g = q.grid;
            if !g.well_formed() || g.bins > crate::mc::record::histogram::MAX_BINS {
                return Err(defect_setting(
                    "grid",
                    format!(
                        "`{}`: [{:?}, {:?}) with {} bins",
                        q.name, g.lo, g.hi, g.bins
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Checks one batch summary against the settings it claims to be run with.
pub(in crate::mc) fn check_batch(st: &RunSettings, b: &BatchSummary) -> Result<(), ShardDefect> {
    let bad = |quantity: Option<&str>, what: String| ShardDefect::Batch {
        batch: b.index,
        quantity: quantity.map(str::to_string),
        what,
    };
    let lanes = st.lanes as u64;
    if b.quantities.len() != st.quantities.len() {
        return Err(bad(
            None,
            format!(
                "{} quantities, the settings list {}",
                b.quantities.len(),
                st.quantities.len()
            ),
        ));
    }
    if b.recorded.checked_add(b.blowups.len() as u64) != Some(lanes) {
        return Err(bad(
            None,
            format!(
                "{} trajectories recorded and {} blown up, but a batch has {lanes}",
                b.recorded,
                b.blowups.len()
            ),
        ));
    }
    let first = b.index as u128 * lanes as u128;
    let last_step =
        st.burn_in_steps as u128 + st.samples_per_trajectory as u128 * st.steps_per_sample as u128;
    let mut seen = std::collections::HashSet::new();
    for blow in &b.blowups {
        let t = blow.trajectory as u128;
        if t < first || t >= first + lanes as u128 || !seen.insert(blow.trajectory) {
            return Err(bad(
                None,
                format!(
                    "blow-up of trajectory {} does not belong to it",
                    blow.trajectory
                ),
            ));
        }
        if blow.step as u128 > last_step || blow.params != st.params {
            return Err(bad(
                None,
                format!("blow-up of trajectory {} is inconsistent", blow.trajectory),
            ));
        }
    }
    // At most a few events per step (the general scheme resolves up to 8, the splitting
    // one per flight), counted over the recording.
    let recording = st.samples_per_trajectory as u128 * st.steps_per_sample as u128;
    if b.impacts as u128 > b.recorded as u128 * recording * 16 {
        return Err(bad(
            None,
            format!(
                "{} impacts are more than its trajectories can have",
                b.impacts
            ),
        ));
    }
    // A folded step follows the most events a step resolves, each an impact.
    if b.folded > b.impacts {
        return Err(bad(
            None,
            format!(
                "{} unresolved steps are more than its {} impacts",
                b.folded, b.impacts
            ),
        ));
    }
    if !st.has_barrier && b.impacts != 0 {
        return Err(bad(
            None,
            format!("{} impacts in a model without a barrier", b.impacts),
        ));
    }
    check_walls(st, b).map_err(|what| bad(None, what))?;
    check_crossings(st, b).map_err(|(q, what)| bad(Some(&st.quantities[q].name), what))?;
    let expected = b.recorded as u128 * st.samples_per_trajectory as u128;
    for (spec, q) in st.quantities.iter().zip(&b.quantities) {
        check_quantity(spec.grid, spec.is_state, q, expected)
            .map_err(|what| bad(Some(&spec.name), what))?;
    }
    Ok(())
}

/// The impact statistics of each wall: one per barrier (or none, from a run that did not
/// record them), their counts adding up to the batch's impacts, finite sums, the speed
/// histogram on the settings' grid holding every impact.
fn check_walls(st: &RunSettings, b: &BatchSummary) -> Result<(), String> {
    if b.walls.is_empty() {
        return Ok(());
    }
    if b.walls.len() != st.barriers.len() || !st.has_barrier {
        return Err(format!(
            "impact statistics of {} walls, the settings list {}",
            b.walls.len(),
            st.barriers.len()
        ));
    }
    let total = b.walls.iter().try_fold(0u64, |a, w| a.checked_add(w.count));
    if total != Some(b.impacts) {
        return Err(format!(
            "the walls' impacts do not add up to the batch's {}",
            b.impacts
        ));
    }
    for w in &b.walls {
        // Each impact's speed is at least 0 and its energy loss is finite.
        if !(w.speed_sum.is_finite() && w.speed_sum >= 0.0 && w.loss_sum.is_finite()) {
            return Err("an impact speed or energy sum that is not finite".into());
        }
        let bins = st.impact_speeds.map_or(0, |g| g.bins + 1);
        let held = w
            .speed_counts
            .iter()
            .try_fold(0u64, |a, &c| a.checked_add(c));
        if w.speed_counts.len() != bins || (bins > 0 && held != Some(w.count)) {
            return Err("an impact-speed histogram off the settings' grid".into());
        }
    }
    Ok(())
}

/// The up-crossing counts: one entry per quantity with levels, in order, each as long as its
/// levels, at most one crossing per level and trajectory between sample points.
fn check_crossings(st: &RunSettings, b: &BatchSummary) -> Result<(), (usize, String)> {
    let counted: Vec<usize> = (0..st.quantities.len())
        .filter(|&q| !st.quantities[q].levels.is_empty())
        .collect();
    if b.crossings.len() != counted.len() {
        return Err((
            counted.first().copied().unwrap_or(0),
            format!(
                "crossings of {} quantities, the settings give levels of {}",
                b.crossings.len(),
                counted.len()
            ),
        ));
    }
    let most = b.recorded as u128 * st.samples_per_trajectory as u128;
    for (c, &q) in b.crossings.iter().zip(&counted) {
        let n = st.quantities[q].levels.len();
        if c.quantity != q || c.up.len() != n || c.up_wide.len() != n {
            return Err((q, "crossings not on the settings' levels".into()));
        }
        if c.up.iter().chain(&c.up_wide).any(|&u| u as u128 > most) {
            return Err((q, "more crossings than its trajectories can have".into()));
        }
    }
    Ok(())
}

/// The invariants of one quantity's batch statistics; `expected` is the number of samples
/// (finite or not) the batch recorded.
fn check_quantity(
    grid: Grid,
    is_state: bool,
    q: &QuantityBatch,
    expected: u128,
) -> Result<(), String> {
    if q.counts.len() != grid.bins {
        return Err(format!(
            "{} bins, the grid has {}",
            q.counts.len(),
            grid.bins
        ));
    }
    let finite: u128 =
        q.counts.iter().map(|&c| c as u128).sum::<u128>() + q.under as u128 + q.over as u128;
    if finite + q.invalid as u128 != expected {
        return Err(format!(
            "{finite} finite and {} invalid samples, but {expected} were recorded",
            q.invalid
        ));
    }
    if is_state && q.invalid != 0 {
        return Err(format!(
            "{} non-finite states counted as samples",
            q.invalid
        ));
    }
    let windows: u128 = q.window_counts.iter().map(|&c| c as u128).sum();
    if windows != finite {
        return Err(format!(
            "the recording's quarters hold {windows} samples, the histogram {finite}"
        ));
    }
    if finite == 0 {
        let empty = q.min == f64::INFINITY
            && q.max == f64::NEG_INFINITY
            && q.sums
                .iter()
                .chain(&q.window_sums)
                .chain(&q.window_squares)
                .all(|&s| s == 0.0);
        return if empty {
            Ok(())
        } else {
            Err("no samples, yet extremes or sums are set".into())
        };
    }
    if !(q.min.is_finite() && q.max.is_finite() && q.min <= q.max) {
        return Err(format!(
            "min {:?} and max {:?} are not finite with min ≤ max",
            q.min, q.max
        ));
    }
    let slack = 1e-9 * (grid.hi - grid.lo);
    if (q.under == 0 && q.min < grid.lo)
        || (q.under > 0 && q.min >= grid.lo)
        || (q.over == 0 && q.max > grid.hi + slack)
        || (q.over > 0 && q.max < grid.hi - slack - grid.width())
    {
        return Err(format!(
            "extremes [{:?}, {:?}] contradict {} samples below and {} above the grid [{:?}, {:?})",
            q.min, q.max, q.under, q.over, grid.lo, grid.hi
        ));
    }
    // |Σ (q − c)ᵏ| ≤ n·Mᵏ with M the largest |q − c| the extremes allow.
    let shift = 0.5 * (grid.lo + grid.hi);
    let m = (q.min - shift).abs().max((q.max - shift).abs());
    let tol = 1.0 + 1e-9;
    let within = |sum: f64, n: f64, k: i32| {
        let bound = n * m.powi(k) * tol;
        !bound.is_finite() || sum.abs() <= bound + f64::MIN_POSITIVE
    };
    for (k, &sum) in q.sums.iter().enumerate() {
        if !within(sum, finite as f64, k as i32 + 1) || (k % 2 == 1 && sum < 0.0) {
            return Err(format!(
                "power sum {} = {sum:.6e} is impossible for its extremes",
                k + 1
            ));
        }
    }
    for w in 0..4 {
        let n = q.window_counts[w] as f64;
        if !within(q.window_sums[w], n, 1)
            || !within(q.window_squares[w], n, 2)
            || q.window_squares[w] < 0.0
        {
            return Err(format!(
                "the sums of quarter {} are impossible for its extremes",
                w + 1
            ));
        }
    }
    check_against_bins(grid, q, shift)
}

/// The range of (q − c)ᵏ for q in [a, b].
fn power_range(k: i32, a: f64, b: f64, c: f64) -> (f64, f64) {
    let (x, y) = ((a - c).powi(k), (b - c).powi(k));
    if k % 2 == 1 {
        (x, y)
    } else if a <= c && c <= b {
        (0.0, x.max(y))
    } else {
        (x.min(y), x.max(y))
    }
}

/// The power sums, the extremes and the quarters' sums must agree with the bin counts: every
/// sample lies in its bin (or below / above the grid, between the extremes and the grid).
fn check_against_bins(grid: Grid, q: &QuantityBatch, shift: f64) -> Result<(), String> {
    let w = grid.width();
    let edge = |j: usize| grid.lo + j as f64 * w;
    let slack = 1e-9 * w;
    let first = q.counts.iter().position(|&c| c > 0);
    let last = q.counts.iter().rposition(|&c| c > 0);
    if q.under == 0 {
        if let Some(j) = first {
            if q.min > edge(j + 1) + slack {
                return Err(format!(
                    "min {:?} lies above bin {j}, the lowest one with samples",
                    q.min
                ));
            }
        }
    }
    if q.over == 0 {
        if let Some(j) = last {
            if q.max < edge(j) - slack {
                return Err(format!(
                    "max {:?} lies below bin {j}, the highest one with samples",
                    q.max
                ));
            }
        }
    }
    let mut regions: Vec<(f64, f64, f64)> = q
        .counts
        .iter()
        .enumerate()
        .filter(|(_, &c)| c > 0)
        .map(|(j, &c)| (c as f64, edge(j) - slack, edge(j + 1) + slack))
        .collect();
    if q.under > 0 {
        regions.push((q.under as f64, q.min, grid.lo));
    }
    if q.over > 0 {
        regions.push((q.over as f64, grid.hi - slack, q.max));
    }
    for k in 1..=4 {
        let (mut lo, mut hi, mut scale) = (0.0, 0.0, 0.0);
        for &(n, a, b) in &regions {
            let (l, h) = power_range(k, a, b, shift);
            lo += n * l;
            hi += n * h;
            scale += n * l.abs().max(h.abs());
        }
        if !(lo.is_finite() && hi.is_finite() && scale.is_finite()) {
            continue;
        }
        // Summation in a different order rounds differently: a relative 1e-6 of the scale.
        let tol = 1e-6 * scale + f64::MIN_POSITIVE;
        let sum = q.sums[k as usize - 1];
        if !(sum >= lo - tol && sum <= hi + tol) {
            return Err(format!(
                "power sum {k} = {sum:.6e} is outside [{lo:.6e}, {hi:.6e}], what its bin \
                 counts allow"
            ));
        }
        if k <= 2 {
            let quarters: f64 = if k == 1 {
                q.window_sums.iter().sum()
            } else {
                q.window_squares.iter().sum()
            };
            if (quarters - sum).abs() > tol || quarters.is_nan() {
                return Err(format!(
                    "the quarters' power sum {k} is {quarters:.6e}, the batch's {sum:.6e}"
                ));
            }
        }
    }
    Ok(())
}
