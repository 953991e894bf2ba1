//! Where records start again after damage, for `recover` ([`super`]): the next offset
//! where a record that verifies begins, found by trying each byte in turn. A chunk qualifies
//! when its fields fit its record and its records decompress to the size and CRC it declares;
//! another record when its opcode is one MCAP defines, its fields fit its length, and another
//! record's header (or the end of the data section, when that end is known sound) follows it.
//!
//! Decompression is metered by a [`Budget`], as the strict reader meters it
//! ([`scan::decompressed_limit`]), so that no file, however many chunk headers it fakes, makes
//! `recover` decompress more than a bounded multiple of its size.

use crate::record::scan::{self, op, Chunk, Parsed, Record, Undecompressable};
use std::borrow::Cow;

/// Why a chunk record does not open; its words are the damage `recover` reports there.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum Unopened {
    /// The record is not a chunk.
    #[error("not a chunk")]
    NotAChunk,
    /// Its fields do not read (the strict reader's words).
    #[error("{0}")]
    Fields(String),
    /// Its length is not that of its fields.
    #[error("chunk record: its length, {length} bytes, is not that of its fields")]
    Length {
        /// The record's length, bytes.
        length: usize,
    },
    /// Its records would take the decompressed bytes beyond the [`Budget`].
    #[error(
        "chunk record: declares {declared} bytes of records, which takes the file's chunks \
         beyond 1024 times the file's size: refused undecompressed"
    )]
    OverBudget {
        /// The records' size it declares, bytes.
        declared: u64,
    },
    /// Its records do not decompress.
    #[error("chunk record: {0}")]
    Decompress(#[from] Undecompressable),
}

/// Decompressed bytes still allowed.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Budget {
    left: u64,
}

impl Budget {
    /// [`scan::decompressed_limit`] of a file of `file_len` bytes.
    pub(crate) fn new(file_len: u64) -> Self {
        Self {
            left: scan::decompressed_limit(file_len),
        }
    }

    fn take(&mut self, n: u64) -> Result<(), Unopened> {
        if n > self.left {
            return Err(Unopened::OverBudget { declared: n });
        }
        self.left -= n;
        Ok(())
    }
}

/// The record whose opcode is at `at`, when its header is inside `end` and its length fits
/// before `end`; any opcode.
pub(crate) fn record_at(bytes: &[u8], at: u64, end: u64) -> Option<Record<'_>> {
    let end = usize::try_from(end).ok()?.min(bytes.len());
    let at = usize::try_from(at).ok()?;
    let body = at.checked_add(9).filter(|b| *b <= end)?;
    let mut length = [0u8; 8];
    length.copy_from_slice(&bytes[at + 1..body]);
    let length = usize::try_from(u64::from_le_bytes(length)).ok()?;
    let stop = body.checked_add(length).filter(|s| *s <= end)?;
    Some(Record {
        offset: at as u64,
        opcode: bytes[at],
        body: &bytes[body..stop],
    })
}

/// The end of `record`'s bytes, as an offset.
pub(crate) fn end_of(record: &Record<'_>) -> u64 {
    record.offset + 9 + record.body.len() as u64
}

/// A chunk record read and verified: the chunk, and its records decompressed. `Err` says why not
/// (its fields, a length that says more than its fields, the decompression, the CRC).
pub(crate) fn open_chunk<'a>(
    record: &Record<'a>,
    budget: &mut Budget,
) -> Result<(Chunk<'a>, Cow<'a, [u8]>), Unopened> {
    let chunk = match scan::parse(record) {
        Ok(Parsed::Chunk(chunk)) => chunk,
        Ok(_) => return Err(Unopened::NotAChunk),
        Err(d) => return Err(Unopened::Fields(d.what)),
    };
    if !scan::chunk_fills_its_record(&chunk, record) {
        return Err(Unopened::Length {
            length: record.body.len(),
        });
    }
    budget.take(chunk.uncompressed_size)?;
    let records = scan::decompress(&chunk)?;
    Ok((chunk, records))
}

/// Whether a record that verifies starts at `at`, inside `end` (`end_is_sound`: a record may end
/// exactly there).
fn starts_record(bytes: &[u8], at: u64, end: u64, end_is_sound: bool, budget: &mut Budget) -> bool {
    if !(op::FOOTER..=op::DATA_END).contains(&bytes[at as usize]) {
        return false;
    }
    let Some(record) = record_at(bytes, at, end) else {
        return false;
    };
    let next = end_of(&record);
    let followed = || {
        (next == end && end_is_sound)
            || record_at(bytes, next, end)
                .is_some_and(|r| (op::FOOTER..=op::DATA_END).contains(&r.opcode))
    };
    if record.opcode == op::CHUNK {
        return match open_chunk(&record, budget) {
            Ok((chunk, _)) => chunk.uncompressed_crc != 0 || followed(),
            Err(_) => false,
        };
    }
    followed() && scan::parse(&record).is_ok()
}

/// The first offset after `from` and before `until` where a record that verifies starts, else
/// `until`.
pub(crate) fn next_record(
    bytes: &[u8],
    from: u64,
    until: u64,
    until_is_sound: bool,
    budget: &mut Budget,
) -> u64 {
    (from + 1..until)
        .find(|at| starts_record(bytes, *at, until, until_is_sound, budget))
        .unwrap_or(until)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget refuses what it cannot pay, as a structured error whose words are the damage
    /// `recover` has always reported there.
    #[test]
    fn a_chunk_beyond_the_budget_is_refused_naming_its_size() {
        let mut budget = Budget::new(0);
        let all = scan::decompressed_limit(0);
        assert!(budget.take(all).is_ok());
        let refused = budget.take(1).expect_err("the budget is spent");
        assert!(matches!(refused, Unopened::OverBudget { declared: 1 }));
        assert_eq!(
            refused.to_string(),
            "chunk record: declares 1 bytes of records, which takes the file's chunks beyond \
             1024 times the file's size: refused undecompressed"
        );
    }
}
