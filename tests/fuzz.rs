//! Bad bytes, proven: arbitrary and mutated bytes into every reader of outside data, with zero
//! panics, zero aborts, no hang, and memory bounded by the input's size.
//!
//! Targets: the CDR decoding of every message the node and the recordings read
//! (`GraspCandidate`, `GripRecommendation`, `GraspCandidateSet`, `GripRecommendationSet`,
//! `MarkerArray`; the node's DDS reader decodes with the same `cdr-encoding` crate and the same
//! serde implementations, after RustDDS has read the encapsulation header), a decoded candidate
//! answered and drawn as the node does (planar and spatial seeds: `model`, 3D components,
//! `rotation_axis`), the MCAP reader behind `replay` and
//! `play` (`bag::read_bytes`, which `bag::read` calls), `recover` (`recover::recover_bytes`), and
//! the JSON-lines reader behind `solve`. Inputs are random bytes (one in five) or valid seeds with one to eight mutations: bit
//! flips, bytes and boundary words (0, 0xff.., 2^31, 2^63, u64::MAX) written anywhere, insertions,
//! deletions, copies and truncations.
//!
//! - **Panics** fail the case (proptest catches them and shrinks the input).
//! - **Memory**: this test binary's global allocator is `cap::Cap`, whose limit is set before
//!   each case to what is allocated plus the target's budget for an input of that size (below);
//!   an allocation beyond it fails. A failed allocation aborts the process (the run fails), or,
//!   where the code asks fallibly (`read_to_end` behind the lz4 and zstd decoders), comes back as
//!   an "out of memory" error, which the MCAP targets count as a failed case ([`over_budget`]).
//!   So every case stayed within its budget, counting every allocation made through Rust's
//!   allocator on every thread (serde's, ours). The C decoders in lz4 and zstd allocate through
//!   malloc and are not counted; what they produce is (`record::scan::decompress`).
//! - **Hangs**: a watchdog aborts the process when one case runs longer than 20 s.
//!
//! The default is 2,000 cases per target, seconds in `cargo test`. The long run (the test profile
//! is optimised; `--release` works as well):
//!
//! ```sh
//! GRASP_ORIENT_FUZZ_CASES=1000000 cargo test --test fuzz -- --nocapture
//! ```
//!
//! `GRASP_ORIENT_FUZZ_SEED=N` repeats a run; `GRASP_ORIENT_FUZZ_SAVE=FILE` writes each input to
//! FILE before running it, to keep the one that aborted.

use cap::Cap;
use grasp_orient::answer::{answer, answer_in_full};
use grasp_orient::answer::{answer_set, Rules};
use grasp_orient::jsonl::answer_lines;
use grasp_orient::msg::{
    cdr, GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet, MarkerArray,
};
use grasp_orient::record::scan::decompressed_limit;
use grasp_orient::record::{bag, recover, BagWriter, Entry, Payload, SetTopics, Topics};
use grasp_orient::solver::Settings;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOCATOR: Cap<std::alloc::System> = Cap::new(std::alloc::System, usize::MAX);

/// Slack for what the test harness's own threads may allocate meanwhile.
const SLACK: usize = 1 << 20;
const MIB: usize = 1 << 20;

/// Runs one input; `Err` for a wrong result (a panic also fails).
type Check = Box<dyn Fn(&[u8]) -> Result<(), TestCaseError>>;

/// One reader of outside bytes.
struct Target {
    name: &'static str,
    seeds: Vec<Vec<u8>>,
    /// Most bytes a case may allocate for an input of `n` bytes.
    budget: fn(usize) -> usize,
    run: Check,
}

// ------------------------------------------------------------------------------------------
// Inputs
// ------------------------------------------------------------------------------------------

#[derive(Debug, Clone)]
enum Mutation {
    Flip(Index, u8),
    Byte(Index, u8),
    Word(Index, u64, u8),
    Insert(Index, Vec<u8>),
    Delete(Index, u16),
    Copy(Index, Index, u16),
    Truncate(Index),
}

/// Words that sit on the edges of lengths and counts.
const WORDS: [u64; 12] = [
    0,
    1,
    0x7f,
    0x80,
    0xff,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    1 << 32,
    u64::MAX / 2,
    u64::MAX,
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, v)| Mutation::Byte(i, v)),
        2 => (any::<Index>(), prop::sample::select(&WORDS[..]), prop::sample::select(&[1u8, 2, 4, 8][..]))
            .prop_map(|(i, w, n)| Mutation::Word(i, w, n)),
        1 => (any::<Index>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, v)| Mutation::Insert(i, v)),
        1 => (any::<Index>(), 1u16..64).prop_map(|(i, n)| Mutation::Delete(i, n)),
        1 => (any::<Index>(), any::<Index>(), 1u16..64).prop_map(|(a, b, n)| Mutation::Copy(a, b, n)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len();
    let at = |i: &Index| if len == 0 { 0 } else { i.index(len) };
    match m {
        Mutation::Flip(i, bit) if len > 0 => bytes[at(i)] ^= 1 << bit,
        Mutation::Byte(i, v) if len > 0 => bytes[at(i)] = *v,
        Mutation::Word(i, w, n) if len > 0 => {
            let start = at(i);
            for (k, b) in w.to_le_bytes().iter().take(*n as usize).enumerate() {
                if let Some(slot) = bytes.get_mut(start + k) {
                    *slot = *b;
                }
            }
        }
        Mutation::Insert(i, v) => {
            let start = at(i);
            bytes.splice(start..start, v.iter().copied());
        }
        Mutation::Delete(i, n) if len > 0 => {
            let start = at(i);
            let end = (start + *n as usize).min(len);
            bytes.drain(start..end);
        }
        Mutation::Copy(a, b, n) if len > 0 => {
            let (from, to) = (at(a), at(b));
            let piece: Vec<u8> = bytes[from..(from + *n as usize).min(len)].to_vec();
            for (k, v) in piece.into_iter().enumerate() {
                if let Some(slot) = bytes.get_mut(to + k) {
                    *slot = v;
                }
            }
        }
        Mutation::Truncate(i) => bytes.truncate(at(i)),
        _ => {}
    }
}

fn inputs(seeds: Arc<Vec<Vec<u8>>>) -> impl Strategy<Value = Vec<u8>> {
    let n = seeds.len();
    prop_oneof![
        1 => prop::collection::vec(any::<u8>(), 0..512),
        4 => (0..n, prop::collection::vec(mutation(), 1..8)).prop_map(move |(k, ms)| {
            let mut bytes = seeds[k].clone();
            for m in &ms {
                apply(&mut bytes, m);
            }
            bytes
        }),
    ]
}

// ------------------------------------------------------------------------------------------
// Seeds
// ------------------------------------------------------------------------------------------

fn paper_cases() -> Vec<GraspCandidate> {
    include_str!("../examples/paper_cases.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a candidate"))
        .collect()
}

/// The paper's cases stood up in the y-z plane of their frame as spatial candidates (`model` 1),
/// the last with gravity out of the grasp plane (it swings), and one more with a centre of mass on
/// the contact axis.
fn spatial_cases() -> Vec<GraspCandidate> {
    let mut out = paper_cases();
    for c in &mut out {
        c.model = GraspCandidate::MODEL_SPATIAL;
        c.id.push_str("-spatial");
        for p in [&mut c.contact_1, &mut c.contact_2, &mut c.center_of_mass] {
            (p.x, p.y, p.z) = (p.z, p.x, p.y);
        }
        for v in [&mut c.normal_1, &mut c.normal_2, &mut c.gravity] {
            (v.x, v.y, v.z) = (v.z, v.x, v.y);
        }
    }
    out[3].gravity.x = 0.5;
    let mut on_axis = out[2].clone();
    on_axis.id = "on-axis".into();
    on_axis.center_of_mass = grasp_orient::msg::Point {
        x: 0.5 * (on_axis.contact_1.x + on_axis.contact_2.x),
        y: 0.5 * (on_axis.contact_1.y + on_axis.contact_2.y),
        z: 0.5 * (on_axis.contact_1.z + on_axis.contact_2.z),
    };
    out.push(on_axis);
    out
}

/// Planar and spatial candidates.
fn all_cases() -> Vec<GraspCandidate> {
    let exact: Vec<_> = paper_cases().into_iter().chain(spatial_cases()).collect();
    exact
        .iter()
        .cloned()
        .chain(with_tolerances(&exact))
        .collect()
}

/// The same candidates with a centre-of-mass box and a mass tolerance, so that mutations reach
/// the robust solvers (planar and spatial) as often as the nominal ones.
fn with_tolerances(cases: &[GraspCandidate]) -> Vec<GraspCandidate> {
    cases
        .iter()
        .map(|c| {
            let mut c = c.clone();
            c.id.push_str("-tolerances");
            let v = 0.05;
            c.center_of_mass_tolerance = grasp_orient::msg::Vector3 { x: v, y: v, z: v };
            c.mass_tolerance = 0.1 * c.mass;
            c
        })
        .collect()
}

fn cdr_seeds<T: serde::Serialize>(messages: &[T]) -> Vec<Vec<u8>> {
    messages
        .iter()
        .map(|m| cdr::encode(m).expect("encodes"))
        .collect()
}

fn answers() -> Vec<GripRecommendation> {
    let mut out: Vec<_> = all_cases()
        .iter()
        .map(|c| answer(c, &Settings::default()))
        .collect();
    let mut bad = paper_cases()[0].clone();
    bad.mass = f64::NAN;
    out.push(answer(&bad, &Settings::default()));
    out
}

/// Sets of none, one and all four paper cases, one with a bad candidate, and their answers.
fn sets() -> (Vec<GraspCandidateSet>, Vec<GripRecommendationSet>) {
    let mut bad = paper_cases()[0].clone();
    bad.mass = f64::NAN;
    let lists = [
        Vec::new(),
        paper_cases()[..1].to_vec(),
        paper_cases(),
        vec![bad],
        all_cases(),
    ];
    let sets: Vec<GraspCandidateSet> = lists
        .into_iter()
        .enumerate()
        .map(|(i, candidates)| GraspCandidateSet {
            id: format!("set-{i}").into(),
            candidates,
            ..GraspCandidateSet::default()
        })
        .collect();
    let answers = sets
        .iter()
        .map(|s| answer_set(s, &Settings::default(), &Rules::default()))
        .collect();
    (sets, answers)
}

fn markers() -> Vec<MarkerArray> {
    all_cases()
        .iter()
        .map(|c| {
            let full = answer_in_full(c, &Settings::default());
            grasp_orient::answer::markers::build(c, &full.reply, full.spatial.as_deref())
        })
        .collect()
}

/// Small recordings as the node writes them (lz4 chunks), with one, two and four candidates.
fn mcap_seeds() -> Vec<Vec<u8>> {
    let scratch = tempfile::Builder::new()
        .prefix("grasp_orient_fuzz_")
        .tempdir()
        .expect("a temporary folder");
    let dir = scratch.path();
    let topics = Topics {
        candidates: "/grasp_candidates".into(),
        recommendations: "/grip_recommendations".into(),
        markers: None,
        sets: Some(SetTopics::default_names()),
        poses: None,
    };
    let mut seeds = Vec::new();
    for n in [1usize, 2, 4, 9] {
        let path = dir.join(format!("seed_{n}.mcap"));
        let mut w = BagWriter::create(&path, &topics, 100).expect("create");
        for (i, c) in all_cases().into_iter().take(n).enumerate() {
            let a = answer(&c, &Settings::default());
            let t = 1_000 + i as u64;
            let entry = |payload| Entry {
                payload,
                log_time: t,
                publish_time: t,
            };
            w.write(&entry(Payload::Candidate(Box::new(c))))
                .expect("write");
            w.write(&entry(Payload::Recommendation(Box::new(a))))
                .expect("write");
        }
        let (sets, answers) = sets();
        for (set, reply) in sets.into_iter().zip(answers).take(n) {
            let entry = |payload| Entry {
                payload,
                log_time: 2_000,
                publish_time: 2_000,
            };
            w.write(&entry(Payload::CandidateSet(Box::new(set))))
                .expect("write");
            w.write(&entry(Payload::RecommendationSet(Box::new(reply))))
                .expect("write");
        }
        w.finish().expect("finish");
        seeds.push(std::fs::read(&path).expect("read back"));
        // The same recording as recover writes it, and cut short.
        let fixed = dir.join(format!("seed_{n}_zstd.mcap"));
        recover::recover(&path, &fixed).expect("recover");
        seeds.push(std::fs::read(&fixed).expect("read back"));
    }
    let whole = seeds[0].clone();
    seeds.push(whole[..whole.len() * 2 / 3].to_vec());
    // One written by rosbags (no compression), from the golden bags.
    seeds.push(include_bytes!("../bags/rosbags_written.mcap").to_vec());
    seeds.push(zstd_bomb());
    seeds
}

/// The decompression bomb, shared with the reader's tests.
#[path = "it/util/zstd_bomb.rs"]
mod bomb;
use bomb::zstd_bomb;

fn json_seeds() -> Vec<Vec<u8>> {
    let cases = include_str!("../examples/paper_cases.jsonl");
    let mut seeds: Vec<Vec<u8>> = cases.lines().map(|l| l.as_bytes().to_vec()).collect();
    seeds.push(cases.as_bytes().to_vec());
    seeds.push(b"not json\n{\"id\": \"half\", \"mass\": 1.0}\r\n\n[[[1]]]\n".to_vec());
    for c in spatial_cases() {
        seeds.push(serde_json::to_vec(&c).expect("JSON"));
    }
    let mut seven = spatial_cases()[0].clone();
    seven.model = 7;
    seeds.push(serde_json::to_vec(&seven).expect("JSON"));
    seeds
}

// ------------------------------------------------------------------------------------------
// Targets
// ------------------------------------------------------------------------------------------

/// Decodes as `T`; what decodes encodes back to bytes that decode to the same encoding.
fn cdr_target<T>(name: &'static str, seeds: Vec<Vec<u8>>) -> Target
where
    T: serde::Serialize + serde::de::DeserializeOwned + 'static,
{
    Target {
        name,
        seeds,
        budget: |n| 16 * n + 2 * MIB,
        run: Box::new(|bytes| {
            if let Ok(m) = cdr::decode::<T>(bytes) {
                let once = cdr::encode(&m).map_err(|e| TestCaseError::fail(e.to_string()))?;
                let back: T = cdr::decode(&once).map_err(|e| TestCaseError::fail(e.to_string()))?;
                let twice = cdr::encode(&back).map_err(|e| TestCaseError::fail(e.to_string()))?;
                prop_assert_eq!(once, twice);
            }
            Ok(())
        }),
    }
}

/// What reading a recording may allocate: decompressed records up to the limit, and decoded
/// messages.
fn mcap_budget(n: usize) -> usize {
    2 * decompressed_limit(n as u64) as usize + 64 * n + 8 * MIB
}

/// Whether a reader's error says that an allocation was refused: the budget was not enough (a
/// decompressor asks for its output fallibly, so the cap comes back as this error, not an abort).
fn over_budget(error: &str) -> bool {
    error.contains("out of memory")
}

fn mcap_read_target() -> Target {
    Target {
        name: "MCAP read (replay, play)",
        seeds: mcap_seeds(),
        budget: mcap_budget,
        run: Box::new(|bytes| {
            match bag::read_bytes(bytes) {
                Ok(b) => {
                    prop_assert!(b.undecodable.len() <= 10);
                    prop_assert!(b.undecodable.len() as u64 <= b.undecodable_count);
                }
                Err(d) => prop_assert!(!over_budget(&d.what), "{}", d),
            }
            Ok(())
        }),
    }
}

fn mcap_recover_target() -> Target {
    Target {
        name: "MCAP recover",
        seeds: mcap_seeds(),
        budget: |n| mcap_budget(n) + 16 * MIB,
        run: Box::new(|bytes| {
            let (got, fixed) = match recover::recover_bytes(bytes, std::io::Cursor::new(Vec::new()))
            {
                Ok(done) => done,
                // Not an MCAP file at all: nothing to recover, and nothing written.
                Err(recover::RecoverError::NotMcap(_)) => return Ok(()),
                Err(e) => return Err(TestCaseError::fail(format!("writing to memory: {e}"))),
            };
            for d in &got.damage {
                prop_assert!(!over_budget(d), "{}", d);
            }
            // What recover writes is a whole recording of as many messages and metadata records,
            // which the strict reader accepts.
            let again = bag::read_bytes(fixed.get_ref());
            prop_assert!(again.is_ok(), "{:?}", again.err());
            let b = again.expect("checked");
            let read = b.candidates.len() as u64
                + b.recommendations.len() as u64
                + b.candidate_sets.len() as u64
                + b.recommendation_sets.len() as u64
                + b.other
                + b.undecodable_count;
            prop_assert_eq!(read, got.kept_total());
            prop_assert_eq!(b.metadata.len() as u64, got.metadata);
            Ok(())
        }),
    }
}

/// A candidate as the node gets it: decoded, answered (planar or spatial), and, when held, drawn;
/// every marker point finite.
fn answer_target() -> Target {
    Target {
        name: "CDR GraspCandidate answered and drawn (node)",
        seeds: cdr_seeds(&all_cases()),
        budget: |n| 64 * n + 4 * MIB,
        run: Box::new(|bytes| {
            if let Ok(c) = cdr::decode::<GraspCandidate>(bytes) {
                let full = answer_in_full(&c, &Settings::default());
                prop_assert!(full.reply.status <= 2, "{}", full.reply.message);
                if full.reply.status == GripRecommendation::STATUS_OK {
                    let m = grasp_orient::answer::markers::build(
                        &c,
                        &full.reply,
                        full.spatial.as_deref(),
                    );
                    for marker in &m.markers {
                        let p = &marker.pose.position;
                        prop_assert!(
                            marker
                                .points
                                .iter()
                                .chain(std::iter::once(p))
                                .all(|q| q.x.is_finite() && q.y.is_finite() && q.z.is_finite()),
                            "marker {} of model {}: a point not finite: {:?} {:?}",
                            marker.ns,
                            c.model,
                            c,
                            marker.points
                        );
                    }
                }
            }
            Ok(())
        }),
    }
}

fn json_target() -> Target {
    Target {
        name: "JSON lines (solve)",
        seeds: json_seeds(),
        budget: |n| 64 * n + 2 * MIB,
        run: Box::new(|bytes| {
            let mut out = Vec::new();
            let counts = answer_lines(
                bytes,
                &mut out,
                &Settings::default(),
                &Rules::default(),
                |_| {},
            )
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
            let lines = bytes
                .split(|&b| b == b'\n')
                .filter(|l| !l.iter().all(u8::is_ascii_whitespace))
                .count();
            prop_assert_eq!(counts.answered, lines);
            let text = String::from_utf8(out).map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(text.lines().count(), lines);
            for line in text.lines() {
                let v: serde_json::Value =
                    serde_json::from_str(line).map_err(|e| TestCaseError::fail(e.to_string()))?;
                prop_assert!(v["status"].as_u64().is_some_and(|s| s <= 2), "{line}");
                if v["status"] == 0 {
                    let k = &v["rotation_axis"];
                    let norm = ["x", "y", "z"]
                        .iter()
                        .map(|a| k[a].as_f64().unwrap_or(f64::NAN).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    prop_assert!((norm - 1.0).abs() < 1e-12, "rotation_axis: {line}");
                }
            }
            Ok(())
        }),
    }
}

// ------------------------------------------------------------------------------------------
// The run
// ------------------------------------------------------------------------------------------

fn env_number(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.trim().parse().ok())
}

/// Starts the watchdog: aborts when a case has run for more than `limit`. The case's start
/// goes in the returned cell, in milliseconds since `epoch` plus one (0: none running).
fn watchdog(limit: Duration, epoch: Instant) -> Arc<AtomicU64> {
    let running = Arc::new(AtomicU64::new(0));
    let seen = running.clone();
    let limit_ms = limit.as_millis() as u64;
    std::thread::spawn(move || loop {
        std::thread::sleep(Duration::from_millis(500));
        let at = seen.load(Ordering::Relaxed);
        if at != 0 && epoch.elapsed().as_millis() as u64 > at + limit_ms {
            eprintln!("fuzz: one case ran longer than {limit:?}: a hang");
            std::process::abort();
        }
    });
    running
}

fn run_target(target: &Target, cases: u32, seed: u64, running: &AtomicU64, epoch: Instant) {
    let seeds = Arc::new(target.seeds.clone());
    let mut bytes_seed = [0u8; 32];
    bytes_seed[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner = TestRunner::new_with_rng(
        config,
        TestRng::from_seed(RngAlgorithm::ChaCha, &bytes_seed),
    );
    let save = std::env::var_os("GRASP_ORIENT_FUZZ_SAVE");
    let started = Instant::now();
    let largest = std::sync::atomic::AtomicUsize::new(0);
    let result = runner.run(&inputs(seeds), |bytes| {
        largest.fetch_max(bytes.len(), Ordering::Relaxed);
        if let Some(path) = &save {
            std::fs::write(path, &bytes).ok();
        }
        let base = ALLOCATOR.allocated();
        running.store(epoch.elapsed().as_millis() as u64 + 1, Ordering::Relaxed);
        ALLOCATOR
            .set_limit(base + (target.budget)(bytes.len()) + SLACK)
            .ok();
        let outcome = (target.run)(&bytes);
        ALLOCATOR.set_limit(usize::MAX).ok();
        running.store(0, Ordering::Relaxed);
        outcome
    });
    let secs = started.elapsed().as_secs_f64();
    if let Err(e) = result {
        panic!("{}: {e}", target.name);
    }
    println!(
        "fuzz {:<26} {cases:>8} inputs (largest {:>6} bytes) in {secs:6.1} s: {:>8.0} per second",
        target.name,
        largest.into_inner(),
        f64::from(cases) / secs.max(1e-9),
    );
}

#[test]
fn no_bytes_panic_abort_hang_or_take_memory_beyond_their_size() {
    let cases =
        env_number("GRASP_ORIENT_FUZZ_CASES").map_or(2_000, |n| n.min(u32::MAX.into()) as u32);
    let seed = env_number("GRASP_ORIENT_FUZZ_SEED").unwrap_or_else(|| {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64)
    });
    println!("fuzz seed {seed} (GRASP_ORIENT_FUZZ_SEED={seed} repeats this run)");
    // A panicking case prints its message, and with RUST_BACKTRACE a backtrace, whose symbols
    // are read with allocations, before proptest catches it. The case's memory limit must not
    // apply to that: a failed allocation inside the hook waits forever on the backtrace lock its
    // own thread holds, and the run hung (the watchdog's message waited on the output lock)
    // instead of failing with the case that panicked. Installed before proptest's own hook, which
    // calls it.
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        ALLOCATOR.set_limit(usize::MAX).ok();
        previous(info);
    }));
    let epoch = Instant::now();
    let running = watchdog(Duration::from_secs(20), epoch);
    let targets = [
        cdr_target::<GraspCandidate>("CDR GraspCandidate", cdr_seeds(&all_cases())),
        answer_target(),
        cdr_target::<GripRecommendation>("CDR GripRecommendation", cdr_seeds(&answers())),
        cdr_target::<MarkerArray>("CDR MarkerArray", cdr_seeds(&markers())),
        cdr_target::<GraspCandidateSet>("CDR GraspCandidateSet", cdr_seeds(&sets().0)),
        cdr_target::<GripRecommendationSet>("CDR GripRecommendationSet", cdr_seeds(&sets().1)),
        mcap_read_target(),
        mcap_recover_target(),
        json_target(),
    ];
    for target in &targets {
        run_target(target, cases, seed, &running, epoch);
    }
}
