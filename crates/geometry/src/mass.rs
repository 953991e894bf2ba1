//! The centre of mass: of a closed mesh from its volume at uniform density, of a primitive its
//! centroid, or the one the candidate gives.
//!
//! # Closed and manifold
//! A mesh has a volume only if it is closed and consistently oriented: every edge (after
//! merging vertices at identical positions) belongs to exactly two triangles, which run along it
//! in opposite directions. [`check_closed`] checks this; anything else is a [`MeshDefect`].
//!
//! Before the check, [`crate::mesh`] welds vertices closer than a tolerance relative to the
//! mesh's size and splits triangles at T-junctions ([`t_junctions`]), so that a surface closed
//! up to single-precision seams and vertices lying on other triangles' edges is closed here;
//! a real hole still leaves an edge in one triangle.
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

use std::collections::HashMap;

use nalgebra::Point3;
use parry3d_f64::math::Vector;

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

/// Most point-to-edge tests [`t_junctions`] makes before it gives up (and the mesh stays as it
/// is): a mesh with a few open edges takes a handful, and an open mesh with 10,000 boundary
/// edges and vertices around one long rim a few million at most in the sweep below.
pub const T_JUNCTION_TESTS: u64 = 50_000_000;

/// T-junctions: for each triangle with an edge in no other triangle, and boundary vertices (of
/// edges in one triangle) lying on that edge, the edge (`0`: corners 0 → 1, `1`: 1 → 2, `2`:
/// 2 → 0) and those vertices in order from its start. A vertex lies on the edge `a → b` when it
/// is within `tolerance` of the segment and farther than `tolerance` from both ends (closer, it
/// would have been welded to the end). One edge per triangle (the first); the caller splits and
/// asks again.
///
/// The search sorts the boundary vertices along the axis where they spread most and tests, for
/// each boundary edge, those within its span on that axis; beyond [`T_JUNCTION_TESTS`] tests, or
/// more than `most` vertices found on edges (the caller's bound on the triangles that splitting
/// adds), it returns none.
pub fn t_junctions(
    vertices: &[Vector],
    triangles: &[[u32; 3]],
    tolerance: f64,
    most: usize,
) -> HashMap<u32, (usize, Vec<u32>)> {
    let mut found = HashMap::new();
    // (low, high, triangle, edge) for every edge; an edge in one triangle is a boundary edge.
    let mut edges: Vec<(u32, u32, u32, usize)> = Vec::with_capacity(triangles.len() * 3);
    for (i, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            edges.push((a.min(b), a.max(b), i as u32, e));
        }
    }
    edges.sort_unstable();
    let boundary: Vec<(u32, usize)> = edges
        .chunk_by(|p, q| p.0 == q.0 && p.1 == q.1)
        .filter(|g| g.len() == 1)
        .map(|g| (g[0].2, g[0].3))
        .collect();
    if boundary.is_empty() || tolerance.is_nan() || tolerance <= 0.0 {
        return found;
    }
    let mut rim: Vec<u32> = boundary
        .iter()
        .flat_map(|&(t, e)| {
            let t = triangles[t as usize];
            [t[e], t[(e + 1) % 3]]
        })
        .collect();
    rim.sort_unstable();
    rim.dedup();
    let point = |k: u32| vertices[k as usize];
    let (mut lo, mut hi) = (
        Vector::splat(f64::INFINITY),
        Vector::splat(f64::NEG_INFINITY),
    );
    for &k in &rim {
        lo = lo.min(point(k));
        hi = hi.max(point(k));
    }
    let spread = hi - lo;
    let axis = if spread.x >= spread.y && spread.x >= spread.z {
        0
    } else if spread.y >= spread.z {
        1
    } else {
        2
    };
    let along = |k: u32| point(k)[axis];
    rim.sort_by(|&p, &q| along(p).total_cmp(&along(q)));
    let keys: Vec<f64> = rim.iter().map(|&k| along(k)).collect();
    let mut tests = 0u64;
    let mut points = 0usize;
    for &(t, e) in &boundary {
        let tri = triangles[t as usize];
        let (a, b) = (tri[e], tri[(e + 1) % 3]);
        let (pa, pb) = (point(a), point(b));
        let from = keys.partition_point(|&x| x < pa[axis].min(pb[axis]) - tolerance);
        let to = keys.partition_point(|&x| x <= pa[axis].max(pb[axis]) + tolerance);
        tests += (to - from) as u64;
        if tests > T_JUNCTION_TESTS {
            return HashMap::new();
        }
        let d = pb - pa;
        let length2 = d.length_squared();
        let mut on: Vec<(f64, u32)> = rim[from..to]
            .iter()
            .filter(|&&m| m != a && m != b)
            .filter_map(|&m| {
                let pm = point(m);
                let s = (pm - pa).dot(d) / length2;
                let off = (pm - pa - d * s).length();
                let inside = s > 0.0
                    && s < 1.0
                    && off <= tolerance
                    && (pm - pa).length() > tolerance
                    && (pm - pb).length() > tolerance;
                inside.then_some((s, m))
            })
            .collect();
        if on.is_empty() || found.contains_key(&t) {
            continue;
        }
        points += on.len();
        if points > most {
            return HashMap::new();
        }
        on.sort_by(|p, q| p.0.total_cmp(&q.0));
        found.insert(t, (e, on.into_iter().map(|(_, m)| m).collect()));
    }
    found
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
