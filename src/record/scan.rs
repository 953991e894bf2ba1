//! MCAP read with every length checked before it is used, so that no input, however damaged,
//! makes a reader allocate what the file does not hold, loop forever or panic.
//!
//! - [`Records`] walks the records of a region (the file after its magic, or a chunk's
//!   decompressed records): each record's length is checked against what remains.
//! - [`parse`] reads one record's fields; every string, byte array and map length is checked
//!   against the record's own length.
//! - [`decompress`] unpacks a chunk into at most the size it declares (memory grows only with
//!   the bytes the decompressor actually produces) and checks its size and CRC.
//! - [`scan`] walks a whole file: the data section, the summary, the footer and the end magic,
//!   and checks the data section's and the summary's CRCs. The chunks of a file may declare at
//!   most [`decompressed_limit`] bytes in all: a few kilobytes of zstd can expand to gigabytes,
//!   and a chunk that would take the file beyond the limit is damage, never decompressed.
//!
//! Damage comes back as a [`Damage`]: the byte offset, what is wrong there, and whether the
//! file merely ends early (a recorder that was killed or is still writing). The MCAP records and
//! their fields are those of the specification (<https://mcap.dev/spec>).

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;
use std::io::Read;

/// The 8 bytes an MCAP file starts and ends with.
pub(crate) const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// The most bytes of records the chunks of a file of `file_len` bytes may declare in all: 1024
/// times its size, and at least 1 MiB. The recordings of `grasp_orient` (lz4, whose ratio cannot
/// exceed 255) and of `recover` (zstd, a few times on messages) stay far below it; what lies
/// beyond it is a decompression bomb. So reading a file holds at most this much decompressed at a
/// time per thread, and decodes at most this much in all.
pub fn decompressed_limit(file_len: u64) -> u64 {
    file_len.saturating_mul(1024).max(1 << 20)
}

/// Record opcodes.
pub(crate) mod op {
    /// Header.
    pub(crate) const HEADER: u8 = 0x01;
    /// Footer.
    pub(crate) const FOOTER: u8 = 0x02;
    /// Schema.
    pub(crate) const SCHEMA: u8 = 0x03;
    /// Channel.
    pub(crate) const CHANNEL: u8 = 0x04;
    /// Message.
    pub(crate) const MESSAGE: u8 = 0x05;
    /// Chunk.
    pub(crate) const CHUNK: u8 = 0x06;
    /// Message index.
    pub(crate) const MESSAGE_INDEX: u8 = 0x07;
    /// Chunk index.
    pub(crate) const CHUNK_INDEX: u8 = 0x08;
    /// Attachment.
    pub(crate) const ATTACHMENT: u8 = 0x09;
    /// Attachment index.
    pub(crate) const ATTACHMENT_INDEX: u8 = 0x0A;
    /// Statistics.
    pub(crate) const STATISTICS: u8 = 0x0B;
    /// Metadata.
    pub(crate) const METADATA: u8 = 0x0C;
    /// Metadata index.
    pub(crate) const METADATA_INDEX: u8 = 0x0D;
    /// Summary offset.
    pub(crate) const SUMMARY_OFFSET: u8 = 0x0E;
    /// Data end.
    pub(crate) const DATA_END: u8 = 0x0F;
}

/// Where a file is damaged and how.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset in the file.
    pub offset: u64,
    /// What is wrong there.
    pub what: String,
    /// Whether the file merely ends early: a recorder that was killed, ran out of disk, or is
    /// still writing. `recover` saves what comes before.
    pub cut_short: bool,
}

impl Damage {
    fn at(offset: u64, what: impl Into<String>) -> Self {
        Self {
            offset,
            what: what.into(),
            cut_short: false,
        }
    }
}

impl fmt::Display for Damage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "at byte {}: {}", self.offset, self.what)
    }
}

/// One record: where it starts, its opcode, and its body (the bytes after opcode and length).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Record<'a> {
    /// Offset of its opcode (in the file, or in a chunk's records).
    pub offset: u64,
    /// The opcode.
    pub opcode: u8,
    /// The body, exactly as long as the record says.
    pub body: &'a [u8],
}

/// The records of a region, each length checked against what remains. Ends after the first
/// damage.
#[derive(Debug)]
pub(crate) struct Records<'a> {
    bytes: &'a [u8],
    pos: usize,
    base: u64,
    /// Whether running out of bytes means the region was cut short (rather than damaged).
    end_is_cut: bool,
    done: bool,
}

impl<'a> Records<'a> {
    /// The records of `bytes`, whose first byte is at offset `base`. `end_is_cut`: a record
    /// running past the end means the region was cut short (a file without its end magic), not
    /// damaged.
    pub(crate) fn new(bytes: &'a [u8], base: u64, end_is_cut: bool) -> Self {
        Self {
            bytes,
            pos: 0,
            base,
            end_is_cut,
            done: false,
        }
    }

    /// Offset of the next record.
    pub(crate) fn position(&self) -> u64 {
        self.base + self.pos as u64
    }
}

impl<'a> Iterator for Records<'a> {
    type Item = Result<Record<'a>, Damage>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done || self.pos == self.bytes.len() {
            return None;
        }
        let offset = Records::position(self);
        let rest = &self.bytes[self.pos..];
        let cut = |what: String| {
            Some(Err(Damage {
                offset,
                what,
                cut_short: self.end_is_cut,
            }))
        };
        if rest.len() < 9 {
            self.done = true;
            return cut(format!(
                "a record starts here but only {} of its 9 header bytes follow",
                rest.len()
            ));
        }
        let opcode = rest[0];
        let mut length = [0u8; 8];
        length.copy_from_slice(&rest[1..9]);
        let length = u64::from_le_bytes(length);
        let available = (rest.len() - 9) as u64;
        if length > available {
            self.done = true;
            return cut(format!(
                "a record (opcode 0x{opcode:02x}) claims {length} bytes, but only {available} \
                 follow"
            ));
        }
        // length <= available, which is a usize.
        let end = 9 + length as usize;
        self.pos += end;
        Some(Ok(Record {
            offset,
            opcode,
            body: &rest[9..end],
        }))
    }
}

/// The fields of one record body, read front to back with every length checked.
struct Fields<'a> {
    bytes: &'a [u8],
    pos: usize,
    offset: u64,
    kind: &'static str,
}

impl<'a> Fields<'a> {
    fn new(record: &Record<'a>, kind: &'static str) -> Self {
        Self {
            bytes: record.body,
            pos: 0,
            offset: record.offset,
            kind,
        }
    }

    fn damage(&self, what: impl fmt::Display) -> Damage {
        Damage::at(self.offset, format!("{} record: {what}", self.kind))
    }

    fn take(&mut self, n: u64, field: &str) -> Result<&'a [u8], Damage> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            return Err(self.damage(format!(
                "{field} needs {n} bytes but the record has {left} left"
            )));
        }
        let start = self.pos;
        self.pos += n as usize;
        Ok(&self.bytes[start..self.pos])
    }

    fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], Damage> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N as u64, field)?);
        Ok(out)
    }

    fn u16(&mut self, field: &str) -> Result<u16, Damage> {
        self.array(field).map(u16::from_le_bytes)
    }

    fn u32(&mut self, field: &str) -> Result<u32, Damage> {
        self.array(field).map(u32::from_le_bytes)
    }

    fn u64(&mut self, field: &str) -> Result<u64, Damage> {
        self.array(field).map(u64::from_le_bytes)
    }

    fn bytes32(&mut self, field: &str) -> Result<&'a [u8], Damage> {
        let n = self.u32(field)?;
        self.take(u64::from(n), field)
    }

    fn string(&mut self, field: &str) -> Result<String, Damage> {
        let bytes = self.bytes32(field)?;
        std::str::from_utf8(bytes)
            .map(str::to_string)
            .map_err(|_| self.damage(format!("{field} is not UTF-8")))
    }

    fn string_map(&mut self, field: &str) -> Result<BTreeMap<String, String>, Damage> {
        let mut inner = Fields {
            bytes: self.bytes32(field)?,
            pos: 0,
            offset: self.offset,
            kind: self.kind,
        };
        let mut map = BTreeMap::new();
        while inner.pos < inner.bytes.len() {
            let key = inner.string(field)?;
            let value = inner.string(field)?;
            if map.insert(key, value).is_some() {
                return Err(self.damage(format!("{field} holds a key twice")));
            }
        }
        Ok(map)
    }

    fn rest(&mut self) -> &'a [u8] {
        let start = self.pos;
        self.pos = self.bytes.len();
        &self.bytes[start..]
    }
}

/// A schema record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Schema<'a> {
    /// Its id (0 is not allowed).
    pub id: u16,
    /// The type name, e.g. `grasp_orient/msg/GraspCandidate`.
    pub name: String,
    /// e.g. `ros2msg`.
    pub encoding: String,
    /// The definition.
    pub data: &'a [u8],
}

/// A channel record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Channel {
    /// Its id.
    pub id: u16,
    /// Its schema's id, 0 for none.
    pub schema_id: u16,
    /// The topic.
    pub topic: String,
    /// e.g. `cdr`.
    pub message_encoding: String,
    /// e.g. `offered_qos_profiles`.
    pub metadata: BTreeMap<String, String>,
}

/// A message record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Message<'a> {
    /// Its channel's id.
    pub channel_id: u16,
    /// Its sequence number.
    pub sequence: u32,
    /// Receive time, ns.
    pub log_time: u64,
    /// Send time, ns.
    pub publish_time: u64,
    /// The payload.
    pub data: &'a [u8],
}

/// A chunk record, still compressed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Chunk<'a> {
    /// Size of its records once decompressed.
    pub uncompressed_size: u64,
    /// CRC-32 of its decompressed records, 0 when not computed.
    pub uncompressed_crc: u32,
    /// `""`, `lz4` or `zstd`.
    pub compression: String,
    /// The compressed records.
    pub data: &'a [u8],
}

/// An attachment record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Attachment<'a> {
    /// When it was logged, ns.
    pub log_time: u64,
    /// When it was created, ns.
    pub create_time: u64,
    /// Its name.
    pub name: String,
    /// Its media type.
    pub media_type: String,
    /// Its bytes.
    pub data: &'a [u8],
}

/// What one record holds, as far as grasp_orient reads it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Parsed<'a> {
    /// The header: the profile, e.g. `ros2`.
    Header {
        /// The profile.
        profile: String,
    },
    /// The footer.
    Footer {
        /// Offset of the summary section, 0 for none.
        summary_start: u64,
        /// CRC-32 of the summary section and the footer's fields before it, 0 when not computed.
        summary_crc: u32,
    },
    /// A schema.
    Schema(Schema<'a>),
    /// A channel.
    Channel(Channel),
    /// A message.
    Message(Message<'a>),
    /// A chunk.
    Chunk(Chunk<'a>),
    /// How many messages of one channel the chunk before holds.
    MessageIndex {
        /// The channel.
        channel_id: u16,
        /// The number of messages.
        count: u64,
    },
    /// The summary's statistics.
    Statistics {
        /// Messages in the file.
        message_count: u64,
        /// Messages per channel.
        per_channel: BTreeMap<u16, u64>,
    },
    /// A metadata record.
    Metadata {
        /// Its name.
        name: String,
        /// Its entries.
        entries: BTreeMap<String, String>,
    },
    /// An attachment whose CRC verified.
    Attachment(Attachment<'a>),
    /// The end of the data section.
    DataEnd {
        /// CRC-32 of the data section, 0 when not computed.
        data_crc: u32,
    },
    /// A record grasp_orient does not read (indexes, summary offsets, unknown opcodes).
    Other,
}

/// Reads the fields of one record. Fields added after the ones read (later versions of the
/// format) are ignored, as the specification asks.
///
/// Longer than a screen by a few lines: one short arm per record type of the specification,
/// field by field in its order; the records with checks of their own (chunk, attachment,
/// statistics) have functions of their own.
pub(crate) fn parse<'a>(record: &Record<'a>) -> Result<Parsed<'a>, Damage> {
    Ok(match record.opcode {
        op::HEADER => {
            let mut f = Fields::new(record, "header");
            Parsed::Header {
                profile: f.string("profile")?,
            }
        }
        op::FOOTER => {
            let mut f = Fields::new(record, "footer");
            let summary_start = f.u64("summary_start")?;
            f.u64("summary_offset_start")?;
            Parsed::Footer {
                summary_start,
                summary_crc: f.u32("summary_crc")?,
            }
        }
        op::SCHEMA => {
            let mut f = Fields::new(record, "schema");
            let schema = Schema {
                id: f.u16("id")?,
                name: f.string("name")?,
                encoding: f.string("encoding")?,
                data: f.bytes32("data")?,
            };
            if schema.id == 0 {
                return Err(f.damage("schema id 0 is reserved"));
            }
            Parsed::Schema(schema)
        }
        op::CHANNEL => {
            let mut f = Fields::new(record, "channel");
            Parsed::Channel(Channel {
                id: f.u16("id")?,
                schema_id: f.u16("schema_id")?,
                topic: f.string("topic")?,
                message_encoding: f.string("message_encoding")?,
                metadata: f.string_map("metadata")?,
            })
        }
        op::MESSAGE => {
            let mut f = Fields::new(record, "message");
            Parsed::Message(Message {
                channel_id: f.u16("channel_id")?,
                sequence: f.u32("sequence")?,
                log_time: f.u64("log_time")?,
                publish_time: f.u64("publish_time")?,
                data: f.rest(),
            })
        }
        op::CHUNK => parse_chunk(record)?,
        op::MESSAGE_INDEX => {
            let mut f = Fields::new(record, "message index");
            let channel_id = f.u16("channel_id")?;
            let entries = f.bytes32("records")?;
            if entries.len() % 16 != 0 {
                return Err(f.damage("its records are not (log_time, offset) pairs"));
            }
            Parsed::MessageIndex {
                channel_id,
                count: entries.len() as u64 / 16,
            }
        }
        op::ATTACHMENT => parse_attachment(record)?,
        op::STATISTICS => parse_statistics(record)?,
        op::METADATA => {
            let mut f = Fields::new(record, "metadata");
            Parsed::Metadata {
                name: f.string("name")?,
                entries: f.string_map("metadata")?,
            }
        }
        op::DATA_END => {
            let mut f = Fields::new(record, "data end");
            Parsed::DataEnd {
                data_crc: f.u32("data_section_crc")?,
            }
        }
        _ => Parsed::Other,
    })
}

fn parse_chunk<'a>(record: &Record<'a>) -> Result<Parsed<'a>, Damage> {
    let mut f = Fields::new(record, "chunk");
    f.u64("message_start_time")?;
    f.u64("message_end_time")?;
    let uncompressed_size = f.u64("uncompressed_size")?;
    let uncompressed_crc = f.u32("uncompressed_crc")?;
    let compression = f.string("compression")?;
    let size = f.u64("records length")?;
    let data = f.take(size, "records")?;
    Ok(Parsed::Chunk(Chunk {
        uncompressed_size,
        uncompressed_crc,
        compression,
        data,
    }))
}

fn parse_attachment<'a>(record: &Record<'a>) -> Result<Parsed<'a>, Damage> {
    let mut f = Fields::new(record, "attachment");
    let log_time = f.u64("log_time")?;
    let create_time = f.u64("create_time")?;
    let name = f.string("name")?;
    let media_type = f.string("media_type")?;
    let size = f.u64("data length")?;
    let data = f.take(size, "data")?;
    let covered = f.pos;
    let crc = f.u32("crc")?;
    let computed = crc32fast::hash(&record.body[..covered]);
    if crc != 0 && crc != computed {
        return Err(f.damage(format!(
            "CRC mismatch (stored 0x{crc:08x}, computed 0x{computed:08x})"
        )));
    }
    Ok(Parsed::Attachment(Attachment {
        log_time,
        create_time,
        name,
        media_type,
        data,
    }))
}

fn parse_statistics<'a>(record: &Record<'a>) -> Result<Parsed<'a>, Damage> {
    let mut f = Fields::new(record, "statistics");
    let message_count = f.u64("message_count")?;
    f.u16("schema_count")?;
    for field in [
        "channel_count",
        "attachment_count",
        "metadata_count",
        "chunk_count",
    ] {
        f.u32(field)?;
    }
    f.u64("message_start_time")?;
    f.u64("message_end_time")?;
    let counts = f.bytes32("channel_message_counts")?;
    if counts.len() % 10 != 0 {
        return Err(f.damage("channel_message_counts is not (u16, u64) pairs"));
    }
    let per_channel = counts
        .chunks_exact(10)
        .map(|pair| {
            let mut id = [0u8; 2];
            let mut n = [0u8; 8];
            id.copy_from_slice(&pair[..2]);
            n.copy_from_slice(&pair[2..]);
            (u16::from_le_bytes(id), u64::from_le_bytes(n))
        })
        .collect();
    Ok(Parsed::Statistics {
        message_count,
        per_channel,
    })
}

/// A chunk index record of the summary: where one chunk lies in the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChunkIndex {
    /// Offset of the chunk record's opcode.
    pub chunk_start: u64,
    /// Length of the whole chunk record (opcode and length field included).
    pub chunk_length: u64,
    /// Size of its compressed records.
    pub compressed_size: u64,
    /// Size of its records once decompressed.
    pub uncompressed_size: u64,
}

/// Reads a chunk index record.
pub(crate) fn parse_chunk_index(record: &Record<'_>) -> Result<ChunkIndex, Damage> {
    let mut f = Fields::new(record, "chunk index");
    f.u64("message_start_time")?;
    f.u64("message_end_time")?;
    let chunk_start = f.u64("chunk_start_offset")?;
    let chunk_length = f.u64("chunk_length")?;
    f.bytes32("message_index_offsets")?;
    f.u64("message_index_length")?;
    f.string("compression")?;
    Ok(ChunkIndex {
        chunk_start,
        chunk_length,
        compressed_size: f.u64("compressed_size")?,
        uncompressed_size: f.u64("uncompressed_size")?,
    })
}

/// Reads the offset and length (of the whole record) that a metadata index or an attachment
/// index record gives, both their first two fields.
pub(crate) fn parse_record_index(record: &Record<'_>) -> Result<(u64, u64), Damage> {
    let mut f = Fields::new(record, "index");
    Ok((f.u64("offset")?, f.u64("length")?))
}

/// Whether a chunk record's body ends where its fields end (a length field that says more
/// hides the records after it).
pub(crate) fn chunk_fills_its_record(chunk: &Chunk<'_>, record: &Record<'_>) -> bool {
    // Two times, the size, the CRC, the compression's length and the records' length.
    let fields = 8 + 8 + 8 + 4 + 4 + 8;
    fields + chunk.compression.len() + chunk.data.len() == record.body.len()
}

/// A chunk's records, decompressed: exactly `uncompressed_size` bytes, their CRC checked when
/// the chunk has one. Memory grows with what the decompressor produces, never with the size the
/// chunk claims. `Err` says why not.
pub(crate) fn decompress<'a>(chunk: &Chunk<'a>) -> Result<Cow<'a, [u8]>, Undecompressable> {
    let size = chunk.uncompressed_size;
    let compressed = chunk.data.len();
    let out: Cow<'a, [u8]> = match chunk.compression.as_str() {
        "" => Cow::Borrowed(chunk.data),
        "lz4" => Cow::Owned(
            lz4::Decoder::new(chunk.data)
                .and_then(|d| read_at_most(d, size, compressed))
                .map_err(Undecompressable::Lz4)?,
        ),
        "zstd" => Cow::Owned(
            zstd::stream::read::Decoder::with_buffer(chunk.data)
                .and_then(|d| read_at_most(d, size, compressed))
                .map_err(Undecompressable::Zstd)?,
        ),
        other => return Err(Undecompressable::Compression(other.to_string())),
    };
    if out.len() as u64 != size {
        return Err(Undecompressable::Size {
            declared: size,
            more: out.len() as u64 > size,
            held: out.len().min(usize::try_from(size).unwrap_or(usize::MAX)),
        });
    }
    if chunk.uncompressed_crc != 0 {
        let computed = crc32fast::hash(&out);
        if computed != chunk.uncompressed_crc {
            return Err(Undecompressable::Crc {
                stored: chunk.uncompressed_crc,
                computed,
            });
        }
    }
    Ok(out)
}

/// Why a chunk's records cannot be had.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum Undecompressable {
    /// The lz4 stream is damaged.
    #[error("lz4: {0}")]
    Lz4(std::io::Error),
    /// The zstd stream is damaged.
    #[error("zstd: {0}")]
    Zstd(std::io::Error),
    /// A compression this reader does not know.
    #[error("unknown compression {0:?}")]
    Compression(String),
    /// The records are not as long as the chunk declares.
    #[error("declares {declared} bytes of records but holds {}{held}", if *more { "more than " } else { "" })]
    Size {
        /// The declared length.
        declared: u64,
        /// Whether it holds more than declared.
        more: bool,
        /// What it holds, at most the declared length.
        held: usize,
    },
    /// The records' CRC is not the stored one.
    #[error("CRC mismatch (stored 0x{stored:08x}, computed 0x{computed:08x})")]
    Crc {
        /// The stored CRC.
        stored: u32,
        /// The CRC of the records.
        computed: u32,
    },
}

/// Everything `reader` gives, up to `limit + 1` bytes (one more shows that it held too many).
/// The first allocation is bounded by what `compressed` bytes can plausibly expand to.
fn read_at_most(reader: impl Read, limit: u64, compressed: usize) -> std::io::Result<Vec<u8>> {
    let guess = (compressed as u64).saturating_mul(8).saturating_add(4096);
    let mut out = Vec::with_capacity(usize::try_from(limit.min(guess)).unwrap_or(0));
    reader.take(limit.saturating_add(1)).read_to_end(&mut out)?;
    Ok(out)
}

/// A record of the data section, parsed, with its offset.
#[derive(Debug, Clone)]
pub(crate) struct Item<'a> {
    /// Offset of its opcode in the file.
    pub offset: u64,
    /// Its opcode.
    pub opcode: u8,
    /// Its fields, or why they could not be read (the record's length was sound, so the walk
    /// went on past it).
    pub parsed: Result<Parsed<'a>, Damage>,
}

/// A file walked from its magic to its end.
#[derive(Debug, Default)]
pub(crate) struct Scan<'a> {
    /// The records of the data section, in file order (the header excluded).
    pub items: Vec<Item<'a>>,
    /// Schemas and channels of the summary section, when the summary's CRC verified (or it has
    /// none).
    pub summary_schemas: Vec<Schema<'a>>,
    /// See `summary_schemas`.
    pub summary_channels: Vec<Channel>,
    /// Messages per channel according to the summary's statistics, when the summary verified.
    pub statistics: Option<(u64, BTreeMap<u16, u64>)>,
    /// Whether the summary's CRC was there and verified.
    pub summary_verified: bool,
    /// Whether the data section's CRC was there and verified.
    pub data_verified: bool,
    /// Offset of the data end record, when the walk reached it.
    pub data_end: Option<u64>,
    /// Where the walk stopped before a sound end (the length of a record ran past the end of
    /// the file, or the end is malformed).
    pub stopped: Option<Damage>,
    /// Damage of the data section as a whole: its CRC does not match, it has no end record.
    pub damage: Vec<Damage>,
    /// Damage of the summary section (which `recover` rebuilds, so nothing is lost by it).
    pub summary_damage: Vec<Damage>,
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

/// A schema as a channel table keeps it (copied out of the chunk it came in).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct KnownSchema {
    /// The type name.
    pub name: String,
    /// e.g. `ros2msg`.
    pub encoding: String,
    /// The definition.
    pub data: Vec<u8>,
}

/// The schemas and channels defined so far, by id. A second definition of an id must equal the
/// first.
#[derive(Debug, Clone, Default)]
pub(crate) struct Table {
    /// Schemas by id.
    pub schemas: std::collections::HashMap<u16, KnownSchema>,
    /// Channels by id.
    pub channels: std::collections::HashMap<u16, Channel>,
}

impl Table {
    /// Adds a schema found at `offset`.
    pub(crate) fn add_schema(&mut self, schema: &Schema<'_>, offset: u64) -> Result<(), Damage> {
        let known = KnownSchema {
            name: schema.name.clone(),
            encoding: schema.encoding.clone(),
            data: schema.data.to_vec(),
        };
        match self.schemas.get(&schema.id) {
            Some(old) if *old != known => Err(Damage::at(
                offset,
                format!("schema {} is defined twice, differently", schema.id),
            )),
            Some(_) => Ok(()),
            None => {
                self.schemas.insert(schema.id, known);
                Ok(())
            }
        }
    }

    /// Adds a channel found at `offset`.
    pub(crate) fn add_channel(&mut self, channel: &Channel, offset: u64) -> Result<(), Damage> {
        match self.channels.get(&channel.id) {
            Some(old) if old != channel => Err(Damage::at(
                offset,
                format!("channel {} is defined twice, differently", channel.id),
            )),
            Some(_) => Ok(()),
            None => {
                self.channels.insert(channel.id, channel.clone());
                Ok(())
            }
        }
    }

    /// The schema of a channel, when it has one and it is known.
    pub(crate) fn schema_of(&self, channel: &Channel) -> Option<&KnownSchema> {
        self.schemas.get(&channel.schema_id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
        let mut out = vec![opcode];
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn lengths_beyond_the_end_are_damage_not_allocations() {
        let mut bytes = record(op::MESSAGE, &[0; 22]);
        bytes.push(op::CHUNK);
        bytes.extend_from_slice(&u64::MAX.to_le_bytes());
        let mut walk = Records::new(&bytes, 8, false);
        assert!(walk.next().is_some_and(|r| r.is_ok()));
        let d = walk.next().expect("an item").expect_err("too long");
        assert_eq!(d.offset, 8 + 31);
        assert!(d.what.contains("claims 18446744073709551615 bytes"), "{d}");
        assert!(walk.next().is_none(), "the walk ends at the first damage");

        // A string length past the record's end.
        let mut body = 7u16.to_le_bytes().to_vec();
        body.extend_from_slice(&u32::MAX.to_le_bytes());
        let r = Record {
            offset: 100,
            opcode: op::SCHEMA,
            body: &body,
        };
        let d = parse(&r).expect_err("too long");
        assert!(
            d.what
                .starts_with("schema record: name needs 4294967295 bytes"),
            "{d}"
        );
    }

    #[test]
    fn a_chunk_claiming_a_huge_size_is_refused_by_what_it_holds() {
        let chunk = Chunk {
            uncompressed_size: 8_500_000_000_000_000_000,
            uncompressed_crc: 0,
            compression: "zstd".into(),
            data: &[0x28, 0xb5, 0x2f, 0xfd, 0, 0x58, 0x11, 0, 0],
        };
        let e = decompress(&chunk).expect_err("not that big").to_string();
        assert!(e.starts_with("declares") || e.starts_with("zstd"), "{e}");
        let chunk = Chunk {
            uncompressed_size: 3,
            uncompressed_crc: crc32fast::hash(b"abd"),
            compression: String::new(),
            data: b"abc",
        };
        assert!(decompress(&chunk)
            .expect_err("bad crc")
            .to_string()
            .contains("CRC mismatch"));
    }

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
