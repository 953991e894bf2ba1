//! The fields of one record, read front to back with every string, byte array and map length
//! checked against the record's own length.

use super::frame::{op, Damage, Record};
use std::collections::BTreeMap;
use std::fmt;

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
    pub(crate) id: u16,
    /// The type name, e.g. `grasp_orient/msg/GraspCandidate`.
    pub(crate) name: String,
    /// e.g. `ros2msg`.
    pub(crate) encoding: String,
    /// The definition.
    pub(crate) data: &'a [u8],
}

/// A channel record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Channel {
    /// Its id.
    pub(crate) id: u16,
    /// Its schema's id, 0 for none.
    pub(crate) schema_id: u16,
    /// The topic.
    pub(crate) topic: String,
    /// e.g. `cdr`.
    pub(crate) message_encoding: String,
    /// e.g. `offered_qos_profiles`.
    pub(crate) metadata: BTreeMap<String, String>,
}

/// A message record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Message<'a> {
    /// Its channel's id.
    pub(crate) channel_id: u16,
    /// Its sequence number.
    pub(crate) sequence: u32,
    /// Receive time, ns.
    pub(crate) log_time: u64,
    /// Send time, ns.
    pub(crate) publish_time: u64,
    /// The payload.
    pub(crate) data: &'a [u8],
}

/// A chunk record, still compressed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Chunk<'a> {
    /// Size of its records once decompressed.
    pub(crate) uncompressed_size: u64,
    /// CRC-32 of its decompressed records, 0 when not computed.
    pub(crate) uncompressed_crc: u32,
    /// `""`, `lz4` or `zstd`.
    pub(crate) compression: String,
    /// The compressed records.
    pub(crate) data: &'a [u8],
}

/// An attachment record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Attachment<'a> {
    /// When it was logged, ns.
    pub(crate) log_time: u64,
    /// When it was created, ns.
    pub(crate) create_time: u64,
    /// Its name.
    pub(crate) name: String,
    /// Its media type.
    pub(crate) media_type: String,
    /// Its bytes.
    pub(crate) data: &'a [u8],
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
    pub(crate) chunk_start: u64,
    /// Length of the whole chunk record (opcode and length field included).
    pub(crate) chunk_length: u64,
    /// Size of its compressed records.
    pub(crate) compressed_size: u64,
    /// Size of its records once decompressed.
    pub(crate) uncompressed_size: u64,
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

#[cfg(test)]
mod tests {
    use super::super::frame::{record_bytes as record, Records};
    use super::*;

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
}
