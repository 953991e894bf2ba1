//! The exact gripping-power solver: pure math, SI units, no ROS, no I/O.
//!
//! # Conventions
//! - **Candidate frame**: the planar frame a grasp arrives in (x-y plane of the message's
//!   `header.frame_id`). Angles are counter-clockwise about +z, in radians.
//! - **Paper frame** (Ito et al., Sect. 2.2; `docs/theory.md`): origin at the centre of mass,
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
//! When the centre of mass and the mass are known only to within tolerances, [`planar::robust::solve`]
//! minimises the worst case of `P` over them instead (the mathematics is in
//! `planar/robust/mod.rs` and `docs/theory.md`).
//!
//! # Modules
//! [`planar`] answers a grasp in a plane ([`planar::solve`], [`planar::analyse`]) and [`spatial`]
//! one in 3D ([`spatial::solve`], [`spatial::analyse`]); each has a `robust` module for the worst
//! case over tolerances ([`planar::robust::solve`], [`spatial::robust::solve`]). The two mirror
//! each other: `Candidate`, `Recommendation`, `Verdict`, `NoForceClosure` in each, named by their
//! module. The root holds only what both share: [`Settings`], [`Objective`], [`AllowedRange`],
//! [`Contact`], [`InvalidInput`] and the input limits.

pub mod planar;
mod sinusoid;
pub mod spatial;
pub mod table_1;

/// The README's example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExample;

/// Scaling by a power of two, exact: what the checks use to take lengths scale-free.
pub use planar::frame::times_pow2;
pub use planar::frame::{
    check_friction, check_mass, BEHIND_TANGENT, MAX_COORDINATE, MAX_FRICTION, MAX_GRAVITY,
    MAX_MASS, MAX_SAFETY_FACTOR, MIN_FRICTION, MIN_WEIGHT, SQUARE_SAFE,
};

use std::fmt;

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

    /// Every name, in the order the documentation lists them.
    pub const NAMES: [&'static str; 3] = ["norm2", "norm1", "internal_force"];
}

impl fmt::Display for Objective {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not one of [`Objective::NAMES`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given:?} is not one of {}", Objective::NAMES.join(", "))]
#[non_exhaustive]
pub struct UnknownObjective {
    /// What was given.
    pub given: String,
}

impl std::str::FromStr for Objective {
    type Err = UnknownObjective;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Objective::from_name(s).ok_or_else(|| UnknownObjective {
            given: s.to_string(),
        })
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
    #[error("{field} must be greater than zero, got {}", Readable(*.value))]
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
    #[error("{mass} and gravity give a weight of {weight:e} N, below the smallest the forces can be computed for ({:e} N)", planar::frame::MIN_WEIGHT)]
    WeightTooSmall {
        /// The field of the mass (`mass`; `object.mass` for a pose candidate).
        mass: &'static str,
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
    /// The friction safety factor is not in `[1, MAX_SAFETY_FACTOR]`.
    #[error(
        "friction safety factor must be in [1, {:e}], got {value}",
        planar::frame::MAX_SAFETY_FACTOR
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
    /// worst case is not found on the region's edges (`crates/solver/src/spatial/robust/mod.rs`).
    #[error(
        "objective norm1 with a center_of_mass_tolerance is not supported for spatial candidates; \
         use norm2 or internal_force"
    )]
    Norm1SpatialTolerance,
}

/// A value as a refusal states it: plainly from 1e-5 up to 1e16 (`-1`, `0.25`, as before), in
/// scientific notation outside (`-1e-300`, not three hundred zeros).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readable(pub f64);

impl fmt::Display for Readable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let magnitude = self.0.abs();
        if magnitude == 0.0 || !magnitude.is_finite() || (1e-5..1e16).contains(&magnitude) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

fn contact_number(c: Contact) -> u8 {
    match c {
        Contact::First => 1,
        Contact::Second => 2,
    }
}
