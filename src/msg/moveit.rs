//! MoveIt's messages as the node reads and answers them: a grasp (`moveit_msgs/Grasp`), an object
//! (`moveit_msgs/CollisionObject`) and the planning scene it comes in (`moveit_msgs/PlanningScene`
//! and every type inside it, so that a whole scene decodes), and the service
//! `grasp_orient/srv/RankGrasps`. Each struct has the fields, order and types of its Jazzy `.msg`
//! file, kept verbatim in `src/msg/jazzy/<pkg>/` (moveit_msgs 2.6.0, octomap_msgs 2.0.0,
//! object_recognition_msgs 2.0.0 from their ros2 branches; shape_msgs, trajectory_msgs,
//! sensor_msgs and geometry_msgs 5.3.6 as their Jazzy wheels install them); the tests below hold
//! them to those files. They are the crate's own (`pub(crate)`), off the library's front door.
//!
//! shape_msgs' `byte` is `uint8` on the wire, and its bounded `float64[<=3]` an unbounded
//! sequence here (the bound is checked where the shape is made). An inline mesh is decoded within
//! the node's bound as `grasp_orient/Mesh` is (`limit_inline_mesh_decoding`).

use super::poses::{bounded_triangles, bounded_vertices};
use super::{
    ColorRgba, Duration, Header, Point, Pose, PoseRecommendationSet, PoseStamped, RosFields,
    RosMessage, RosType, Transform, TransformStamped, Vector3,
};
use serde::{Deserialize, Serialize};

crate_message! {
    /// `geometry_msgs/Point32`.
    Point32 = geometry_msgs/Point32 [] { x: f32, y: f32, z: f32 }
}

crate_message! {
    /// `geometry_msgs/Polygon`.
    Polygon = geometry_msgs/Polygon [] { points: Vec<Point32> }
}

crate_message! {
    /// `geometry_msgs/Twist`.
    Twist = geometry_msgs/Twist [] { linear: Vector3, angular: Vector3 }
}

crate_message! {
    /// `geometry_msgs/Wrench`.
    Wrench = geometry_msgs/Wrench [] { force: Vector3, torque: Vector3 }
}

crate_message! {
    /// `geometry_msgs/Vector3Stamped`.
    Vector3Stamped = geometry_msgs/Vector3Stamped [] { header: Header, vector: Vector3 }
}

crate_message! {
    /// `sensor_msgs/JointState`.
    JointState = sensor_msgs/JointState [] {
        header: Header,
        name: Vec<String>,
        position: Vec<f64>,
        velocity: Vec<f64>,
        effort: Vec<f64>,
    }
}

crate_message! {
    /// `sensor_msgs/MultiDOFJointState`.
    MultiDofJointState = sensor_msgs/MultiDOFJointState [] {
        header: Header,
        joint_names: Vec<String>,
        transforms: Vec<Transform>,
        twist: Vec<Twist>,
        wrench: Vec<Wrench>,
    }
}

crate_message! {
    /// `shape_msgs/MeshTriangle`.
    ShapeMeshTriangle = shape_msgs/MeshTriangle [] { vertex_indices: [u32; 3] }
}

crate_message! {
    /// `shape_msgs/Mesh`: decoded within the node's inline mesh bound.
    ShapeMesh = shape_msgs/Mesh [] {
        /// The triangles.
        #[serde(deserialize_with = "bounded_triangles")]
        triangles: Vec<ShapeMeshTriangle>,
        /// The vertices.
        #[serde(deserialize_with = "bounded_vertices")]
        vertices: Vec<Point>,
    }
}

crate_message! {
    /// `shape_msgs/Plane`.
    Plane = shape_msgs/Plane [] { coef: [f64; 4] }
}

crate_message! {
    /// `shape_msgs/SolidPrimitive`.
    ShapePrimitive = shape_msgs/SolidPrimitive [
        BOX: u8 = 1,
        SPHERE: u8 = 2,
        CYLINDER: u8 = 3,
        CONE: u8 = 4,
        PRISM: u8 = 5,
        BOX_X: u8 = 0,
        BOX_Y: u8 = 1,
        BOX_Z: u8 = 2,
        SPHERE_RADIUS: u8 = 0,
        CYLINDER_HEIGHT: u8 = 0,
        CYLINDER_RADIUS: u8 = 1,
        CONE_HEIGHT: u8 = 0,
        CONE_RADIUS: u8 = 1,
        PRISM_HEIGHT: u8 = 0,
    ] {
        kind as "type": u8,
        dimensions: Vec<f64>,
        polygon: Polygon,
    }
}

crate_message! {
    /// `trajectory_msgs/JointTrajectoryPoint`.
    JointTrajectoryPoint = trajectory_msgs/JointTrajectoryPoint [] {
        positions: Vec<f64>,
        velocities: Vec<f64>,
        accelerations: Vec<f64>,
        effort: Vec<f64>,
        time_from_start: Duration,
    }
}

crate_message! {
    /// `trajectory_msgs/JointTrajectory`.
    JointTrajectory = trajectory_msgs/JointTrajectory [] {
        header: Header,
        joint_names: Vec<String>,
        points: Vec<JointTrajectoryPoint>,
    }
}

crate_message! {
    /// `object_recognition_msgs/ObjectType`.
    ObjectType = object_recognition_msgs/ObjectType [] { key: String, db: String }
}

crate_message! {
    /// `octomap_msgs/Octomap`.
    Octomap = octomap_msgs/Octomap [] {
        header: Header,
        binary: bool,
        id: String,
        resolution: f64,
        data: Vec<i8>,
    }
}

crate_message! {
    /// `octomap_msgs/OctomapWithPose`.
    OctomapWithPose = octomap_msgs/OctomapWithPose [] {
        header: Header,
        origin: Pose,
        octomap: Octomap,
    }
}

crate_message! {
    /// `moveit_msgs/GripperTranslation`.
    GripperTranslation = moveit_msgs/GripperTranslation [] {
        direction: Vector3Stamped,
        desired_distance: f32,
        min_distance: f32,
    }
}

crate_message! {
    /// `moveit_msgs/Grasp`.
    Grasp = moveit_msgs/Grasp [] {
        id: String,
        pre_grasp_posture: JointTrajectory,
        grasp_posture: JointTrajectory,
        grasp_pose: PoseStamped,
        grasp_quality: f64,
        pre_grasp_approach: GripperTranslation,
        post_grasp_retreat: GripperTranslation,
        post_place_retreat: GripperTranslation,
        max_contact_force: f32,
        allowed_touch_objects: Vec<String>,
    }
}

crate_message! {
    /// `moveit_msgs/CollisionObject`.
    CollisionObject = moveit_msgs/CollisionObject [
        ADD: u8 = 0,
        REMOVE: u8 = 1,
        APPEND: u8 = 2,
        MOVE: u8 = 3,
    ] {
        header: Header,
        pose: Pose,
        id: String,
        kind as "type": ObjectType,
        primitives: Vec<ShapePrimitive>,
        primitive_poses: Vec<Pose>,
        meshes: Vec<ShapeMesh>,
        mesh_poses: Vec<Pose>,
        planes: Vec<Plane>,
        plane_poses: Vec<Pose>,
        subframe_names: Vec<String>,
        subframe_poses: Vec<Pose>,
        operation: u8,
    }
}

crate_message! {
    /// `moveit_msgs/AttachedCollisionObject`.
    AttachedCollisionObject = moveit_msgs/AttachedCollisionObject [] {
        link_name: String,
        object: CollisionObject,
        touch_links: Vec<String>,
        detach_posture: JointTrajectory,
        weight: f64,
    }
}

crate_message! {
    /// `moveit_msgs/RobotState`.
    RobotState = moveit_msgs/RobotState [] {
        joint_state: JointState,
        multi_dof_joint_state: MultiDofJointState,
        attached_collision_objects: Vec<AttachedCollisionObject>,
        is_diff: bool,
    }
}

crate_message! {
    /// `moveit_msgs/AllowedCollisionEntry`.
    AllowedCollisionEntry = moveit_msgs/AllowedCollisionEntry [] { enabled: Vec<bool> }
}

crate_message! {
    /// `moveit_msgs/AllowedCollisionMatrix`.
    AllowedCollisionMatrix = moveit_msgs/AllowedCollisionMatrix [] {
        entry_names: Vec<String>,
        entry_values: Vec<AllowedCollisionEntry>,
        default_entry_names: Vec<String>,
        default_entry_values: Vec<bool>,
    }
}

crate_message! {
    /// `moveit_msgs/LinkPadding`.
    LinkPadding = moveit_msgs/LinkPadding [] { link_name: String, padding: f64 }
}

crate_message! {
    /// `moveit_msgs/LinkScale`.
    LinkScale = moveit_msgs/LinkScale [] { link_name: String, scale: f64 }
}

crate_message! {
    /// `moveit_msgs/ObjectColor`.
    ObjectColor = moveit_msgs/ObjectColor [] { id: String, color: ColorRgba }
}

crate_message! {
    /// `moveit_msgs/PlanningSceneWorld`.
    PlanningSceneWorld = moveit_msgs/PlanningSceneWorld [] {
        collision_objects: Vec<CollisionObject>,
        octomap: OctomapWithPose,
    }
}

crate_message! {
    /// `moveit_msgs/PlanningScene`.
    PlanningScene = moveit_msgs/PlanningScene [] {
        name: String,
        robot_state: RobotState,
        robot_model_name: String,
        fixed_frame_transforms: Vec<TransformStamped>,
        allowed_collision_matrix: AllowedCollisionMatrix,
        link_padding: Vec<LinkPadding>,
        link_scale: Vec<LinkScale>,
        object_colors: Vec<ObjectColor>,
        world: PlanningSceneWorld,
        is_diff: bool,
    }
}

/// `srv/RankGrasps.srv`, request.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RankGraspsRequest {
    /// The object, or only its id.
    pub(crate) object: CollisionObject,
    /// The grasps.
    pub(crate) grasps: Vec<Grasp>,
    /// The fingers' opening before they close, m.
    pub(crate) width: f64,
    /// N; 0: the parameter.
    pub(crate) max_grip_force: f64,
}

/// `srv/RankGrasps.srv`, response.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RankGraspsResponse {
    /// The grasps that can be held, least grip force first.
    pub(crate) grasps: Vec<Grasp>,
    /// For each of them, its index in the request.
    pub(crate) indices: Vec<u32>,
    /// The whole answer, one recommendation per grasp of the request.
    pub(crate) recommendation_set: PoseRecommendationSet,
}

impl ros2_client::Message for RankGraspsRequest {}
impl ros2_client::Message for RankGraspsResponse {}

impl RosFields for RankGraspsRequest {
    fn fields() -> Vec<(&'static str, String)> {
        vec![
            ("object", CollisionObject::ros_type()),
            ("grasps", Vec::<Grasp>::ros_type()),
            ("width", f64::ros_type()),
            ("max_grip_force", f64::ros_type()),
        ]
    }
}

impl RosFields for RankGraspsResponse {
    fn fields() -> Vec<(&'static str, String)> {
        vec![
            ("grasps", Vec::<Grasp>::ros_type()),
            ("indices", Vec::<u32>::ros_type()),
            ("recommendation_set", PoseRecommendationSet::ros_type()),
        ]
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::msg::cdr;

    /// `(name, type)` of the fields and `(name, type, value)` of the constants of a `.msg` text,
    /// types qualified with `package`, `byte` read as `uint8` (the same on the wire) and a
    /// bounded sequence as a sequence.
    #[allow(clippy::type_complexity)]
    pub(crate) fn parse(
        text: &str,
        package: &str,
    ) -> (Vec<(String, String)>, Vec<(String, String, String)>) {
        const PRIMITIVES: [&str; 14] = [
            "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
            "int32", "uint32", "int64", "uint64", "string",
        ];
        let (mut fields, mut constants) = (Vec::new(), Vec::new());
        for line in text.lines() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let (ty, rest) = line.split_once(char::is_whitespace).expect("type and name");
            let mut ty = ty.replace("byte", "uint8");
            if let Some(at) = ty.find("[<=") {
                ty = format!("{}[]", &ty[..at]);
            }
            let base = ty.split('[').next().unwrap_or(&ty).to_string();
            if !base.contains('/') && !PRIMITIVES.contains(&base.as_str()) {
                ty = format!("{package}/{ty}");
            }
            if base == "Header" {
                ty = ty.replace(&format!("{package}/Header"), "std_msgs/Header");
            }
            let rest = rest.trim();
            match rest.split_once('=') {
                Some((name, value)) => {
                    constants.push((name.trim().to_string(), ty, value.trim().to_string()))
                }
                None => fields.push((rest.split_whitespace().next().expect("a name").into(), ty)),
            }
        }
        (fields, constants)
    }

    pub(crate) fn holds<M: RosMessage>(text: &str) {
        let (fields, constants) = parse(text, M::PACKAGE);
        let ours: Vec<(String, String)> = M::fields()
            .into_iter()
            .map(|(n, t)| (n.to_string(), t))
            .collect();
        assert_eq!(ours, fields, "{}", M::TYPE_NAME);
        let ours: Vec<(String, String, String)> = M::constants()
            .into_iter()
            .map(|(n, t, v)| (n.to_string(), t, v))
            .collect();
        assert_eq!(ours, constants, "{}", M::TYPE_NAME);
    }

    macro_rules! jazzy {
        ($pkg:literal, $name:literal) => {
            include_str!(concat!("jazzy/", $pkg, "/", $name, ".msg"))
        };
    }

    /// Every struct has the fields, in order, and the constants of its Jazzy file.
    #[test]
    fn every_struct_is_its_jazzy_file() {
        holds::<Point32>(jazzy!("geometry_msgs", "Point32"));
        holds::<Polygon>(jazzy!("geometry_msgs", "Polygon"));
        holds::<Twist>(jazzy!("geometry_msgs", "Twist"));
        holds::<Wrench>(jazzy!("geometry_msgs", "Wrench"));
        holds::<Vector3Stamped>(jazzy!("geometry_msgs", "Vector3Stamped"));
        holds::<JointState>(jazzy!("sensor_msgs", "JointState"));
        holds::<MultiDofJointState>(jazzy!("sensor_msgs", "MultiDOFJointState"));
        holds::<ShapeMeshTriangle>(jazzy!("shape_msgs", "MeshTriangle"));
        holds::<ShapeMesh>(jazzy!("shape_msgs", "Mesh"));
        holds::<Plane>(jazzy!("shape_msgs", "Plane"));
        holds::<ShapePrimitive>(jazzy!("shape_msgs", "SolidPrimitive"));
        holds::<JointTrajectoryPoint>(jazzy!("trajectory_msgs", "JointTrajectoryPoint"));
        holds::<JointTrajectory>(jazzy!("trajectory_msgs", "JointTrajectory"));
        holds::<ObjectType>(jazzy!("object_recognition_msgs", "ObjectType"));
        holds::<Octomap>(jazzy!("octomap_msgs", "Octomap"));
        holds::<OctomapWithPose>(jazzy!("octomap_msgs", "OctomapWithPose"));
        holds::<GripperTranslation>(jazzy!("moveit_msgs", "GripperTranslation"));
        holds::<Grasp>(jazzy!("moveit_msgs", "Grasp"));
        holds::<CollisionObject>(jazzy!("moveit_msgs", "CollisionObject"));
        holds::<AttachedCollisionObject>(jazzy!("moveit_msgs", "AttachedCollisionObject"));
        holds::<RobotState>(jazzy!("moveit_msgs", "RobotState"));
        holds::<AllowedCollisionEntry>(jazzy!("moveit_msgs", "AllowedCollisionEntry"));
        holds::<AllowedCollisionMatrix>(jazzy!("moveit_msgs", "AllowedCollisionMatrix"));
        holds::<LinkPadding>(jazzy!("moveit_msgs", "LinkPadding"));
        holds::<LinkScale>(jazzy!("moveit_msgs", "LinkScale"));
        holds::<ObjectColor>(jazzy!("moveit_msgs", "ObjectColor"));
        holds::<PlanningSceneWorld>(jazzy!("moveit_msgs", "PlanningSceneWorld"));
        holds::<PlanningScene>(jazzy!("moveit_msgs", "PlanningScene"));
    }

    /// The service's fields are its `.srv` file's, above and below `---`.
    #[test]
    fn the_service_is_its_srv_file() {
        let text = include_str!("../../srv/RankGrasps.srv");
        let (request, response) = text.split_once("---").expect("two halves");
        let fields = |t: &str| parse(t, "grasp_orient").0;
        let ours = |f: Vec<(&'static str, String)>| -> Vec<(String, String)> {
            f.into_iter().map(|(n, t)| (n.to_string(), t)).collect()
        };
        assert_eq!(ours(RankGraspsRequest::fields()), fields(request));
        assert_eq!(ours(RankGraspsResponse::fields()), fields(response));
    }

    /// A scene with something in every field goes through CDR and back unchanged.
    #[test]
    fn a_full_scene_round_trips() {
        let object = CollisionObject {
            id: "mug".into(),
            primitives: vec![ShapePrimitive {
                kind: ShapePrimitive::BOX,
                dimensions: vec![0.1, 0.2, 0.3],
                polygon: Polygon {
                    points: vec![Point32 {
                        x: 1.0,
                        y: 2.0,
                        z: 3.0,
                    }],
                },
            }],
            primitive_poses: vec![Pose::default()],
            meshes: vec![ShapeMesh {
                triangles: vec![ShapeMeshTriangle {
                    vertex_indices: [0, 1, 2],
                }],
                vertices: vec![Point::default(); 3],
            }],
            mesh_poses: vec![Pose::default()],
            planes: vec![Plane {
                coef: [0.0, 0.0, 1.0, 0.5],
            }],
            plane_poses: vec![Pose::default()],
            subframe_names: vec!["tip".into()],
            subframe_poses: vec![Pose::default()],
            operation: CollisionObject::APPEND,
            ..CollisionObject::default()
        };
        let scene = PlanningScene {
            name: "scene".into(),
            robot_state: RobotState {
                joint_state: JointState {
                    name: vec!["j".into()],
                    position: vec![0.5],
                    ..JointState::default()
                },
                attached_collision_objects: vec![AttachedCollisionObject {
                    link_name: "hand".into(),
                    object: object.clone(),
                    weight: 0.2,
                    ..AttachedCollisionObject::default()
                }],
                is_diff: true,
                ..RobotState::default()
            },
            allowed_collision_matrix: AllowedCollisionMatrix {
                entry_names: vec!["a".into()],
                entry_values: vec![AllowedCollisionEntry {
                    enabled: vec![true],
                }],
                default_entry_names: vec!["a".into()],
                default_entry_values: vec![false],
            },
            object_colors: vec![ObjectColor {
                id: "mug".into(),
                color: ColorRgba::default(),
            }],
            world: PlanningSceneWorld {
                collision_objects: vec![object],
                octomap: OctomapWithPose {
                    octomap: Octomap {
                        id: "OcTree".into(),
                        resolution: 0.05,
                        data: vec![-1, 2, 3],
                        ..Octomap::default()
                    },
                    ..OctomapWithPose::default()
                },
            },
            is_diff: true,
            ..PlanningScene::default()
        };
        let bytes = cdr::encode(&scene).expect("encoded");
        let back: PlanningScene = cdr::decode(&bytes).expect("decoded");
        assert_eq!(back, scene);
        // Every cut of it is an error, never a panic; so is a name claiming 4 GiB.
        for end in 0..bytes.len() {
            assert!(
                cdr::decode::<PlanningScene>(&bytes[..end]).is_err(),
                "cut at {end}"
            );
        }
        let mut lying = bytes[..8].to_vec();
        lying.extend_from_slice(&u32::MAX.to_le_bytes());
        assert!(cdr::decode::<PlanningScene>(&lying).is_err());
    }
}
