//! A decompression bomb in MCAP form, for the reader's tests (`tests/it/recordings.rs`) and the
//! fuzz test's seeds (`tests/fuzz.rs`, which takes this file as a module of its own).

/// The MCAP magic and the opcodes of the records written here, from the MCAP specification.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const CHUNK: u8 = 0x06;
    pub const DATA_END: u8 = 0x0F;
}

/// A whole, valid MCAP file of about 2 kB whose one zstd chunk holds 64 MiB of zeros: reading it
/// must stay within the budget of a 2 kB file (`record::scan::decompressed_limit`).
pub fn zstd_bomb() -> Vec<u8> {
    use std::io::Write;
    let record = |opcode: u8, body: &[u8]| {
        let mut out = vec![opcode];
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
        out
    };
    let string = |s: &str| {
        let mut out = (s.len() as u32).to_le_bytes().to_vec();
        out.extend_from_slice(s.as_bytes());
        out
    };
    let size = 64u64 << 20;
    let mut zstd = zstd::stream::write::Encoder::new(Vec::new(), 3).expect("an encoder");
    for _ in 0..size >> 16 {
        zstd.write_all(&[0; 1 << 16]).expect("compress");
    }
    let packed = zstd.finish().expect("compressed");
    let mut chunk = [0u8; 16].to_vec();
    chunk.extend_from_slice(&size.to_le_bytes());
    chunk.extend_from_slice(&0u32.to_le_bytes());
    chunk.extend(string("zstd"));
    chunk.extend_from_slice(&(packed.len() as u64).to_le_bytes());
    chunk.extend(packed);
    let mut bytes = MAGIC.to_vec();
    bytes.extend(record(op::HEADER, &[string("ros2"), string("")].concat()));
    bytes.extend(record(op::CHUNK, &chunk));
    bytes.extend(record(op::DATA_END, &0u32.to_le_bytes()));
    bytes.extend(record(op::FOOTER, &[0; 20]));
    bytes.extend_from_slice(MAGIC);
    bytes
}
