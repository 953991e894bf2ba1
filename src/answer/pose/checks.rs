//! The numbers of a pose candidate checked and turned into geometry: the gripper pose as an isometry, coordinates, scales, the object's numbers, and the hint that a mesh may be in millimetres.

use crate::msg::{GraspObject, Point, Pose, Vector3};
use crate::solver::{
    check_friction, check_mass, spatial::check_weight, times_pow2, MAX_COORDINATE, MAX_GRAVITY,
    SQUARE_SAFE,
};
use grasp_orient_geometry::{GeometryError, GripperPose, Object, Shape};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3 as V3};
use std::fmt::Display;

use super::refusal::{NumberFault, PoseRefusal, MAX_SCALE, MIN_SCALE, UNITS_HINT_RATIO};

/// A pose as an isometry, its quaternion normalised. `field` names the pose: each coordinate of
/// its position must be finite and within the solver's coordinate limit, each component of its
/// quaternion finite, and the quaternion not zero.
///
/// # Normalisation
/// A quaternion is a rotation at any length: it is divided by its norm. The norm of one whose
/// largest component `m` lies outside `1e-150..=1e150` is first brought near 1 by an exact power
/// of two (`2^-floor(log2 m)`), since squaring its components would overflow (norm 1e200: inf)
/// or underflow (norm 1e-200: 0); one inside is divided by its norm as it is, bit for bit as
/// before.
pub(super) fn isometry(p: &Pose, field: &dyn Display) -> Result<Isometry3<f64>, PoseRefusal> {
    let t = &p.position;
    for (axis, v) in [("x", t.x), ("y", t.y), ("z", t.z)] {
        coordinate(&format_args!("{field}.position.{axis}"), v)?;
    }
    let o = &p.orientation;
    for (axis, v) in [("x", o.x), ("y", o.y), ("z", o.z), ("w", o.w)] {
        if !v.is_finite() {
            return Err(PoseRefusal::Number {
                field: format!("{field}.orientation.{axis}"),
                fault: NumberFault::NotFinite,
            });
        }
    }
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    let largest = q.coords.amax();
    if largest == 0.0 {
        return Err(PoseRefusal::Orientation {
            field: format!("{field}.orientation"),
            norm: 0.0,
        });
    }
    let q = if SQUARE_SAFE.contains(&largest) {
        q
    } else {
        let k = -(largest.log2().floor() as i32);
        Quaternion::from(q.coords.map(|c| times_pow2(c, k)))
    };
    Ok(Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// A coordinate of a pose candidate, m: finite and within the solver's coordinate limit.
pub(super) fn coordinate(field: &dyn Display, v: f64) -> Result<(), PoseRefusal> {
    let fault = if !v.is_finite() {
        NumberFault::NotFinite
    } else if v.abs() > MAX_COORDINATE {
        NumberFault::Above {
            value: v,
            limit: MAX_COORDINATE,
            unit: " m",
        }
    } else {
        return Ok(());
    };
    Err(PoseRefusal::Number {
        field: field.to_string(),
        fault,
    })
}

/// A mesh's scale: each axis's factor within `[MIN_SCALE, MAX_SCALE]`. A factor that is zero or
/// negative is left to the geometry, which names the resource and the scale.
pub(super) fn check_scale(scale: [f64; 3]) -> Result<(), PoseRefusal> {
    for (axis, v) in ["x", "y", "z"].into_iter().zip(scale) {
        let fault = if !v.is_finite() {
            NumberFault::NotFinite
        } else if v > MAX_SCALE {
            NumberFault::Above {
                value: v,
                limit: MAX_SCALE,
                unit: "",
            }
        } else if v > 0.0 && v < MIN_SCALE {
            NumberFault::Below {
                value: v,
                minimum: MIN_SCALE,
            }
        } else {
            continue;
        };
        return Err(PoseRefusal::Number {
            field: format!("object.scale.{axis}"),
            fault,
        });
    }
    Ok(())
}

/// The object's friction and mass as the solver checks them, named as the pose candidate's
/// fields (the spatial candidate gives `object.friction` to both contacts, and would name
/// `friction_1`), and the weight they make with `gravity` once gravity is within the solver's
/// limits (otherwise the solver names the gravity field at fault, `gravity.z`, the same path).
pub(super) fn check_object_numbers(o: &GraspObject, gravity: &Vector3) -> Result<(), PoseRefusal> {
    check_friction("object.friction", o.friction)?;
    let mass = check_mass("object.mass", o.mass)?;
    let g = V3::new(gravity.x, gravity.y, gravity.z);
    let gravity_checked = g.iter().all(|c| c.abs() <= MAX_GRAVITY) && g != V3::zeros();
    if gravity_checked {
        check_weight("object.mass", mass, &g)?;
    }
    Ok(())
}

/// A finger's refusal for starting inside the object, with a hint about units when the object is
/// a mesh [`UNITS_HINT_RATIO`] times wider along the closing line than the opening.
///
/// The extent is the spread of the mesh's vertices along the closing axis `b` in the object
/// frame, `max(v·b) − min(v·b)`: the object's own length along the line the fingers close on.
pub(super) fn units_hint(
    e: GeometryError,
    gripper: &GripperPose,
    object: &Object,
    o: &GraspObject,
) -> PoseRefusal {
    let Shape::Mesh(mesh) = &object.shape else {
        return e.into();
    };
    let b_header = gripper.tool_pose.rotation * gripper.closing_axis.unit().into_inner();
    let b = object.pose.rotation.inverse() * b_header;
    let (lo, hi) = mesh
        .corners()
        .flatten()
        .map(|v| V3::from(v).dot(&b))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
    let ratio = (hi - lo) / gripper.width;
    if UNITS_HINT_RATIO.contains(&ratio) {
        PoseRefusal::StartsInsideUnits {
            source: e,
            ratio,
            unit_scale: [o.scale.x, o.scale.y, o.scale.z] == [1.0; 3],
        }
    } else {
        e.into()
    }
}

pub(super) fn point(p: &Point3<f64>) -> Point {
    Point {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

pub(super) fn vector(v: &nalgebra::UnitVector3<f64>) -> Vector3 {
    Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}
