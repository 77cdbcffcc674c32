//! A shard's place in a split run: the `index`-th of `count` disjoint ranges of statistics
//! batches, written `K/N` on the command line and in file names.

use serde::{Deserialize, Serialize};

use crate::mc::error::McError;

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

impl std::str::FromStr for Shard {
    type Err = McError;

    /// Parses `K/N`, K counted from 1 as in the file names `shard_K_of_N.json`.
    ///
    /// ```
    /// use fpsolve::mc::Shard;
    /// let s: Shard = "2/3".parse().unwrap();
    /// assert_eq!((s.index, s.count), (1, 3));
    /// assert!("0/3".parse::<Shard>().is_err());
    /// assert!("4/3".parse::<Shard>().is_err());
    /// ```
    fn from_str(text: &str) -> Result<Shard, McError> {
        let bad = || McError::BadSetting {
            name: "shard",
            reason: format!("`{text}`: expected K/N with 1 <= K <= N"),
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let k: u64 = k.trim().parse().map_err(|_| bad())?;
        let n: u64 = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || k > n {
            return Err(bad());
        }
        Shard::new(k - 1, n)
    }
}
