//! The buffer's behaviour: chains, statics and dynamics, interpolation, tf2's errors, caps; its
//! numbers against an independent numpy computation (`tests/tf/reference.json`); and random,
//! hostile messages.

use super::*;
use crate::msg::{Header, Pose, Quaternion as WireQ, Vector3 as WireV};
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use std::f64::consts::FRAC_PI_2;

const S: i64 = 1_000_000_000;

fn stamp(ns: i64) -> Time {
    Time {
        sec: (ns.div_euclid(S)) as i32,
        nanosec: ns.rem_euclid(S) as u32,
    }
}

/// `child` at `t` in `parent`, turned `angle` about z, at `ns`.
fn tf(parent: &str, child: &str, ns: i64, t: [f64; 3], angle: f64) -> TransformStamped {
    let (s, c) = (angle / 2.0).sin_cos();
    tf_q(parent, child, ns, t, [0.0, 0.0, s, c])
}

fn tf_q(parent: &str, child: &str, ns: i64, t: [f64; 3], q: [f64; 4]) -> TransformStamped {
    TransformStamped {
        header: Header {
            stamp: stamp(ns),
            frame_id: parent.into(),
        },
        child_frame_id: child.into(),
        transform: crate::msg::Transform {
            translation: WireV {
                x: t[0],
                y: t[1],
                z: t[2],
            },
            rotation: WireQ {
                x: q[0],
                y: q[1],
                z: q[2],
                w: q[3],
            },
        },
    }
}

fn close(a: Vector3<f64>, b: [f64; 3]) -> bool {
    (a - Vector3::from(b)).norm() < 1e-12
}

fn at(buffer: &TfBuffer, target: &str, source: &str, ns: i64, p: [f64; 3]) -> Vector3<f64> {
    let t = buffer.lookup(target, source, ns).expect("a transform");
    (t * Point3::from(p)).coords
}

/// world ← base (dynamic, moving along x) ← arm (static: 1 m up, turned 90° about z).
fn robot() -> TfBuffer {
    let mut b = TfBuffer::new();
    b.insert(&tf("base", "arm", 0, [0.0, 0.0, 1.0], FRAC_PI_2), true);
    b.insert(&tf("world", "base", 10 * S, [0.0, 0.0, 0.0], 0.0), false);
    b.insert(&tf("world", "base", 12 * S, [2.0, 0.0, 0.0], 0.0), false);
    b
}

#[test]
fn a_chain_composes_parent_by_parent() {
    let b = robot();
    // arm's x axis is base's y: a point 1 m along arm's x is at (x_base, 1, 1) in world.
    assert!(close(
        at(&b, "world", "arm", 10 * S, [1.0, 0.0, 0.0]),
        [0.0, 1.0, 1.0]
    ));
    assert!(close(
        at(&b, "world", "arm", 12 * S, [1.0, 0.0, 0.0]),
        [2.0, 1.0, 1.0]
    ));
    // The other way: world's origin seen from arm at 12 s.
    assert!(close(
        at(&b, "arm", "world", 12 * S, [2.0, 1.0, 1.0]),
        [1.0, 0.0, 0.0]
    ));
    // A frame to itself is the identity, even a frame only ever a parent.
    assert!(close(
        at(&b, "world", "world", 5, [3.0, 4.0, 5.0]),
        [3.0, 4.0, 5.0]
    ));
    // Between two siblings' children, through the common ancestor.
    let mut b = robot();
    b.insert(&tf("base", "cam", 0, [0.0, 0.5, 0.0], 0.0), true);
    assert!(close(
        at(&b, "cam", "arm", 11 * S, [0.0, 0.0, 0.0]),
        [0.0, -0.5, 1.0]
    ));
}

#[test]
fn translation_is_interpolated_linearly_and_rotation_by_slerp() {
    let b = robot();
    assert!(close(
        at(&b, "world", "base", 11 * S, [0.0; 3]),
        [1.0, 0.0, 0.0]
    ));
    assert!(close(
        at(&b, "world", "base", 10 * S + S / 2, [0.0; 3]),
        [0.5, 0.0, 0.0]
    ));
    let mut b = TfBuffer::new();
    b.insert(&tf("w", "r", 0, [0.0; 3], 0.0), false);
    b.insert(&tf("w", "r", S, [0.0; 3], FRAC_PI_2), false);
    // A quarter of the way from 0 to 90° about z is 22.5°.
    let x = at(&b, "w", "r", S / 4, [1.0, 0.0, 0.0]);
    let a = FRAC_PI_2 / 4.0;
    assert!(close(x, [a.cos(), a.sin(), 0.0]), "{x}");
    // The shorter arc: from 0 to -q (the same rotation written with negated quaternion).
    let mut b = TfBuffer::new();
    b.insert(&tf_q("w", "r", S, [0.0; 3], [0.0, 0.0, 0.0, 1.0]), false);
    let (s, c) = (FRAC_PI_2 / 2.0).sin_cos();
    b.insert(&tf_q("w", "r", 2 * S, [0.0; 3], [0.0, 0.0, -s, -c]), false);
    let x = at(&b, "w", "r", S + S / 2, [1.0, 0.0, 0.0]);
    let h = FRAC_PI_2 / 2.0;
    assert!(close(x, [h.cos(), h.sin(), 0.0]), "{x}");
}

#[test]
fn time_zero_is_the_latest_time_common_to_the_chain() {
    let mut b = robot();
    b.insert(&tf("arm", "tool", 11 * S, [1.0, 0.0, 0.0], 0.0), false);
    // base's latest is 12 s, tool's 11 s: the lookup is at 11 s, base interpolated at x = 1.
    assert!(close(at(&b, "world", "tool", 0, [0.0; 3]), [1.0, 1.0, 1.0]));
    // Statics alone: any time.
    assert!(close(at(&b, "base", "arm", 0, [0.0; 3]), [0.0, 0.0, 1.0]));
}

#[test]
fn extrapolation_is_refused_with_tf2s_words() {
    let b = robot();
    let e = b
        .lookup("world", "arm", 13 * S)
        .expect_err("after the latest");
    assert_eq!(
        e.to_string(),
        "Lookup would require extrapolation into the future.  Requested time 13.000000 but the \
         latest data is at time 12.000000, when looking up transform from frame [arm] to frame \
         [world]"
    );
    let e = b
        .lookup("arm", "world", 9 * S + S / 2)
        .expect_err("before the first");
    assert_eq!(
        e.to_string(),
        "Lookup would require extrapolation into the past.  Requested time 9.500000 but the \
         earliest data is at time 10.000000, when looking up transform from frame [world] to \
         frame [arm]"
    );
    let mut b = TfBuffer::new();
    b.insert(&tf("w", "r", 3 * S, [0.0; 3], 0.0), false);
    let e = b.lookup("w", "r", 4 * S).expect_err("one sample");
    assert_eq!(
        e.to_string(),
        "Lookup would require extrapolation at time 4.000000, but only time 3.000000 is in the \
         buffer, when looking up transform from frame [r] to frame [w]"
    );
}

#[test]
fn unknown_empty_and_slashed_frames_are_refused_with_tf2s_words() {
    let b = robot();
    assert_eq!(
        b.lookup("a", "base", 0).expect_err("unknown").to_string(),
        "\"a\" passed to lookupTransform argument target_frame does not exist. "
    );
    assert_eq!(
        b.lookup("base", "b", 0).expect_err("unknown").to_string(),
        "\"b\" passed to lookupTransform argument source_frame does not exist. "
    );
    assert_eq!(
        b.lookup("", "base", 0).expect_err("empty").to_string(),
        "Invalid argument \"\" passed to lookupTransform argument target_frame - in tf2 \
         frame_ids cannot be empty"
    );
    assert!(matches!(
        b.lookup("/base", "arm", 0),
        Err(TfError::Slash(..))
    ));
}

#[test]
fn two_trees_are_not_joined() {
    let mut b = robot();
    b.insert(&tf("map", "odom", 0, [0.0; 3], 0.0), true);
    assert_eq!(
        b.lookup("odom", "arm", 0)
            .expect_err("two trees")
            .to_string(),
        "Could not find a connection between 'odom' and 'arm' because they are not part of the \
         same tree.Tf has two or more unconnected trees."
    );
    assert!(matches!(
        b.lookup("map", "base", 11 * S),
        Err(TfError::NotConnected { .. })
    ));
}

#[test]
fn a_frame_can_move_to_another_parent_over_time() {
    let mut b = TfBuffer::new();
    b.insert(&tf("a", "x", S, [1.0, 0.0, 0.0], 0.0), false);
    b.insert(&tf("b", "x", 2 * S, [0.0, 1.0, 0.0], 0.0), false);
    b.insert(&tf("a", "x", 3 * S, [1.0, 0.0, 0.0], 0.0), false);
    assert!(close(at(&b, "b", "x", 2 * S, [0.0; 3]), [0.0, 1.0, 0.0]));
    // Across a change of parent, the older sample holds: at 1.5 s, x is still under a.
    assert!(close(
        at(&b, "a", "x", S + S / 2, [0.0; 3]),
        [1.0, 0.0, 0.0]
    ));
    assert!(matches!(
        b.lookup("b", "x", S + S / 2),
        Err(TfError::NotConnected { .. })
    ));
}

#[test]
fn a_loop_of_parents_fails_the_lookup_without_hanging() {
    let mut b = TfBuffer::new();
    b.insert(&tf("a", "b", S, [0.0; 3], 0.0), false);
    b.insert(&tf("b", "c", S, [0.0; 3], 0.0), false);
    b.insert(&tf("c", "a", S, [0.0; 3], 0.0), false);
    b.insert(&tf("w", "z", S, [0.0; 3], 0.0), false);
    assert_eq!(b.lookup("a", "z", S), Err(TfError::Loop));
    assert_eq!(b.lookup("z", "a", 0), Err(TfError::Loop));
    assert_eq!(b.lookup("w", "c", S), Err(TfError::Loop));
    assert_eq!(
        TfError::Loop.to_string(),
        "The tf tree is invalid because it contains a loop."
    );
}

#[test]
fn statics_hold_at_every_time_and_replace_dynamics() {
    let mut b = robot();
    assert!(b.lookup("base", "arm", 1).is_ok());
    assert!(b.lookup("base", "arm", 1_000_000 * S).is_ok());
    b.insert(&tf("world", "base", 0, [5.0, 0.0, 0.0], 0.0), true);
    assert!(close(
        at(&b, "world", "base", 99 * S, [0.0; 3]),
        [5.0, 0.0, 0.0]
    ));
    assert_eq!(b.sample_count(), 2);
}

#[test]
fn dynamics_are_kept_ten_seconds_behind_the_latest() {
    let mut b = TfBuffer::new();
    for k in 0..30 {
        b.insert(&tf("w", "r", k * S, [k as f64, 0.0, 0.0], 0.0), false);
    }
    // 19 s to 29 s: eleven samples.
    assert_eq!(b.sample_count(), 11);
    assert!(matches!(
        b.lookup("w", "r", 18 * S),
        Err(TfError::Extrapolation { .. })
    ));
    assert!(b.lookup("w", "r", 19 * S).is_ok());
    // Older than the window: dropped, counted.
    b.insert(&tf("w", "r", 5 * S, [0.0; 3], 0.0), false);
    assert_eq!(b.dropped().too_old, 1);
    // The same stamp again replaces the sample.
    b.insert(&tf("w", "r", 29 * S, [-1.0, 0.0, 0.0], 0.0), false);
    assert_eq!(b.sample_count(), 11);
    assert!(close(at(&b, "w", "r", 29 * S, [0.0; 3]), [-1.0, 0.0, 0.0]));
}

#[test]
fn bad_transforms_are_dropped_as_tf2_drops_them() {
    let mut b = TfBuffer::new();
    b.insert(&tf("a", "a", S, [0.0; 3], 0.0), false);
    b.insert(&tf("", "a", S, [0.0; 3], 0.0), false);
    b.insert(&tf("a", "/", S, [0.0; 3], 0.0), false);
    b.insert(
        &tf("a", &"x".repeat(MAX_FRAME_NAME_BYTES + 1), S, [0.0; 3], 0.0),
        false,
    );
    b.insert(&tf("a", "b", S, [f64::NAN, 0.0, 0.0], 0.0), false);
    b.insert(&tf("a", "b", S, [f64::INFINITY, 0.0, 0.0], 0.0), false);
    b.insert(&tf("a", "b", S, [0.0, 0.0, -1.000_001e6], 0.0), false);
    b.insert(&tf_q("a", "b", S, [0.0; 3], [0.0, 0.0, 0.0, 0.0]), false);
    b.insert(&tf_q("a", "b", S, [0.0; 3], [0.0, 0.0, 0.0, 1.01]), false);
    b.insert(
        &tf_q("a", "b", S, [0.0; 3], [0.0, 0.0, f64::NAN, 1.0]),
        false,
    );
    assert_eq!(
        b.dropped(),
        Dropped {
            bad_frame: 4,
            bad_value: 6,
            too_old: 0,
            over_cap: 0
        }
    );
    assert_eq!((b.frame_count(), b.sample_count()), (0, 0));
    // Within tf2's tolerance: kept, normalised; and a leading slash is stripped.
    b.insert(&tf_q("/a", "b", S, [0.0; 3], [0.0, 0.0, 0.0, 1.004]), false);
    let t = b.lookup("a", "b", S).expect("kept");
    assert!((t.rotation.quaternion().norm() - 1.0).abs() < 1e-15);
}

#[test]
fn the_caps_bound_frames_and_samples() {
    let mut b = TfBuffer::new();
    let message = TfMessage {
        transforms: (0..MAX_FRAMES + 10)
            .map(|i| tf("root", &format!("f{i}"), S, [0.0; 3], 0.0))
            .collect(),
    };
    b.insert_message(&message, false);
    assert_eq!(b.frame_count(), MAX_FRAMES);
    assert_eq!(b.dropped().over_cap, 11);
    // One frame at 2 kHz for 10 s: its oldest go past MAX_SAMPLES_PER_FRAME.
    let mut b = TfBuffer::new();
    for k in 0..2 * MAX_SAMPLES_PER_FRAME as i64 {
        b.insert(&tf("w", "r", S + k * 500_000, [0.0; 3], 0.0), false);
    }
    assert_eq!(b.sample_count(), MAX_SAMPLES_PER_FRAME);
    assert!(b
        .lookup("w", "r", S + 2 * MAX_SAMPLES_PER_FRAME as i64 * 250_000)
        .is_ok());
    assert!(b.lookup("w", "r", S).is_err());
    // Many frames, each many samples: never more than MAX_SAMPLES in all.
    let mut b = TfBuffer::new();
    let frames = MAX_SAMPLES / MAX_SAMPLES_PER_FRAME + 5;
    for k in 0..MAX_SAMPLES_PER_FRAME as i64 {
        for f in 0..frames {
            b.insert(
                &tf("w", &format!("f{f}"), S + k * 100_000, [0.0; 3], 0.0),
                false,
            );
        }
    }
    assert!(b.sample_count() <= MAX_SAMPLES, "{}", b.sample_count());
    assert!(
        b.sample_count() > MAX_SAMPLES - frames,
        "{}",
        b.sample_count()
    );
    // Every frame still answers at its own latest.
    for f in 0..frames {
        assert!(b.lookup("w", &format!("f{f}"), 0).is_ok(), "f{f}");
    }
    // Full: a frame of one sample moves on to a newer one, keeps it for an older one, and a
    // new frame gets none.
    let mut b = TfBuffer::new();
    b.insert(&tf("w", "lone", S, [0.0; 3], 0.0), false);
    for k in 0..(MAX_SAMPLES + MAX_SAMPLES_PER_FRAME) as i64 {
        let f = k as usize % (MAX_SAMPLES / MAX_SAMPLES_PER_FRAME + 1);
        b.insert(
            &tf("w", &format!("f{f}"), S + k * 1000, [0.0; 3], 0.0),
            false,
        );
    }
    assert_eq!(b.sample_count(), MAX_SAMPLES);
    b.insert(&tf("w", "lone", 2 * S, [1.0, 0.0, 0.0], 0.0), false);
    assert!(close(at(&b, "w", "lone", 0, [0.0; 3]), [1.0, 0.0, 0.0]));
    assert!(b.lookup("w", "lone", S).is_err());
    b.insert(&tf("w", "lone", S + S / 2, [0.0; 3], 0.0), false);
    assert!(close(at(&b, "w", "lone", 0, [0.0; 3]), [1.0, 0.0, 0.0]));
    let over = b.dropped().over_cap;
    b.insert(&tf("w", "newcomer", 2 * S, [0.0; 3], 0.0), false);
    assert_eq!(b.dropped().over_cap, over + 1);
    assert_eq!(
        b.lookup("w", "newcomer", 0)
            .expect_err("not kept")
            .to_string(),
        "\"newcomer\" passed to lookupTransform argument source_frame does not exist. "
    );
    assert_eq!(b.sample_count(), MAX_SAMPLES);
}

#[test]
fn gravity_turns_into_the_candidates_frame() {
    let mut b = TfBuffer::new();
    // The tool is turned 90° about x from world: world's -z is the tool's +y... (R_x(90°)
    // maps tool y to world z, so world -z is tool -y).
    let (s, c) = (FRAC_PI_2 / 2.0).sin_cos();
    b.insert(
        &tf_q("world", "tool", 0, [1.0, 2.0, 3.0], [s, 0.0, 0.0, c]),
        true,
    );
    let header = Header {
        stamp: stamp(0),
        frame_id: "tool".into(),
    };
    let g = gravity_in(&b, "world", [0.0, 0.0, -9.80665], &header)
        .expect("gravity_frame set")
        .expect("a transform");
    assert!(close(g, [0.0, -9.80665, 0.0]), "{g}");
    assert!(gravity_in(&b, "", [0.0, 0.0, -9.8], &header).is_none());
    let header = Header {
        stamp: stamp(0),
        frame_id: "camera".into(),
    };
    let e = gravity_in(&b, "world", [0.0, 0.0, -9.8], &header)
        .expect("gravity_frame set")
        .expect_err("no camera");
    assert_eq!(
        e.to_string(),
        "no transform of the gravity from frame \"world\" to frame \"camera\": \"camera\" passed \
         to lookupTransform argument target_frame does not exist. "
    );
}

#[test]
fn a_pose_is_re_expressed_in_the_candidates_frame() {
    let mut b = TfBuffer::new();
    b.insert(&tf("world", "table", 0, [1.0, 0.0, 0.0], FRAC_PI_2), true);
    let header = Header {
        stamp: stamp(7 * S),
        frame_id: "world".into(),
    };
    let (s, c) = (FRAC_PI_2 / 2.0).sin_cos();
    let pose = Pose {
        position: crate::msg::Point {
            x: 1.0,
            y: 0.0,
            z: 0.5,
        },
        orientation: WireQ {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        },
    };
    let p = pose_in(&b, &pose, "table", &header).expect("a transform");
    // table's x is world's y; the object turned 90° about z on a table turned 90°: 180°.
    assert!((p.position.x - 1.0).abs() < 1e-12 && (p.position.y - 1.0).abs() < 1e-12);
    assert!((p.position.z - 0.5).abs() < 1e-12);
    assert!(p.orientation.z.abs() > 1.0 - 1e-12 && p.orientation.w.abs() < 1e-12);
    assert_eq!(pose_in(&b, &pose, "", &header), Ok(pose.clone()));
    assert_eq!(pose_in(&b, &pose, "world", &header), Ok(pose.clone()));
    let e = pose_in(&b, &pose, "shelf", &header).expect_err("no shelf");
    assert!(
        e.to_string().contains("\"shelf\" to frame \"world\""),
        "{e}"
    );
}

#[derive(serde::Deserialize)]
struct Reference {
    transforms: Vec<RefTransform>,
    lookups: Vec<RefLookup>,
}

#[derive(serde::Deserialize)]
struct RefTransform {
    parent: String,
    child: String,
    #[serde(rename = "static")]
    is_static: bool,
    stamp_ns: i64,
    t: [f64; 3],
    q: [f64; 4],
}

#[derive(serde::Deserialize)]
struct RefLookup {
    target: String,
    source: String,
    time_ns: i64,
    /// Asked at time 0: numpy's `time_ns` is the latest common time it found.
    latest: bool,
    #[serde(default)]
    translation: Option<[f64; 3]>,
    #[serde(default)]
    rotation: Option<[f64; 9]>,
    #[serde(default)]
    error: Option<String>,
}

/// A buffer of the reference's transforms, and its lookups.
fn reference_buffer() -> (TfBuffer, Vec<RefLookup>) {
    let reference: Reference =
        serde_json::from_str(include_str!("../../tests/tf/reference.json")).expect("JSON");
    let mut b = TfBuffer::new();
    for t in &reference.transforms {
        b.insert(
            &tf_q(&t.parent, &t.child, t.stamp_ns, t.t, t.q),
            t.is_static,
        );
    }
    (b, reference.lookups)
}

/// Our transform is numpy's, to 1e-9 in every entry of the 3×4 matrix.
fn assert_same(i: usize, t: &nalgebra::Isometry3<f64>, l: &RefLookup) {
    let m = t.to_homogeneous();
    let tr = l.translation.expect("a translation");
    let r = l.rotation.expect("a rotation");
    for k in 0..3 {
        assert!((m[(k, 3)] - tr[k]).abs() < 1e-9, "{i}: {m} vs {tr:?}");
        for j in 0..3 {
            assert!((m[(k, j)] - r[3 * k + j]).abs() < 1e-9, "{i}: {m} vs {r:?}");
        }
    }
}

/// The buffer's lookups against numpy's (`tests/ros/tf_reference.py`: homogeneous matrices,
/// its own slerp), at the times numpy chose: between samples, at stamps, after them, and the
/// latest common time (which `time_zero_matches_the_numpy_reference` asks for as 0).
#[test]
fn lookups_match_the_numpy_reference() {
    let (b, lookups) = reference_buffer();
    let (mut ok, mut failed) = (0, 0);
    for (i, l) in lookups.iter().enumerate() {
        let got = b.lookup(&l.target, &l.source, l.time_ns);
        match (&l.error, got) {
            (None, Ok(t)) => {
                assert_same(i, &t, l);
                ok += 1;
            }
            (Some(kind), Err(e)) => {
                let matches = match (kind.as_str(), &e) {
                    ("not_connected", TfError::NotConnected { .. }) => true,
                    (why, TfError::Extrapolation { why: x, .. }) => matches!(
                        (why, x),
                        ("future", error::Extrapolation::Future { .. })
                            | ("past", error::Extrapolation::Past { .. })
                            | ("single", error::Extrapolation::Single { .. })
                    ),
                    _ => false,
                };
                assert!(matches, "{i}: numpy says {kind}, we say {e}");
                failed += 1;
            }
            (want, got) => panic!(
                "{i} {} <- {}: numpy {want:?}, ours {got:?}",
                l.target, l.source
            ),
        }
    }
    assert!(ok >= 50 && failed >= 10, "{ok} answered, {failed} refused");
}

/// Time 0 finds the latest common time numpy found: each lookup numpy made at time 0 gives,
/// asked at 0, numpy's transform.
#[test]
fn time_zero_matches_the_numpy_reference() {
    let (b, lookups) = reference_buffer();
    let mut checked = 0;
    for (i, l) in lookups.iter().enumerate().filter(|(_, l)| l.latest) {
        match (&l.error, b.lookup(&l.target, &l.source, 0)) {
            (None, Ok(t)) => {
                assert_same(i, &t, l);
                checked += 1;
            }
            (Some(_), Err(_)) => {}
            (want, got) => panic!("{i}: numpy {want:?}, ours {got:?}"),
        }
    }
    assert!(checked >= 30, "{checked}");
}

/// Random messages (bad quaternions, NaN, cycles, frames with two parents, huge numbers of
/// frames) never panic, keep the buffer within its caps, and lookups among them end.
#[test]
fn random_hostile_messages_stay_within_the_caps() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut b = TfBuffer::new();
    let names: Vec<String> = (0..40).map(|i| format!("f{i}")).collect();
    let wild = [
        f64::NAN,
        f64::INFINITY,
        -f64::INFINITY,
        0.0,
        1e308,
        2e6,
        -1e-308,
        1.0,
    ];
    for round in 0..300 {
        let n = rng.gen_range(0..200);
        let transforms = (0..n)
            .map(|_| {
                let mut v = || {
                    if rng.gen_bool(0.1) {
                        wild[rng.gen_range(0..wild.len())]
                    } else {
                        rng.gen_range(-2.0..2.0)
                    }
                };
                let t = [v(), v(), v()];
                let q = [v(), v(), v(), v()];
                let parent = names[rng.gen_range(0..names.len())].clone();
                let child = names[rng.gen_range(0..names.len())].clone();
                let ns = rng.gen_range(-20 * S..40 * S);
                tf_q(&parent, &child, ns, t, q)
            })
            .collect();
        b.insert_message(&TfMessage { transforms }, rng.gen_bool(0.2));
        for _ in 0..20 {
            let a = &names[rng.gen_range(0..names.len())];
            let c = &names[rng.gen_range(0..names.len())];
            let time = if rng.gen_bool(0.3) {
                0
            } else {
                rng.gen_range(-20 * S..40 * S)
            };
            if let Ok(t) = b.lookup(a, c, time) {
                assert!(t.to_homogeneous().iter().all(|x| x.is_finite()), "{round}");
            }
        }
        assert!(b.frame_count() <= MAX_FRAMES && b.sample_count() <= MAX_SAMPLES);
    }
    assert!(b.dropped().bad_value > 0 && b.dropped().bad_frame > 0);
    // 100,000 frames in one message: a long chain and a wide fan.
    let chain = TfMessage {
        transforms: (0..100_000)
            .map(|i| {
                tf(
                    &format!("c{i}"),
                    &format!("c{}", i + 1),
                    S,
                    [0.1, 0.0, 0.0],
                    0.01,
                )
            })
            .collect(),
    };
    let mut b = TfBuffer::new();
    b.insert_message(&chain, false);
    assert_eq!(b.frame_count(), MAX_FRAMES);
    assert!(b.sample_count() <= MAX_SAMPLES);
    // Deeper than tf2's MAX_GRAPH_DEPTH: refused as a loop would be, as tf2 does.
    assert_eq!(b.lookup("c0", "c5000", 0), Err(TfError::Loop));
    assert!(b.lookup("c0", "c900", 0).is_ok());
}
