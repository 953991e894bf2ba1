//! grasping_msgs as the node's grasp planner proxy forwards them (`~/find_graspable_objects`):
//! the action `FindGraspableObjects` and the messages of its goal, result and feedback
//! (`GraspableObject`, `Object`, `ObjectProperty`), from grasping_msgs 0.4.0 (its ros2 branch),
//! with `sensor_msgs/PointCloud2` and `PointField` (common_interfaces 5.3.6, as its Jazzy wheel
//! installs them). Each text is kept verbatim in `src/msg/jazzy/<pkg>/`; the tests below hold
//! every struct to it, field for field. The crate's own (`pub(crate)`), off the library's front
//! door.
//!
//! A point cluster is decoded whole or not at all: its `data` beyond [`MAX_CLOUD_BYTES`] makes
//! the message fail to decode (the proxy then aborts the goal saying so), since a cut cloud
//! forwarded on would be a wrong one.

use super::moveit::{Grasp, Plane, ShapeMesh, ShapePrimitive};
use super::{Header, Pose, RosMessage, RosType};
use serde::{Deserialize, Serialize};

/// The most bytes of a point cluster's `data` decoded.
pub(crate) const MAX_CLOUD_BYTES: usize = 64 << 20;

crate_message! {
    /// `sensor_msgs/PointField`.
    PointField = sensor_msgs/PointField [
        INT8: u8 = 1,
        UINT8: u8 = 2,
        INT16: u8 = 3,
        UINT16: u8 = 4,
        INT32: u8 = 5,
        UINT32: u8 = 6,
        FLOAT32: u8 = 7,
        FLOAT64: u8 = 8,
    ] {
        name: String,
        offset: u32,
        datatype: u8,
        count: u32,
    }
}

crate_message! {
    /// `sensor_msgs/PointCloud2`: `data` decoded within [`MAX_CLOUD_BYTES`].
    PointCloud2 = sensor_msgs/PointCloud2 [] {
        header: Header,
        height: u32,
        width: u32,
        fields: Vec<PointField>,
        is_bigendian: bool,
        point_step: u32,
        row_step: u32,
        /// The points' bytes.
        #[serde(deserialize_with = "bounded_cloud")]
        data: Vec<u8>,
        is_dense: bool,
    }
}

crate_message! {
    /// `grasping_msgs/ObjectProperty`.
    ObjectProperty = grasping_msgs/ObjectProperty [] { name: String, value: String }
}

crate_message! {
    /// `grasping_msgs/Object`: its shapes' poses in `header`'s frame.
    Object = grasping_msgs/Object [] {
        header: Header,
        name: String,
        support_surface: String,
        properties: Vec<ObjectProperty>,
        point_cluster: PointCloud2,
        primitives: Vec<ShapePrimitive>,
        primitive_poses: Vec<Pose>,
        meshes: Vec<ShapeMesh>,
        mesh_poses: Vec<Pose>,
        surface: Plane,
    }
}

crate_message! {
    /// `grasping_msgs/GraspableObject`.
    GraspableObject = grasping_msgs/GraspableObject [] { object: Object, grasps: Vec<Grasp> }
}

/// `grasping_msgs/action/FindGraspableObjects`, goal (`Copy`, as ros2-client's goal handles
/// need).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub(crate) struct FindGoal {
    /// false: objects only, no grasps planned.
    pub(crate) plan_grasps: bool,
}

/// `grasping_msgs/action/FindGraspableObjects`, result.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub(crate) struct FindResult {
    /// The graspable objects found.
    pub(crate) objects: Vec<GraspableObject>,
    /// Other objects, which may be support surfaces.
    pub(crate) support_surfaces: Vec<Object>,
}

/// `grasping_msgs/action/FindGraspableObjects`, feedback.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub(crate) struct FindFeedback {
    /// An object as it is found and its grasps planned.
    pub(crate) object: GraspableObject,
}

impl ros2_client::Message for FindGoal {}
impl ros2_client::Message for FindResult {}
impl ros2_client::Message for FindFeedback {}

impl FindGoal {
    /// `(name, ROS type)` of every field (tests).
    #[cfg(test)]
    fn fields() -> Vec<(&'static str, String)> {
        vec![("plan_grasps", bool::ros_type())]
    }
}

impl FindResult {
    /// `(name, ROS type)` of every field (tests).
    #[cfg(test)]
    fn fields() -> Vec<(&'static str, String)> {
        vec![
            ("objects", Vec::<GraspableObject>::ros_type()),
            ("support_surfaces", Vec::<Object>::ros_type()),
        ]
    }
}

impl FindFeedback {
    /// `(name, ROS type)` of every field (tests).
    #[cfg(test)]
    fn fields() -> Vec<(&'static str, String)> {
        vec![("object", GraspableObject::ros_type())]
    }
}

/// A point cluster's bytes, refused beyond [`MAX_CLOUD_BYTES`] before any is held.
fn bounded_cloud<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
    struct Bytes;
    impl<'de> serde::de::Visitor<'de> for Bytes {
        type Value = Vec<u8>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            write!(f, "at most {MAX_CLOUD_BYTES} bytes")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<u8>, A::Error> {
            let too_many = || {
                serde::de::Error::custom(format!(
                    "a point cluster of more than {MAX_CLOUD_BYTES} bytes"
                ))
            };
            let hint = seq.size_hint().unwrap_or(0);
            if hint > MAX_CLOUD_BYTES {
                return Err(too_many());
            }
            let mut kept = Vec::with_capacity(hint.min(1 << 16));
            while let Some(b) = seq.next_element::<u8>()? {
                if kept.len() == MAX_CLOUD_BYTES {
                    return Err(too_many());
                }
                kept.push(b);
            }
            Ok(kept)
        }
        fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
            if v.len() > MAX_CLOUD_BYTES {
                return Err(E::custom(format!(
                    "a point cluster of more than {MAX_CLOUD_BYTES} bytes"
                )));
            }
            Ok(v.to_vec())
        }
    }
    d.deserialize_seq(Bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::cdr;
    use crate::msg::moveit::tests::{holds, parse};

    macro_rules! jazzy {
        ($pkg:literal, $name:literal) => {
            include_str!(concat!("jazzy/", $pkg, "/", $name, ".msg"))
        };
    }

    /// Every struct has the fields, in order, and the constants of its file.
    #[test]
    fn every_struct_is_its_file() {
        holds::<PointField>(jazzy!("sensor_msgs", "PointField"));
        holds::<PointCloud2>(jazzy!("sensor_msgs", "PointCloud2"));
        holds::<ObjectProperty>(jazzy!("grasping_msgs", "ObjectProperty"));
        holds::<Object>(jazzy!("grasping_msgs", "Object"));
        holds::<GraspableObject>(jazzy!("grasping_msgs", "GraspableObject"));
    }

    /// The action's goal, result and feedback are its file's three parts.
    #[test]
    fn the_action_is_its_file() {
        let text = include_str!("jazzy/grasping_msgs/FindGraspableObjects.action");
        let parts: Vec<&str> = text.split("\n---\n").collect();
        assert_eq!(parts.len(), 3);
        let fields = |t: &str| parse(t, "grasping_msgs").0;
        let ours = |f: Vec<(&'static str, String)>| -> Vec<(String, String)> {
            f.into_iter().map(|(n, t)| (n.to_string(), t)).collect()
        };
        assert_eq!(ours(FindGoal::fields()), fields(parts[0]));
        assert_eq!(ours(FindResult::fields()), fields(parts[1]));
        assert_eq!(ours(FindFeedback::fields()), fields(parts[2]));
    }

    fn result() -> FindResult {
        let cloud = PointCloud2 {
            height: 1,
            width: 2,
            fields: vec![PointField {
                name: "x".into(),
                offset: 0,
                datatype: PointField::FLOAT32,
                count: 1,
            }],
            point_step: 4,
            row_step: 8,
            data: vec![1, 2, 3, 4, 5, 6, 7, 8],
            is_dense: true,
            ..PointCloud2::default()
        };
        let object = Object {
            name: "mug".into(),
            support_surface: "table".into(),
            properties: vec![ObjectProperty {
                name: "color".into(),
                value: "red".into(),
            }],
            point_cluster: cloud,
            primitives: vec![ShapePrimitive {
                kind: ShapePrimitive::BOX,
                dimensions: vec![0.1, 0.2, 0.3],
                ..ShapePrimitive::default()
            }],
            primitive_poses: vec![Pose::default()],
            surface: Plane {
                coef: [0.0, 0.0, 1.0, -0.7],
            },
            ..Object::default()
        };
        FindResult {
            objects: vec![GraspableObject {
                object: object.clone(),
                grasps: vec![Grasp {
                    id: "g0".into(),
                    ..Grasp::default()
                }],
            }],
            support_surfaces: vec![object],
        }
    }

    /// A result with a cloud, shapes and grasps goes through CDR and back unchanged; every cut
    /// of it is an error, never a panic.
    #[test]
    fn a_result_round_trips() {
        let r = result();
        let bytes = cdr::encode(&r).expect("encoded");
        let back: FindResult = cdr::decode(&bytes).expect("decoded");
        assert_eq!(back, r);
        for end in 0..bytes.len() {
            assert!(
                cdr::decode::<FindResult>(&bytes[..end]).is_err(),
                "cut at {end}"
            );
        }
    }

    /// A cloud of more than the bound is refused; one of the bound decodes.
    #[test]
    fn a_cloud_beyond_the_bound_does_not_decode() {
        let cloud = PointCloud2 {
            data: vec![7; MAX_CLOUD_BYTES],
            ..PointCloud2::default()
        };
        let bytes = cdr::encode(&cloud).expect("encoded");
        let back: PointCloud2 = cdr::decode(&bytes).expect("decoded");
        assert_eq!(back.data.len(), MAX_CLOUD_BYTES);
        let mut over = cloud;
        over.data.push(7);
        let bytes = cdr::encode(&over).expect("encoded");
        let e = cdr::decode::<PointCloud2>(&bytes).expect_err("refused");
        assert!(format!("{e:?}").contains("point cluster"), "{e:?}");
    }
}
