//! `recover`: what a cut-short or damaged recording still holds, copied into a fresh, finished
//! MCAP file with the same profile, schemas, channels and metadata.
//!
//! Damage in one record never hides the records after it:
//! - When the summary's CRC verifies (`summary`), its chunk, metadata and attachment
//!   indexes say where each of those records lies and how long it is. Each is read at its place
//!   on its own: one whose opcode, length, fields, decompression or CRC do not check out is
//!   dropped, and the walk goes on at the next record the index places.
//! - Elsewhere (no usable summary, or bytes between indexed records), the walk goes record by
//!   record; at a record that does not read, it finds the next offset where a record that
//!   verifies starts (`resync`) and goes on from there.
//!
//! Only what verifies is kept: a chunk is kept whole or dropped whole, and so is a message whose
//! channel no record defines. What is dropped is counted per topic: exactly, from the summary's
//! statistics, when the summary verifies; else from the message index records that follow a
//! dropped chunk; where neither says, the loss is reported as uncounted. A data section CRC that
//! does not match is reported too. [`Recovered::lost_anything`] is what `recover`'s exit code
//! follows.
//!
//! The pieces, in `recover/`: `summary.rs` (the summary read from the end: where its indexes
//! place each record), `walk.rs` (how the data section is walked), `resync.rs` (where records
//! start again after damage), `lost.rs` (what a damaged place is reported as), `copy.rs` (what is
//! written), `report.rs` (what is saved and lost, as [`Recovered`]).

mod copy;
mod lost;
mod report;
mod resync;
mod summary;
mod walk;

use super::bag::{read_file, BagError};
use super::output::Replacement;
use super::scan::{self, Table};
use copy::{copy_counts, topic, Copy};
pub use report::{RecoverError, Recovered};
use std::collections::BTreeMap;
use std::io::{Seek, Write};
use std::path::Path;
use summary::Summary;
use walk::Walk;

/// Recovers `broken` into `fixed`, which is written under a temporary name beside it and renamed
/// into place only when complete (a crash leaves whatever `fixed` was before). Refuses to write
/// over `broken` itself.
pub fn recover(broken: &Path, fixed: &Path) -> Result<Recovered, BagError> {
    let output = Replacement::create(fixed, &[broken])?;
    let bytes = read_file(broken)?;
    let (file, output) = output.into_parts();
    let (got, file) =
        recover_bytes(&bytes, std::io::BufWriter::new(file)).map_err(|e| match e {
            RecoverError::NotMcap(damage) => BagError::Damaged {
                path: broken.to_path_buf(),
                damage,
            },
            RecoverError::Write(source) => BagError::Mcap {
                path: fixed.to_path_buf(),
                source,
            },
        })?;
    let io = |source| BagError::Io {
        path: fixed.to_path_buf(),
        source,
    };
    drop(file.into_inner().map_err(|e| io(e.into_error()))?);
    output.commit().map_err(io)?;
    Ok(got)
}

/// The copying: walks `bytes` and writes what verifies to `out`, which it returns finished.
pub fn recover_bytes<W: Write + Seek>(
    bytes: &[u8],
    out: W,
) -> Result<(Recovered, W), RecoverError> {
    let (profile, first) = scan::header(bytes).map_err(RecoverError::NotMcap)?;
    let mut got = Recovered {
        profile,
        ..Recovered::default()
    };
    let mut copy = Copy::new(out, &got.profile)?;
    let mut table = Table::default();
    let summary = summary::read(bytes);
    match &summary {
        Ok(s) => {
            for schema in &s.schemas {
                table.add_schema(schema, 0).ok();
            }
            for channel in &s.channels {
                table.add_channel(channel, 0).ok();
            }
            if s.shift != 0 {
                got.damaged(|| {
                    format!(
                        "the summary lies {} bytes from where its footer says: bytes were {} \
                         before it (the records its index places are looked for at both places)",
                        s.shift.unsigned_abs(),
                        if s.shift > 0 { "inserted" } else { "removed" }
                    )
                });
            }
        }
        Err(Some(d)) => got
            .notes
            .push(format!("the summary is not used {d}; a new one is written")),
        Err(None) => {}
    }
    let mut walk = Walk::new(bytes, summary.as_ref().ok());
    walk.run(first, &mut copy, &mut table, &mut got)?;
    got.kept = copy_counts(&copy.kept, &table);
    got.chunks_kept = walk.chunks_kept;
    if let Ok(s) = &summary {
        exact_counts(s, &copy.kept, &table, &mut got);
    }
    let out = copy.finish(&table)?;
    Ok((got, out))
}

/// With a verified summary, the exact numbers dropped: per channel from its statistics, and the
/// chunks of its index that were not kept.
fn exact_counts(s: &Summary<'_>, kept: &BTreeMap<u16, u64>, table: &Table, got: &mut Recovered) {
    got.chunks_dropped = (s.chunks.len() as u64).saturating_sub(got.chunks_kept);
    let Some((_, per_channel)) = &s.statistics else {
        return;
    };
    let mut dropped = BTreeMap::new();
    for (id, n) in per_channel {
        let kept = kept.get(id).copied().unwrap_or(0);
        if *n > kept {
            *dropped.entry(topic(table, *id)).or_default() += n - kept;
        }
    }
    got.dropped = dropped;
    got.uncounted = 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::bag::{read_bytes, Bag};
    use crate::record::scan::{op, Parsed};
    use crate::record::settings::{SettingsRecord, METADATA_NAME};
    use crate::record::{BagWriter, Entry, Payload};
    use std::io::Cursor;

    /// A small recording as the node writes it: settings metadata, the paper's cases with their
    /// answers, in two chunks.
    fn node_bag() -> Vec<u8> {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let path = dir.path().join("node.mcap");
        let mut w = BagWriter::create(&path, &crate::record::tests::topics(), 100).expect("create");
        let settings = SettingsRecord {
            since: 0,
            node: "/grasp_orient".into(),
            reason: "start".into(),
            config: crate::config::Config::default(),
        };
        w.write(&Entry {
            payload: Payload::settings(settings),
            log_time: 0,
            publish_time: 0,
        })
        .expect("settings");
        for (i, c) in crate::msg::paper_cases().into_iter().enumerate() {
            let a = crate::answer::answer(&c, &crate::solver::Settings::default());
            let t = 1_000 + i as u64;
            for payload in [
                Payload::request::<crate::kind::Candidates>(c.clone()),
                Payload::answer::<crate::kind::Candidates>(a),
            ] {
                w.write(&Entry {
                    payload,
                    log_time: t,
                    publish_time: t,
                })
                .expect("write");
            }
            if i == 1 {
                w.flush().expect("a second chunk");
            }
        }
        w.finish().expect("finish");
        std::fs::read(&path).expect("read back")
    }

    fn golden() -> Vec<u8> {
        std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/bags/paper_cases.mcap"
        ))
        .expect("the golden bag")
    }

    fn recover_in_memory(bytes: &[u8]) -> Result<(Recovered, Vec<u8>), RecoverError> {
        recover_bytes(bytes, Cursor::new(Vec::new())).map(|(got, out)| (got, out.into_inner()))
    }

    /// What a reader sees of a bag: the messages and the metadata.
    fn content(bag: &Bag) -> impl PartialEq + std::fmt::Debug + '_ {
        (
            &bag.streams.candidates.requests,
            &bag.streams.candidates.answers,
            bag.other,
            &bag.metadata,
        )
    }

    #[test]
    fn a_whole_file_is_copied_whole_and_nothing_is_reported_lost() {
        for bytes in [node_bag(), golden()] {
            let (got, out) = recover_in_memory(&bytes).expect("recovers");
            assert!(!got.lost_anything(), "{got:?}");
            let (a, b) = (
                read_bytes(&bytes).expect("whole"),
                read_bytes(&out).expect("whole"),
            );
            assert_eq!(content(&a), content(&b));
            assert_eq!(got.kept_total(), 8);
        }
        let (got, _) = recover_in_memory(&node_bag()).expect("recovers");
        assert_eq!(got.metadata, 1, "the settings are kept");
        assert_eq!(got.profile, "ros2");
    }

    /// A flip in every byte of two bags (bit `i % 8` of byte `i`; every byte, so every field
    /// of every record): `recover` never panics, and either reports a loss or wrote exactly
    /// what the undamaged file holds. The strict reader refuses every flip of the bag our
    /// writer made (it has a data section CRC); of the one mcap_ros2 wrote (which has none), it
    /// refuses every flip that changes what the file holds.
    #[test]
    fn a_flip_in_any_byte_is_caught() {
        for (original, data_crc) in [(node_bag(), true), (golden(), false)] {
            let whole = read_bytes(&original).expect("the original reads");
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            let share = original.len().div_ceil(threads);
            let silent: Vec<String> = std::thread::scope(|scope| {
                let handles: Vec<_> = (0..original.len())
                    .collect::<Vec<_>>()
                    .chunks(share)
                    .map(|bytes_to_flip| {
                        let (original, whole) = (&original, &whole);
                        let bytes_to_flip = bytes_to_flip.to_vec();
                        scope.spawn(move || {
                            let mut silent = Vec::new();
                            let mut bytes = original.clone();
                            for i in bytes_to_flip {
                                let bit = 1u8 << (i % 8);
                                bytes[i] ^= bit;
                                let what = format!("byte {i} bit {bit:#04x}");
                                match read_bytes(&bytes) {
                                    Ok(_) if data_crc => silent.push(format!("{what}: read it")),
                                    Ok(b) if content(&b) != content(whole) => {
                                        silent.push(format!("{what}: read it differently"));
                                    }
                                    _ => {}
                                }
                                if let Ok((got, out)) = recover_in_memory(&bytes) {
                                    let same = || {
                                        read_bytes(&out)
                                            .is_ok_and(|b| content(&b) == content(whole))
                                    };
                                    if !got.lost_anything() && !same() {
                                        silent.push(format!(
                                            "{what}: recover reported nothing lost but wrote \
                                             something else"
                                        ));
                                    }
                                }
                                bytes[i] ^= bit;
                            }
                            silent
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().expect("no panic"))
                    .collect()
            });
            assert!(
                silent.is_empty(),
                "{} silent flips: {:?}",
                silent.len(),
                &silent[..silent.len().min(10)]
            );
        }
    }

    #[test]
    fn a_cut_file_keeps_its_whole_chunks_and_reports_a_cut_one() {
        let bytes = node_bag();
        let whole = read_bytes(&bytes).expect("whole");
        let scan = scan::scan(&bytes).expect("scans");
        let chunks: Vec<(usize, usize)> = scan
            .items
            .iter()
            .filter_map(|i| match &i.parsed {
                Ok(Parsed::Chunk(c)) => {
                    let start = i.offset as usize;
                    let end = c.data.as_ptr() as usize - bytes.as_ptr() as usize + c.data.len();
                    Some((start, end))
                }
                _ => None,
            })
            .collect();
        // The settings record ends where the next record starts.
        let metadata = scan
            .items
            .windows(2)
            .find(|w| w[0].opcode == op::METADATA)
            .map(|w| (w[0].offset as usize, w[1].offset as usize))
            .expect("the settings record");
        let header_end = 8 + 9 + 30;
        for end in 0..bytes.len() {
            match recover_in_memory(&bytes[..end]) {
                Err(RecoverError::NotMcap(d)) => assert!(end < header_end, "at {end}: {d}"),
                Err(e) => panic!("at {end}: {e}"),
                Ok((got, out)) => {
                    let back = read_bytes(&out).expect("the output is whole");
                    assert!(
                        whole
                            .streams
                            .candidates
                            .requests
                            .starts_with(&back.streams.candidates.requests),
                        "at {end}"
                    );
                    let in_a_chunk = chunks.iter().any(|(s, e)| *s < end && end < *e);
                    let in_metadata = (metadata.0 < end) && (end < metadata.1);
                    assert_eq!(
                        got.uncounted,
                        u64::from(in_a_chunk),
                        "cut at {end}: {got:?}"
                    );
                    assert_eq!(
                        got.lost_anything(),
                        in_a_chunk || in_metadata,
                        "cut at {end}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_flipped_chunk_opcode_drops_the_chunk_and_counts_it_per_topic() {
        let mut bytes = node_bag();
        let scan = scan::scan(&bytes).expect("scans");
        let chunk = scan
            .items
            .iter()
            .filter(|i| i.opcode == op::CHUNK)
            .nth(2)
            .expect("a chunk with messages")
            .offset;
        bytes[chunk as usize] = 0x86;
        let (got, out) = recover_in_memory(&bytes).expect("recovers");
        assert!(got.lost_anything());
        assert_eq!(got.dropped.get("/grasp_candidates"), Some(&2), "{got:?}");
        assert_eq!(
            got.dropped.get("/grip_recommendations"),
            Some(&2),
            "{got:?}"
        );
        assert_eq!(
            read_bytes(&out)
                .expect("whole")
                .streams
                .candidates
                .requests
                .len(),
            2
        );
        // The same chunk with a flipped bit in its compressed records.
        let mut bytes = node_bag();
        bytes[chunk as usize + 100] ^= 0x10;
        let (got, _) = recover_in_memory(&bytes).expect("recovers");
        assert_eq!(got.dropped_total(), 4, "{got:?}");
        assert!(
            got.damage[0].starts_with(&format!("at byte {chunk}: chunk record: ")),
            "{got:?}"
        );
    }

    #[test]
    fn what_is_not_a_recording_is_refused() {
        for bytes in [
            &b""[..],
            scan::MAGIC,
            b"\x00\x01random bytes that are no MCAP at all",
        ] {
            assert!(matches!(
                recover_in_memory(bytes),
                Err(RecoverError::NotMcap(_))
            ));
        }
        assert_eq!(METADATA_NAME, "grasp_orient.settings");
    }
}
