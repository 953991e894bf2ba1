//! `visualization_msgs/MarkerArray` and the types it needs, as in ROS 2 Jazzy (checked against
//! the Jazzy `.msg` files shipped with the `ros-visualization-msgs` 5.3.6 wheel); and
//! `geometry_msgs/PoseStamped` (a pose answer's tool pose), next to the `Pose` it holds (checked
//! against the `ros-geometry-msgs` 5.3.6 wheel's file).

use super::{Header, Point, Quaternion, RosMessage, RosType, Vector3};
use serde::{Deserialize, Serialize};

ros_message! {
    /// `std_msgs/ColorRGBA`.
    ColorRgba = std_msgs/ColorRGBA [] {
        /// Red, 0..1.
        r: f32,
        /// Green, 0..1.
        g: f32,
        /// Blue, 0..1.
        b: f32,
        /// Opacity, 0..1.
        a: f32,
    }
}

ros_message! {
    /// `builtin_interfaces/Duration`.
    Duration = builtin_interfaces/Duration [] {
        /// Seconds.
        sec: i32,
        /// Nanoseconds.
        nanosec: u32,
    }
}

ros_message! {
    /// `geometry_msgs/Pose`.
    Pose = geometry_msgs/Pose [] {
        /// Position, m.
        position: Point,
        /// Orientation.
        orientation: Quaternion,
    }
}

ros_message! {
    /// `geometry_msgs/PoseStamped`: a pose with the frame it is given in and its time.
    PoseStamped = geometry_msgs/PoseStamped [] {
        /// The frame of `pose` and its time.
        #[serde(default)]
        header: Header,
        /// The pose in `header.frame_id`.
        pose: Pose,
    }
}

ros_message! {
    /// `sensor_msgs/CompressedImage` (a marker's texture; always empty here).
    CompressedImage = sensor_msgs/CompressedImage [] {
        /// Header.
        header: Header,
        /// Image format.
        format: String,
        /// Compressed bytes.
        data: Vec<u8>,
    }
}

ros_message! {
    /// `visualization_msgs/UVCoordinate`.
    UvCoordinate = visualization_msgs/UVCoordinate [] {
        /// u.
        u: f32,
        /// v.
        v: f32,
    }
}

ros_message! {
    /// `visualization_msgs/MeshFile`.
    MeshFile = visualization_msgs/MeshFile [] {
        /// File name.
        filename: String,
        /// File bytes.
        data: Vec<u8>,
    }
}

ros_message! {
    /// `visualization_msgs/Marker` (Jazzy layout).
    Marker = visualization_msgs/Marker [
        ARROW: i32 = 0,
        CUBE: i32 = 1,
        SPHERE: i32 = 2,
        CYLINDER: i32 = 3,
        LINE_STRIP: i32 = 4,
        LINE_LIST: i32 = 5,
        CUBE_LIST: i32 = 6,
        SPHERE_LIST: i32 = 7,
        POINTS: i32 = 8,
        TEXT_VIEW_FACING: i32 = 9,
        MESH_RESOURCE: i32 = 10,
        TRIANGLE_LIST: i32 = 11,
        ARROW_STRIP: i32 = 12,
        ADD: i32 = 0,
        MODIFY: i32 = 0,
        DELETE: i32 = 2,
        DELETEALL: i32 = 3,
    ] {
        /// Frame and stamp.
        header: Header,
        /// Namespace of the marker.
        ns: String,
        /// Id within the namespace.
        id: i32,
        /// `ARROW` .. (`type` on the wire).
        kind as "type": i32,
        /// `ADD`, `DELETE`, `DELETEALL`.
        action: i32,
        /// Pose of the marker.
        pose: Pose,
        /// Scale, m.
        scale: Vector3,
        /// Colour.
        color: ColorRgba,
        /// How long it stays; zero = forever.
        lifetime: Duration,
        /// Whether it follows its frame.
        frame_locked: bool,
        /// Points, m (lists, strips, arrows).
        points: Vec<Point>,
        /// Per-point colours.
        colors: Vec<ColorRgba>,
        /// Texture URI.
        texture_resource: String,
        /// Texture.
        texture: CompressedImage,
        /// Texture coordinates.
        uv_coordinates: Vec<UvCoordinate>,
        /// Text of a text marker.
        text: String,
        /// Mesh URI.
        mesh_resource: String,
        /// Mesh.
        mesh_file: MeshFile,
        /// Whether a mesh uses its own materials.
        mesh_use_embedded_materials: bool,
    }
}

ros_message! {
    /// `visualization_msgs/MarkerArray`.
    MarkerArray = visualization_msgs/MarkerArray [] {
        /// The markers.
        markers: Vec<Marker>,
    }
}
