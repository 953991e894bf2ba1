//! Reading recordings back: ours, or any rosbag2-style MCAP with a `GraspCandidate` topic.
//!
//! [`read`] is strict: the file must be whole, every CRC it carries must verify (chunks, data
//! section, summary), every length must fit, and anything else is an error naming the file and
//! the byte offset ([`BagError::Damaged`]). A file that merely ends early is told apart, with a
//! pointer to `recover` ([`super::recover`]). The records are walked by [`super::scan`], which
//! checks every length against the file before anything is allocated; chunks are decompressed
//! and decoded on all cores.

use super::channels::{ChannelReader, Channels, RecordedFields};
use super::scan::{self, Damage, Parsed, Table};
use crate::kind::{self, Kind, Streams, Visit};
use crate::msg::cdr;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What goes wrong reading or recovering a bag.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a regular file (a device, a folder): nothing a recording can be read from.
    #[error("{path}: not a regular file")]
    NotAFile {
        /// The path.
        path: PathBuf,
    },
    /// The file is not a whole, undamaged MCAP recording.
    #[error("{path} {}{}", damage_words(damage), recover_hint(path, damage))]
    Damaged {
        /// The file.
        path: PathBuf,
        /// Where and what.
        damage: Damage,
    },
    /// The output cannot be written there (it is an input, or its folder refuses it).
    #[error(transparent)]
    Output(#[from] super::output::OutputError),
    /// Writing an MCAP file failed.
    #[error("{path}: cannot write the MCAP file: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: mcap::McapError,
    },
    /// A channel carries one of our types in a version that is not a prefix of ours.
    #[error("{path}: {why}")]
    Incompatible {
        /// The file.
        path: PathBuf,
        /// The channel, and the first field that differs.
        why: String,
    },
}

fn damage_words(damage: &Damage) -> String {
    if damage.cut_short {
        format!("is cut short {damage}")
    } else {
        format!("is damaged {damage}")
    }
}

fn recover_hint(path: &Path, damage: &Damage) -> String {
    if damage.cut_short {
        format!(
            " (a recorder that was killed, ran out of disk or is still writing); `grasp_orient \
             recover {} -o FIXED.mcap` saves what is complete",
            path.display()
        )
    } else {
        String::new()
    }
}

/// How many examples of one kind of trouble a report keeps.
pub(crate) const EXAMPLES_KEPT: usize = 10;

/// Adds an example to `examples` unless it holds [`EXAMPLES_KEPT`] already; `example` is only
/// made when there is room.
pub(crate) fn keep_example(examples: &mut Vec<String>, example: impl FnOnce() -> String) {
    if examples.len() < EXAMPLES_KEPT {
        examples.push(example());
    }
}

pub(crate) use crate::kind::Recorded;

/// The grasp_orient messages of one bag, in file order.
#[derive(Debug, Default, PartialEq)]
pub struct Bag {
    /// The requests and answers of every kind.
    pub streams: Streams,
    /// Which fields of our types the recording has (recordings made before a type grew lack its
    /// trailing fields, which decode at their defaults).
    pub fields: RecordedFields,
    /// Channels of our types in a version that is not a prefix of ours, with why.
    pub incompatible: Vec<String>,
    /// Messages on other topics, left alone.
    pub other: u64,
    /// Messages of our types that did not decode, with why (first few).
    pub undecodable: Vec<String>,
    /// How many did not decode.
    pub undecodable_count: u64,
    /// Every metadata record, in file order: name and entries (the settings the node recorded
    /// are among them, [`super::settings`]).
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
}

impl Bag {
    /// Appends `next`, which follows `self` in the file.
    fn append(&mut self, next: Bag) {
        self.streams.append(next.streams);
        self.fields.merge(&next.fields);
        for why in next.incompatible {
            if !self.incompatible.contains(&why) {
                self.incompatible.push(why);
            }
        }
        self.other += next.other;
        self.undecodable_count += next.undecodable_count;
        for example in next.undecodable {
            keep_example(&mut self.undecodable, || example);
        }
        self.metadata.extend(next.metadata);
    }

    /// Messages of every kind it holds.
    fn messages(&self) -> u64 {
        self.streams.len() + self.other + self.undecodable_count
    }
}

/// Reads a whole file, refusing what is not a regular file (`/dev/zero` would never end).
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, BagError> {
    let io = |source| BagError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(BagError::NotAFile {
            path: path.to_path_buf(),
        });
    }
    std::fs::read(path).map_err(io)
}

/// Reads every grasp_orient message of a bag, in file order, and its metadata records. Any
/// damage, and a file that is not whole, is an error naming the byte offset.
pub fn read(path: &Path) -> Result<Bag, BagError> {
    let bytes = read_file(path)?;
    let bag = read_bytes(&bytes).map_err(|damage| BagError::Damaged {
        path: path.to_path_buf(),
        damage,
    })?;
    compatible(bag, path)
}

/// The bag, or the error naming its first channel of ours in a version that is not a prefix of
/// ours.
fn compatible(bag: Bag, path: &Path) -> Result<Bag, BagError> {
    match bag.incompatible.first() {
        Some(why) => Err(BagError::Incompatible {
            path: path.to_path_buf(),
            why: why.clone(),
        }),
        None => Ok(bag),
    }
}

/// [`read`] of a file's bytes.
pub fn read_bytes(bytes: &[u8]) -> Result<Bag, Damage> {
    let scan = scan::scan(bytes)?;
    if let Some(d) = scan.record_damage() {
        return Err(d.clone());
    }
    let mut table = Table::default();
    for s in &scan.summary_schemas {
        table.add_schema(s, 0)?;
    }
    for c in &scan.summary_channels {
        table.add_channel(c, 0)?;
    }
    let bag = match decode_in_parallel(&scan, &table)? {
        Some(bag) => bag,
        // A message came before its channel's definition in another share of the file.
        None => match decode_share(&scan.items, table) {
            Ok(bag) => bag,
            Err(Stop::Damage(d)) => return Err(d),
            Err(Stop::Unresolved) => {
                return Err(Damage {
                    offset: 0,
                    what: "a message refers to a channel no record defines".into(),
                    cut_short: false,
                })
            }
        },
    };
    // Chunks check themselves while they are decoded, and name the damaged one; a CRC of the
    // whole data section or summary that still fails names damage outside the chunks.
    if let Some(d) = scan.section_damage() {
        return Err(d.clone());
    }
    if let Some((count, _)) = &scan.statistics {
        if *count != bag.messages() {
            return Err(Damage {
                offset: bytes.len() as u64,
                what: format!(
                    "the summary counts {count} messages but the file holds {}",
                    bag.messages()
                ),
                cut_short: false,
            });
        }
    }
    Ok(bag)
}

/// Why decoding a share stopped.
enum Stop {
    /// The file is damaged.
    Damage(Damage),
    /// A message's channel is defined only in an earlier share (or nowhere).
    Unresolved,
}

impl From<Damage> for Stop {
    fn from(d: Damage) -> Self {
        Stop::Damage(d)
    }
}

/// Decodes the data section in one share per core, each share a run of whole records in file
/// order. `None` when a share met a message whose channel is defined only in an earlier share.
fn decode_in_parallel(scan: &scan::Scan<'_>, table: &Table) -> Result<Option<Bag>, Damage> {
    let chunks = scan
        .items
        .iter()
        .filter(|i| i.opcode == scan::op::CHUNK)
        .count();
    let threads = if chunks < 2 {
        1
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    };
    let per = scan.items.len().div_ceil(threads).max(1);
    let decode = |share| match decode_share(share, table.clone()) {
        Ok(bag) => Ok(Some(bag)),
        Err(Stop::Unresolved) => Ok(None),
        Err(Stop::Damage(d)) => Err(d),
    };
    let parts: Vec<Result<Option<Bag>, Damage>> = if threads == 1 {
        vec![decode(&scan.items)]
    } else {
        std::thread::scope(|scope| {
            let handles: Vec<_> = scan
                .items
                .chunks(per)
                .map(|share| scope.spawn(move || decode(share)))
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join().unwrap_or_else(|_| {
                        Err(Damage {
                            offset: 0,
                            what: "a decoding thread panicked".into(),
                            cut_short: false,
                        })
                    })
                })
                .collect()
        })
    };
    let mut bag = Bag::default();
    for part in parts {
        match part? {
            Some(p) => bag.append(p),
            None => return Ok(None),
        }
    }
    Ok(Some(bag))
}

/// Decodes a run of data-section records in order, growing `table` with the definitions met.
fn decode_share(items: &[scan::Item<'_>], mut table: Table) -> Result<Bag, Stop> {
    let mut bag = Bag::default();
    let mut channels = Channels::default();
    for item in items {
        let parsed = item.parsed.as_ref().map_err(|d| Stop::Damage(d.clone()))?;
        match parsed {
            Parsed::Schema(s) => table.add_schema(s, item.offset)?,
            Parsed::Channel(c) => table.add_channel(c, item.offset)?,
            Parsed::Message(m) => take(&mut bag, &table, &mut channels, m)?,
            Parsed::Chunk(chunk) => {
                decode_chunk(&mut bag, &mut table, &mut channels, chunk, item.offset)?
            }
            Parsed::Metadata { name, entries } => {
                bag.metadata.push((name.clone(), entries.clone()))
            }
            _ => {}
        }
    }
    Ok(bag)
}

/// Decodes the records of one chunk.
fn decode_chunk(
    bag: &mut Bag,
    table: &mut Table,
    channels: &mut Channels,
    chunk: &scan::Chunk<'_>,
    offset: u64,
) -> Result<(), Stop> {
    let records = scan::decompress(chunk).map_err(|why| Damage {
        offset,
        what: format!("chunk record: {why}"),
        cut_short: false,
    })?;
    for record in chunk_records(&records, offset) {
        match record? {
            (inner, Parsed::Schema(s)) => table.add_schema(&s, inner)?,
            (inner, Parsed::Channel(c)) => table.add_channel(&c, inner)?,
            (_, Parsed::Message(m)) => take(bag, table, channels, &m)?,
            _ => {}
        }
    }
    Ok(())
}

/// The records of a decompressed chunk at `offset`: schemas, channels and messages, each with
/// the chunk's offset (damage inside a chunk is reported at the chunk, naming the inner byte).
pub(crate) fn chunk_records<'a>(
    records: &'a [u8],
    offset: u64,
) -> impl Iterator<Item = Result<(u64, Parsed<'a>), Damage>> + 'a {
    let inside = move |d: Damage| Damage {
        offset,
        what: format!(
            "chunk record: at byte {} of its records: {}",
            d.offset, d.what
        ),
        cut_short: false,
    };
    scan::Records::new(records, 0, false).map(move |record| {
        let record = record.map_err(inside)?;
        match record.opcode {
            scan::op::SCHEMA | scan::op::CHANNEL | scan::op::MESSAGE => {
                Ok((offset, scan::parse(&record).map_err(inside)?))
            }
            other => Err(inside(Damage {
                offset: record.offset,
                what: format!("opcode 0x{other:02x} has no place inside a chunk"),
                cut_short: false,
            })),
        }
    })
}

/// Decodes one message into the bag's lists, or notes why it did not decode. Channels are picked
/// by schema name alone (with or without the `/msg/`), never by the schema text, so recordings
/// written with any form of the definitions read alike; the schema text only says which fields
/// the recorded version of the type has ([`super::channels`]).
fn take(
    out: &mut Bag,
    table: &Table,
    channels: &mut Channels,
    message: &scan::Message<'_>,
) -> Result<(), Stop> {
    let Some(reader) = channels.reader(table, message.channel_id, &mut out.fields) else {
        return Err(Stop::Unresolved);
    };
    let (log_time, publish_time) = (message.log_time, message.publish_time);
    let reader = match reader {
        Ok(reader) => reader.clone(),
        Err(why) => {
            let why = why.to_string();
            if !out.incompatible.contains(&why) {
                out.incompatible.push(why);
            }
            out.undecodable_count += 1;
            return Ok(());
        }
    };
    let failed = |out: &mut Bag, e: cdr::CdrError| {
        out.undecodable_count += 1;
        keep_example(&mut out.undecodable, || {
            let topic = table
                .channels
                .get(&message.channel_id)
                .map_or("?", |c| c.topic.as_str());
            format!("{topic} #{} (log time {log_time}): {e}", message.sequence)
        });
    };
    let Some(channel) = reader.carried else {
        out.other += 1;
        return Ok(());
    };
    let times = (log_time, publish_time);
    if let Err(e) = PUSH[channel.slot()](&reader, message.data, &mut out.streams, times) {
        failed(out, e);
    }
    Ok(())
}

/// Decodes one message of a channel into its stream.
type Push = fn(&ChannelReader, &[u8], &mut Streams, (u64, u64)) -> Result<(), cdr::CdrError>;

/// [`Push`] of each channel, by [`kind::Channel::slot`].
static PUSH: std::sync::LazyLock<[Push; kind::Channel::COUNT]> = std::sync::LazyLock::new(|| {
    /// Decodes `bytes` onto the end of `list`, with the message's times.
    fn decode_onto<M: serde::de::DeserializeOwned>(
        r: &ChannelReader,
        bytes: &[u8],
        list: &mut Vec<Recorded<M>>,
        (log_time, publish_time): (u64, u64),
    ) -> Result<(), cdr::CdrError> {
        let message = r.decode(bytes)?;
        list.push(Recorded {
            message,
            log_time,
            publish_time,
        });
        Ok(())
    }
    fn request<K: Kind>(
        r: &ChannelReader,
        bytes: &[u8],
        streams: &mut Streams,
        times: (u64, u64),
    ) -> Result<(), cdr::CdrError> {
        decode_onto(r, bytes, &mut K::stream_mut(streams).requests, times)
    }
    fn answer<K: Kind>(
        r: &ChannelReader,
        bytes: &[u8],
        streams: &mut Streams,
        times: (u64, u64),
    ) -> Result<(), cdr::CdrError> {
        decode_onto(r, bytes, &mut K::stream_mut(streams).answers, times)
    }
    struct Table([Push; kind::Channel::COUNT]);
    impl Visit for Table {
        fn kind<K: Kind>(&mut self) {
            self.0[kind::Channel::request::<K>().slot()] = request::<K>;
            self.0[kind::Channel::answer::<K>().slot()] = answer::<K>;
        }
    }
    let mut table = Table([request::<kind::Candidates>; kind::Channel::COUNT]);
    kind::each(&mut table);
    table.0
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{BagWriter, Entry, Payload, Topics};

    fn topics() -> Topics {
        Topics::new("/grasp_candidates", "/grip_recommendations")
            .with::<crate::kind::Sets>("/grasp_candidate_sets", "/grip_recommendation_sets")
    }

    /// The paper's cases and their answers, written by [`BagWriter`] into `path`.
    pub(crate) fn write_paper_cases(path: &Path) {
        let mut w = BagWriter::create(path, &topics(), 100).expect("create");
        let settings = crate::solver::Settings::default();
        for (i, c) in crate::msg::paper_cases().into_iter().enumerate() {
            let a = crate::answer::answer(&c, &settings);
            let t = 1_000 + i as u64;
            w.write(&Entry {
                payload: Payload::request::<crate::kind::Candidates>(c),
                log_time: t,
                publish_time: t - 1,
            })
            .expect("write");
            w.write(&Entry {
                payload: Payload::answer::<crate::kind::Candidates>(a),
                log_time: t,
                publish_time: t,
            })
            .expect("write");
        }
        assert_eq!(
            w.finish()
                .expect("finish")
                .requests::<crate::kind::Candidates>(),
            4
        );
    }

    #[test]
    fn write_then_read_gives_the_same_messages() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("round_trip.mcap");
        write_paper_cases(&path);
        let bag = read(&path).expect("read");
        assert_eq!(bag.streams.candidates.requests.len(), 4);
        assert_eq!(bag.streams.candidates.answers.len(), 4);
        for (got, want) in bag
            .streams
            .candidates
            .requests
            .iter()
            .zip(&crate::msg::paper_cases())
        {
            assert_eq!(&got.message, want);
        }
        assert_eq!(bag.streams.candidates.requests[1].publish_time, 1_000);
    }

    /// Every kind, through its one path: written as `Payload::request::<K>` and
    /// `Payload::answer::<K>` on the channels `Topics::default_names` gives it, read back into its
    /// own stream, in order, with its times; the writer's counts name the same channels.
    #[test]
    fn every_kind_is_written_and_read_back_through_its_stream() {
        struct Write<'a>(&'a mut BagWriter, u64);
        impl Visit for Write<'_> {
            fn kind<K: Kind>(&mut self) {
                for (i, payload) in [
                    Payload::request::<K>(K::Request::default()),
                    Payload::answer::<K>(K::Answer::default()),
                    Payload::request::<K>(K::Request::default()),
                ]
                .into_iter()
                .enumerate()
                {
                    let t = 1_000 * (K::INDEX as u64 + 1) + i as u64;
                    let entry = Entry {
                        payload,
                        log_time: t,
                        publish_time: t - 1,
                    };
                    self.0.write(&entry).expect("write");
                    self.1 += 1;
                }
            }
        }
        struct Check<'a>(&'a Bag, &'a crate::record::Written);
        impl Visit for Check<'_> {
            fn kind<K: Kind>(&mut self) {
                let stream = self.0.streams.of::<K>();
                let what = std::any::type_name::<K>();
                assert_eq!(stream.requests.len(), 2, "{what}");
                assert_eq!(stream.answers.len(), 1, "{what}");
                assert_eq!(stream.requests[0].message, K::Request::default(), "{what}");
                let base = 1_000 * (K::INDEX as u64 + 1);
                let times: Vec<u64> = stream.requests.iter().map(|r| r.log_time).collect();
                assert_eq!(times, [base, base + 2], "{what}");
                assert_eq!(stream.answers[0].publish_time, base, "{what}");
                assert_eq!(
                    (self.1.requests::<K>(), self.1.answers::<K>()),
                    (2, 1),
                    "{what}"
                );
            }
        }
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("kinds.mcap");
        let mut w = BagWriter::create(&path, &Topics::default_names(), 100).expect("create");
        let mut write = Write(&mut w, 0);
        kind::each(&mut write);
        let count = write.1;
        let written = w.finish().expect("finish");
        let bag = read(&path).expect("read");
        assert_eq!(bag.streams.len(), count);
        assert_eq!(bag.other + bag.undecodable_count, 0);
        kind::each(&mut Check(&bag, &written));
    }

    #[test]
    fn a_cut_file_is_refused_with_the_offset_and_a_pointer_to_recover() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("whole.mcap");
        write_paper_cases(&path);
        let bytes = std::fs::read(&path).expect("read");
        let cut = dir.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).expect("write");
        let e = read(&cut).expect_err("a cut file is not readable as it is");
        let text = e.to_string();
        assert!(text.contains("cut.mcap is cut short at byte "), "{text}");
        assert!(text.contains("grasp_orient recover"), "{text}");
    }

    #[test]
    fn not_a_regular_file_is_refused_at_once() {
        let e = read(Path::new("/dev/zero")).expect_err("a device");
        assert_eq!(e.to_string(), "/dev/zero: not a regular file");
        let dir = tempfile::tempdir().expect("a temporary folder");
        assert!(matches!(read(dir.path()), Err(BagError::NotAFile { .. })));
    }
}
