//! The sweep's shard flags: `fpsolve sweep --shard K/N` (one shard's points, written as
//! `sweep_shard_K_of_N.json`) and `fpsolve merge` of sweep shards into `sweep.csv` and
//! `sweep.json` of the whole sweep.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use fpsolve::cancel::Cancel;
use fpsolve::job::Progress;
use fpsolve::mc::Shard;
use fpsolve::report::OutputDir;
use fpsolve::sweep::{merge_sweep_shards, MergedSweep, Sweep, SweepShard};

use super::{begin_output, commit_output, flag, lib, Bar, Failure};

/// `--shard K/N` of `fpsolve sweep`.
#[derive(Args, Debug)]
pub(crate) struct SweepShardArg {
    /// Solve only part K of N of the points (`--shard 3/10`, K from 1, consecutive points)
    /// and write sweep_shard_K_of_N.json into --out; `fpsolve merge` joins the parts.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
}

impl SweepShardArg {
    /// The shard asked for, checked against the sweep's `points`: K/N well formed with
    /// 1 ≤ K ≤ N ≤ points.
    pub(crate) fn parse(&self, points: usize) -> Result<Option<Shard>> {
        let Some(spec) = self.shard.as_deref() else {
            return Ok(None);
        };
        // The Monte Carlo shards' K/N, with the sweep's words when it is malformed.
        let Ok(part) = spec.parse::<Shard>() else {
            bail!("--shard `{spec}`: expected K/N with 1 <= K <= N");
        };
        if part.count > points as u64 {
            bail!("--shard `{spec}`: at most {points} shards (the sweep's points)");
        }
        Ok(Some(part))
    }
}

/// Solves one shard of `sweep` and writes its file into `dir` (shards of one sweep share a
/// directory: each adds its own file, atomically). Failed points are in the file; the merge
/// reports them.
pub(crate) fn run_shard(
    sweep: Sweep<'_>,
    shard: Shard,
    dir: &Path,
    quiet: bool,
) -> Result<(), Failure> {
    let out = OutputDir::create(dir).map_err(flag("--out"))?;
    let bar = Bar::new(quiet);
    bar.stage("sweep shard");
    let part = sweep
        .progress(&|done, total| bar.advance(done, total))
        .run_shard(shard, &Cancel::new())
        .expect("a sweep whose flag nobody holds is never cancelled");
    bar.finish();
    let file = part.write(&out).map_err(lib)?;
    let points = part.points();
    println!(
        "shard {} of {}: points {}..{} of {} in {:.1} s",
        shard.index + 1,
        shard.count,
        points.start,
        points.end,
        part.identity.points.len(),
        part.wall_ms / 1e3
    );
    println!("wrote {}", file.display());
    Ok(())
}

/// Every `sweep_shard_*.json` in `dirs`, read and named by its path; `None` when there is
/// none (the directories hold Monte Carlo shards, or nothing).
pub(crate) fn read_sweep_shards(dirs: &[PathBuf]) -> Result<Option<Vec<(String, SweepShard)>>> {
    let mut shards = Vec::new();
    for dir in dirs {
        let entries =
            std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))?;
        let mut names: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("sweep_shard_") && n.ends_with(".json"))
            })
            .collect();
        names.sort();
        for p in names {
            let text =
                std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
            let shard: SweepShard = serde_json::from_str(&text)
                .with_context(|| format!("{} is not a sweep shard file", p.display()))?;
            shards.push((p.display().to_string(), shard));
        }
    }
    Ok((!shards.is_empty()).then_some(shards))
}

/// The shards checked and merged (before anything is written): any defect names its file.
pub(crate) fn merge(shards: &[(String, SweepShard)]) -> Result<MergedSweep> {
    merge_sweep_shards(shards).map_err(anyhow::Error::new)
}

/// Writes a merged sweep and says what it holds; failed points are flagged (exit 1) as by
/// a single run.
pub(crate) fn write_merged(merged: &MergedSweep, out: &Path) -> Result<(), Failure> {
    let run = begin_output(out)?;
    let files = merged.write(run.out()).map_err(lib)?;
    let points = merged.points();
    let mut failed = 0;
    for (method, solved) in merged.solved_by() {
        println!("{method}: {solved} of {points} points solved");
        failed += points - solved;
    }
    println!(
        "merged {} sweep shards (sweep.csv and sweep.json; figures are drawn by a single run)",
        merged.shards()
    );
    commit_output(run, files.len())?;
    if failed > 0 {
        return Err(Failure::Flagged(format!(
            "error: {failed} (point, method) pairs failed (reported in sweep.csv and sweep.json; the others were kept)"
        )));
    }
    Ok(())
}
