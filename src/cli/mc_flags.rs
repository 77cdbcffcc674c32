//! The Monte Carlo flags of the command line (`--mc N`, `--samples`, `--trajectories`,
//! `--grid`, …) read and checked into an `McConfig`, with notes on values that were rounded.

use anyhow::{anyhow, bail, Result};
use fpsolve::mc::{BurnIn, Grid, McConfig, NamedGrid};

use crate::McArgs;

/// A count given as `200000000`, `2e8` or `2.5e6`.
pub(crate) fn parse_count(text: &str, what: &str) -> Result<u64> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| anyhow!("{what} `{text}` is not a number"))?;
    if !(v.is_finite() && (1.0..=1e15).contains(&v)) {
        bail!("{what} `{text}` must be between 1 and 1e15");
    }
    if v.fract() != 0.0 {
        bail!("{what} `{text}` is not a whole number");
    }
    Ok(v as u64)
}

/// The Monte Carlo flags read and checked (before any computation), with the notes to print
/// about values that were rounded.
pub(crate) struct McFlags {
    pub(crate) config: McConfig,
    pub(crate) notes: Vec<String>,
}

impl McFlags {
    /// `samples` is the value of `flag` (`--mc` or `--samples`).
    pub(crate) fn parse(args: &McArgs, samples: &str, flag: &str) -> Result<McFlags> {
        let requested = parse_count(
            samples,
            &format!("{flag}: the number of Monte Carlo samples"),
        )?;
        let mut notes = Vec::new();
        if args.trajectories == 0 {
            bail!("--trajectories must be at least 1");
        }
        let lanes = McConfig::default().lanes as u64;
        let batches = args.trajectories.div_ceil(lanes);
        let trajectories = batches
            .checked_mul(lanes)
            .filter(|t| *t <= 1 << 40)
            .ok_or_else(|| {
                anyhow!(
                    "--trajectories {} is more than fpsolve can run (at most 2^40)",
                    args.trajectories
                )
            })?;
        if trajectories != args.trajectories {
            notes.push(format!(
                "--trajectories {} rounded up to {trajectories} (whole statistics batches of {lanes})",
                args.trajectories
            ));
        }
        let per_trajectory = requested.div_ceil(trajectories).max(1);
        let total = per_trajectory.saturating_mul(trajectories);
        if total != requested {
            notes.push(format!(
                "{requested} Monte Carlo samples rounded up to {total} ({per_trajectory} per trajectory × {trajectories} trajectories)"
            ));
        }
        let mut grids: Vec<(String, Grid)> = Vec::new();
        for g in &args.grid {
            let NamedGrid { name, grid } = g.parse().map_err(|e| anyhow!("--grid {e}"))?; // the grid error names the argument
            if grids.iter().any(|(n, _)| n == &name) {
                bail!("--grid `{g}`: a grid for `{name}` is already given");
            }
            grids.push((name, grid));
        }
        let config = McConfig {
            dt: args.dt,
            spacing: args.spacing,
            trajectories,
            samples: per_trajectory,
            burn_in: match args.burn_in {
                Some(t) => BurnIn::Time(t),
                None => McConfig::default().burn_in,
            },
            seed: args.seed,
            grids,
            ..McConfig::default()
        };
        Ok(McFlags { config, notes })
    }
}
