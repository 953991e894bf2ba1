//! A set of 1,000 gripper poses on a 100,000-triangle mesh answered through the answer layer
//! (`Answering::answer::<PoseSets>`: the fingers cast, the 3D solve, the grip force, the ranking, the
//! wire answers, as `rank` and a node's set do), against the same 1,000 grasps given as a set of
//! contact candidates through the same layer (`Answering::answer::<Sets>`): the spatial candidates the
//! poses make, taken from the pose path itself. Target: the poses at most 3 times the contacts,
//! once the mesh is loaded. Also printed: the time to parse the mesh file alone, and to load and
//! index it (the first set on a resource, through the answerer's cache, which keeps it within
//! `MESH_CACHE_BYTES`).
//!
//! The two sets run back to back, alternating, in one process on the calling thread; the medians
//! of the rounds are printed, and the ratio of the medians (`docs/performance.md`).
//!
//! `cargo bench --bench poses` (add `-- ROUNDS`; default 31).

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[path = "../crates/geometry/benches/shared/torus.rs"]
mod torus;

use grasp_orient::answer::{Answering, PoseAnswerer, Rules, MESH_CACHE_BYTES};
use grasp_orient::geometry::{parse, AmentIndex, ClosingAxis, GripperPose, MeshCache};
use grasp_orient::kind::{PoseSets, Sets};
use grasp_orient::msg::{
    GraspCandidate, GraspCandidateSet, GraspObject, GraspPose, GripRecommendation, Pose,
    PoseCandidate, PoseCandidateSet, Vector3,
};
use grasp_orient::solver::Settings;
use nalgebra::{Isometry3, Translation3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// The torus in the object frame `frame`, a mesh resource in millimetres.
fn pose_set(resource: &str, frame: &Isometry3<f64>, grippers: &[GripperPose]) -> PoseCandidateSet {
    PoseCandidateSet {
        id: "torus".into(),
        object: GraspObject {
            pose: Pose::from(frame),
            mesh: resource.into(),
            scale: Vector3 {
                x: 0.001,
                y: 0.001,
                z: 0.001,
            },
            mass: 0.3,
            friction: 0.5,
            ..GraspObject::default()
        },
        poses: grippers
            .iter()
            .enumerate()
            .map(|(i, g)| GraspPose {
                id: format!("pose-{i}").into(),
                grasp_pose: Pose::from(&g.tool_pose),
                width: g.width,
            })
            .collect(),
        gravity: Vector3 {
            x: 0.0,
            y: 0.0,
            z: -9.81,
        },
        ..PoseCandidateSet::default()
    }
}

/// The contact candidates of the same grasps: each pose's spatial candidate as the pose path makes
/// it, or, for a pose it refuses, the empty candidate it answers in its place (refused again).
fn contact_set(answerer: &PoseAnswerer, set: &PoseCandidateSet) -> GraspCandidateSet {
    let candidates = set
        .poses
        .iter()
        .map(|p| {
            let single = PoseCandidate {
                header: set.header.clone(),
                id: p.id.clone(),
                grasp_pose: p.grasp_pose.clone(),
                width: p.width,
                object: set.object.clone(),
                gravity: set.gravity.clone(),
            };
            answerer
                .spatial_candidate(&single)
                .unwrap_or_else(|_| GraspCandidate {
                    id: p.id.clone(),
                    ..GraspCandidate::default()
                })
        })
        .collect();
    GraspCandidateSet {
        id: set.id.clone(),
        candidates,
        ..GraspCandidateSet::default()
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

/// The time this thread has run on a core (`CLOCK_THREAD_CPUTIME_ID`): a set's time less the
/// time others' processes had the core; on this shared machine the wall time of a longer run
/// catches more of their time slices.
fn on_cpu() -> Option<Duration> {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    let secs = u64::try_from(t.tv_sec).ok()?;
    let nanos = u32::try_from(t.tv_nsec).ok()?;
    Some(Duration::new(secs, nanos))
}

/// Wall time and time on a core of one run.
fn timed_both<T>(f: impl FnOnce() -> T) -> (Duration, Option<Duration>) {
    let cpu = on_cpu();
    let wall = timed(f);
    let cpu = on_cpu()
        .zip(cpu)
        .map(|(after, before)| after.saturating_sub(before));
    (wall, cpu)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The medians of 5: parsing the mesh file alone, and loading and indexing it through a new
/// cache.
fn mesh_times(resource: &str, path: &std::path::Path) -> (Duration, Duration) {
    let parse_only = median(
        (0..5)
            .map(|_| timed(|| parse(resource, path).expect("parses")))
            .collect(),
    );
    let load_index = median(
        (0..5)
            .map(|_| {
                let cache = MeshCache::new(AmentIndex::default(), MESH_CACHE_BYTES);
                timed(|| cache.get(resource, [0.001; 3]).expect("loads"))
            })
            .collect(),
    );
    (parse_only, load_index)
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(31);
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("torus.stl");
    let triangles = torus::write_torus_stl(&path, 250, 200);
    let resource = path.display().to_string();

    let (parse_only, load_index) = mesh_times(&resource, &path);

    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let frame = Isometry3::from_parts(
        Translation3::new(0.5, -0.2, 0.3),
        torus::random_rotation(&mut rng),
    );
    let grippers = torus::poses(&mut rng, &frame);
    let poses = pose_set(&resource, &frame, &grippers);
    let (settings, rules) = (Settings::default(), Rules::default());
    let with = Answering::new(
        settings,
        rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    let answerer = with.poses();
    let first = Instant::now();
    let answered = with.answer::<PoseSets>(&poses);
    let first = first.elapsed();
    let contacts = contact_set(answerer, &poses);
    let same = with.answer::<Sets>(&contacts);
    let status = |r: &GripRecommendation| r.status;
    assert_eq!(
        answered
            .recommendations
            .iter()
            .map(|p| status(&p.recommendation))
            .collect::<Vec<_>>(),
        same.recommendations.iter().map(status).collect::<Vec<_>>(),
        "the two sets are the same grasps"
    );
    assert_eq!(answered.ranking, same.ranking);
    let touching = answered
        .recommendations
        .iter()
        .filter(|p| !p.contact_1.x.is_nan())
        .count();

    let (mut pose_times, mut contact_times) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        pose_times.push(timed_both(|| with.answer::<PoseSets>(&poses)));
        contact_times.push(timed_both(|| with.answer::<Sets>(&contacts)));
    }
    let walls = |t: &[(Duration, Option<Duration>)]| median(t.iter().map(|p| p.0).collect());
    let cpus = |t: &[(Duration, Option<Duration>)]| {
        let cpu: Option<Vec<Duration>> = t.iter().map(|p| p.1).collect();
        cpu.map(median)
    };
    let (pose_time, contact_time) = (walls(&pose_times), walls(&contact_times));
    let mesh = answerer.meshes();
    println!(
        "mesh: {triangles} triangles; parse alone {:.1} ms; load and index {:.1} ms (once per \
         resource and scale); kept: {} mesh, {:.1} MB of at most {} MB; loads {}",
        ms(parse_only),
        ms(load_index),
        mesh.len(),
        mesh.bytes() as f64 / 1e6,
        MESH_CACHE_BYTES >> 20,
        mesh.loads()
    );
    println!(
        "the first set of poses (loading the mesh): {:.1} ms; {touching} of 1,000 poses with two \
         contacts, {} ranked",
        ms(first),
        answered.ranking.len()
    );
    println!(
        "{rounds} rounds, medians: 1,000 poses {:.2} ms, the same 1,000 as contact candidates \
         {:.2} ms; poses : contacts = {:.2} (target ≤ 3)",
        ms(pose_time),
        ms(contact_time),
        pose_time.as_secs_f64() / contact_time.as_secs_f64()
    );
    if let (Some(pose_cpu), Some(contact_cpu)) = (cpus(&pose_times), cpus(&contact_times)) {
        println!(
            "on a core (this thread's run time), medians: 1,000 poses {:.2} ms, the same as \
             contact candidates {:.2} ms; poses : contacts = {:.2}",
            ms(pose_cpu),
            ms(contact_cpu),
            pose_cpu.as_secs_f64() / contact_cpu.as_secs_f64()
        );
    }
}
