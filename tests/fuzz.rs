//! Bad bytes, proven: arbitrary and mutated bytes into every reader of outside data, with zero
//! panics, zero aborts, no hang, and memory bounded by the input's size.
//!
//! Targets: the CDR decoding of every message the node and the recordings read
//! (`GraspCandidate`, `GripRecommendation`, `GraspCandidateSet`, `GripRecommendationSet`,
//! `MarkerArray`; the node's DDS reader decodes with the same `cdr-encoding` crate and the same
//! serde implementations, after RustDDS has read the encapsulation header), a decoded candidate
//! answered and drawn as the node does (planar and spatial seeds: `model`, 3D components,
//! `rotation_axis`), the MCAP reader behind `replay` and
//! `play` (`bag::read_bytes`, which `bag::read` calls), `recover` (`recover::recover_bytes`),
//! the JSON-lines reader behind `solve`, and mesh files (binary and ASCII STL, OBJ, COLLADA)
//! through `geometry::parse_bytes` and `Mesh::from_triangles`, as `solve`, `replay` and the node
//! load them (tests `mesh_stl_bytes`, `mesh_obj_bytes`, `mesh_collada_bytes`). Inputs are random bytes (one in five) or valid seeds with one to eight mutations: bit
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
//! GRASP_ORIENT_FUZZ_CASES=100000 cargo test --test fuzz mesh_ -- --nocapture
//! ```
//!
//! The tests share the allocator's limit and the watchdog, so they take turns (a lock).
//!
//! `GRASP_ORIENT_FUZZ_SEED=N` repeats a run; `GRASP_ORIENT_FUZZ_SAVE=FILE` writes each input to
//! FILE before running it, to keep the one that aborted.

use cap::Cap;
use grasp_orient::answer::{answer_in_full, Answering};
use grasp_orient::geometry::{parse_bytes, GeometryError, Mesh};
use grasp_orient::jsonl::answer_lines;
use grasp_orient::kind::{Candidates, Sets};
use grasp_orient::msg::{
    cdr, GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet, MarkerArray,
};
use grasp_orient::record::decompressed_limit;
use grasp_orient::record::{bag, recover, BagWriter, Entry, Payload, Topics};
use grasp_orient::solver::Settings;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Once, OnceLock};
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
    /// The run of ASCII digits nearest the index replaced by a number on an edge (text formats:
    /// counts, indices, units).
    Number(Index, &'static str),
}

/// Numbers that sit on the edges of counts, indices and units written as text.
const NUMBERS: [&str; 12] = [
    "0",
    "1",
    "-1",
    "2",
    "3",
    "255",
    "65536",
    "4294967295",
    "4294967296",
    "1e39",
    "-0.001",
    "nan",
];

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
        2 => (any::<Index>(), prop::sample::select(&NUMBERS[..])).prop_map(|(i, n)| Mutation::Number(i, n)),
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
        Mutation::Number(i, n) if len > 0 => {
            let start = at(i);
            let Some(first) = (start..len)
                .chain((0..start).rev())
                .find(|&k| bytes[k].is_ascii_digit())
            else {
                return;
            };
            let mut from = first;
            while from > 0 && bytes[from - 1].is_ascii_digit() {
                from -= 1;
            }
            let mut to = first;
            while to < len && bytes[to].is_ascii_digit() {
                to += 1;
            }
            bytes.splice(from..to, n.bytes());
        }
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
        .map(|c| Answering::from_env().answer::<Candidates>(c))
        .collect();
    let mut bad = paper_cases()[0].clone();
    bad.mass = f64::NAN;
    out.push(Answering::from_env().answer::<Candidates>(&bad));
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
        .map(|s| Answering::from_env().answer::<Sets>(s))
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
    let topics = Topics::new("/grasp_candidates", "/grip_recommendations")
        .with::<grasp_orient::kind::Sets>("/grasp_candidate_sets", "/grip_recommendation_sets");
    let mut seeds = Vec::new();
    for n in [1usize, 2, 4, 9] {
        let path = dir.join(format!("seed_{n}.mcap"));
        let mut w = BagWriter::create(&path, &topics, 100).expect("create");
        for (i, c) in all_cases().into_iter().take(n).enumerate() {
            let a = Answering::from_env().answer::<Candidates>(&c);
            let t = 1_000 + i as u64;
            let entry = |payload| Entry {
                payload,
                log_time: t,
                publish_time: t,
            };
            w.write(&entry(Payload::request::<grasp_orient::kind::Candidates>(
                c,
            )))
            .expect("write");
            w.write(&entry(Payload::answer::<grasp_orient::kind::Candidates>(a)))
                .expect("write");
        }
        let (sets, answers) = sets();
        for (set, reply) in sets.into_iter().zip(answers).take(n) {
            let entry = |payload| Entry {
                payload,
                log_time: 2_000,
                publish_time: 2_000,
            };
            w.write(&entry(Payload::request::<grasp_orient::kind::Sets>(set)))
                .expect("write");
            w.write(&entry(Payload::answer::<grasp_orient::kind::Sets>(reply)))
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
            let read = b.streams.candidates.requests.len() as u64
                + b.streams.candidates.answers.len() as u64
                + b.streams.sets.requests.len() as u64
                + b.streams.sets.answers.len() as u64
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
                &grasp_orient::answer::Answering::from_env(),
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
// Mesh files
// ------------------------------------------------------------------------------------------

/// The corners of a 40 mm cube in millimetres and its 12 outward triangles.
fn cube() -> (Vec<[f32; 3]>, Vec<[usize; 3]>) {
    let v = (0..8)
        .map(|i| [0, 1, 2].map(|k| 40.0 * ((i >> k) & 1) as f32 - 20.0))
        .collect();
    let t = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    (v, t)
}

fn binary_stl(v: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut out = vec![0u8; 80];
    out.extend((t.len() as u32).to_le_bytes());
    for tri in t {
        out.extend([0u8; 12]);
        for &k in tri {
            for c in v[k] {
                out.extend(c.to_le_bytes());
            }
        }
        out.extend([0u8; 2]);
    }
    out
}

fn ascii_stl(v: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut out = String::from("solid cube\n");
    for tri in t {
        out.push_str("  facet normal 0 0 0\n    outer loop\n");
        for &k in tri {
            let [x, y, z] = v[k];
            out.push_str(&format!("      vertex {x:e} {y:e} {z:e}\n"));
        }
        out.push_str("    endloop\n  endfacet\n");
    }
    out.push_str("endsolid cube\n");
    out.into_bytes()
}

fn obj(v: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut out = String::from("# cube\no cube\n");
    for [x, y, z] in v {
        out.push_str(&format!("v {x} {y} {z}\n"));
    }
    out.push_str("vn 0 0 1\nvt 0 0\n");
    for [a, b, c] in t {
        out.push_str(&format!("f {}/1/1 {}/1/1 {}/1/1\n", a + 1, b + 1, c + 1));
    }
    out.into_bytes()
}

/// The cube as COLLADA: as `<triangles>`, or as a `<polylist>` of its six quads with normals,
/// with a unit and the geometry under `depth` nested nodes.
fn collada(polylist: bool, unit: &str, depth: usize) -> Vec<u8> {
    let (v, t) = cube();
    let corners: Vec<String> = v.iter().flatten().map(|c| c.to_string()).collect();
    let primitive = if polylist {
        let quads = "0 2 3 1 4 5 7 6 0 1 5 4 2 6 7 3 0 4 6 2 1 3 7 5";
        let with_normals: Vec<String> = quads
            .split(' ')
            .enumerate()
            .map(|(i, k)| format!("{k} {}", i / 4))
            .collect();
        format!(
            r##"<polylist count="6"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="NORMAL" source="#n" offset="1"/><vcount>4 4 4 4 4 4</vcount><p>{}</p></polylist>"##,
            with_normals.join(" ")
        )
    } else {
        let p: Vec<String> = t.iter().flatten().map(|k| k.to_string()).collect();
        format!(
            r##"<triangles count="12"><input semantic="VERTEX" source="#v" offset="0"/><p>{}</p></triangles>"##,
            p.join(" ")
        )
    };
    let open = "<node>".repeat(depth);
    let close = "</node>".repeat(depth);
    format!(
        r##"<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit meter="{unit}"/><up_axis>Z_UP</up_axis></asset>
<library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="pa" count="24">{}</float_array><technique_common><accessor source="#pa" count="8" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<source id="n"><float_array id="na" count="18">0 0 -1 0 0 1 0 -1 0 0 1 0 -1 0 0 1 0 0</float_array><technique_common><accessor source="#na" count="6" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
{primitive}
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s">{open}<node id="c"><matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</matrix><instance_geometry url="#g"/></node>{close}</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"##,
        corners.join(" ")
    )
    .into_bytes()
}

/// Parsed as `name` says and, when it parses, built as the node builds a mesh: refused with
/// status 2 or built, a closed one with a finite positive volume. The first `closed` seeds are
/// checked to build closed meshes first (the seeds reach the whole parser).
fn mesh_target(
    name: &'static str,
    file: &'static str,
    seeds: Vec<Vec<u8>>,
    closed: usize,
    budget: fn(usize) -> usize,
) -> Target {
    for (i, seed) in seeds.iter().take(closed).enumerate() {
        let (v, t) = parse_bytes(file, Path::new(file), seed)
            .unwrap_or_else(|e| panic!("{name}: seed {i}: {e}"));
        let mesh = Mesh::from_triangles(file, &v, &t, [0.001; 3])
            .unwrap_or_else(|e| panic!("{name}: seed {i}: {e}"));
        assert!(mesh.is_closed(), "{name}: seed {i} is not closed");
    }
    Target {
        name,
        seeds,
        budget,
        run: Box::new(move |bytes| {
            let refused = |e: &GeometryError| {
                prop_assert_eq!(e.status(), 2, "{}", e);
                Ok(())
            };
            match parse_bytes(file, Path::new(file), bytes) {
                Err(e) => refused(&e),
                Ok((vertices, triangles)) => {
                    match Mesh::from_triangles(file, &vertices, &triangles, [0.001; 3]) {
                        Err(e) => refused(&e),
                        Ok(mesh) => {
                            if let Ok(v) = mesh.volume() {
                                prop_assert!(v.is_finite() && v > 0.0, "volume {}", v);
                            }
                            prop_assert!(mesh.triangle_count() <= triangles.len() * 2);
                            Ok(())
                        }
                    }
                }
            }
        }),
    }
}

fn stl_targets() -> [Target; 2] {
    let (v, t) = cube();
    let binary = binary_stl(&v, &t);
    let mut open = t.clone();
    open.pop();
    // A mesh-loader-made binary STL whose count disagrees with its size, and one of a single
    // triangle.
    let mut miscounted = binary.clone();
    miscounted[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
    let ascii = ascii_stl(&v, &t);
    [
        mesh_target(
            "mesh binary STL",
            "fuzz.stl",
            vec![
                binary,
                miscounted,
                binary_stl(&v, &open),
                binary_stl(&v, &t[..1]),
            ],
            2,
            // Per 50-byte triangle: three f32 corners and a face from mesh-loader, three f64
            // corners, and the built mesh (merged vertices, BVH, triangles at vertices):
            // within 40 bytes per input byte.
            |n| 40 * n + 4 * MIB,
        ),
        mesh_target(
            "mesh ASCII STL",
            "fuzz.stl",
            vec![
                ascii.clone(),
                ascii_stl(&v, &open),
                ascii[..ascii.len() / 2].to_vec(),
            ],
            1,
            |n| 16 * n + 4 * MIB,
        ),
    ]
}

fn obj_target() -> Target {
    let (v, t) = cube();
    mesh_target(
        "mesh OBJ",
        "fuzz.obj",
        vec![
            include_bytes!("../meshes/block_mm.obj").to_vec(),
            obj(&v, &t),
            b"mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\ng one\nf 1 3 2\nf -4 -3 -1\ng two\nf 1 4 3 2\nl 1 2\n".to_vec(),
        ],
        2,
        // A face line of a few bytes makes three corners (f32, then f64) and a built mesh's share.
        |n| 64 * n + 4 * MIB,
    )
}

fn collada_target() -> Target {
    mesh_target(
        "mesh COLLADA",
        "fuzz.dae",
        vec![
            collada(false, "0.001", 0),
            collada(true, "1", 3),
            collada(false, "0,01", 40),
        ],
        3,
        // The text twice (decoded, then with its unit blanked), two XML trees (the check's and
        // mesh-loader's, a few tens of bytes per node), and the mesh as for the others.
        |n| 96 * n + 4 * MIB,
    )
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

/// The cases per target, and the seed, from the environment (printed, to repeat the run).
fn cases_and_seed() -> (u32, u64) {
    let cases =
        env_number("GRASP_ORIENT_FUZZ_CASES").map_or(2_000, |n| n.min(u32::MAX.into()) as u32);
    let seed = env_number("GRASP_ORIENT_FUZZ_SEED").unwrap_or_else(|| {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64)
    });
    println!("fuzz seed {seed} (GRASP_ORIENT_FUZZ_SEED={seed} repeats this run)");
    (cases, seed)
}

/// Runs the targets, one test at a time (they share the allocator's limit): the panic hook and
/// the watchdog are started once for the binary.
fn run_targets(targets: &[Target], cases: u32, seed: u64) {
    static TURN: Mutex<()> = Mutex::new(());
    static HOOK: Once = Once::new();
    static WATCHDOG: OnceLock<(Arc<AtomicU64>, Instant)> = OnceLock::new();
    let _turn = TURN.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    // A panicking case prints its message, and with RUST_BACKTRACE a backtrace, whose symbols
    // are read with allocations, before proptest catches it. The case's memory limit must not
    // apply to that: a failed allocation inside the hook waits forever on the backtrace lock its
    // own thread holds, and the run hung (the watchdog's message waited on the output lock)
    // instead of failing with the case that panicked. Installed before proptest's own hook, which
    // calls it.
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            ALLOCATOR.set_limit(usize::MAX).ok();
            previous(info);
        }));
    });
    let (running, epoch) = WATCHDOG.get_or_init(|| {
        let epoch = Instant::now();
        (watchdog(Duration::from_secs(20), epoch), epoch)
    });
    for target in targets {
        run_target(target, cases, seed, running, *epoch);
    }
}

#[test]
fn no_bytes_panic_abort_hang_or_take_memory_beyond_their_size() {
    let (cases, seed) = cases_and_seed();
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
    run_targets(&targets, cases, seed);
}

/// Mesh files: a panic inside the parser is contained by `parse_bytes` (and counted as a
/// refusal); a stack overflow or a failed allocation would abort the run. Ten times the cases of
/// the other targets (a case takes tens of microseconds).
#[test]
fn mesh_stl_bytes() {
    let (cases, seed) = cases_and_seed();
    run_targets(&stl_targets(), cases.saturating_mul(10), seed);
}

#[test]
fn mesh_obj_bytes() {
    let (cases, seed) = cases_and_seed();
    run_targets(&[obj_target()], cases.saturating_mul(10), seed);
}

#[test]
fn mesh_collada_bytes() {
    let (cases, seed) = cases_and_seed();
    run_targets(&[collada_target()], cases.saturating_mul(10), seed);
}
