//! The parameter table: every setting of grasp_orient, declared once. Each entry gives the doc
//! line, the name, the type, the default, the unit and, where narrower than the type's, the
//! domain; `(fixed)` marks what cannot change while the node runs. From this table come
//! [`Config`], the params file `config/grasp_orient.yaml`, the node's `--help`, the ROS parameter
//! descriptors and the parameter table of `docs/node.md`.
//!
//! To add a parameter: add its doc comment and its line here, run
//! `GRASP_ORIENT_REGENERATE=1 cargo test --lib config` to rewrite the params file and the table
//! in `docs/node.md`, and use the new field.

use super::choices::RangeKind;
use super::declare::{parameters, Domain};
use crate::answer::{GripperDrive, RankBy, DEFAULT_MAX_SET_SIZE};
use crate::solver::{Objective, MAX_COORDINATE, MAX_GRAVITY, MAX_SAFETY_FACTOR};
use grasp_orient_geometry::ClosingAxis;
use std::f64::consts::PI;

parameters! {
    /// What is minimised: norm2 (Euclidean norm of the contact forces, the paper's figures),
    /// norm1 (sum of their magnitudes) or internal_force (the squeeze alone).
    objective: Objective = Objective::Norm2, "";
    /// Where the recommended orientation may lie: from_above (the object hangs below the
    /// fingers), graspable (the paper's whole range, eq. 8) or bounds (range_min to range_max).
    range: RangeKind = RangeKind::FromAbove, "";
    /// Lower bound of the gravity angle in the paper's object frame when range is bounds, below
    /// range_max; bounds a turn (2π) or more apart allow every angle.
    range_min: f64 = -PI, "rad", in Domain::FINITE;
    /// Upper bound of the gravity angle in the paper's object frame when range is bounds, above
    /// range_min.
    range_max: f64 = PI, "rad", in Domain::FINITE;
    /// Divides both friction coefficients before solving; 1 reproduces the paper.
    friction_safety_factor: f64 = 1.0, "", in Domain::Real { min: 1.0, max: MAX_SAFETY_FACTOR };
    /// QoS history depth (keep-last, reliable, volatile) of every topic.
    qos_depth (fixed): i64 = 100, "messages", in Domain::Integer { min: 1, max: 100_000 };
    /// Publish visualization_msgs/MarkerArray on grip_markers; an answer's markers are built
    /// only while grip_markers has a subscriber or record_markers is on.
    publish_markers: bool = true, "";
    /// Record candidates, answers and the settings in force to a new MCAP file (rosbag2
    /// conventions) named after the node and its start time. Takes effect when set: false
    /// closes the file, true starts a new one (or retries one that failed).
    record: bool = true, "";
    /// Folder for the recordings, relative to the working directory; set while recording, the
    /// file is closed and a new one started there.
    record_dir: String = "runs".into(), "";
    /// Record the markers as well; set while recording, the file is closed and a new one
    /// started.
    record_markers: bool = false, "";
    /// How the gripper's fingers are driven, which picks the grip force: coupled (one motor, the
    /// grip force is internal_force) or independent (each finger its own, the grip force is
    /// finger_force).
    gripper_drive: GripperDrive = GripperDrive::Coupled, "";
    /// The most grip force the gripper gives; a grasp that needs more gets status 3. 0 (the
    /// default) means no limit.
    max_grip_force: f64 = 0.0, "N", in Domain::at_least(0.0);
    /// What ranks the candidates of a set, least first: grip_force (the one gripper_drive picks)
    /// or objective (gripping_power); ties go to the smaller wrist rotation.
    rank_by: RankBy = RankBy::GripForce, "";
    /// The most candidates a set may hold; a larger set is refused whole (STATUS_TOO_LARGE of
    /// GripRecommendationSet) rather than stalling the node.
    max_set_size: i64 = DEFAULT_MAX_SET_SIZE as i64, "candidates", in Domain::at_least_integer(1);
    /// Threads a set of 128 candidates or more is solved on, the node's set thread among them: 0
    /// (the default) one per core, 1 only the set thread. Every number gives the same answer.
    solver_threads (fixed): i64 = 0, "threads", in Domain::Integer { min: 0, max: 1024 };
    /// The most time the node spends solving one set, from when its solving starts; the candidates
    /// not solved by then get status 4 (STATUS_NOT_SOLVED of GripRecommendation) and the set
    /// STATUS_INCOMPLETE. Checked between candidates. 0 means no limit.
    max_set_time: f64 = 10.0, "s", in Domain::Real { min: 0.0, max: 86_400.0 };
    /// The most sets that wait while another is solved; a set that arrives when that many wait is
    /// refused at once, nothing solved (STATUS_BUSY of GripRecommendationSet).
    max_queued_sets: i64 = 16, "sets", in Domain::Integer { min: 0, max: 1024 };
    /// Half-widths [x, y, z] of a box around each candidate's centre of mass, along its frame's
    /// axes, for a candidate whose own center_of_mass_tolerance is zero; the answer is the worst
    /// case over every centre of mass in the box (docs/uncertainty.md).
    center_of_mass_tolerance: [f64; 3] = [0.0; 3], "m",
        in Domain::Below { min: 0.0, limit: MAX_COORDINATE };
    /// The mass of a candidate whose own mass_tolerance is zero lies in mass ± this; the answer is
    /// the worst case over it (a candidate lighter than this is refused, status 2).
    mass_tolerance: f64 = 0.0, "kg", in Domain::Below { min: 0.0, limit: MAX_MASS };
    /// The axis of the gripper's tool frame along which the fingers close, for pose candidates
    /// (x, y or z; docs/poses.md); solve, rank, replay and the node read it.
    closing_axis: ClosingAxis = ClosingAxis::Y, "";
    /// The most time a pose candidate's answer waits for its mesh to be loaded (or its inline
    /// mesh indexed) off the node's thread; then it gets status 2 and the load goes on in the
    /// background, filling the cache for the next candidate. A set waits no longer than this
    /// nor than its max_set_time.
    max_mesh_load_time: f64 = 3.0, "s", in Domain::Real { min: 0.001, max: 3600.0 };
    /// The most triangles an inline mesh (object.inline_mesh) may have, and a third of the most
    /// vertices; a larger one is refused (status 2) without being indexed, and the node decodes
    /// no more of it than this and one more triangle (the decoding bound is the largest value
    /// set while the node runs). Indexing takes about 0.4 kB a triangle while it runs, and up
    /// to 8 of them may run at once; solve, rank, plot and replay apply it too.
    max_inline_mesh_triangles: i64 = 250_000, "triangles",
        in Domain::Integer { min: 1, max: 100_000_000 };
    /// The directories under which the node reads file:// and plain-path mesh resources,
    /// relative ones from the working directory; package:// resources are read only inside
    /// their package's share directory. Empty (the default): package:// resources only. Any
    /// other file a candidate names is refused with one message, whatever the reason
    /// (docs/bad-input.md); solve, rank, plot and replay, run by a local user, read any path.
    mesh_roots (fixed): Vec<String> = Vec::new(), "";
    /// The largest mesh file the node reads; a larger one is refused before it is read
    /// (status 2).
    max_mesh_file_bytes (fixed): i64 = 256 << 20, "bytes",
        in Domain::Integer { min: 1, max: 1 << 40 };
    /// The largest serialized message the node's readers take in; a larger one, sent in DDS
    /// fragments, is dropped before any of it is held (a warning at most every 10 s per topic,
    /// no answer) and the writer's later messages are taken as usual. The default is some ten
    /// times an inline mesh of max_inline_mesh_triangles' default; 64 KiB or less is one
    /// datagram, which the transport bounds anyway; the wire's sample size ends at 4 GiB.
    max_message_bytes (fixed): i64 = 256 << 20, "bytes",
        in Domain::Integer { min: 65_536, max: (1 << 32) - 1 };
    /// The TF frame in which gravity holds the value of the parameter gravity (docs/node.md#tf).
    /// Empty (the default): each candidate's own gravity field is used.
    gravity_frame: String = String::new(), "";
    /// Gravitational acceleration [x, y, z] in gravity_frame, turned by TF into each candidate's
    /// frame at its stamp when gravity_frame is set. Each component within ±5000, so that in
    /// any frame each stays within the solver's 1e4.
    gravity: [f64; 3] = [0.0, 0.0, -9.80665], "m/s²",
        in Domain::Real { min: -MAX_GRAVITY / 2.0, max: MAX_GRAVITY / 2.0 };
    /// The most time a candidate waits for the transforms it needs (from gravity_frame and an
    /// object pose's frame to its own, at its stamp) to arrive on /tf or /tf_static; then it gets
    /// status 2 naming both frames. 0: no wait.
    tf_timeout: f64 = 0.1, "s", in Domain::Real { min: 0.0, max: 10.0 };
    /// The control_msgs/action/GripperCommand server (ros2_control's gripper controllers, e.g.
    /// /gripper_controller/gripper_cmd) that the service ~/grip sends an answer's grip force to,
    /// as command.max_effort (docs/node.md#grip). Empty (the default): none. Not with
    /// parallel_gripper_action.
    gripper_action (fixed): String = String::new(), "";
    /// The control_msgs/action/ParallelGripperCommand server (Jazzy's parallel gripper
    /// controller) that ~/grip sends an answer's grip force to, as the effort of each joint of
    /// parallel_gripper_joints. Empty (the default): none. Not with gripper_action.
    parallel_gripper_action (fixed): String = String::new(), "";
    /// The joints a ParallelGripperCommand goal names (command.name), each commanded to
    /// grip_position with the grip force as its effort; at least one when
    /// parallel_gripper_action is set.
    parallel_gripper_joints: Vec<String> = Vec::new(), "";
    /// Multiplies an answer's grip force before ~/grip sends it (the result capped by
    /// max_grip_force): a margin on the force itself, on top of friction_safety_factor's on the
    /// friction the answer was solved with.
    grip_safety_factor: f64 = 1.0, "", in Domain::Real { min: 1.0, max: MAX_SAFETY_FACTOR };
    /// The position ~/grip commands (GripperCommand's command.position, each joint's position of
    /// ParallelGripperCommand), in the controller's units (m or rad): a position the fingers
    /// cannot reach around the object, so that they stop on it at the force sent. 0 (the
    /// default): closed, for controllers whose 0 is closed.
    grip_position: f64 = 0.0, "m", in Domain::FINITE;
    /// The most time a ~/grip call waits for the gripper's action: for its server to be found,
    /// the goal accepted and its result; then the call fails saying which step was missing (a
    /// goal accepted but without a result is canceled).
    grip_timeout: f64 = 5.0, "s", in Domain::Real { min: 0.001, max: 3600.0 };
    /// A YAML file giving the mass and friction (and optionally the centre of mass, or a density
    /// instead of the mass) of named objects: MoveIt CollisionObjects by id, and pose candidates'
    /// mesh resources whose mass or friction is 0 (docs/node.md#objects). Read once at start, at
    /// most 1 MiB. Empty (the default): no table.
    objects_file (fixed): String = String::new(), "";
    /// The grasping_msgs/action/FindGraspableObjects server of a grasp planner (e.g.
    /// simple_grasping's find_objects) whose goals the node's own action
    /// ~/find_graspable_objects forwards, returning the planner's objects with each one's grasps
    /// ranked as ~/rank_grasps ranks them (docs/node.md#moveit). Empty (the default): no proxy.
    grasp_planner_action (fixed): String = String::new(), "";
    /// The most time a goal of ~/find_graspable_objects takes: the planner found, its goal
    /// accepted, its result back and every object's grasps ranked; then the goal is aborted
    /// saying which step was missing (the planner's goal canceled).
    grasp_planner_timeout: f64 = 30.0, "s", in Domain::Real { min: 0.001, max: 3600.0 };
    /// The opening the fingers close from (a ~/rank_grasps call's width) for every grasp of a
    /// planner's objects that ~/find_graspable_objects ranks.
    grasp_planner_width: f64 = 0.1, "m", in Domain::Real { min: 1e-6, max: 10.0 };
}

impl super::choices::Choice for ClosingAxis {
    const NAMES: &'static [&'static str] = &ClosingAxis::NAMES;
}

/// The largest mass a candidate may have, kg (`MAX_MASS` of `crates/solver/src/limits.rs`,
/// which the crate keeps to itself): a mass tolerance from it on leaves no candidate a mass
/// above its tolerance, so every one would be refused. `config::tests` checks the two agree.
pub(crate) const MAX_MASS: f64 = 1e9;
