//! How `recover` walks the data section: each record the summary's indexes place is read at its
//! place, the others one after the other; at a record that does not read, the walk goes on at
//! the next record the index places or that [`super::resync`] finds, and leaves the damaged
//! place to [`super::lost`].

use super::copy::Copy;
use super::lost::Pending;
use super::report::Recovered;
use super::resync::{self, Budget};
use super::summary::Summary;
use crate::record::bag::chunk_records;
use crate::record::scan::{self, op, Damage, Parsed, Record, Table, MAGIC};
use std::collections::BTreeMap;
use std::io::{Seek, Write};

/// What the walk did with one record.
enum Step {
    /// Went on to this offset.
    Next(u64),
    /// The data section ended (a data end record, or a footer).
    Stop,
    /// The record here is damaged: `opcode` is what it is believed to be, and `skip`, when
    /// known, where the next record starts.
    Damaged {
        damage: Damage,
        opcode: u8,
        skip: Option<u64>,
    },
}

/// The walk of the data section.
pub(super) struct Walk<'a> {
    bytes: &'a [u8],
    /// Where the data section ends: where a verified summary starts, else where the end magic
    /// (or the file) ends.
    end: u64,
    /// Whether a record may end exactly at `end` (a verified summary starts there).
    end_is_sound: bool,
    /// The records a verified summary's indexes place, by offset: opcode and whole length.
    known: BTreeMap<u64, (u8, u64)>,
    /// Decompression allowed to the walk and to the search for the next record.
    budget: Budget,
    resync_budget: Budget,
    /// A dropped place that the index records after it may count.
    lost: Pending,
    /// Chunks copied whole.
    pub(super) chunks_kept: u64,
}

impl<'a> Walk<'a> {
    pub(super) fn new(bytes: &'a [u8], summary: Option<&Summary<'_>>) -> Self {
        let complete = bytes.len() >= 2 * MAGIC.len() && bytes.ends_with(MAGIC);
        let end = match summary {
            Some(s) => s.start,
            None if complete => (bytes.len() - MAGIC.len()) as u64,
            None => bytes.len() as u64,
        };
        let mut walk = Self {
            bytes,
            end,
            end_is_sound: summary.is_some(),
            known: BTreeMap::new(),
            budget: Budget::new(bytes.len() as u64),
            resync_budget: Budget::new(bytes.len() as u64),
            lost: Pending::default(),
            chunks_kept: 0,
        };
        if let Some(s) = summary {
            for c in &s.chunks {
                walk.place(op::CHUNK, c.chunk_start, c.chunk_length, s.shift, |at| {
                    chunk_size_at(bytes, at) == Some(c.uncompressed_size)
                });
            }
            for (opcode, offset, length) in &s.records {
                walk.place(*opcode, *offset, *length, s.shift, |_| false);
            }
        }
        walk
    }

    /// Places a record an index gives at `offset` (or, when the summary was moved, at `offset +
    /// shift`): where a record of that opcode and length starts; else where `alike` (a chunk of
    /// the indexed size whose length field is damaged); else, when nothing moved, at `offset`
    /// (a record damaged there). Not placed when it does not fit the data section.
    fn place(
        &mut self,
        opcode: u8,
        offset: u64,
        length: u64,
        shift: i64,
        alike: impl Fn(u64) -> bool,
    ) {
        let fits = |at: &u64| length >= 9 && at.checked_add(length).is_some_and(|e| e <= self.end);
        let mut places = vec![offset];
        if shift != 0 {
            places.extend(offset.checked_add_signed(shift));
        }
        places.retain(fits);
        let exact = |at: &u64| {
            resync::record_at(self.bytes, *at, self.end)
                .is_some_and(|r| r.opcode == opcode && 9 + r.body.len() as u64 == length)
        };
        let at = places
            .iter()
            .find(|at| exact(at))
            .or_else(|| places.iter().find(|at| alike(**at)))
            .or_else(|| places.first().filter(|_| shift == 0));
        if let Some(at) = at {
            self.known.insert(*at, (opcode, length));
        }
    }

    /// Walks from `at` to the end of the data section.
    pub(super) fn run<W: Write + Seek>(
        &mut self,
        mut at: u64,
        copy: &mut Copy<W>,
        table: &mut Table,
        got: &mut Recovered,
    ) -> Result<(), mcap::McapError> {
        let mut stopped = false;
        while at < self.end {
            match self.step(at, copy, table, got)? {
                Step::Next(next) => at = next,
                Step::Stop => {
                    stopped = true;
                    break;
                }
                Step::Damaged {
                    damage,
                    opcode,
                    skip,
                } => {
                    let next = skip.unwrap_or_else(|| self.resync(at));
                    self.lost
                        .damaged(damage, opcode, next, next == self.end, got);
                    at = next;
                }
            }
        }
        self.lost.flush(got);
        if !stopped && !self.end_is_sound && at == self.bytes.len() as u64 {
            got.notes.push(format!(
                "the file ends at byte {at} where a record ends, without its summary (a recorder \
                 that was killed or is still writing): nothing in it was cut"
            ));
        }
        Ok(())
    }

    /// The next offset after `at` where a record starts: the next one an index places, or an
    /// earlier one found by trying each byte.
    fn resync(&mut self, at: u64) -> u64 {
        let (until, sound) = match self.known.range(at + 1..).next() {
            Some((next, _)) => (*next, true),
            None => (self.end, self.end_is_sound),
        };
        resync::next_record(self.bytes, at, until, sound, &mut self.resync_budget)
    }

    /// Reads the record at `at` and copies what it holds.
    fn step<W: Write + Seek>(
        &mut self,
        at: u64,
        copy: &mut Copy<W>,
        table: &mut Table,
        got: &mut Recovered,
    ) -> Result<Step, mcap::McapError> {
        let known = self.known.get(&at).copied();
        let until = match self.known.range(at + 1..).next() {
            Some((next, _)) => *next,
            None => self.end,
        };
        let Some(record) = resync::record_at(self.bytes, at, until) else {
            return Ok(self.unreadable(at, until, known));
        };
        let next = resync::end_of(&record);
        if let Some((opcode, length)) = known {
            if record.opcode != opcode || next - at != length {
                return Ok(Step::Damaged {
                    damage: Damage {
                        offset: at,
                        what: format!(
                            "a record of opcode 0x{:02x} and {} bytes, where the summary's index \
                             places one of opcode 0x{opcode:02x} and {length} bytes",
                            record.opcode,
                            next - at
                        ),
                        cut_short: false,
                    },
                    opcode,
                    skip: Some(at + length),
                });
            }
        } else if next < until
            && resync::record_at(self.bytes, next, until).is_none()
            && (until < self.end || self.end_is_sound || self.end < self.bytes.len() as u64)
        {
            // What follows is no record (where the file is cut short, a record that runs past
            // its end proves nothing): this record's length is likely damaged.
            return Ok(Step::Damaged {
                damage: Damage {
                    offset: at,
                    what: format!(
                        "a record (opcode 0x{:02x}) of {} bytes is followed by no record",
                        record.opcode,
                        next - at
                    ),
                    cut_short: false,
                },
                opcode: record.opcode,
                skip: None,
            });
        }
        // Where the record ends is believed when the index says so, or when a record follows
        // there and the record's length is not that of a chunk whose fields say otherwise;
        // else the walk looks for the next record after its start.
        let framed = known.is_some()
            || ((next == until || resync::record_at(self.bytes, next, until).is_some())
                && !matches!(scan::parse(&record), Ok(Parsed::Chunk(c))
                    if !scan::chunk_fills_its_record(&c, &record)));
        self.read(&record, copy, table, got).map(|step| match step {
            Step::Damaged { damage, opcode, .. } => Step::Damaged {
                damage,
                opcode,
                skip: framed.then_some(next),
            },
            other => other,
        })
    }

    /// The record at `at` runs past `until` (or has no room for its header).
    fn unreadable(&self, at: u64, until: u64, known: Option<(u8, u64)>) -> Step {
        let bytes = self.bytes;
        let opcode = bytes[at as usize];
        let left = bytes.len() as u64 - at;
        let claims = (left >= 9).then(|| {
            let mut length = [0u8; 8];
            length.copy_from_slice(&bytes[at as usize + 1..at as usize + 9]);
            u64::from_le_bytes(length)
        });
        let cut_short = !self.end_is_sound
            && until == self.end
            && self.end == bytes.len() as u64
            && claims.is_none_or(|n| n > left - 9);
        let what = match claims {
            None => format!("a record starts here but only {left} of its 9 header bytes follow"),
            Some(n) => format!(
                "a record (opcode 0x{opcode:02x}) claims {n} bytes, but only {} follow{}",
                until.saturating_sub(at + 9).min(left - 9),
                if until < self.end {
                    " before the next record the summary's index places"
                } else {
                    ""
                }
            ),
        };
        Step::Damaged {
            damage: Damage {
                offset: at,
                what,
                cut_short,
            },
            opcode: known.map_or(opcode, |(o, _)| o),
            skip: known.map(|(_, length)| at + length),
        }
    }

    /// Copies what the sound record `record` holds.
    fn read<W: Write + Seek>(
        &mut self,
        record: &Record<'a>,
        copy: &mut Copy<W>,
        table: &mut Table,
        got: &mut Recovered,
    ) -> Result<Step, mcap::McapError> {
        let next = resync::end_of(record);
        let damaged = |what: String| Step::Damaged {
            damage: Damage {
                offset: record.offset,
                what,
                cut_short: false,
            },
            opcode: record.opcode,
            skip: None,
        };
        if record.opcode == op::CHUNK {
            let (_, records) = match resync::open_chunk(record, &mut self.budget) {
                Ok(opened) => opened,
                Err(why) => return Ok(damaged(why.to_string())),
            };
            // Nothing of a chunk is used unless every record in it reads.
            let list: Vec<(u64, Parsed<'_>)> =
                match chunk_records(&records, record.offset).collect() {
                    Ok(list) => list,
                    Err(d) => return Ok(damaged(d.what)),
                };
            self.lost.flush(got);
            for (offset, inner) in list {
                copy.record(inner, offset, table, got)?;
            }
            self.chunks_kept += 1;
            return Ok(Step::Next(next));
        }
        let parsed = match scan::parse(record) {
            Ok(parsed) => parsed,
            Err(d) => return Ok(damaged(d.what)),
        };
        match parsed {
            Parsed::MessageIndex { channel_id, count } => {
                self.lost.index(channel_id, count, table, got);
                return Ok(Step::Next(next));
            }
            Parsed::DataEnd { data_crc } => {
                self.lost.flush(got);
                self.check_data_crc(record.offset, data_crc, got);
                return Ok(if self.end_is_sound {
                    Step::Next(next)
                } else {
                    Step::Stop
                });
            }
            Parsed::Footer { .. } => return Ok(Step::Stop),
            Parsed::Other if !(op::HEADER..=op::DATA_END).contains(&record.opcode) => {
                self.lost.unknown(record.offset, record.opcode, got);
                return Ok(Step::Next(next));
            }
            _ => {}
        }
        self.lost.flush(got);
        copy.record(parsed, record.offset, table, got)?;
        Ok(Step::Next(next))
    }

    /// The data section's CRC, when it has one.
    fn check_data_crc(&self, data_end: u64, stored: u32, got: &mut Recovered) {
        if stored == 0 {
            return;
        }
        let computed = crc32fast::hash(&self.bytes[..data_end as usize]);
        if computed != stored {
            got.damaged(|| {
                format!(
                    "at byte {data_end}: the data section's CRC does not match (stored \
                     0x{stored:08x}, computed 0x{computed:08x})"
                )
            });
        }
    }
}

/// The uncompressed size a chunk record at `at` declares, read where it lies whatever its
/// length field says.
fn chunk_size_at(bytes: &[u8], at: u64) -> Option<u64> {
    let at = usize::try_from(at).ok()?;
    let field = bytes.get(at.checked_add(9 + 16)?..at.checked_add(9 + 24)?)?;
    let mut size = [0u8; 8];
    size.copy_from_slice(field);
    (bytes[at] == op::CHUNK).then_some(u64::from_le_bytes(size))
}
