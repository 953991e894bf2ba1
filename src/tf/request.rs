//! A request of any kind turned by TF, through [`Framing::framed`]: each part's gravity from the
//! parameter `gravity` in `gravity_frame`, and its object's pose from `object.frame_id`, into the
//! part's header frame at its stamp. One function for every kind.

use super::{gravity_in, pose_in, TfBuffer, TfFailure};
use crate::kind::{Framed, Framing};
use crate::msg::Vector3;
use compact_str::CompactString;

/// What the node turns requests by: the parameters `gravity_frame` and `gravity`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Gravity {
    /// The frame `vector` is given in; empty: each request's own gravity holds.
    pub(crate) frame: CompactString,
    /// Gravitational acceleration in `frame`, m/s².
    pub(crate) vector: [f64; 3],
}

/// Whether `request` needs TF at all: `gravity_frame` is set, or its object is given in a frame
/// of its own.
pub(crate) fn needs<K: Framing>(gravity: &Gravity, request: &K::Request) -> bool {
    !gravity.frame.is_empty() || !K::object_frame(request).is_empty()
}

/// `request` as the node answers it: every part's gravity (when `gravity.frame` is set) the
/// parameter turned into the part's header frame, and its object's pose (when given in another
/// frame) moved into the header frame, `object.frame_id` then empty; or the first transform the
/// buffer cannot give. `request` itself is left as it came, so that a request waiting for its
/// transforms is tried again whole. What comes back needs no TF: it is what the node records, and
/// `replay` answers it alike.
pub(crate) fn resolve<K: Framing>(
    buffer: &TfBuffer,
    gravity: &Gravity,
    request: &K::Request,
) -> Result<K::Request, TfFailure> {
    let mut out = request.clone();
    let mut failure = None;
    K::framed(&mut out, &mut |part: Framed<'_>| {
        if failure.is_none() {
            failure = turn(buffer, gravity, part).err();
        }
    });
    failure.map_or(Ok(out), Err)
}

/// One part turned in place.
fn turn(buffer: &TfBuffer, gravity: &Gravity, part: Framed<'_>) -> Result<(), TfFailure> {
    if let Some(g) = gravity_in(buffer, &gravity.frame, gravity.vector, part.header) {
        let g = g?;
        *part.gravity = Vector3 {
            x: g.x,
            y: g.y,
            z: g.z,
        };
    }
    if let Some(object) = part.object {
        if !object.frame_id.is_empty() {
            object.pose = pose_in(buffer, &object.pose, &object.frame_id, part.header)?;
            object.frame_id = CompactString::default();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kind::{Candidates, PoseSets, Poses, Sets};
    use crate::msg::{
        GraspCandidate, GraspCandidateSet, Header, PoseCandidate, Time, TransformStamped,
    };

    /// The pose set's message, named through its kind.
    type PoseSet = <PoseSets as crate::kind::Kind>::Request;

    const S: i32 = 1;

    fn header(frame: &str, sec: i32) -> Header {
        Header {
            stamp: Time { sec, nanosec: 0 },
            frame_id: frame.into(),
        }
    }

    /// `child` in `parent` at `sec` (0 and static: always), at `t`, turned `angle` about x.
    fn about_x(parent: &str, child: &str, sec: i32, t: [f64; 3], angle: f64) -> TransformStamped {
        let mut m = TransformStamped {
            header: header(parent, sec),
            child_frame_id: child.into(),
            ..TransformStamped::default()
        };
        m.transform.translation = Vector3 {
            x: t[0],
            y: t[1],
            z: t[2],
        };
        let (s, c) = (angle / 2.0).sin_cos();
        m.transform.rotation.x = s;
        m.transform.rotation.w = c;
        m
    }

    /// world ← base (static, 1 m up, no turn) ← camera (moving: turned 0 about x at 1 s, 90° at
    /// 3 s, so 45° at 2 s by slerp); table (static under world, 2 m along x).
    fn buffer() -> TfBuffer {
        let mut b = TfBuffer::new();
        b.insert(&about_x("world", "base", 0, [0.0, 0.0, 1.0], 0.0), true);
        b.insert(&about_x("world", "table", 0, [2.0, 0.0, 0.0], 0.0), true);
        let quarter = std::f64::consts::FRAC_PI_2;
        b.insert(&about_x("base", "camera", S, [0.0, 0.0, 0.0], 0.0), false);
        b.insert(
            &about_x("base", "camera", 3 * S, [0.0, 0.0, 0.0], quarter),
            false,
        );
        b
    }

    fn world_gravity() -> Gravity {
        Gravity {
            frame: "world".into(),
            vector: [0.0, 0.0, -10.0],
        }
    }

    fn g(v: &Vector3) -> [f64; 3] {
        [v.x, v.y, v.z]
    }

    fn near(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    // The camera turned θ about x in world: a direction d in world is (d_x, c d_y + s d_z,
    // −s d_y + c d_z) in the camera (R_x(θ)ᵀ d), written out here rather than taken from the
    // buffer: (0, 0, −10) is (0, −10 s, −10 c).
    fn in_camera(theta: f64) -> [f64; 3] {
        [0.0, -10.0 * theta.sin(), -10.0 * theta.cos()]
    }

    /// Every kind's gravity is the parameter turned into each part's own frame at its own
    /// stamp: a candidate, each member of a set (two frames, two stamps), a pose candidate and
    /// a pose set.
    #[test]
    fn every_kind_gets_the_parameter_turned_into_its_frame_at_its_stamp() {
        let b = buffer();
        let gravity = world_gravity();
        let c = GraspCandidate {
            header: header("camera", 2),
            ..GraspCandidate::default()
        };
        let r = resolve::<Candidates>(&b, &gravity, &c).expect("camera at 2 s");
        assert!(
            near(g(&r.gravity), in_camera(std::f64::consts::FRAC_PI_4)),
            "{r:?}"
        );
        let set = GraspCandidateSet {
            candidates: vec![
                c.clone(),
                GraspCandidate {
                    header: header("base", 0),
                    ..GraspCandidate::default()
                },
                GraspCandidate {
                    header: header("camera", 3),
                    ..GraspCandidate::default()
                },
            ],
            ..GraspCandidateSet::default()
        };
        let r = resolve::<Sets>(&b, &gravity, &set).expect("every member");
        let got: Vec<_> = r.candidates.iter().map(|c| g(&c.gravity)).collect();
        let want = [
            in_camera(std::f64::consts::FRAC_PI_4),
            [0.0, 0.0, -10.0],
            in_camera(std::f64::consts::FRAC_PI_2),
        ];
        assert!(got.iter().zip(want).all(|(a, b)| near(*a, b)), "{got:?}");
        let p = PoseCandidate {
            header: header("camera", 2),
            ..PoseCandidate::default()
        };
        let r = resolve::<Poses>(&b, &gravity, &p).expect("camera at 2 s");
        assert!(near(g(&r.gravity), in_camera(std::f64::consts::FRAC_PI_4)));
        let ps = PoseSet {
            header: header("camera", 3),
            ..PoseSet::default()
        };
        let r = resolve::<PoseSets>(&b, &gravity, &ps).expect("camera at 3 s");
        assert!(near(g(&r.gravity), in_camera(std::f64::consts::FRAC_PI_2)));
    }

    /// An object pose given in `table` comes back in the header frame, `frame_id` emptied, for
    /// a pose candidate and a pose set alike; the gravity of the request is left alone without
    /// `gravity_frame`.
    #[test]
    fn an_object_pose_is_moved_into_the_header_frame() {
        let b = buffer();
        let none = Gravity {
            frame: "".into(),
            vector: [0.0, 0.0, -10.0],
        };
        let mut p = PoseCandidate {
            header: header("camera", 3),
            ..PoseCandidate::default()
        };
        p.gravity.y = -9.0;
        assert!(!needs::<Poses>(&none, &p));
        p.object.frame_id = "table".into();
        p.object.pose.position.x = 0.5;
        p.object.pose.orientation.w = 1.0;
        assert!(needs::<Poses>(&none, &p));
        let r = resolve::<Poses>(&b, &none, &p).expect("table to camera");
        // The point (0.5, 0, 0) of the table is (2.5, 0, 0) in world, (2.5, 0, -1) in base; the
        // camera at 3 s is turned 90° about x at base's origin: (x, y, z) in base is (x, z, -y)
        // in the camera, so (2.5, -1, 0).
        let o = &r.object;
        assert!(o.frame_id.is_empty());
        assert!(near(
            [o.pose.position.x, o.pose.position.y, o.pose.position.z],
            [2.5, -1.0, 0.0]
        ));
        // Its orientation is the camera's turn undone: -90° about x.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = &o.pose.orientation;
        assert!(
            near([q.x, q.y, q.z], [-h, 0.0, 0.0]) && (q.w - h).abs() < 1e-12,
            "{q:?}"
        );
        assert_eq!(g(&r.gravity), [0.0, -9.0, 0.0]);
        let ps = PoseSet {
            header: p.header.clone(),
            object: p.object.clone(),
            ..PoseSet::default()
        };
        let r = resolve::<PoseSets>(&b, &none, &ps).expect("table to camera");
        assert_eq!(r.object, o.clone());
        assert!(!needs::<Candidates>(&none, &GraspCandidate::default()));
        assert!(needs::<Candidates>(
            &world_gravity(),
            &GraspCandidate::default()
        ));
    }

    /// The first transform missing is the answer, naming its two frames, and the request is
    /// left as it came: a set whose third member's stamp lies past the camera's latest sample.
    #[test]
    fn a_missing_transform_names_both_frames_and_leaves_the_request() {
        let b = buffer();
        let mut set = GraspCandidateSet::default();
        for (frame, sec) in [("base", 0), ("camera", 2), ("camera", 4), ("nowhere", 0)] {
            set.candidates.push(GraspCandidate {
                header: header(frame, sec),
                ..GraspCandidate::default()
            });
        }
        let before = set.clone();
        let e = resolve::<Sets>(&b, &world_gravity(), &set).expect_err("4 s is past 3 s");
        assert_eq!(set, before);
        assert_eq!(
            e.to_string(),
            "no transform of the gravity from frame \"world\" to frame \"camera\": Lookup would \
             require extrapolation into the future.  Requested time 4.000000 but the latest data \
             is at time 3.000000, when looking up transform from frame [world] to frame [camera]"
        );
        let mut p = PoseCandidate {
            header: header("base", 0),
            ..PoseCandidate::default()
        };
        p.object.frame_id = "shelf".into();
        let e = resolve::<Poses>(&b, &world_gravity(), &p).expect_err("no shelf");
        assert!(
            e.to_string().starts_with(
                "no transform of the pose from frame \"shelf\" to frame \"base\": \"shelf\" \
                 passed to lookupTransform argument source_frame does not exist"
            ),
            "{e}"
        );
    }
}
