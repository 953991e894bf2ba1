//! Why a pose candidate is refused before it is solved ([`PoseRefusal`], [`Refused`]), and the limits it is held to.

use crate::msg::GripRecommendation;
use crate::solver::{InvalidInput, Readable, MAX_COORDINATE};
use grasp_orient_geometry::GeometryError;
use std::fmt::{self, Display};

/// The largest opening accepted, m: the solver's coordinate limit ([`MAX_COORDINATE`]), since
/// the fingers start `width / 2` from the tool frame's origin. Beyond it the contacts, computed
/// from finger starts `width / 2` away, would have lost every digit of the object's size (an
/// opening of 1e300 m made both contacts the same point).
pub(super) const MAX_WIDTH: f64 = MAX_COORDINATE;
/// The smallest scale factor accepted on a mesh's axis: from nanometres to metres. Below it the
/// mesh shrinks towards a point, and its faces' normals are lost to underflow (a scale of 1e-100
/// made the contact normals NaN).
pub(super) const MIN_SCALE: f64 = 1e-9;
/// The largest scale factor accepted on a mesh's axis. Above it the vertices leave the solver's
/// coordinate limit for any mesh unit in use, and reach infinity from single-precision files.
pub(super) const MAX_SCALE: f64 = 1e9;
/// A finger starting inside a mesh that is, along the closing line, between these many times
/// wider than the opening: the refusal adds a hint that the mesh may be in millimetres without a
/// scale. A mesh in millimetres read as metres is 1000 times too large, so an object from 0.3 to
/// 1000 times the opening in truth (a gripper rarely closes on one more than 300 times its
/// opening) lands here; beyond the upper end it is the opening that is wrong, not the units.
pub(super) const UNITS_HINT_RATIO: std::ops::RangeInclusive<f64> = 300.0..=1e6;

/// What is wrong with one number of a pose candidate (the solver's words for the same faults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum NumberFault {
    /// NaN or infinite.
    NotFinite,
    /// Larger in magnitude than `limit` (with its unit, leading space included).
    Above {
        /// The value.
        value: f64,
        /// The largest accepted magnitude.
        limit: f64,
        /// Its unit, with its leading space.
        unit: &'static str,
    },
    /// Below `minimum`.
    Below {
        /// The value.
        value: f64,
        /// The smallest accepted value.
        minimum: f64,
    },
}

impl Display for NumberFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            NumberFault::NotFinite => f.write_str("is not a finite number"),
            NumberFault::Above { value, limit, unit } => write!(
                f,
                "is out of range: {value:e} exceeds {limit:e}{unit} in magnitude"
            ),
            NumberFault::Below { value, minimum } => write!(
                f,
                "is out of range: {value:e} is below the smallest accepted {minimum:e}"
            ),
        }
    }
}

/// Why a pose candidate cannot be turned into a grasp.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum PoseRefusal {
    /// The geometry's refusal: status 1 for a finger that closes on nothing, 2 otherwise.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// Not exactly one of `mesh`, `inline_mesh` and `primitive` is given.
    #[error("object: give exactly one shape (mesh, inline_mesh or primitive), got {given}")]
    Shapes {
        /// The shapes given, by field name (empty for none).
        given: String,
    },
    /// A primitive with a scale other than 1.
    #[error(
        "object.scale must be 1 on every axis for a primitive (its dimensions are metres), got \
         [{}, {}, {}]", Readable(.scale[0]), Readable(.scale[1]), Readable(.scale[2])
    )]
    PrimitiveScale {
        /// The scale given.
        scale: [f64; 3],
    },
    /// A quaternion that is no rotation.
    #[error("{field} is not a rotation: its norm is {norm}")]
    Orientation {
        /// `grasp_pose.orientation`, `object.pose.orientation`, `poses[i].grasp_pose.orientation`.
        field: String,
        /// Its norm.
        norm: f64,
    },
    /// A number of the pose candidate out of its domain, named by its path in the message
    /// (`grasp_pose.position.x`, `poses[2].width`, `object.scale.y`, …).
    #[error("{field} {fault}")]
    Number {
        /// The field's path.
        field: String,
        /// What is wrong with it.
        fault: NumberFault,
    },
    /// A number the solver refuses, named by the pose candidate's field it comes from
    /// (`object.friction`, which is both contacts' friction; `object.mass`).
    #[error(transparent)]
    Solver(#[from] InvalidInput),
    /// A finger starts inside a mesh that is many times wider than the opening along the closing
    /// line: the geometry's refusal, with a hint about the mesh's units.
    #[error(
        "{source}: the mesh is {} times wider than the opening along the closing line: is it in \
         millimetres? {}",
        Rounded(*.ratio),
        if *.unit_scale { "set object.scale to 0.001" } else { "check object.scale" }
    )]
    StartsInsideUnits {
        /// The geometry's refusal ([`GeometryError::StartsInside`]).
        source: GeometryError,
        /// The mesh's extent along the closing line over the opening.
        ratio: f64,
        /// Whether `object.scale` is 1 on every axis.
        unit_scale: bool,
    },
    /// An inline mesh of more triangles than `max_inline_mesh_triangles`, refused before it is
    /// indexed. No count in the words: the node decodes no more than the bound and one more
    /// (`msg::limit_inline_mesh_decoding`), so it does not know the count of a larger mesh.
    #[error(
        "object.inline_mesh has more triangles than max_inline_mesh_triangles ({max}); send a \
         coarser mesh"
    )]
    InlineTriangles {
        /// `max_inline_mesh_triangles`.
        max: usize,
    },
    /// An inline mesh of more vertices than three per allowed triangle (a triangle soup has
    /// three; more are vertices no triangle uses, held all the same).
    #[error(
        "object.inline_mesh has more vertices than 3 x max_inline_mesh_triangles ({max_vertices})"
    )]
    InlineVertices {
        /// Three times `max_inline_mesh_triangles`.
        max_vertices: usize,
    },
    /// `center_of_mass` given without `has_center_of_mass`.
    #[error(
        "object.center_of_mass is given but object.has_center_of_mass is false: set it true, or \
         leave center_of_mass at zero for the shape's centroid"
    )]
    CenterOfMassFlag,
    /// The object's pose given in a frame of its own, where no TF turns it into the header
    /// frame (anything but the node).
    #[error(
        "object.frame_id is \"{frame}\": only the node turns an object pose from another frame \
         into the header frame, by TF; here give object.pose in the header frame and leave \
         frame_id empty"
    )]
    ObjectFrame {
        /// The frame given.
        frame: String,
    },
}

/// A ratio to about three significant digits, as a plain number (`1000`, `2500`, `15000`).
struct Rounded(f64);

impl Display for Rounded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.0;
        if !(r.is_finite() && r >= 1.0) {
            return write!(f, "{r:e}");
        }
        let digits = r.log10().floor() as i32;
        let step = 10f64.powi((digits - 2).max(0));
        let rounded = (r / step).round() * step;
        if rounded < 1e16 {
            write!(f, "{rounded:.0}")
        } else {
            write!(f, "{rounded:e}")
        }
    }
}

impl PoseRefusal {
    /// The status of the answer: 1 when a finger closes on nothing, 2 otherwise.
    pub(crate) fn status(&self) -> u8 {
        match self {
            PoseRefusal::Geometry(e) => e.status(),
            _ => GripRecommendation::STATUS_INVALID_INPUT,
        }
    }
}

/// A refusal as an answer gives it: its status and words (the geometry's errors hold an
/// `io::Error`, which does not clone, and a set's object refused is every pose's refusal).
#[derive(Debug, Clone)]
pub(crate) struct Refused {
    /// The answer's status.
    pub(crate) status: u8,
    /// Its message.
    pub(crate) message: String,
}

impl From<PoseRefusal> for Refused {
    fn from(e: PoseRefusal) -> Self {
        Refused {
            status: e.status(),
            message: e.to_string(),
        }
    }
}
