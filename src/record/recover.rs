//! `recover`: what a cut-short or damaged recording still holds, copied into a fresh, finished
//! MCAP file with the same profile, schemas, channels and metadata.
//!
//! Damage in one record never hides the records after it:
//! - When the summary's CRC verifies ([`super::summary`]), its chunk, metadata and attachment
//!   indexes say where each of those records lies and how long it is. Each is read at its place
//!   on its own: one whose opcode, length, fields, decompression or CRC do not check out is
//!   dropped, and the walk goes on at the next record the index places.
//! - Elsewhere (no usable summary, or bytes between indexed records), the walk goes record by
//!   record; at a record that does not read, it finds the next offset where a record that
//!   verifies starts ([`super::resync`]) and goes on from there.
//!
//! Only what verifies is kept: a chunk is kept whole or dropped whole, and so is a message whose
//! channel no record defines. What is dropped is counted per topic: exactly, from the summary's
//! statistics, when the summary verifies; else from the message index records that follow a
//! dropped chunk; where neither says, the loss is reported as uncounted. A data section CRC that
//! does not match is reported too. [`Recovered::lost_anything`] is what `recover`'s exit code
//! follows.

use super::bag::{chunk_records, keep_example, read_file, BagError};
use super::output::Replacement;
use super::resync::{self, Budget};
use super::scan::{self, op, Damage, Parsed, Record, Table, MAGIC};
use super::summary::{self, Summary};
use std::collections::{BTreeMap, HashMap};
use std::io::{Seek, Write};
use std::path::Path;

/// What [`recover`] saved and what it could not.
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

    fn damaged(&mut self, what: impl FnOnce() -> String) {
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

/// Recovers `broken` into `fixed`, which is written under a temporary name beside it and renamed
/// into place only when complete (a crash leaves whatever `fixed` was before). Refuses to write
/// over `broken` itself.
pub fn recover(broken: &Path, fixed: &Path) -> Result<Recovered, BagError> {
    let output = Replacement::create(fixed, &[broken])?;
    let bytes = read_file(broken)?;
    let (file, output) = output.into_parts();
    let (got, file) =
        recover_bytes(&bytes, std::io::BufWriter::new(file)).map_err(|e| match e {
            RecoverError::NotMcap(damage) => BagError::Damaged {
                path: broken.to_path_buf(),
                damage,
            },
            RecoverError::Write(source) => BagError::Mcap {
                path: fixed.to_path_buf(),
                source,
            },
        })?;
    let io = |source| BagError::Io {
        path: fixed.to_path_buf(),
        source,
    };
    drop(file.into_inner().map_err(|e| io(e.into_error()))?);
    output.commit().map_err(io)?;
    Ok(got)
}

/// The copying: walks `bytes` and writes what verifies to `out`, which it returns finished.
pub fn recover_bytes<W: Write + Seek>(
    bytes: &[u8],
    out: W,
) -> Result<(Recovered, W), RecoverError> {
    let (profile, first) = scan::header(bytes).map_err(RecoverError::NotMcap)?;
    let mut got = Recovered {
        profile,
        ..Recovered::default()
    };
    let mut copy = Copy::new(out, &got.profile)?;
    let mut table = Table::default();
    let summary = summary::read(bytes);
    match &summary {
        Ok(s) => {
            for schema in &s.schemas {
                table.add_schema(schema, 0).ok();
            }
            for channel in &s.channels {
                table.add_channel(channel, 0).ok();
            }
            if s.shift != 0 {
                got.damaged(|| {
                    format!(
                        "the summary lies {} bytes from where its footer says: bytes were {} \
                         before it (the records its index places are looked for at both places)",
                        s.shift.unsigned_abs(),
                        if s.shift > 0 { "inserted" } else { "removed" }
                    )
                });
            }
        }
        Err(Some(d)) => got
            .notes
            .push(format!("the summary is not used {d}; a new one is written")),
        Err(None) => {}
    }
    let mut walk = Walk::new(bytes, summary.as_ref().ok());
    walk.run(first, &mut copy, &mut table, &mut got)?;
    got.kept = copy_counts(&copy.kept, &table);
    got.chunks_kept = walk.chunks_kept;
    if let Ok(s) = &summary {
        exact_counts(s, &copy.kept, &table, &mut got);
    }
    let out = copy.finish(&table)?;
    Ok((got, out))
}

/// With a verified summary, the exact numbers dropped: per channel from its statistics, and the
/// chunks of its index that were not kept.
fn exact_counts(s: &Summary<'_>, kept: &BTreeMap<u16, u64>, table: &Table, got: &mut Recovered) {
    got.chunks_dropped = (s.chunks.len() as u64).saturating_sub(got.chunks_kept);
    let Some((_, per_channel)) = &s.statistics else {
        return;
    };
    let mut dropped = BTreeMap::new();
    for (id, n) in per_channel {
        let kept = kept.get(id).copied().unwrap_or(0);
        if *n > kept {
            *dropped.entry(topic(table, *id)).or_default() += n - kept;
        }
    }
    got.dropped = dropped;
    got.uncounted = 0;
}

/// A damaged place whose messages the message index records after it may count.
struct Lost {
    /// Where, and what is wrong there.
    damage: Damage,
    /// Messages the index records after it counted.
    counted: u64,
    /// What it is believed to be when no index record counts messages in it.
    kind: LostKind,
}

/// What a damaged place is believed to be, when no message index record follows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LostKind {
    /// A chunk (or a message): its messages are lost, and how many is not recorded.
    Chunk,
    /// Bytes that start with no opcode MCAP defines: no record, nothing lost but the bytes.
    Bytes,
    /// A sound record of an opcode MCAP does not define, which readers skip: not reported.
    Unknown,
}

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
struct Walk<'a> {
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
    lost: Option<Lost>,
    chunks_kept: u64,
}

impl<'a> Walk<'a> {
    fn new(bytes: &'a [u8], summary: Option<&Summary<'_>>) -> Self {
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
            lost: None,
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
    fn run<W: Write + Seek>(
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
                    self.damaged(damage, opcode, next, got);
                    at = next;
                }
            }
        }
        self.flush(got);
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
            self.flush(got);
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
                if let Some(lost) = &mut self.lost {
                    lost.counted += count;
                    *got.dropped.entry(topic(table, channel_id)).or_default() += count;
                }
                return Ok(Step::Next(next));
            }
            Parsed::DataEnd { data_crc } => {
                self.flush(got);
                self.check_data_crc(record.offset, data_crc, got);
                return Ok(if self.end_is_sound {
                    Step::Next(next)
                } else {
                    Step::Stop
                });
            }
            Parsed::Footer { .. } => return Ok(Step::Stop),
            Parsed::Other if !(op::HEADER..=op::DATA_END).contains(&record.opcode) => {
                self.flush(got);
                self.lost = Some(Lost {
                    damage: Damage {
                        offset: record.offset,
                        what: format!(
                            "a record of opcode 0x{:02x}, which MCAP does not define, followed by \
                             message index records: a damaged chunk",
                            record.opcode
                        ),
                        cut_short: false,
                    },
                    counted: 0,
                    kind: LostKind::Unknown,
                });
                return Ok(Step::Next(next));
            }
            _ => {}
        }
        self.flush(got);
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

    /// Reports the damaged record at `damage.offset`, believed of `opcode`, which the walk
    /// leaves for `next`.
    fn damaged(&mut self, damage: Damage, opcode: u8, next: u64, got: &mut Recovered) {
        self.flush(got);
        let cut = damage.cut_short && next == self.end;
        match opcode {
            op::MESSAGE_INDEX | op::DATA_END if cut => got.notes.push(format!(
                "{damage}: an index or end record was cut (they are rebuilt; no message is in them)"
            )),
            op::MESSAGE_INDEX => got.damaged(|| {
                format!("{damage}: a message index record (no message is in it) is dropped")
            }),
            op::METADATA | op::ATTACHMENT => got.damaged(|| format!("{damage}: dropped")),
            op::SCHEMA | op::CHANNEL => got.damaged(|| {
                format!("{damage}: dropped; its messages are dropped unless the summary names it")
            }),
            op::DATA_END => got.damaged(|| format!("{damage}: dropped")),
            op::CHUNK | op::MESSAGE if cut => {
                self.lost = Some(Lost {
                    damage: Damage {
                        what: format!(
                            "{}: the file is cut short inside this record; the messages in it \
                             are lost, and how many is not recorded",
                            damage.what
                        ),
                        ..damage
                    },
                    counted: 0,
                    kind: LostKind::Chunk,
                })
            }
            _ => {
                let defined = (op::HEADER..=op::DATA_END).contains(&opcode);
                self.lost = Some(Lost {
                    damage: Damage {
                        what: if defined {
                            format!("{}; the walk goes on at byte {next}", damage.what)
                        } else {
                            format!(
                                "{}; the {} bytes up to byte {next} start no record",
                                damage.what,
                                next - damage.offset
                            )
                        },
                        ..damage
                    },
                    counted: 0,
                    kind: if defined {
                        LostKind::Chunk
                    } else {
                        LostKind::Bytes
                    },
                })
            }
        }
    }

    /// Reports the pending dropped place, with the messages the index records after it counted.
    fn flush(&mut self, got: &mut Recovered) {
        let Some(lost) = self.lost.take() else {
            return;
        };
        let d = lost.damage;
        match lost.kind {
            _ if lost.counted > 0 => {
                got.chunks_dropped += 1;
                got.damaged(|| format!("{d}: its {} messages are dropped", lost.counted));
            }
            LostKind::Chunk => {
                got.chunks_dropped += 1;
                got.uncounted += 1;
                got.damaged(|| {
                    if d.cut_short {
                        d.to_string()
                    } else {
                        format!("{d}: dropped, with a number of messages nothing records")
                    }
                });
            }
            LostKind::Bytes => got.damaged(|| format!("{d}: skipped")),
            LostKind::Unknown => {}
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

/// The output being written: the MCAP writer and the ids it gave to the input's schemas and
/// channels.
struct Copy<W: Write + Seek> {
    writer: mcap::Writer<W>,
    schemas: HashMap<u16, u16>,
    channels: HashMap<u16, u16>,
    /// Messages kept per input channel.
    kept: BTreeMap<u16, u64>,
}

impl<W: Write + Seek> Copy<W> {
    fn new(out: W, profile: &str) -> Result<Self, mcap::McapError> {
        Ok(Self {
            writer: mcap::WriteOptions::new()
                .profile(profile)
                .library(concat!("grasp_orient recover ", env!("CARGO_PKG_VERSION")))
                // As the node writes its recordings.
                .compression(Some(mcap::Compression::Lz4))
                .create(out)?,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            kept: BTreeMap::new(),
        })
    }

    /// The output's id for input channel `id`, adding its schema and itself when first met.
    fn channel(&mut self, table: &Table, id: u16) -> Result<Option<u16>, mcap::McapError> {
        if let Some(out) = self.channels.get(&id) {
            return Ok(Some(*out));
        }
        let Some(channel) = table.channels.get(&id) else {
            return Ok(None);
        };
        let schema = match table.schema_of(channel) {
            Some(s) => match self.schemas.get(&channel.schema_id) {
                Some(out) => *out,
                None => {
                    let out = self.writer.add_schema(&s.name, &s.encoding, &s.data)?;
                    self.schemas.insert(channel.schema_id, out);
                    out
                }
            },
            None => 0,
        };
        let out = self.writer.add_channel(
            schema,
            &channel.topic,
            &channel.message_encoding,
            &channel.metadata,
        )?;
        self.channels.insert(id, out);
        Ok(Some(out))
    }

    /// Copies a message found at `offset` (its own, or its chunk's), or drops it and counts it
    /// when no record defines its channel.
    fn message(
        &mut self,
        table: &Table,
        m: &scan::Message<'_>,
        offset: u64,
        got: &mut Recovered,
    ) -> Result<(), mcap::McapError> {
        let Some(channel_id) = self.channel(table, m.channel_id)? else {
            *got.dropped
                .entry(format!("channel {}", m.channel_id))
                .or_default() += 1;
            got.damaged(|| {
                format!(
                    "at byte {offset}: a message on channel {}, which no record defines: dropped",
                    m.channel_id
                )
            });
            return Ok(());
        };
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        self.writer.write_to_known_channel(&header, m.data)?;
        *self.kept.entry(m.channel_id).or_default() += 1;
        Ok(())
    }

    /// Copies one sound record found at `offset` (its own, or its chunk's).
    fn record(
        &mut self,
        record: Parsed<'_>,
        offset: u64,
        table: &mut Table,
        got: &mut Recovered,
    ) -> Result<(), mcap::McapError> {
        match record {
            Parsed::Schema(s) => {
                if let Err(d) = table.add_schema(&s, offset) {
                    got.damaged(|| format!("{d}; the first definition is kept"));
                }
            }
            Parsed::Channel(c) => {
                if let Err(d) = table.add_channel(&c, offset) {
                    got.damaged(|| format!("{d}; the first definition is kept"));
                }
            }
            Parsed::Message(m) => self.message(table, &m, offset, got)?,
            Parsed::Metadata { name, entries } => {
                self.writer.write_metadata(&mcap::records::Metadata {
                    name,
                    metadata: entries,
                })?;
                got.metadata += 1;
            }
            Parsed::Attachment(a) => self.writer.attach(&mcap::Attachment {
                log_time: a.log_time,
                create_time: a.create_time,
                name: a.name,
                media_type: a.media_type,
                data: std::borrow::Cow::Borrowed(a.data),
            })?,
            _ => {}
        }
        Ok(())
    }

    /// Adds the channels no kept message used (so that they survive too), finishes the file,
    /// and gives it back.
    fn finish(mut self, table: &Table) -> Result<W, mcap::McapError> {
        let mut ids: Vec<u16> = table.channels.keys().copied().collect();
        ids.sort_unstable();
        for id in ids {
            self.channel(table, id)?;
        }
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }
}

fn topic(table: &Table, channel_id: u16) -> String {
    table
        .channels
        .get(&channel_id)
        .map_or_else(|| format!("channel {channel_id}"), |c| c.topic.clone())
}

fn copy_counts(kept: &BTreeMap<u16, u64>, table: &Table) -> BTreeMap<String, u64> {
    let mut out = BTreeMap::new();
    for (id, n) in kept {
        *out.entry(topic(table, *id)).or_default() += n;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::bag::{read_bytes, Bag};
    use crate::record::settings::{SettingsRecord, METADATA_NAME};
    use crate::record::{BagWriter, Entry, Payload};
    use std::io::Cursor;

    /// A small recording as the node writes it: settings metadata, the paper's cases with their
    /// answers, in two chunks.
    fn node_bag() -> Vec<u8> {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("node.mcap");
        let mut w = BagWriter::create(&path, &crate::record::tests::topics(), 100).expect("create");
        let settings = SettingsRecord {
            since: 0,
            node: "/grasp_orient".into(),
            reason: "start".into(),
            config: crate::config::Config::default(),
        };
        w.write(&Entry {
            payload: Payload::Settings(Box::new(settings)),
            log_time: 0,
            publish_time: 0,
        })
        .expect("settings");
        for (i, c) in crate::msg::paper_cases().into_iter().enumerate() {
            let a = crate::answer::answer(&c, &crate::solver::Settings::default());
            let t = 1_000 + i as u64;
            for payload in [
                Payload::request::<crate::kind::Candidates>(c.clone()),
                Payload::answer::<crate::kind::Candidates>(a),
            ] {
                w.write(&Entry {
                    payload,
                    log_time: t,
                    publish_time: t,
                })
                .expect("write");
            }
            if i == 1 {
                w.flush().expect("a second chunk");
            }
        }
        w.finish().expect("finish");
        std::fs::read(&path).expect("read back")
    }

    fn golden() -> Vec<u8> {
        std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/bags/paper_cases.mcap"
        ))
        .expect("the golden bag")
    }

    fn recover_in_memory(bytes: &[u8]) -> Result<(Recovered, Vec<u8>), RecoverError> {
        recover_bytes(bytes, Cursor::new(Vec::new())).map(|(got, out)| (got, out.into_inner()))
    }

    /// What a reader sees of a bag: the messages and the metadata.
    fn content(bag: &Bag) -> impl PartialEq + std::fmt::Debug + '_ {
        (
            &bag.streams.candidates.requests,
            &bag.streams.candidates.answers,
            bag.other,
            &bag.metadata,
        )
    }

    #[test]
    fn a_whole_file_is_copied_whole_and_nothing_is_reported_lost() {
        for bytes in [node_bag(), golden()] {
            let (got, out) = recover_in_memory(&bytes).expect("recovers");
            assert!(!got.lost_anything(), "{got:?}");
            let (a, b) = (
                read_bytes(&bytes).expect("whole"),
                read_bytes(&out).expect("whole"),
            );
            assert_eq!(content(&a), content(&b));
            assert_eq!(got.kept_total(), 8);
        }
        let (got, _) = recover_in_memory(&node_bag()).expect("recovers");
        assert_eq!(got.metadata, 1, "the settings are kept");
        assert_eq!(got.profile, "ros2");
    }

    /// A flip in every byte of two bags (bit `i % 8` of byte `i`; every byte, so every field
    /// of every record): `recover` never panics, and either reports a loss or wrote exactly
    /// what the undamaged file holds. The strict reader refuses every flip of the bag our
    /// writer made (it has a data section CRC); of the one mcap_ros2 wrote (which has none), it
    /// refuses every flip that changes what the file holds.
    #[test]
    fn a_flip_in_any_byte_is_caught() {
        for (original, data_crc) in [(node_bag(), true), (golden(), false)] {
            let whole = read_bytes(&original).expect("the original reads");
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            let share = original.len().div_ceil(threads);
            let silent: Vec<String> = std::thread::scope(|scope| {
                let handles: Vec<_> = (0..original.len())
                    .collect::<Vec<_>>()
                    .chunks(share)
                    .map(|bytes_to_flip| {
                        let (original, whole) = (&original, &whole);
                        let bytes_to_flip = bytes_to_flip.to_vec();
                        scope.spawn(move || {
                            let mut silent = Vec::new();
                            let mut bytes = original.clone();
                            for i in bytes_to_flip {
                                let bit = 1u8 << (i % 8);
                                bytes[i] ^= bit;
                                let what = format!("byte {i} bit {bit:#04x}");
                                match read_bytes(&bytes) {
                                    Ok(_) if data_crc => silent.push(format!("{what}: read it")),
                                    Ok(b) if content(&b) != content(whole) => {
                                        silent.push(format!("{what}: read it differently"));
                                    }
                                    _ => {}
                                }
                                if let Ok((got, out)) = recover_in_memory(&bytes) {
                                    let same = || {
                                        read_bytes(&out)
                                            .is_ok_and(|b| content(&b) == content(whole))
                                    };
                                    if !got.lost_anything() && !same() {
                                        silent.push(format!(
                                            "{what}: recover reported nothing lost but wrote \
                                             something else"
                                        ));
                                    }
                                }
                                bytes[i] ^= bit;
                            }
                            silent
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().expect("no panic"))
                    .collect()
            });
            assert!(
                silent.is_empty(),
                "{} silent flips: {:?}",
                silent.len(),
                &silent[..silent.len().min(10)]
            );
        }
    }

    #[test]
    fn a_cut_file_keeps_its_whole_chunks_and_reports_a_cut_one() {
        let bytes = node_bag();
        let whole = read_bytes(&bytes).expect("whole");
        let scan = scan::scan(&bytes).expect("scans");
        let chunks: Vec<(usize, usize)> = scan
            .items
            .iter()
            .filter_map(|i| match &i.parsed {
                Ok(Parsed::Chunk(c)) => {
                    let start = i.offset as usize;
                    let end = c.data.as_ptr() as usize - bytes.as_ptr() as usize + c.data.len();
                    Some((start, end))
                }
                _ => None,
            })
            .collect();
        // The settings record ends where the next record starts.
        let metadata = scan
            .items
            .windows(2)
            .find(|w| w[0].opcode == op::METADATA)
            .map(|w| (w[0].offset as usize, w[1].offset as usize))
            .expect("the settings record");
        let header_end = 8 + 9 + 30;
        for end in 0..bytes.len() {
            match recover_in_memory(&bytes[..end]) {
                Err(RecoverError::NotMcap(d)) => assert!(end < header_end, "at {end}: {d}"),
                Err(e) => panic!("at {end}: {e}"),
                Ok((got, out)) => {
                    let back = read_bytes(&out).expect("the output is whole");
                    assert!(
                        whole
                            .streams
                            .candidates
                            .requests
                            .starts_with(&back.streams.candidates.requests),
                        "at {end}"
                    );
                    let in_a_chunk = chunks.iter().any(|(s, e)| *s < end && end < *e);
                    let in_metadata = (metadata.0 < end) && (end < metadata.1);
                    assert_eq!(
                        got.uncounted,
                        u64::from(in_a_chunk),
                        "cut at {end}: {got:?}"
                    );
                    assert_eq!(
                        got.lost_anything(),
                        in_a_chunk || in_metadata,
                        "cut at {end}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_flipped_chunk_opcode_drops_the_chunk_and_counts_it_per_topic() {
        let mut bytes = node_bag();
        let scan = scan::scan(&bytes).expect("scans");
        let chunk = scan
            .items
            .iter()
            .filter(|i| i.opcode == op::CHUNK)
            .nth(2)
            .expect("a chunk with messages")
            .offset;
        bytes[chunk as usize] = 0x86;
        let (got, out) = recover_in_memory(&bytes).expect("recovers");
        assert!(got.lost_anything());
        assert_eq!(got.dropped.get("/grasp_candidates"), Some(&2), "{got:?}");
        assert_eq!(
            got.dropped.get("/grip_recommendations"),
            Some(&2),
            "{got:?}"
        );
        assert_eq!(
            read_bytes(&out)
                .expect("whole")
                .streams
                .candidates
                .requests
                .len(),
            2
        );
        // The same chunk with a flipped bit in its compressed records.
        let mut bytes = node_bag();
        bytes[chunk as usize + 100] ^= 0x10;
        let (got, _) = recover_in_memory(&bytes).expect("recovers");
        assert_eq!(got.dropped_total(), 4, "{got:?}");
        assert!(
            got.damage[0].starts_with(&format!("at byte {chunk}: chunk record: ")),
            "{got:?}"
        );
    }

    #[test]
    fn what_is_not_a_recording_is_refused() {
        for bytes in [
            &b""[..],
            &scan::MAGIC[..],
            b"\x00\x01random bytes that are no MCAP at all",
        ] {
            assert!(matches!(
                recover_in_memory(bytes),
                Err(RecoverError::NotMcap(_))
            ));
        }
        assert_eq!(METADATA_NAME, "grasp_orient.settings");
    }
}
