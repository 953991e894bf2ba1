//! The summary of a file, read from its end for `recover` ([`super`]): the footer just
//! before the end magic says where the summary starts and carries the CRC of the summary and of
//! its own fields. A summary whose CRC verifies is believed: its schemas, channels and statistics,
//! and the chunk, metadata and attachment indexes that say where each of those records lies, so
//! that damage in one record cannot hide the ones after it.
//!
//! Bytes inserted into or removed from the data section move the summary away from where the
//! footer says it starts. The summary offset records (fixed 26-byte records just before the
//! footer) are found by stepping back from the footer, and their distance from where the footer
//! puts them is the shift; a summary found there whose CRC verifies is used, and each index
//! entry is looked for at its recorded offset and at the shifted one.

use crate::record::scan::{self, op, Channel, ChunkIndex, Damage, Parsed, Record, Schema, MAGIC};
use std::collections::BTreeMap;

/// Bytes of a footer record: opcode, length, summary_start, summary_offset_start, summary_crc.
const FOOTER_LEN: usize = 1 + 8 + 8 + 8 + 4;
/// Bytes of a summary offset record: opcode, length, group_opcode, group_start, group_length.
const SUMMARY_OFFSET_LEN: usize = 1 + 8 + 1 + 8 + 8;

/// A summary whose CRC verified.
#[derive(Debug, Default)]
pub(crate) struct Summary<'a> {
    /// Where it starts in this file: the data section ends here.
    pub(crate) start: u64,
    /// How far it lies from where the footer says (bytes inserted, or removed when negative,
    /// before it).
    pub(crate) shift: i64,
    /// Its schemas.
    pub(crate) schemas: Vec<Schema<'a>>,
    /// Its channels.
    pub(crate) channels: Vec<Channel>,
    /// Messages in the file, and per channel.
    pub(crate) statistics: Option<(u64, BTreeMap<u16, u64>)>,
    /// Where each chunk lies, as recorded (before the shift).
    pub(crate) chunks: Vec<ChunkIndex>,
    /// Offset and length of each metadata and attachment record, as recorded, with its opcode.
    pub(crate) records: Vec<(u8, u64, u64)>,
}

/// Why a file's summary is not used: `None` when it has none to use (no footer, which a cut
/// file lacks; no summary; a summary without a CRC), else the damage.
pub(crate) type Unused = Option<Damage>;

/// The summary of `bytes`, when its CRC verifies.
pub(crate) fn read(bytes: &[u8]) -> Result<Summary<'_>, Unused> {
    let len = bytes.len();
    if len < 2 * MAGIC.len() + FOOTER_LEN || !bytes.ends_with(MAGIC) {
        return Err(None);
    }
    let footer = len - MAGIC.len() - FOOTER_LEN;
    let field = |at: usize| -> u64 {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[at..at + 8]);
        u64::from_le_bytes(b)
    };
    if bytes[footer] != op::FOOTER || field(footer + 1) != (FOOTER_LEN - 9) as u64 {
        return Err(Some(Damage {
            offset: footer as u64,
            what: "no footer record before the end magic".into(),
            cut_short: false,
        }));
    }
    let summary_start = field(footer + 9);
    let offsets_start = field(footer + 17);
    let mut crc = [0u8; 4];
    crc.copy_from_slice(&bytes[footer + 25..footer + 29]);
    let crc = u32::from_le_bytes(crc);
    if summary_start == 0 || crc == 0 {
        return Err(None);
    }
    let covered = footer + 25;
    let verifies = |start: u64| {
        usize::try_from(start)
            .ok()
            .filter(|s| (MAGIC.len()..=footer).contains(s))
            .is_some_and(|s| crc32fast::hash(&bytes[s..covered]) == crc)
    };
    let shift = offsets_shift(bytes, footer, offsets_start);
    let found = [0, shift].into_iter().find_map(|shift| {
        let start = summary_start.checked_add_signed(shift)?;
        verifies(start).then_some((start, shift))
    });
    let Some((start, shift)) = found else {
        return Err(Some(Damage {
            offset: summary_start,
            what: format!(
                "the summary's CRC does not match (stored 0x{crc:08x}) where the footer puts it, \
                 nor where its summary offset records put it"
            ),
            cut_short: false,
        }));
    };
    let mut summary = Summary {
        start,
        shift,
        ..Summary::default()
    };
    let body = &bytes[start as usize..footer];
    for record in scan::Records::new(body, start, false) {
        // The CRC verified: damage here is a writer's mistake, and the summary is not used.
        take(&mut summary, &record.map_err(Some)?).map_err(Some)?;
    }
    Ok(summary)
}

/// Adds one summary record to `summary`.
fn take<'a>(summary: &mut Summary<'a>, record: &Record<'a>) -> Result<(), Damage> {
    match record.opcode {
        op::CHUNK_INDEX => summary.chunks.push(scan::parse_chunk_index(record)?),
        op::METADATA_INDEX | op::ATTACHMENT_INDEX => {
            let (offset, length) = scan::parse_record_index(record)?;
            let opcode = if record.opcode == op::METADATA_INDEX {
                op::METADATA
            } else {
                op::ATTACHMENT
            };
            summary.records.push((opcode, offset, length));
        }
        _ => match scan::parse(record)? {
            Parsed::Schema(s) => summary.schemas.push(s),
            Parsed::Channel(c) => summary.channels.push(c),
            Parsed::Statistics {
                message_count,
                per_channel,
            } => summary.statistics = Some((message_count, per_channel)),
            _ => {}
        },
    }
    Ok(())
}

/// How far the summary offset records that end at `footer` lie from `recorded`, where the
/// footer says they start; 0 when there are none or they lie there.
fn offsets_shift(bytes: &[u8], footer: usize, recorded: u64) -> i64 {
    let mut start = footer;
    while start >= SUMMARY_OFFSET_LEN {
        let at = start - SUMMARY_OFFSET_LEN;
        let mut len = [0u8; 8];
        len.copy_from_slice(&bytes[at + 1..at + 9]);
        if bytes[at] != op::SUMMARY_OFFSET
            || u64::from_le_bytes(len) != (SUMMARY_OFFSET_LEN - 9) as u64
        {
            break;
        }
        start = at;
    }
    if recorded == 0 || start == footer {
        return 0;
    }
    i64::try_from(start as u64)
        .ok()
        .zip(i64::try_from(recorded).ok())
        .map_or(0, |(found, recorded)| found - recorded)
}
