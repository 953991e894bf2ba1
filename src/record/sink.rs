//! The file under a recording, and closing one whose writing failed.
//!
//! [`Sink`] passes writes to the file and keeps count of where it is, so that the recording
//! knows where its last complete flush ended. Once a write has failed it takes nothing more:
//! the MCAP writer tries to finish the file when it is dropped, and must not write a summary
//! after a half-written chunk. [`close_at`] then cuts the file back to the last complete flush
//! and ends it as the MCAP writer would have: a data end record with the data section's CRC, a
//! summary (schemas, channels, statistics, chunk and metadata indexes, summary offsets) built
//! from the records the file holds, the footer with the summary's CRC, the magic. Every reader
//! then opens what was written, indexed (`rosbags` refuses unindexed files whose messages are
//! not in time order, as a node's recording is not: an answer is logged after the next
//! candidate may have been received). When there is no room for that end, the file is left
//! ending at its last complete flush, for `grasp_orient recover` ([`close`]).

use super::scan::{op, MAGIC};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// What a [`Sink`] shares with its recording.
#[derive(Debug, Default)]
pub(super) struct State {
    position: AtomicU64,
    refused: AtomicBool,
    /// Tests: writes past this many bytes fail as on a full disk.
    limit: AtomicU64,
}

impl State {
    /// Bytes written so far (the position after the last write).
    pub(super) fn position(&self) -> u64 {
        self.position.load(Ordering::SeqCst)
    }

    /// From now on every write fails.
    pub(super) fn refuse_writes(&self) {
        self.refused.store(true, Ordering::SeqCst);
    }

    /// Writes past `bytes` fail with "no space left on device" (for tests of a full disk).
    #[cfg(test)]
    pub(super) fn fail_past(&self, bytes: u64) {
        self.limit.store(bytes, Ordering::SeqCst);
    }
}

/// A recording's file: counts its position, and refuses every write after the first failure.
#[derive(Debug)]
pub(super) struct Sink {
    file: File,
    state: Arc<State>,
}

impl Sink {
    /// Writes into `file` from its start.
    pub(super) fn new(file: File) -> Self {
        Self {
            file,
            state: Arc::new(State {
                limit: AtomicU64::new(u64::MAX),
                ..State::default()
            }),
        }
    }

    /// Its state, to look at from the recording.
    pub(super) fn state(&self) -> Arc<State> {
        self.state.clone()
    }

    fn failed(&self, e: std::io::Error) -> std::io::Error {
        self.state.refuse_writes();
        e
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.state.refused.load(Ordering::SeqCst) {
            return Err(std::io::Error::other(
                "an earlier write to this file failed",
            ));
        }
        let position = self.state.position();
        let room = self
            .state
            .limit
            .load(Ordering::SeqCst)
            .saturating_sub(position);
        if room == 0 && !buf.is_empty() {
            // ENOSPC, as a full disk answers.
            return Err(self.failed(std::io::Error::from_raw_os_error(28)));
        }
        let buf = &buf[..buf.len().min(usize::try_from(room).unwrap_or(usize::MAX))];
        match self.file.write(buf) {
            Ok(n) => {
                self.state
                    .position
                    .store(position + n as u64, Ordering::SeqCst);
                Ok(n)
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush().map_err(|e| self.failed(e))
    }
}

impl Seek for Sink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        let at = self.file.seek(pos).map_err(|e| self.failed(e))?;
        self.state.position.store(at, Ordering::SeqCst);
        Ok(at)
    }
}

/// A schema the recording defined.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct SchemaDef {
    /// Its id.
    pub(crate) id: u16,
    /// The type name.
    pub(crate) name: String,
    /// `ros2msg`.
    pub(crate) encoding: String,
    /// The definition.
    pub(crate) data: Vec<u8>,
}

/// A channel the recording defined.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct ChannelDef {
    /// Its id.
    pub(crate) id: u16,
    /// Its schema's id.
    pub(crate) schema_id: u16,
    /// The topic.
    pub(crate) topic: String,
    /// `cdr`.
    pub(crate) encoding: String,
    /// `offered_qos_profiles`.
    pub(crate) metadata: BTreeMap<String, String>,
}

/// The schemas and channels of a recording, as its writer made them: what a summary repeats.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(super) struct Definitions {
    /// Schemas.
    pub(crate) schemas: Vec<SchemaDef>,
    /// Channels.
    pub(crate) channels: Vec<ChannelDef>,
}

/// A file a recording is closed in: read, written, and cut to a length.
pub(super) trait Cut: Read + Write + Seek {
    /// Cuts (or extends) the file to `length` bytes.
    fn cut(&mut self, length: u64) -> std::io::Result<()>;
    /// Makes what was written durable.
    fn sync(&mut self) -> std::io::Result<()>;
}

impl Cut for File {
    fn cut(&mut self, length: u64) -> std::io::Result<()> {
        self.set_len(length)
    }

    fn sync(&mut self) -> std::io::Result<()> {
        self.sync_all()
    }
}

/// Cuts the MCAP file at `path` back to `length` bytes (the end of its last complete flush)
/// and ends it there: a data end record with the CRC of those bytes, a summary of what they
/// hold (with `defs`), the footer, the end magic ([`close`]).
pub(super) fn close_at(path: &Path, length: u64, defs: &Definitions) -> std::io::Result<()> {
    let mut file = OpenOptions::new().read(true).write(true).open(path)?;
    close(&mut file, length, defs)
}

/// [`close_at`] on an open file. When the end does not fit (a disk full again, a file-size
/// limit the last flush ended just short of: the summary repeats every schema, some kilobytes),
/// the file is cut back to `length` once more and the error returned: it then holds every chunk
/// up to its last complete flush and nothing after, which `grasp_orient recover` copies whole into
/// a closed file. A summary without the schemas or the chunk index would fit more often, but
/// `rosbags` cannot read a recording through it (its messages are not in time order), so none is
/// written.
pub(super) fn close<F: Cut>(file: &mut F, length: u64, defs: &Definitions) -> std::io::Result<()> {
    file.cut(length)?;
    let end = end_of(file, length, defs)?;
    file.seek(SeekFrom::Start(length))?;
    if let Err(e) = file.write_all(&end).and_then(|()| file.sync()) {
        // Whatever part of the end was written goes. Should the cut fail too, `e` still says
        // why the file is not closed.
        let _cut = file.cut(length);
        return Err(e);
    }
    Ok(())
}

/// The records that end a file cut at `length`: data end, summary, footer, magic.
fn end_of<F: Read + Seek>(
    file: &mut F,
    length: u64,
    defs: &Definitions,
) -> std::io::Result<Vec<u8>> {
    file.seek(SeekFrom::Start(0))?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut reader = (&mut *file).take(length);
    loop {
        let n = reader.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    let index = Index::of(file, length)?;
    let mut end = Vec::new();
    record(&mut end, op::DATA_END, &hasher.finalize().to_le_bytes());
    let summary_start = length + end.len() as u64;
    let (summary, offsets_at) = summary(&index, defs, summary_start);
    end.extend_from_slice(&summary);
    let summary_offset_start = summary_start + offsets_at;
    let mut footer = vec![op::FOOTER];
    footer.extend_from_slice(&20u64.to_le_bytes());
    footer.extend_from_slice(&summary_start.to_le_bytes());
    footer.extend_from_slice(&summary_offset_start.to_le_bytes());
    // The summary CRC covers the summary and the footer up to this field.
    let mut crc = crc32fast::Hasher::new();
    crc.update(&summary);
    crc.update(&footer);
    footer.extend_from_slice(&crc.finalize().to_le_bytes());
    end.extend_from_slice(&footer);
    end.extend_from_slice(MAGIC);
    Ok(end)
}

/// A chunk of the file, as its chunk index record describes it.
#[derive(Debug, Default)]
struct ChunkEntry {
    start_time: u64,
    end_time: u64,
    offset: u64,
    length: u64,
    index_offsets: BTreeMap<u16, u64>,
    index_length: u64,
    compression: String,
    compressed_size: u64,
    uncompressed_size: u64,
    messages: u64,
}

/// What the records of a file's data section say, for its summary.
#[derive(Debug, Default)]
struct Index {
    chunks: Vec<ChunkEntry>,
    /// (offset, length, name) of each metadata record.
    metadata: Vec<(u64, u64, String)>,
    per_channel: BTreeMap<u16, u64>,
}

impl Index {
    /// Walks the records of the first `length` bytes of `file` (whole records: the file was cut
    /// at a flush), reading only their headers.
    fn of<F: Read + Seek>(file: &mut F, length: u64) -> std::io::Result<Self> {
        let mut out = Index::default();
        let mut at = MAGIC.len() as u64;
        let mut head = [0u8; 9];
        while at + 9 <= length {
            file.seek(SeekFrom::Start(at))?;
            file.read_exact(&mut head)?;
            let size = u64::from_le_bytes(head[1..9].try_into().unwrap_or([0; 8]));
            let next = at.saturating_add(9).saturating_add(size);
            if next > length {
                break;
            }
            let body = |file: &mut F, n: u64| -> std::io::Result<Vec<u8>> {
                let mut b = vec![0u8; usize::try_from(n.min(size)).unwrap_or(0)];
                file.read_exact(&mut b)?;
                Ok(b)
            };
            match head[0] {
                op::CHUNK => {
                    // The header fields; the compression name is a few bytes.
                    let b = body(file, 1024)?;
                    if let Some(chunk) = chunk_entry(&b, at, 9 + size) {
                        out.chunks.push(chunk);
                    }
                }
                op::MESSAGE_INDEX => {
                    let b = body(file, 6)?;
                    if let (Some(last), &[lo, hi, n0, n1, n2, n3]) =
                        (out.chunks.last_mut(), b.as_slice())
                    {
                        let channel = u16::from_le_bytes([lo, hi]);
                        let count = u64::from(u32::from_le_bytes([n0, n1, n2, n3])) / 16;
                        last.index_offsets.insert(channel, at);
                        last.index_length += 9 + size;
                        last.messages += count;
                        *out.per_channel.entry(channel).or_default() += count;
                    }
                }
                op::METADATA => {
                    let b = body(file, size)?;
                    let name = read_str(&b, &mut 0).unwrap_or_default();
                    out.metadata.push((at, 9 + size, name));
                }
                _ => {}
            }
            at = next;
        }
        Ok(out)
    }
}

/// The chunk index entry of the chunk record at `offset` whose body starts with `b`.
fn chunk_entry(b: &[u8], offset: u64, length: u64) -> Option<ChunkEntry> {
    let mut at = 0;
    let start_time = read_u64(b, &mut at)?;
    let end_time = read_u64(b, &mut at)?;
    let uncompressed_size = read_u64(b, &mut at)?;
    at += 4; // uncompressed CRC
    let compression = read_str(b, &mut at)?;
    let compressed_size = read_u64(b, &mut at)?;
    Some(ChunkEntry {
        start_time,
        end_time,
        offset,
        length,
        compression,
        compressed_size,
        uncompressed_size,
        ..ChunkEntry::default()
    })
}

fn read_u64(b: &[u8], at: &mut usize) -> Option<u64> {
    let v = u64::from_le_bytes(b.get(*at..*at + 8)?.try_into().ok()?);
    *at += 8;
    Some(v)
}

fn read_str(b: &[u8], at: &mut usize) -> Option<String> {
    let n = u32::from_le_bytes(b.get(*at..*at + 4)?.try_into().ok()?) as usize;
    let s = std::str::from_utf8(b.get(*at + 4..*at + 4 + n)?)
        .ok()?
        .to_string();
    *at += 4 + n;
    Some(s)
}

/// One record: opcode, length, body.
fn record(out: &mut Vec<u8>, opcode: u8, body: &[u8]) {
    out.push(opcode);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

fn put_map(out: &mut Vec<u8>, map: &BTreeMap<String, String>) {
    let mut body = Vec::new();
    for (k, v) in map {
        put_str(&mut body, k);
        put_str(&mut body, v);
    }
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
}

/// The summary section starting at `start`: schemas, channels, statistics, chunk indexes,
/// metadata indexes, then one summary offset per group; and where those offsets start in it.
fn summary(index: &Index, defs: &Definitions, start: u64) -> (Vec<u8>, u64) {
    let mut groups: Vec<(u8, Vec<u8>)> = Vec::new();
    let mut schemas = Vec::new();
    for s in &defs.schemas {
        let mut b = s.id.to_le_bytes().to_vec();
        put_str(&mut b, &s.name);
        put_str(&mut b, &s.encoding);
        b.extend_from_slice(&(s.data.len() as u32).to_le_bytes());
        b.extend_from_slice(&s.data);
        record(&mut schemas, op::SCHEMA, &b);
    }
    groups.push((op::SCHEMA, schemas));
    let mut channels = Vec::new();
    for c in &defs.channels {
        let mut b = c.id.to_le_bytes().to_vec();
        b.extend_from_slice(&c.schema_id.to_le_bytes());
        put_str(&mut b, &c.topic);
        put_str(&mut b, &c.encoding);
        put_map(&mut b, &c.metadata);
        record(&mut channels, op::CHANNEL, &b);
    }
    groups.push((op::CHANNEL, channels));
    groups.push((op::STATISTICS, statistics(index, defs)));
    let mut chunks = Vec::new();
    for c in &index.chunks {
        let mut b = Vec::new();
        for v in [c.start_time, c.end_time, c.offset, c.length] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&((c.index_offsets.len() * 10) as u32).to_le_bytes());
        for (channel, offset) in &c.index_offsets {
            b.extend_from_slice(&channel.to_le_bytes());
            b.extend_from_slice(&offset.to_le_bytes());
        }
        b.extend_from_slice(&c.index_length.to_le_bytes());
        put_str(&mut b, &c.compression);
        b.extend_from_slice(&c.compressed_size.to_le_bytes());
        b.extend_from_slice(&c.uncompressed_size.to_le_bytes());
        record(&mut chunks, op::CHUNK_INDEX, &b);
    }
    groups.push((op::CHUNK_INDEX, chunks));
    let mut metadata = Vec::new();
    for (offset, length, name) in &index.metadata {
        let mut b = offset.to_le_bytes().to_vec();
        b.extend_from_slice(&length.to_le_bytes());
        put_str(&mut b, name);
        record(&mut metadata, op::METADATA_INDEX, &b);
    }
    groups.push((op::METADATA_INDEX, metadata));
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (opcode, bytes) in groups.into_iter().filter(|(_, b)| !b.is_empty()) {
        let mut b = vec![opcode];
        b.extend_from_slice(&(start + out.len() as u64).to_le_bytes());
        b.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        record(&mut offsets, op::SUMMARY_OFFSET, &b);
        out.extend_from_slice(&bytes);
    }
    let offsets_at = out.len() as u64;
    out.extend_from_slice(&offsets);
    (out, offsets_at)
}

/// The statistics record of what `index` counted.
fn statistics(index: &Index, defs: &Definitions) -> Vec<u8> {
    let with_messages = index.chunks.iter().filter(|c| c.messages > 0);
    let start = with_messages
        .clone()
        .map(|c| c.start_time)
        .min()
        .unwrap_or(0);
    let end = with_messages.map(|c| c.end_time).max().unwrap_or(0);
    let mut b = index
        .per_channel
        .values()
        .sum::<u64>()
        .to_le_bytes()
        .to_vec();
    b.extend_from_slice(&(defs.schemas.len() as u16).to_le_bytes());
    b.extend_from_slice(&(defs.channels.len() as u32).to_le_bytes());
    b.extend_from_slice(&0u32.to_le_bytes()); // attachments
    b.extend_from_slice(&(index.metadata.len() as u32).to_le_bytes());
    b.extend_from_slice(&(index.chunks.len() as u32).to_le_bytes());
    b.extend_from_slice(&start.to_le_bytes());
    b.extend_from_slice(&end.to_le_bytes());
    b.extend_from_slice(&((index.per_channel.len() * 10) as u32).to_le_bytes());
    for (channel, n) in &index.per_channel {
        b.extend_from_slice(&channel.to_le_bytes());
        b.extend_from_slice(&n.to_le_bytes());
    }
    let mut out = Vec::new();
    record(&mut out, op::STATISTICS, &b);
    out
}
