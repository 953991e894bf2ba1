//! The message definitions cannot drift:
//! - every wire struct has the fields, order, types and constants of its `.msg` file: ours in
//!   `msg/`, the standard ones as ROS 2 Jazzy installs them;
//! - every embedded definition (`msg::definitions::DEFINITIONS`) is that file, byte for byte.
//!
//! The standard files are the ROS 2 peer's (`tests/peer/setup.sh`), found as rosbag2 finds them:
//! through the ament index on `AMENT_PREFIX_PATH`, which `tests/run.sh` sets to the peer's. With
//! no `AMENT_PREFIX_PATH`, the peer in setup.sh's default folder is used. The two tests that read
//! them (`peer_*`) belong to the peer suite: plain `cargo test` lists them as ignored, and
//! `tests/run.sh` runs them with `--ignored` once the peer is installed. Run without a peer, they
//! fail, saying how to install it.

use grasp_orient::msg::definitions::{split_type_name, DEFINITIONS};
use grasp_orient::msg::RosFields;
use grasp_orient::msg::{
    ColorRgba, CompressedImage, Duration, GraspCandidate, GraspCandidateSet, GraspObject,
    GraspPose, GripRecommendation, GripRecommendationSet, Header, Marker, MarkerArray, Mesh,
    MeshFile, MeshTriangle, Point, Pose, PoseCandidate, PoseCandidateSet, PoseRecommendation,
    PoseRecommendationSet, PoseStamped, Quaternion, RecommendPosesRequest, RecommendPosesResponse,
    RecommendRequest, RecommendResponse, RosMessage, SolidPrimitive, TfMessage, Time, Transform,
    TransformStamped, UvCoordinate, Vector3,
};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// The install prefixes to look for ROS packages in.
fn prefixes() -> Vec<PathBuf> {
    if let Some(path) = std::env::var_os("AMENT_PREFIX_PATH").filter(|p| !p.is_empty()) {
        return std::env::split_paths(&path).collect();
    }
    // tests/peer/setup.sh's default: ${GRASP_ORIENT_PEER_DIR:-${XDG_CACHE_HOME:-~/.cache}/grasp_orient/ros-peer}
    let peer = std::env::var_os("GRASP_ORIENT_PEER_DIR")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("XDG_CACHE_HOME")
                .map(PathBuf::from)
                .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
                .map(|cache| cache.join("grasp_orient/ros-peer"))
        });
    peer.map(|p| vec![p.join("install"), p.join("venv")])
        .unwrap_or_default()
}

/// The text of a `.msg` file: ours from `msg/`, the others from the ROS 2 install, as
/// `ament_index_cpp::get_package_share_directory` finds their package.
fn msg_file(type_name: &str) -> String {
    let (package, name) = split_type_name(type_name).expect("a message type name");
    let path = if package == "grasp_orient" {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("msg/{name}.msg"))
    } else if package == NOT_IN_THE_PEER {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join(format!("src/msg/jazzy/{package}/{name}.msg"))
    } else {
        let prefixes = prefixes();
        let prefix = prefixes
            .iter()
            .find(|p| {
                p.join("share/ament_index/resource_index/packages")
                    .join(package)
                    .is_file()
            })
            .unwrap_or_else(|| {
                panic!(
                    "ROS 2 package {package} not found in {prefixes:?}: this test reads the \
                     Jazzy .msg files of the ROS 2 peer. Run `bash tests/run.sh`, or \
                     `source \"$(bash tests/peer/setup.sh | tail -n 1)\"` before `cargo test`."
                )
            });
        prefix.join(format!("share/{package}/msg/{name}.msg"))
    };
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The one standard package the peer lacks: PyPI carries no `ros-tf2-msgs` wheel. Its file is
/// held to the copy in `src/msg/jazzy/` (geometry2 0.36.4, the Jazzy branch's), which
/// `tf_message_is_geometry2s_file` checks line by line.
const NOT_IN_THE_PEER: &str = "tf2_msgs";

struct Parsed {
    /// `(name, type)`, relative types qualified with the package.
    fields: Vec<(String, String)>,
    /// `(name, type, value)`.
    constants: BTreeSet<(String, String, String)>,
}

const PRIMITIVES: [&str; 15] = [
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring",
];

/// `Point[]` in package `geometry_msgs` is `geometry_msgs/Point[]`.
fn qualified(ty: &str, package: &str) -> String {
    let base = ty.split(['[', '<']).next().unwrap_or(ty);
    if base.contains('/') || PRIMITIVES.contains(&base) {
        ty.to_string()
    } else {
        format!("{package}/{ty}")
    }
}

/// The fields and constants of a `.msg` text (comments, blank lines and default values left out).
fn parse(text: &str, package: &str) -> Parsed {
    let mut fields = Vec::new();
    let mut constants = BTreeSet::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line.split_once(char::is_whitespace).expect("type and name");
        let rest = rest.trim();
        if let Some((name, value)) = rest.split_once('=') {
            constants.insert((
                name.trim().to_string(),
                ty.to_string(),
                value.trim().to_string(),
            ));
        } else {
            let name = rest.split_whitespace().next().expect("a field name");
            fields.push((name.to_string(), qualified(ty, package)));
        }
    }
    Parsed { fields, constants }
}

/// Rust fields `(name, ROS type)` with relative types qualified by `package`.
fn qualified_fields(fields: Vec<(&'static str, String)>, package: &str) -> Vec<(String, String)> {
    fields
        .into_iter()
        .map(|(n, t)| (n.to_string(), qualified(&t, package)))
        .collect()
}

/// `M` against its `.msg` file: same fields in the same order, same types, same constants.
fn check<M: RosMessage>() {
    let parsed = parse(&msg_file(M::TYPE_NAME), M::PACKAGE);
    let rust = qualified_fields(M::fields(), M::PACKAGE);
    assert_eq!(
        rust,
        parsed.fields,
        "{}: fields differ from the Rust struct",
        M::TYPE_NAME
    );
    let consts: BTreeSet<(String, String, String)> = M::constants()
        .into_iter()
        .map(|(n, t, v)| (n.to_string(), t, v))
        .collect();
    assert_eq!(
        consts,
        parsed.constants,
        "{}: constants differ",
        M::TYPE_NAME
    );
    assert_eq!(
        M::TYPE_NAME,
        format!("{}/msg/{}", M::PACKAGE, M::NAME),
        "the full name is made of package and name"
    );
}

#[test]
fn grasp_candidate_matches_its_msg_file() {
    check::<GraspCandidate>();
}

#[test]
fn grip_recommendation_matches_its_msg_file() {
    check::<GripRecommendation>();
}

/// The pose candidate messages (docs/poses.md), each against its `.msg` file.
fn check_pose_messages() -> [(&'static str, fn()); 9] {
    [
        (MeshTriangle::TYPE_NAME, check::<MeshTriangle> as fn()),
        (Mesh::TYPE_NAME, check::<Mesh>),
        (SolidPrimitive::TYPE_NAME, check::<SolidPrimitive>),
        (GraspObject::TYPE_NAME, check::<GraspObject>),
        (PoseCandidate::TYPE_NAME, check::<PoseCandidate>),
        (GraspPose::TYPE_NAME, check::<GraspPose>),
        (PoseCandidateSet::TYPE_NAME, check::<PoseCandidateSet>),
        (PoseRecommendation::TYPE_NAME, check::<PoseRecommendation>),
        (
            PoseRecommendationSet::TYPE_NAME,
            check::<PoseRecommendationSet>,
        ),
    ]
}

#[test]
fn pose_messages_match_their_msg_files() {
    for (_, check) in check_pose_messages() {
        check();
    }
}

/// `tf2_msgs/TFMessage` against its Jazzy file (no peer needed: the file is the copy here), and
/// the copy is geometry2's text: its one field, its comment-free line.
#[test]
fn tf_message_is_geometry2s_file() {
    check::<TfMessage>();
    assert_eq!(
        msg_file(TfMessage::TYPE_NAME),
        "geometry_msgs/TransformStamped[] transforms\n"
    );
}

#[test]
fn sets_match_their_msg_files() {
    check::<GraspCandidateSet>();
    check::<GripRecommendationSet>();
}

/// `srv/NAME.srv`: the request above `---` and the response below, field for field.
fn check_service(name: &str, request_fields: FieldList, response_fields: FieldList) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("srv/{name}.srv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("srv/{name}.srv: {e}"));
    let (request, response) = text.split_once("\n---\n").expect("request --- response");
    assert_eq!(
        parse(request, "grasp_orient").fields,
        qualified_fields(request_fields(), "grasp_orient"),
        "{name} request"
    );
    assert_eq!(
        parse(response, "grasp_orient").fields,
        qualified_fields(response_fields(), "grasp_orient"),
        "{name} response"
    );
}

/// `(name, ROS type)` of a request's or a response's fields.
type FieldList = fn() -> Vec<(&'static str, String)>;

#[test]
fn the_recommend_service_matches_its_srv_file() {
    check_service(
        "Recommend",
        RecommendRequest::fields,
        RecommendResponse::fields,
    );
}

#[test]
fn the_recommend_poses_service_matches_its_srv_file() {
    check_service(
        "RecommendPoses",
        RecommendPosesRequest::fields,
        RecommendPosesResponse::fields,
    );
}

/// Every message and service of `msg/` and `srv/` is in CMakeLists.txt's rosidl list, so that a
/// colcon build (and the ROS 2 peer, `tests/peer/setup.sh`) generates it.
#[test]
fn cmake_registers_every_message_and_service() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let cmake = std::fs::read_to_string(root.join("CMakeLists.txt")).expect("CMakeLists.txt");
    let list = cmake
        .split("rosidl_generate_interfaces(")
        .nth(1)
        .and_then(|rest| rest.split(')').next())
        .expect("a rosidl_generate_interfaces call");
    // The interfaces built only where moveit_msgs is found, named in the list by a variable.
    let moveit = cmake
        .split("set(moveit_interfaces \"")
        .nth(2)
        .and_then(|rest| rest.split('"').next())
        .map(|f| format!("\"{f}\""))
        .filter(|_| list.contains("${moveit_interfaces}"));
    let mut files = 0;
    for dir in ["msg", "srv"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("msg/ and srv/") {
            let name = entry.expect("an entry").file_name();
            let file = format!("\"{dir}/{}\"", name.to_string_lossy());
            assert!(
                list.contains(&file) || moveit.as_deref() == Some(file.as_str()),
                "{file} is not in CMakeLists.txt's rosidl list"
            );
            files += 1;
        }
    }
    assert!(files >= 15, "only {files} files in msg/ and srv/");
}

/// The peer's build of this package (tests/peer/setup.sh, from CMakeLists.txt) installs every
/// message of `msg/` as it is here.
#[test]
#[ignore = "reads the ROS 2 peer's build of grasp_orient: tests/run.sh runs it with --ignored"]
fn peer_installs_every_message_of_this_package() {
    let prefixes = prefixes();
    let share = prefixes
        .iter()
        .map(|p| p.join("share/grasp_orient"))
        .find(|s| s.join("msg").is_dir())
        .unwrap_or_else(|| panic!("no share/grasp_orient/msg in {prefixes:?}: source the peer"));
    for (type_name, text) in DEFINITIONS {
        let (package, name) = split_type_name(type_name).expect("a message type name");
        if package != "grasp_orient" {
            continue;
        }
        let path = share.join(format!("msg/{name}.msg"));
        let installed = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (not in CMakeLists.txt?)", path.display()));
        assert_eq!(&installed, text, "{}", path.display());
    }
    // RankGrasps: the peer has moveit_msgs (tests/peer/setup.sh builds it first).
    for name in ["Recommend", "RecommendPoses", "RankGrasps"] {
        let path = share.join(format!("srv/{name}.srv"));
        assert!(path.is_file(), "{} is not installed", path.display());
    }
}

/// The grip-force fields come after every field of the contract before them, in this order.
#[test]
fn grip_force_fields_come_last_in_order() {
    let fields: Vec<&str> = GripRecommendation::fields()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let at = fields
        .iter()
        .position(|f| *f == "finger_force")
        .expect("finger_force");
    assert_eq!(fields[at - 1], "candidate_c");
    assert_eq!(fields[at + 1], "finger_force_current");
}

/// Every standard wire struct against the file ROS 2 Jazzy installs, and no embedded definition
/// without its struct.
#[test]
#[ignore = "reads the ROS 2 peer's Jazzy .msg files: tests/run.sh runs it with --ignored"]
fn peer_standard_structs_match_the_jazzy_msg_files() {
    let checked = [
        (Time::TYPE_NAME, check::<Time> as fn()),
        (Duration::TYPE_NAME, check::<Duration>),
        (Header::TYPE_NAME, check::<Header>),
        (ColorRgba::TYPE_NAME, check::<ColorRgba>),
        (Point::TYPE_NAME, check::<Point>),
        (Vector3::TYPE_NAME, check::<Vector3>),
        (Quaternion::TYPE_NAME, check::<Quaternion>),
        (Pose::TYPE_NAME, check::<Pose>),
        (PoseStamped::TYPE_NAME, check::<PoseStamped>),
        (Transform::TYPE_NAME, check::<Transform>),
        (TransformStamped::TYPE_NAME, check::<TransformStamped>),
        (TfMessage::TYPE_NAME, check::<TfMessage>),
        (CompressedImage::TYPE_NAME, check::<CompressedImage>),
        (UvCoordinate::TYPE_NAME, check::<UvCoordinate>),
        (MeshFile::TYPE_NAME, check::<MeshFile>),
        (Marker::TYPE_NAME, check::<Marker>),
        (MarkerArray::TYPE_NAME, check::<MarkerArray>),
        (GraspCandidate::TYPE_NAME, check::<GraspCandidate>),
        (GripRecommendation::TYPE_NAME, check::<GripRecommendation>),
        (GraspCandidateSet::TYPE_NAME, check::<GraspCandidateSet>),
        (
            GripRecommendationSet::TYPE_NAME,
            check::<GripRecommendationSet>,
        ),
    ];
    for (_, check) in &checked {
        check();
    }
    let poses = check_pose_messages();
    let structs: BTreeSet<&str> = checked
        .iter()
        .chain(&poses)
        .map(|(name, _)| *name)
        .collect();
    let embedded: BTreeSet<&str> = DEFINITIONS.iter().map(|(name, _)| *name).collect();
    assert_eq!(
        structs, embedded,
        "every embedded definition has its wire struct"
    );
}

/// Every embedded definition is its `.msg` file, byte for byte (comments, blank lines, trailing
/// spaces and final newline included), as rosbag2 reads it.
#[test]
#[ignore = "reads the ROS 2 peer's Jazzy .msg files: tests/run.sh runs it with --ignored"]
fn peer_embedded_definitions_are_the_installed_files() {
    embedded_definitions_are_their_files(|_| true);
}

/// This package's embedded definitions are its `msg/*.msg` files, byte for byte; with no peer.
#[test]
fn embedded_definitions_of_this_package_are_its_msg_files() {
    embedded_definitions_are_their_files(|package| package == "grasp_orient");
}

fn embedded_definitions_are_their_files(of: impl Fn(&str) -> bool) {
    let mut checked = 0;
    for (type_name, text) in DEFINITIONS {
        let (package, _) = split_type_name(type_name).expect("a message type name");
        if !of(package) {
            continue;
        }
        checked += 1;
        let file = msg_file(type_name);
        assert!(
            text == file,
            "{type_name}: the embedded text differs from the installed .msg file; copy the \
             file into src/msg/jazzy/ again.\n--- embedded\n{text}\n--- installed\n{file}"
        );
    }
    assert!(checked > 0, "no embedded definition was checked");
}

/// The first release's contract fixes the first fields of GripRecommendation; extra fields may only
/// come after them.
#[test]
fn contract_fields_come_first_and_in_order() {
    let contract = [
        "header",
        "candidate_id",
        "status",
        "message",
        "wrist_rotation",
        "rotation",
        "gravity_direction",
        "gravity_angle",
        "gripping_power",
        "internal_force",
        "contact_forces",
        "gripping_power_current",
        "internal_force_current",
        "grasp_case",
        "local_minima",
        "local_minima_power",
        "local_minima_labels",
    ];
    let fields: Vec<&str> = GripRecommendation::fields()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(&fields[..contract.len()], &contract);
}

/// The Jazzy `.msg` files kept in `src/msg/jazzy/` for the packages the peer installs from their
/// wheels (std_msgs, geometry_msgs, sensor_msgs, shape_msgs, trajectory_msgs, …), which the
/// crate's own wire structs of MoveIt's messages are checked against (`src/msg/moveit.rs`), are
/// the peer's files byte for byte. The packages the peer builds from these very copies
/// (moveit_msgs, octomap_msgs, object_recognition_msgs, control_msgs, grasping_msgs, tf2_msgs)
/// are their upstream files, as `tests/peer/setup.sh` says where from.
#[test]
#[ignore = "reads the ROS 2 peer's Jazzy .msg files: tests/run.sh runs it with --ignored"]
fn peer_jazzy_copies_are_the_peers_files() {
    const BUILT_FROM_HERE: [&str; 6] = [
        "moveit_msgs",
        "octomap_msgs",
        "object_recognition_msgs",
        "control_msgs",
        "grasping_msgs",
        NOT_IN_THE_PEER,
    ];
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src/msg/jazzy");
    let mut compared = 0;
    for package in std::fs::read_dir(&root).expect("src/msg/jazzy") {
        let package = package.expect("an entry").file_name();
        let package = package.to_string_lossy();
        if BUILT_FROM_HERE.contains(&package.as_ref()) {
            continue;
        }
        for file in std::fs::read_dir(root.join(package.as_ref())).expect("a package") {
            let file = file.expect("an entry").file_name();
            let name = file.to_string_lossy();
            let name = name.strip_suffix(".msg").expect("a .msg file");
            let ours =
                std::fs::read_to_string(root.join(package.as_ref()).join(format!("{name}.msg")))
                    .expect("our copy");
            assert_eq!(
                ours,
                msg_file(&format!("{package}/msg/{name}")),
                "src/msg/jazzy/{package}/{name}.msg"
            );
            compared += 1;
        }
    }
    assert!(compared >= 25, "only {compared} files compared");
}
