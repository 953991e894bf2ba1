//! Input the solver refuses: each refusal names the field at fault and the limit it breaks.

use crate::contact::Contact;
use std::fmt;

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
    #[error("{mass} and gravity give a weight of {weight:e} N, below the smallest the forces can be computed for ({:e} N)", crate::limits::MIN_WEIGHT)]
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
        crate::limits::MAX_SAFETY_FACTOR
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
