//! The one error type of the crate.

use std::fmt;
use std::path::PathBuf;

/// Which finger: finger 1 starts on the `−` side of the closing axis, finger 2 on the `+` side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Finger {
    /// Starts at `centre − (width/2)·b`, moves along `+b`.
    One,
    /// Starts at `centre + (width/2)·b`, moves along `−b`.
    Two,
}

impl Finger {
    /// Both fingers, in order.
    pub const BOTH: [Finger; 2] = [Finger::One, Finger::Two];

    /// 1 or 2.
    pub fn number(self) -> u8 {
        match self {
            Finger::One => 1,
            Finger::Two => 2,
        }
    }
}

impl fmt::Display for Finger {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// What is wrong with a mesh's topology, found by its closedness check
/// ([`crate::mesh::check_closed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MeshDefect {
    /// An edge belongs to a number of triangles other than two (1: a hole's border; 3 or more:
    /// non-manifold). Vertex indices are after merging vertices at identical positions.
    EdgeUse {
        /// The edge's two vertices.
        edge: [u32; 2],
        /// How many triangles hold it.
        triangles: usize,
    },
    /// An edge runs the same way in both of its triangles: the triangles are not consistently
    /// oriented.
    Orientation {
        /// The edge, as it runs in both triangles.
        edge: [u32; 2],
    },
    /// The mesh is closed but encloses no volume.
    ZeroVolume,
}

impl fmt::Display for MeshDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshDefect::EdgeUse { edge, triangles } => write!(
                f,
                "it is open or non-manifold: edge ({}, {}) belongs to {triangles} triangle{} instead of 2",
                edge[0],
                edge[1],
                if *triangles == 1 { "" } else { "s" }
            ),
            MeshDefect::Orientation { edge } => write!(
                f,
                "its triangles are not consistently oriented: edge ({}, {}) runs the same way in two triangles",
                edge[0], edge[1]
            ),
            MeshDefect::ZeroVolume => write!(f, "it encloses no volume"),
        }
    }
}

/// Everything this crate refuses, each naming the resource and what is wrong with it.
///
/// [`GeometryError::status`] maps them to the product's statuses: 1 for a finger that closes on
/// nothing (the answer is no), 2 for everything else (the input is wrong).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// The resource names a scheme other than `package://`, `file://` or none.
    #[error(
        "mesh resource {}: unsupported scheme (use package://, file:// or a path)",
        abbreviate(resource)
    )]
    UnsupportedScheme {
        /// The resource as given.
        resource: String,
    },
    /// `package://` with an invalid package name (ament's rule: `[a-zA-Z0-9][a-zA-Z0-9_-]+`).
    #[error(
        "mesh resource {}: {package:?} is not a valid package name",
        abbreviate(resource)
    )]
    InvalidPackageName {
        /// The resource as given.
        resource: String,
        /// The package part.
        package: String,
    },
    /// No prefix of `AMENT_PREFIX_PATH` has the package in its ament index.
    #[error(
        "mesh resource {}: package {package:?} not found in the ament index of {searched:?}",
        abbreviate(resource)
    )]
    PackageNotFound {
        /// The resource as given.
        resource: String,
        /// The package part.
        package: String,
        /// The prefixes searched.
        searched: Vec<PathBuf>,
    },
    /// The file could not be read.
    #[error(
        "mesh resource {}: cannot read {path:?}: {source}",
        abbreviate(resource)
    )]
    Unreadable {
        /// The resource as given.
        resource: String,
        /// Where it resolved to.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The resource string is longer than [`MAX_RESOURCE_BYTES`]; refused before anything
    /// else, and printed abbreviated.
    #[error(
        "mesh resource {}: longer than {MAX_RESOURCE_BYTES} bytes",
        abbreviate(resource)
    )]
    ResourceTooLong {
        /// The resource as given.
        resource: String,
    },
    /// Under a confined access ([`crate::load::Access::confined`], the node's): the file is not
    /// under the mesh roots (nor, for `package://`, inside its package's share directory), or
    /// cannot be opened, or is not a regular file, or its package is not found. One message for
    /// every cause, so that a refusal tells nothing of the host's files.
    #[error(
        "mesh resource {}: not under mesh_roots or not readable",
        abbreviate(resource)
    )]
    NotReadable {
        /// The resource as given.
        resource: String,
    },
    /// Under a local access (the command line's): the file is a FIFO, a device, a directory or a
    /// socket, which is refused at once rather than read.
    #[error(
        "mesh resource {}: {path:?} is not a regular file",
        abbreviate(resource)
    )]
    NotRegularFile {
        /// The resource as given.
        resource: String,
        /// Where it resolved to.
        path: PathBuf,
    },
    /// The file holds more than the most bytes a mesh file may have.
    #[error("mesh resource {}: the file holds more than {max} bytes, the most a mesh file may hold (max_mesh_file_bytes)", abbreviate(resource))]
    FileTooLarge {
        /// The resource as given.
        resource: String,
        /// The bound, bytes.
        max: u64,
    },
    /// The file name does not end in `.stl`, `.obj` or `.dae`.
    #[error(
        "mesh resource {}: unknown mesh format (expected .stl, .obj or .dae)",
        abbreviate(resource)
    )]
    UnknownFormat {
        /// The resource as given.
        resource: String,
    },
    /// The file could not be parsed as its format.
    #[error(
        "mesh resource {}: cannot parse {path:?}: {source}",
        abbreviate(resource)
    )]
    Unparsable {
        /// The resource as given.
        resource: String,
        /// Where it resolved to.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The mesh has no triangle (or only degenerate ones, after merging identical vertices).
    #[error("mesh {}: has no triangle", abbreviate(resource))]
    EmptyMesh {
        /// The resource, or the name of an inline mesh.
        resource: String,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "mesh {}: triangle {triangle} refers to vertex {index}, but there are {vertices} vertices",
        abbreviate(resource)
    )]
    VertexIndex {
        /// The resource, or the name of an inline mesh.
        resource: String,
        /// The triangle's index.
        triangle: usize,
        /// The index it gives.
        index: u32,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A vertex coordinate is NaN or infinite (after scaling).
    #[error("mesh {}: vertex {vertex} is not finite", abbreviate(resource))]
    NonFiniteVertex {
        /// The resource, or the name of an inline mesh.
        resource: String,
        /// The vertex's index.
        vertex: usize,
    },
    /// A scale factor is zero, negative or not finite.
    #[error(
        "mesh {}: scale {scale:?} must be finite and greater than zero on every axis",
        abbreviate(resource)
    )]
    BadScale {
        /// The resource, or the name of an inline mesh.
        resource: String,
        /// The scale given.
        scale: [f64; 3],
    },
    /// A centre of mass was needed from an open, non-manifold, inconsistently oriented or flat
    /// mesh, and none was given.
    #[error(
        "mesh {}: no centre of mass given and none can be computed, because {defect}",
        abbreviate(resource)
    )]
    NotClosed {
        /// The resource, or the name of an inline mesh.
        resource: String,
        /// What is wrong with it.
        defect: MeshDefect,
    },
    /// A `shape_msgs/SolidPrimitive` type this crate does not know (PRISM = 5 included).
    #[error("solid primitive: unknown or unsupported type {type_number} (box = 1, sphere = 2, cylinder = 3, cone = 4)")]
    UnknownPrimitive {
        /// The `type` field.
        type_number: u8,
    },
    /// The dimensions do not fit the primitive: wrong count, or a value not finite and positive.
    #[error("solid primitive {kind}: dimensions {given:?} are wrong: expected {expected}")]
    PrimitiveDimensions {
        /// "box", "sphere", "cylinder" or "cone".
        kind: &'static str,
        /// The dimensions given.
        given: Vec<f64>,
        /// What was expected.
        expected: &'static str,
    },
    /// A pose, width or given centre of mass is NaN or infinite, or the width is not positive.
    #[error("{field} must be finite{}", if *positive { " and greater than zero" } else { "" })]
    BadNumber {
        /// Which input.
        field: &'static str,
        /// Whether it must also be positive.
        positive: bool,
    },
    /// The finger's path to the other finger's start meets no surface.
    #[error("finger {finger} closes on nothing")]
    ClosesOnNothing {
        /// Which finger.
        finger: Finger,
    },
    /// The finger starts inside the object: the opening is narrower than the object along the
    /// closing line.
    #[error("finger {finger} starts inside the object {}: the opening is narrower than the object along the closing line", abbreviate(resource))]
    StartsInside {
        /// Which finger.
        finger: Finger,
        /// The object's resource or primitive.
        resource: String,
    },
    /// The file's bytes are malformed for its format in a way that is refused before (or
    /// contained while) it is parsed: elements nested too deep, a count beyond the values held,
    /// an index past its source, or a structure the parser fails on.
    #[error("mesh resource {resource:?}: the file is malformed: {reason}")]
    MalformedMesh {
        /// The resource as given.
        resource: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A COLLADA file's `<unit meter>` is not a finite number greater than zero.
    #[error("mesh resource {resource:?}: COLLADA <unit meter={unit:?}> must be a finite number of metres greater than zero")]
    BadUnit {
        /// The resource as given.
        resource: String,
        /// The unit as written.
        unit: String,
    },
}

impl GeometryError {
    /// The product's status: 1 when a finger closes on nothing (no grasp), 2 otherwise (the
    /// input is wrong).
    pub fn status(&self) -> u8 {
        match self {
            GeometryError::ClosesOnNothing { .. } => 1,
            _ => 2,
        }
    }
}

/// The longest mesh resource string accepted, bytes: far above any real path or URI (Linux's
/// `PATH_MAX` is 4096), far below a message-sized string echoed back.
pub const MAX_RESOURCE_BYTES: usize = 4096;

/// How much of a resource an error prints, bytes: all of one this long or shorter.
const SHOWN_RESOURCE_BYTES: usize = 200;

/// A resource as errors print it: quoted (`{:?}`) whole when it has at most 200 bytes, else its
/// first 200 bytes (cut at a character's boundary), quoted, then `…(N bytes)`.
pub fn abbreviate(resource: &str) -> String {
    if resource.len() <= SHOWN_RESOURCE_BYTES {
        return format!("{resource:?}");
    }
    let mut end = SHOWN_RESOURCE_BYTES;
    while !resource.is_char_boundary(end) {
        end -= 1;
    }
    format!("{:?}…({} bytes)", &resource[..end], resource.len())
}
