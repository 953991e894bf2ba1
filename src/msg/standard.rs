//! The standard Jazzy messages every other one is made of: `builtin_interfaces/Time`,
//! `std_msgs/Header`, `geometry_msgs/Point`, `Vector3` and `Quaternion`; and what `/tf` and
//! `/tf_static` carry (`src/tf/` keeps them): `tf2_msgs/TFMessage` and the geometry types it
//! needs. `geometry_msgs/Transform` and `TransformStamped` are checked against the Jazzy `.msg`
//! files shipped with the `ros-geometry-msgs` 5.3.6 wheel; `tf2_msgs/TFMessage` is geometry2
//! 0.36.4's (the Jazzy branch) file.

use super::{CompactString, RosMessage, RosType};
use serde::{Deserialize, Serialize};

ros_message! {
    /// `builtin_interfaces/Time`.
    Time = builtin_interfaces/Time [] {
        /// Seconds since the epoch.
        sec: i32,
        /// Nanoseconds within the second.
        nanosec: u32,
    }
}

ros_message! {
    /// `std_msgs/Header`.
    Header = std_msgs/Header [] {
        /// Time of the data.
        #[serde(default)]
        stamp: Time,
        /// Frame the data is expressed in.
        #[serde(default)]
        frame_id: CompactString,
    }
}

ros_message! {
    /// `geometry_msgs/Point`, m.
    Point = geometry_msgs/Point [] {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// z, m (ignored by the planar solver).
        #[serde(default)]
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Vector3`.
    Vector3 = geometry_msgs/Vector3 [] {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z (ignored by the planar solver).
        #[serde(default)]
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Quaternion`.
    Quaternion = geometry_msgs/Quaternion [] {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
        /// w.
        w: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Transform`: where a child frame is in its parent frame.
    Transform = geometry_msgs/Transform [] {
        /// The child frame's origin in the parent frame, m.
        translation: Vector3,
        /// The child frame's orientation in the parent frame (a unit quaternion).
        rotation: Quaternion,
    }
}

ros_message! {
    /// `geometry_msgs/TransformStamped`: `header.frame_id` (the parent) to `child_frame_id` at
    /// `header.stamp`.
    TransformStamped = geometry_msgs/TransformStamped [] {
        /// The parent frame and the time of the transform.
        header: Header,
        /// The child frame.
        child_frame_id: CompactString,
        /// The child frame in the parent frame.
        transform: Transform,
    }
}

ros_message! {
    /// `tf2_msgs/TFMessage`: the message of `/tf` and `/tf_static`.
    TfMessage = tf2_msgs/TFMessage [] {
        /// The transforms.
        transforms: Vec<TransformStamped>,
    }
}
