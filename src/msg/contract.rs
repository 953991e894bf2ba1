//! How a wire struct names its fields and types in ROS terms, so tests can hold it to its `.msg`.

use super::{Header, Point, Quaternion, Time, Vector3};

/// A Rust type's name in a `.msg` file.
pub trait RosType {
    /// `float64`, `string`, `float64[4]`, `std_msgs/Header`, …
    fn ros_type() -> String;
}

/// Implements [`RosType`] for each `type => "ros/Name"`.
macro_rules! ros_type_names {
    ($($t:ty => $name:literal),* $(,)?) => {
        $(impl $crate::msg::RosType for $t {
            fn ros_type() -> String {
                $name.to_string()
            }
        })*
    };
}
pub(crate) use ros_type_names;

ros_type_names! {
    f64 => "float64",
    f32 => "float32",
    u8 => "uint8",
    i8 => "int8",
    u32 => "uint32",
    i32 => "int32",
    i64 => "int64",
    bool => "bool",
    String => "string",
    Time => "builtin_interfaces/Time",
    Header => "std_msgs/Header",
    Point => "geometry_msgs/Point",
    Vector3 => "geometry_msgs/Vector3",
    Quaternion => "geometry_msgs/Quaternion",
}

impl<T: RosType, const N: usize> RosType for [T; N] {
    fn ros_type() -> String {
        format!("{}[{N}]", T::ros_type())
    }
}

impl<T: RosType> RosType for Vec<T> {
    fn ros_type() -> String {
        format!("{}[]", T::ros_type())
    }
}

/// A wire struct that mirrors a ROS message.
pub trait RosMessage {
    /// Full type name, `package/msg/Name`.
    const TYPE_NAME: &'static str;
    /// `(name, ROS type)` of every field, in order.
    fn fields() -> Vec<(&'static str, String)>;
    /// `(name, ROS type, value)` of every constant.
    fn constants() -> Vec<(&'static str, String, String)>;
}
