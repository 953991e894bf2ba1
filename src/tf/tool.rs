//! A pose answer's tool pose re-expressed in `gravity_frame` (docs/node.md#tf): the answer layer
//! gives it in the candidate's header frame, and the node, which has TF, moves it into the
//! frame its gravity is given in, by the transform looked up at the candidate's stamp when the
//! request was turned, so that the gravity and the tool pose use one and the same state of the
//! tree (a stamp of 0 means the latest, which moves as transforms come).

use super::{nanoseconds, strip_slash, TfBuffer, TfFailure};
use crate::msg::{clip, Header, Point, PoseStamped, Quaternion as WireQuaternion};
use compact_str::CompactString;
use nalgebra::{Isometry3, Point3, Quaternion};

/// The frame tool poses are expressed in, and the transform into it from a request's header
/// frame at the request's stamp.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ToolFrame {
    /// `gravity_frame`, as the parameter gives it (cut to an answer's frame length).
    pub(crate) frame: CompactString,
    /// `T_frame_header`: maps a point given in the header frame into `frame`.
    pub(crate) from_header: Isometry3<f64>,
}

/// The frame the tool poses of a request with `header` are given in when `gravity_frame` is
/// set: `T_gravity_header` at the header's stamp (stamp 0: the latest common time). `None`
/// when `gravity_frame` is empty: the tool poses stay in the header frame.
pub(crate) fn tool_frame(
    buffer: &TfBuffer,
    gravity_frame: &str,
    header: &Header,
) -> Option<Result<ToolFrame, TfFailure>> {
    if gravity_frame.is_empty() {
        return None;
    }
    Some(
        buffer
            .lookup(
                strip_slash(gravity_frame),
                strip_slash(&header.frame_id),
                nanoseconds(&header.stamp),
            )
            .map(|from_header| ToolFrame {
                frame: clip(gravity_frame).into(),
                from_header,
            })
            .map_err(|error| TfFailure {
                what: "tool pose",
                from: header.frame_id.clone(),
                to: gravity_frame.into(),
                error: Box::new(error),
            }),
    )
}

impl ToolFrame {
    /// `pose`, given in its header's frame, in this frame: `T_frame_header · T_header_tool`
    /// (position `R p + t`, orientation `q_t · q`); its stamp kept. A pose that is not all
    /// finite (a refused answer's NaN) is left as it is, in the header frame.
    pub(crate) fn express(&self, pose: &mut PoseStamped) {
        let (p, q) = (&pose.pose.position, &pose.pose.orientation);
        let numbers = [p.x, p.y, p.z, q.x, q.y, q.z, q.w];
        if !numbers.iter().all(|v| v.is_finite()) {
            return;
        }
        let t = &self.from_header;
        let position = t * Point3::new(p.x, p.y, p.z);
        let r = t.rotation.quaternion() * Quaternion::new(q.w, q.x, q.y, q.z);
        pose.pose.position = Point {
            x: position.x,
            y: position.y,
            z: position.z,
        };
        pose.pose.orientation = WireQuaternion {
            x: r.i,
            y: r.j,
            z: r.k,
            w: r.w,
        };
        pose.header.frame_id = self.frame.clone();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Pose, Time, TransformStamped, Vector3};
    use crate::tf::Gravity;

    /// `camera` 1 m above `world`, turned 90° about x: `(x, y, z)` of the camera is
    /// `(x, −z, y) + (0, 0, 1)` in world, worked out by hand.
    #[test]
    fn a_tool_pose_is_moved_into_the_gravity_frame_and_nan_stays_put() {
        let mut b = TfBuffer::new();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let mut t = TransformStamped::default();
        t.header.frame_id = "world".into();
        t.child_frame_id = "camera".into();
        t.transform.translation = Vector3 {
            x: 0.0,
            y: 0.0,
            z: 1.0,
        };
        t.transform.rotation = WireQuaternion {
            x: h,
            y: 0.0,
            z: 0.0,
            w: h,
        };
        b.insert(&t, true);
        let header = Header {
            stamp: Time { sec: 5, nanosec: 0 },
            frame_id: "camera".into(),
        };
        let gravity = Gravity {
            frame: "world".into(),
            vector: [0.0, 0.0, -9.8],
        };
        assert!(tool_frame(&b, "", &header).is_none());
        let frame = tool_frame(&b, &gravity.frame, &header)
            .expect("gravity_frame set")
            .expect("camera in world");
        let mut pose = PoseStamped {
            header: header.clone(),
            pose: Pose {
                position: Point {
                    x: 0.1,
                    y: 0.2,
                    z: 0.3,
                },
                orientation: WireQuaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
            },
        };
        frame.express(&mut pose);
        assert_eq!(pose.header.frame_id, "world");
        assert_eq!(pose.header.stamp, header.stamp);
        let p = &pose.pose.position;
        let near = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(near(p.x, 0.1) && near(p.y, -0.3) && near(p.z, 1.2), "{p:?}");
        let q = &pose.pose.orientation;
        assert!(
            near(q.x, h) && near(q.y, 0.0) && near(q.z, 0.0) && near(q.w, h),
            "{q:?}"
        );
        let mut refused = pose.clone();
        refused.header = header.clone();
        refused.pose.position.x = f64::NAN;
        let before = format!("{refused:?}");
        frame.express(&mut refused);
        assert_eq!(
            format!("{refused:?}"),
            before,
            "a NaN pose stays in the header frame"
        );
        let e = tool_frame(
            &b,
            "world",
            &Header {
                frame_id: "nowhere".into(),
                ..header
            },
        )
        .expect("gravity_frame set")
        .expect_err("no such frame");
        assert!(
            e.to_string().starts_with(
                "no transform of the tool pose from frame \"nowhere\" to frame \"world\""
            ),
            "{e}"
        );
    }
}
