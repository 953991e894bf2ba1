//! Reading MCAP bytes with every length taken from the file checked before anything is
//! allocated, for [`super::bag`].
//!
//! mcap's in-memory readers (`MessageStream`, `Summary::stream_chunk`) trust the lengths of the
//! records inside a chunk: one flipped bit asked for an 8.5e18-byte buffer ("capacity
//! overflow"). The readers here drive mcap's sans-io reader themselves, with a limit on every
//! record and every read: [`record_limit`] of the file's size. A record larger than that is an
//! error ([`mcap::McapError::RecordTooLarge`]), never an allocation.
//!
//! What that bounds: every buffer mcap or this module allocates for a file of `n` bytes holds at
//! most `record_limit(n)` bytes, besides the file itself. Chunks decompress one record at a time,
//! so a chunk's declared size allocates nothing. The C decoders keep their own state: lz4 at most
//! 4 MiB and a bit per frame, zstd at most its 128 MiB default window.

use mcap::read::ChannelAccumulator;
use mcap::records::{ChunkIndex, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{McapError, McapResult, Message, Summary};
use std::borrow::Cow;
use std::io::Read;
use std::path::Path;

/// How many times its compressed size a record may be: lz4 cannot expand data more than 255
/// times; zstd can, and such chunks are refused unless [`MIN_RECORD_LIMIT`] covers them.
pub const MAX_EXPANSION: usize = 1024;
/// The limit for small files: records up to 1 MiB are always accepted.
pub const MIN_RECORD_LIMIT: usize = 1 << 20;

/// The largest record accepted in a file of `file_len` bytes.
pub fn record_limit(file_len: usize) -> usize {
    file_len.saturating_mul(MAX_EXPANSION).max(MIN_RECORD_LIMIT)
}

/// The bytes of a regular file, read up to the length it has when opened: a device such as
/// `/dev/zero`, a pipe or a directory is refused rather than read forever.
pub fn read_file(path: &Path) -> std::io::Result<Vec<u8>> {
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    let len = usize::try_from(meta.len()).map_err(std::io::Error::other)?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len)
        .map_err(std::io::Error::other)?;
    file.take(meta.len()).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// The summary of a whole file (`mcap::Summary::read`, which `bag::read` uses to read chunks in
/// parallel), once every string in the summary section is known to fit in its record.
pub fn summary(bytes: &[u8]) -> McapResult<Option<Summary>> {
    // As mcap's summary reader finds the section: the footer's summary start, records from
    // there to the end magic, each at most what is left of the file.
    const FOOTER_AND_MAGIC: usize = 1 + 8 + 20 + 8;
    let Some(footer) = bytes
        .len()
        .checked_sub(FOOTER_AND_MAGIC)
        .and_then(|at| bytes.get(at + 9..at + 17))
    else {
        return Summary::read(bytes);
    };
    let start = u64::from_le_bytes(footer.try_into().map_err(|_| McapError::BadFooter)?);
    if let Some(section) = usize::try_from(start).ok().and_then(|s| bytes.get(s..)) {
        if start != 0 {
            let options = LinearReaderOptions::default()
                .with_skip_start_magic(true)
                .with_record_length_limit(section.len());
            let mut reader = LinearReader::new_with_options(options);
            let mut rest = section;
            while let Some(event) = reader.next_event() {
                match event {
                    // Whatever else is wrong, mcap's own reader meets it the same way.
                    Err(_) => break,
                    Ok(LinearReadEvent::ReadRequest(need)) => {
                        let n = need.min(rest.len());
                        let (now, later) = rest.split_at(n);
                        reader.insert(n).copy_from_slice(now);
                        reader.notify_read(n);
                        rest = later;
                    }
                    Ok(LinearReadEvent::Record { opcode, data }) => check_strings(opcode, data)?,
                }
            }
        }
    }
    Summary::read(bytes)
}

/// The header record of a file (profile and library), if its first record is one that parses.
pub fn header(bytes: &[u8]) -> Option<mcap::records::Header> {
    let options = LinearReaderOptions::default()
        .with_skip_end_magic(true)
        .with_emit_chunks(true)
        .with_record_length_limit(bytes.len());
    let mut reader = LinearReader::new_with_options(options);
    let mut rest = bytes;
    loop {
        match reader.next_event()?.ok()? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
            }
            LinearReadEvent::Record { opcode, data } => {
                check_strings(opcode, data).ok()?;
                return match mcap::parse_record(opcode, data).ok()? {
                    Record::Header(h) => Some(h),
                    _ => None,
                };
            }
        }
    }
}

/// Fails when a string inside record `body` claims more bytes than the record has left: mcap
/// parses strings (`binrw`'s `count`) by reserving their claimed length before reading them, so
/// a flipped bit in a length asked for gigabytes. The walk follows mcap's record layouts up to
/// each record's last string.
pub fn check_strings(opcode: u8, body: &[u8]) -> McapResult<()> {
    use mcap::records::op;
    /// Fixed bytes, one string, a map of strings, or the `u16 → u64` map of a chunk index.
    enum Field {
        Fixed(usize),
        Str,
        StrMap,
        IdMap,
    }
    use Field::{Fixed, IdMap, Str, StrMap};
    let layout: &[Field] = match opcode {
        op::HEADER => &[Str, Str],
        op::SCHEMA => &[Fixed(2), Str, Str],
        op::CHANNEL => &[Fixed(4), Str, Str, StrMap],
        op::CHUNK => &[Fixed(28), Str],
        op::CHUNK_INDEX => &[Fixed(32), IdMap, Fixed(8), Str],
        op::ATTACHMENT => &[Fixed(16), Str, Str],
        op::ATTACHMENT_INDEX => &[Fixed(40), Str, Str],
        op::METADATA => &[Str, StrMap],
        op::METADATA_INDEX => &[Fixed(16), Str],
        _ => &[],
    };
    let too_long = |len: u64| McapError::RecordTooLarge { opcode, len };
    let mut at = 0usize;
    // Moves past `n` bytes; false when the record ends first (mcap then fails without
    // allocating, so the walk may stop).
    let skip = |at: &mut usize, n: usize| match at.checked_add(n) {
        Some(end) if end <= body.len() => {
            *at = end;
            true
        }
        _ => false,
    };
    let u32_at = |at: usize| {
        body.get(at..at + 4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_le_bytes)
    };
    let string = |at: &mut usize| -> McapResult<bool> {
        let Some(len) = u32_at(*at) else {
            return Ok(false);
        };
        *at += 4;
        if !skip(at, len as usize) {
            return Err(too_long(len.into()));
        }
        Ok(true)
    };
    for field in layout {
        let more = match field {
            Fixed(n) => skip(&mut at, *n),
            Str => string(&mut at)?,
            StrMap | IdMap => {
                let Some(map_len) = u32_at(at) else {
                    return Ok(());
                };
                at += 4;
                let end = at.saturating_add(map_len as usize);
                let mut ok = true;
                // As mcap reads maps: whole entries while the start is inside the map's bytes.
                while ok && at < end {
                    ok = match field {
                        StrMap => string(&mut at)? && string(&mut at)?,
                        _ => skip(&mut at, 2 + 8),
                    };
                }
                ok
            }
        };
        if !more {
            return Ok(());
        }
    }
    Ok(())
}

/// The messages of MCAP bytes in file order, each linked to its channel, like
/// `mcap::MessageStream` but with every record bounded by [`record_limit`]. Nothing is yielded
/// after the first error.
pub struct Messages<'a> {
    rest: &'a [u8],
    reader: LinearReader,
    channels: ChannelAccumulator<'static>,
    stop_at_data_end: bool,
    past_data_end: bool,
    done: bool,
}

impl std::fmt::Debug for Messages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("rest", &self.rest.len())
            .field("done", &self.done)
            .finish_non_exhaustive()
    }
}

impl<'a> Messages<'a> {
    /// Every message of a whole file. With `ignore_end_magic` (a recording cut short), reading
    /// ends at the data end record, or at the first error.
    pub fn file(bytes: &'a [u8], ignore_end_magic: bool) -> Self {
        let options = LinearReaderOptions::default()
            .with_skip_end_magic(ignore_end_magic)
            .with_record_length_limit(record_limit(bytes.len()));
        Self::new(
            bytes,
            options,
            ChannelAccumulator::default(),
            ignore_end_magic,
        )
    }

    /// The messages of one chunk of `file`, found by its index in `summary`; checked against the
    /// file's size before anything is read.
    pub fn chunk(file: &'a [u8], index: &ChunkIndex, summary: &Summary) -> McapResult<Self> {
        let start = usize::try_from(index.chunk_start_offset).map_err(|_| McapError::BadIndex)?;
        let len = usize::try_from(index.chunk_length).map_err(|_| McapError::BadIndex)?;
        let bytes = start
            .checked_add(len)
            .and_then(|end| file.get(start..end))
            .ok_or(McapError::BadIndex)?;
        // A chunk index must point at a chunk record, not at any record that happens to be there.
        if bytes.first() != Some(&mcap::records::op::CHUNK) {
            return Err(McapError::BadIndex);
        }
        let options = LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_record_length_limit(record_limit(file.len()));
        Ok(Self::new(
            bytes,
            options,
            ChannelAccumulator::from_summary(summary),
            true,
        ))
    }

    fn new(
        bytes: &'a [u8],
        options: LinearReaderOptions,
        channels: ChannelAccumulator<'static>,
        stop_at_data_end: bool,
    ) -> Self {
        Self {
            rest: bytes,
            reader: LinearReader::new_with_options(options.with_emit_chunks(false)),
            channels,
            stop_at_data_end,
            past_data_end: false,
            done: false,
        }
    }

    /// The next message, `None` at the end; an error ends the stream.
    fn step(&mut self) -> Option<McapResult<Message<'static>>> {
        loop {
            let (opcode, data) = match self.reader.next_event()? {
                Err(e) => return Some(Err(e)),
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let n = need.min(self.rest.len());
                    let (now, later) = self.rest.split_at(n);
                    self.reader.insert(n).copy_from_slice(now);
                    self.reader.notify_read(n);
                    self.rest = later;
                    continue;
                }
                Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
            };
            if let Err(e) = check_strings(opcode, data) {
                return Some(Err(e));
            }
            let record = match mcap::parse_record(opcode, data) {
                Ok(r) => r,
                Err(e) => return Some(Err(e)),
            };
            // The summary repeats schemas and channels: read on to the end magic without
            // re-checking them.
            if self.past_data_end {
                continue;
            }
            let linked = match record {
                Record::Schema { header, data } => self
                    .channels
                    .add_schema(header, Cow::Owned(data.into_owned())),
                Record::Channel(channel) => self.channels.add_channel(channel),
                Record::Message { header, data } => {
                    return Some(match self.channels.get(header.channel_id) {
                        Some(channel) => Ok(Message {
                            channel,
                            sequence: header.sequence,
                            log_time: header.log_time,
                            publish_time: header.publish_time,
                            data: Cow::Owned(data.into_owned()),
                        }),
                        None => Err(McapError::UnknownChannel(
                            header.sequence,
                            header.channel_id,
                        )),
                    });
                }
                Record::DataEnd(_) if self.stop_at_data_end => return None,
                Record::DataEnd(_) => {
                    self.past_data_end = true;
                    Ok(())
                }
                _ => Ok(()),
            };
            if let Err(e) = linked {
                return Some(Err(e));
            }
        }
    }
}

impl Iterator for Messages<'_> {
    type Item = McapResult<Message<'static>>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = self.step();
        if !matches!(next, Some(Ok(_))) {
            self.done = true;
        }
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file whose one chunk holds a message record claiming `u64::MAX / 2` bytes.
    fn lying_file() -> Vec<u8> {
        let mut out = Vec::new();
        let mut writer = mcap::WriteOptions::new()
            .compression(None)
            .create(std::io::Cursor::new(&mut out))
            .expect("writer");
        let schema = writer
            .add_schema("s", "ros2msg", b"int32 a")
            .expect("schema");
        let channel = writer
            .add_channel(schema, "/t", "cdr", &Default::default())
            .expect("channel");
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: 1,
            log_time: 1,
            publish_time: 1,
        };
        writer
            .write_to_known_channel(&header, &[0xAB; 8])
            .expect("message");
        writer.finish().expect("finish");
        drop(writer);
        // The message record: opcode 5, then its length; make the length absurd.
        let at = out
            .windows(9)
            .position(|w| w[0] == mcap::records::op::MESSAGE && w[1..9] == 30u64.to_le_bytes())
            .expect("the message record");
        out[at + 1..at + 9].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
        out
    }

    #[test]
    fn a_record_longer_than_the_file_is_an_error_not_an_allocation() {
        let bytes = lying_file();
        let got: Vec<_> = Messages::file(&bytes, false).collect();
        assert!(
            matches!(got.last(), Some(Err(McapError::RecordTooLarge { .. }))),
            "{got:?}"
        );
        let summary = Summary::read(&bytes).expect("a summary").expect("present");
        for index in &summary.chunk_indexes {
            let got: Vec<_> = Messages::chunk(&bytes, index, &summary)
                .expect("the index is in the file")
                .collect();
            assert!(matches!(got.last(), Some(Err(_))), "{got:?}");
        }
        let mut bad = summary.chunk_indexes[0].clone();
        bad.chunk_length = u64::MAX;
        assert!(Messages::chunk(&bytes, &bad, &summary).is_err());
    }

    #[test]
    fn only_regular_files_are_read() {
        let e = read_file(Path::new("/dev/zero")).expect_err("a device");
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(read_file(Path::new("/")).is_err());
    }
}
