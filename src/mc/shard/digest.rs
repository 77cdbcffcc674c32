//! The digests a shard file carries, so that `merge` can tell an honest file from an edited
//! one. The invariants of [`check`](crate::mc::shard::check) catch edits that contradict
//! themselves; counts moved between neighbouring bins, an extreme moved inside its range or
//! a different barrier map do not, and would merge into silently wrong numbers.
//!
//! Each digest is a 128-bit FNV-1a hash of the canonical serialisation of what it covers
//! (the JSON serde writes for it, whose floats are shortest round-trip strings, so it is the
//! same before and after a trip through a file): one of the run's settings, one of the
//! shard's statistics, both with the shard's index and count. Not a defence against an
//! adversary, who could recompute it, but any accidental or manual edit changes it.

use serde::{Deserialize, Serialize};

use crate::mc::error::DigestPart;
use crate::mc::record::batch::BatchSummary;
use crate::mc::settings::RunSettings;
use crate::mc::shard::index::Shard;

/// FNV-1a's 128-bit offset basis and prime.
const OFFSET: u128 = 0x6c62_272e_07bb_0142_62b8_2175_6295_c58d;
const PRIME: u128 = 0x0000_0000_0100_0000_0000_0000_0000_013b;

/// The two digests of a shard file, as 32 hexadecimal digits each.
///
/// ```
/// use fpsolve::mc::{McConfig, Shard, Simulation};
/// use fpsolve::model::{load_model, Override};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
/// let model = load_model(path.as_ref()).unwrap().bind(&[Override::number("c", 0.5)]).unwrap();
/// let config = McConfig { trajectories: 64, lanes: 16, samples: 20, ..McConfig::default() };
/// let part = Simulation::new(&model, &config).unwrap().run_shard(Shard::new(1, 2).unwrap()).unwrap();
/// let json = serde_json::to_value(&part).unwrap();
/// assert_eq!(json["digest"]["settings"].as_str().unwrap().len(), 32);
/// assert_eq!(json["digest"]["content"].as_str().unwrap().len(), 32);
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardDigest {
    /// Digest of the run's settings (every field, barriers included) and the shard's index
    /// and count.
    pub settings: String,
    /// Digest of the shard's index and count and its statistics: every batch's counts,
    /// sums, extremes, impacts and blow-ups, fine and coarse.
    pub content: String,
}

impl ShardDigest {
    /// The digests of a shard's parts.
    pub(in crate::mc) fn of(
        settings: &RunSettings,
        shard: Shard,
        batches: &[BatchSummary],
        coarse: &[BatchSummary],
    ) -> Result<ShardDigest, serde_json::Error> {
        Ok(ShardDigest {
            settings: hex(&("fpsolve shard settings v1", shard, settings))?,
            content: hex(&("fpsolve shard content v1", shard, batches, coarse))?,
        })
    }

    /// The first digest that disagrees with `actual` (the digests of the parts as read).
    pub(in crate::mc) fn mismatch(&self, actual: &ShardDigest) -> Option<DigestPart> {
        if self.settings != actual.settings {
            Some(DigestPart::Settings)
        } else if self.content != actual.content {
            Some(DigestPart::Content)
        } else {
            None
        }
    }
}

/// FNV-1a over the bytes written to it.
struct Fnv1a(u128);

impl std::io::Write for Fnv1a {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        for &b in bytes {
            self.0 = (self.0 ^ b as u128).wrapping_mul(PRIME);
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The digest of a value's canonical serialisation, as hexadecimal.
fn hex<T: Serialize>(value: &T) -> Result<String, serde_json::Error> {
    let mut hash = Fnv1a(OFFSET);
    serde_json::to_writer(&mut hash, value)?;
    Ok(format!("{:032x}", hash.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published FNV-1a 128 test vectors: the empty string and "a".
    #[test]
    fn fnv1a_128_matches_the_reference_values() {
        use std::io::Write;
        let digest = |s: &str| {
            let mut h = Fnv1a(OFFSET);
            h.write_all(s.as_bytes()).unwrap();
            h.0
        };
        assert_eq!(digest(""), 0x6c62272e07bb014262b821756295c58d);
        assert_eq!(digest("a"), 0xd228cb696f1a8caf78912b704e4a8964);
    }

    #[test]
    fn every_byte_changes_the_digest() {
        let a = hex(&("x", 1.0f64)).unwrap();
        assert_ne!(a, hex(&("x", 1.0000000000000002f64)).unwrap());
        assert_ne!(a, hex(&("y", 1.0f64)).unwrap());
        assert_eq!(a, hex(&("x", 1.0f64)).unwrap());
    }
}
