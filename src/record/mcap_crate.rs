//! Why the recordings' reader is our own ([`super::scan`], [`super::recover`]) and not
//! the `mcap` crate's, which writes every recording: the inputs on which its readers stop,
//! deliver unverified messages, panic or allocate what the file does not hold, where ours reads,
//! refuses with a byte offset, or goes on past the damage (`docs/recordings.md`, "Why the reader
//! is our own where it is"). Each test fails when the crate's readers stop behaving so, which
//! says that the reason given for our own reader no longer holds.
//!
//! The crate's readers: `mcap::MessageStream` with chunk CRCs checked (its reader of a file in
//! memory), and `mcap::sans_io::LinearReader` with every check it has (chunk CRCs before any
//! message of the chunk, the data section's and the summary's CRCs, a record length limit of
//! [`decompressed_limit`], what ours allows a file's chunks in all).
//!
//! `reader_time_and_memory` (ignored; by hand) measures the time and peak memory of each reader on
//! a large recording.

use super::bag::read_bytes;
use super::recover::recover_bytes;
use super::scan::{self, decompressed_limit, op, Parsed, Record, Records, MAGIC};
use super::{BagWriter, Entry, Payload};
use crate::kind::Candidates;
use mcap::read::Options;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::io::Cursor;
use std::panic::catch_unwind;
use std::path::Path;
use std::time::Instant;

/// `node_recorded.mcap`: 84 messages in three chunks (`bags/README.md`).
const NODE_BAG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/node_recorded.mcap");

/// What `MessageStream` gave: the messages before it ended, and the error it ended with.
#[derive(Debug, PartialEq)]
struct Streamed {
    messages: usize,
    error: Option<String>,
}

/// `mcap::MessageStream` with chunk CRCs checked; `None` when it panicked.
fn mcap_stream(bytes: &[u8]) -> Option<Streamed> {
    catch_unwind(|| {
        let mut messages = 0;
        let stream =
            match mcap::MessageStream::new_with_options(bytes, Options::ValidateChunkCrcs.into()) {
                Ok(stream) => stream,
                Err(e) => {
                    return Streamed {
                        messages,
                        error: Some(e.to_string()),
                    }
                }
            };
        for message in stream {
            match message {
                Ok(_) => messages += 1,
                Err(e) => {
                    return Streamed {
                        messages,
                        error: Some(e.to_string()),
                    }
                }
            }
        }
        Streamed {
            messages,
            error: None,
        }
    })
    .ok()
}

/// What the sans-io reader gave: the messages of the data section, the first error, and whether
/// asking again after it moved on (a record, or the end) rather than repeating it.
#[derive(Debug, PartialEq)]
struct Linear {
    messages: usize,
    error: Option<String>,
    moves_on: bool,
}

/// `mcap::sans_io::LinearReader` with every check, fed from memory.
fn mcap_linear(bytes: &[u8]) -> Linear {
    let options = LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(
            usize::try_from(decompressed_limit(bytes.len() as u64)).unwrap_or(usize::MAX),
        );
    let mut reader = LinearReader::new_with_options(options);
    let (mut fed, mut messages, mut summary) = (0, 0, false);
    let mut error: Option<String> = None;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(bytes.len() - fed);
                reader.insert(n).copy_from_slice(&bytes[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                if error.is_some() {
                    break;
                }
                summary |= opcode == op::DATA_END;
                // Each message's header and payload read, as our reader reads them.
                let message = opcode == op::MESSAGE
                    && !summary
                    && matches!(
                        mcap::parse_record(opcode, data),
                        Ok(mcap::records::Record::Message { .. })
                    );
                messages += usize::from(message);
            }
            Err(e) if error.is_none() => error = Some(e.to_string()),
            // The same error again: the reader does not get past it.
            Err(e) => {
                let again = Some(e.to_string()) == error;
                return Linear {
                    messages,
                    error,
                    moves_on: !again,
                };
            }
        }
    }
    Linear {
        messages,
        moves_on: true,
        error,
    }
}

/// Offset, length and messages of each chunk of an undamaged file, in file order, as the crate's own summary and chunk
/// reader count them (nothing of ours).
fn messages_per_chunk(bytes: &[u8]) -> Vec<(u64, u64, usize)> {
    let summary = mcap::read::Summary::read(bytes)
        .expect("a summary")
        .expect("it has one");
    let mut chunks: Vec<_> = summary.chunk_indexes.iter().collect();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    chunks
        .into_iter()
        .map(|c| {
            let mut n = 0;
            for message in summary.stream_chunk(bytes, c).expect("a chunk") {
                message.expect("a message");
                n += 1;
            }
            (c.chunk_start_offset, c.chunk_length, n)
        })
        .collect()
}

/// Messages `recover` keeps and counts dropped.
fn recovered(bytes: &[u8]) -> (u64, u64) {
    let (got, _) = recover_bytes(bytes, Cursor::new(Vec::new())).expect("recovers");
    (got.kept_total(), got.dropped_total())
}

/// One damaged place in a chunk: the crate's readers stop there (the sans-io one for good),
/// `MessageStream` first hands out the damaged chunk's messages; our strict reader refuses the
/// file at the chunk's offset, and `recover` keeps every other chunk.
#[test]
fn damage_in_one_chunk_stops_the_crates_readers_not_recover() {
    let bag = std::fs::read(NODE_BAG).expect("the golden bag");
    let chunks = messages_per_chunk(&bag);
    let total: usize = chunks.iter().map(|c| c.2).sum();
    let (damaged, length, in_it) = chunks[1];
    let at = usize::try_from(damaged).expect("an offset");
    let before: usize = chunks[..1].iter().map(|c| c.2).sum();
    assert!(in_it > 0 && total > before + in_it, "{chunks:?}");

    // A flipped bit in the middle of the chunk's compressed records.
    let mut bytes = bag.clone();
    bytes[at + usize::try_from(length / 2).expect("a length")] ^= 0x10;
    let streamed = mcap_stream(&bytes).expect("no panic");
    assert_eq!(streamed.messages, before + in_it, "{streamed:?}");
    assert!(streamed.error.is_some_and(|e| e.contains("CRC")));
    let linear = mcap_linear(&bytes);
    assert_eq!(
        (linear.messages, linear.moves_on),
        (before, false),
        "{linear:?}"
    );
    let refused = read_bytes(&bytes).expect_err("refused");
    assert_eq!(refused.offset, damaged, "{refused}");
    let kept = (total - in_it) as u64;
    assert_eq!(recovered(&bytes), (kept, in_it as u64));

    // A flipped bit in the chunk's length field.
    let mut bytes = bag.clone();
    bytes[at + 3] ^= 0x01;
    let linear = mcap_linear(&bytes);
    assert!(linear.messages < total && !linear.moves_on, "{linear:?}");
    assert_eq!(read_bytes(&bytes).expect_err("refused").offset, damaged);
    assert_eq!(recovered(&bytes), (kept, in_it as u64));

    // The chunk's opcode flipped to one MCAP does not define: `MessageStream` skips the chunk
    // without a word; the data section's CRC says it is damaged.
    let mut bytes = bag.clone();
    bytes[at] = 0x86;
    let streamed = mcap_stream(&bytes).expect("no panic");
    assert_eq!(
        streamed,
        Streamed {
            messages: total - in_it,
            error: None
        }
    );
    assert!(read_bytes(&bytes)
        .expect_err("refused")
        .what
        .contains("data section's CRC"));
    assert_eq!(recovered(&bytes), (kept, in_it as u64));
}

/// Bytes inserted between two chunks (a copy gone wrong): the crate's readers stop at them;
/// `recover` finds the summary moved and keeps every message.
#[test]
fn inserted_bytes_stop_the_crates_readers_not_recover() {
    let bag = std::fs::read(NODE_BAG).expect("the golden bag");
    let chunks = messages_per_chunk(&bag);
    let total: usize = chunks.iter().map(|c| c.2).sum();
    let at = usize::try_from(chunks[2].0).expect("an offset");
    let mut bytes = bag.clone();
    bytes.splice(at..at, [0u8; 3]);
    let read_up_to = chunks[..2].iter().map(|c| c.2).sum();
    let streamed = mcap_stream(&bytes).expect("no panic");
    assert_eq!(streamed.messages, read_up_to, "{streamed:?}");
    assert!(streamed.error.is_some());
    let linear = mcap_linear(&bytes);
    assert_eq!((linear.messages, linear.moves_on), (read_up_to, false));
    assert_eq!(read_bytes(&bytes).expect_err("refused").offset, at as u64);
    assert_eq!(recovered(&bytes), (total as u64, 0));
}

/// A file cut inside its last chunk (a killed recorder): here the crate's checked reader gives
/// what `recover` keeps, the whole chunks before the cut; it says neither where the cut is nor
/// that the rest is lost, which our strict reader and `recover` do.
#[test]
fn a_cut_file_is_where_the_crates_reader_serves() {
    let bag = std::fs::read(NODE_BAG).expect("the golden bag");
    let chunks = messages_per_chunk(&bag);
    let last = usize::try_from(chunks[2].0).expect("an offset");
    let whole: usize = chunks[..2].iter().map(|c| c.2).sum();
    let bytes = &bag[..last + 500];
    let linear = mcap_linear(bytes);
    assert_eq!(linear.messages, whole, "{linear:?}");
    assert!(linear.error.is_some_and(|e| !e.contains(&last.to_string())));
    let refused = read_bytes(bytes).expect_err("refused");
    assert!(
        refused.cut_short && refused.offset == last as u64,
        "{refused}"
    );
    let (got, _) = recover_bytes(bytes, Cursor::new(Vec::new())).expect("recovers");
    assert_eq!(
        (got.kept_total(), got.uncounted),
        (whole as u64, 1),
        "{got:?}"
    );
}

fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut out = vec![opcode];
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
    out
}

fn string(s: &str) -> Vec<u8> {
    let mut out = (s.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(s.as_bytes());
    out
}

/// A whole file: header, `records`, data end, an empty footer.
fn file(records: &[Vec<u8>]) -> Vec<u8> {
    let mut bytes = MAGIC.to_vec();
    bytes.extend(record(op::HEADER, &[string("ros2"), string("")].concat()));
    bytes.extend(records.concat());
    bytes.extend(record(op::DATA_END, &0u32.to_le_bytes()));
    bytes.extend(record(op::FOOTER, &[0; 20]));
    bytes.extend_from_slice(MAGIC);
    bytes
}

/// An attachment record whose body ends two bytes into its CRC field: the crate's record parser
/// (behind every one of its readers) slices past the body and panics; ours names the field.
#[test]
fn a_short_attachment_panics_the_crates_parser() {
    let mut body = [0u8; 16].to_vec();
    body.extend(string("a"));
    body.extend(string("b"));
    body.extend_from_slice(&0u64.to_le_bytes());
    body.extend_from_slice(&[0; 2]);
    let theirs = catch_unwind(|| mcap::parse_record(op::ATTACHMENT, &body).map(|_| ()));
    assert!(theirs.is_err(), "no panic: {theirs:?}");
    let bytes = file(&[record(op::ATTACHMENT, &body)]);
    assert_eq!(mcap_stream(&bytes), None, "MessageStream panics");
    let ours = scan::parse(&Record {
        offset: 0,
        opcode: op::ATTACHMENT,
        body: &body,
    })
    .expect_err("damage");
    assert!(ours.what.contains("crc needs 4 bytes"), "{ours}");
    assert!(read_bytes(&bytes).is_err());
    assert!(recover_bytes(&bytes, Cursor::new(Vec::new())).is_ok());
}

/// A 150-byte file whose one zstd chunk starts with a message record claiming 64 MiB: the
/// crate's `MessageStream` (no record length limit) makes room for the claim, zeroed, before it
/// finds nothing in it; ours refuses the chunk unopened (it declares more than 1024 times the
/// file). Each reader runs in a process of its own, whose peak resident memory is its own.
#[test]
fn a_claimed_length_is_allocated_by_the_crates_stream() {
    let claim = 64u64 << 20;
    let mut inner = vec![op::MESSAGE];
    inner.extend_from_slice(&claim.to_le_bytes());
    inner.extend_from_slice(&[0; 64]);
    let packed = zstd::encode_all(&inner[..], 3).expect("zstd");
    let mut chunk = [0u8; 16].to_vec();
    chunk.extend_from_slice(&(claim + 9).to_le_bytes());
    chunk.extend_from_slice(&0u32.to_le_bytes());
    chunk.extend(string("zstd"));
    chunk.extend_from_slice(&(packed.len() as u64).to_le_bytes());
    chunk.extend(packed);
    let bytes = file(&[record(op::CHUNK, &chunk)]);
    assert!(bytes.len() < 200);
    let ours = read_bytes(&bytes).expect_err("refused");
    assert!(ours.what.contains("1024 times"), "{ours}");
    let streamed = mcap_stream(&bytes).expect("no panic");
    assert!(streamed.error.is_some(), "{streamed:?}");

    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("claim.mcap");
    std::fs::write(&path, &bytes).expect("written");
    let peak = |which| in_child(which, &path).2;
    let (base, ours, recover, theirs) = (
        peak("file"),
        peak("ours-bag"),
        peak("recover"),
        peak("mcap-stream"),
    );
    println!("peak kB: baseline {base}, ours {ours}, recover {recover}, MessageStream {theirs}");
    let mib = 1024;
    assert!(
        ours < base + 4 * mib && recover < base + 4 * mib,
        "ours {ours}, recover {recover}"
    );
    assert!(
        theirs > base + claim / 1024 / 2,
        "MessageStream {theirs} kB"
    );
}

// ------------------------------------------------------------------------------------------
// The measurement

/// A recording of `n` candidates and their answers, those of `bags/random_grasps.mcap` in turn
/// under new ids and times, as the node writes it (lz4 chunks of 1 MiB).
fn large_bag(path: &std::path::Path, n: usize) {
    let golden = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/bags/random_grasps.mcap"
    ))
    .expect("the golden bag");
    let recorded = read_bytes(&golden).expect("reads").streams.candidates;
    let (candidates, recommendations) = (recorded.requests, recorded.answers);
    let mut writer = BagWriter::create(path, &super::tests::topics(), 100).expect("create");
    for i in 0..n {
        let (mut c, mut a) = (
            candidates[i % candidates.len()].message.clone(),
            recommendations[i % recommendations.len()].message.clone(),
        );
        c.id = format!("g{i}").into();
        a.candidate_id = c.id.clone();
        let time = 1_000_000_000 + i as u64 * 1000;
        for payload in [
            Payload::request::<Candidates>(c),
            Payload::answer::<Candidates>(a),
        ] {
            writer
                .write(&Entry {
                    payload,
                    log_time: time,
                    publish_time: time,
                })
                .expect("write");
        }
    }
    writer.finish().expect("finish");
}

/// Our reader at the level of the crate's: the file walked and checked, each chunk decompressed
/// and checked, each message record read (on one thread, no CDR decoding). Messages and their
/// payload bytes.
fn ours_records(bytes: &[u8]) -> (u64, u64) {
    let scan = scan::scan(bytes).expect("an MCAP file");
    assert!(scan.record_damage().is_none() && scan.section_damage().is_none());
    let (mut n, mut payload) = (0, 0);
    for item in &scan.items {
        if let Ok(Parsed::Chunk(chunk)) = &item.parsed {
            let records = scan::decompress(chunk).expect("decompresses");
            for record in Records::new(&records, 0, false) {
                if let Ok(Parsed::Message(m)) = scan::parse(&record.expect("a record")) {
                    n += 1;
                    payload += m.data.len() as u64;
                }
            }
        }
    }
    (n, payload)
}

/// The crate's `MessageStream` with chunk CRCs checked: messages and their payload bytes.
fn mcap_records(bytes: &[u8]) -> (u64, u64) {
    let stream = mcap::MessageStream::new_with_options(bytes, Options::ValidateChunkCrcs.into())
        .expect("a stream");
    stream
        .map(|m| m.expect("a message"))
        .fold((0, 0), |(n, p), m| (n + 1, p + m.data.len() as u64))
}

/// Peak resident memory of this process so far, kB (`VmHWM`).
fn peak_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmHWM")
}

/// One reader in a process of its own, for its peak memory: run by [`in_child`].
#[test]
#[ignore = "a child of the tests that measure memory"]
fn reader_child() {
    let (Ok(which), Ok(path)) = (
        std::env::var("GRASP_ORIENT_READER"),
        std::env::var("GRASP_ORIENT_READER_BAG"),
    ) else {
        return;
    };
    let bytes = std::fs::read(path).expect("the bag");
    let t = Instant::now();
    let messages = match which.as_str() {
        "file" => 0,
        "ours" => ours_records(&bytes).0,
        "ours-bag" => read_bytes(&bytes).map_or(0, |bag| bag.streams.candidates.len()),
        "recover" => {
            recover_bytes(&bytes, Cursor::new(Vec::new())).map_or(0, |(got, _)| got.kept_total())
        }
        "mcap-stream" => mcap_stream(&bytes).map_or(0, |s| s.messages as u64),
        "mcap-linear" => mcap_linear(&bytes).messages as u64,
        other => panic!("no reader {other}"),
    };
    let ms = t.elapsed().as_secs_f64() * 1e3;
    println!("READER {which} {messages} {ms:.1} {}", peak_kb());
}

/// Runs `which` reader on the file at `path` in a child process: messages read, milliseconds,
/// peak resident memory in kB.
fn in_child(which: &str, path: &Path) -> (u64, f64, u64) {
    let out = std::process::Command::new(std::env::current_exe().expect("this test"))
        .args([
            "--exact",
            "record::mcap_crate::reader_child",
            "--ignored",
            "--nocapture",
        ])
        .env("GRASP_ORIENT_READER", which)
        .env("GRASP_ORIENT_READER_BAG", path)
        .output()
        .expect("the child runs");
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("READER "))
        .unwrap_or_else(|| panic!("{which}: {text}"));
    let fields: Vec<&str> = line.split_whitespace().collect();
    (
        fields[1].parse().expect("messages"),
        fields[2].parse().expect("ms"),
        fields[3].parse().expect("kB"),
    )
}

/// Time and peak memory of each reader on a recording of 200,000 candidates and their answers
/// (`GRASP_ORIENT_READER_N` for another size), each in a process of its own, best of 3:
/// `cargo test --lib mcap_crate::reader_time_and_memory -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, by hand"]
fn reader_time_and_memory() {
    let n = std::env::var("GRASP_ORIENT_READER_N")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(200_000);
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("large.mcap");
    large_bag(&path, n);
    let bytes = std::fs::read(&path).expect("the bag");
    assert_eq!(
        ours_records(&bytes),
        mcap_records(&bytes),
        "the same messages"
    );
    println!(
        "{n} candidates and their answers, {:.1} MiB; time best of 3, peak resident memory:",
        bytes.len() as f64 / f64::from(1 << 20)
    );
    drop(bytes);
    for which in ["file", "ours", "ours-bag", "mcap-stream", "mcap-linear"] {
        let runs: Vec<(u64, f64, u64)> = (0..3).map(|_| in_child(which, &path)).collect();
        let ms = runs.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
        let kb = runs.iter().map(|r| r.2).min().unwrap_or(0);
        println!(
            "  {which:<12} {:>7} messages {ms:>7.0} ms  {:>7.1} MiB",
            runs[0].0,
            kb as f64 / 1024.0
        );
    }
}
