//! Complete message definitions in rosbag2's `ros2msg` form: the type's own `.msg` text first,
//! then every type it depends on, each after a line of 80 `=` and a line `MSG: pkg/msg/Name`.
//! MCAP readers (rosbag2, Foxglove, `rosbags`, `mcap-ros2-support`) build decoders from it.

/// One `.msg` definition by full type name. Ours are the files in `msg/`; the standard ones are
/// the fields of the Jazzy definitions (comments left out).
fn definition(type_name: &str) -> Option<&'static str> {
    Some(match type_name {
        "grasp_orient/msg/GraspCandidate" => include_str!("../../msg/GraspCandidate.msg"),
        "grasp_orient/msg/GripRecommendation" => {
            include_str!("../../msg/GripRecommendation.msg")
        }
        "builtin_interfaces/msg/Time" => "int32 sec\nuint32 nanosec\n",
        "builtin_interfaces/msg/Duration" => "int32 sec\nuint32 nanosec\n",
        "std_msgs/msg/Header" => "builtin_interfaces/Time stamp\nstring frame_id\n",
        "std_msgs/msg/ColorRGBA" => "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
        "geometry_msgs/msg/Point" => "float64 x\nfloat64 y\nfloat64 z\n",
        "geometry_msgs/msg/Vector3" => "float64 x\nfloat64 y\nfloat64 z\n",
        "geometry_msgs/msg/Quaternion" => "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
        "geometry_msgs/msg/Pose" => "Point position\nQuaternion orientation\n",
        "sensor_msgs/msg/CompressedImage" => "std_msgs/Header header\nstring format\nuint8[] data\n",
        "visualization_msgs/msg/UVCoordinate" => "float32 u\nfloat32 v\n",
        "visualization_msgs/msg/MeshFile" => "string filename\nuint8[] data\n",
        "visualization_msgs/msg/MarkerArray" => "Marker[] markers\n",
        "visualization_msgs/msg/Marker" => concat!(
            "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n",
            "int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n",
            "int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n",
            "int32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n",
            "std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n",
            "geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n",
            "builtin_interfaces/Duration lifetime\nbool frame_locked\n",
            "geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\n",
            "string texture_resource\nsensor_msgs/CompressedImage texture\n",
            "UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\n",
            "MeshFile mesh_file\nbool mesh_use_embedded_materials\n",
        ),
        _ => return None,
    })
}

/// The field types of a definition that are messages, as full type names, in order.
fn dependencies(package: &str, text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        if line.contains('=') && !line.contains(' ') {
            continue;
        }
        let base = ty.split('[').next().unwrap_or(ty);
        let primitive = matches!(
            base,
            "bool"
                | "byte"
                | "char"
                | "float32"
                | "float64"
                | "int8"
                | "uint8"
                | "int16"
                | "uint16"
                | "int32"
                | "uint32"
                | "int64"
                | "uint64"
                | "string"
                | "wstring"
        ) || base.starts_with("string<");
        if primitive {
            continue;
        }
        let full = match base.split_once('/') {
            Some((pkg, name)) => format!("{pkg}/msg/{name}"),
            None => format!("{package}/msg/{base}"),
        };
        out.push(full);
    }
    out
}

/// The complete `ros2msg` definition of `type_name` (`pkg/msg/Name`), or `None` for a type this
/// crate does not know.
pub fn full_text(type_name: &str) -> Option<String> {
    let mut text = definition(type_name)?.to_string();
    let mut seen = vec![type_name.to_string()];
    let mut queue = dependencies(package_of(type_name), &text);
    while let Some(dep) = queue.first().cloned() {
        queue.remove(0);
        if seen.contains(&dep) {
            continue;
        }
        let body = definition(&dep)?;
        if !text.ends_with('\n') {
            text.push('\n');
        }
        text.push_str(&"=".repeat(80));
        text.push_str("\nMSG: ");
        text.push_str(&dep);
        text.push('\n');
        text.push_str(body);
        queue.extend(dependencies(package_of(&dep), body));
        seen.push(dep);
    }
    Some(text)
}

fn package_of(type_name: &str) -> &str {
    type_name.split('/').next().unwrap_or("")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_dependency_is_known_and_listed_once() {
        for ty in [
            "grasp_orient/msg/GraspCandidate",
            "grasp_orient/msg/GripRecommendation",
            "visualization_msgs/msg/MarkerArray",
        ] {
            let text = full_text(ty).unwrap_or_else(|| panic!("{ty} has unknown dependencies"));
            let headers: Vec<&str> = text.lines().filter(|l| l.starts_with("MSG: ")).collect();
            let mut unique = headers.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(headers.len(), unique.len(), "{ty}");
            assert!(text.contains(&format!("{}\nMSG: ", "=".repeat(80))));
        }
        let candidate = full_text("grasp_orient/msg/GraspCandidate").expect("known");
        for dep in [
            "std_msgs/msg/Header",
            "builtin_interfaces/msg/Time",
            "geometry_msgs/msg/Point",
            "geometry_msgs/msg/Vector3",
        ] {
            assert!(candidate.contains(&format!("MSG: {dep}\n")), "{dep}");
        }
    }
}
