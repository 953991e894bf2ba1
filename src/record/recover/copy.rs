//! What `recover` writes: the output file, with the input's schemas and channels under the ids
//! the writer gives them, and the messages, metadata and attachments that verified.

use super::report::Recovered;
use crate::record::scan::{self, Parsed, Table};
use std::collections::{BTreeMap, HashMap};
use std::io::{Seek, Write};

/// The output being written: the MCAP writer and the ids it gave to the input's schemas and
/// channels.
pub(super) struct Copy<W: Write + Seek> {
    writer: mcap::Writer<W>,
    schemas: HashMap<u16, u16>,
    channels: HashMap<u16, u16>,
    /// Messages kept per input channel.
    pub(super) kept: BTreeMap<u16, u64>,
}

impl<W: Write + Seek> Copy<W> {
    pub(super) fn new(out: W, profile: &str) -> Result<Self, mcap::McapError> {
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
    pub(super) fn record(
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
    pub(super) fn finish(mut self, table: &Table) -> Result<W, mcap::McapError> {
        let mut ids: Vec<u16> = table.channels.keys().copied().collect();
        ids.sort_unstable();
        for id in ids {
            self.channel(table, id)?;
        }
        self.writer.finish()?;
        Ok(self.writer.into_inner())
    }
}

/// The topic of input channel `channel_id`, or `channel N` when no record names it.
pub(super) fn topic(table: &Table, channel_id: u16) -> String {
    table
        .channels
        .get(&channel_id)
        .map_or_else(|| format!("channel {channel_id}"), |c| c.topic.clone())
}

/// Messages kept per input channel, as messages kept per topic.
pub(super) fn copy_counts(kept: &BTreeMap<u16, u64>, table: &Table) -> BTreeMap<String, u64> {
    let mut out = BTreeMap::new();
    for (id, n) in kept {
        *out.entry(topic(table, *id)).or_default() += n;
    }
    out
}
