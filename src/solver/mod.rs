//! The exact gripping-power solver: pure math, SI units, no ROS, no I/O.
//!
//! # Conventions
//! - **Candidate frame**: the planar frame a grasp arrives in (x-y plane of the message's
//!   `header.frame_id`). Angles are counter-clockwise about +z, in radians.
//! - **Paper frame** (Ito et al., Sect. 2.2; `shared/problem.md`): origin at the centre of mass,
//!   x axis along the contact line from contact 2 to contact 1, y axis such that both contacts
//!   have the same `y >= 0`; contact 1 at `(x1, y)`, contact 2 at `(-x2, y)`. The frame is always
//!   right-handed: when the candidate's labelling would make it left-handed, the two contacts are
//!   relabelled internally and every answer is relabelled back.
//! - **Normals** point into the object. In the paper frame the inward normals are
//!   `(-sin φ1, -cos φ1)` and `(sin φ2, -cos φ2)`.
//! - **Gravity** points along `(sin θ, -cos θ)` in the paper frame; `θ` is the *gravity angle*,
//!   the orientation to choose. It is reported in the paper's own interval: the graspable range
//!   `[θ_min, θ_max]` of eqs. (8)–(10), which may reach past `-π` when the centre of mass does not
//!   lie between the contacts.
//! - **Friction**: Coulomb, half-angle of the cone `ξ = atan(μ)`. A safety factor `s >= 1`
//!   divides both coefficients before anything else (`s = 1` is the paper).
//! - **Contact forces** `(N1, F1, N2, F2)`: normal force along the inward normal, friction along
//!   the inward normal turned by +90° about +z, in the candidate's labelling. (The paper's own
//!   tangent at contact 1 points the other way; the conversion happens at the boundary.)
//! - **Units**: metres, kilograms, m/s², newtons. Inside, lengths are scaled by the contact
//!   distance and forces by `m |g|`, which makes the answer exactly invariant to units.
//!
//! # What is computed
//! For each θ the force-balance solutions form a line `F = F_T + α F_N` (Appendix A); the six
//! contact inequalities bound α from below by `α_min(θ)`, the upper envelope of sinusoids. The
//! objective (gripping power) is `P(θ) = min ||F_T + α F_N||` over feasible α. The recommendation
//! is the exact minimiser of `P` over the allowed range, found from the envelope's breakpoints and
//! the closed-form stationary points of each piece.
//!
//! When the centre of mass and the mass are known only to within tolerances, [`solve_robust`]
//! minimises the worst case of `P` over them instead (issue 13; the mathematics is in
//! `src/solver/robust.rs`).

mod analysis;
mod finger;
mod frame;
mod paper;
mod robust;
mod sinusoid;
mod spatial;

pub use analysis::{Analysis, PointValue};
pub use frame::{MAX_COORDINATE, MAX_SAFETY_FACTOR};
pub use paper::CandidateAngles;
pub use robust::{
    solve_robust, BoxPoint, BoxPointKind, NoCommonOrientation, RobustRecommendation, RobustVerdict,
    Uncertainty,
};
pub use spatial::{
    analyse_spatial, sliced_friction, solve_spatial, solve_spatial_robust, AxisRelation,
    CurrentPose, RegionPoint, RegionPointKind, SpatialCandidate, SpatialMiss,
    SpatialNoCommonOrientation, SpatialNoForceClosure, SpatialRecommendation,
    SpatialRobustRecommendation, SpatialRobustVerdict, SpatialUncertainty, SpatialVerdict,
    IN_PLANE_TOLERANCE, NEAR_AXIS, ON_AXIS,
};

use frame::GraspFrame;

#[cfg(test)]
pub(crate) mod table_1 {
    //! The paper's Table 1, the same fixture the integration tests use.
    use super::Candidate;
    include!("../../tests/common/table_1.rs");
}

use nalgebra::Vector2;
use std::fmt;

/// A two-finger planar grasp in the candidate's own frame. SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Contact point 1, m.
    pub contact_1: Vector2<f64>,
    /// Contact point 2, m.
    pub contact_2: Vector2<f64>,
    /// Surface normal at contact 1, pointing into the object; any length > 0.
    pub normal_1: Vector2<f64>,
    /// Surface normal at contact 2, pointing into the object; any length > 0.
    pub normal_2: Vector2<f64>,
    /// Coulomb friction coefficient at contact 1, > 0.
    pub friction_1: f64,
    /// Coulomb friction coefficient at contact 2, > 0.
    pub friction_2: f64,
    /// Centre of mass, m.
    pub center_of_mass: Vector2<f64>,
    /// Mass, kg, > 0.
    pub mass: f64,
    /// Gravitational acceleration at the current pose, m/s².
    pub gravity: Vector2<f64>,
}

/// What the solver minimises over the feasible contact forces at each orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Objective {
    /// Euclidean norm of `(N1, F1, N2, F2)`, N (the paper's figures).
    #[default]
    Norm2,
    /// Sum of absolute values of `(N1, F1, N2, F2)`, N.
    Norm1,
    /// The squeeze force each finger adds along the contact line, N.
    InternalForce,
}

impl Objective {
    /// The name used in configuration files and messages.
    pub fn name(&self) -> &'static str {
        match self {
            Objective::Norm2 => "norm2",
            Objective::Norm1 => "norm1",
            Objective::InternalForce => "internal_force",
        }
    }

    /// Parses a name as written by [`Objective::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "norm2" => Some(Objective::Norm2),
            "norm1" => Some(Objective::Norm1),
            "internal_force" => Some(Objective::InternalForce),
            _ => None,
        }
    }
}

/// The gravity angles the recommendation may take.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AllowedRange {
    /// The object hangs below the fingers: the upward vertical through the centre of mass meets
    /// the segment between the contacts. `[-atan2(x1, y), atan2(x2, y)]`, closed.
    #[default]
    FromAbove,
    /// The paper's whole graspable range (8), closed.
    Graspable,
    /// Explicit gravity-angle bounds in the paper frame, rad; intersected with the graspable range.
    Bounds {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
    },
}

/// How to solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// What to minimise.
    pub objective: Objective,
    /// Where the recommendation may lie.
    pub range: AllowedRange,
    /// Divides both friction coefficients, >= 1 (1 = the paper).
    pub friction_safety_factor: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            objective: Objective::default(),
            range: AllowedRange::default(),
            friction_safety_factor: 1.0,
        }
    }
}

/// Which contact, in the candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// `contact_1`.
    First,
    /// `contact_2`.
    Second,
}

impl Contact {
    /// The other contact.
    pub fn other(self) -> Contact {
        match self {
            Contact::First => Contact::Second,
            Contact::Second => Contact::First,
        }
    }
}

impl fmt::Display for Contact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Contact::First => "contact_1",
            Contact::Second => "contact_2",
        })
    }
}

/// Input the solver refuses, naming the field at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidInput {
    /// A field is NaN or infinite.
    #[error("{field} is not a finite number")]
    NotFinite {
        /// The field.
        field: &'static str,
    },
    /// A field must be strictly positive.
    #[error("{field} must be greater than zero, got {value}")]
    NotPositive {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A field's magnitude is beyond what the solver accepts.
    #[error("{field} is out of range: {value:e} exceeds {limit:e}{unit} in magnitude")]
    OutOfRange {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// Largest accepted magnitude.
        limit: f64,
        /// Unit of the limit, with its leading space (empty for none).
        unit: &'static str,
    },
    /// A field is below the smallest value the solver accepts.
    #[error("{field} is out of range: {value:e} is below the smallest accepted {minimum:e}")]
    BelowMinimum {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// Smallest accepted value.
        minimum: f64,
    },
    /// The weight `mass × |gravity|` (in-plane gravity) is too small to compute forces with.
    #[error("mass and gravity give a weight of {weight:e} N, below the smallest the forces can be computed for ({:e} N)", frame::MIN_WEIGHT)]
    WeightTooSmall {
        /// `mass × |gravity|`, N.
        weight: f64,
    },
    /// A vector has no component in the grasp plane.
    #[error("{field} has no component in the x-y plane")]
    ZeroInPlane {
        /// The field.
        field: &'static str,
    },
    /// The two contacts are the same point.
    #[error("contact_1 and contact_2 coincide")]
    CoincidentContacts,
    /// A normal points out of the object (away from the other contact).
    #[error("normal_{} does not point into the object: it points away from {}", contact_number(*.contact), .contact.other())]
    NormalOutward {
        /// The contact whose normal is wrong.
        contact: Contact,
    },
    /// The centre of mass lies outside the convex object.
    #[error("center_of_mass lies outside the object: behind the surface tangent at {contact}")]
    CenterOfMassOutside {
        /// The contact whose tangent line separates it.
        contact: Contact,
    },
    /// The friction safety factor is not in `[1, MAX_SAFETY_FACTOR]`.
    #[error(
        "friction safety factor must be in [1, {:e}], got {value}",
        frame::MAX_SAFETY_FACTOR
    )]
    SafetyFactor {
        /// The value given.
        value: f64,
    },
    /// Explicit range bounds are not an interval.
    #[error("range bounds must be finite with lo < hi, got [{lo}, {hi}]")]
    RangeBounds {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
    },
    /// Explicit range bounds miss the graspable range of this grasp.
    #[error("the allowed range [{lo:.6}, {hi:.6}] rad does not meet this grasp's graspable range [{graspable_lo:.6}, {graspable_hi:.6}] rad")]
    RangeOutsideGraspable {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
        /// Graspable range start, rad.
        graspable_lo: f64,
        /// Graspable range end, rad.
        graspable_hi: f64,
    },
    /// A tolerance (centre of mass, mass) is negative or too large.
    #[error("{field} must be at least 0 and less than {limit:e}{unit}, got {value:e}")]
    Tolerance {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The least value refused.
        limit: f64,
        /// Unit of the limit, with its leading space.
        unit: &'static str,
    },
    /// A vector that must have a direction is zero (spatial candidates).
    #[error("{field} is the zero vector")]
    ZeroVector {
        /// The field.
        field: &'static str,
    },
    /// A normal is perpendicular to the grasp plane through both contacts and the centre of mass,
    /// so its projection into that plane, the planar normal, has no direction (spatial candidates).
    #[error(
        "{field} is perpendicular to the grasp plane through both contacts and the centre of mass"
    )]
    NormalPerpendicularToGraspPlane {
        /// The field.
        field: &'static str,
    },
    /// The centre of mass is at a contact point (spatial candidates).
    #[error("center_of_mass coincides with {contact}")]
    CenterOfMassAtContact {
        /// The contact.
        contact: Contact,
    },
    /// The 1-norm objective with a centre-of-mass tolerance on a spatial candidate: each object
    /// hangs in its own plane and the 1-norm depends on that plane's split of the forces, so the
    /// worst case is not found on the region's edges (`src/solver/spatial/robust/mod.rs`).
    #[error(
        "objective norm1 with a center_of_mass_tolerance is not supported for spatial candidates; \
         use norm2 or internal_force"
    )]
    Norm1SpatialTolerance,
}

fn contact_number(c: Contact) -> u8 {
    match c {
        Contact::First => 1,
        Contact::Second => 2,
    }
}

/// One friction cone that misses the other contact (no force closure, eq. 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeMiss {
    /// The contact whose cone misses, in the candidate's labelling.
    pub contact: Contact,
    /// Half-angle of its cone after the safety factor, rad.
    pub half_angle: f64,
    /// Angle between its inward normal and the direction to the other contact, rad.
    pub angle_to_other: f64,
}

/// Why a grasp has no force closure: one or both cones miss the other contact.
#[derive(Debug, Clone, PartialEq)]
pub struct NoForceClosure {
    /// The cones that miss (one or two).
    pub misses: Vec<ConeMiss>,
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
            write!(
                f,
                "the friction cone at {} (half-angle {:.4} rad) misses {} by {:.4} rad",
                m.contact,
                m.half_angle,
                m.contact.other(),
                m.angle_to_other - m.half_angle
            )?;
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

/// Theorem 1's classification by which friction cones contain the centre of mass, in the
/// candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GraspCase {
    /// (a) both cones contain the centre of mass.
    A,
    /// (b) the cone at contact 1 contains it, the other does not.
    B,
    /// (c) the cone at contact 2 contains it, the other does not.
    C,
    /// (d) neither cone contains it.
    D,
}

impl GraspCase {
    /// `"a"` .. `"d"`.
    pub fn name(&self) -> &'static str {
        match self {
            GraspCase::A => "a",
            GraspCase::B => "b",
            GraspCase::C => "c",
            GraspCase::D => "d",
        }
    }
}

/// The paper's five candidate orientations (Theorem 1), in the candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperCandidate {
    /// Centre of mass above contact 2 (`θ_min`).
    A,
    /// Centre of mass and `p_ul` on one vertical (`θ_36`).
    B,
    /// Centre of mass below `p_uu` (`θ_34`), the paper's "meaningful" minimum.
    C,
    /// Centre of mass and `p_lu` on one vertical (`θ_45`).
    D,
    /// Centre of mass above contact 1 (`θ_max`).
    E,
}

impl PaperCandidate {
    /// `"A"` .. `"E"`.
    pub fn name(&self) -> &'static str {
        match self {
            PaperCandidate::A => "A",
            PaperCandidate::B => "B",
            PaperCandidate::C => "C",
            PaperCandidate::D => "D",
            PaperCandidate::E => "E",
        }
    }

    /// The same geometric candidate with the two contacts' labels exchanged.
    pub fn relabelled(self) -> Self {
        match self {
            PaperCandidate::A => PaperCandidate::E,
            PaperCandidate::B => PaperCandidate::D,
            PaperCandidate::C => PaperCandidate::C,
            PaperCandidate::D => PaperCandidate::B,
            PaperCandidate::E => PaperCandidate::A,
        }
    }
}

/// What became of the paper's candidate C (`θ_34`) for one grasp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CandidateC {
    /// Theorem 1 holds: `θ_34` is the recommendation.
    Recommended = 0,
    /// The objective passes through `θ_34` without a local minimum (Theorem 1 is wrong here).
    NotAMinimum = 1,
    /// `θ_34` is a local minimum, but another point of the allowed range is lower.
    Beaten = 2,
    /// `θ_34` lies outside the allowed range.
    OutOfRange = 3,
}

/// One local minimum of the objective over the graspable range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalMinimum {
    /// Gravity angle, rad (paper frame).
    pub gravity_angle: f64,
    /// Objective value there, N.
    pub power: f64,
    /// The paper's candidate it coincides with, if any (candidate's labelling).
    pub label: Option<PaperCandidate>,
}

/// The answer for a grasp with force closure.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    /// The objective minimised.
    pub objective: Objective,
    /// Recommended gravity angle θ, rad, paper frame.
    pub gravity_angle: f64,
    /// Rotation of the object about +z of the candidate frame, rad in (-π, π], that takes the
    /// current pose to the recommended one.
    pub wrist_rotation: f64,
    /// Unit vector: where gravity points in the candidate frame after that rotation.
    pub gravity_direction: Vector2<f64>,
    /// Objective value at the recommendation, N.
    pub gripping_power: f64,
    /// Squeeze force each finger adds along the contact line there, N.
    pub internal_force: f64,
    /// `(N1, F1, N2, F2)` there, N, candidate's labelling (module conventions).
    pub contact_forces: [f64; 4],
    /// Objective value at the current pose, N.
    pub gripping_power_current: f64,
    /// Squeeze force needed at the current pose, N.
    pub internal_force_current: f64,
    /// Gravity angle of the current pose, rad, paper frame.
    pub current_gravity_angle: f64,
    /// Theorem 1's case.
    pub grasp_case: GraspCase,
    /// Every local minimum of the objective over the graspable range, in increasing angle.
    pub local_minima: Vec<LocalMinimum>,
    /// The paper's candidate the recommendation coincides with, if any.
    pub recommended_label: Option<PaperCandidate>,
    /// What became of candidate C.
    pub candidate_c: CandidateC,
    /// The larger push along the contact line that either finger gives at the recommendation, N:
    /// `internal_force + |W_line|/2`, with `W_line` the weight's component along the line. What
    /// each independently driven finger must give (coupled fingers give `internal_force`; the
    /// derivation is in `finger.rs`).
    pub finger_force: f64,
    /// The same at the current pose, N.
    pub finger_force_current: f64,
}

/// The solver's verdict on valid input.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The grasp can be held: here is the best orientation.
    Recommended(Box<Recommendation>),
    /// No orientation can hold the grasp.
    NoForceClosure(NoForceClosure),
}

/// Solves one candidate: the orientation of least gripping power and the forces it needs.
///
/// Bad input is an `Err`; a valid grasp that cannot be held is `Ok(Verdict::NoForceClosure)`.
///
/// # Example
/// The paper's case study (c) (Table 1): a square held at the middle of two opposite sides,
/// friction √3 and 1/√3, `Mg = 1`. The least gripping power is at candidate C,
/// `θ_34 = -π/12` (Table 2 prints +0.261: its sign is wrong, see `tests/paper.rs`).
/// ```
/// use grasp_orient::solver::{solve_orientation, Candidate, PaperCandidate, Settings, Verdict};
/// use nalgebra::Vector2;
///
/// let grasp = Candidate {
///     contact_1: Vector2::new(1.0, 1.0),
///     contact_2: Vector2::new(-1.0, 1.0),
///     normal_1: Vector2::new(-1.0, 0.0),
///     normal_2: Vector2::new(1.0, 0.0),
///     friction_1: 3f64.sqrt(),
///     friction_2: 1.0 / 3f64.sqrt(),
///     center_of_mass: Vector2::zeros(),
///     mass: 1.0,
///     gravity: Vector2::new(0.0, -1.0),
/// };
/// let Ok(Verdict::Recommended(r)) = solve_orientation(&grasp, &Settings::default()) else {
///     panic!("the grasp has force closure");
/// };
/// assert!((r.gravity_angle + std::f64::consts::PI / 12.0).abs() < 1e-12);
/// assert_eq!(r.recommended_label, Some(PaperCandidate::C));
/// assert!((r.gripping_power - 1.0).abs() < 1e-12); // P = Mg here
/// ```
pub fn solve_orientation(
    candidate: &Candidate,
    settings: &Settings,
) -> Result<Verdict, InvalidInput> {
    // `analyse`, without the Result around its Result: the analysis is not moved once more.
    let frame = GraspFrame::new(candidate, settings.friction_safety_factor)?;
    match Analysis::new(&frame, settings.objective) {
        Ok(analysis) => Ok(Verdict::Recommended(Box::new(
            analysis.recommend(&settings.range)?,
        ))),
        Err(miss) => Ok(Verdict::NoForceClosure(miss)),
    }
}

/// The gripping power of one grasp over its whole graspable range, for plots and studies: what
/// [`solve_orientation`] minimises, with the paper's bounds and candidate angles. Uses the
/// objective and friction safety factor of `settings` (the range only matters to
/// [`Analysis::recommend`]).
///
/// Bad input is an `Err`; a valid grasp without force closure is `Ok(Err(NoForceClosure))`.
pub fn analyse(
    candidate: &Candidate,
    settings: &Settings,
) -> Result<Result<Analysis, NoForceClosure>, InvalidInput> {
    let frame = GraspFrame::new(candidate, settings.friction_safety_factor)?;
    Ok(Analysis::new(&frame, settings.objective))
}
