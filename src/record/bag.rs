//! Reading recordings back: ours, or any rosbag2-style MCAP with a `GraspCandidate` topic, and
//! recovering what a killed recording holds.

use super::bounded;
use crate::msg::{cdr, GraspCandidate, GripRecommendation};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Schema name of candidates.
pub const CANDIDATE_TYPE: &str = "grasp_orient/msg/GraspCandidate";
/// Schema name of recommendations.
pub const RECOMMENDATION_TYPE: &str = "grasp_orient/msg/GripRecommendation";

/// What goes wrong reading or recovering a bag.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not a readable MCAP.
    #[error("{path}: not a readable MCAP file: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: mcap::McapError,
    },
}

/// A message with the times it was recorded at, ns since the epoch.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded<T> {
    /// The message.
    pub message: T,
    /// Receive time.
    pub log_time: u64,
    /// Send time.
    pub publish_time: u64,
}

/// The grasp_orient messages of one bag, in file order.
#[derive(Debug, Default)]
pub struct Bag {
    /// Every candidate.
    pub candidates: Vec<Recorded<GraspCandidate>>,
    /// Every recommendation.
    pub recommendations: Vec<Recorded<GripRecommendation>>,
    /// Messages on other topics, left alone.
    pub other: u64,
    /// Messages of our types that did not decode, with why (first few).
    pub undecodable: Vec<String>,
    /// How many did not decode.
    pub undecodable_count: u64,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> BagError + '_ {
    move |source| BagError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn mcap_err(path: &Path) -> impl Fn(mcap::McapError) -> BagError + '_ {
    move |source| BagError::Mcap {
        path: path.to_path_buf(),
        source,
    }
}

/// Whether a channel carries `type_name` (`pkg/msg/Name`) as CDR; schema names are accepted
/// with or without the `/msg/`. Called for every message, so it compares without allocating.
fn carries(channel: &mcap::Channel<'_>, type_name: &str) -> bool {
    let Some(schema) = &channel.schema else {
        return false;
    };
    channel.message_encoding == "cdr" && short_name(&schema.name) == short_name(type_name)
}

/// `(pkg, Name)` of `pkg/msg/Name` or `pkg/Name`.
fn short_name(name: &str) -> Option<(&str, &str)> {
    name.split_once('/')
        .map(|(pkg, rest)| (pkg, rest.strip_prefix("msg/").unwrap_or(rest)))
}

/// Decodes one message of ours into the bag's lists, or notes why it did not decode.
fn take(out: &mut Bag, message: &mcap::Message<'_>) {
    let (log_time, publish_time) = (message.log_time, message.publish_time);
    let failed = |out: &mut Bag, e: cdr::CdrError| {
        out.undecodable_count += 1;
        if out.undecodable.len() < 10 {
            out.undecodable.push(format!(
                "{} #{}: {e}",
                message.channel.topic, message.sequence
            ));
        }
    };
    if carries(&message.channel, CANDIDATE_TYPE) {
        match cdr::decode::<GraspCandidate>(&message.data) {
            Ok(m) => out.candidates.push(Recorded {
                message: m,
                log_time,
                publish_time,
            }),
            Err(e) => failed(out, e),
        }
    } else if carries(&message.channel, RECOMMENDATION_TYPE) {
        match cdr::decode::<GripRecommendation>(&message.data) {
            Ok(m) => out.recommendations.push(Recorded {
                message: m,
                log_time,
                publish_time,
            }),
            Err(e) => failed(out, e),
        }
    } else {
        out.other += 1;
    }
}

impl Bag {
    /// Appends `next`, which follows `self` in the file.
    fn append(&mut self, next: Bag) {
        self.candidates.extend(next.candidates);
        self.recommendations.extend(next.recommendations);
        self.other += next.other;
        self.undecodable_count += next.undecodable_count;
        let room = 10usize.saturating_sub(self.undecodable.len());
        self.undecodable
            .extend(next.undecodable.into_iter().take(room));
    }
}

/// Reads every grasp_orient message of a bag, in file order. When the summary indexes every
/// message into chunks, the chunks are decompressed and decoded on all cores.
pub fn read(path: &Path) -> Result<Bag, BagError> {
    let bytes = bounded::read_file(path).map_err(io(path))?;
    parse(&bytes).map_err(mcap_err(path))
}

/// [`read`] for bytes in memory: any bytes, with every length checked ([`bounded`]).
pub fn parse(bytes: &[u8]) -> Result<Bag, mcap::McapError> {
    if let Some(bag) = read_chunks_in_parallel(bytes)? {
        return Ok(bag);
    }
    let mut bag = Bag::default();
    for message in bounded::Messages::file(bytes, false) {
        take(&mut bag, &message?);
    }
    Ok(bag)
}

/// `None` when the file has no summary or not all messages are in indexed chunks.
fn read_chunks_in_parallel(bytes: &[u8]) -> Result<Option<Bag>, mcap::McapError> {
    let Some(summary) = bounded::summary(bytes)? else {
        return Ok(None);
    };
    let indexed: u64 = summary
        .chunk_indexes
        .iter()
        .map(|c| c.message_index_offsets.len() as u64)
        .sum();
    let total = summary.stats.as_ref().map(|s| s.message_count);
    if summary.chunk_indexes.is_empty() || total.is_none() || indexed == 0 {
        return Ok(None);
    }
    let mut chunks = summary.chunk_indexes.clone();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per = chunks.len().div_ceil(threads).max(1);
    let summary = &summary;
    let parts: Vec<Result<Bag, mcap::McapError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = chunks
            .chunks(per)
            .map(|group| {
                scope.spawn(move || {
                    let mut part = Bag::default();
                    for chunk in group {
                        for message in bounded::Messages::chunk(bytes, chunk, summary)? {
                            take(&mut part, &message?);
                        }
                    }
                    Ok(part)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or(Err(mcap::McapError::BadIndex)))
            .collect()
    });
    let mut bag = Bag::default();
    for part in parts {
        bag.append(part?);
    }
    let seen = bag.candidates.len() as u64
        + bag.recommendations.len() as u64
        + bag.other
        + bag.undecodable_count;
    // Messages outside chunks would be missed: then read the file front to back instead.
    Ok((Some(seen) == total).then_some(bag))
}

/// What [`recover`] salvaged.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Recovered {
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
    /// Why reading stopped, when it did not reach a clean end.
    pub stopped: Option<String>,
}

/// Copies every complete message of a recording that was cut short (a killed process, a full
/// disk) into a fresh, finished MCAP file, with the same schemas, channels and profile.
pub fn recover(broken: &Path, fixed: &Path) -> Result<Recovered, BagError> {
    let bytes = bounded::read_file(broken).map_err(io(broken))?;
    let file = File::create(fixed).map_err(io(fixed))?;
    recover_bytes(&bytes, BufWriter::new(file)).map_err(mcap_err(fixed))
}

/// [`recover`] from bytes in memory into any seekable writer; an error is the writer's (what
/// stops the reading is [`Recovered::stopped`]).
pub fn recover_bytes<W: std::io::Write + std::io::Seek>(
    bytes: &[u8],
    sink: W,
) -> Result<Recovered, mcap::McapError> {
    let profile = bounded::header(bytes)
        .map(|h| h.profile)
        .unwrap_or_default();
    let mut writer = mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!("grasp_orient recover ", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .create(sink)?;
    let mut channels: HashMap<u16, u16> = HashMap::new();
    let mut out = Recovered::default();
    for message in bounded::Messages::file(bytes, true) {
        let message = match message {
            Ok(m) => m,
            Err(e) => {
                out.stopped = Some(e.to_string());
                break;
            }
        };
        let channel = &message.channel;
        let id = match channels.get(&channel.id) {
            Some(id) => *id,
            None => {
                let schema = match &channel.schema {
                    Some(s) => writer.add_schema(&s.name, &s.encoding, &s.data)?,
                    None => 0,
                };
                let id = writer.add_channel(
                    schema,
                    &channel.topic,
                    &channel.message_encoding,
                    &channel.metadata,
                )?;
                channels.insert(channel.id, id);
                id
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: message.sequence,
            log_time: message.log_time,
            publish_time: message.publish_time,
        };
        writer.write_to_known_channel(&header, &message.data)?;
        *out.per_topic.entry(channel.topic.clone()).or_default() += 1;
    }
    writer.finish()?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{BagWriter, Entry, Payload, Topics};

    fn topics() -> Topics {
        Topics {
            candidates: "/grasp_candidates".into(),
            recommendations: "/grip_recommendations".into(),
            markers: None,
        }
    }

    fn cases() -> Vec<GraspCandidate> {
        include_str!("../../examples/paper_cases.jsonl")
            .lines()
            .map(|l| serde_json::from_str(l).expect("json"))
            .collect()
    }

    #[test]
    fn write_then_read_gives_the_same_messages() {
        let dir = std::env::temp_dir().join(format!("grasp_orient_bag_{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("round_trip.mcap");
        let mut w = BagWriter::create(&path, &topics(), 100).expect("create");
        let settings = crate::solver::Settings::default();
        for (i, c) in cases().into_iter().enumerate() {
            let a = crate::msg::answer(&c, &settings);
            let t = 1_000 + i as u64;
            w.write(&Entry {
                payload: Payload::Candidate(Box::new(c)),
                log_time: t,
                publish_time: t - 1,
            })
            .expect("write");
            w.write(&Entry {
                payload: Payload::Recommendation(Box::new(a)),
                log_time: t,
                publish_time: t,
            })
            .expect("write");
        }
        assert_eq!(w.finish().expect("finish").candidates, 4);
        let bag = read(&path).expect("read");
        assert_eq!(bag.candidates.len(), 4);
        assert_eq!(bag.recommendations.len(), 4);
        let sent = cases();
        for (got, want) in bag.candidates.iter().zip(&sent) {
            assert_eq!(&got.message, want);
        }
        assert_eq!(bag.candidates[1].publish_time, 1_000);

        // Cut the file short, as a killed process leaves it: recover keeps what is whole.
        let bytes = std::fs::read(&path).expect("read");
        let cut = dir.join("cut.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).expect("write");
        assert!(read(&cut).is_err(), "a cut file is not readable as it is");
        let fixed = dir.join("fixed.mcap");
        let got = recover(&cut, &fixed).expect("recover");
        let again = read(&fixed).expect("recovered file reads");
        assert_eq!(
            got.per_topic.values().sum::<u64>() as usize,
            again.candidates.len() + again.recommendations.len()
        );
    }
}
