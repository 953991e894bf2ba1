//! `recover` on the golden bags damaged in the ways users met: a flipped bit in the length field
//! of each chunk in turn, bytes inserted mid-file, a file cut short; with the summary, and with
//! the summary gone. Every intact chunk is kept, and the counts are exact: kept + dropped is the
//! bag's message count, checked against the layout the test reads from the file by hand. And the
//! files `recover -o` and `replay --write` write get the mode the umask gives.

use crate::util::run::{bin, temp_dir};
use grasp_orient::record::bag::read_bytes;
use grasp_orient::record::recover::{recover_bytes, Recovered};
use std::io::Cursor;
use std::path::Path;

/// `node_recorded.mcap`: 38 candidates, 38 answers and 8 marker arrays (`bags/README.md`), in
/// three chunks (the first holds the schemas and channels only).
const NODE_BAG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/node_recorded.mcap");
const NODE_BAG_MESSAGES: u64 = 84;

/// A chunk of a file as the test reads it by hand: its offset and length, and the messages the
/// message index records after it count.
#[derive(Debug, Clone, Copy)]
struct ChunkAt {
    offset: usize,
    length: usize,
    messages: u64,
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"))
}

/// The chunks of an undamaged file and where its data section ends (the offset of its data end
/// record), walking records by their lengths: opcode 0x06 a chunk, 0x07 a message index record
/// (channel u16, then a u32 length of 16-byte entries), 0x0F the data end.
fn layout(bytes: &[u8]) -> (Vec<ChunkAt>, usize) {
    let mut chunks: Vec<ChunkAt> = Vec::new();
    let mut at = 8;
    loop {
        let (op, len) = (bytes[at], u64_at(bytes, at + 1) as usize);
        match op {
            0x06 => chunks.push(ChunkAt {
                offset: at,
                length: 9 + len,
                messages: 0,
            }),
            0x07 => {
                let entries = u32::from_le_bytes(bytes[at + 11..at + 15].try_into().expect("4"));
                chunks.last_mut().expect("a chunk before").messages += u64::from(entries) / 16;
            }
            0x0F => return (chunks, at),
            _ => {}
        }
        at += 9 + len;
    }
}

fn node_bag() -> Vec<u8> {
    std::fs::read(NODE_BAG).expect("the golden bag")
}

fn recover(bytes: &[u8]) -> (Recovered, Vec<u8>) {
    let (got, out) = recover_bytes(bytes, Cursor::new(Vec::new())).expect("recovers");
    (got, out.into_inner())
}

/// Messages of every kind in a file that the strict reader reads.
fn messages_read(bytes: &[u8]) -> u64 {
    let b = read_bytes(bytes).expect("the output is a whole recording");
    (b.streams.candidates.requests.len() + b.streams.candidates.answers.len()) as u64
        + b.other
        + b.undecodable_count
}

/// `got` kept every message but those of `lost` (a chunk, or none), counted all of them, and
/// wrote a whole file holding what it kept.
fn kept_all_but(got: &Recovered, out: &[u8], lost: Option<ChunkAt>, what: &str) {
    let lost_messages = lost.map_or(0, |c| c.messages);
    assert_eq!(
        got.kept_total(),
        NODE_BAG_MESSAGES - lost_messages,
        "{what}: {got:?}"
    );
    assert_eq!(got.dropped_total(), lost_messages, "{what}: {got:?}");
    assert_eq!(got.uncounted, 0, "{what}: {got:?}");
    assert_eq!(
        (got.chunks_kept, got.chunks_dropped),
        (3 - u64::from(lost.is_some()), u64::from(lost.is_some())),
        "{what}: {got:?}"
    );
    assert_eq!(got.metadata, 2, "{what}: the settings records are kept");
    assert_eq!(messages_read(out), got.kept_total(), "{what}");
}

/// A flipped bit in the length field of each chunk in turn, low and high bits: that chunk is
/// dropped and counted, every other chunk is kept. With the summary, its chunk index places the
/// next chunk; with the summary cut off, the walk finds it by trying each byte.
#[test]
fn a_flipped_chunk_length_drops_that_chunk_alone_and_counts_it() {
    let whole = node_bag();
    let (chunks, data_end) = layout(&whole);
    assert_eq!(chunks.len(), 3);
    assert_eq!(
        chunks.iter().map(|c| c.messages).sum::<u64>(),
        NODE_BAG_MESSAGES
    );
    // Without its summary and footer: as a recorder killed after its data section leaves it.
    let no_summary = whole[..data_end + 13].to_vec();
    for chunk in &chunks {
        for (byte, bit) in [(1, 0x01), (1, 0x80), (2, 0x10), (3, 0x01), (8, 0x40)] {
            for (name, original) in [("with summary", &whole), ("no summary", &no_summary)] {
                let mut bytes = original.clone();
                bytes[chunk.offset + byte] ^= bit;
                let what = format!("{name}, chunk at {}, byte {byte} ^ {bit:#x}", chunk.offset);
                let (got, out) = recover(&bytes);
                if name == "with summary" {
                    kept_all_but(&got, &out, Some(*chunk), &what);
                } else {
                    // The first chunk holds the schemas and channels: without the summary,
                    // nothing else defines them, and every message is dropped, counted per
                    // channel.
                    let lost = if chunk.offset == chunks[0].offset {
                        NODE_BAG_MESSAGES
                    } else {
                        chunk.messages
                    };
                    assert_eq!(
                        got.kept_total(),
                        NODE_BAG_MESSAGES - lost,
                        "{what}: {got:?}"
                    );
                    assert_eq!(got.dropped_total(), lost, "{what}: {got:?}");
                    assert_eq!(messages_read(&out), got.kept_total(), "{what}");
                }
                assert!(got.lost_anything(), "{what}");
            }
        }
    }
}

/// Pseudo-random bytes (a fixed linear congruential sequence): what a stray write leaves.
fn noise(n: usize) -> Vec<u8> {
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (x >> 56) as u8
        })
        .collect()
}

/// 5 kB inserted mid-file: between records nothing is lost; inside a chunk, that chunk alone.
/// The summary, moved by the insertion, is found by its summary offset records, and its index
/// places the chunks after the insertion; without the summary, the walk finds them.
#[test]
fn inserted_bytes_lose_at_most_the_chunk_they_fall_in() {
    let whole = node_bag();
    let (chunks, data_end) = layout(&whole);
    let (c1, c2) = (chunks[1], chunks[2]);
    let places = [
        (c1.offset, None, "where the second chunk starts"),
        (
            c1.offset + c1.length / 2,
            Some(c1),
            "inside the second chunk",
        ),
        (c2.offset, None, "where the third chunk starts"),
        (c2.offset + 40, Some(c2), "inside the third chunk"),
    ];
    for fill in [noise(5000), vec![0; 5000]] {
        for (at, lost, name) in places {
            let mut bytes = whole[..at].to_vec();
            bytes.extend_from_slice(&fill);
            bytes.extend_from_slice(&whole[at..]);
            let what = format!("5000 bytes {name} (byte {at})");
            let (got, out) = recover(&bytes);
            kept_all_but(&got, &out, lost, &what);
            assert!(got.lost_anything(), "{what}: the insertion is damage");
            assert!(
                got.damage
                    .iter()
                    .any(|d| d.contains("5000 bytes") && d.contains("inserted")),
                "{what}: {got:?}"
            );
            // The same without the summary: chunks after the insertion are found by trying
            // each byte.
            let cut = data_end + 13 + fill.len();
            let (got, out) = recover(&bytes[..cut]);
            let lost = lost.map_or(0, |c| c.messages);
            assert_eq!(
                got.kept_total(),
                NODE_BAG_MESSAGES - lost,
                "{what}: {got:?}"
            );
            assert_eq!(got.dropped_total(), lost, "{what}: {got:?}");
            assert_eq!(messages_read(&out), got.kept_total(), "{what}");
        }
    }
}

/// Bytes removed inside a chunk move the summary back: it is found, and only that chunk is lost.
#[test]
fn removed_bytes_lose_only_the_chunk_they_were_in() {
    let whole = node_bag();
    let (chunks, _) = layout(&whole);
    for (chunk, n) in [(chunks[1], 100), (chunks[2], 7)] {
        let at = chunk.offset + chunk.length / 2;
        let mut bytes = whole[..at].to_vec();
        bytes.extend_from_slice(&whole[at + n..]);
        let what = format!("{n} bytes removed at {at}");
        let (got, out) = recover(&bytes);
        kept_all_but(&got, &out, Some(chunk), &what);
        assert!(
            got.damage
                .iter()
                .any(|d| d.contains(&format!("{n} bytes")) && d.contains("removed")),
            "{what}: {got:?}"
        );
    }
}

/// A file cut short keeps every chunk before the cut; the chunk cut through is dropped, and
/// nothing says how many messages it held.
#[test]
fn a_cut_file_keeps_every_chunk_before_the_cut() {
    let whole = node_bag();
    let (chunks, data_end) = layout(&whole);
    for (i, chunk) in chunks.iter().enumerate().skip(1) {
        let before: u64 = chunks[..i].iter().map(|c| c.messages).sum();
        for cut in [chunk.offset + 9 + 20, chunk.offset + chunk.length - 1] {
            let (got, out) = recover(&whole[..cut]);
            let what = format!("cut at {cut}, inside the chunk at {}", chunk.offset);
            assert_eq!(got.kept_total(), before, "{what}: {got:?}");
            assert_eq!(
                (got.uncounted, got.chunks_dropped),
                (1, 1),
                "{what}: {got:?}"
            );
            assert!(
                got.damage[0].contains(&format!("at byte {}: ", chunk.offset))
                    && got.damage[0].contains("cut short inside this record"),
                "{what}: {got:?}"
            );
            assert_eq!(messages_read(&out), before, "{what}");
        }
    }
    // Cut after the data section: nothing lost.
    let (got, _) = recover(&whole[..data_end + 13]);
    assert!(!got.lost_anything(), "{got:?}");
    assert_eq!(got.kept_total(), NODE_BAG_MESSAGES);
}

/// Every golden bag recovers whole, with nothing reported lost.
#[test]
fn every_golden_bag_recovers_whole() {
    for name in [
        "node_recorded",
        "paper_cases",
        "random_grasps",
        "rosbags_written",
    ] {
        let path = format!("{}/bags/{name}.mcap", env!("CARGO_MANIFEST_DIR"));
        let bytes = std::fs::read(&path).expect("a golden bag");
        let (got, out) = recover(&bytes);
        assert!(!got.lost_anything(), "{name}: {got:?}");
        assert_eq!(messages_read(&out), messages_read(&bytes), "{name}");
        assert_eq!(got.chunks_dropped, 0, "{name}");
    }
}

/// `recover` run as users run it on a bag with a flipped chunk length: it names the counts and
/// exits 1.
#[test]
fn the_command_prints_exact_counts_and_exits_1() {
    let dir = temp_dir("recover_counts");
    let mut bytes = node_bag();
    let (chunks, _) = layout(&bytes);
    bytes[chunks[1].offset + 2] ^= 0x01;
    let broken = dir.path().join("broken.mcap");
    std::fs::write(&broken, &bytes).expect("write");
    let fixed = dir.path().join("fixed.mcap");
    let out = bin()
        .args(["recover", s(&broken), "-o", s(&fixed)])
        .output()
        .expect("runs");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let kept = NODE_BAG_MESSAGES - chunks[1].messages;
    assert!(
        text.contains(&format!("recovered {kept} messages in 2 chunks"))
            && text.contains(&format!(
                "{} messages and 1 chunk dropped",
                chunks[1].messages
            )),
        "{text}"
    );
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8")
}

/// The mode of the file a command run under `umask` writes to `output`.
fn mode_written(umask: &str, command: &str, output: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    let script = format!("umask {umask} && exec \"$0\" {command} \"$1\"");
    let out = std::process::Command::new("sh")
        .args(["-c", &script, env!("CARGO_BIN_EXE_grasp_orient"), s(output)])
        .output()
        .expect("runs");
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{command}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::metadata(output)
        .expect("written")
        .permissions()
        .mode()
        & 0o777
}

/// The outputs of `recover -o` and `replay --write` get 0666 less the umask, like any file a
/// command creates (they are written under a temporary name and renamed).
#[test]
fn outputs_get_the_mode_the_umask_gives() {
    let dir = temp_dir("modes");
    for (umask, mode) in [("022", 0o644), ("027", 0o640), ("002", 0o664)] {
        for (command, name) in [
            (format!("recover {NODE_BAG} -o"), "recovered.mcap"),
            (format!("replay {NODE_BAG} --write"), "replayed.mcap"),
        ] {
            let output = dir.path().join(format!("{umask}-{name}"));
            assert_eq!(
                mode_written(umask, &command, &output),
                mode,
                "{command} under umask {umask}"
            );
        }
    }
}

/// A flipped bit anywhere after the header (every third byte, each bit in turn): kept + dropped
/// is the bag's message count, always; a flip in the data section damages one record, and one in
/// the summary leaves the data section to the walk.
#[test]
fn a_flip_anywhere_is_counted_exactly() {
    let whole = node_bag();
    // After the header record (a damaged header is no MCAP file: `recover` refuses it).
    let first = 8 + 9 + u64_at(&whole, 9) as usize;
    for i in (first..whole.len()).step_by(3) {
        let mut bytes = whole.clone();
        bytes[i] ^= 1 << (i % 8);
        let (got, out) = recover(&bytes);
        assert_eq!(messages_read(&out), got.kept_total(), "byte {i}");
        assert_eq!(got.uncounted, 0, "byte {i}: {got:?}");
        assert_eq!(
            got.kept_total() + got.dropped_total(),
            NODE_BAG_MESSAGES,
            "byte {i}: {got:?}"
        );
    }
}
