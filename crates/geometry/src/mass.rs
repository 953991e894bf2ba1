//! The centre of mass: of a closed mesh from its volume at uniform density, of a primitive its
//! centroid, or the one the candidate gives.
//!
//! # Closed and manifold
//! A mesh has a volume only if it is closed and consistently oriented: every edge (after
//! merging vertices at identical positions) belongs to exactly two triangles, which run along it
//! in opposite directions. [`check_closed`] checks this; anything else is a [`MeshDefect`].
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

use crate::error::{GeometryError, MeshDefect};
use crate::shape::Shape;

/// Every edge in exactly two triangles, running opposite ways.
///
/// The first defect found in the order of the edges' sorted vertex pairs is returned, so the
/// answer does not depend on hashing.
pub fn check_closed(triangles: &[[u32; 3]]) -> Result<(), MeshDefect> {
    // (low, high, forward): forward when the triangle runs low → high.
    let mut edges: Vec<(u32, u32, bool)> = Vec::with_capacity(triangles.len() * 3);
    for t in triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            edges.push((a.min(b), a.max(b), a < b));
        }
    }
    edges.sort_unstable();
    for group in edges.chunk_by(|p, q| p.0 == q.0 && p.1 == q.1) {
        let edge = [group[0].0, group[0].1];
        if group.len() != 2 {
            return Err(MeshDefect::EdgeUse {
                edge,
                triangles: group.len(),
            });
        }
        if group[0].2 == group[1].2 {
            let edge = if group[0].2 { edge } else { [edge[1], edge[0]] };
            return Err(MeshDefect::Orientation { edge });
        }
    }
    Ok(())
}

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
    crate::cast::check_pose(pose, "object pose")?;
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

#[cfg(test)]
mod tests {
    use super::*;

    // A tetrahedron wound outward.
    const TETRA: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];

    #[test]
    fn closed_tetrahedron_passes() {
        assert_eq!(check_closed(&TETRA), Ok(()));
    }

    #[test]
    fn a_missing_triangle_is_an_open_edge() {
        assert_eq!(
            check_closed(&TETRA[..3]),
            Err(MeshDefect::EdgeUse {
                edge: [0, 2],
                triangles: 1
            })
        );
    }

    #[test]
    fn a_flipped_triangle_is_misoriented() {
        let mut t = TETRA;
        t[3] = [0, 2, 3];
        assert!(matches!(
            check_closed(&t),
            Err(MeshDefect::Orientation { .. })
        ));
    }

    #[test]
    fn a_third_triangle_on_an_edge_is_non_manifold() {
        let mut t = TETRA.to_vec();
        t.push([0, 1, 4]);
        t.push([0, 4, 1]);
        assert!(matches!(
            check_closed(&t),
            Err(MeshDefect::EdgeUse { triangles: 4, .. })
        ));
    }
}
