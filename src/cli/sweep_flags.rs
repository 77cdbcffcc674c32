//! The sweep's shard flags: `fpsolve sweep --shard K/N` (one shard's points, written as
//! `sweep_shard_K_of_N.json`) and `fpsolve merge` of sweep shards into `sweep.csv` and
//! `sweep.json` of the whole sweep.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use fpsolve::base::cancel::Cancel;
use fpsolve::base::input_file::{read_regular_text, MAX_RESULT_FILE_BYTES};
use fpsolve::job::Progress;
use fpsolve::mc::Shard;
use fpsolve::report::OutputDir;
use fpsolve::solve::MethodName;
use fpsolve::sweep::{merge_sweep_shards, MergedSweep, Sweep, SweepShard, SweepSpec};

use crate::{begin_output, commit_output, flag, lib, sayln, Bar, Failure};

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
    sayln!(
        "shard {} of {}: points {}..{} of {} in {:.1} s",
        shard.index + 1,
        shard.count,
        points.start,
        points.end,
        part.identity.points.len(),
        part.wall_ms / 1e3
    );
    sayln!("wrote {}", file.display());
    Ok(())
}

/// The files in `dir` whose names start with `prefix` and end in `.json`, sorted.
fn shard_files(dir: &Path, prefix: &str) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))?;
    let mut names: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(prefix) && n.ends_with(".json"))
        })
        .collect();
    names.sort();
    Ok(names)
}

/// Solves every point of `sweep` and writes its files into `dir`; failed points are flagged
/// (exit 1) after the files are written.
pub(crate) fn run_whole(
    sweep: Sweep<'_>,
    spec: &SweepSpec,
    degree: usize,
    dir: &Path,
    quiet: bool,
) -> Result<(), Failure> {
    let run = begin_output(dir)?;
    let t = std::time::Instant::now();
    let bar = Bar::new(quiet);
    bar.stage("sweep");
    let result = sweep
        .progress(&|done, total| bar.advance(done, total))
        .run();
    bar.finish();
    let files = result.write(run.out()).map_err(lib)?;
    let seconds = t.elapsed().as_secs_f64();
    let failed: usize = result
        .methods
        .names()
        .iter()
        .map(|&m| spec.len() - result.converged_by(m))
        .sum();
    if result.methods.names() == [MethodName::Epc] {
        sayln!(
            "{} of {} points converged at degree {degree} in {seconds:.1} s",
            result.converged(),
            spec.len(),
        );
    } else {
        for &m in result.methods.names() {
            sayln!(
                "{m}: {} of {} points solved",
                result.converged_by(m),
                spec.len()
            );
        }
        sayln!("in {seconds:.1} s");
    }
    if result.tail_thresholds.is_empty() {
        sayln!("no tail thresholds: no method solved any point, so sweep.csv has no p_gt columns");
    }
    commit_output(run, files.len())?;
    // Refused points count once, not once per method: no method was asked to solve them.
    let refused = result.refused();
    let failed = failed - refused * result.methods.names().len();
    if failed > 0 || refused > 0 {
        let mut what = Vec::new();
        if refused > 0 {
            what.push(format!(
                "{refused} points refused before any work (no stationary density)"
            ));
        }
        if failed > 0 && result.methods.names().len() == 1 {
            what.push(format!("{failed} points failed"));
        } else if failed > 0 {
            what.push(format!("{failed} (point, method) pairs failed"));
        }
        return Err(Failure::Flagged(format!(
            "error: {} (reported in sweep.csv and sweep.json; the others were kept)",
            what.join(", ")
        )));
    }
    Ok(())
}

/// Every `sweep_shard_*.json` in `dirs`, read and named by its path; `None` when there is
/// none (the directories hold Monte Carlo shards, or nothing). Directories holding both
/// kinds are refused: one merge joins one run.
pub(crate) fn read_sweep_shards(dirs: &[PathBuf]) -> Result<Option<Vec<(String, SweepShard)>>> {
    let mut shards = Vec::new();
    let mut monte_carlo = None;
    for dir in dirs {
        if let Some(p) = shard_files(dir, "shard_")?.into_iter().next() {
            monte_carlo = Some(p);
        }
        let names = shard_files(dir, "sweep_shard_")?;
        for p in names {
            let text = read_regular_text(&p, MAX_RESULT_FILE_BYTES)
                .with_context(|| format!("reading {}", p.display()))?;
            let shard: SweepShard = serde_json::from_str(&text)
                .with_context(|| format!("{} is not a sweep shard file", p.display()))?;
            shards.push((p.display().to_string(), shard));
        }
    }
    if let (Some(mc), Some((sweep, _))) = (monte_carlo, shards.first()) {
        bail!(
            "{} is a Monte Carlo shard and {sweep} a sweep shard: merge each run on its own",
            mc.display()
        );
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
        sayln!("{method}: {solved} of {points} points solved");
        failed += points - solved;
    }
    sayln!(
        "merged {} sweep shards (sweep.csv and sweep.json; figures are drawn by a single run)",
        merged.shards()
    );
    commit_output(run, files.len())?;
    // As a single run counts them: a refused point once, not once per method.
    let methods = merged.solved_by().count();
    let refused = merged.refused();
    let failed = failed - refused * methods;
    if failed > 0 || refused > 0 {
        let mut what = Vec::new();
        if refused > 0 {
            what.push(format!(
                "{refused} points refused before any work (no stationary density)"
            ));
        }
        if failed > 0 && methods == 1 {
            what.push(format!("{failed} points failed"));
        } else if failed > 0 {
            what.push(format!("{failed} (point, method) pairs failed"));
        }
        return Err(Failure::Flagged(format!(
            "error: {} (reported in sweep.csv and sweep.json; the others were kept)",
            what.join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::SweepShardArg;

    fn arg(text: &str) -> SweepShardArg {
        SweepShardArg {
            shard: Some(text.to_string()),
        }
    }

    #[test]
    fn shard_flags_are_checked_against_the_points() {
        let part = arg("2/3").parse(10).unwrap().unwrap();
        assert_eq!((part.index, part.count), (1, 3));
        assert!(SweepShardArg { shard: None }.parse(10).unwrap().is_none());
        for bad in ["0/3", "4/3", "a/b", "3", "1/0", "-1/2", "1/11"] {
            assert!(arg(bad).parse(10).is_err(), "{bad}");
        }
        assert!(arg("10/10").parse(10).is_ok());
    }
}
