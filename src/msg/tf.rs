//! `tf2_msgs/TFMessage` and the geometry types it needs, as in ROS 2 Jazzy: what `/tf` and
//! `/tf_static` carry (`src/tf/` keeps them). `geometry_msgs/Transform` and `TransformStamped`
//! are checked against the Jazzy `.msg` files shipped with the `ros-geometry-msgs` 5.3.6 wheel;
//! `tf2_msgs/TFMessage` is geometry2 0.36.4's (the Jazzy branch) file.

use super::{Header, Quaternion, RosMessage, RosType, Vector3};
use compact_str::CompactString;
use serde::{Deserialize, Serialize};

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
