//! The Rust path of `benches/bench_python.py`: the grasps and poses that the script gives the
//! Python module, read from the raw files it writes, answered through the root crate's answer
//! layer on the calling thread (one core), without Python: the grasps one by one with
//! the answering object, as `grasp_orient solve` answers its lines, and in slices of 64 through
//! its batch path (`Answering::answer_many`), as the module answers them; the poses as one pose
//! set through it, as `cargo bench --bench poses` times them. Prints one line each:
//! `grasps N SECONDS ON_CORE`, `grasps_batch N SECONDS ON_CORE` and `poses N SECONDS ON_CORE`
//! (the medians of `ROUNDS` rounds of the wall time and of the time on a core).
//!
//! `cargo bench -p grasp_orient_python --bench rust_path -- DIR [ROUNDS]`, DIR holding
//! `grasps.f64` (rows of 20 values: contact_1, normal_1, contact_2, normal_2, center_of_mass,
//! gravity, mass, friction) and optionally `vertices.f64` (rows of 3), `triangles.u32` (rows of
//! 3), `poses.f64` (rows of 8: position, quaternion x y z w, width) and `object.f64` (mass,
//! friction, gravity x y z, scale).

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use grasp_orient::answer::{Answering, PoseAnswerer, Rules};
use grasp_orient::geometry::{AmentIndex, ClosingAxis};
use grasp_orient::kind::{Candidates, PoseSets};
use grasp_orient::msg::{
    GraspCandidate, GraspObject, GraspPose, Mesh, MeshTriangle, Point, Pose, PoseCandidateSet,
    Quaternion, Vector3,
};
use grasp_orient::solver::Settings;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

fn floats(path: &Path) -> std::io::Result<Vec<f64>> {
    let bytes = std::fs::read(path)?;
    Ok(bytes
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
        .collect())
}

fn indices(path: &Path) -> std::io::Result<Vec<u32>> {
    let bytes = std::fs::read(path)?;
    Ok(bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

fn point(v: &[f64]) -> Point {
    Point {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

fn vector(v: &[f64]) -> Vector3 {
    Vector3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

/// The planar candidate of one row, as the module makes it.
fn candidate(r: &[f64]) -> GraspCandidate {
    GraspCandidate {
        contact_1: point(&r[0..3]),
        normal_1: vector(&r[3..6]),
        contact_2: point(&r[6..9]),
        normal_2: vector(&r[9..12]),
        center_of_mass: point(&r[12..15]),
        gravity: vector(&r[15..18]),
        mass: r[18],
        friction_1: r[19],
        friction_2: r[19],
        model: GraspCandidate::MODEL_PLANAR,
        ..GraspCandidate::default()
    }
}

/// Candidates the module makes and answers at a time (`crates/python/src/grasps.rs`).
const SLICE: usize = 64;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The time this thread has run on a core (`CLOCK_THREAD_CPUTIME_ID`): on a shared machine,
/// the wall time less the time others' processes had the core.
fn on_core() -> Duration {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    Duration::new(
        u64::try_from(t.tv_sec).unwrap_or(0),
        u32::try_from(t.tv_nsec).unwrap_or(0),
    )
}

/// The wall time and the time on a core `f` takes, in seconds.
fn timed(f: impl FnOnce()) -> (f64, f64) {
    let (wall, core) = (Instant::now(), on_core());
    f();
    let core = on_core().saturating_sub(core);
    (wall.elapsed().as_secs_f64(), core.as_secs_f64())
}

/// `NAME N WALL ON_CORE`, the medians of `times`.
fn report(name: &str, n: usize, times: Vec<(f64, f64)>) {
    let (wall, core): (Vec<f64>, Vec<f64>) = times.into_iter().unzip();
    println!("{name} {n} {:.6} {:.6}", median(wall), median(core));
}

fn grasps(dir: &Path, rounds: usize) -> std::io::Result<()> {
    let values = floats(&dir.join("grasps.f64"))?;
    let with = Answering::new(
        Settings::default(),
        Rules::default(),
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    let rows: Vec<&[f64]> = values.chunks_exact(20).collect();
    let mut one_by_one = Vec::with_capacity(rounds);
    let mut batch = Vec::with_capacity(rounds);
    let mut candidates = Vec::with_capacity(SLICE);
    for _ in 0..rounds {
        one_by_one.push(timed(|| {
            for r in &rows {
                black_box(with.answer::<Candidates>(&candidate(r)));
            }
        }));
        // The module's way: slices of its size made into candidates, answered together.
        batch.push(timed(|| {
            for slice in rows.chunks(SLICE) {
                candidates.clear();
                candidates.extend(slice.iter().map(|r| candidate(r)));
                black_box(with.answer_many::<Candidates>(&candidates));
            }
        }));
    }
    report("grasps", rows.len(), one_by_one);
    report("grasps_batch", rows.len(), batch);
    Ok(())
}

fn pose_set(dir: &Path) -> std::io::Result<PoseCandidateSet> {
    let vertices = floats(&dir.join("vertices.f64"))?;
    let triangles = indices(&dir.join("triangles.u32"))?;
    let poses = floats(&dir.join("poses.f64"))?;
    let o = floats(&dir.join("object.f64"))?;
    Ok(PoseCandidateSet {
        object: GraspObject {
            pose: Pose {
                orientation: Quaternion {
                    w: 1.0,
                    ..Quaternion::default()
                },
                ..Pose::default()
            },
            inline_mesh: Mesh {
                vertices: vertices.chunks_exact(3).map(point).collect(),
                triangles: triangles
                    .chunks_exact(3)
                    .map(|t| MeshTriangle {
                        vertex_indices: [t[0], t[1], t[2]],
                    })
                    .collect(),
            },
            scale: vector(&[o[5], o[5], o[5]]),
            mass: o[0],
            friction: o[1],
            ..GraspObject::default()
        },
        poses: poses
            .chunks_exact(8)
            .map(|p| GraspPose {
                grasp_pose: Pose {
                    position: point(&p[0..3]),
                    orientation: Quaternion {
                        x: p[3],
                        y: p[4],
                        z: p[5],
                        w: p[6],
                    },
                },
                width: p[7],
                ..GraspPose::default()
            })
            .collect(),
        gravity: vector(&o[2..5]),
        ..PoseCandidateSet::default()
    })
}

fn poses(dir: &Path, rounds: usize) -> std::io::Result<()> {
    let set = pose_set(dir)?;
    let rules = Rules {
        max_set_size: usize::MAX,
        ..Rules::default()
    };
    let with = Answering::new(
        Settings::default(),
        rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    let times = (0..rounds)
        .map(|_| {
            timed(|| {
                black_box(with.answer::<PoseSets>(&set));
            })
        })
        .collect();
    report("poses", set.poses.len(), times);
    Ok(())
}

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let Some(dir) = args.first() else {
        eprintln!("usage: rust_path DIR [ROUNDS]");
        std::process::exit(2);
    };
    let rounds = args.get(1).and_then(|r| r.parse().ok()).unwrap_or(3);
    let dir = Path::new(dir);
    grasps(dir, rounds)?;
    if dir.join("poses.f64").exists() {
        poses(dir, rounds)?;
    }
    Ok(())
}
