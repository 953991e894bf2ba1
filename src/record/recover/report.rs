//! What `recover` reports: what it saved, what it dropped, and why nothing could be saved.

use crate::record::bag::keep_example;
use crate::record::scan::Damage;
use std::collections::BTreeMap;

/// What `recover` saved and what it could not.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Recovered {
    /// The profile of the recording, e.g. `ros2`.
    pub profile: String,
    /// Messages kept, per topic.
    pub kept: BTreeMap<String, u64>,
    /// Messages dropped, per topic (`channel N` when no record names its topic).
    pub dropped: BTreeMap<String, u64>,
    /// Chunks kept.
    pub chunks_kept: u64,
    /// Chunks dropped: exactly, those of the summary's chunk index that were not kept, when the
    /// summary verified; else the damaged places that held a chunk's messages.
    pub chunks_dropped: u64,
    /// Damaged places whose number of messages nothing in the file tells.
    pub uncounted: u64,
    /// Metadata records kept.
    pub metadata: u64,
    /// What was damaged, with byte offsets (the first few).
    pub damage: Vec<String>,
    /// How many damaged places were found.
    pub damage_count: u64,
    /// Things that lost nothing, e.g. a summary that had to be rebuilt, or a file that ends
    /// where a record ends.
    pub notes: Vec<String>,
}

impl Recovered {
    /// Whether anything was dropped or could not be verified.
    pub fn lost_anything(&self) -> bool {
        !self.dropped.is_empty() || self.uncounted > 0 || self.damage_count > 0
    }

    /// Messages kept.
    pub fn kept_total(&self) -> u64 {
        self.kept.values().sum()
    }

    /// Messages dropped and counted.
    pub fn dropped_total(&self) -> u64 {
        self.dropped.values().sum()
    }

    pub(super) fn damaged(&mut self, what: impl FnOnce() -> String) {
        self.damage_count += 1;
        keep_example(&mut self.damage, what);
    }
}

/// Why nothing could be recovered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecoverError {
    /// The input is not an MCAP recording at all.
    #[error("{0}")]
    NotMcap(Damage),
    /// Writing the output failed.
    #[error("{0}")]
    Write(#[from] mcap::McapError),
}
