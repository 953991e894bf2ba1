//! MCAP recordings in rosbag2's conventions, and reading them back.
//!
//! A recording is one file per run: profile `ros2`; one schema per type, encoding `ros2msg`, with
//! the complete definition exactly as rosbag2 writes it ([`crate::msg::definitions`]); message
//! encoding `cdr` with the 4-byte encapsulation header; channel metadata `offered_qos_profiles`;
//! `log_time` the receive time, `publish_time` the send time; the settings in force as metadata
//! ([`settings`]). Chunks are lz4-compressed and closed about once a second (on saturated cores
//! a little later, [`pump`]), so a killed process loses about the last second ([`recover`] reads
//! the rest).
//!
//! Files are never truncated or shared: a recording is created new (`O_EXCL`) under a name
//! carrying the node's name and the start time, with a numeric suffix on a clash
//! ([`Recorder::start`]); commands write their outputs beside the destination and rename them
//! into place when complete ([`output`]).
//!
//! Writing happens on threads of its own ([`pump`]: a writer at idle priority, and a rescuer for
//! when the cores are saturated): the answering loop only hands over messages, so a slow disk
//! delays the file, never the answers. When a write fails (a full disk), the file is cut back to
//! its last complete flush and closed there, so what it holds stays readable, and the recording
//! stops with the cause ([`RecordError::Stopped`]). [`lifecycle`] starts and stops the files of
//! a node run as its `record` parameters say.

pub mod bag;
pub(crate) mod channels;
pub(crate) mod lifecycle;
#[cfg(test)]
mod mcap_crate;
pub(crate) mod output;
mod pump;
pub mod recover;
pub(crate) mod scan;
pub mod settings;
mod sink;

pub use channels::{IncompatibleChannel, RecordedFields};
pub use output::OutputError;
pub use scan::chunk::decompressed_limit;
pub use scan::frame::Damage;

use crate::kind::{self, Kind, Visit};
use crate::msg::{cdr, definitions, MarkerArray, RosMessage};
use settings::{SettingsRecord, METADATA_NAME};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::BufWriter;
use std::path::{Path, PathBuf};
#[cfg(test)]
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
#[cfg(test)]
use std::time::Instant;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Longest time between two flushes of the file.
pub(crate) const FLUSH_EVERY: Duration = Duration::from_secs(1);
/// Chunk size before compression, bytes.
const CHUNK_SIZE: u64 = 1 << 20;

/// What goes wrong with a recording.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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
    #[error("MCAP error in {path}: {}", with_causes(source))]
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
    /// A type has no complete definition in [`definitions::DEFINITIONS`].
    #[error("no message definition for {0}")]
    UnknownType(&'static str),
    /// The file was closed after a failure, and takes nothing more.
    #[error("recording {path} was stopped by an earlier failure")]
    AlreadyStopped {
        /// The file.
        path: PathBuf,
    },
    /// Writing failed part way (a full disk): the file was cut back to its last complete flush
    /// and closed there, if that could be done.
    #[error("recording {path} stopped: {cause}; {}", closed_words(kept, closed))]
    Stopped {
        /// The file.
        path: PathBuf,
        /// Why writing failed.
        cause: Box<RecordError>,
        /// What the file holds now.
        kept: Written,
        /// Whether the file could be closed at its last flush (`Err` says why not).
        closed: Result<(), std::io::Error>,
    },
}

/// An error and its causes, `: `-separated (the MCAP writer's I/O errors hide the OS's words
/// one level down).
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let words = c.to_string();
        if !text.contains(&words) {
            text = format!("{text}: {words}");
        }
        cause = c.source();
    }
    text
}

fn closed_words(kept: &Written, closed: &Result<(), std::io::Error>) -> String {
    match closed {
        Ok(()) => format!(
            "the file was closed at its last complete flush and holds {} candidates, {} \
             recommendations, {} marker arrays",
            kept.requests::<crate::kind::Candidates>(),
            kept.answers::<crate::kind::Candidates>(),
            kept.markers
        ),
        Err(why) => format!(
            "the file could not be closed ({why}); up to its last complete flush it holds {} \
             candidates, {} recommendations, {} marker arrays, which `grasp_orient recover` \
             copies into a closed file",
            kept.requests::<crate::kind::Candidates>(),
            kept.answers::<crate::kind::Candidates>(),
            kept.markers
        ),
    }
}

/// One message for the recording: a request or an answer of one kind ([`crate::kind`]), a
/// marker array, or the settings in force from a time on.
#[derive(Debug, Clone)]
pub struct Payload(Carried);

/// What a [`Payload`] carries.
#[derive(Debug, Clone)]
enum Carried {
    /// A request or an answer, on its kind's channel.
    Message(kind::Channel, Arc<dyn Encode>),
    /// On the markers topic.
    Markers(Box<MarkerArray>),
    /// Written as a metadata record (the entry's times are not used).
    Settings(Box<SettingsRecord>),
}

impl Payload {
    /// A request of kind `K`.
    pub fn request<K: Kind>(message: K::Request) -> Self {
        Payload(Carried::Message(
            kind::Channel::request::<K>(),
            Arc::new(message),
        ))
    }

    /// An answer of kind `K`.
    pub fn answer<K: Kind>(message: K::Answer) -> Self {
        Payload(Carried::Message(
            kind::Channel::answer::<K>(),
            Arc::new(message),
        ))
    }

    /// A marker array, on the markers topic.
    pub(crate) fn markers(markers: MarkerArray) -> Self {
        Payload(Carried::Markers(Box::new(markers)))
    }

    /// The settings in force from `settings.since` on, written as a metadata record (the
    /// entry's times are not used).
    pub fn settings(settings: SettingsRecord) -> Self {
        Payload(Carried::Settings(Box::new(settings)))
    }
}

/// A message the recording's writer thread encodes as CDR.
pub(crate) trait Encode: std::fmt::Debug + Send + Sync {
    /// The message as encapsulated CDR.
    fn encode(&self) -> Result<Vec<u8>, cdr::CdrError>;
}

impl<T: serde::Serialize + std::fmt::Debug + Send + Sync> Encode for T {
    fn encode(&self) -> Result<Vec<u8>, cdr::CdrError> {
        cdr::encode(self)
    }
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

/// Topic names of a recording's channels: each kind's requests and answers, and the markers; a
/// channel without a name is left out.
#[derive(Debug, Clone, Default)]
pub struct Topics {
    /// By [`kind::Channel::slot`].
    names: [Option<String>; kind::Channel::COUNT],
    /// Markers; `None` leaves them out.
    pub markers: Option<String>,
}

impl Topics {
    /// Candidates and their recommendations on these topics, and no other channel.
    pub fn new(candidates: impl Into<String>, recommendations: impl Into<String>) -> Self {
        Self::default().with::<kind::Candidates>(candidates, recommendations)
    }

    /// Every kind on the node's default topics (`/grasp_candidates`, ...), markers left out.
    pub(crate) fn default_names() -> Self {
        Self::named(|base| format!("/{base}"))
    }

    /// Every kind on the topics `name` gives each base name of [`Kind::TOPICS`] (the node's
    /// namespace and remappings), markers left out.
    pub(crate) fn named(name: impl Fn(&str) -> String) -> Self {
        struct All<F>(Topics, F);
        impl<F: Fn(&str) -> String> Visit for All<F> {
            fn kind<K: Kind>(&mut self) {
                let [request, answer] = K::TOPICS.map(|t| (self.1)(t));
                self.0 = std::mem::take(&mut self.0).with::<K>(request, answer);
            }
        }
        let mut all = All(Self::default(), name);
        kind::each(&mut all);
        all.0
    }

    /// With kind `K`'s requests and answers on these topics.
    pub fn with<K: Kind>(
        mut self,
        requests: impl Into<String>,
        answers: impl Into<String>,
    ) -> Self {
        self.names[kind::Channel::request::<K>().slot()] = Some(requests.into());
        self.names[kind::Channel::answer::<K>().slot()] = Some(answers.into());
        self
    }

    /// With the markers on `topic`.
    pub(crate) fn with_markers(mut self, topic: impl Into<String>) -> Self {
        self.markers = Some(topic.into());
        self
    }

    /// The topic of `channel`, if the recording has it.
    pub(crate) fn of(&self, channel: kind::Channel) -> Option<&str> {
        self.names[channel.slot()].as_deref()
    }

    /// The topic of kind `K`'s requests, if the recording has it.
    pub(crate) fn requests<K: Kind>(&self) -> Option<&str> {
        self.of(kind::Channel::request::<K>())
    }

    /// The topic of kind `K`'s answers, if the recording has it.
    pub(crate) fn answers<K: Kind>(&self) -> Option<&str> {
        self.of(kind::Channel::answer::<K>())
    }
}

/// Messages written per channel, and settings records.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Written {
    /// By [`kind::Channel::slot`].
    messages: [u64; kind::Channel::COUNT],
    /// Marker arrays.
    pub markers: u64,
    /// Settings metadata records.
    pub settings: u64,
}

impl Written {
    /// Messages written on `channel`.
    pub(crate) fn of(&self, channel: kind::Channel) -> u64 {
        self.messages[channel.slot()]
    }

    /// Requests of kind `K` written.
    pub fn requests<K: Kind>(&self) -> u64 {
        self.of(kind::Channel::request::<K>())
    }

    /// Answers of kind `K` written.
    pub fn answers<K: Kind>(&self) -> u64 {
        self.of(kind::Channel::answer::<K>())
    }
}

/// Nanoseconds since the Unix epoch, now.
pub(crate) fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// `YYYYMMDDTHHMMSSZ` of a time in ns since the epoch (UTC, proleptic Gregorian).
pub(crate) fn stamp_name(ns: u64) -> String {
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

/// The part of a recording's name that names its node: the full name without its leading
/// slash, namespaces joined by `__` (which no ROS name contains, so two nodes never share it),
/// e.g. `/arm/grasp_orient` gives `arm__grasp_orient`.
pub(crate) fn node_stem(node: &str) -> String {
    let stem = node.trim_start_matches('/').replace('/', "__");
    if stem.is_empty() {
        "grasp_orient".to_string()
    } else {
        stem
    }
}

/// rosbag2's `offered_qos_profiles` YAML (Jazzy form) for a reliable, volatile, keep-last
/// publisher with no deadline, lifespan or lease (rosbag2 writes "infinite" as the largest
/// `rmw_time_t` it can store).
pub(crate) fn qos_yaml(depth: i64) -> String {
    let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: keep_last\n  depth: {depth}\n  reliability: reliable\n  durability: volatile\n  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: automatic\n  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false\n"
    )
}

/// Channels of a recording: each kind's requests and answers ([`kind::Channel::slot`]), then the
/// markers.
const CHANNELS: usize = kind::Channel::COUNT + 1;
/// The markers' place among the channels.
const MARKERS: usize = kind::Channel::COUNT;

/// An MCAP writer with the channels of a grasp_orient recording. It never truncates a file:
/// [`BagWriter::create`] makes a new one, [`BagWriter::on_file`] takes an open one (a temporary
/// file beside the destination). When a write fails, the file is cut back to its last complete
/// flush and closed there ([`RecordError::Stopped`]).
pub struct BagWriter {
    path: PathBuf,
    writer: Option<mcap::Writer<BufWriter<sink::Sink>>>,
    sink: Arc<sink::State>,
    /// The topics of the channels made by their first message.
    topics: Topics,
    /// Channel metadata (`offered_qos_profiles`).
    metadata: BTreeMap<String, String>,
    channels: [Option<u16>; CHANNELS],
    sequence: [u32; CHANNELS],
    written: Written,
    /// Where the last complete flush ended, and what the file held then.
    committed: (u64, Written),
    /// The schemas and channels written, for the summary of a file closed after a failure.
    definitions: sink::Definitions,
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
    /// Creates `path`, which must not exist yet, with the channels of `topics`.
    pub fn create(path: &Path, topics: &Topics, qos_depth: i64) -> Result<Self, RecordError> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(|source| RecordError::Create {
                path: path.to_path_buf(),
                source,
            })?;
        Self::on_file(file, path, topics, qos_depth)
    }

    /// Writes into `file` (empty, opened for writing), known to the user as `path`.
    pub(crate) fn on_file(
        file: File,
        path: &Path,
        topics: &Topics,
        qos_depth: i64,
    ) -> Result<Self, RecordError> {
        Self::on_sink(sink::Sink::new(file), path, topics, qos_depth)
    }

    fn on_sink(
        sink: sink::Sink,
        path: &Path,
        topics: &Topics,
        qos_depth: i64,
    ) -> Result<Self, RecordError> {
        let mcap_error = |source| RecordError::Mcap {
            path: path.to_path_buf(),
            source,
        };
        let state = sink.state();
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("grasp_orient ", env!("CARGO_PKG_VERSION")))
            // lz4: a fraction of zstd's CPU, which on a small machine is shared with DDS.
            .compression(Some(mcap::Compression::Lz4))
            .chunk_size(Some(CHUNK_SIZE))
            // Chunks are built in memory and written whole: the file never holds half of one
            // with a provisional header.
            .disable_seeking(true)
            .create(BufWriter::new(sink))
            .map_err(mcap_error)?;
        let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), qos_yaml(qos_depth))]);
        let mut defs = sink::Definitions::default();
        let mut channel = |topic: &str, type_name: &'static str| -> Result<u16, RecordError> {
            let text =
                definitions::full_text(type_name).ok_or(RecordError::UnknownType(type_name))?;
            let schema = writer
                .add_schema(type_name, "ros2msg", text.as_bytes())
                .map_err(mcap_error)?;
            let id = writer
                .add_channel(schema, topic, "cdr", &metadata)
                .map_err(mcap_error)?;
            defs.schemas.push(sink::SchemaDef {
                id: schema,
                name: type_name.to_string(),
                encoding: "ros2msg".to_string(),
                data: text.into_bytes(),
            });
            defs.channels.push(sink::ChannelDef {
                id,
                schema_id: schema,
                topic: topic.to_string(),
                encoding: "cdr".to_string(),
                metadata: metadata.clone(),
            });
            Ok(id)
        };
        // The channels of the kinds the node always has, then the markers, are made now; the
        // others by their first message, as rosbag2 adds a topic when it first sees a
        // publisher: a run without sets records no set channels.
        let mut channels = [None; CHANNELS];
        for (c, type_name, at_start) in kind::Channel::all() {
            if let Some(topic) = topics.of(c).filter(|_| at_start) {
                channels[c.slot()] = Some(channel(topic, type_name)?);
            }
        }
        if let Some(t) = &topics.markers {
            channels[MARKERS] = Some(channel(t, MarkerArray::TYPE_NAME)?);
        }
        // The file on disk is at once a readable start of a recording.
        writer.flush().map_err(mcap_error)?;
        Ok(Self {
            path: path.to_path_buf(),
            committed: (state.position(), Written::default()),
            writer: Some(writer),
            sink: state,
            topics: topics.clone(),
            metadata,
            channels,
            sequence: [0; CHANNELS],
            written: Written::default(),
            definitions: defs,
        })
    }

    /// The file being written.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Cuts the file back to its last complete flush, closes it there, and says so with
    /// `cause`. Nothing more is written.
    fn stop(&mut self, cause: RecordError) -> RecordError {
        if matches!(cause, RecordError::Stopped { .. }) {
            return cause;
        }
        // The MCAP writer's own clean-up must not write after the failure.
        self.sink.refuse_writes();
        drop(self.writer.take());
        let (length, kept) = self.committed;
        let closed = sink::close_at(&self.path, length, &self.definitions);
        RecordError::Stopped {
            path: self.path.clone(),
            cause: Box::new(cause),
            kept,
            closed,
        }
    }

    fn mcap_failed(&mut self, source: mcap::McapError) -> RecordError {
        let cause = RecordError::Mcap {
            path: self.path.clone(),
            source,
        };
        self.stop(cause)
    }

    /// The MCAP writer, while the file is open. (The error is made only when it is needed: it
    /// had cost every message a copy of the path, made and dropped.)
    fn writer(&mut self) -> Result<&mut mcap::Writer<BufWriter<sink::Sink>>, RecordError> {
        let path = &self.path;
        self.writer
            .as_mut()
            .ok_or_else(|| RecordError::AlreadyStopped { path: path.clone() })
    }

    /// Writes one message (dropped when the recording has no channel for it), or a settings
    /// record (after which the file is flushed).
    pub fn write(&mut self, entry: &Entry) -> Result<(), RecordError> {
        let (index, bytes) = match &entry.payload.0 {
            Carried::Message(channel, m) => (channel.slot(), m.encode()?),
            Carried::Markers(m) => (MARKERS, cdr::encode(m.as_ref())?),
            Carried::Settings(s) => return self.write_settings(s),
        };
        if index != MARKERS && self.channels[index].is_none() {
            self.add_lazy_channel(index)?;
        }
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
        if let Err(e) = self.writer()?.write_to_known_channel(&header, &bytes) {
            return Err(self.mcap_failed(e));
        }
        match self.written.messages.get_mut(index) {
            Some(n) => *n += 1,
            None => self.written.markers += 1,
        }
        Ok(())
    }

    /// Makes the channel of slot `index` on its first message, if the recording has it; it
    /// joins the definitions a file closed after a failure is summarised with.
    fn add_lazy_channel(&mut self, index: usize) -> Result<(), RecordError> {
        let Some((c, type_name, _)) = kind::Channel::all().get(index).copied() else {
            return Ok(());
        };
        let Some(topic) = self.topics.of(c).map(str::to_string) else {
            return Ok(());
        };
        let text = definitions::full_text(type_name).ok_or(RecordError::UnknownType(type_name))?;
        let metadata = self.metadata.clone();
        let schema = match self
            .writer()?
            .add_schema(type_name, "ros2msg", text.as_bytes())
        {
            Ok(id) => id,
            Err(e) => return Err(self.mcap_failed(e)),
        };
        let id = match self.writer()?.add_channel(schema, &topic, "cdr", &metadata) {
            Ok(id) => id,
            Err(e) => return Err(self.mcap_failed(e)),
        };
        self.definitions.schemas.push(sink::SchemaDef {
            id: schema,
            name: type_name.to_string(),
            encoding: "ros2msg".to_string(),
            data: text.into_bytes(),
        });
        self.definitions.channels.push(sink::ChannelDef {
            id,
            schema_id: schema,
            topic,
            encoding: "cdr".to_string(),
            metadata,
        });
        self.channels[index] = Some(id);
        Ok(())
    }

    fn write_settings(&mut self, settings: &SettingsRecord) -> Result<(), RecordError> {
        let record = mcap::records::Metadata {
            name: METADATA_NAME.to_string(),
            metadata: settings.to_metadata(),
        };
        if let Err(e) = self.writer()?.write_metadata(&record) {
            return Err(self.mcap_failed(e));
        }
        self.written.settings += 1;
        self.flush()
    }

    /// Closes the current chunk and hands the bytes to the OS.
    pub(crate) fn flush(&mut self) -> Result<(), RecordError> {
        if let Err(e) = self.writer()?.flush() {
            return Err(self.mcap_failed(e));
        }
        self.committed = (self.sink.position(), self.written);
        Ok(())
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<Written, RecordError> {
        self.flush()?;
        if let Err(e) = self.writer()?.finish() {
            return Err(self.mcap_failed(e));
        }
        drop(self.writer.take());
        Ok(self.written)
    }
}

/// A recording being written by its own threads ([`pump`]).
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    writers: pump::Writers,
}

/// Called from a writer thread when it stops on a failure.
pub(crate) type OnStop = Arc<dyn Fn() + Send + Sync>;

impl Recorder {
    /// Starts a recording in `dir` (created if missing) for node `node` (its full name): a new
    /// file `<node>_<UTC start>.mcap` ([`node_stem`], [`stamp_name`]), `_1`, `_2`, ... added
    /// when that name is taken. `on_stop` hears when writing fails.
    pub fn start(
        dir: &Path,
        node: &str,
        topics: Topics,
        qos_depth: i64,
        on_stop: OnStop,
    ) -> Result<Self, RecordError> {
        std::fs::create_dir_all(dir).map_err(|source| RecordError::Create {
            path: dir.to_path_buf(),
            source,
        })?;
        let (file, path) = create_unique(dir, &node_stem(node), &stamp_name(now_ns()))?;
        let bag = BagWriter::on_file(file, &path, &topics, qos_depth)?;
        Self::spawn(bag, on_stop)
    }

    fn spawn(bag: BagWriter, on_stop: OnStop) -> Result<Self, RecordError> {
        let path = bag.path().to_path_buf();
        let writers = pump::Writers::start(bag, on_stop).map_err(|source| RecordError::Create {
            path: path.clone(),
            source,
        })?;
        Ok(Self { path, writers })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the writer stopped on a failure ([`Recorder::finish`] gives it).
    pub(crate) fn has_stopped(&self) -> bool {
        self.writers.has_stopped()
    }

    /// Hands a message to the writer; never blocks. Returns false once the writer has stopped
    /// (its error comes out of [`Recorder::finish`]).
    pub fn record(&self, entry: Entry) -> bool {
        self.record_all(vec![entry])
    }

    /// Hands messages to the writer to be written together (no flush falls between them, so a
    /// candidate and its answer are both in the file or neither is); never blocks.
    pub(crate) fn record_all(&self, entries: Vec<Entry>) -> bool {
        self.writers.hand_over(entries)
    }

    /// Writes everything handed over, closes the file, and says how much it holds.
    pub fn finish(mut self) -> Result<Written, RecordError> {
        self.writers.finish()
    }
}

/// Creates `<stem>_<stamp>.mcap` in `dir`, or `<stem>_<stamp>_<n>.mcap` for the first free `n`,
/// never opening an existing file.
fn create_unique(dir: &Path, stem: &str, stamp: &str) -> Result<(File, PathBuf), RecordError> {
    let mut last = None;
    for n in 0..10_000u32 {
        let name = if n == 0 {
            format!("{stem}_{stamp}.mcap")
        } else {
            format!("{stem}_{stamp}_{n}.mcap")
        };
        let path = dir.join(name);
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(file) => return Ok((file, path)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(path),
            Err(source) => return Err(RecordError::Create { path, source }),
        }
    }
    Err(RecordError::Create {
        path: last.unwrap_or_else(|| dir.to_path_buf()),
        source: std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            "10,000 recordings of this node started in the same second",
        ),
    })
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

    #[test]
    fn node_names_make_distinct_file_names() {
        assert_eq!(node_stem("/grasp_orient"), "grasp_orient");
        assert_eq!(
            node_stem("/arm/left/grasp_orient"),
            "arm__left__grasp_orient"
        );
        assert_ne!(
            node_stem("/arm/grasp_orient"),
            node_stem("/arm_grasp/orient")
        );
        assert_eq!(node_stem(""), "grasp_orient");
    }

    #[test]
    fn a_new_recording_never_opens_an_existing_file() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let taken = dir.path().join("taken.mcap");
        std::fs::write(&taken, b"precious").expect("write");
        let e = BagWriter::create(&taken, &topics(), 100).expect_err("exists");
        assert!(matches!(e, RecordError::Create { .. }), "{e}");
        assert_eq!(std::fs::read(&taken).expect("read"), b"precious");
        let (_, a) = create_unique(dir.path(), "n", "20260101T000000Z").expect("first");
        let (_, b) = create_unique(dir.path(), "n", "20260101T000000Z").expect("second");
        let (_, c) = create_unique(dir.path(), "n", "20260101T000000Z").expect("third");
        let names: Vec<_> = [a, b, c]
            .iter()
            .map(|p| p.file_name().expect("named").to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "n_20260101T000000Z.mcap",
                "n_20260101T000000Z_1.mcap",
                "n_20260101T000000Z_2.mcap"
            ]
        );
    }

    /// The candidate and answer channels only (for the record module's tests).
    pub(super) fn topics() -> Topics {
        Topics::new("/grasp_candidates", "/grip_recommendations")
    }

    /// Paper case `i % 4` as a candidate received at `i` ns.
    pub(super) fn candidate(i: usize) -> Entry {
        let c = crate::msg::paper_cases().swap_remove(i % 4);
        Entry {
            payload: Payload::request::<kind::Candidates>(c),
            log_time: i as u64,
            publish_time: i as u64,
        }
    }

    /// A full disk, as the file system answers it (ENOSPC past a size): the writer stops with
    /// the cause, and the file is closed at its last flush, readable, with what it says.
    #[test]
    fn a_full_disk_closes_the_file_at_its_last_flush() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("full.mcap");
        let mut bag = BagWriter::create(&path, &topics(), 100).expect("create");
        let start = bag.sink.position();
        bag.sink.fail_past(start + 64 * 1024);
        let mut error = None;
        for i in 0..100_000 {
            if let Err(e) = bag.write(&candidate(i)) {
                error = Some(e);
                break;
            }
            if i % 100 == 99 {
                if let Err(e) = bag.flush() {
                    error = Some(e);
                    break;
                }
            }
        }
        let Some(RecordError::Stopped {
            cause,
            kept,
            closed,
            ..
        }) = error
        else {
            panic!("expected the recording to stop, got {error:?}");
        };
        assert!(
            cause.to_string().contains("No space left on device"),
            "{cause}"
        );
        assert!(closed.is_ok(), "{closed:?}");
        assert!(
            kept.requests::<crate::kind::Candidates>() >= 100
                && kept.requests::<crate::kind::Candidates>() % 100 == 0,
            "{kept:?}"
        );
        let back = bag::read(&path).expect("the closed file reads as it is");
        assert_eq!(
            back.streams.candidates.requests.len() as u64,
            kept.requests::<crate::kind::Candidates>()
        );
        // Closed as the MCAP writer would have: both CRCs, and a summary that counts it all.
        let bytes = std::fs::read(&path).expect("read");
        let closed = scan::scan(&bytes).expect("an MCAP file");
        assert!(
            closed.data_verified && closed.summary_verified,
            "{closed:?}"
        );
        assert_eq!(closed.summary_channels.len(), 2);
        let (count, per_channel) = closed.statistics.expect("statistics");
        assert_eq!(count, kept.requests::<crate::kind::Candidates>());
        assert_eq!(
            per_channel.values().sum::<u64>(),
            kept.requests::<crate::kind::Candidates>()
        );
        assert!(bag.write(&candidate(0)).is_err(), "nothing more is written");
        drop(bag);
        assert_eq!(
            bag::read(&path)
                .expect("still whole")
                .streams
                .candidates
                .requests
                .len() as u64,
            kept.requests::<crate::kind::Candidates>(),
            "dropping the writer after the failure writes nothing"
        );
    }

    /// A file-size limit the last flush ended too near for the summary (some kilobytes: it
    /// repeats the schemas): the close fails and says why, the file is cut back to that flush,
    /// and `recover` copies every candidate it held. With room, the same bytes close.
    #[test]
    fn a_close_with_no_room_for_the_summary_leaves_the_file_at_its_last_flush() {
        /// An in-memory file whose writes fail past `limit` bytes, as under `RLIMIT_FSIZE`.
        struct Limited {
            bytes: std::io::Cursor<Vec<u8>>,
            limit: u64,
        }
        impl std::io::Read for Limited {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                self.bytes.read(buf)
            }
        }
        impl std::io::Seek for Limited {
            fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
                self.bytes.seek(pos)
            }
        }
        impl std::io::Write for Limited {
            fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
                let room = self.limit.saturating_sub(self.bytes.position());
                if room == 0 {
                    return Err(std::io::ErrorKind::FileTooLarge.into());
                }
                let n = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
                self.bytes.write(&buf[..n])
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        impl sink::Cut for Limited {
            fn cut(&mut self, length: u64) -> std::io::Result<()> {
                let length = usize::try_from(length).expect("in memory");
                self.bytes.get_mut().resize(length, 0);
                Ok(())
            }
            fn sync(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }

        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("limited.mcap");
        let mut bag = BagWriter::create(&path, &topics(), 100).expect("create");
        for i in 0..300 {
            bag.write(&candidate(i)).expect("written");
            if i % 100 == 99 {
                bag.flush().expect("flushed");
            }
        }
        let (length, kept) = bag.committed;
        assert_eq!(kept.requests::<crate::kind::Candidates>(), 300);
        let at_flush = std::fs::read(&path).expect("read")[..length as usize].to_vec();
        let defs = bag.definitions.clone();
        drop(bag);

        let mut file = Limited {
            bytes: std::io::Cursor::new(at_flush.clone()),
            limit: length + 100,
        };
        let e = sink::close(&mut file, length, &defs).expect_err("no room for the summary");
        assert_eq!(e.kind(), std::io::ErrorKind::FileTooLarge);
        assert_eq!(
            file.bytes.get_ref().as_slice(),
            at_flush.as_slice(),
            "cut back to the last flush, nothing of the end left"
        );
        let (got, _) = recover::recover_bytes(file.bytes.get_ref(), std::io::Cursor::new(vec![]))
            .expect("recovers");
        assert_eq!(got.kept.get("/grasp_candidates"), Some(&300), "{got:?}");
        assert!(!got.lost_anything(), "recover exits 0 on it: {got:?}");

        let mut roomy = Limited {
            bytes: std::io::Cursor::new(at_flush),
            limit: u64::MAX,
        };
        sink::close(&mut roomy, length, &defs).expect("closed");
        let closed = scan::scan(roomy.bytes.get_ref()).expect("an MCAP file");
        assert!(
            closed.data_verified && closed.summary_verified,
            "{closed:?}"
        );
        assert_eq!(closed.statistics.map(|(n, _)| n), Some(300));
        let text = RecordError::Stopped {
            path: path.clone(),
            cause: Box::new(RecordError::AlreadyStopped { path }),
            kept,
            closed: Err(e),
        }
        .to_string();
        assert!(
            text.contains("could not be closed") && text.contains("holds 300 candidates"),
            "{text}"
        );
    }

    /// The writer thread on a full disk: it stops, says so once through `on_stop`, and its
    /// error names the cause and what the closed file holds.
    #[test]
    fn a_recorder_on_a_full_disk_stops_and_says_so_once() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("full.mcap");
        let bag = BagWriter::create(&path, &topics(), 100).expect("create");
        bag.sink.fail_past(bag.sink.position() + 32 * 1024);
        let calls = Arc::new(AtomicU64::new(0));
        let counter = calls.clone();
        let recorder = Recorder::spawn(
            bag,
            Arc::new(move || {
                counter.fetch_add(1, Ordering::SeqCst);
            }),
        )
        .expect("spawned");
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut i = 0;
        while !recorder.has_stopped() && Instant::now() < deadline {
            for _ in 0..200 {
                recorder.record(candidate(i));
                i += 1;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(recorder.has_stopped(), "never stopped after {i} candidates");
        assert!(
            !recorder.record(candidate(0)),
            "a stopped writer takes nothing"
        );
        let e = recorder.finish().expect_err("stopped");
        assert_eq!(calls.load(Ordering::SeqCst), 1);
        let text = e.to_string();
        assert!(
            text.contains("No space left on device")
                && text.contains("closed at its last complete flush"),
            "{text}"
        );
        bag::read(&path).expect("the file reads as it is");
    }
}
