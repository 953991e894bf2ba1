//! Test objects: meshes generated here (a surface of revolution, an L-shaped prism), random
//! frames and random gripper poses.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3, Vector4};
use rand::Rng;

use crate::reference::divergence_volume_centroid;

/// Vertices and triangles of a mesh, outward-wound.
#[derive(Debug, Clone)]
pub struct TestMesh {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl TestMesh {
    pub fn points(&self, scale: f64) -> Vec<Point3<f64>> {
        self.vertices
            .iter()
            .map(|v| Point3::new(v[0] * scale, v[1] * scale, v[2] * scale))
            .collect()
    }

    pub fn indices(&self) -> Vec<[usize; 3]> {
        self.triangles
            .iter()
            .map(|t| t.map(|k| k as usize))
            .collect()
    }
}

/// The closed surface swept by a profile `(ρ, z)` turned about z in `segments` steps. Its end
/// points lie on the axis (`ρ = 0`), where one vertex stands for the whole ring. The triangles
/// are wound outward (turned if the reference's volume comes out negative).
pub fn revolve(profile: &[(f64, f64)], segments: u32) -> TestMesh {
    let mut vertices = Vec::new();
    let mut rings: Vec<Vec<u32>> = Vec::new();
    for &(rho, z) in profile {
        let start = vertices.len() as u32;
        if rho == 0.0 {
            vertices.push([0.0, 0.0, z]);
            rings.push(vec![start; segments as usize]);
        } else {
            for j in 0..segments {
                let a = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
                vertices.push([rho * a.cos(), rho * a.sin(), z]);
            }
            rings.push((start..start + segments).collect());
        }
    }
    let mut triangles = Vec::new();
    for w in rings.windows(2) {
        let (p, q) = (&w[0], &w[1]);
        for j in 0..segments as usize {
            let k = (j + 1) % segments as usize;
            for t in [[p[j], q[k], p[k]], [p[j], q[j], q[k]]] {
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    triangles.push(t);
                }
            }
        }
    }
    let mesh = TestMesh {
        vertices,
        triangles,
    };
    let (volume, _) = divergence_volume_centroid(&mesh.points(1.0), &mesh.indices());
    if volume < 0.0 {
        let triangles = mesh.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect();
        return TestMesh { triangles, ..mesh };
    }
    mesh
}

/// A mug without a handle: outer radius `r`, wall `wall`, height `h`, bottom `wall` thick,
/// open at the top. Not convex.
pub fn mug(r: f64, wall: f64, h: f64, segments: u32) -> TestMesh {
    let inner = r - wall;
    revolve(
        &[
            (0.0, wall),
            (inner, wall),
            (inner, h),
            (r, h),
            (r, 0.0),
            (0.0, 0.0),
        ],
        segments,
    )
}

/// A closed cylinder of radius `r` and height `h` centred on the origin, `segments` facets.
pub fn faceted_cylinder(r: f64, h: f64, segments: u32) -> TestMesh {
    revolve(
        &[(0.0, h / 2.0), (r, h / 2.0), (r, -h / 2.0), (0.0, -h / 2.0)],
        segments,
    )
}

/// An L-shaped prism: the L of side `a` with arms `a/2` wide, `depth` along z. Not convex.
pub fn l_prism(a: f64, depth: f64) -> TestMesh {
    let b = a / 2.0;
    let outline = [(0.0, 0.0), (a, 0.0), (a, b), (b, b), (b, a), (0.0, a)];
    let mut vertices = Vec::new();
    for z in [0.0, depth] {
        for &(x, y) in &outline {
            vertices.push([x, y, z]);
        }
    }
    // Caps: a fan from the reflex corner (index 3), which covers the L.
    let fan = [[3, 4, 5], [3, 5, 0], [3, 0, 1], [3, 1, 2]];
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for f in fan {
        triangles.push([f[0], f[2], f[1]]); // bottom, facing −z
        triangles.push([f[0] + 6, f[1] + 6, f[2] + 6]); // top, facing +z
    }
    for i in 0..6 {
        let j = (i + 1) % 6;
        triangles.push([i, j, j + 6]);
        triangles.push([i, j + 6, i + 6]);
    }
    TestMesh {
        vertices,
        triangles,
    }
}

/// A uniformly random rotation.
pub fn random_rotation(rng: &mut impl Rng) -> UnitQuaternion<f64> {
    loop {
        let q = Vector4::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let n = q.norm();
        if n > 0.1 && n <= 1.0 {
            return UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(q / n));
        }
    }
}

/// A random frame within `reach` metres of the origin.
pub fn random_frame(rng: &mut impl Rng, reach: f64) -> Isometry3<f64> {
    let t = Vector3::new(
        rng.gen_range(-reach..reach),
        rng.gen_range(-reach..reach),
        rng.gen_range(-reach..reach),
    );
    Isometry3::from_parts(Translation3::from(t), random_rotation(rng))
}
