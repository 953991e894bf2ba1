//! The standard Jazzy messages every other one is made of: `builtin_interfaces/Time`,
//! `std_msgs/Header`, `geometry_msgs/Point`, `Vector3` and `Quaternion`.

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
