//! Where records start again after damage, for `recover` ([`super::recover`]): the next offset
//! where a record that verifies begins, found by trying each byte in turn. A chunk qualifies
//! when its fields fit its record and its records decompress to the size and CRC it declares;
//! another record when its opcode is one MCAP defines, its fields fit its length, and another
//! record's header (or the end of the data section, when that end is known sound) follows it.
//!
//! Decompression is metered by a [`Budget`], as the strict reader meters it
//! ([`scan::decompressed_limit`]), so that no file, however many chunk headers it fakes, makes
//! `recover` decompress more than a bounded multiple of its size.

use super::scan::{self, op, Chunk, Parsed, Record};
use std::borrow::Cow;

/// Decompressed bytes still allowed.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    left: u64,
}

impl Budget {
    /// [`scan::decompressed_limit`] of a file of `file_len` bytes.
    pub fn new(file_len: u64) -> Self {
        Self {
            left: scan::decompressed_limit(file_len),
        }
    }

    fn take(&mut self, n: u64) -> Result<(), String> {
        if n > self.left {
            return Err(format!(
                "declares {n} bytes of records, which takes the file's chunks beyond 1024 times \
                 the file's size: refused undecompressed"
            ));
        }
        self.left -= n;
        Ok(())
    }
}

/// The record whose opcode is at `at`, when its header is inside `end` and its length fits
/// before `end`; any opcode.
pub fn record_at(bytes: &[u8], at: u64, end: u64) -> Option<Record<'_>> {
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
pub fn end_of(record: &Record<'_>) -> u64 {
    record.offset + 9 + record.body.len() as u64
}

/// A chunk record read and verified: the chunk, and its records decompressed. `Err` says why not
/// (its fields, a length that says more than its fields, the decompression, the CRC).
pub fn open_chunk<'a>(
    record: &Record<'a>,
    budget: &mut Budget,
) -> Result<(Chunk<'a>, Cow<'a, [u8]>), String> {
    let chunk = match scan::parse(record) {
        Ok(Parsed::Chunk(chunk)) => chunk,
        Ok(_) => return Err("not a chunk".into()),
        Err(d) => return Err(d.what),
    };
    if !scan::chunk_fills_its_record(&chunk, record) {
        return Err(format!(
            "chunk record: its length, {} bytes, is not that of its fields",
            record.body.len()
        ));
    }
    budget
        .take(chunk.uncompressed_size)
        .map_err(|why| format!("chunk record: {why}"))?;
    let records = scan::decompress(&chunk).map_err(|why| format!("chunk record: {why}"))?;
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
pub fn next_record(
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
