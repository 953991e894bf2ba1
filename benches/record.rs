//! Recording and replay speed, in one process:
//! - answers per second with recording on against off: the node's work per candidate (solve,
//!   then hand the candidate and its answer to the recorder) with a real recording being written;
//! - replay throughput of a 1,000,000-candidate recording (read, decode, solve, compare).
//!
//! `cargo bench --bench record` (add `-- N` for another bag size).

#[path = "../tests/it/util/mod.rs"]
#[allow(dead_code, unused_imports)] // a benchmark uses a part of the tests' helpers
mod common;

use grasp_orient::answer::Answering;
use grasp_orient::kind::Candidates;
use grasp_orient::msg::{GraspCandidate, Header, Point, Time, Vector3};
use grasp_orient::record::{bag, BagWriter, Entry, Payload, Recorder, Topics};
use grasp_orient::replay::{replay, Plan};
use grasp_orient::solver::Settings;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

fn topics() -> Topics {
    Topics::new("/grasp_candidates", "/grip_recommendations")
}

fn message(i: usize, c: &grasp_orient::solver::planar::Candidate) -> GraspCandidate {
    let p = |v: nalgebra::Vector2<f64>| Point {
        x: v.x,
        y: v.y,
        z: 0.0,
    };
    let q = |v: nalgebra::Vector2<f64>| Vector3 {
        x: v.x,
        y: v.y,
        z: 0.0,
    };
    GraspCandidate {
        header: Header {
            stamp: Time {
                sec: (i / 1000) as i32,
                nanosec: (i % 1000) as u32 * 1_000_000,
            },
            frame_id: "tool0".into(),
        },
        id: format!("g{i}").into(),
        contact_1: p(c.contact_1),
        contact_2: p(c.contact_2),
        normal_1: q(c.normal_1),
        normal_2: q(c.normal_2),
        friction_1: c.friction_1,
        friction_2: c.friction_2,
        center_of_mass: p(c.center_of_mass),
        mass: c.mass,
        gravity: q(c.gravity),
        model: GraspCandidate::MODEL_PLANAR,
        ..GraspCandidate::default()
    }
}

/// The report, one measurement after another, each with its baseline.
fn main() {
    let n: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let settings = Settings::default();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let pool: Vec<GraspCandidate> = (0..10_000)
        .map(|i| message(i, &common::random_grasp(&mut rng)))
        .collect();
    let dir = common::run::temp_dir("bench");
    let dir = dir.path();

    recording_cost(&pool, &settings, dir);
    bag_and_replay(&pool, &settings, dir, n);
}

/// The answering path with and without a live recording, alternated, best of 5.
fn recording_cost(pool: &[GraspCandidate], settings: &Settings, dir: &std::path::Path) {
    let with = Answering::from_env().with_settings(*settings);
    let rounds = 200_000;
    let (mut off, mut on) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let t = Instant::now();
        for i in 0..rounds {
            black_box(with.answer::<Candidates>(&pool[i % pool.len()]));
        }
        off = off.min(t.elapsed().as_secs_f64());
        let recorder = Recorder::start(
            dir,
            "/grasp_orient_bench",
            topics(),
            100,
            std::sync::Arc::new(|| {}),
        )
        .expect("recorder");
        let t = Instant::now();
        for i in 0..rounds {
            let c = &pool[i % pool.len()];
            let a = with.answer::<Candidates>(c);
            let now = i as u64;
            recorder.record(Entry {
                payload: Payload::request::<grasp_orient::kind::Candidates>(c.clone()),
                log_time: now,
                publish_time: now,
            });
            recorder.record(Entry {
                payload: Payload::answer::<grasp_orient::kind::Candidates>(black_box(a)),
                log_time: now,
                publish_time: now,
            });
        }
        on = on.min(t.elapsed().as_secs_f64());
        let path = recorder.path().to_path_buf();
        recorder.finish().expect("finish");
        std::fs::remove_file(path).ok();
    }
    println!("recording cost on the answering path ({rounds} candidates, best of 5):");
    println!(
        "  off {:>10.0} answers/s\n  on  {:>10.0} answers/s   cost {:.1} %",
        rounds as f64 / off,
        rounds as f64 / on,
        100.0 * (on - off) / off
    );
}

/// A bag of `n` candidates with their answers, then replay it.
fn bag_and_replay(pool: &[GraspCandidate], settings: &Settings, dir: &std::path::Path, n: usize) {
    let with = Answering::from_env().with_settings(*settings);
    let path = dir.join("big.mcap");
    std::fs::remove_file(&path).ok();
    let t = Instant::now();
    let mut writer = BagWriter::create(&path, &topics(), 100).expect("create");
    for i in 0..n {
        let mut c = pool[i % pool.len()].clone();
        c.id = format!("g{i}").into();
        let a = with.answer::<Candidates>(&c);
        let time = 1_000_000_000 + i as u64 * 1000;
        writer
            .write(&Entry {
                payload: Payload::request::<grasp_orient::kind::Candidates>(c),
                log_time: time,
                publish_time: time,
            })
            .expect("write");
        writer
            .write(&Entry {
                payload: Payload::answer::<grasp_orient::kind::Candidates>(a),
                log_time: time,
                publish_time: time,
            })
            .expect("write");
    }
    writer.finish().expect("finish");
    let size = std::fs::metadata(&path).map_or(0, |m| m.len());
    println!(
        "wrote a {n}-candidate bag ({:.1} MB) in {:.1} s",
        size as f64 / 1e6,
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let recorded = bag::read(&path).expect("read");
    let read_s = t.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let summary = replay(&recorded, &Plan::fixed(*settings), |_| {}).expect("replays");
    let solve_s = t2.elapsed().as_secs_f64();
    let total = t.elapsed().as_secs_f64();
    assert_eq!(summary.compared, n as u64);
    assert_eq!(summary.differing, 0);
    println!(
        "replay of {n} candidates: {total:.2} s in all (read + decode {read_s:.2} s, \
         solve + compare {solve_s:.2} s), {:.0} candidates/s, {} differ",
        n as f64 / total,
        summary.differing
    );
    std::fs::remove_file(&path).ok();
}
