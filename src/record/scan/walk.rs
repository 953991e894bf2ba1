//! A whole file walked from its magic to its end: the header, the data section (each chunk's
//! declared size counted against [`decompressed_limit`]), the summary, the footer and the end
//! magic, with the data section's and the summary's CRCs checked.

use super::chunk::decompressed_limit;
use super::fields::{parse, Channel, Parsed, Schema};
use super::frame::{op, Damage, Record, Records, MAGIC};
use std::collections::BTreeMap;

/// A record of the data section, parsed, with its offset.
#[derive(Debug, Clone)]
pub(crate) struct Item<'a> {
    /// Offset of its opcode in the file.
    pub(crate) offset: u64,
    /// Its opcode.
    pub(crate) opcode: u8,
    /// Its fields, or why they could not be read (the record's length was sound, so the walk
    /// went on past it).
    pub(crate) parsed: Result<Parsed<'a>, Damage>,
}

/// A file walked from its magic to its end.
#[derive(Debug, Default)]
pub(crate) struct Scan<'a> {
    /// The records of the data section, in file order (the header excluded).
    pub(crate) items: Vec<Item<'a>>,
    /// Schemas and channels of the summary section, when the summary's CRC verified (or it has
    /// none).
    pub(crate) summary_schemas: Vec<Schema<'a>>,
    /// See `summary_schemas`.
    pub(crate) summary_channels: Vec<Channel>,
    /// Messages per channel according to the summary's statistics, when the summary verified.
    pub(crate) statistics: Option<(u64, BTreeMap<u16, u64>)>,
    /// Whether the summary's CRC was there and verified.
    pub(crate) summary_verified: bool,
    /// Whether the data section's CRC was there and verified.
    pub(crate) data_verified: bool,
    /// Offset of the data end record, when the walk reached it.
    pub(crate) data_end: Option<u64>,
    /// Where the walk stopped before a sound end (the length of a record ran past the end of
    /// the file, or the end is malformed).
    pub(crate) stopped: Option<Damage>,
    /// Damage of the data section as a whole: its CRC does not match, it has no end record.
    pub(crate) damage: Vec<Damage>,
    /// Damage of the summary section (which `recover` rebuilds, so nothing is lost by it).
    pub(crate) summary_damage: Vec<Damage>,
}

impl Scan<'_> {
    /// The first damage the walk met in a record, or where it stopped.
    pub(crate) fn record_damage(&self) -> Option<&Damage> {
        let in_items = self.items.iter().filter_map(|i| i.parsed.as_ref().err());
        in_items.chain(self.stopped.iter()).min_by_key(|d| d.offset)
    }

    /// The first damage of the data section or the summary as a whole (their CRCs).
    pub(crate) fn section_damage(&self) -> Option<&Damage> {
        self.damage.iter().chain(&self.summary_damage).next()
    }
}

/// Walks a whole file. `Err` when it is not an MCAP file at all (empty, too short, no magic, no
/// header record); damage after the header is reported in the [`Scan`].
pub(crate) fn scan(bytes: &[u8]) -> Result<Scan<'_>, Damage> {
    let (_, mut records) = open(bytes)?;
    let mut out = Scan::default();
    walk(bytes, &mut records, &mut out);
    Ok(out)
}

/// The profile of a file's header record and the offset of the record after it. `Err` when it
/// is not an MCAP file at all (empty, too short, no magic, no header record).
pub(crate) fn header(bytes: &[u8]) -> Result<(String, u64), Damage> {
    let (profile, records) = open(bytes)?;
    Ok((profile, records.position()))
}

/// Checks the magic and reads the header: its profile, and the walk of the records after it.
fn open(bytes: &[u8]) -> Result<(String, Records<'_>), Damage> {
    if bytes.is_empty() {
        return Err(Damage::at(0, "the file is empty (0 bytes)"));
    }
    if !bytes.starts_with(MAGIC) {
        if bytes.len() < MAGIC.len() && MAGIC.starts_with(bytes) {
            return Err(Damage {
                offset: bytes.len() as u64,
                what: format!("only {} bytes of the MCAP magic", bytes.len()),
                cut_short: true,
            });
        }
        return Err(Damage::at(0, "no MCAP magic: not an MCAP file"));
    }
    let complete = bytes.len() >= 2 * MAGIC.len() && bytes.ends_with(MAGIC);
    let mut records = Records::new(&bytes[MAGIC.len()..], MAGIC.len() as u64, !complete);
    match records.next() {
        None => Err(Damage {
            offset: MAGIC.len() as u64,
            what: "the file holds only the MCAP magic, no records".into(),
            cut_short: true,
        }),
        Some(Err(d)) => Err(d),
        Some(Ok(r)) => match parse(&r) {
            Ok(Parsed::Header { profile }) => Ok((profile, records)),
            Ok(_) => Err(Damage::at(r.offset, "the first record is not a header")),
            Err(d) => Err(d),
        },
    }
}

/// The data section, then the summary, then the footer and the end magic.
fn walk<'a>(bytes: &'a [u8], records: &mut Records<'a>, out: &mut Scan<'a>) {
    let mut data_end: Option<(u64, u32)> = None;
    let mut summary = Vec::new();
    let mut declared = Declared::new(bytes.len() as u64);
    loop {
        let record = match records.next() {
            None => {
                out.stopped = Some(Damage {
                    offset: bytes.len() as u64,
                    what: "the file ends without its footer".into(),
                    cut_short: true,
                });
                return;
            }
            Some(Err(d)) => {
                out.stopped = Some(d);
                return;
            }
            Some(Ok(r)) => r,
        };
        let parsed = parse(&record);
        if record.opcode == op::FOOTER {
            finish(bytes, record, parsed, data_end, &summary, out);
            return;
        }
        if data_end.is_some() {
            summary.push(Item {
                offset: record.offset,
                opcode: record.opcode,
                parsed,
            });
            continue;
        }
        if let Ok(Parsed::DataEnd { data_crc }) = parsed {
            data_end = Some((record.offset, data_crc));
            out.data_end = Some(record.offset);
            continue;
        }
        out.items.push(Item {
            offset: record.offset,
            opcode: record.opcode,
            parsed: declared.admit(record.offset, parsed),
        });
    }
}

/// The decompressed bytes the chunks of the data section declare, against
/// [`decompressed_limit`].
struct Declared {
    total: u64,
    limit: u64,
}

impl Declared {
    fn new(file_len: u64) -> Self {
        Self {
            total: 0,
            limit: decompressed_limit(file_len),
        }
    }

    /// `parsed`, or damage for a chunk that would take the total beyond the limit (which then
    /// does not count: `recover` drops it and goes on).
    fn admit<'a>(
        &mut self,
        offset: u64,
        parsed: Result<Parsed<'a>, Damage>,
    ) -> Result<Parsed<'a>, Damage> {
        let Ok(Parsed::Chunk(chunk)) = &parsed else {
            return parsed;
        };
        let total = self.total.saturating_add(chunk.uncompressed_size);
        if total > self.limit {
            return Err(Damage::at(
                offset,
                format!(
                    "chunk record: declares {} bytes of records, which takes the file's chunks \
                     beyond {} bytes, 1024 times the file's size: refused undecompressed",
                    chunk.uncompressed_size, self.limit
                ),
            ));
        }
        self.total = total;
        parsed
    }
}

/// Checks the end of a file whose footer is `footer`: the end magic right after it, the data
/// section's CRC, the summary's CRC; keeps the summary's schemas, channels and statistics.
fn finish<'a>(
    bytes: &'a [u8],
    footer: Record<'a>,
    parsed: Result<Parsed<'a>, Damage>,
    data_end: Option<(u64, u32)>,
    summary: &[Item<'a>],
    out: &mut Scan<'a>,
) {
    let end = footer.offset as usize + 9 + footer.body.len();
    if bytes.len() - end != MAGIC.len() || !bytes.ends_with(MAGIC) {
        out.stopped = Some(Damage::at(
            end as u64,
            format!(
                "the footer is followed by {} bytes, not by the 8-byte end magic",
                bytes.len() - end
            ),
        ));
        return;
    }
    let (summary_start, summary_crc) = match parsed {
        Ok(Parsed::Footer {
            summary_start,
            summary_crc,
        }) => (summary_start, summary_crc),
        other => {
            out.stopped = Some(other.err().unwrap_or_else(|| {
                Damage::at(footer.offset, "the footer record does not read as one")
            }));
            return;
        }
    };
    check_data_section(bytes, footer.offset, data_end, out);
    if summary_start != 0 {
        check_summary(
            bytes,
            footer.offset,
            summary_start,
            summary_crc,
            summary,
            out,
        );
    }
}

/// Checks the data section's CRC (the bytes before the data end record at `data_end`).
fn check_data_section(bytes: &[u8], footer: u64, data_end: Option<(u64, u32)>, out: &mut Scan<'_>) {
    match data_end {
        None => out.damage.push(Damage::at(
            footer,
            "the footer comes without a data end record before it",
        )),
        Some((_, 0)) => {}
        Some((offset, stored)) => {
            let computed = crc32fast::hash(&bytes[..offset as usize]);
            if computed == stored {
                out.data_verified = true;
            } else {
                out.damage.push(Damage::at(
                    offset,
                    format!(
                        "the data section's CRC does not match (stored 0x{stored:08x}, \
                         computed 0x{computed:08x})"
                    ),
                ));
            }
        }
    }
}

/// Checks the summary that starts at `summary_start` against the footer at `footer`, and keeps
/// its schemas, channels and statistics.
fn check_summary<'a>(
    bytes: &'a [u8],
    footer: u64,
    summary_start: u64,
    summary_crc: u32,
    summary: &[Item<'a>],
    out: &mut Scan<'a>,
) {
    // The summary CRC covers the summary section and the footer up to its summary_crc field.
    let covered_end = footer as usize + 9 + 16;
    if summary_start > footer || summary.first().map(|i| i.offset) != Some(summary_start) {
        out.summary_damage.push(Damage::at(
            footer,
            format!("the footer's summary offset {summary_start} does not start a summary record"),
        ));
        return;
    }
    if summary_crc != 0 {
        let computed = crc32fast::hash(&bytes[summary_start as usize..covered_end]);
        if computed != summary_crc {
            out.summary_damage.push(Damage::at(
                summary_start,
                format!(
                    "the summary's CRC does not match (stored 0x{summary_crc:08x}, computed \
                     0x{computed:08x})"
                ),
            ));
            return;
        }
        out.summary_verified = true;
    }
    for item in summary {
        match &item.parsed {
            Ok(Parsed::Schema(s)) => out.summary_schemas.push(s.clone()),
            Ok(Parsed::Channel(c)) => out.summary_channels.push(c.clone()),
            Ok(Parsed::Statistics {
                message_count,
                per_channel,
            }) => out.statistics = Some((*message_count, per_channel.clone())),
            Ok(_) => {}
            Err(d) => out.summary_damage.push(d.clone()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::frame::record_bytes as record;
    use super::*;

    #[test]
    fn chunks_may_not_declare_more_than_the_limit_in_all() {
        let limit = decompressed_limit(0);
        assert_eq!(limit, 1 << 20);
        assert_eq!(decompressed_limit(1 << 20), 1 << 30);
        assert_eq!(decompressed_limit(u64::MAX), u64::MAX);
        let chunk = |size: u64| {
            let mut body = Vec::new();
            body.extend_from_slice(&[0; 16]);
            body.extend_from_slice(&size.to_le_bytes());
            body.extend_from_slice(&0u32.to_le_bytes());
            body.extend_from_slice(&0u32.to_le_bytes());
            body.extend_from_slice(&0u64.to_le_bytes());
            record(op::CHUNK, &body)
        };
        let mut bytes = MAGIC.to_vec();
        bytes.extend(record(op::HEADER, &[0; 8]));
        let first = bytes.len() as u64;
        bytes.extend(chunk(limit - 10));
        let second = bytes.len() as u64;
        bytes.extend(chunk(11));
        bytes.extend(chunk(10));
        bytes.extend(chunk(u64::MAX));
        let scan = scan(&bytes).expect("a header");
        let parsed: Vec<_> = scan.items.iter().map(|i| i.parsed.is_ok()).collect();
        // The second would take the total one byte beyond the limit; the third fits exactly.
        assert_eq!(parsed, [true, false, true, false]);
        assert_eq!(scan.items[0].offset, first);
        let d = scan.record_damage().expect("damage");
        assert_eq!(d.offset, second);
        assert!(
            d.what.contains("declares 11 bytes") && d.what.contains("1024 times"),
            "{d}"
        );
    }

    #[test]
    fn empty_short_and_foreign_files_are_not_mcap() {
        assert_eq!(scan(b"").expect_err("empty").offset, 0);
        let d = scan(&MAGIC[..5]).expect_err("short");
        assert!(d.cut_short && d.what.contains("5 bytes"), "{d}");
        let d = scan(MAGIC).expect_err("magic only");
        assert!(d.cut_short && d.what.contains("only the MCAP magic"), "{d}");
        let d = scan(b"random bytes, not a recording").expect_err("foreign");
        assert!(d.what.contains("not an MCAP file"), "{d}");
        let mut zeros = MAGIC.to_vec();
        zeros.extend_from_slice(&[0; 64]);
        let d = scan(&zeros).expect_err("zeros");
        assert!(d.what.contains("not a header"), "{d}");
    }
}
