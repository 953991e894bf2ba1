//! A chunk's records decompressed: bounded by what the chunk declares and what the decompressor
//! produces, their size and CRC checked; and the limit on what the chunks of a file may declare.

use super::fields::Chunk;
use super::frame::Record;
use std::borrow::Cow;
use std::io::Read;

/// The most bytes of records the chunks of a file of `file_len` bytes may declare in all: 1024
/// times its size, and at least 1 MiB. The recordings of `grasp_orient` (lz4, whose ratio cannot
/// exceed 255) and of `recover` (zstd, a few times on messages) stay far below it; what lies
/// beyond it is a decompression bomb. So reading a file holds at most this much decompressed at a
/// time per thread, and decodes at most this much in all.
pub fn decompressed_limit(file_len: u64) -> u64 {
    file_len.saturating_mul(1024).max(1 << 20)
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
