//! What the spatial solver answers: where the centre of mass lies with respect to the contact
//! axis, whether the current pose holds, the recommendation, and why a grasp has no force
//! closure (module docs §1–§6).

use crate::planar::ConeMiss;
use crate::Contact;
use nalgebra::Vector3;
use std::fmt;

/// The centre of mass counts as on the contact axis when its distance from the axis is at most
/// this fraction of the contact distance. It is the fraction below which the planar model calls
/// two contacts coincident; below it the plane through the contacts and the centre of mass is not
/// determined by the data to better than about 1e-7 rad.
pub const ON_AXIS: f64 = 1e-9;

/// A centre of mass within this fraction of the contact distance from the contact axis (and not
/// on it) gives a sensitive answer: an error of 1e-3 of the contact distance in the centre of mass
/// can turn the grasp plane by 0.1 rad or more.
pub const NEAR_AXIS: f64 = 1e-2;

/// Current gravity more than this many radians out of Π cannot be held: the object swings. (Near
/// the axis the tolerance grows by the rounding of Π's normal, see module docs §5.)
pub const IN_PLANE_TOLERANCE: f64 = 1e-9;

/// Where the centre of mass lies with respect to the contact axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisRelation {
    /// Off the axis by at least [`NEAR_AXIS`] of the contact distance: Π is well determined.
    OffAxis,
    /// Off the axis by less than [`NEAR_AXIS`] but more than [`ON_AXIS`]: Π is exact but turns
    /// quickly with the centre of mass, so the answer is sensitive.
    NearAxis,
    /// On the axis: every plane through the axis can hold gravity; Π is the best of them. A
    /// centre of mass slightly off the axis would confine gravity to its own plane, so the answer
    /// is sensitive too.
    OnAxis,
}

impl AxisRelation {
    /// Whether the answer is sensitive to the centre of mass (near or on the axis).
    pub fn is_sensitive(&self) -> bool {
        !matches!(self, AxisRelation::OffAxis)
    }

    /// A sentence for the answer's message when the answer is sensitive.
    pub fn note(&self) -> Option<&'static str> {
        match self {
            AxisRelation::OffAxis => None,
            AxisRelation::NearAxis => Some(
                "sensitive: the centre of mass lies within 1% of the contact distance from the \
                 contact axis, so the grasp plane turns quickly with any error in it",
            ),
            AxisRelation::OnAxis => Some(
                "sensitive: the centre of mass lies on the contact axis, so every plane through \
                 the axis can hold it and this is the best of them; a centre of mass off the axis \
                 would confine gravity to its own plane",
            ),
        }
    }
}

/// Whether the object can be held at its current pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CurrentPose {
    /// Gravity lies in Π (within [`IN_PLANE_TOLERANCE`]); the current-pose fields hold its forces.
    Held,
    /// Gravity is `out_of_plane` rad out of Π: two point contacts cannot resist the torque about
    /// the contact axis, so the object swings. The current-pose fields are `+∞`.
    Swings {
        /// Angle between the current gravity and Π, rad.
        out_of_plane: f64,
    },
}

impl CurrentPose {
    /// A sentence for the answer's message when the object swings.
    pub fn note(&self) -> Option<String> {
        match self {
            CurrentPose::Held => None,
            CurrentPose::Swings { out_of_plane } => Some(format!(
                "at the current pose the object swings about the contact axis: gravity is \
                 {out_of_plane:.6} rad out of the grasp plane"
            )),
        }
    }
}

/// The answer for a spatial grasp with force closure.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialRecommendation")]
pub struct Recommendation {
    /// The planar answer in Π (module docs §3): gravity angle, local minima, labels, case, what
    /// became of candidate C, powers and contact forces in newtons. Its `gravity_direction` is in
    /// the basis `(plane_x, plane_y)`, its `wrist_rotation` is signed about `plane_normal` and
    /// turns the projection of the current gravity into Π, and its `current_gravity_angle` is
    /// that projection's. Its current-pose powers are `+∞` when the object swings.
    pub planar: crate::planar::Recommendation,
    /// Unit `e_x` of Π in the candidate frame.
    pub plane_x: Vector3<f64>,
    /// Unit `e_y` of Π in the candidate frame.
    pub plane_y: Vector3<f64>,
    /// Unit normal `ν = e_x × e_y` of Π in the candidate frame.
    pub plane_normal: Vector3<f64>,
    /// Unit vector: the recommended gravity direction in the candidate frame (it lies in Π).
    pub gravity_direction: Vector3<f64>,
    /// Unit axis, candidate frame, of the smallest rotation of the object that takes gravity from
    /// its current direction to the recommended one (module docs §4).
    pub rotation_axis: Vector3<f64>,
    /// Angle of that rotation, rad in `[0, π]`.
    pub rotation_angle: f64,
    /// Contact forces at the recommendation as 3D vectors in the candidate frame, N
    /// (`N_i û_i + F_i ν × û_i`).
    pub force_vectors: [Vector3<f64>; 2],
    /// `û_i`: unit projections of the inward normals into Π, along which `N_i` is reported.
    pub normal_directions: [Vector3<f64>; 2],
    /// `ν × û_i`: the directions along which `F_i` is reported.
    pub friction_directions: [Vector3<f64>; 2],
    /// `μ'_i`: the friction coefficients of the cones sliced by Π, after the safety factor.
    pub sliced_friction: [f64; 2],
    /// `tan β_i` of the tilt of each normal out of Π ([`Recommendation::normal_tilt`]).
    pub(super) tilt_tangent: [f64; 2],
    /// Whether the current pose can be held.
    pub current_pose: CurrentPose,
    /// Where the centre of mass lies with respect to the contact axis.
    pub axis: AxisRelation,
    /// Distance of the centre of mass from the contact axis over the contact distance.
    pub center_of_mass_offset: f64,
    /// The planar candidate solved in Π, for [`analyse`](super::analyse): contacts and centre of
    /// mass in the coordinates `(plane_x, plane_y)` (as given, or halved to fit the planar
    /// limits), the projected normals, the sliced coefficients (already divided by the safety
    /// factor), unit gravity along the projection of the current one, and the weight `m |g|` as
    /// its mass, so that its powers are in newtons.
    pub(super) plane_candidate: crate::planar::Candidate,
}

impl Recommendation {
    /// `β_i`: the tilt of each normal out of Π, rad in `[0, π/2)`.
    pub fn normal_tilt(&self) -> [f64; 2] {
        self.tilt_tangent.map(f64::atan)
    }

    /// The rotation as a unit quaternion `[x, y, z, w]`.
    pub fn quaternion(&self) -> [f64; 4] {
        let (s, c) = (0.5 * self.rotation_angle).sin_cos();
        let k = self.rotation_axis * s;
        [k.x, k.y, k.z, c]
    }
}

/// One reason a spatial grasp has no force closure, naming the contact.
#[derive(Debug, Clone, Copy, PartialEq)]
#[doc(alias = "SpatialMiss")]
pub enum Miss {
    /// The normal is tilted out of the grasp plane by `tilt >= half_angle`: the friction cone
    /// meets Π in no more than a ray.
    Tilted {
        /// The contact, candidate's labelling.
        contact: Contact,
        /// Tilt of its normal out of Π, rad.
        tilt: f64,
        /// Half-angle of its 3D cone after the safety factor, rad.
        half_angle: f64,
    },
    /// The (sliced) friction cone misses the other contact, as in the planar model.
    Cone(ConeMiss),
}

/// Why a spatial grasp has no force closure.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialNoForceClosure")]
pub struct NoForceClosure {
    /// One or two misses.
    pub misses: Vec<Miss>,
    /// The safety factor that divided the friction coefficients.
    pub friction_safety_factor: f64,
}

impl fmt::Display for NoForceClosure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no force closure: ")?;
        for (i, m) in self.misses.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            match m {
                Miss::Tilted {
                    contact,
                    tilt,
                    half_angle,
                } => write!(
                    f,
                    "the normal at {contact} is tilted out of the grasp plane by {tilt:.4} rad, \
                     beyond the friction angle {half_angle:.4} rad"
                )?,
                Miss::Cone(m) => write!(
                    f,
                    "the friction cone at {} (half-angle {:.4} rad in the grasp plane) misses {} \
                     by {:.4} rad",
                    m.contact,
                    m.half_angle,
                    m.contact.other(),
                    m.angle_to_other - m.half_angle
                )?,
            }
        }
        if self.friction_safety_factor != 1.0 {
            write!(
                f,
                " (friction divided by safety factor {})",
                self.friction_safety_factor
            )?;
        }
        Ok(())
    }
}

/// The solver's verdict on a valid spatial candidate.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialVerdict")]
pub enum Verdict {
    /// The grasp can be held: here is the best orientation.
    Recommended(Box<Recommendation>),
    /// No orientation can hold the grasp.
    NoForceClosure(NoForceClosure),
}
