//! The framing of MCAP records: the magic, the opcodes, a record's opcode and length checked
//! against the bytes that remain, and the [`Damage`] every reader reports.

use std::fmt;

/// The record opcodes: the `mcap` crate's, whose writer writes the recordings, so that reader and
/// writer share one definition.
pub(crate) use mcap::records::op;
/// The 8 bytes an MCAP file starts and ends with (the `mcap` crate's, as the opcodes).
pub(crate) use mcap::MAGIC;

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
    pub(super) fn at(offset: u64, what: impl Into<String>) -> Self {
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
    pub(crate) offset: u64,
    /// The opcode.
    pub(crate) opcode: u8,
    /// The body, exactly as long as the record says.
    pub(crate) body: &'a [u8],
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

/// The bytes of one record: opcode, length, body (for the tests of the readers).
#[cfg(test)]
pub(super) fn record_bytes(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut out = vec![opcode];
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
    out
}
