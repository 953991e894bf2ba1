//! Recordings with pose candidates and pose sets (docs/recordings.md): written as the node writes
//! them (`BagWriter` on the node's pose topics, the answers by `PoseAnswerer`, as the node's), they
//! replay unchanged; a changed contact fails the replay; a mesh named by `package://` that cannot
//! be found at replay time is an error (exit 2), not a pass. `package://grasp_orient/...` is
//! found through `tests/prefix`, a test install prefix holding `meshes/`.

use crate::util::run::{bin, temp_dir};
use grasp_orient::answer::PoseAnswerer;
use grasp_orient::config::Config;
use grasp_orient::geometry::{AmentIndex, ClosingAxis};
use grasp_orient::msg::{PoseCandidate, PoseCandidateSet, PoseRecommendation};
use grasp_orient::record::settings::SettingsRecord;
use grasp_orient::record::{BagWriter, Payload};
use std::path::{Path, PathBuf};

/// The test install prefix: `package://grasp_orient/meshes/block_mm.obj` resolves there.
fn prefix() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/prefix")
}

const BLOCK: &str = r#""mesh": "package://grasp_orient/meshes/block_mm.obj", "scale": {"x": 0.001, "y": 0.001, "z": 0.001}"#;
const CYLINDER: &str = r#""primitive": {"type": 3, "dimensions": [0.12, 0.033]}"#;
const UNKNOWN: &str = r#""primitive": {"type": 7, "dimensions": [0.04]}"#;

fn object(shape: &str) -> String {
    format!(
        r#"{{"pose": {{"position": {{"x": 0.5, "y": 0.0, "z": 0.1}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.1494, "w": 0.9888}}}}, {shape}, "mass": 0.25, "friction": 0.5}}"#
    )
}

fn tool(z: f64) -> String {
    format!(
        r#"{{"position": {{"x": 0.5, "y": 0.0, "z": {z}}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}"#
    )
}

fn candidate(k: u32, shape: &str, z: f64, width: f64) -> PoseCandidate {
    let line = format!(
        r#"{{"header": {{"frame_id": "base_link", "stamp": {{"sec": 1, "nanosec": {k}}}}}, "id": "pose-{k}", "grasp_pose": {}, "width": {width}, "object": {}, "gravity": {{"x": 0.0, "y": 0.0, "z": -9.81}}}}"#,
        tool(z),
        object(shape)
    );
    serde_json::from_str(&line).expect("a PoseCandidate")
}

fn set(id: &str, shape: &str) -> PoseCandidateSet {
    let poses: Vec<String> = [(0.1, 0.09), (0.08, 0.09), (0.12, 0.09), (0.1, 0.02)]
        .iter()
        .enumerate()
        .map(|(k, (z, w))| {
            format!(
                r#"{{"id": "m{k}", "grasp_pose": {}, "width": {w}}}"#,
                tool(*z)
            )
        })
        .collect();
    let line = format!(
        r#"{{"header": {{"frame_id": "base_link", "stamp": {{"sec": 2, "nanosec": 0}}}}, "id": "{id}", "object": {}, "poses": [{}], "gravity": {{"x": 0.0, "y": 0.0, "z": -9.81}}, "max_grip_force": 0.0}}"#,
        object(shape),
        poses.join(", ")
    );
    serde_json::from_str(&line).expect("a PoseCandidateSet")
}

/// Writes a recording of pose candidates (a mesh by `package://`, a cylinder, refusals: a
/// finger starting inside, an unknown primitive, one closing on nothing) and pose sets, each
/// with its answer; `change` may alter the answers of the single candidates before they are
/// written.
fn write_bag(path: &Path, change: impl Fn(&mut PoseRecommendation)) {
    let config = Config::default();
    let with = config
        .answering(PoseAnswerer::new(
            ClosingAxis::Y,
            AmentIndex::new([prefix()]),
        ))
        .expect("valid");
    let topics = crate::util::pose_bag_topics();
    let w = BagWriter::create(path, &topics, 100).expect("create");
    let mut entries = vec![Payload::settings(SettingsRecord {
        since: 0,
        node: "/grasp_orient".into(),
        reason: "start".into(),
        config,
    })];
    let singles = [
        candidate(0, BLOCK, 0.1, 0.09),
        candidate(1, BLOCK, 0.08, 0.09),
        candidate(2, CYLINDER, 0.1, 0.09),
        candidate(3, CYLINDER, 0.1, 0.02),
        candidate(4, UNKNOWN, 0.1, 0.09),
        candidate(5, BLOCK, 0.5, 0.09),
    ];
    for c in singles {
        let mut a = with.answer::<grasp_orient::kind::Poses>(&c);
        change(&mut a);
        entries.push(Payload::request::<grasp_orient::kind::Poses>(c));
        entries.push(Payload::answer::<grasp_orient::kind::Poses>(a));
    }
    for s in [set("block", BLOCK), set("cylinder", CYLINDER)] {
        let a = with.answer::<grasp_orient::kind::PoseSets>(&s);
        assert!(!a.ranking.is_empty(), "{a:?}");
        entries.push(Payload::request::<grasp_orient::kind::PoseSets>(s));
        entries.push(Payload::answer::<grasp_orient::kind::PoseSets>(a));
    }
    crate::util::write_in_order(w, entries, 1_000_000_000, 1000);
}

fn replay(bag: &Path, with_prefix: bool) -> (Option<i32>, String) {
    let mut cmd = bin();
    cmd.arg("replay").arg(bag);
    if with_prefix {
        cmd.env("AMENT_PREFIX_PATH", prefix());
    } else {
        cmd.env_remove("AMENT_PREFIX_PATH");
    }
    let out = cmd.output().expect("binary runs");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code(), text)
}

#[test]
fn a_recording_of_pose_candidates_and_sets_replays_unchanged() {
    let dir = temp_dir("pose_replay");
    let bag = dir.path().join("poses.mcap");
    write_bag(&bag, |_| {});
    let (code, text) = replay(&bag, true);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("replayed 14 candidates")
            && text.contains("14 compared")
            && text.contains("0 differ"),
        "{text}"
    );
    assert!(
        text.contains("6 of the candidates were pose candidates and 2 of the sets pose sets"),
        "{text}"
    );
    assert!(text.contains("replayed 2 sets"), "{text}");
}

#[test]
fn a_changed_contact_fails_the_replay() {
    let dir = temp_dir("pose_replay_changed");
    let bag = dir.path().join("poses.mcap");
    write_bag(&bag, |a| {
        if a.recommendation.candidate_id == "pose-2" {
            a.contact_1.x += 1e-6;
        }
    });
    let (code, text) = replay(&bag, true);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("pose candidate \"pose-2\": contact_1"),
        "{text}"
    );
}

/// A recorded tool pose off by 1e-6 m fails the replay; one recorded in another frame than the
/// answer's header (a node with `gravity_frame` set, by TF) is not compared, since replay has no
/// TF to say where it would be.
#[test]
fn a_changed_tool_pose_fails_the_replay_and_one_in_another_frame_is_left_alone() {
    let dir = temp_dir("pose_replay_tool");
    let bag = dir.path().join("poses.mcap");
    write_bag(&bag, |a| {
        if a.recommendation.candidate_id == "pose-2" {
            assert!(a.tool_pose.pose.position.z.is_finite(), "{a:?}");
            a.tool_pose.pose.position.z += 1e-6;
        }
    });
    let (code, text) = replay(&bag, true);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("pose candidate \"pose-2\": tool_pose"),
        "{text}"
    );
    let elsewhere = dir.path().join("elsewhere.mcap");
    write_bag(&elsewhere, |a| {
        if a.recommendation.candidate_id == "pose-2" {
            a.tool_pose.header.frame_id = "world".into();
            a.tool_pose.pose.position.z += 1.0;
        }
    });
    let (code, text) = replay(&elsewhere, true);
    assert_eq!(code, Some(0), "{text}");
}

#[test]
fn a_mesh_missing_at_replay_is_an_error() {
    let dir = temp_dir("pose_replay_no_mesh");
    let bag = dir.path().join("poses.mcap");
    write_bag(&bag, |_| {});
    let (code, text) = replay(&bag, false);
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("mesh package://grasp_orient/meshes/block_mm.obj of a recorded pose cannot be read at replay time"),
        "{text}"
    );
}

/// An inline mesh the node refused as beyond `max_inline_mesh_triangles` is recorded as the node
/// decoded it, cut to one triangle beyond the bound (`max_inline_mesh_triangles` 200: 201
/// triangles, 601 vertices, all at the origin). `replay` refuses it under the recorded bound
/// with the node's words, alone and as a set's object, instead of casting poses onto the cut
/// mesh (which refuses it for another cause).
#[test]
fn a_recorded_refusal_of_a_cut_inline_mesh_replays_unchanged() {
    let dir = temp_dir("pose_replay_cut_inline");
    let bag = dir.path().join("cut.mcap");
    let config = Config {
        max_inline_mesh_triangles: 200,
        ..Config::default()
    };
    let with = config
        .answering(PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()))
        .expect("valid");
    let cut = |text: &str| {
        let mut v: serde_json::Value = serde_json::from_str(text).expect("json");
        v["object"] = serde_json::json!({
            "pose": {"position": {"x": 0.5, "y": 0.0, "z": 0.1},
                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
            "inline_mesh": {
                "triangles": vec![serde_json::json!({"vertex_indices": [0, 1, 2]}); 201],
                "vertices": vec![serde_json::json!({"x": 0.0, "y": 0.0, "z": 0.0}); 601],
            },
            "mass": 0.25, "friction": 0.5
        });
        v
    };
    let single: PoseCandidate = serde_json::from_value(cut(&serde_json::to_string(&candidate(
        0, CYLINDER, 0.1, 0.09,
    ))
    .expect("json")))
    .expect("a PoseCandidate");
    let pose_set: PoseCandidateSet = serde_json::from_value(cut(&serde_json::to_string(&set(
        "cut", CYLINDER,
    ))
    .expect("json")))
    .expect("a PoseCandidateSet");
    let answer = with.answer::<grasp_orient::kind::Poses>(&single);
    assert_eq!(answer.recommendation.status, 2);
    assert!(
        answer
            .recommendation
            .message
            .contains("more triangles than max_inline_mesh_triangles (200)"),
        "{}",
        answer.recommendation.message
    );
    let set_answer = with.answer::<grasp_orient::kind::PoseSets>(&pose_set);
    // Without the bound the cut mesh is refused for another cause: what a replay that did not
    // apply the recorded bound would answer.
    let unbounded = Config::default()
        .answering(PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()))
        .expect("valid")
        .answer::<grasp_orient::kind::Poses>(&single);
    assert_ne!(
        unbounded.recommendation.message,
        answer.recommendation.message
    );
    let w = BagWriter::create(&bag, &crate::util::pose_bag_topics(), 100).expect("create");
    let entries = [
        Payload::settings(SettingsRecord {
            since: 0,
            node: "/grasp_orient".into(),
            reason: "start".into(),
            config,
        }),
        Payload::request::<grasp_orient::kind::Poses>(single),
        Payload::answer::<grasp_orient::kind::Poses>(answer),
        Payload::request::<grasp_orient::kind::PoseSets>(pose_set),
        Payload::answer::<grasp_orient::kind::PoseSets>(set_answer),
    ];
    crate::util::write_in_order(w, entries, 1_000_000_000, 1000);
    let (code, text) = replay(&bag, false);
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("5 compared") && text.contains(" 0 differ"),
        "{text}"
    );
}
