//! Shards: disjoint ranges of statistics batches, run anywhere, merged bit for bit.
//!
//! A run is a fixed sequence of statistics batches (each a fixed set of trajectories with
//! their own random streams), and every statistic is reduced over batches in index order.
//! A shard runs a contiguous range of batches and keeps each batch's summary, so merging
//! the shards replays exactly the reduction a single run performs. Floating-point values in
//! shard files are written as their shortest round-trip decimal strings, so a shard that has
//! been through JSON merges to the same bits as one that has not.
//!
//! Every shard carries a [`ShardDigest`] of its settings and of its statistics, both with its
//! index and count, which merge recomputes: an edited or damaged file, or one renamed to
//! another index, is refused by name.

use serde::{Deserialize, Serialize};

use crate::mc::error::McError;
use crate::mc::error::ShardDefect;
use crate::mc::record::batch::BatchSummary;
use crate::mc::settings::RunSettings;
use crate::mc::shard::check::check_batch;
use crate::mc::shard::digest::ShardDigest;
use crate::mc::shard::index::Shard;
use crate::mc::stats::result::{finalize_run, McResult};

/// What one shard computed: the run's settings (to check that shards belong together), one
/// summary per statistics batch, and the coarse (2·dt) summaries of its batches that are in
/// the bias estimate's range. Serialise it with serde (JSON) and merge with [`merge_shards`]
/// or [`merge_named`], which check it with [`ShardOutput::validate`] first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardOutput {
    /// Where the part came from (the `provenance` block of a JSON result: version, schema,
    /// command, time, the threads it ran with, the model's name, file and text; absent in
    /// files of an older fpsolve). Not a number of the run: the digests do not cover it, and
    /// a merge reports it ([`Provenance::merged`](crate::model::Provenance::merged)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<serde_json::Value>,
    /// The resolved settings of the whole run.
    pub settings: RunSettings,
    /// Which shard this is.
    pub shard: Shard,
    pub(crate) batches: Vec<BatchSummary>,
    pub(crate) coarse: Vec<BatchSummary>,
    /// The digests it was written with (absent in files of an older fpsolve, which are
    /// refused).
    #[serde(default)]
    pub(crate) digest: Option<ShardDigest>,
}

impl ShardOutput {
    /// A shard's parts with their digests.
    pub(in crate::mc) fn sealed(
        settings: RunSettings,
        shard: Shard,
        batches: Vec<BatchSummary>,
        coarse: Vec<BatchSummary>,
    ) -> Result<ShardOutput, McError> {
        let digest = ShardDigest::of(&settings, shard, &batches, &coarse).map_err(|e| {
            McError::BadSetting {
                name: "shard",
                reason: format!("its statistics cannot be serialised: {e}"),
            }
        })?;
        Ok(ShardOutput {
            provenance: None,
            settings,
            shard,
            batches,
            coarse,
            digest: Some(digest),
        })
    }

    /// Number of statistics batches this shard holds.
    pub fn batches(&self) -> usize {
        self.batches.len()
    }

    /// Checks every invariant of the shard on its own: valid settings, an index that fits
    /// the split, exactly the statistics batches (and coarse batches) its index implies,
    /// and within each batch counts that add up to the recorded samples, bins matching the
    /// grid, extremes and power sums consistent with each other; then its digests, which any
    /// edit of its settings or statistics (or index) breaks. Errors name the shard as
    /// `shard K of N`, counted from 1 like the file names.
    ///
    /// ```
    /// use fpsolve::mc::{McConfig, Shard, Simulation};
    /// use fpsolve::model::{load_model, Override};
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let file = load_model(path.as_ref()).unwrap();
    /// let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
    /// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
    /// let sim = Simulation::new(&model, &config).unwrap();
    /// let mut part = sim.run_shard(Shard::new(0, 2).unwrap()).unwrap();
    /// assert!(part.validate().is_ok());
    /// part.shard.index = 5;
    /// assert!(part.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), McError> {
        let label = format!(
            "shard {} of {}",
            self.shard.index.saturating_add(1),
            self.shard.count
        );
        self.defect().map_err(|defect| McError::BadShard {
            shard: label,
            defect,
        })
    }

    fn defect(&self) -> Result<(), ShardDefect> {
        let st = &self.settings;
        st.check()?;
        let (index, count) = (self.shard.index, self.shard.count);
        if count == 0 || index >= count || count > st.batches {
            return Err(ShardDefect::Index {
                index: index.saturating_add(1),
                count,
            });
        }
        let range = self.shard.batch_range(st.batches);
        let found: Vec<u64> = self.batches.iter().map(|b| b.index).collect();
        if !found.iter().copied().eq(range.clone()) {
            return Err(ShardDefect::Batches {
                expected: range,
                found: found.into_iter().take(8).collect(),
            });
        }
        let coarse_range = range.start.min(st.bias_batches)..range.end.min(st.bias_batches);
        let found: Vec<u64> = self.coarse.iter().map(|b| b.index).collect();
        if !found.iter().copied().eq(coarse_range.clone()) {
            return Err(ShardDefect::Batches {
                expected: coarse_range,
                found: found.into_iter().take(8).collect(),
            });
        }
        for b in &self.batches {
            check_batch(st, b)?;
        }
        let coarse = st.coarse();
        for b in &self.coarse {
            check_batch(&coarse, b)?;
        }
        // The invariants above name what contradicts itself; the digests catch the edits
        // that do not (a count moved to the next bin, an extreme moved inside its range, a
        // different barrier map), and an index edited together with its batches.
        let written = self.digest.as_ref().ok_or(ShardDefect::NoDigest)?;
        let actual =
            ShardDigest::of(st, self.shard, &self.batches, &self.coarse).map_err(|_| {
                ShardDefect::Digest {
                    part: crate::mc::error::DigestPart::Content,
                }
            })?;
        match written.mismatch(&actual) {
            Some(part) => Err(ShardDefect::Digest { part }),
            None => Ok(()),
        }
    }

    /// Whether `name` (a path) names another shard than this one: `shard_K_of_N.json` with
    /// K/N not its index and count. Other names say nothing (the contents decide).
    fn renamed(&self, name: &str) -> Result<(), ShardDefect> {
        let file = std::path::Path::new(name)
            .file_name()
            .and_then(|f| f.to_str())
            .unwrap_or("");
        let Some(numbers) = file
            .strip_prefix("shard_")
            .and_then(|f| f.strip_suffix(".json"))
        else {
            return Ok(());
        };
        let Some((k, n)) = numbers.split_once("_of_") else {
            return Ok(());
        };
        let (Ok(k), Ok(n)) = (k.parse::<u64>(), n.parse::<u64>()) else {
            return Ok(());
        };
        let (index, count) = (self.shard.index.saturating_add(1), self.shard.count);
        if (k, n) == (index, count) {
            return Ok(());
        }
        Err(ShardDefect::Renamed {
            named_index: k,
            named_count: n,
            index,
            count,
        })
    }
}

/// Merges the outputs of all shards of one run (in any order) into the run's result, which
/// is bit for bit the result of running it unsharded. Shards are named `shard K of N` in
/// errors; [`merge_named`] names them by file.
///
/// Every shard is validated first ([`ShardOutput::validate`]); shards of different runs,
/// missing or duplicated shards are errors, never a panic.
pub fn merge_shards(shards: &[ShardOutput]) -> Result<McResult, McError> {
    let named: Vec<(String, &ShardOutput)> = shards
        .iter()
        .map(|s| {
            (
                format!(
                    "shard {} of {}",
                    s.shard.index.saturating_add(1),
                    s.shard.count
                ),
                s,
            )
        })
        .collect();
    merge_impl(&named)
}

/// [`merge_shards`] with a name per shard (its file name), used in every error message. A
/// name of the form `shard_K_of_N.json` must agree with the shard's contents (which its
/// digests cover): a file renamed to another index is refused.
///
/// ```
/// use fpsolve::mc::{merge_named, McConfig, Shard, Simulation};
/// use fpsolve::model::{load_model, Override};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
/// let file = load_model(path.as_ref()).unwrap();
/// let model = file.bind(&[Override::number("c", 0.5)]).unwrap();
/// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
/// let sim = Simulation::new(&model, &config).unwrap();
/// let a = sim.run_shard(Shard::new(0, 2).unwrap()).unwrap();
/// let err = merge_named(&[("shard_1_of_2.json", a)]).unwrap_err();
/// assert!(err.to_string().contains("shard_1_of_2.json is part of a split into 2"));
/// ```
pub fn merge_named<S: AsRef<str>>(shards: &[(S, ShardOutput)]) -> Result<McResult, McError> {
    let named: Vec<(String, &ShardOutput)> = shards
        .iter()
        .map(|(n, s)| (n.as_ref().to_string(), s))
        .collect();
    for (name, s) in &named {
        s.renamed(name).map_err(|defect| McError::BadShard {
            shard: name.clone(),
            defect,
        })?;
    }
    merge_impl(&named)
}

fn merge_impl(shards: &[(String, &ShardOutput)]) -> Result<McResult, McError> {
    let mismatch = |reason: String| McError::ShardMismatch { reason };
    for (name, s) in shards {
        s.defect().map_err(|defect| McError::BadShard {
            shard: name.clone(),
            defect,
        })?;
    }
    let (first_name, first) = shards
        .first()
        .ok_or_else(|| mismatch("no shards given".into()))?;
    let count = first.shard.count;
    if count > shards.len() as u64 {
        return Err(mismatch(format!(
            "{first_name} is part of a split into {count}, but only {} shards are given",
            shards.len()
        )));
    }
    let mut slots: Vec<Option<(&String, &ShardOutput)>> = vec![None; count as usize];
    for (name, s) in shards {
        if s.settings != first.settings {
            return Err(mismatch(format!(
                "{name} was run with different settings (model, parameters, seed, grids, …) \
                 than {first_name}"
            )));
        }
        if s.shard.count != count {
            return Err(mismatch(format!(
                "{name} is part of a split into {}, {first_name} of a split into {count}",
                s.shard.count
            )));
        }
        let slot = &mut slots[s.shard.index as usize];
        if let Some((other, _)) = slot {
            return Err(mismatch(format!(
                "{name} and {other} are both shard {} of {count}",
                s.shard.index + 1
            )));
        }
        *slot = Some((name, s));
    }
    let mut batches = Vec::new();
    let mut coarse = Vec::new();
    for (k, slot) in slots.iter().enumerate() {
        let (_, s) =
            slot.ok_or_else(|| mismatch(format!("shard {} of {count} is missing", k + 1)))?;
        batches.extend(s.batches.iter());
        coarse.extend(s.coarse.iter());
    }
    finalize_run(&first.settings, &batches, &coarse)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::mc::{reference, McConfig, Simulation};
    use serde_json::{json, Value};

    /// Each part says where it came from (the model, the threads of the pool it ran on),
    /// first in its file; a merge reports the parts' model and threads, and parts without a
    /// provenance (files of an older fpsolve) merge to the same numbers.
    #[test]
    fn parts_carry_their_provenance_and_the_merge_reports_it() {
        let model = reference::linear_oscillator(0.5, 1.0, 1.0)
            .bind(&[])
            .unwrap();
        let config = McConfig {
            trajectories: 64,
            lanes: 16,
            samples: 20,
            ..McConfig::default()
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let parts: Vec<ShardOutput> = (0..2)
            .map(|k| one.install(|| sim.run_shard(Shard::new(k, 2).unwrap()).unwrap()))
            .collect();
        for part in &parts {
            let p = part.provenance.as_ref().unwrap();
            assert_eq!(p["threads"], 1, "{p}");
            assert_eq!(p["model"]["name"], "linear", "{p}");
            assert_eq!(p["schema_version"], crate::report::SCHEMA_VERSION);
            let text = serde_json::to_string_pretty(part).unwrap();
            assert!(
                text.starts_with("{\n  \"provenance\": {"),
                "{}",
                &text[..80]
            );
        }
        let merged = crate::model::Provenance::merged(parts.iter().map(|p| p.provenance.as_ref()));
        assert_eq!(merged.threads, 1);
        assert_eq!(merged.model.unwrap().name, "linear");
        let old: Vec<ShardOutput> = parts
            .iter()
            .cloned()
            .map(|mut p| {
                p.provenance = None;
                p
            })
            .collect();
        assert_eq!(merge_shards(&old).unwrap(), merge_shards(&parts).unwrap());
        assert_eq!(merge_shards(&parts).unwrap(), sim.run().unwrap());
        let text = serde_json::to_string(&old[0]).unwrap();
        assert!(!text.contains("provenance"));
        let back: ShardOutput = serde_json::from_str(&text).unwrap();
        assert_eq!(back, old[0]);
    }

    /// The two shards of a small real run, as JSON values (as they arrive from files).
    fn two_shards() -> (McResult, Vec<Value>) {
        two_shards_seeded(McConfig::default().seed)
    }

    /// [`two_shards`] of the run seeded with `seed`.
    fn two_shards_seeded(seed: u64) -> (McResult, Vec<Value>) {
        let model = reference::linear_oscillator(0.5, 1.0, 1.0)
            .bind(&[])
            .unwrap();
        let config = McConfig {
            trajectories: 64,
            lanes: 16,
            samples: 20,
            seed,
            ..McConfig::default()
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let parts = (0..2)
            .map(|k| {
                serde_json::to_value(sim.run_shard(Shard::new(k, 2).unwrap()).unwrap()).unwrap()
            })
            .collect();
        (sim.run().unwrap(), parts)
    }

    fn merge_values(parts: &[Value]) -> Result<McResult, McError> {
        let named: Vec<(String, ShardOutput)> = parts
            .iter()
            .enumerate()
            .map(|(k, v)| {
                (
                    format!("dir/shard_{}_of_2.json", k + 1),
                    serde_json::from_value(v.clone()).unwrap(),
                )
            })
            .collect();
        merge_named(&named)
    }

    /// A run with a wall, a speed histogram and crossing levels, split into three shards
    /// sent through JSON files, merges to the single run: the walls' statistics and the
    /// crossing rates (with their biases from the 2·dt run) equal, bit for bit.
    #[test]
    fn impact_and_crossing_statistics_merge_to_the_whole_run() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/models/grid_impact_linear.sde"
        );
        let model = crate::model::load_model(path.as_ref())
            .unwrap()
            .bind(&[crate::model::Override::number("r", 0.8)])
            .unwrap();
        let config = McConfig {
            trajectories: 96,
            lanes: 16,
            samples: 40,
            seed: 5,
            bias_fraction: 1.0,
            levels: vec![("y".into(), vec![-0.2, 0.5, 1.5])],
            impact_speeds: Some(crate::mc::Grid::new(-0.25, 5.25, 11).unwrap()),
            ..McConfig::default()
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let whole = sim.run().unwrap();
        let walls = &whole.impacts.as_ref().unwrap().walls;
        assert!(walls[0].count > 0 && walls[0].speeds.is_some());
        assert!(whole.crossings[0].rate.iter().all(|r| r.value > 0.0));
        assert!(whole.crossings[0].time_step_bias.is_some());
        let parts: Vec<Value> = (0..3)
            .map(|k| {
                serde_json::to_value(sim.run_shard(Shard::new(k, 3).unwrap()).unwrap()).unwrap()
            })
            .collect();
        let named: Vec<(String, ShardOutput)> = parts
            .iter()
            .enumerate()
            .map(|(k, v)| {
                (
                    format!("shard_{k}"),
                    serde_json::from_value(v.clone()).unwrap(),
                )
            })
            .collect();
        assert_eq!(merge_named(&named).unwrap(), whole);
        // A shard whose walls' counts do not add up is refused, not merged.
        let mut bad = parts.clone();
        bad[1]["batches"][0]["walls"][0]["count"] = json!(0);
        assert!(merge_values_n(&bad).is_err());
        let mut bad = parts;
        bad[2]["batches"][0]["crossings"][0]["up"] = json!([1, 2]);
        assert!(merge_values_n(&bad).is_err());
    }

    fn merge_values_n(parts: &[Value]) -> Result<McResult, McError> {
        let named: Vec<(String, ShardOutput)> = parts
            .iter()
            .enumerate()
            .map(|(k, v)| {
                (
                    format!("shard_{k}"),
                    serde_json::from_value(v.clone()).unwrap(),
                )
            })
            .collect();
        merge_named(&named)
    }

    #[test]
    fn valid_shards_merge_to_the_whole_run() {
        let (whole, parts) = two_shards();
        assert_eq!(merge_values(&parts).unwrap(), whole);
    }

    #[test]
    fn corrupt_shards_are_errors_naming_the_file() {
        let (_, parts) = two_shards();
        type Edit = fn(&mut Value);
        let cases: [(&str, Edit); 10] = [
            ("one bin short", |v| {
                v["batches"][0]["quantities"][0]["counts"]
                    .as_array_mut()
                    .unwrap()
                    .pop();
            }),
            ("an extra bin", |v| {
                v["batches"][1]["quantities"][1]["counts"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!(0));
            }),
            ("an empty quantity list", |v| {
                v["settings"]["quantities"] = json!([]);
            }),
            ("a batch without quantities", |v| {
                v["batches"][0]["quantities"] = json!([]);
            }),
            ("a count of 1e12", |v| {
                v["batches"][0]["quantities"][0]["counts"][3] = json!(1_000_000_000_000u64);
            }),
            ("recorded: 0", |v| {
                v["batches"][0]["recorded"] = json!(0);
            }),
            ("min above max", |v| {
                let q = &mut v["batches"][0]["quantities"][1];
                let (lo, hi) = (q["min"].clone(), q["max"].clone());
                q["min"] = hi;
                q["max"] = lo;
            }),
            ("a non-finite power sum", |v| {
                v["batches"][1]["quantities"][0]["sums"][1] = json!("NaN");
            }),
            ("an impossible power sum", |v| {
                v["batches"][1]["quantities"][0]["sums"][3] = json!("1e30");
            }),
            ("a shard index beyond the split", |v| {
                v["shard"]["index"] = json!(7);
            }),
        ];
        for (what, edit) in cases {
            let mut bad = parts.clone();
            edit(&mut bad[1]);
            let err = merge_values(&bad).unwrap_err();
            eprintln!("{what}: {err}");
            assert!(
                matches!(&err, McError::BadShard { shard, .. } if shard == "dir/shard_2_of_2.json"),
                "{what}: {err}"
            );
        }
    }

    /// Paths to every leaf of a JSON value.
    fn leaves(v: &Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    path.push(k.clone());
                    leaves(x, path, out);
                    path.pop();
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    path.push(i.to_string());
                    leaves(x, path, out);
                    path.pop();
                }
            }
            _ => out.push(path.clone()),
        }
    }

    fn leaf<'a>(v: &'a mut Value, path: &[String]) -> &'a mut Value {
        path.iter().fold(v, |v, k| match v {
            Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
            other => &mut other[k.as_str()],
        })
    }

    /// Every leaf of a real shard file replaced by each of a set of hostile values: the merge
    /// answers (mostly with an error) and never panics.
    #[test]
    fn no_single_field_edit_makes_merge_panic() {
        let model = reference::linear_oscillator(0.5, 1.0, 1.0)
            .bind(&[])
            .unwrap();
        let grid = crate::mc::Grid::new(-4.0, 4.0, 3).unwrap();
        let config = McConfig {
            trajectories: 16,
            lanes: 4,
            samples: 8,
            grids: vec![("z".into(), grid), ("v".into(), grid)],
            ..McConfig::default()
        };
        let sim = Simulation::new(&model, &config).unwrap();
        let parts: Vec<Value> = (0..2)
            .map(|k| {
                serde_json::to_value(sim.run_shard(Shard::new(k, 2).unwrap()).unwrap()).unwrap()
            })
            .collect();
        let mut paths = Vec::new();
        leaves(&parts[1], &mut Vec::new(), &mut paths);
        // Where the part came from is no number of the run: any value merges (the merge
        // reports it), so its edits are not counted.
        assert!(paths.iter().any(|p| p[0] == "provenance"));
        paths.retain(|p| p[0] != "provenance");
        let hostile = [
            json!(0),
            json!(1),
            json!(3),
            json!(1_000_000_000_000u64),
            json!(u64::MAX),
            json!("NaN"),
            json!("inf"),
            json!("-inf"),
            json!("-1e300"),
            json!("0.0"),
            json!(true),
            json!(false),
        ];
        let (mut tried, mut accepted) = (0, 0);
        for path in &paths {
            for h in &hostile {
                let mut bad = parts.clone();
                let target = leaf(&mut bad[1], path);
                let same = match (&*target, h) {
                    (Value::String(a), Value::String(b)) => {
                        a.parse::<f64>().ok().map(f64::to_bits)
                            == b.parse::<f64>().ok().map(f64::to_bits)
                    }
                    // 1 for 1.0 is the same file to serde.
                    (Value::Number(a), Value::Number(b)) => {
                        a.as_f64().map(f64::to_bits) == b.as_f64().map(f64::to_bits)
                    }
                    (a, b) => a == b,
                };
                if same {
                    continue;
                }
                *target = h.clone();
                let named: Result<Vec<(String, ShardOutput)>, _> = bad
                    .iter()
                    .enumerate()
                    .map(|(k, v)| serde_json::from_value(v.clone()).map(|s| (format!("f{k}"), s)))
                    .collect();
                let Ok(named) = named else { continue };
                tried += 1;
                let outcome = std::panic::catch_unwind(|| merge_named(&named));
                match outcome {
                    Ok(r) => {
                        if r.is_ok() {
                            eprintln!("merged: {path:?} = {h}");
                        }
                        accepted += r.is_ok() as usize;
                    }
                    Err(_) => panic!("merge panicked with {path:?} = {h}"),
                }
            }
        }
        eprintln!(
            "{} leaves, {tried} edited files parsed, {accepted} merged",
            paths.len()
        );
        assert!(tried > 500);
        // Every edit of a value is caught (before the digests, some merged into other numbers).
        assert_eq!(accepted, 0);
    }

    /// Edits that keep a shard consistent with itself, which only the digests catch, and a
    /// shard named as another: each refused, naming the file.
    #[test]
    fn consistent_edits_and_renamed_shards_are_refused() {
        let (_, parts) = two_shards();
        type Edit = fn(&mut Value);
        let cases: [(&str, Edit, &str); 4] = [
            (
                "a count moved to the next bin",
                |v| {
                    let counts = v["batches"][0]["quantities"][0]["counts"]
                        .as_array_mut()
                        .unwrap();
                    let j = (0..counts.len() - 1)
                        .find(|&j| {
                            counts[j].as_u64().unwrap() > 1 && counts[j + 1].as_u64().unwrap() > 0
                        })
                        .unwrap();
                    counts[j] = json!(counts[j].as_u64().unwrap() - 1);
                    counts[j + 1] = json!(counts[j + 1].as_u64().unwrap() + 1);
                },
                "statistics do not match",
            ),
            (
                "an extreme moved inside its range",
                |v| {
                    let q = &mut v["batches"][0]["quantities"][0];
                    let max: f64 = q["max"].as_str().unwrap().parse().unwrap();
                    q["max"] = json!(format!("{:?}", max * (1.0 - 1e-12)));
                },
                "statistics do not match",
            ),
            (
                "the seed",
                |v| {
                    v["settings"]["seed"] = json!(99);
                },
                "run settings do not match",
            ),
            (
                "no digest",
                |v| {
                    v.as_object_mut().unwrap().remove("digest");
                },
                "carries no digest",
            ),
        ];
        for (what, edit, says) in cases {
            let mut bad = parts.clone();
            edit(&mut bad[1]);
            let err = merge_values(&bad).unwrap_err();
            assert!(
                matches!(&err, McError::BadShard { shard, .. } if shard == "dir/shard_2_of_2.json"),
                "{what}: {err}"
            );
            assert!(err.to_string().contains(says), "{what}: {err}");
        }
        let swapped = [
            (
                "dir/shard_1_of_2.json",
                serde_json::from_value::<ShardOutput>(parts[1].clone()).unwrap(),
            ),
            (
                "dir/shard_2_of_2.json",
                serde_json::from_value::<ShardOutput>(parts[0].clone()).unwrap(),
            ),
        ];
        let err = merge_named(&swapped).unwrap_err();
        assert!(
            matches!(&err, McError::BadShard { shard, defect: ShardDefect::Renamed { .. } } if shard == "dir/shard_1_of_2.json"),
            "{err}"
        );
    }

    #[test]
    fn duplicated_missing_and_foreign_shards_are_errors() {
        let (_, parts) = two_shards();
        let copy = |v: &Value| serde_json::from_value::<ShardOutput>(v.clone()).unwrap();
        let twice = [
            ("a/shard_1_of_2.json", copy(&parts[0])),
            ("b/shard_1_of_2.json", copy(&parts[0])),
        ];
        let err = merge_named(&twice).unwrap_err();
        assert!(err.to_string().contains("both shard 1 of 2"), "{err}");
        let err = merge_values(&parts[..1]).unwrap_err();
        assert!(err.to_string().contains("split into 2"), "{err}");
        let mut foreign = parts.clone();
        foreign[1] = two_shards_seeded(99).1.swap_remove(1);
        let err = merge_values(&foreign).unwrap_err();
        assert!(
            err.to_string()
                .contains("dir/shard_2_of_2.json was run with different settings"),
            "{err}"
        );
    }

    #[test]
    fn shard_ranges_partition_the_batches() {
        for count in 1..7 {
            let mut next = 0;
            for index in 0..count {
                let r = Shard::new(index, count).unwrap().batch_range(20);
                assert_eq!(r.start, next);
                next = r.end;
            }
            assert_eq!(next, 20);
        }
    }
}
