//! Spatial candidates: contacts, normals, centre of mass and gravity in 3D, reduced exactly to the
//! paper's planar problem (`docs/theory.md#spatial-reduction`).
//!
//! # Conventions
//! - **Candidate frame**: every point and vector is 3D in the candidate's own frame. SI units.
//! - **Normals** point into the object and may have any length > 0. `a = (p1 − p2)/|p1 − p2|` is
//!   the *contact axis*, from contact 2 to contact 1.
//! - **Friction**: Coulomb cones of half-angle `ξ_i`, `tan ξ_i = μ_i / s`; the safety factor `s`
//!   divides each coefficient *before* the cone is sliced (§2).
//! - **Gravity** `g` at the current pose; the weight is `W = m |g|` (all of `g`, not a projection).
//!
//! # 1. Why the plane Π is exact (centre of mass off the contact axis)
//! Forces `f_i` at `p_i` hold the weight `m g` at `c` when
//!
//! ```text
//!   f1 + f2 + m g = 0                       (S1)  forces
//!   r1 × f1 + r2 × f2 = 0,  r_i = p_i − c   (S2)  moments about c (the weight has none)
//! ```
//!
//! Let `ν` be the unit normal of Π, the plane through `p1`, `p2`, `c`, and split
//! `f_i = f_i∥ + f_iν ν`. As `r_i ∈ Π`, `r_i × f_i∥` is along `ν` and `r_i × ν` lies in Π, so the
//! in-plane part of (S2) is `f1ν (r1 × ν) + f2ν (r2 × ν) = (f1ν r1 + f2ν r2) × ν = 0`, that is
//! `f1ν r1 + f2ν r2 = 0`. Off the axis `r1` and `r2` are independent, so `f1ν = f2ν = 0`, and the
//! `ν` part of (S1) gives `g · ν = 0`. Every pose that can be held has gravity in Π and both contact
//! forces in Π; conversely, with gravity in Π the grasp holds exactly when the planar problem in Π
//! holds with each 3D cone replaced by its slice by Π (§2). The paper's planar problem in Π is
//! therefore the whole 3D problem, not an approximation. Checked against an SOCP over two 3D force
//! vectors with circular cones (`tests/it/util/spatial.rs`, `tests/it/spatial.rs`), which also finds
//! every gravity direction out of Π infeasible.
//!
//! # 2. A 3D friction cone sliced by Π
//! The cone `K = {f : f · n̂ ≥ |f| cos ξ}` around the unit inward normal `n̂`. Write
//! `n̂ = cos β û + sin β ν` with `û` the unit projection of `n̂` into Π and `β` the tilt of the
//! normal out of Π. For `f ∈ Π`, `f · n̂ = cos β (f · û)`, so
//!
//! ```text
//!   f ∈ K ∩ Π  ⇔  f · û ≥ |f| cos ξ / cos β  =: |f| cos ξ'
//! ```
//!
//! a planar cone around `û` with half-angle `ξ'`, `cos ξ' = cos ξ / cos β`; it is more than a ray
//! exactly when `β < ξ`. Its coefficient is
//!
//! ```text
//!   μ' = tan ξ' = sqrt(1/cos²ξ' − 1) = sqrt((1 + μ²) cos²β − 1) = sqrt(μ² cos²β − sin²β)
//!      = sqrt((μ − t)(μ + t) / (1 + t²)),   t = tan β = |n · ν| / |n − (n · ν) ν|
//! ```
//!
//! The last form is what [`sliced_friction`] computes: no trigonometry, and the only cancellation
//! is `μ − t` itself near the limit. `t ≥ μ` (`β ≥ ξ`) leaves no force closure, reported as
//! [`Miss::Tilted`]. Checked by unit tests against direct membership in the 3D cone.
//!
//! # 3. The plane's orientation and the planar answer
//! `ν = ±(p1 − c) × (p2 − c) / |…|` with the sign that makes `ν_z > 0` (or `ν_z = 0, ν_y > 0`, or
//! `ν_z = ν_y = 0, ν_x > 0`) in the candidate frame. Π's basis `(e_x, e_y)` is the rotation that
//! takes `+z` to `ν` applied to `+x` and `+y`. So a grasp lying in the x-y plane has `ν = +z`,
//! `e_x = +x`, `e_y = +y` and reads exactly as the planar model (`tests/it/spatial.rs` checks 1e-12).
//! The planar problem is solved in the coordinates `(e_x, e_y)`, and [`Recommendation::planar`]
//! is its answer as the planar model gives it: the gravity angle and local minima in the paper frame
//! of Π (right-handed about `ν`), labels A–E and the case a–d in the candidate's labelling.
//!
//! **Contact forces** `(N1, F1, N2, F2)` (the `contact_forces` of the planar answer, newtons):
//! `N_i` along `û_i`, the unit projection of the inward normal into Π, and `F_i` along `ν × û_i`
//! (the planar rule "inward normal turned +90° about +z" with `ν` for `+z`). The 3D vectors
//! `f_i = N_i û_i + F_i ν × û_i` are [`Recommendation::force_vectors`]. The 2-norm and the
//! internal force do not depend on this split; the 1-norm objective is the 1-norm of these four
//! components (in 3D terms the normal force is `N_i cos β_i`).
//!
//! # 4. The rotation
//! With `ĝ0` the current gravity direction and `d` the recommended one (in Π), rotating the object
//! by `R` turns gravity, seen in the object's frame, into `Rᵀ ĝ0`. The smallest `R` with
//! `Rᵀ ĝ0 = d` turns about `k = (d × ĝ0)/|d × ĝ0|` by `φ = ∠(d, ĝ0) ∈ [0, π]`:
//! [`Recommendation::rotation_axis`] and [`Recommendation::rotation_angle`]. In the
//! basis `(e_x, e_y, ν)`, with `ω` the planar wrist rotation (signed about `ν`, from the projection
//! of `ĝ0` to `d`) and `ĝ0 = (g_x, g_y, g_ν)`, `g_∥ = |(g_x, g_y)|`:
//!
//! ```text
//!   d × ĝ0 = (d_y g_ν, −d_x g_ν, g_∥ sin ω),   d · ĝ0 = g_∥ cos ω,   φ = atan2(|d × ĝ0|, d · ĝ0)
//! ```
//!
//! which keeps full relative accuracy for small rotations. When `ĝ0 ∈ Π` this is `k = ±ν`,
//! `φ = |ω|`: the planar answer. When `d × ĝ0 = 0` the axis is `ν`.
//!
//! # 5. The current pose
//! If `ĝ0` is more than [`IN_PLANE_TOLERANCE`] out of Π, §1 says no force can hold the object
//! there: it swings about the contact axis. (To that tolerance is added the uncertainty of Π's
//! normal from rounding: `64 ε M / dist`, with `M` the largest coordinate magnitude and `dist` the
//! distance of the centre of mass from the axis; it matters only near the axis.) The current-pose powers are then `+∞` and
//! [`CurrentPose::Swings`] gives the angle. Otherwise they are the planar ones at the projection of
//! `ĝ0`, with the full weight.
//!
//! # 6. Centre of mass on the contact axis
//! When `c` lies on the axis (within [`ON_AXIS`] of the contact distance) Π is not defined by the
//! data: every plane through the axis can hold gravity, and the forces lie in the plane through
//! the axis and gravity. The best orientation is then an optimum over planes as well; see
//! [`on_axis`] for the structure that makes it exact (for the 2-norm and the internal force, a
//! short list of planes and one closed-form function of the plane angle whose stationary points
//! are bracketed and bisected; the plane is found to better than 1e-9 rad, 3e-11 measured). The
//! answer's Π is the plane through the axis and the recommended gravity, with `e_x` along the
//! axis (contact 2 → contact 1) and `e_y` against the recommended gravity's part across the axis,
//! so that the recommended gravity angle lies in `[−π/2, π/2]`. When the recommended gravity is
//! along the axis every plane through it holds the same 3D forces; Π is then one of the planes
//! searched (the current gravity's when it ties), and the planar quantities (gravity angle ±π/2,
//! the split of each force into `N_i`, `F_i`) are those of that plane.
//!
//! A centre of mass *near* the axis (within [`NEAR_AXIS`] of the contact distance, but beyond
//! [`ON_AXIS`]) is solved in its own plane Π, which is exact for point contacts, but Π turns by
//! about `ε / offset` rad for a centre-of-mass error `ε` (relative to the contact distance), and
//! the on-axis answer (best over planes) differs from it: [`AxisRelation::NearAxis`] flags such
//! answers as sensitive, and so does [`AxisRelation::OnAxis`].
//!
//! # 7. Refused input
//! As the planar model (non-finite values, magnitudes, mass, friction, coincident contacts,
//! normals pointing out of the object, a centre of mass outside it), with every component named
//! (`contact_1.z`, …), plus: a zero normal or gravity ([`InvalidInput::ZeroVector`]), a normal
//! perpendicular to Π ([`InvalidInput::NormalPerpendicularToGraspPlane`]: its projection, the
//! planar normal, has no direction), and a centre of mass at a contact
//! ([`InvalidInput::CenterOfMassAtContact`]).

mod answer;
pub(crate) mod batch;
mod candidate;
pub mod on_axis;
mod plane;
pub mod robust;

pub use answer::{
    AxisRelation, CurrentPose, Miss, NoForceClosure, Recommendation, Verdict, IN_PLANE_TOLERANCE,
    NEAR_AXIS, ON_AXIS,
};
pub use candidate::Candidate;
pub use plane::{check_weight, sliced_friction};

use super::{InvalidInput, Settings};
use crate::planar::analysis::Analysis;
use crate::planar::frame::GraspFrame;
use plane::{Basis, Geometry, PlaneSolve};

/// Solves one spatial candidate: the orientation of least gripping power, as a 3D rotation, and
/// the planar answer in the grasp plane.
///
/// Bad input is an `Err` naming the field; a valid grasp that cannot be held is
/// `Ok(Verdict::NoForceClosure)`.
///
/// # Example
/// The paper's case (c) square (Table 1), stood up in the y-z plane of a frame whose gravity
/// points along -z: the best gravity direction is the planar one, `θ_34 = -π/12` (in Π), and the
/// rotation turns about ±x, the normal of the grasp plane.
/// ```
/// use grasp_orient_solver::{Settings, spatial};
/// use nalgebra::Vector3;
///
/// let grasp = spatial::Candidate {
///     contact_1: Vector3::new(0.0, 1.0, 1.0),
///     contact_2: Vector3::new(0.0, -1.0, 1.0),
///     normal_1: Vector3::new(0.0, -1.0, 0.0),
///     normal_2: Vector3::new(0.0, 1.0, 0.0),
///     friction_1: 3f64.sqrt(),
///     friction_2: 1.0 / 3f64.sqrt(),
///     center_of_mass: Vector3::zeros(),
///     mass: 1.0,
///     gravity: Vector3::new(0.0, 0.0, -1.0),
/// };
/// let Ok(spatial::Verdict::Recommended(r)) = spatial::solve(&grasp, &Settings::default()) else {
///     panic!("the grasp has force closure");
/// };
/// assert!((r.planar.gravity_angle.abs() - std::f64::consts::PI / 12.0).abs() < 1e-12);
/// assert!((r.rotation_angle - std::f64::consts::PI / 12.0).abs() < 1e-12);
/// assert!(r.rotation_axis.x.abs() > 1.0 - 1e-12);
/// assert!((r.planar.gripping_power - 1.0).abs() < 1e-12);
/// ```
#[doc(alias = "solve_spatial")]
pub fn solve(candidate: &Candidate, settings: &Settings) -> Result<Verdict, InvalidInput> {
    let geometry = Geometry::new(candidate, settings.friction_safety_factor)?;
    if geometry.offset <= ON_AXIS {
        return on_axis::solve(&geometry, settings);
    }
    let axis = if geometry.offset < NEAR_AXIS {
        AxisRelation::NearAxis
    } else {
        AxisRelation::OffAxis
    };
    let basis = Basis::through_center_of_mass(&geometry);
    let plane = match PlaneSolve::new(&geometry, &basis, geometry.planar_points(&basis)) {
        Ok(p) => p,
        Err(Ok(misses)) => return Ok(Verdict::NoForceClosure(misses)),
        Err(Err(invalid)) => return Err(invalid),
    };
    let planar = match plane.solve(settings)? {
        Ok(r) => r,
        Err(miss) => return Ok(Verdict::NoForceClosure(miss)),
    };
    let current_pose = match geometry.out_of_plane(&basis, geometry.in_plane_tolerance()) {
        Some(out_of_plane) => CurrentPose::Swings { out_of_plane },
        None => CurrentPose::Held,
    };
    Ok(Verdict::Recommended(Box::new(plane.assemble(
        planar,
        current_pose,
        axis,
    ))))
}

/// The gripping power over the whole graspable range of the grasp plane Π, for plots and studies:
/// the planar [`Analysis`] of the candidate the reduction solved in Π (module docs §3; friction
/// sliced by Π after the safety factor, powers in newtons, gravity angles in the paper frame of
/// Π), with the spatial answer. For a centre of mass on the contact axis Π is the plane the search
/// chose (§6).
///
/// Bad input is an `Err`; a valid grasp without force closure is `Ok(Err(_))`, as from
/// [`solve`].
#[allow(clippy::type_complexity)]
#[doc(alias = "analyse_spatial")]
pub fn analyse(
    candidate: &Candidate,
    settings: &Settings,
) -> Result<Result<(Analysis, Recommendation), NoForceClosure>, InvalidInput> {
    let r = match solve(candidate, settings)? {
        Verdict::Recommended(r) => r,
        Verdict::NoForceClosure(why) => return Ok(Err(why)),
    };
    // The sliced friction is already divided by the safety factor: the planar frame gets 1.
    let frame = GraspFrame::from_valid(&r.plane_candidate, 1.0);
    Ok(match Analysis::new(&frame, settings.objective) {
        Ok(analysis) => Ok((analysis, *r)),
        // Not reached: the planar solver held this very candidate a moment ago.
        Err(crate::planar::NoForceClosure { misses, .. }) => Err(NoForceClosure {
            misses: misses.into_iter().map(Miss::Cone).collect(),
            friction_safety_factor: settings.friction_safety_factor,
        }),
    })
}
