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
//!
//! The pieces, in `scan/`: `frame.rs` (the magic, the opcodes, a record's length against what
//! remains, the damage reported), `fields.rs` (one record's fields), `chunk.rs` (a chunk
//! decompressed, and the limit on what a file's chunks declare), `walk.rs` (the whole file, its
//! sections and CRCs), `table.rs` (the schemas and channels met). Why this reader is not the
//! `mcap` crate's: `docs/recordings.md`, "Why the reader is our own where it is".

pub(crate) mod chunk;
mod fields;
pub(crate) mod frame;
mod table;
mod walk;

pub(crate) use chunk::decompressed_limit;
pub(crate) use chunk::{chunk_fills_its_record, decompress, Undecompressable};
pub(crate) use fields::{
    parse, parse_chunk_index, parse_record_index, Channel, Chunk, ChunkIndex, Message, Parsed,
    Schema,
};
pub(crate) use frame::Damage;
pub(crate) use frame::{op, Record, Records, MAGIC};
pub(crate) use table::{KnownSchema, Table};
pub(crate) use walk::{header, scan, Item, Scan};
