//! `recover`: what a cut-short or damaged recording still holds, copied into a fresh, finished
//! MCAP file with the same profile, schemas, channels and metadata.
//!
//! Only what verifies is kept: a chunk whose CRC, size or records do not check out is dropped
//! whole, and so is a message whose channel no record defines. What is dropped is counted per
//! topic: from the summary's statistics when the summary's own CRC verifies, else from the
//! message index records that follow each chunk; where neither says, the loss is reported as
//! uncounted. A damaged data section CRC is reported too, since it means some record outside
//! the chunks changed. [`Recovered::lost_anything`] is what `recover`'s exit code follows.

use super::bag::{chunk_records, keep_example, read_file, BagError};
use super::output::Replacement;
use super::scan::{self, op, Damage, Parsed, Table};
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
    let scan = scan::scan(bytes).map_err(RecoverError::NotMcap)?;
    let mut got = Recovered {
        profile: scan.profile.clone().unwrap_or_default(),
        ..Recovered::default()
    };
    let mut copy = Copy::new(out, &got.profile)?;
    let mut table = Table::default();
    if scan.summary_verified {
        for s in &scan.summary_schemas {
            table.add_schema(s, 0).ok();
        }
        for c in &scan.summary_channels {
            table.add_channel(c, 0).ok();
        }
    }
    for (i, item) in scan.items.iter().enumerate() {
        copy.item(&scan.items, i, item, &mut table, &mut got)?;
    }
    judge_the_end(bytes, &scan, &table, &copy.kept, &mut got);
    got.kept = copy_counts(&copy.kept, &table);
    let out = copy.finish(&table)?;
    Ok((got, out))
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

    /// Handles the data-section record `items[i]`.
    fn item(
        &mut self,
        items: &[scan::Item<'_>],
        i: usize,
        item: &scan::Item<'_>,
        table: &mut Table,
        got: &mut Recovered,
    ) -> Result<(), mcap::McapError> {
        let parsed = match &item.parsed {
            Ok(p) => p,
            Err(d) => {
                if matches!(item.opcode, op::CHUNK | op::MESSAGE) {
                    drop_chunk(items, i, d, table, got);
                } else if matches!(item.opcode, op::METADATA | op::ATTACHMENT) {
                    got.damaged(|| format!("{d}: dropped"));
                } else if matches!(item.opcode, op::SCHEMA | op::CHANNEL) {
                    got.damaged(|| {
                        format!("{d}: its messages are dropped unless the summary names it")
                    });
                }
                return Ok(());
            }
        };
        match parsed {
            Parsed::Schema(s) => {
                if let Err(d) = table.add_schema(s, item.offset) {
                    got.damaged(|| format!("{d}; the first definition is kept"));
                }
            }
            Parsed::Channel(c) => {
                if let Err(d) = table.add_channel(c, item.offset) {
                    got.damaged(|| format!("{d}; the first definition is kept"));
                }
            }
            Parsed::Message(m) => self.message(table, m, item.offset, got)?,
            Parsed::Chunk(chunk) => match scan::decompress(chunk) {
                Err(why) => {
                    let d = Damage {
                        offset: item.offset,
                        what: format!("chunk record: {why}"),
                        cut_short: false,
                    };
                    drop_chunk(items, i, &d, table, got);
                }
                // Nothing of a chunk is used unless every record in it reads.
                Ok(records) => match chunk_records(&records, item.offset).collect() {
                    Ok(list) => {
                        let list: Vec<(u64, Parsed<'_>)> = list;
                        for (offset, record) in list {
                            self.chunk_record(record, offset, table, got)?;
                        }
                    }
                    Err(d) => drop_chunk(items, i, &d, table, got),
                },
            },
            Parsed::Metadata { name, entries } => {
                self.writer.write_metadata(&mcap::records::Metadata {
                    name: name.clone(),
                    metadata: entries.clone(),
                })?;
                got.metadata += 1;
            }
            Parsed::Attachment(a) => self.writer.attach(&mcap::Attachment {
                log_time: a.log_time,
                create_time: a.create_time,
                name: a.name.clone(),
                media_type: a.media_type.clone(),
                data: std::borrow::Cow::Borrowed(a.data),
            })?,
            _ => {}
        }
        Ok(())
    }

    /// Copies one record of a verified chunk.
    fn chunk_record(
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

/// A chunk (or a message record) at `items[i]` did not verify: counts its messages from the
/// message index records after it, or as uncounted.
fn drop_chunk(
    items: &[scan::Item<'_>],
    i: usize,
    damage: &Damage,
    table: &Table,
    got: &mut Recovered,
) {
    let mut counted = 0u64;
    for next in items.iter().skip(i + 1) {
        match &next.parsed {
            Ok(Parsed::MessageIndex { channel_id, count }) if next.opcode == op::MESSAGE_INDEX => {
                *got.dropped.entry(topic(table, *channel_id)).or_default() += count;
                counted += count;
            }
            _ => break,
        }
    }
    if counted == 0 {
        got.uncounted += 1;
        got.damaged(|| format!("{damage}: dropped, with a number of messages nothing records"));
    } else {
        got.damaged(|| format!("{damage}: its {counted} messages are dropped"));
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

/// How the file ended, whether the data section verified, and, when the summary verified, the
/// exact numbers dropped per channel from its statistics.
fn judge_the_end(
    bytes: &[u8],
    scan: &scan::Scan<'_>,
    table: &Table,
    kept: &BTreeMap<u16, u64>,
    got: &mut Recovered,
) {
    for d in &scan.summary_damage {
        got.notes
            .push(format!("the summary is damaged {d}; a new one is written"));
    }
    for d in &scan.damage {
        got.damaged(|| d.to_string());
    }
    if let Some(d) = &scan.stopped {
        let in_summary = scan.data_end.is_some_and(|end| d.offset > end);
        match bytes.get(d.offset as usize).copied() {
            _ if in_summary => got.notes.push(format!(
                "the file's end is damaged {d}; a new one is written"
            )),
            None if d.cut_short => got.notes.push(format!(
                "the file ends at byte {} where a record ends, without its summary (a recorder \
                 that was killed or is still writing): nothing in it was cut",
                d.offset
            )),
            Some(op::MESSAGE_INDEX | op::DATA_END) if d.cut_short => got.notes.push(format!(
                "{d}: an index or end record was cut (they are rebuilt; no message is in them)"
            )),
            Some(op::METADATA | op::ATTACHMENT | op::SCHEMA | op::CHANNEL) if d.cut_short => {
                got.damaged(|| format!("{d}: the record there was cut and is dropped"));
            }
            _ => {
                got.uncounted += 1;
                got.damaged(|| {
                    if d.cut_short {
                        format!(
                            "{d}: the file is cut short inside this record; the messages in it \
                             are lost, and how many is not recorded"
                        )
                    } else {
                        format!(
                            "{d}: everything from there on is lost, and how many messages is not \
                             recorded"
                        )
                    }
                });
            }
        }
    }
    if let (true, Some((_, per_channel))) = (scan.summary_verified, &scan.statistics) {
        // The statistics count every message of the file: the exact loss per channel.
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::bag::{read_bytes, Bag};
    use crate::record::settings::{SettingsRecord, METADATA_NAME};
    use crate::record::{BagWriter, Entry, Payload, Topics};
    use std::io::Cursor;

    /// A small recording as the node writes it: settings metadata, the paper's cases with their
    /// answers, in two chunks.
    fn node_bag() -> Vec<u8> {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("node.mcap");
        let topics = Topics {
            candidates: "/grasp_candidates".into(),
            recommendations: "/grip_recommendations".into(),
            markers: None,
            sets: None,
        };
        let mut w = BagWriter::create(&path, &topics, 100).expect("create");
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
                Payload::Candidate(Box::new(c.clone())),
                Payload::Recommendation(Box::new(a)),
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
            &bag.candidates,
            &bag.recommendations,
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
                    assert!(whole.candidates.starts_with(&back.candidates), "at {end}");
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
        assert_eq!(read_bytes(&out).expect("whole").candidates.len(), 2);
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
