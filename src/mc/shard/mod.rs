//! Runs split into shards of statistics batches, each run anywhere and merged bit for bit
//! into the unsplit result. A shard file is checked (digests, settings, batch ranges)
//! before anything is merged.

pub(crate) mod check;
pub(crate) mod digest;
pub(crate) mod index;
pub(crate) mod part;
