//! A scaled triangle mesh, indexed once for ray casts (a BVH over its triangles).
//!
//! Building one: check the scale (finite and `> 0` per axis), the vertices (finite) and the
//! indices (in range); scale the vertices into metres; merge vertices at identical positions
//! (STL stores each triangle's corners apart); drop triangles that become degenerate (two equal
//! corners); check closedness ([`check_closed`]). A closed mesh gets its volume and
//! centroid and is turned outward if it was wound inward (negative volume). Every mesh gets
//! parry's BVH over its triangles, a compact copy of it that the fingers' casts walk (`bvh.rs`),
//! and the list of the triangles at each vertex, from which the
//! pseudo-normal of an edge or a vertex is computed when a finger meets one (rarely: parry's own
//! pseudo-normals for every edge and vertex took 40 % of the time to index and a quarter of the
//! memory).
//!
//! # Closed and manifold
//! A mesh has a volume only if it is closed and consistently oriented: every edge (after
//! merging vertices at identical positions) belongs to exactly two triangles, which run along it
//! in opposite directions. [`check_closed`] checks this; anything else is a [`MeshDefect`].
//!
//! Before the check, [`Mesh::from_triangles`] welds vertices closer than a tolerance relative to
//! the mesh's size and splits triangles at T-junctions ([`t_junctions`]), so that a surface
//! closed up to single-precision seams and vertices lying on other triangles' edges is closed
//! here; a real hole still leaves an edge in one triangle.

use std::collections::HashMap;
use std::mem::{size_of, size_of_val};

use nalgebra::Point3;
use parry3d_f64::mass_properties::details::trimesh_signed_volume_and_center_of_mass;
use parry3d_f64::math::Vector;
use parry3d_f64::shape::{TriMesh, TriMeshFlags};

use crate::bvh::CompactBvh;
use crate::error::{GeometryError, MeshDefect};

/// A scaled, merged, checked and indexed triangle mesh, in the object frame, metres.
#[derive(Debug, Clone)]
pub struct Mesh {
    resource: String,
    trimesh: TriMesh,
    /// The copy of the trimesh's BVH the fingers' casts walk.
    compact: CompactBvh,
    /// The triangles at vertex `v` are `at_vertex[first[v]..first[v + 1]]`.
    first: Vec<u32>,
    at_vertex: Vec<u32>,
    closed: Result<Closed, MeshDefect>,
    size: f64,
    bytes: usize,
}

#[derive(Debug, Clone, Copy)]
struct Closed {
    volume: f64,
    centroid: Vector,
}

impl Mesh {
    /// A mesh from vertices (in the mesh's units) and triangles (indices into `vertices`), as
    /// `shape_msgs/Mesh` gives them, scaled per axis by `scale` into metres.
    ///
    /// `resource` names the mesh in errors (a file's resource, or e.g. `"inline mesh"`).
    pub fn from_triangles(
        resource: impl Into<String>,
        vertices: &[[f64; 3]],
        triangles: &[[u32; 3]],
        scale: [f64; 3],
    ) -> Result<Self, GeometryError> {
        let resource = resource.into();
        check_scale(&resource, scale)?;
        check_indices(&resource, vertices.len(), triangles)?;
        let scaled = vertices.iter().enumerate().map(|(i, v)| {
            let p = Vector::new(v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]);
            if p.is_finite() {
                Ok(p)
            } else {
                Err(GeometryError::NonFiniteVertex {
                    resource: resource.clone(),
                    vertex: i,
                })
            }
        });
        let scaled = scaled.collect::<Result<Vec<_>, _>>()?;
        let tolerance = weld_tolerance(&scaled);
        let (vertices, mut triangles) = merge_vertices(&scaled, triangles, tolerance);
        if triangles.is_empty() {
            return Err(GeometryError::EmptyMesh { resource });
        }
        // T-junctions are looked for only where an edge is open (a closed mesh has none, and is
        // not sorted twice).
        let mut closed = check_closed(&triangles);
        if matches!(closed, Err(MeshDefect::EdgeUse { triangles: 1, .. })) {
            split_t_junctions(&vertices, &mut triangles, tolerance);
            closed = check_closed(&triangles);
        }
        let closed = closed.and_then(|()| {
            let (volume, centroid) =
                trimesh_signed_volume_and_center_of_mass(&vertices, &triangles);
            if volume == 0.0 || !volume.is_finite() {
                Err(MeshDefect::ZeroVolume)
            } else {
                Ok(Closed { volume, centroid })
            }
        });
        if let Ok(Closed { volume, .. }) = closed {
            if volume < 0.0 {
                for t in &mut triangles {
                    t.swap(1, 2);
                }
            }
        }
        let (first, at_vertex) = triangles_at_vertices(vertices.len(), &triangles);
        let trimesh =
            TriMesh::with_flags(vertices, triangles, TriMeshFlags::empty()).map_err(|_| {
                GeometryError::EmptyMesh {
                    resource: resource.clone(),
                }
            })?;
        let closed = closed.map(|c| Closed {
            volume: c.volume.abs(),
            centroid: c.centroid,
        });
        let compact = CompactBvh::new(&trimesh);
        let aabb = trimesh.local_aabb();
        let size = (aabb.maxs - aabb.mins).length();
        let bytes = estimate_bytes(&trimesh, &resource)
            + size_of_val(&first[..])
            + size_of_val(&at_vertex[..])
            + compact.bytes();
        Ok(Mesh {
            resource,
            trimesh,
            compact,
            first,
            at_vertex,
            closed,
            size,
            bytes,
        })
    }

    /// The resource (or name) the mesh was made from.
    pub fn resource(&self) -> &str {
        &self.resource
    }

    /// The diagonal of its bounding box, m.
    pub fn size(&self) -> f64 {
        self.size
    }

    /// Vertices after merging, m.
    pub fn vertex_count(&self) -> usize {
        self.trimesh.vertices().len()
    }

    /// Triangles after dropping degenerate ones.
    pub fn triangle_count(&self) -> usize {
        self.trimesh.indices().len()
    }

    /// Whether it is closed, manifold, consistently oriented and encloses a volume.
    pub fn is_closed(&self) -> bool {
        self.closed.is_ok()
    }

    /// The enclosed volume, m³ (closed meshes).
    pub fn volume(&self) -> Result<f64, MeshDefect> {
        self.closed.map(|c| c.volume)
    }

    /// The centroid of the enclosed volume in the object frame, m (closed meshes).
    pub fn centroid(&self) -> Result<Point3<f64>, MeshDefect> {
        self.closed
            .map(|c| Point3::new(c.centroid.x, c.centroid.y, c.centroid.z))
    }

    /// What it holds in memory, bytes (parry's count of its vertices, triangles and BVH, the
    /// compact copy of the BVH, and the triangles at each vertex).
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    pub(crate) fn trimesh(&self) -> &TriMesh {
        &self.trimesh
    }

    pub(crate) fn compact_bvh(&self) -> &CompactBvh {
        &self.compact
    }

    /// The corners of each triangle, object frame, metres (after merging and scaling), in the
    /// mesh's winding: for drawing it.
    pub fn corners(&self) -> impl Iterator<Item = [[f64; 3]; 3]> + '_ {
        let points = self.trimesh.vertices();
        self.trimesh.indices().iter().map(move |t| {
            t.map(|i| {
                let p = points[i as usize];
                [p.x, p.y, p.z]
            })
        })
    }

    fn triangles_at(&self, vertex: u32) -> impl Iterator<Item = u32> + '_ {
        let v = vertex as usize;
        self.at_vertex[self.first[v] as usize..self.first[v + 1] as usize]
            .iter()
            .copied()
    }

    /// The pseudo-normal of a vertex (not normalised): the unit normals of the triangles at it,
    /// each weighted by the triangle's angle there.
    pub(crate) fn vertex_pseudo_normal(&self, vertex: u32) -> Vector {
        let points = self.trimesh.vertices();
        self.triangles_at(vertex)
            .map(|t| {
                let corners = self.trimesh.indices()[t as usize];
                let k = corners.iter().position(|&c| c == vertex).unwrap_or(0);
                let p = points[corners[k] as usize];
                let u = points[corners[(k + 1) % 3] as usize] - p;
                let w = points[corners[(k + 2) % 3] as usize] - p;
                let angle = u.cross(w).length().atan2(u.dot(w));
                unit_normal(self.trimesh.triangle(t)) * angle
            })
            .sum()
    }

    /// The pseudo-normal of an edge (not normalised): the sum of the unit normals of the
    /// triangles along it.
    pub(crate) fn edge_pseudo_normal(&self, a: u32, b: u32) -> Vector {
        self.triangles_at(a)
            .filter(|&t| self.trimesh.indices()[t as usize].contains(&b))
            .map(|t| unit_normal(self.trimesh.triangle(t)))
            .sum()
    }

    /// This mesh scaled uniformly by `factor`, without merging its vertices, checking its
    /// closedness or building its BVH again: the vertices are multiplied by `factor` (the same
    /// products, bit for bit, as [`Mesh::from_triangles`] takes of vertices at this mesh's
    /// scale), the BVH's boxes too, parry's and the compact copy's (a product is monotone in its
    /// factor, so each scaled box still holds its scaled triangles; `CompactBvh::scaled`), in
    /// one pass over each without building either again, the volume and centroid are summed again over the scaled
    /// triangles, and the topology (merged vertices, closedness, triangles at each vertex) is
    /// the same. Where scaling would change what merging finds (a coordinate that underflows to
    /// a subnormal number or zero, two corners of a triangle that round to one point), the mesh
    /// is indexed again from its vertices ([`Mesh::rescaled`]).
    pub fn scaled(&self, factor: f64) -> Result<Mesh, GeometryError> {
        check_scale(&self.resource, [factor; 3])?;
        let points = self.trimesh.vertices();
        let keeps_topology = points.iter().all(|p| {
            let q = *p * factor;
            [(p.x, q.x), (p.y, q.y), (p.z, q.z)]
                .iter()
                .all(|&(a, b)| b.is_finite() && (a == 0.0 || b.is_normal()))
        }) && self.trimesh.indices().iter().all(|t| {
            let [a, b, c] = t.map(|k| points[k as usize] * factor);
            a != b && b != c && c != a
        });
        if !keeps_topology {
            return self.rescaled([factor; 3]);
        }
        let trimesh = self.trimesh.clone().scaled(Vector::splat(factor));
        let closed = self.closed.and_then(|_| {
            let (volume, centroid) =
                trimesh_signed_volume_and_center_of_mass(trimesh.vertices(), trimesh.indices());
            if volume == 0.0 || !volume.is_finite() {
                Err(MeshDefect::ZeroVolume)
            } else {
                Ok(Closed {
                    volume: volume.abs(),
                    centroid,
                })
            }
        });
        let compact = self.compact.scaled(factor);
        let aabb = trimesh.local_aabb();
        Ok(Mesh {
            resource: self.resource.clone(),
            size: (aabb.maxs - aabb.mins).length(),
            trimesh,
            compact,
            first: self.first.clone(),
            at_vertex: self.at_vertex.clone(),
            closed,
            bytes: self.bytes,
        })
    }

    /// This mesh scaled per axis by `scale`, indexed again from its (merged) vertices and
    /// triangles: what [`Mesh::from_triangles`] makes of them, without the file they came from.
    pub fn rescaled(&self, scale: [f64; 3]) -> Result<Mesh, GeometryError> {
        let vertices: Vec<[f64; 3]> = self
            .trimesh
            .vertices()
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect();
        Mesh::from_triangles(
            self.resource.clone(),
            &vertices,
            self.trimesh.indices(),
            scale,
        )
    }
}

fn unit_normal(t: parry3d_f64::shape::Triangle) -> Vector {
    (t.b - t.a).cross(t.c - t.a).normalize_or_zero()
}

/// For each vertex, the triangles that have it as a corner (compressed rows: offsets, then the
/// triangles' indices).
fn triangles_at_vertices(vertices: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut first = vec![0u32; vertices + 1];
    for t in triangles {
        for &c in t {
            first[c as usize + 1] += 1;
        }
    }
    for v in 0..vertices {
        first[v + 1] += first[v];
    }
    let mut next = first.clone();
    let mut at_vertex = vec![0u32; triangles.len() * 3];
    for (i, t) in triangles.iter().enumerate() {
        for &c in t {
            at_vertex[next[c as usize] as usize] = i as u32;
            next[c as usize] += 1;
        }
    }
    (first, at_vertex)
}

fn check_scale(resource: &str, scale: [f64; 3]) -> Result<(), GeometryError> {
    if scale.iter().all(|s| s.is_finite() && *s > 0.0) {
        Ok(())
    } else {
        Err(GeometryError::BadScale {
            resource: resource.to_owned(),
            scale,
        })
    }
}

fn check_indices(
    resource: &str,
    vertices: usize,
    triangles: &[[u32; 3]],
) -> Result<(), GeometryError> {
    for (i, t) in triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&k| k as usize >= vertices) {
            return Err(GeometryError::VertexIndex {
                resource: resource.to_owned(),
                triangle: i,
                index,
                vertices,
            });
        }
    }
    Ok(())
}

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

/// How close two vertices are to be one, m: [`WELD_TOLERANCE`] times the larger of the
/// vertices' bounding-box diagonal and their largest coordinate's magnitude.
///
/// Why this size: mesh files hold single-precision coordinates, whose spacing (one unit in the
/// last place) at a magnitude `M` is at most `M · 2⁻²³ ≈ 1.19e-7 · M`. An exporter that writes
/// the two sides of a seam from different computations leaves them a few such units apart, so
/// `1e-6 · max(diagonal, M)` (at least 8.4 units in the last place of any coordinate, as
/// `max(diagonal, M) ≥ M`) joins them. Points that far apart are not features a single-precision
/// file can place reliably, so nothing real is joined.
pub(crate) fn weld_tolerance(vertices: &[Vector]) -> f64 {
    let mut lo = Vector::splat(f64::INFINITY);
    let mut hi = Vector::splat(f64::NEG_INFINITY);
    for v in vertices {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    if vertices.is_empty() {
        return 0.0;
    }
    let diagonal = (hi - lo).length();
    let magnitude = lo.abs().max(hi.abs()).max_element();
    WELD_TOLERANCE * diagonal.max(magnitude)
}

/// The weld tolerance relative to the mesh's size (`weld_tolerance`).
pub const WELD_TOLERANCE: f64 = 1e-6;

/// One vertex per position up to `tolerance` (a vertex joins the first kept vertex within
/// `tolerance` of it, Euclidean, in the order given; bit-identical positions first, by hashing,
/// with −0 as +0), triangles renumbered, and triangles with two equal corners dropped. A kept
/// vertex keeps its own position, so the mesh's geometry moves by at most `tolerance`.
fn merge_vertices(
    vertices: &[Vector],
    triangles: &[[u32; 3]],
    tolerance: f64,
) -> (Vec<Vector>, Vec<[u32; 3]>) {
    let mut first: HashMap<[u64; 3], u32> = HashMap::with_capacity(vertices.len());
    let mut distinct = Vec::with_capacity(vertices.len());
    let mut new_index = Vec::with_capacity(vertices.len());
    for v in vertices {
        let key = [
            (v.x + 0.0).to_bits(),
            (v.y + 0.0).to_bits(),
            (v.z + 0.0).to_bits(),
        ];
        let index = *first.entry(key).or_insert_with(|| {
            distinct.push(*v);
            // At most as many as the input's vertices, which `u32` indices address.
            (distinct.len() - 1) as u32
        });
        new_index.push(index);
    }
    drop(first);
    let (merged, welded) = weld(&distinct, tolerance);
    let triangles = triangles
        .iter()
        .map(|t| t.map(|k| welded[new_index[k as usize] as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .collect();
    (merged, triangles)
}

/// Distinct positions joined within `tolerance`: a grid of cells `tolerance` wide, where a vertex
/// looks for a kept one in its cell and the 26 around it (every point within `tolerance` is in
/// one of them). The kept vertices, and the kept index of each input vertex.
fn weld(vertices: &[Vector], tolerance: f64) -> (Vec<Vector>, Vec<u32>) {
    if tolerance.is_nan() || tolerance <= 0.0 || tolerance.is_infinite() {
        return (vertices.to_vec(), (0..vertices.len() as u32).collect());
    }
    let cell = |v: &Vector| {
        [v.x, v.y, v.z].map(|c| {
            // Finite coordinates over a tolerance of 1e-6 of their magnitude: within ±1e7.
            (c / tolerance).floor() as i64
        })
    };
    // The kept vertices of a cell: `head[cell]`, then `next[k]` (u32::MAX ends the list).
    let mut head: HashMap<[i64; 3], u32> = HashMap::with_capacity(vertices.len());
    let mut next: Vec<u32> = Vec::with_capacity(vertices.len());
    let mut kept: Vec<Vector> = Vec::with_capacity(vertices.len());
    let mut index = Vec::with_capacity(vertices.len());
    let squared = tolerance * tolerance;
    for v in vertices {
        let c = cell(v);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let mut k = head
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .copied()
                        .unwrap_or(u32::MAX);
                    while k != u32::MAX {
                        if (kept[k as usize] - *v).length_squared() <= squared {
                            found = Some(k);
                            break 'search;
                        }
                        k = next[k as usize];
                    }
                }
            }
        }
        let k = found.unwrap_or_else(|| {
            let k = kept.len() as u32;
            kept.push(*v);
            let slot = head.entry(c).or_insert(u32::MAX);
            next.push(*slot);
            *slot = k;
            k
        });
        index.push(k);
    }
    (kept, index)
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

/// Closes T-junctions: where a vertex lies on another triangle's edge (within `tolerance` of it,
/// strictly between its ends), and that edge and the vertex's own edges are each in one triangle
/// only (a crack of zero width), the triangle is split at the vertex into a fan from its opposite
/// corner. Splitting a triangle `(a, b, c)` at `m = a + t(b − a)` leaves its area, its normal and
/// its term of the volume integral unchanged: the signed volume `det(a, m, c) + det(m, b, c)` is
/// `t·det(a, b, c) + (1 − t)·det(a, b, c)` by linearity in the second argument. Up to three
/// passes (a triangle may have T-junctions on each of its edges), adding at most as many
/// triangles as there were (a real T-junction adds one per vertex on an edge; vertices by the
/// thousand on a line of overlapping triangles would add them by the million); what remains
/// open stays open.
fn split_t_junctions(vertices: &[Vector], triangles: &mut Vec<[u32; 3]>, tolerance: f64) {
    let mut most = triangles.len();
    for _ in 0..3 {
        let splits = t_junctions(vertices, triangles, tolerance, most);
        if splits.is_empty() {
            return;
        }
        let added: usize = splits.values().map(|(_, on)| on.len()).sum();
        most -= added.min(most);
        let mut out = Vec::with_capacity(triangles.len() + splits.len() * 2);
        for (i, t) in triangles.iter().enumerate() {
            match splits.get(&(i as u32)) {
                None => out.push(*t),
                Some((edge, on)) => {
                    // The edge runs t[edge] → t[edge + 1]; the opposite corner is t[edge + 2].
                    let a = t[*edge];
                    let b = t[(*edge + 1) % 3];
                    let c = t[(*edge + 2) % 3];
                    let mut from = a;
                    for &m in on.iter().chain(std::iter::once(&b)) {
                        out.push([from, m, c]);
                        from = m;
                    }
                }
            }
        }
        *triangles = out;
    }
}

fn estimate_bytes(trimesh: &TriMesh, resource: &str) -> usize {
    // parry's own count: vertices, triangles, the BVH.
    size_of::<Mesh>() - size_of::<TriMesh>() + trimesh.total_memory_size() + resource.len()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The cube of side `unit` with a corner at the origin: its 8 corners and 12 triangles (each
    /// face split along a diagonal). Also the BVH tests' cube.
    pub(crate) fn cube_split(unit: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let v = (0..8)
            .map(|i| {
                [
                    unit * f64::from(i & 1),
                    unit * f64::from((i >> 1) & 1),
                    unit * f64::from((i >> 2) & 1),
                ]
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q: &[u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (v, t)
    }

    #[test]
    fn unshared_corners_are_merged_and_the_cube_is_closed() {
        let (v, t) = cube_split(1.0);
        // Every triangle with its own three corners, as in an STL file.
        let v2: Vec<[f64; 3]> = t.iter().flat_map(|t| t.map(|k| v[k as usize])).collect();
        let t2: Vec<[u32; 3]> = (0..t.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let mesh = Mesh::from_triangles("cube", &v2, &t2, [2.0, 2.0, 2.0]).expect("a cube");
        assert_eq!(mesh.vertex_count(), 8);
        assert!((mesh.volume().expect("closed") - 8.0).abs() < 1e-12);
        let c = mesh.centroid().expect("closed");
        assert!((c - Point3::new(1.0, 1.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn an_inward_wound_mesh_is_turned_outward() {
        let (v, mut t) = cube_split(1.0);
        for tri in &mut t {
            tri.swap(0, 1);
        }
        let mesh = Mesh::from_triangles("cube", &v, &t, [1.0; 3]).expect("a cube");
        assert!((mesh.volume().expect("closed") - 1.0).abs() < 1e-12);
        let tri = mesh.trimesh().triangle(0);
        let normal = (tri.b - tri.a).cross(tri.c - tri.a);
        let outward = tri.a + tri.b + tri.c - Vector::splat(1.5);
        assert!(normal.dot(outward) > 0.0);
    }

    #[test]
    fn bad_scale_index_and_vertex_are_refused() {
        let (v, t) = cube_split(1.0);
        for scale in [[0.0, 1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, f64::NAN]] {
            assert!(matches!(
                Mesh::from_triangles("m", &v, &t, scale),
                Err(GeometryError::BadScale { .. })
            ));
        }
        assert!(matches!(
            Mesh::from_triangles("m", &v, &[[0, 1, 8]], [1.0; 3]),
            Err(GeometryError::VertexIndex { index: 8, .. })
        ));
        let mut v2 = v.clone();
        v2[3][1] = f64::INFINITY;
        assert!(matches!(
            Mesh::from_triangles("m", &v2, &t, [1.0; 3]),
            Err(GeometryError::NonFiniteVertex { vertex: 3, .. })
        ));
        assert!(matches!(
            Mesh::from_triangles("m", &v, &[[0, 0, 1]], [1.0; 3]),
            Err(GeometryError::EmptyMesh { .. })
        ));
    }

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
