//! The compact tree's tests: its boxes hold parry's, and its walks find the first hits parry's
//! search finds. They build their meshes with [`Mesh::from_triangles`], which builds on the tree,
//! so they sit in a file of their own above both `bvh.rs` and `mesh.rs`.

use super::*;
use crate::mesh::Mesh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The cast before the compact copy: parry's own best-first search of its BVH, with the same
/// box test on parry's `f64` boxes.
fn parry_first_hit(trimesh: &TriMesh, ray: &Ray, max: f64) -> Option<(u32, f64)> {
    let slabs = Slabs::new(ray);
    trimesh.bvh().find_best(
        max,
        |node: &BvhNode, best| {
            let (mins, maxs) = (node.mins(), node.maxs());
            slabs.entry_of([mins.x, mins.y, mins.z], [maxs.x, maxs.y, maxs.z], best)
        },
        |id, best| trimesh.triangle(id).cast_local_ray(ray, best, false),
    )
}

/// A torus of `rings × sides` quads, turned and moved off the axes, and a unit cube (whose
/// edges and faces lie on the axes' planes).
fn meshes() -> Vec<Mesh> {
    let (rings, sides) = (48u32, 32u32);
    let turn = nalgebra::UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
    let vertex = |i: u32, j: u32| {
        let u = std::f64::consts::TAU * f64::from(i % rings) / f64::from(rings);
        let v = std::f64::consts::TAU * f64::from(j % sides) / f64::from(sides);
        let rho = 0.06 + 0.025 * v.cos();
        let p = turn * nalgebra::Vector3::new(rho * u.cos(), rho * u.sin(), 0.025 * v.sin());
        [p.x + 0.1, p.y - 0.2, p.z + 0.05]
    };
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let k = vertices.len() as u32;
            vertices.extend([vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1)]);
            vertices.extend([vertex(i, j + 1)]);
            triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
        }
    }
    let torus = Mesh::from_triangles("torus", &vertices, &triangles, [1.0; 3]).expect("torus");
    let (cube_vertices, cube_triangles) = crate::mesh::tests::cube_split(1.0);
    let cube =
        Mesh::from_triangles("cube", &cube_vertices, &cube_triangles, [1.0; 3]).expect("cube");
    vec![torus, cube]
}

/// [`meshes`] scaled uniformly, their trees scaled too ([`CompactBvh::scaled`]), not built again.
fn scaled_meshes() -> Vec<Mesh> {
    let [torus, cube]: [Mesh; 2] = meshes().try_into().expect("two meshes");
    let mut scaled: Vec<Mesh> = [2.7, 1.0 + 1e-12, 0.001]
        .iter()
        .map(|&factor| torus.scaled(factor).expect("scaled"))
        .collect();
    scaled.push(cube.scaled(0.3).expect("scaled"));
    scaled
}

fn unit(rng: &mut ChaCha8Rng) -> Vector {
    loop {
        let v = Vector::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if v.length() > 0.1 && v.length() <= 1.0 {
            return v.normalize();
        }
    }
}

/// A ray's origin and direction: from anywhere around the mesh (inside or outside), or
/// through a corner or a point of an edge of one of its triangles, crossing it or along the
/// triangle's plane, from before or from the point itself; sometimes along an axis.
fn random_ray(rng: &mut ChaCha8Rng, mesh: &Mesh) -> (Vector, Vector) {
    let aabb = mesh.trimesh().local_aabb();
    let (centre, half) = (aabb.center(), aabb.half_extents());
    let mut d = unit(rng);
    if rng.gen_bool(0.1) {
        let axis = rng.gen_range(0..3);
        d = Vector::ZERO;
        d[axis] = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
    }
    if rng.gen_bool(0.4) {
        let offset = Vector::new(
            rng.gen_range(-1.5..1.5),
            rng.gen_range(-1.5..1.5),
            rng.gen_range(-1.5..1.5),
        );
        return (centre + offset * half, d);
    }
    let t = mesh
        .trimesh()
        .triangle(rng.gen_range(0..mesh.triangle_count() as u32));
    let corners = [t.a, t.b, t.c];
    let k = rng.gen_range(0..3);
    let s = if rng.gen_bool(0.3) {
        0.0
    } else {
        rng.gen_range(0.0..1.0)
    };
    let point = corners[k] + (corners[(k + 1) % 3] - corners[k]) * s;
    if rng.gen_bool(0.3) {
        // Along the triangle's plane, through its edge.
        let normal = (t.b - t.a).cross(t.c - t.a).normalize();
        let along = d - normal * d.dot(normal);
        if along.length() > 0.1 {
            d = along.normalize();
        }
    }
    let back = if rng.gen_bool(0.2) {
        0.0
    } else {
        rng.gen_range(0.0..2.0) * half.length()
    };
    (point - d * back, d)
}

/// The first hit by plain ray-triangle tests over all the triangles (parry's test, the least
/// time; at a tie, the first triangle).
fn every_triangle(trimesh: &TriMesh, ray: &Ray, max: f64) -> Option<(u32, f64)> {
    (0..trimesh.indices().len() as u32)
        .filter_map(|i| {
            trimesh
                .triangle(i)
                .cast_local_ray(ray, max, false)
                .map(|t| (i, t))
        })
        .min_by(|p, q| p.1.total_cmp(&q.1))
}

/// The same time as before bit for bit, and the same triangle or, at a tie, one the ray meets
/// at that very time; or, where parry's search missed the first hit, the first hit over all
/// the triangles (the count of which is returned).
fn agree(
    trimesh: &TriMesh,
    ray: &Ray,
    max: f64,
    new: Option<(u32, f64)>,
    old: Option<(u32, f64)>,
) -> usize {
    let time = |hit: Option<(u32, f64)>| hit.map(|(_, t)| t.to_bits());
    let truth = if time(new) == time(old) {
        old
    } else {
        let truth = every_triangle(trimesh, ray, max);
        assert_ne!(
            time(old),
            time(truth),
            "{ray:?} {max}: {new:?}, before {old:?}"
        );
        truth
    };
    assert_eq!(time(new), time(truth), "{ray:?} {max}: {new:?}, {truth:?}");
    if let (Some((id, t)), Some((other, _))) = (new, truth) {
        if id != other {
            let again = trimesh.triangle(id).cast_local_ray(ray, max, false);
            assert_eq!(again, Some(t), "{ray:?}: a tie {id}, {other}");
        }
    }
    usize::from(time(new) != time(old))
}

#[test]
fn the_copy_is_parrys_tree_with_boxes_rounded_outward() {
    for mesh in meshes().into_iter().chain(scaled_meshes()) {
        let tree = mesh.compact_bvh();
        let trimesh = mesh.trimesh();
        // Each node's boxes hold their subtrees' triangles.
        let mut stack = vec![(0u32, [f64::NEG_INFINITY; 3], [f64::INFINITY; 3])];
        let mut leaves = Vec::new();
        while let Some((quad, lo, hi)) = stack.pop() {
            let quad = &tree.quads[quad as usize];
            for k in 0..4 {
                if quad.child[k] == NONE {
                    assert!(quad.mins[0][k] > quad.maxs[0][k]);
                    continue;
                }
                let mins = [0, 1, 2].map(|a| f64::from(quad.mins[a][k]));
                let maxs = [0, 1, 2].map(|a| f64::from(quad.maxs[a][k]));
                assert!((0..3).all(|a| lo[a] <= mins[a] && maxs[a] <= hi[a]));
                let child = quad.child[k];
                if child & LEAF != 0 {
                    leaves.push(child & !LEAF);
                    let t = trimesh.triangle(child & !LEAF);
                    for p in [t.a, t.b, t.c] {
                        let p = [p.x, p.y, p.z];
                        assert!((0..3).all(|a| mins[a] <= p[a] && p[a] <= maxs[a]));
                    }
                } else {
                    stack.push((child, mins, maxs));
                }
            }
        }
        // Each triangle once.
        leaves.sort_unstable();
        assert_eq!(leaves.len(), trimesh.indices().len());
        assert!(leaves.iter().enumerate().all(|(i, &id)| i as u32 == id));
    }
}

#[test]
fn the_walks_find_what_parrys_search_found() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (mut hits, mut both, mut missed) = (0, 0, 0);
    for mesh in meshes() {
        let (trimesh, tree) = (mesh.trimesh(), mesh.compact_bvh());
        let size = mesh.size();
        for _ in 0..20_000 {
            let (origin, d) = random_ray(&mut rng, &mesh);
            let length = rng.gen_range(0.0..1.5) * size;
            let max = if rng.gen_bool(0.2) { f64::MAX } else { length };
            // One ray alone.
            let ray = Ray::new(origin, d);
            let old = parry_first_hit(trimesh, &ray, max);
            missed += agree(trimesh, &ray, max, tree.first_hit(trimesh, &ray, max), old);
            hits += usize::from(old.is_some());
            // Two fingers: from either end of a segment towards the other.
            let other = Ray::new(origin + d * length, -d);
            let new = [&ray, &other].map(|r| tree.first_hit(trimesh, r, length));
            let old = [&ray, &other].map(|r| parry_first_hit(trimesh, r, length));
            missed += agree(trimesh, &ray, length, new[0], old[0]);
            missed += agree(trimesh, &other, length, new[1], old[1]);
            both += usize::from(old[0].is_some() && old[1].is_some());
        }
    }
    // The rays meet the meshes often, from both ends.
    assert!(
        hits > 10_000 && both > 5_000,
        "{hits} hits, {both} from both ends"
    );
    eprintln!("{hits} hits, {both} from both ends; parry's search missed {missed} first hits");
}

/// A scaled tree's walks find the first hits: the same times, bit for bit, as plain ray-triangle
/// tests over all the triangles and as a tree built anew from the scaled mesh, on rays from
/// around the mesh and through the insides of its triangles. (Rays along a triangle's plane, as
/// [`random_ray`] makes some, are left out here: parry's triangle test may report such a ray
/// meeting the triangle's plane outside the triangle, and whether a walk gets to try that
/// triangle then depends on the boxes' last bits.)
#[test]
fn the_walks_of_scaled_trees_find_the_first_hits() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut hits = 0;
    for mesh in scaled_meshes() {
        let (trimesh, tree) = (mesh.trimesh(), mesh.compact_bvh());
        let rebuilt = CompactBvh::new(trimesh);
        let aabb = trimesh.local_aabb();
        let (centre, half) = (aabb.center(), aabb.half_extents());
        for _ in 0..5_000 {
            let d = unit(&mut rng);
            let origin = if rng.gen_bool(0.5) {
                let offset = Vector::new(
                    rng.gen_range(-1.5..1.5),
                    rng.gen_range(-1.5..1.5),
                    rng.gen_range(-1.5..1.5),
                );
                centre + offset * half
            } else {
                let t = trimesh.triangle(rng.gen_range(0..mesh.triangle_count() as u32));
                let (u, v) = (rng.gen_range(0.05..0.9), rng.gen_range(0.05..0.9));
                let (u, v) = if u + v < 0.95 {
                    (u, v)
                } else {
                    (0.95 - v, 0.95 - u)
                };
                let inside = t.a + (t.b - t.a) * u + (t.c - t.a) * v;
                inside - d * (rng.gen_range(0.01..2.0) * half.length())
            };
            let ray = Ray::new(origin, d);
            let max = if rng.gen_bool(0.2) {
                f64::MAX
            } else {
                rng.gen_range(0.0..3.0) * half.length()
            };
            let time = |hit: Option<(u32, f64)>| hit.map(|(_, t)| t.to_bits());
            let got = tree.first_hit(trimesh, &ray, max);
            let truth = every_triangle(trimesh, &ray, max);
            assert_eq!(time(got), time(truth), "{ray:?} {max}: {got:?}, {truth:?}");
            assert_eq!(
                time(got),
                time(rebuilt.first_hit(trimesh, &ray, max)),
                "{ray:?} {max}"
            );
            hits += usize::from(got.is_some());
        }
    }
    assert!(hits > 5_000, "{hits} hits");
}
