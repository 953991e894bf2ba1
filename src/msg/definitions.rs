//! Complete message definitions (`ros2msg` schemas), byte for byte as rosbag2 (Jazzy) writes them
//! into MCAP, so that every reader that builds decoders from them (Foxglove's `@foxglove/rosmsg`,
//! `rosbags`, `mcap-ros2-support`, `ros2 bag`) decodes our recordings.
//!
//! # What rosbag2 does
//! Read in ros2/rosbag2, branch `jazzy` (tags 0.26.0 to 0.26.5 build the text the same way; later
//! commits only changed error handling):
//! `rosbag2_cpp/src/rosbag2_cpp/message_definitions/local_message_definition_source.cpp`,
//! `LocalMessageDefinitionSource::get_full_text`, called by `SequentialWriter::create_topic`
//! (`rosbag2_cpp/src/rosbag2_cpp/writers/sequential_writer.cpp`); `MCAPStorage::create_topic`
//! (`rosbag2_storage_mcap/src/mcap_storage.cpp`) stores the result unchanged as the schema's data,
//! with the schema name the topic type (`pkg/msg/Name`) and encoding `ros2msg`. Its unit test
//! `rosbag2_cpp/test/rosbag2_cpp/test_local_message_definition_source.cpp` (`can_find_msg_deps`)
//! shows the result.
//! - **Files**: each type's `.msg` file is read whole and verbatim (comments, blank lines, trailing
//!   spaces, its final newline) from `<share of pkg>/msg/<Name>.msg`, the share directory found
//!   through the ament index (`AMENT_PREFIX_PATH`). A name is understood as
//!   `^([a-zA-Z0-9_]+)/(?:msg/|srv/)?([a-zA-Z0-9_]+)$`, so `pkg/Name` and `pkg/msg/Name` are the
//!   same file.
//! - **Dependencies of one text**: every match of
//!   `(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+` (`MSG_FIELD_TYPE_REGEX`), minus the primitive
//!   types `bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64
//!   string` (`wstring` is not in the list); a name without `/` gets the package of the text in
//!   front (`Point` in `geometry_msgs/Pose` is `geometry_msgs/Point`). They go into a
//!   `std::set<std::string>`: deduplicated and sorted byte-wise, not in field order.
//! - **Order**: depth first. After a type's own text come its dependencies in that sorted order,
//!   each followed at once by its own dependencies, recursively (at most 50 deep).
//! - **Each type once**: one set of the names seen so far, as the fields write them (so
//!   `std_msgs/Header`, never `std_msgs/msg/Header`); a name already in it is skipped. The root
//!   type is not in the set.
//! - **Separator**: before each dependency, `"\n"`, a line of exactly 80 `=`, and the line
//!   `MSG: <name as the field writes it>`. The `"\n"` is added even though the text before it
//!   already ends with one, so an empty line precedes every separator.
//! - **End**: nothing is appended; the text ends as the last file ends (with its newline).
//!
//! Readers must not depend on the form: recordings made before this matched rosbag2 (headers
//! `MSG: std_msgs/msg/Header`, comments left out) still read and replay, because
//! [`crate::record::bag`] picks channels by schema name and decodes CDR with the Rust structs.
//!
//! # One table
//! [`DEFINITIONS`] holds each type's full name (the wire struct's [`RosMessage::TYPE_NAME`]) and
//! its `.msg` text. Ours are the files in `msg/`; the standard ones are copies of the files ROS 2
//! Jazzy installs (common_interfaces 5.3.6, rcl_interfaces 2.0.3; Apache-2.0; and `tf2_msgs` of
//! geometry2 0.36.4, BSD), kept verbatim in `src/msg/jazzy/<pkg>/<Name>.msg`.
//! `tests/it/msg_contract.rs` holds every row to the peer's real file
//! (`share/<pkg>/msg/<Name>.msg`, found through `AMENT_PREFIX_PATH`; `tf2_msgs`, which PyPI
//! carries no wheel of, to its copy here) and every wire struct to its file, field for field;
//! `tests/ros` compares the schemas of the node's recordings with an
//! independent Python port of rosbag2's algorithm over the peer's files.

use super::{
    ColorRgba, CompressedImage, Duration, GraspCandidate, GraspCandidateSet, GraspObject,
    GraspPose, GripRecommendation, GripRecommendationSet, Header, Marker, MarkerArray, Mesh,
    MeshFile, MeshTriangle, Point, Pose, PoseCandidate, PoseCandidateSet, PoseRecommendation,
    PoseRecommendationSet, PoseStamped, Quaternion, RosMessage, SolidPrimitive, TfMessage, Time,
    Transform, TransformStamped, UvCoordinate, Vector3,
};
use std::collections::BTreeSet;

/// Every message type this crate reads or writes, by full name, with its `.msg` text exactly as
/// its package ships it.
pub const DEFINITIONS: [(&str, &str); 30] = [
    (
        GraspCandidate::TYPE_NAME,
        include_str!("../../msg/GraspCandidate.msg"),
    ),
    (
        GripRecommendation::TYPE_NAME,
        include_str!("../../msg/GripRecommendation.msg"),
    ),
    (
        GraspCandidateSet::TYPE_NAME,
        include_str!("../../msg/GraspCandidateSet.msg"),
    ),
    (
        GripRecommendationSet::TYPE_NAME,
        include_str!("../../msg/GripRecommendationSet.msg"),
    ),
    (
        MeshTriangle::TYPE_NAME,
        include_str!("../../msg/MeshTriangle.msg"),
    ),
    (Mesh::TYPE_NAME, include_str!("../../msg/Mesh.msg")),
    (
        SolidPrimitive::TYPE_NAME,
        include_str!("../../msg/SolidPrimitive.msg"),
    ),
    (
        GraspObject::TYPE_NAME,
        include_str!("../../msg/GraspObject.msg"),
    ),
    (
        PoseCandidate::TYPE_NAME,
        include_str!("../../msg/PoseCandidate.msg"),
    ),
    (
        GraspPose::TYPE_NAME,
        include_str!("../../msg/GraspPose.msg"),
    ),
    (
        PoseCandidateSet::TYPE_NAME,
        include_str!("../../msg/PoseCandidateSet.msg"),
    ),
    (
        PoseRecommendation::TYPE_NAME,
        include_str!("../../msg/PoseRecommendation.msg"),
    ),
    (
        PoseRecommendationSet::TYPE_NAME,
        include_str!("../../msg/PoseRecommendationSet.msg"),
    ),
    (
        Time::TYPE_NAME,
        include_str!("jazzy/builtin_interfaces/Time.msg"),
    ),
    (
        Duration::TYPE_NAME,
        include_str!("jazzy/builtin_interfaces/Duration.msg"),
    ),
    (Header::TYPE_NAME, include_str!("jazzy/std_msgs/Header.msg")),
    (
        ColorRgba::TYPE_NAME,
        include_str!("jazzy/std_msgs/ColorRGBA.msg"),
    ),
    (
        Point::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/Point.msg"),
    ),
    (
        Vector3::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/Vector3.msg"),
    ),
    (
        Quaternion::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/Quaternion.msg"),
    ),
    (
        Pose::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/Pose.msg"),
    ),
    (
        PoseStamped::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/PoseStamped.msg"),
    ),
    (
        Transform::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/Transform.msg"),
    ),
    (
        TransformStamped::TYPE_NAME,
        include_str!("jazzy/geometry_msgs/TransformStamped.msg"),
    ),
    (
        TfMessage::TYPE_NAME,
        include_str!("jazzy/tf2_msgs/TFMessage.msg"),
    ),
    (
        CompressedImage::TYPE_NAME,
        include_str!("jazzy/sensor_msgs/CompressedImage.msg"),
    ),
    (
        UvCoordinate::TYPE_NAME,
        include_str!("jazzy/visualization_msgs/UVCoordinate.msg"),
    ),
    (
        MeshFile::TYPE_NAME,
        include_str!("jazzy/visualization_msgs/MeshFile.msg"),
    ),
    (
        Marker::TYPE_NAME,
        include_str!("jazzy/visualization_msgs/Marker.msg"),
    ),
    (
        MarkerArray::TYPE_NAME,
        include_str!("jazzy/visualization_msgs/MarkerArray.msg"),
    ),
];

/// The line before each dependency's `MSG: ` line.
const SEPARATOR: &str =
    "================================================================================\n";

/// rosbag2's `ROSBAG2_CPP_LOCAL_MESSAGE_DEFINITION_SOURCE_MAX_RECURSION_DEPTH`.
const MAX_DEPTH: u32 = 50;

/// rosbag2's `PRIMITIVE_TYPES`.
const PRIMITIVES: [&str; 14] = [
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string",
];

/// `(package, Name)` of `package/Name` or `package/msg/Name` (or `package/srv/Name`), as
/// rosbag2's `PACKAGE_TYPENAME_REGEX` reads a type name; `None` for anything else.
pub fn split_type_name(name: &str) -> Option<(&str, &str)> {
    let word = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
    let (package, rest) = name.split_once('/')?;
    let base = rest
        .strip_prefix("msg/")
        .or_else(|| rest.strip_prefix("srv/"))
        .unwrap_or(rest);
    (word(package) && word(base)).then_some((package, base))
}

/// The `.msg` text of a type (`pkg/Name` or `pkg/msg/Name`), or `None` for a type this crate
/// does not know.
pub(crate) fn definition(type_name: &str) -> Option<&'static str> {
    let wanted = split_type_name(type_name)?;
    DEFINITIONS
        .iter()
        .find(|(name, _)| split_type_name(name) == Some(wanted))
        .map(|(_, text)| *text)
}

/// The complete `ros2msg` definition of `type_name` exactly as rosbag2 (Jazzy) writes it (see
/// the module doc), or `None` when it or one of its dependencies is not in [`DEFINITIONS`].
pub(crate) fn full_text(type_name: &str) -> Option<String> {
    full_text_from(type_name, &definition)
}

/// [`full_text`] with the `.msg` texts from `lookup`.
fn full_text_from<'a>(type_name: &str, lookup: &dyn Fn(&str) -> Option<&'a str>) -> Option<String> {
    let mut seen = BTreeSet::new();
    let mut out = String::new();
    append(type_name, MAX_DEPTH, lookup, &mut seen, &mut out)?;
    Some(out)
}

/// rosbag2's `append_recursive`: the type's text, then each dependency not seen yet after its
/// separator, depth first.
fn append<'a>(
    type_name: &str,
    depth: u32,
    lookup: &dyn Fn(&str) -> Option<&'a str>,
    seen: &mut BTreeSet<String>,
    out: &mut String,
) -> Option<()> {
    if depth == 0 {
        return None;
    }
    let (package, _) = split_type_name(type_name)?;
    let text = lookup(type_name)?;
    out.push_str(text);
    for dependency in dependencies(text, package) {
        if seen.insert(dependency.clone()) {
            out.push('\n');
            out.push_str(SEPARATOR);
            out.push_str("MSG: ");
            out.push_str(&dependency);
            out.push('\n');
            append(&dependency, depth - 1, lookup, seen, out)?;
        }
    }
    Some(())
}

/// rosbag2's `parse_msg_dependencies`: the non-primitive field types of a text, with the package
/// put in front of relative names, sorted and deduplicated.
fn dependencies(text: &str, package: &str) -> BTreeSet<String> {
    field_types(text)
        .into_iter()
        .filter(|ty| !PRIMITIVES.contains(ty))
        .map(|ty| {
            if ty.contains('/') {
                ty.to_string()
            } else {
                format!("{package}/{ty}")
            }
        })
        .collect()
}

/// `\s` of rosbag2's regular expressions (`std::regex`, C locale): space, `\t`, `\n`, `\v`, `\f`,
/// `\r`.
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

/// Every type rosbag2's `MSG_FIELD_TYPE_REGEX`, `(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+`,
/// captures in `text`, in order: one search after another, each starting where the last match
/// ended. Written out by hand (the library has no regular expression engine); a unit test runs
/// the same pattern through the `regex` crate and compares.
fn field_types(text: &str) -> Vec<&str> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        // A match begins at the start of the text (`^`) or at a line feed.
        if start == 0 || bytes[start] == b'\n' {
            if let Some((ty, end)) = field_type_at(bytes, start) {
                out.push(&text[ty]);
                start = end;
                continue;
            }
        }
        start += 1;
    }
    out
}

/// The match of the field-type pattern that begins at `start`, if any: the captured type's byte
/// range and where the match ends.
///
/// Backtracking cannot find another match than the greedy path: after the leading white space
/// only a name can follow, and a shorter name is followed by a name character, which is neither
/// `[` nor white space.
fn field_type_at(bytes: &[u8], start: usize) -> Option<(std::ops::Range<usize>, usize)> {
    let skip_space = |mut i: usize| {
        while i < bytes.len() && is_space(bytes[i]) {
            i += 1;
        }
        i
    };
    // `\n` (or `^`), then `\s*`: the line feed itself is white space too.
    let name_start = skip_space(start);
    let mut name_end = name_start;
    while name_end < bytes.len()
        && (bytes[name_end].is_ascii_alphanumeric() || matches!(bytes[name_end], b'_' | b'/'))
    {
        name_end += 1;
    }
    if name_end == name_start {
        return None;
    }
    // `(?:\[[^\]]*\])?`: the brackets are tried first; without them `\s+` would face the `[`.
    let mut after = name_end;
    if bytes.get(after) == Some(&b'[') {
        let close = bytes[after..].iter().position(|&b| b == b']')?;
        after += close + 1;
    }
    // `\s+`, greedy.
    if !bytes.get(after).copied().is_some_and(is_space) {
        return None;
    }
    Some((name_start..name_end, skip_space(after)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOP_LEVEL: [&str; 10] = [
        TfMessage::TYPE_NAME,
        GraspCandidate::TYPE_NAME,
        GripRecommendation::TYPE_NAME,
        GraspCandidateSet::TYPE_NAME,
        GripRecommendationSet::TYPE_NAME,
        MarkerArray::TYPE_NAME,
        PoseCandidate::TYPE_NAME,
        PoseCandidateSet::TYPE_NAME,
        PoseRecommendation::TYPE_NAME,
        PoseRecommendationSet::TYPE_NAME,
    ];

    /// The dependency lines of a full text, in order.
    fn headers(text: &str) -> Vec<&str> {
        text.lines().filter(|l| l.starts_with("MSG: ")).collect()
    }

    #[test]
    fn every_dependency_is_known_and_listed_once_under_the_name_its_field_uses() {
        for ty in TOP_LEVEL {
            let text = full_text(ty).unwrap_or_else(|| panic!("{ty} has unknown dependencies"));
            let headers = headers(&text);
            let unique: BTreeSet<&str> = headers.iter().copied().collect();
            assert_eq!(headers.len(), unique.len(), "{ty}");
            assert!(headers.iter().all(|h| !h.contains("/msg/")), "{headers:?}");
            assert!(text.starts_with(definition(ty).expect("known")));
            assert!(text.contains(&format!("\n\n{SEPARATOR}MSG: ")), "{ty}");
        }
        let candidate = full_text(GraspCandidate::TYPE_NAME).expect("known");
        assert_eq!(
            headers(&candidate),
            [
                "MSG: geometry_msgs/Point",
                "MSG: geometry_msgs/Vector3",
                "MSG: std_msgs/Header",
                "MSG: builtin_interfaces/Time",
            ]
        );
    }

    /// rosbag2's own unit test `can_find_msg_deps`, with its test package's two files.
    #[test]
    fn rosbag2s_own_test_case() {
        let lookup = |name: &str| match split_type_name(name) {
            Some(("rosbag2_test_msgdefs", "ComplexMsg")) => {
                Some("rosbag2_test_msgdefs/BasicMsg b\n")
            }
            Some(("rosbag2_test_msgdefs", "BasicMsg")) => Some("float32 c\n"),
            _ => None,
        };
        assert_eq!(
            full_text_from("rosbag2_test_msgdefs/ComplexMsg", &lookup).as_deref(),
            Some(
                "rosbag2_test_msgdefs/BasicMsg b\n\n\
                 ================================================================================\n\
                 MSG: rosbag2_test_msgdefs/BasicMsg\nfloat32 c\n"
            )
        );
    }

    /// Depth first, siblings sorted, each name once (a diamond and a cycle back to the root,
    /// which is not in the set of seen names).
    #[test]
    fn depth_first_in_sorted_order_each_once() {
        let lookup = |name: &str| match split_type_name(name)? {
            ("p", "Root") => Some("p/C c\nB b\nq/A a\n"),
            ("p", "B") => Some("q/A a\nRoot r\n"),
            ("p", "C") => Some("int32 x\n"),
            ("q", "A") => Some("float64 y\n"),
            _ => None,
        };
        let text = full_text_from("p/msg/Root", &lookup).expect("all known");
        let order: Vec<&str> = text
            .lines()
            .filter_map(|l| l.strip_prefix("MSG: "))
            .collect();
        assert_eq!(order, ["p/B", "p/Root", "p/C", "q/A"]);
        assert!(text.ends_with("MSG: q/A\nfloat64 y\n"), "{text}");
        assert_eq!(full_text_from("p/Missing", &lookup), None);
    }

    #[test]
    fn dependencies_are_sorted_deduplicated_and_qualified() {
        let text = "# comment Foo bar\nPoint b\n  geometry_msgs/Vector3[] v # x\nPoint[3] c\n\
                    int32 X=1\nstring<=5 s\nwstring w\nfloat64 d 0\n";
        let deps: Vec<String> = dependencies(text, "geometry_msgs").into_iter().collect();
        assert_eq!(
            deps,
            [
                "geometry_msgs/Point",
                "geometry_msgs/Vector3",
                "geometry_msgs/wstring"
            ]
        );
    }

    #[test]
    fn names_are_read_as_rosbag2_reads_them() {
        assert_eq!(
            split_type_name("std_msgs/Header"),
            Some(("std_msgs", "Header"))
        );
        assert_eq!(
            split_type_name("std_msgs/msg/Header"),
            Some(("std_msgs", "Header"))
        );
        assert_eq!(split_type_name("std_msgs/msg/a/Header"), None);
        assert_eq!(split_type_name("Header"), None);
        assert_eq!(definition("std_msgs/Header"), definition(Header::TYPE_NAME));
    }

    /// The hand-written scanner against rosbag2's pattern run by the `regex` crate (ASCII `\s`,
    /// as `std::regex` in the C locale), on every embedded file and on random texts made of the
    /// characters that matter.
    #[test]
    fn field_types_match_rosbag2s_regex() {
        let regex = regex::bytes::Regex::new(r"(?-u)(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
            .expect("rosbag2's pattern compiles");
        let by_regex = |text: &str| -> Vec<String> {
            regex
                .captures_iter(text.as_bytes())
                .map(|c| String::from_utf8_lossy(&c[1]).into_owned())
                .collect()
        };
        for (name, text) in DEFINITIONS {
            assert_eq!(field_types(text), by_regex(text), "{name}");
        }
        let alphabet = [
            "a",
            "b/",
            "_",
            "9",
            " ",
            "  ",
            "\t",
            "\n",
            "\n\n",
            "\r",
            "\x0b",
            "[",
            "]",
            "[<=3]",
            "#",
            "=",
            "<",
            "x ",
            "Point p\n",
        ];
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 32) as usize
        };
        let mut found = 0;
        for _ in 0..20_000 {
            let text: String = (0..next() % 24)
                .map(|_| alphabet[next() % alphabet.len()])
                .collect();
            let types = field_types(&text);
            assert_eq!(types, by_regex(&text), "{text:?}");
            found += types.len();
        }
        assert!(
            found > 5_000,
            "the random texts hold too few field types: {found}"
        );
    }
}
