//! Sweep shards: a consecutive block of a sweep's points, solved anywhere, merged into the
//! `sweep.csv` and `sweep.json` of one run, bit for bit (timings aside).
//!
//! A shard K of N solves the points [`crate::mc::Shard::batch_range`] gives out of the
//! sweep's points (the Monte Carlo shards' split, so the vocabulary is one). Every shard
//! finds the tail thresholds' reference point by walking the sweep from its first point
//! ([`super::thresholds`]), so all shards share the thresholds of the whole run. A shard file
//! keeps each point as the text its row of `sweep.csv` and its entry of `sweep.json` are,
//! so a merge only orders and joins text: no number goes through a parse.

use std::ops::Range;
use std::path::PathBuf;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::base::cancel::{Cancel, Cancelled};
use crate::mc::Shard;
use crate::report::{check_finite, write_json, OutputDir, Provenance, ReportError};

use super::{PointOutcome, Sweep, SweepPoint, SweepResult};

/// What a sweep shard file says it is.
const KIND: &str = "fpsolve sweep shard";

/// What makes two shards parts of one sweep: the model, the methods and their settings, and
/// every point's values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepIdentity {
    /// The model's name.
    pub model: String,
    /// The methods, as `--method` takes them (`epc,grid`).
    pub methods: String,
    /// The EPC degree.
    pub degree: usize,
    /// The grid's cells, when `grid` is among the methods.
    pub cells: Option<[usize; 2]>,
    /// The swept parameters.
    pub parameters: Vec<String>,
    /// The fixed overrides, as `name=expr`.
    pub fixed: Vec<String>,
    /// Every point of the sweep (not only the shard's), in order.
    pub points: Vec<Vec<f64>>,
}

/// One point of a shard, as the text of its `sweep.csv` row and its `sweep.json` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct ShardPoint {
    /// Its index among the sweep's points.
    index: usize,
    /// Its row of `sweep.csv`, without the line end.
    csv: String,
    /// Its entry of `sweep.json`'s `points`, pretty-printed at the top level.
    json: String,
    /// Whether each method (in the sweep's order) solved it.
    solved: Vec<bool>,
}

impl ShardPoint {
    /// Whether the point was refused before any work: its `sweep.json` entry's outcomes have
    /// status `refused` (the entry is the checked content of the shard, so no second record
    /// of it is needed).
    fn refused(&self) -> bool {
        serde_json::from_str::<serde_json::Value>(&self.json)
            .ok()
            .and_then(|v| {
                v["outcomes"]
                    .as_array()
                    .map(|o| o.iter().any(|o| o["status"] == "refused"))
            })
            .unwrap_or(false)
    }
}

/// A shard of a sweep: what `fpsolve sweep --shard K/N` writes, and what
/// [`merge_sweep_shards`] joins.
///
/// ```
/// use fpsolve::base::cancel::Cancel;
/// use fpsolve::mc::Shard;
/// use fpsolve::sweep::{merge_sweep_shards, Sweep, SweepSpec};
/// let model = fpsolve::model::parse_model("model m\nparam c = 1\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
/// let spec = SweepSpec::parse(&["c=0.5:1:3".into()])?;
/// let sweep = Sweep::new(&model, &spec).degree(2);
/// let parts: Vec<_> = (0..2)
///     .map(|k| sweep.run_shard(Shard::new(k, 2).unwrap(), &Cancel::new()).unwrap())
///     .map(|s| (s.file_name(), s))
///     .collect();
/// let merged = merge_sweep_shards(&parts)?;
/// assert_eq!(merged.csv(), sweep.run().to_csv());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepShard {
    /// Always `fpsolve sweep shard`.
    kind: String,
    /// Which shard.
    pub shard: Shard,
    /// The sweep it is part of.
    pub identity: SweepIdentity,
    /// The header line of `sweep.csv`.
    csv_header: String,
    /// `sweep.json` of the whole sweep without its points and with no time: the same text
    /// in every shard of one sweep.
    json_head: String,
    /// The shard's points, in order.
    points: Vec<ShardPoint>,
    /// Wall time of the shard in milliseconds.
    pub wall_ms: f64,
    /// Where the shard came from (the `provenance` block of a JSON result; absent in files
    /// written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<serde_json::Value>,
    /// The shard's result as computed (not in the file): checked for non-finite numbers
    /// before the file is written, as a single run's `sweep.json` is.
    #[serde(skip)]
    result: Option<Box<SweepResult>>,
}

/// Why shards cannot be merged into one sweep (or a shard file is not right): each names the
/// file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SweepShardError {
    /// No shard was given.
    #[error("no sweep shard files given")]
    NoShards,
    /// The file is not a sweep shard.
    #[error("{file} is not a sweep shard file")]
    NotAShard {
        /// The file.
        file: String,
    },
    /// The shard's index does not fit its split, or it holds other points than its index
    /// says.
    #[error("{file} claims to be shard {index} of {count} (counted from 1) of {points} points, but holds points {found:?} instead of {expected:?} (counted from 0)")]
    Points {
        /// The file.
        file: String,
        /// Its index, from 1.
        index: u64,
        /// Its split.
        count: u64,
        /// Points of the sweep.
        points: usize,
        /// The points it must hold.
        expected: Range<usize>,
        /// The points it holds (first and one past the last).
        found: Range<usize>,
    },
    /// Two shards are of different sweeps.
    #[error("{file} is of a different sweep than {first}: they differ in {what}")]
    Mismatch {
        /// The file.
        file: String,
        /// The first shard's file.
        first: String,
        /// What differs.
        what: ShardDifference,
    },
    /// Two files are the same shard.
    #[error("{file} and {other} are both shard {index} of {count}")]
    Duplicated {
        /// The file.
        file: String,
        /// The other file.
        other: String,
        /// The shard, from 1.
        index: u64,
        /// The split.
        count: u64,
    },
    /// Shards of the split are missing.
    #[error("shards {missing:?} of {count} (counted from 1) are missing; {first} is one of them")]
    Missing {
        /// The missing shards, from 1.
        missing: Vec<u64>,
        /// The split.
        count: u64,
        /// A file of the split.
        first: String,
    },
}

/// What two shards of different sweeps differ in ([`SweepShardError::Mismatch`]), checked in
/// this order.
///
/// ```
/// use fpsolve::sweep::ShardDifference;
/// assert_eq!(ShardDifference::FixedParameters.to_string(), "fixed parameters");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardDifference {
    /// The model's name.
    Model,
    /// The methods.
    Methods,
    /// The EPC degree.
    Degree,
    /// The grid's cells.
    Cells,
    /// The swept parameters.
    Parameters,
    /// The fixed overrides.
    FixedParameters,
    /// The values of the points.
    Points,
    /// The number of shards the sweep is split into.
    Split,
    /// The tail thresholds or the columns of the CSV and JSON.
    Columns,
}

impl std::fmt::Display for ShardDifference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ShardDifference::Model => "model",
            ShardDifference::Methods => "methods",
            ShardDifference::Degree => "degree",
            ShardDifference::Cells => "cells",
            ShardDifference::Parameters => "parameters",
            ShardDifference::FixedParameters => "fixed parameters",
            ShardDifference::Points => "points",
            ShardDifference::Split => "split",
            ShardDifference::Columns => "tail thresholds or columns",
        })
    }
}

impl Sweep<'_> {
    /// Solves only the points of shard `shard` (consecutive, [`Shard::batch_range`] of the
    /// sweep's points), with the tail thresholds of the whole sweep: what `fpsolve sweep
    /// --shard K/N` writes. Shards merge with [`merge_sweep_shards`] into the text of
    /// [`SweepResult::to_csv`] and `sweep.json` of one run. A split into more shards than
    /// points leaves some shards empty; they merge all the same.
    ///
    /// # Errors
    /// [`Cancelled`] when `cancel` is set.
    pub fn run_shard(&self, shard: Shard, cancel: &Cancel) -> Result<SweepShard, Cancelled> {
        let start = Instant::now();
        let range = points_of(shard, self.spec.len());
        let (raw, reference) = self.solve_range(range.clone(), cancel)?;
        let result = self.assemble(raw, reference, start);
        Ok(SweepShard::of(shard, &self.spec.points(), range, result))
    }
}

/// The points of shard `shard` out of `total`.
fn points_of(shard: Shard, total: usize) -> Range<usize> {
    let r = shard.batch_range(total as u64);
    r.start as usize..r.end as usize
}

impl SweepShard {
    fn of(shard: Shard, all: &[Vec<f64>], range: Range<usize>, mut result: SweepResult) -> Self {
        let csv = result.to_csv();
        let mut lines = csv.lines();
        let csv_header = lines.next().unwrap_or_default().to_string();
        let rows: Vec<String> = lines.map(str::to_string).collect();
        let points = std::mem::take(&mut result.points);
        let wall_ms = result.wall_ms;
        result.wall_ms = 0.0;
        // The head is the same text in every shard of one sweep: no time, no provenance
        // (the shard file carries its own; the merge writes the merged file's).
        let provenance = result.provenance.take();
        let json_head = serde_json::to_string_pretty(&result).expect("a sweep serialises");
        result.wall_ms = wall_ms;
        let identity = SweepIdentity {
            model: result.model.clone(),
            methods: result.methods.to_string(),
            degree: result.degree,
            cells: result.cells,
            parameters: result.parameters.clone(),
            fixed: result.fixed.clone(),
            points: all.to_vec(),
        };
        let entries = points
            .iter()
            .zip(rows)
            .zip(range)
            .map(|((p, csv), index)| ShardPoint {
                index,
                csv,
                json: serde_json::to_string_pretty(p).expect("a sweep point serialises"),
                solved: p
                    .outcomes
                    .iter()
                    .map(|o| matches!(o.outcome, PointOutcome::Converged(_)))
                    .collect(),
            })
            .collect();
        let typed: Vec<SweepPoint> = points;
        SweepShard {
            kind: KIND.to_string(),
            shard,
            identity,
            csv_header,
            json_head,
            points: entries,
            wall_ms,
            provenance: provenance.map(|p| serde_json::to_value(p).expect("provenance serialises")),
            result: Some(Box::new(SweepResult {
                points: typed,
                ..result
            })),
        }
    }

    /// The file a shard is written to: `sweep_shard_K_of_N.json` (K from 1).
    pub fn file_name(&self) -> String {
        format!(
            "sweep_shard_{}_of_{}.json",
            self.shard.index + 1,
            self.shard.count
        )
    }

    /// The points of the sweep this shard solved (indices among the sweep's points).
    pub fn points(&self) -> Range<usize> {
        points_of(self.shard, self.identity.points.len())
    }

    /// Writes the shard atomically into `out` as [`file_name`](Self::file_name).
    ///
    /// # Errors
    /// [`ReportError`] when the file cannot be written.
    pub fn write(&self, out: &OutputDir) -> Result<PathBuf, ReportError> {
        let name = self.file_name();
        if let Some(result) = &self.result {
            check_finite(&out.path().join(&name), result.as_ref())?;
        }
        write_json(out, &name, self)
    }

    /// Checks the shard on its own: its kind, and that it holds exactly the points its
    /// index implies, one row and entry each.
    fn check(&self, file: &str) -> Result<(), SweepShardError> {
        if self.kind != KIND {
            return Err(SweepShardError::NotAShard {
                file: file.to_string(),
            });
        }
        let total = self.identity.points.len();
        let (index, count) = (self.shard.index, self.shard.count);
        let found = match (self.points.first(), self.points.last()) {
            (Some(a), Some(b)) => a.index..b.index + 1,
            _ => 0..0,
        };
        let methods = self.identity.methods.split(',').count();
        let fits = count > 0 && index < count;
        let expected = if fits {
            points_of(self.shard, total)
        } else {
            0..0
        };
        let consecutive = self
            .points
            .iter()
            .zip(expected.clone())
            .all(|(p, i)| p.index == i && p.solved.len() == methods);
        if !fits || self.points.len() != expected.len() || !consecutive {
            return Err(SweepShardError::Points {
                file: file.to_string(),
                index: index.saturating_add(1),
                count,
                points: total,
                expected,
                found,
            });
        }
        Ok(())
    }
}

/// Sweep shards merged: the text of `sweep.csv` and `sweep.json` of the whole sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct MergedSweep {
    csv: String,
    json: String,
    methods: Vec<String>,
    points: usize,
    solved: Vec<usize>,
    all_solved: usize,
    refused: usize,
    shards: u64,
}

impl MergedSweep {
    /// `sweep.csv` of the whole sweep: as [`SweepResult::to_csv`] of one run.
    pub fn csv(&self) -> &str {
        &self.csv
    }

    /// `sweep.json` of the whole sweep: as one run writes it, but for the timings (the
    /// points' own, and in place of the total the sum of the shards' wall times).
    pub fn json(&self) -> &str {
        &self.json
    }

    /// Points of the sweep.
    pub fn points(&self) -> usize {
        self.points
    }

    /// Points every method solved.
    pub fn converged(&self) -> usize {
        self.all_solved
    }

    /// Points refused before any work (no stationary density), as
    /// [`SweepResult::refused`](crate::sweep::SweepResult::refused) counts them in one run.
    pub fn refused(&self) -> usize {
        self.refused
    }

    /// Points each method solved, with the method's name, in the sweep's order.
    pub fn solved_by(&self) -> impl Iterator<Item = (&str, usize)> {
        self.methods
            .iter()
            .map(String::as_str)
            .zip(self.solved.iter().copied())
    }

    /// Shards merged.
    pub fn shards(&self) -> u64 {
        self.shards
    }

    /// Writes `sweep.csv` and `sweep.json` into `out` (atomically each). The merge draws no
    /// figures: they are drawn by a single run.
    ///
    /// # Errors
    /// [`ReportError`] when a file cannot be written.
    pub fn write(&self, out: &OutputDir) -> Result<Vec<PathBuf>, ReportError> {
        Ok(vec![
            out.write_atomic("sweep.csv", self.csv.as_bytes())?,
            out.write_atomic("sweep.json", self.json.as_bytes())?,
        ])
    }
}

/// Merges the shards of one sweep (in any order), each named by its file in errors: every
/// shard checked on its own, then against the first (model, methods and settings, points,
/// split, thresholds), then the split checked complete and without duplicates.
///
/// # Errors
/// [`SweepShardError`] naming the file.
pub fn merge_sweep_shards<S: AsRef<str>>(
    shards: &[(S, SweepShard)],
) -> Result<MergedSweep, SweepShardError> {
    let (first_name, first) = shards.first().ok_or(SweepShardError::NoShards)?;
    let first_name = first_name.as_ref();
    for (name, s) in shards {
        s.check(name.as_ref())?;
    }
    let count = first.shard.count;
    let mut slots: Vec<Option<(&str, &SweepShard)>> = vec![None; count as usize];
    for (name, s) in shards {
        let name = name.as_ref();
        let mismatch = |what| SweepShardError::Mismatch {
            file: name.to_string(),
            first: first_name.to_string(),
            what,
        };
        let (a, b) = (&s.identity, &first.identity);
        let checks = [
            (a.model == b.model, ShardDifference::Model),
            (a.methods == b.methods, ShardDifference::Methods),
            (a.degree == b.degree, ShardDifference::Degree),
            (a.cells == b.cells, ShardDifference::Cells),
            (a.parameters == b.parameters, ShardDifference::Parameters),
            (a.fixed == b.fixed, ShardDifference::FixedParameters),
            (a.points == b.points, ShardDifference::Points),
            (s.shard.count == count, ShardDifference::Split),
            (
                s.csv_header == first.csv_header && s.json_head == first.json_head,
                ShardDifference::Columns,
            ),
        ];
        if let Some((_, what)) = checks.iter().find(|(same, _)| !same) {
            return Err(mismatch(*what));
        }
        let slot = &mut slots[s.shard.index as usize];
        if let Some((other, _)) = slot {
            return Err(SweepShardError::Duplicated {
                file: name.to_string(),
                other: other.to_string(),
                index: s.shard.index + 1,
                count,
            });
        }
        *slot = Some((name, s));
    }
    let missing: Vec<u64> = (0..count)
        .filter(|&k| slots[k as usize].is_none())
        .map(|k| k + 1)
        .collect();
    if !missing.is_empty() {
        return Err(SweepShardError::Missing {
            missing,
            count,
            first: first_name.to_string(),
        });
    }
    let parts: Vec<&SweepShard> = slots.into_iter().flatten().map(|(_, s)| s).collect();
    Ok(join(first, &parts))
}

/// The whole sweep's text from its complete, checked, ordered shards.
fn join(first: &SweepShard, parts: &[&SweepShard]) -> MergedSweep {
    let points: Vec<&ShardPoint> = parts.iter().flat_map(|s| &s.points).collect();
    let mut csv = first.csv_header.clone();
    csv.push('\n');
    for p in &points {
        csv.push_str(&p.csv);
        csv.push('\n');
    }
    let wall_ms: f64 = parts.iter().map(|s| s.wall_ms).sum();
    let entries: Vec<String> = points.iter().map(|p| indent(&p.json, "    ")).collect();
    // The merged file's provenance is the merge's (its command and time), with the model
    // the shards were run on and the threads they ran with.
    let provenance = Provenance::merged(parts.iter().map(|s| s.provenance.as_ref()));
    let json = splice(&first.json_head, &entries.join(",\n"), wall_ms, &provenance);
    let methods: Vec<String> = first
        .identity
        .methods
        .split(',')
        .map(String::from)
        .collect();
    let solved = (0..methods.len())
        .map(|m| points.iter().filter(|p| p.solved[m]).count())
        .collect();
    MergedSweep {
        csv,
        json,
        methods,
        points: points.len(),
        solved,
        all_solved: points
            .iter()
            .filter(|p| p.solved.iter().all(|&s| s))
            .count(),
        refused: points.iter().filter(|p| p.refused()).count(),
        shards: first.shard.count,
    }
}

/// `text` with every line indented by `by`.
fn indent(text: &str, by: &str) -> String {
    text.lines()
        .map(|l| format!("{by}{l}"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The pretty `sweep.json` of a head without provenance, points and time, with the merge's
/// provenance, the points' entries and the time put in: the text serde_json writes for the
/// whole result.
fn splice(head: &str, entries: &str, wall_ms: f64, provenance: &Provenance) -> String {
    let tail = "  \"points\": [],\n  \"wall_ms\": 0.0\n}";
    let body = head
        .strip_suffix(tail)
        .and_then(|b| b.strip_prefix("{\n"))
        .expect("a sweep's JSON is an object ending with its points and its time");
    let provenance = serde_json::to_string_pretty(provenance).expect("provenance serialises");
    let points = if entries.is_empty() {
        "[]".to_string()
    } else {
        format!("[\n{entries}\n  ]")
    };
    let time = serde_json::to_string(&wall_ms).expect("a time serialises");
    format!(
        "{{\n  \"provenance\": {},\n{body}  \"points\": {points},\n  \"wall_ms\": {time}\n}}\n",
        indent(&provenance, "  ").trim_start()
    )
}
