//! Where a single pose candidate with an inline mesh (`object.inline_mesh`) is worth answering
//! off the node's thread (`INLINE_OFF_THREAD_TRIANGLES` in `src/node/answer.rs`): the time to
//! answer one pose on a closed inline mesh of 24 to 100,000 triangles on the calling thread (the
//! mesh indexed anew, as the node does for every such candidate, then cast and solved), against
//! two baselines measured in the same run: the same pose on a box primitive (the answer without
//! an index), and a hop to smol's blocking pool and back (`smol::unblock` of an empty closure,
//! what the node's thread pays at least to hand a candidate off).
//!
//! Medians of the rounds, all on one thread, in one process; docs/node.md.
//!
//! `cargo bench --bench inline_mesh` (add `-- ROUNDS`; default 31).

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use grasp_orient::answer::{Answering, PoseAnswerer, Rules};
use grasp_orient::geometry::{AmentIndex, ClosingAxis};
use grasp_orient::kind::Poses;
use grasp_orient::msg::{GraspObject, Pose, PoseCandidate, SolidPrimitive, Vector3};
use grasp_orient::solver::Settings;
use std::hint::black_box;
use std::time::{Duration, Instant};

#[path = "../tests/it/util/torus.rs"]
mod torus;
use torus::torus;

/// A gripper at the origin closing along its y axis from 90 mm apart, across the torus's tube (or
/// the box), gravity along -z.
fn candidate(object: GraspObject) -> PoseCandidate {
    PoseCandidate {
        id: "bench".into(),
        grasp_pose: Pose {
            orientation: grasp_orient::msg::Quaternion {
                w: 1.0,
                ..Default::default()
            },
            ..Pose::default()
        },
        width: 0.09,
        object: GraspObject {
            pose: Pose {
                orientation: grasp_orient::msg::Quaternion {
                    w: 1.0,
                    ..Default::default()
                },
                ..Pose::default()
            },
            scale: Vector3 {
                x: 1.0,
                y: 1.0,
                z: 1.0,
            },
            mass: 0.25,
            friction: 0.5,
            ..object
        },
        gravity: Vector3 {
            x: 0.0,
            y: 0.0,
            z: -9.81,
        },
        ..PoseCandidate::default()
    }
}

fn median(mut samples: Vec<Duration>) -> Duration {
    samples.sort();
    samples[samples.len() / 2]
}

fn timed<T>(f: impl FnOnce() -> T) -> Duration {
    let start = Instant::now();
    black_box(f());
    start.elapsed()
}

fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(31);
    let (settings, rules) = (Settings::default(), Rules::default());
    let with = Answering::new(
        settings,
        rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    let on_box = candidate(GraspObject {
        primitive: SolidPrimitive {
            kind: 1,
            dimensions: vec![0.04, 0.06, 0.08],
        },
        ..GraspObject::default()
    });
    let status = with.answer::<Poses>(&on_box).recommendation.status;
    assert_eq!(status, 0, "the box is gripped");
    let sizes: [(u32, u32); 11] = [
        (4, 3),
        (6, 4),
        (8, 4),
        (8, 8),
        (10, 5),
        (15, 10),
        (25, 20),
        (50, 30),
        (100, 50),
        (250, 60),
        (250, 200),
    ];
    let poses: Vec<PoseCandidate> = sizes
        .iter()
        .map(|&(rings, sides)| {
            candidate(GraspObject {
                inline_mesh: torus(rings, sides),
                ..GraspObject::default()
            })
        })
        .collect();
    for p in &poses {
        let reply = with.answer::<Poses>(p);
        assert_eq!(
            reply.recommendation.status, 0,
            "{:?}",
            reply.recommendation.message
        );
    }
    let (mut hops, mut boxes) = (Vec::new(), Vec::new());
    let mut meshes = vec![Vec::new(); poses.len()];
    for _ in 0..rounds {
        hops.push(timed(|| smol::block_on(smol::unblock(|| black_box(1)))));
        boxes.push(timed(|| with.answer::<Poses>(&on_box)));
        for (p, times) in poses.iter().zip(&mut meshes) {
            times.push(timed(|| with.answer::<Poses>(p)));
        }
    }
    let (hop, on_box) = (median(hops), median(boxes));
    println!("inline meshes, one pose each, medians of {rounds} rounds on one thread");
    println!(
        "baseline: a hop to smol's blocking pool and back {:.1} µs",
        us(hop)
    );
    println!(
        "baseline: the same pose on a box primitive       {:.1} µs",
        us(on_box)
    );
    println!("triangles   answer µs   less the box µs   µs/triangle   answer/hop   answer/box");
    for (p, times) in poses.iter().zip(meshes) {
        let t = median(times);
        let n = p.object.inline_mesh.triangles.len();
        let index = us(t) - us(on_box);
        println!(
            "{n:>9}   {:>9.1}   {index:>15.1}   {:>11.3}   {:>10.1}   {:>10.1}",
            us(t),
            index / n as f64,
            us(t) / us(hop),
            us(t) / us(on_box)
        );
    }
}
