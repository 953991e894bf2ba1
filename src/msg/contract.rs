//! How a wire struct names its fields and types in ROS terms, so tests can hold it to its `.msg`,
//! and the one place its ROS type name comes from.

/// A Rust type's name in a `.msg` file.
pub trait RosType {
    /// `float64`, `string`, `float64[4]`, `std_msgs/Header`, …
    fn ros_type() -> String;
}

/// Implements [`RosType`] for each primitive `type => "name"`.
macro_rules! primitive_names {
    ($($t:ty => $name:literal),* $(,)?) => {
        $(impl RosType for $t {
            fn ros_type() -> String {
                $name.to_string()
            }
        })*
    };
}

primitive_names! {
    f64 => "float64",
    f32 => "float32",
    u8 => "uint8",
    i8 => "int8",
    u32 => "uint32",
    i32 => "int32",
    i64 => "int64",
    bool => "bool",
    String => "string",
    compact_str::CompactString => "string",
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

/// A wire struct that mirrors a ROS message (declared with `ros_message!`, which also makes it a
/// [`RosType`] named `package/Name`).
pub trait RosMessage {
    /// ROS package, e.g. `grasp_orient`.
    const PACKAGE: &'static str;
    /// Type name within the package, e.g. `GraspCandidate`.
    const NAME: &'static str;
    /// Full type name, `package/msg/Name`: the schema name in recordings and the key of
    /// [`super::definitions::DEFINITIONS`].
    const TYPE_NAME: &'static str;
    /// `(name, ROS type)` of every field, in order.
    fn fields() -> Vec<(&'static str, String)>;
    /// `(name, ROS type, value)` of every constant.
    fn constants() -> Vec<(&'static str, String, String)>;
}

/// A service's request or response: `(name, ROS type)` of its fields, as in its `srv/*.srv`
/// file above (request) or below (response) the `---`.
pub trait RosFields {
    /// `(name, ROS type)` of every field, in order.
    fn fields() -> Vec<(&'static str, String)>;
}

/// The type name ros2-client announces a topic of `M` under (`package/msg/Name`).
pub(crate) fn message_type_name<M: RosMessage>() -> ros2_client::MessageTypeName {
    ros2_client::MessageTypeName::new(M::PACKAGE, M::NAME)
}
