//! MCAP recordings in rosbag2's conventions, and reading them back.
//!
//! A recording is one file per run: profile `ros2`; one schema per type, encoding `ros2msg`, with
//! the complete definition ([`crate::msg::definitions`]); message encoding `cdr` with the 4-byte
//! encapsulation header; channel metadata `offered_qos_profiles`; `log_time` the receive time,
//! `publish_time` the send time. Chunks are lz4-compressed and closed at least once a second, so a
//! killed process loses at most the last second ([`bag::recover`] reads the rest).
//!
//! Writing happens on its own thread: the answering loop only hands over messages, so a slow disk
//! delays the file, never the answers. [`lifecycle`] starts and stops the files of a node run as
//! its `record` parameter says.

pub mod bag;
pub mod bounded;
pub mod lifecycle;

use crate::msg::{cdr, definitions, GraspCandidate, GripRecommendation, MarkerArray};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Longest time between two flushes of the file.
pub const FLUSH_EVERY: Duration = Duration::from_secs(1);
/// How often the writer thread takes what the answering loop handed over.
const BATCH_EVERY: Duration = Duration::from_millis(10);
/// Chunk size before compression, bytes.
const CHUNK_SIZE: u64 = 1 << 20;

/// What goes wrong with a recording.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The folder or file could not be made.
    #[error("cannot create the recording {path}: {source}")]
    Create {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("MCAP error in {path}: {source}")]
    Mcap {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: mcap::McapError,
    },
    /// A message did not encode.
    #[error("cannot encode a message: {0}")]
    Encode(#[from] cdr::CdrError),
    /// The writer thread stopped.
    #[error("the recording thread panicked")]
    Thread,
}

/// One message for the recording.
#[derive(Debug, Clone)]
pub enum Payload {
    /// On the candidates topic.
    Candidate(Box<GraspCandidate>),
    /// On the recommendations topic.
    Recommendation(Box<GripRecommendation>),
    /// On the markers topic.
    Markers(Box<MarkerArray>),
}

/// A message with its times, ns since the Unix epoch.
#[derive(Debug, Clone)]
pub struct Entry {
    /// The message.
    pub payload: Payload,
    /// When it was received (or sent, for what this node publishes).
    pub log_time: u64,
    /// When its publisher sent it, where known.
    pub publish_time: u64,
}

/// Topic names of the three channels.
#[derive(Debug, Clone)]
pub struct Topics {
    /// Candidates, e.g. `/grasp_candidates`.
    pub candidates: String,
    /// Recommendations.
    pub recommendations: String,
    /// Markers; `None` leaves them out.
    pub markers: Option<String>,
}

/// Messages written per channel.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Written {
    /// Candidates.
    pub candidates: u64,
    /// Recommendations.
    pub recommendations: u64,
    /// Marker arrays.
    pub markers: u64,
}

/// A recording being written by its own thread.
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    tx: Option<mpsc::Sender<Entry>>,
    thread: Option<JoinHandle<Result<Written, RecordError>>>,
}

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// `YYYYMMDDTHHMMSSZ` of a time in ns since the epoch (UTC, proleptic Gregorian).
pub fn stamp_name(ns: u64) -> String {
    let secs = ns / 1_000_000_000;
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// rosbag2's `offered_qos_profiles` YAML (Jazzy form) for a reliable, volatile, keep-last
/// publisher with no deadline, lifespan or lease (rosbag2 writes "infinite" as the largest
/// `rmw_time_t` it can store).
pub fn qos_yaml(depth: i64) -> String {
    let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: keep_last\n  depth: {depth}\n  reliability: reliable\n  durability: volatile\n  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: automatic\n  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false\n"
    )
}

/// An MCAP writer with the three channels of a grasp_orient recording.
pub struct BagWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: [Option<u16>; 3],
    sequence: [u32; 3],
    written: Written,
}

impl std::fmt::Debug for BagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("path", &self.path)
            .field("written", &self.written)
            .finish()
    }
}

impl BagWriter {
    /// Creates `path` with the channels of `topics`.
    pub fn create(path: &Path, topics: &Topics, qos_depth: i64) -> Result<Self, RecordError> {
        let mcap_error = |source| RecordError::Mcap {
            path: path.to_path_buf(),
            source,
        };
        let file = File::create(path).map_err(|source| RecordError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("grasp_orient ", env!("CARGO_PKG_VERSION")))
            // lz4: a fraction of zstd's CPU, which on a small machine is shared with DDS.
            .compression(Some(mcap::Compression::Lz4))
            .chunk_size(Some(CHUNK_SIZE))
            .create(BufWriter::new(file))
            .map_err(mcap_error)?;
        let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), qos_yaml(qos_depth))]);
        let mut channel = |topic: &str, type_name: &str| -> Result<u16, RecordError> {
            let text = definitions::full_text(type_name).unwrap_or_default();
            let schema = writer
                .add_schema(type_name, "ros2msg", text.as_bytes())
                .map_err(mcap_error)?;
            writer
                .add_channel(schema, topic, "cdr", &metadata)
                .map_err(mcap_error)
        };
        let channels = [
            Some(channel(
                &topics.candidates,
                "grasp_orient/msg/GraspCandidate",
            )?),
            Some(channel(
                &topics.recommendations,
                "grasp_orient/msg/GripRecommendation",
            )?),
            match &topics.markers {
                Some(t) => Some(channel(t, "visualization_msgs/msg/MarkerArray")?),
                None => None,
            },
        ];
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            channels,
            sequence: [0; 3],
            written: Written::default(),
        })
    }

    fn mcap_error(&self, source: mcap::McapError) -> RecordError {
        RecordError::Mcap {
            path: self.path.clone(),
            source,
        }
    }

    /// Writes one message (markers are dropped when the recording has no markers channel).
    pub fn write(&mut self, entry: &Entry) -> Result<(), RecordError> {
        let (index, bytes) = match &entry.payload {
            Payload::Candidate(m) => (0, cdr::encode(m.as_ref())?),
            Payload::Recommendation(m) => (1, cdr::encode(m.as_ref())?),
            Payload::Markers(m) => (2, cdr::encode(m.as_ref())?),
        };
        let Some(channel_id) = self.channels[index] else {
            return Ok(());
        };
        self.sequence[index] = self.sequence[index].wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence[index],
            log_time: entry.log_time,
            publish_time: entry.publish_time,
        };
        self.writer
            .write_to_known_channel(&header, &bytes)
            .map_err(|e| self.mcap_error(e))?;
        match index {
            0 => self.written.candidates += 1,
            1 => self.written.recommendations += 1,
            _ => self.written.markers += 1,
        }
        Ok(())
    }

    /// Closes the current chunk and hands the bytes to the OS.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush().map_err(|e| self.mcap_error(e))
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<Written, RecordError> {
        self.writer.finish().map_err(|e| self.mcap_error(e))?;
        Ok(self.written)
    }
}

impl Recorder {
    /// Starts a recording in `dir` (created if missing), named by the start time.
    pub fn start(dir: &Path, topics: Topics, qos_depth: i64) -> Result<Self, RecordError> {
        std::fs::create_dir_all(dir).map_err(|source| RecordError::Create {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(format!("grasp_orient_{}.mcap", stamp_name(now_ns())));
        let mut bag = BagWriter::create(&path, &topics, qos_depth)?;
        let (tx, rx) = mpsc::channel::<Entry>();
        let thread = std::thread::Builder::new()
            .name("grasp_orient-record".into())
            .spawn(move || {
                // Wake every BATCH_EVERY and write what has come, rather than once per message:
                // on a small machine the answering path and DDS keep the cores.
                let mut last_flush = Instant::now();
                let mut dirty = false;
                loop {
                    std::thread::sleep(BATCH_EVERY);
                    let mut open = true;
                    loop {
                        match rx.try_recv() {
                            Ok(entry) => {
                                bag.write(&entry)?;
                                dirty = true;
                            }
                            Err(mpsc::TryRecvError::Empty) => break,
                            Err(mpsc::TryRecvError::Disconnected) => {
                                open = false;
                                break;
                            }
                        }
                    }
                    if !open {
                        break;
                    }
                    if last_flush.elapsed() >= FLUSH_EVERY {
                        if dirty {
                            bag.flush()?;
                            dirty = false;
                        }
                        last_flush = Instant::now();
                    }
                }
                bag.finish()
            })
            .map_err(|source| RecordError::Create {
                path: path.clone(),
                source,
            })?;
        Ok(Self {
            path,
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Hands a message to the writer; never blocks. Returns false once the writer has stopped
    /// (its error comes out of [`Recorder::finish`]).
    pub fn record(&self, entry: Entry) -> bool {
        self.tx.as_ref().is_some_and(|tx| tx.send(entry).is_ok())
    }

    /// Writes everything handed over, closes the file, and says how much it holds.
    pub fn finish(mut self) -> Result<Written, RecordError> {
        drop(self.tx.take());
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(result)) => result,
            Some(Err(_)) => Err(RecordError::Thread),
            None => Ok(Written::default()),
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        drop(self.tx.take());
        if let Some(thread) = self.thread.take() {
            if let Ok(Err(e)) = thread.join() {
                log::error!("recording {}: {e}", self.path.display());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamp_names_are_utc_dates() {
        assert_eq!(stamp_name(0), "19700101T000000Z");
        // 2026-11-22 05:40:00 UTC
        assert_eq!(
            stamp_name(1_795_326_000 * 1_000_000_000),
            "20261122T054000Z"
        );
        assert_eq!(stamp_name(951_782_400 * 1_000_000_000), "20000229T000000Z");
    }
}
