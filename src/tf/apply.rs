//! What the node asks of the buffer for a candidate: gravity in the candidate's frame at its
//! stamp, and a pose re-expressed from its own frame into the candidate's.

use super::{nanoseconds, strip_slash, TfBuffer, TfError};
use crate::msg::{Header, Point, Pose, Quaternion as WireQuaternion};
use compact_str::CompactString;
use nalgebra::{Quaternion, Vector3};
use std::fmt;

/// A transform the buffer could not give, naming both frames (tf2's own text after them).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TfFailure {
    /// What was being transformed: `"gravity"` or `"pose"`.
    pub(crate) what: &'static str,
    /// The frame it is given in.
    pub(crate) from: CompactString,
    /// The frame it was wanted in.
    pub(crate) to: CompactString,
    /// Why, as tf2 says it.
    pub(crate) error: Box<TfError>,
}

impl fmt::Display for TfFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "no transform of the {} from frame \"{}\" to frame \"{}\": {}",
            self.what, self.from, self.to, self.error
        )
    }
}

impl std::error::Error for TfFailure {}

/// Gravity, `gravity` in frame `gravity_frame` (the parameters of the same names), as a vector
/// in the frame and at the stamp of `header` (stamp 0: the latest common time). A direction
/// only turns with the frames: `g_header = R_header_gravity · g`, the translation left out.
/// `None` when `gravity_frame` is empty: the candidate's own gravity holds.
pub(crate) fn gravity_in(
    buffer: &TfBuffer,
    gravity_frame: &str,
    gravity: [f64; 3],
    header: &Header,
) -> Option<Result<Vector3<f64>, TfFailure>> {
    if gravity_frame.is_empty() {
        return None;
    }
    let g = Vector3::from(gravity);
    Some(
        buffer
            .lookup(
                strip_slash(&header.frame_id),
                strip_slash(gravity_frame),
                nanoseconds(&header.stamp),
            )
            .map(|t| t.rotation * g)
            .map_err(|error| TfFailure {
                what: "gravity",
                from: gravity_frame.into(),
                to: header.frame_id.clone(),
                error: Box::new(error),
            }),
    )
}

/// `pose`, given in frame `frame`, as a pose in the frame and at the stamp of `header`:
/// `T_header_pose = T_header_frame · T_frame_pose`. Unchanged when `frame` is empty or the
/// header's own.
pub(crate) fn pose_in(
    buffer: &TfBuffer,
    pose: &Pose,
    frame: &str,
    header: &Header,
) -> Result<Pose, TfFailure> {
    let from = strip_slash(frame);
    let to = strip_slash(&header.frame_id);
    if from.is_empty() || from == to {
        return Ok(pose.clone());
    }
    let t = buffer
        .lookup(to, from, nanoseconds(&header.stamp))
        .map_err(|error| TfFailure {
            what: "pose",
            from: frame.into(),
            to: header.frame_id.clone(),
            error: Box::new(error),
        })?;
    let p = &pose.position;
    let q = &pose.orientation;
    // Position: the point moved, `R p + t`. Orientation: `q_t · q`, the plain Hamilton product,
    // so that a pose quaternion of the wrong length (or NaN) keeps its fault and the pose check
    // that runs on the result refuses it as it would the original.
    let position = t * nalgebra::Point3::new(p.x, p.y, p.z);
    let r = t.rotation.quaternion() * Quaternion::new(q.w, q.x, q.y, q.z);
    Ok(Pose {
        position: Point {
            x: position.x,
            y: position.y,
            z: position.z,
        },
        orientation: WireQuaternion {
            x: r.i,
            y: r.j,
            z: r.k,
            w: r.w,
        },
    })
}
