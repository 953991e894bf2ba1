//! The centre of mass: of a closed mesh from its volume at uniform density, of a primitive its
//! centroid, or the one the candidate gives.
//!
//! # Closedness
//! Only a closed, consistently oriented mesh has a volume and so a centroid; the check
//! ([`check_closed`]) and the welding and T-junction splitting before it belong to the mesh
//! and run when it is built ([`crate::mesh`]).
//!
//! # Formula (divergence theorem)
//! For a closed surface `∂V` with outward unit normal `n`, the divergence theorem turns volume
//! integrals into surface integrals: `∫_V ∇·F dV = ∮_∂V F·n dA`.
//! - With `F = (x − r)/3` (`∇·F = 1`) the volume is `V = (1/3) ∮ (x − r)·n dA`; on a triangle
//!   `(a, b, c)` the integrand is constant, and the sum over the triangles is
//!   `V = Σ_t V_t`, `V_t = (a − r)·((b − r) × (c − r)) / 6`: the signed volume of the
//!   tetrahedron from a reference point `r` to the triangle.
//! - With `F` chosen per coordinate (`F_i = (x − r)_i (x − r)/4`, `∇·F_i = (x − r)_i`), the
//!   first moment is `∫_V (x − r) dV = Σ_t V_t (a + b + c − 3r)/4`, the tetrahedra's centroids
//!   weighted by their signed volumes; so the centroid is
//!   `c = r + Σ_t V_t (a + b + c − 3r)/4 / V`.
//!
//! Any `r` gives the same result in exact arithmetic; taking `r` at the mean of the vertices
//! keeps the terms small. The sum is parry's `trimesh_signed_volume_and_center_of_mass`. A
//! negative `V` means the triangles are wound inward: the mesh is turned outward instead of
//! refused (see [`crate::mesh`]).

use nalgebra::Point3;

use crate::error::GeometryError;
pub use crate::mesh::{check_closed, t_junctions, T_JUNCTION_TESTS};
use crate::shape::{check_pose, Shape};

/// The centre of mass in the frame the object's pose is given in (the header frame).
///
/// `given` (in the object frame) wins when present; otherwise a primitive's centroid, or a closed
/// mesh's centroid at uniform density. An open, non-manifold or inconsistently oriented mesh
/// without `given` is [`GeometryError::NotClosed`].
pub fn center_of_mass(
    pose: &nalgebra::Isometry3<f64>,
    shape: &Shape,
    given: Option<Point3<f64>>,
) -> Result<Point3<f64>, GeometryError> {
    check_pose(pose, "object pose")?;
    let local = match (given, shape) {
        (Some(point), _) => {
            if !point.iter().all(|v| v.is_finite()) {
                return Err(GeometryError::BadNumber {
                    field: "center_of_mass",
                    positive: false,
                });
            }
            point
        }
        (None, Shape::Primitive(primitive)) => {
            primitive.check()?;
            primitive.centroid()
        }
        (None, Shape::Mesh(mesh)) => {
            mesh.centroid().map_err(|defect| GeometryError::NotClosed {
                resource: mesh.resource().to_owned(),
                defect,
            })?
        }
    };
    Ok(pose * local)
}
