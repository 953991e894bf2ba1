//! The tool pose to carry the object in: the gripper pose after the answer's rotation, about the
//! grasp centre, in the candidate's header frame (`docs/poses.md`, "The tool pose").
//!
//! # Derivation
//! The answer's rotation `R` (`recommendation.rotation`, the unit quaternion `r` of angle
//! `wrist_rotation` about `rotation_axis`, both in the header frame H) is a rotation **of the
//! object** in H: gravity, seen in the object's frame, goes from `ĝ0` to `Rᵀ ĝ0`, the
//! recommended direction (`docs/theory.md`, "The rotation"). The object is held between the
//! fingers, so gripper and object move as one rigid body: a rigid motion that turns the object
//! by `R` turns the tool frame by the same `R`, and moves every point `x` of both to
//! `c + R (x − c)` for some fixed point `c`. Gravity seen in the object depends on `R` alone,
//! not on `c`, so the grip forces and the answer hold for any `c`; `c` only says where the
//! object ends up. It is taken as the **grasp centre**, the midpoint of the two contacts
//! `m = (p1 + p2) / 2`: the held point of the object then stays where it is (the object turns
//! in place, between the fingers, as a wrist turning about the grasp would turn it), and a turn
//! about the contact axis (the smallest rotation's axis is often it or near it) leaves both
//! contacts where they are. The tool frame's origin `t` lies on the closing line too, but it is
//! the fingers' midpoint before closing: when the object does not sit midway between the
//! fingertips, `t ≠ m`, and a turn about `t` would carry the object by `(I − R)(m − t)` as
//! well.
//!
//! So, with the tool pose `(t, q)` in H (`q` the normalised `grasp_pose.orientation`):
//!
//! ```text
//! position    t' = m + R (t − m)
//! orientation q' = r ⊗ q          (R applied in H: a left product)
//! ```
//!
//! The header is the candidate's; the node re-expresses the pose in `gravity_frame` when that
//! is set (`crate::tf::ToolFrame`).
//!
//! # Without a rotation
//! An answer with no rotation (refused by the geometry or by the solver: NaN; a set's member
//! never solved: zero) gets the candidate's header and a pose all NaN, as every other number
//! of a refused answer is NaN; a zero quaternion would read as a rotation gone wrong.

use crate::msg::{Header, Point, Pose, PoseStamped, Quaternion as WireQuaternion};
use grasp_orient_geometry::Grasp;
use nalgebra::{Isometry3, Quaternion, UnitQuaternion};

/// The tool pose of an answer: `tool` (the gripper pose, in the header frame) turned by
/// `rotation` (the answer's) about the midpoint of the grasp's contacts; all NaN when
/// `rotation` is not one (a component not finite, or all zero).
pub(crate) fn tool_pose(
    header: &Header,
    tool: &Isometry3<f64>,
    grasp: &Grasp,
    rotation: &WireQuaternion,
) -> PoseStamped {
    let q = Quaternion::new(rotation.w, rotation.x, rotation.y, rotation.z);
    if !q.coords.iter().all(|c| c.is_finite()) || q.coords.amax() == 0.0 {
        return no_tool_pose(header);
    }
    let r = UnitQuaternion::from_quaternion(q);
    let [c1, c2] = &grasp.contacts;
    let m = nalgebra::center(&c1.point, &c2.point);
    let t = tool.translation.vector;
    let position = m + r * (t - m.coords);
    let orientation = r * tool.rotation;
    let o = orientation.quaternion();
    PoseStamped {
        header: header.clone(),
        pose: Pose {
            position: Point {
                x: position.x,
                y: position.y,
                z: position.z,
            },
            orientation: WireQuaternion {
                x: o.i,
                y: o.j,
                z: o.k,
                w: o.w,
            },
        },
    }
}

/// The tool pose of an answer without a rotation: `header`, and NaN for every number.
pub(crate) fn no_tool_pose(header: &Header) -> PoseStamped {
    let nan = f64::NAN;
    PoseStamped {
        header: header.clone(),
        pose: Pose {
            position: Point {
                x: nan,
                y: nan,
                z: nan,
            },
            orientation: WireQuaternion {
                x: nan,
                y: nan,
                z: nan,
                w: nan,
            },
        },
    }
}

#[cfg(test)]
mod tests {
    //! The tool pose against a computation written out here by hand, sharing nothing with the
    //! code above: quaternions to matrices by the textbook formula, the rotation from
    //! `rotation_axis` and `wrist_rotation` by Rodrigues' formula (not from the answer's
    //! quaternion), plain 3 × 3 products.
    use super::super::PoseAnswerer;
    use crate::answer::Rules;
    use crate::msg::{
        GraspObject, Header, Point, Pose, PoseCandidate, Quaternion, SolidPrimitive, Vector3,
    };
    use crate::solver::Settings;
    use grasp_orient_geometry::{AmentIndex, ClosingAxis};

    type M3 = [[f64; 3]; 3];

    /// The rotation matrix of `(x, y, z, w)`, normalised first.
    fn matrix(q: [f64; 4]) -> M3 {
        let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        let [x, y, z, w] = q.map(|c| c / n);
        [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - z * w),
                2.0 * (x * z + y * w),
            ],
            [
                2.0 * (x * y + z * w),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - x * w),
            ],
            [
                2.0 * (x * z - y * w),
                2.0 * (y * z + x * w),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ]
    }

    /// `R = I + sin φ K + (1 − cos φ) K²`, `K` the cross-product matrix of the unit axis `k`.
    fn rodrigues(k: [f64; 3], phi: f64) -> M3 {
        let kk = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
        let k2 = product(&kk, &kk);
        let (s, c) = phi.sin_cos();
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                f64::from(u8::from(i == j)) + s * kk[i][j] + (1.0 - c) * k2[i][j]
            })
        })
    }

    fn product(a: &M3, b: &M3) -> M3 {
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
    }

    fn apply(a: &M3, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
    }

    fn transposed(a: &M3) -> M3 {
        std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
    }

    fn gap(a: [f64; 3], b: [f64; 3]) -> f64 {
        (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
    }

    fn xyz(p: &Point) -> [f64; 3] {
        [p.x, p.y, p.z]
    }

    /// A random number generator of its own (xorshift), uniform in [0, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn within(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
        fn quaternion(&mut self) -> Quaternion {
            // Not normalised: the answer layer normalises a pose's quaternion, and so does
            // `matrix`.
            let [x, y, z, w] = [0; 4].map(|_| self.within(-1.0, 1.0));
            Quaternion { x, y, z, w }
        }
    }

    /// On random boxes in random poses, gripped at random points and orientations inside them
    /// with a random centre of mass and gravity: every answer with a rotation carries the tool
    /// pose `m + R (t − m)`, `R · R_tool` (m the midpoint of the contacts, R by Rodrigues from
    /// the answer's axis and angle) to 1e-12; the object, turned with the tool, meets gravity
    /// from the recommended direction (`(R R_tool)ᵀ ĝ = R_toolᵀ d`: the sign of the turn); the
    /// contacts, carried along, stay where they were in the tool frame; and an answer without a
    /// rotation has the candidate's header and NaN.
    #[test]
    fn the_tool_pose_is_the_grasp_pose_turned_about_the_grasp_centre() {
        let answerer = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let (settings, rules) = (Settings::default(), Rules::default());
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let (mut turned, mut refused, mut off_centre) = (0, 0, 0);
        for k in 0..400 {
            let candidate = random_candidate(&mut rng, k);
            let (tool, header) = (&candidate.grasp_pose, &candidate.header);
            let g = {
                let v = &candidate.gravity;
                [v.x, v.y, v.z]
            };
            let a = answerer.answer(&candidate, &settings, &rules);
            let r = &a.recommendation;
            let tp = &a.tool_pose;
            assert_eq!(tp.header, r.header, "{k}");
            assert_eq!(tp.header.frame_id, header.frame_id, "{k}");
            if !r.rotation.w.is_finite() {
                let p = &tp.pose;
                assert!(
                    [p.position.x, p.position.y, p.position.z]
                        .iter()
                        .all(|v| v.is_nan())
                        && xyz4(&p.orientation).iter().all(|v| v.is_nan()),
                    "{k}: {tp:?}"
                );
                refused += 1;
                continue;
            }
            turned += 1;
            let k_axis = [r.rotation_axis.x, r.rotation_axis.y, r.rotation_axis.z];
            let rot = rodrigues(k_axis, r.wrist_rotation);
            let m: [f64; 3] =
                std::array::from_fn(|i| 0.5 * (xyz(&a.contact_1)[i] + xyz(&a.contact_2)[i]));
            let t = xyz(&tool.position);
            if gap(m, t) > 1e-4 {
                off_centre += 1;
            }
            let moved = apply(&rot, std::array::from_fn(|i| t[i] - m[i]));
            let want_position: [f64; 3] = std::array::from_fn(|i| m[i] + moved[i]);
            let got_position = xyz(&tp.pose.position);
            assert!(
                gap(got_position, want_position) < 1e-12,
                "{k}: position {got_position:?}, by hand {want_position:?}"
            );
            let r_tool = matrix(xyz4(&tool.orientation));
            let want = product(&rot, &r_tool);
            let got = matrix(xyz4(&tp.pose.orientation));
            for (row, by_hand) in got.iter().zip(&want) {
                assert!(gap(*row, *by_hand) < 1e-12, "{k}: {got:?} by hand {want:?}");
            }
            // Gravity seen from the turned tool is the recommended direction seen from the
            // tool now.
            let norm = g.iter().map(|c| c * c).sum::<f64>().sqrt();
            let g_hat = g.map(|c| c / norm);
            let d = [
                r.gravity_direction.x,
                r.gravity_direction.y,
                r.gravity_direction.z,
            ];
            let seen_then = apply(&transposed(&got), g_hat);
            let recommended = apply(&transposed(&r_tool), d);
            assert!(
                gap(seen_then, recommended) < 1e-9,
                "{k}: gravity from the turned tool {seen_then:?}, recommended {recommended:?}"
            );
            // The contacts, turned with the tool about m, sit where they sat in the tool frame.
            for c in [xyz(&a.contact_1), xyz(&a.contact_2)] {
                let before = apply(&transposed(&r_tool), std::array::from_fn(|i| c[i] - t[i]));
                let c_then: [f64; 3] = {
                    let v = apply(&rot, std::array::from_fn(|i| c[i] - m[i]));
                    std::array::from_fn(|i| m[i] + v[i])
                };
                let after = apply(
                    &transposed(&got),
                    std::array::from_fn(|i| c_then[i] - got_position[i]),
                );
                assert!(gap(before, after) < 1e-12, "{k}: {before:?} {after:?}");
            }
        }
        println!("{turned} tool poses turned, {refused} without a rotation, {off_centre} off the tool origin");
        assert!(turned >= 120, "only {turned} answers with a rotation");
        assert!(
            refused >= 1,
            "no answer without a rotation: {turned} turned"
        );
        assert!(
            off_centre >= 60,
            "the grasp centre is the tool origin in most: {off_centre}"
        );
    }

    /// A gripper pose inside a random box in a random pose, a random turn, a random centre of
    /// mass, gravity, mass and friction, in a frame of its own.
    fn random_candidate(rng: &mut Rng, k: usize) -> PoseCandidate {
        let size = [0; 3].map(|_| rng.within(0.02, 0.12));
        let inside = |rng: &mut Rng, f: f64| size.map(|s| rng.within(-f * s / 2.0, f * s / 2.0));
        let com = inside(rng, 0.8);
        let at = inside(rng, 0.6);
        let object_pose = Pose {
            position: Point {
                x: rng.within(-1.0, 1.0),
                y: rng.within(-1.0, 1.0),
                z: rng.within(-1.0, 1.0),
            },
            orientation: rng.quaternion(),
        };
        // The gripper at `at` in the object frame, turned at random: in the header frame.
        let ro = matrix(xyz4(&object_pose.orientation));
        let to = apply(&ro, at);
        let tool_q = {
            let q = rng.quaternion();
            quaternion_product(xyz4(&object_pose.orientation), xyz4(&q))
        };
        let tool = Pose {
            position: Point {
                x: object_pose.position.x + to[0],
                y: object_pose.position.y + to[1],
                z: object_pose.position.z + to[2],
            },
            orientation: Quaternion {
                x: tool_q[0],
                y: tool_q[1],
                z: tool_q[2],
                w: tool_q[3],
            },
        };
        let g = [0; 3].map(|_| rng.within(-1.0, 1.0));
        let header = Header {
            frame_id: format!("frame-{k}").into(),
            ..Header::default()
        };
        PoseCandidate {
            header: header.clone(),
            id: format!("p{k}").into(),
            grasp_pose: tool.clone(),
            width: 0.5,
            object: GraspObject {
                pose: object_pose,
                primitive: SolidPrimitive {
                    kind: SolidPrimitive::BOX,
                    dimensions: size.to_vec(),
                },
                scale: Vector3 {
                    x: 1.0,
                    y: 1.0,
                    z: 1.0,
                },
                mass: rng.within(0.1, 2.0),
                friction: rng.within(0.3, 1.2),
                has_center_of_mass: true,
                center_of_mass: Point {
                    x: com[0],
                    y: com[1],
                    z: com[2],
                },
                ..GraspObject::default()
            },
            gravity: Vector3 {
                x: 9.81 * g[0],
                y: 9.81 * g[1],
                z: 9.81 * g[2],
            },
        }
    }

    fn xyz4(q: &Quaternion) -> [f64; 4] {
        [q.x, q.y, q.z, q.w]
    }

    /// The Hamilton product `a b` of `(x, y, z, w)` quaternions.
    fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        let [ax, ay, az, aw] = a;
        let [bx, by, bz, bw] = b;
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    }
}
