//! Shards: disjoint ranges of statistics batches, run anywhere, merged bit for bit.
//!
//! A run is a fixed sequence of statistics batches (each a fixed set of trajectories with
//! their own random streams), and every statistic is reduced over batches in index order.
//! A shard runs a contiguous range of batches and keeps each batch's summary, so merging
//! the shards replays exactly the reduction a single run performs. Floating-point values in
//! shard files are written as their shortest round-trip decimal strings, so a shard that has
//! been through JSON merges to the same bits as one that has not.

use serde::{Deserialize, Serialize};

use super::ensemble::{finalize_run, BatchSummary, McResult, RunSettings};
use super::McError;

/// Which part of a run to compute: the `index`-th of `count` disjoint shards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 0-based shard index (`0 ≤ index < count`).
    pub index: u64,
    /// Number of shards the run is split into.
    pub count: u64,
}

impl Shard {
    /// The `index`-th of `count` shards.
    ///
    /// ```
    /// assert!(fpsolve::mc::Shard::new(2, 3).is_ok());
    /// assert!(fpsolve::mc::Shard::new(3, 3).is_err());
    /// ```
    pub fn new(index: u64, count: u64) -> Result<Shard, McError> {
        if count == 0 || index >= count {
            return Err(McError::BadSetting {
                name: "shard",
                reason: format!("shard {index} of {count}: need 0 ≤ index < count"),
            });
        }
        Ok(Shard { index, count })
    }

    /// The whole run as one shard.
    pub fn whole() -> Shard {
        Shard { index: 0, count: 1 }
    }

    /// The statistics batches of this shard, out of `batches`.
    pub fn batch_range(&self, batches: u64) -> std::ops::Range<u64> {
        let cut = |k: u64| ((k as u128 * batches as u128) / self.count as u128) as u64;
        cut(self.index)..cut(self.index + 1)
    }
}

/// What one shard computed: the run's settings (to check that shards belong together) and
/// one summary per statistics batch. Serialise it with serde (JSON) and merge with
/// [`merge_shards`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardOutput {
    /// The resolved settings of the whole run.
    pub settings: RunSettings,
    /// Which shard this is.
    pub shard: Shard,
    pub(crate) batches: Vec<BatchSummary>,
}

impl ShardOutput {
    /// Number of statistics batches this shard holds.
    pub fn batches(&self) -> usize {
        self.batches.len()
    }
}

/// Merges the outputs of all shards of one run (in any order) into the run's result, which
/// is bit for bit the result of running it unsharded.
///
/// Shards of different runs, missing or duplicated shards are errors.
pub fn merge_shards(shards: &[ShardOutput]) -> Result<McResult, McError> {
    let mismatch = |reason: String| McError::ShardMismatch { reason };
    let first = shards
        .first()
        .ok_or_else(|| mismatch("no shards given".into()))?;
    let count = first.shard.count;
    let mut slots: Vec<Option<&ShardOutput>> = vec![None; count as usize];
    for s in shards {
        if s.settings != first.settings {
            return Err(mismatch(format!(
                "shard {} was run with different settings than shard {}",
                s.shard.index, first.shard.index
            )));
        }
        if s.shard.count != count || s.shard.index >= count {
            return Err(mismatch(format!(
                "shard {} of {} does not belong to a split into {count}",
                s.shard.index, s.shard.count
            )));
        }
        let slot = &mut slots[s.shard.index as usize];
        if slot.is_some() {
            return Err(mismatch(format!("shard {} given twice", s.shard.index)));
        }
        *slot = Some(s);
    }
    let mut batches = Vec::new();
    for (k, slot) in slots.iter().enumerate() {
        let s = slot.ok_or_else(|| mismatch(format!("shard {k} of {count} is missing")))?;
        let want = s.shard.batch_range(first.settings.batches);
        let got: Vec<u64> = s.batches.iter().map(|b| b.index).collect();
        if got != want.clone().collect::<Vec<_>>() {
            return Err(mismatch(format!(
                "shard {k} should hold batches {want:?} but holds {} others",
                got.len()
            )));
        }
        batches.extend(s.batches.iter());
    }
    finalize_run(&first.settings, &batches)
}

/// Serde helpers writing `f64` as its shortest round-trip decimal string (`"0.1"`, `"inf"`),
/// which Rust parses back to the same bits.
pub(crate) mod exact {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(crate) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{v:?}"))
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }

    /// The same for `[f64; 4]`.
    pub(crate) mod array4 {
        use serde::{Deserialize, Deserializer, Serializer};

        pub(crate) fn serialize<S: Serializer>(v: &[f64; 4], s: S) -> Result<S::Ok, S::Error> {
            let t: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
            serde::Serialize::serialize(&t, s)
        }

        pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 4], D::Error> {
            let t = <[String; 4]>::deserialize(d)?;
            let mut out = [0.0; 4];
            for (o, x) in out.iter_mut().zip(&t) {
                *o = x.parse().map_err(serde::de::Error::custom)?;
            }
            Ok(out)
        }
    }

    /// The same for `[f64; 2]`.
    pub(crate) mod array2 {
        use serde::{Deserialize, Deserializer, Serializer};

        pub(crate) fn serialize<S: Serializer>(v: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
            let t: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
            serde::Serialize::serialize(&t, s)
        }

        pub(crate) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
            let t = <[String; 2]>::deserialize(d)?;
            Ok([
                t[0].parse().map_err(serde::de::Error::custom)?,
                t[1].parse().map_err(serde::de::Error::custom)?,
            ])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn exact_floats_round_trip_through_json() {
        #[derive(Serialize, Deserialize)]
        struct W(#[serde(with = "exact")] f64);
        for v in [0.1, 1.0 / 3.0, 1e-300, f64::INFINITY, -0.0, 5e-324] {
            let j = serde_json::to_string(&W(v)).unwrap();
            let back: W = serde_json::from_str(&j).unwrap();
            assert_eq!(back.0.to_bits(), v.to_bits(), "{j}");
        }
    }
}
