//! The benchmarks' object and poses: a 100,000-triangle torus in millimetres as binary STL, and
//! 1,000 poses across its tube as a planner would give them (`benches/cast.rs` here, and the
//! root's `benches/poses.rs`, which includes this file).

use std::io::Write;

use grasp_orient_geometry::{ClosingAxis, GripperPose};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;

/// A torus of `rings × sides` quads (two triangles each), in millimetres, as binary STL.
pub fn write_torus_stl(path: &std::path::Path, rings: u32, sides: u32) -> usize {
    let (big, small) = (60.0f64, 25.0f64);
    let vertex = |i: u32, j: u32| -> [f32; 3] {
        let u = std::f64::consts::TAU * f64::from(i % rings) / f64::from(rings);
        let v = std::f64::consts::TAU * f64::from(j % sides) / f64::from(sides);
        let rho = big + small * v.cos();
        [
            (rho * u.cos()) as f32,
            (rho * u.sin()) as f32,
            (small * v.sin()) as f32,
        ]
    };
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    let mut bytes = vec![0u8; 80];
    bytes.extend((triangles.len() as u32).to_le_bytes());
    for t in &triangles {
        bytes.extend([0u8; 12]);
        for v in t {
            for x in v {
                bytes.extend(x.to_le_bytes());
            }
        }
        bytes.extend([0u8; 2]);
    }
    let mut file = std::fs::File::create(path).expect("create the STL file");
    file.write_all(&bytes).expect("write the STL file");
    triangles.len()
}

pub fn random_rotation(rng: &mut impl Rng) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(
        rng.gen_range(-3.2..3.2),
        rng.gen_range(-1.6..1.6),
        rng.gen_range(-3.2..3.2),
    )
}

/// 1,000 poses on the torus's tube, as a planner would give them: the tool's centre on the tube's
/// centre line, closing across the tube (vertically or radially, tilted by up to 0.3 rad), the
/// rest of the orientation random about the closing axis.
pub fn poses(rng: &mut impl Rng, frame: &Isometry3<f64>) -> Vec<GripperPose> {
    (0..1000)
        .map(|_| {
            let u: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let centre = Point3::new(0.06 * u.cos(), 0.06 * u.sin(), 0.0);
            let across = if rng.gen_bool(0.5) {
                Vector3::z()
            } else {
                Vector3::new(u.cos(), u.sin(), 0.0)
            };
            let tilt = UnitQuaternion::from_scaled_axis(Vector3::new(
                rng.gen_range(-0.3..0.3),
                rng.gen_range(-0.3..0.3),
                rng.gen_range(-0.3..0.3),
            ));
            let b = tilt * across;
            let spin = UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(b),
                rng.gen_range(0.0..std::f64::consts::TAU),
            );
            let to_b = UnitQuaternion::rotation_between(&Vector3::y(), &b)
                .unwrap_or_else(UnitQuaternion::identity);
            GripperPose {
                tool_pose: Isometry3::from_parts(
                    Translation3::from((frame * centre).coords),
                    frame.rotation * spin * to_b,
                ),
                width: 0.08,
                closing_axis: ClosingAxis::Y,
            }
        })
        .collect()
}
