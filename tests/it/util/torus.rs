//! A closed inline mesh for the tests and the inline-mesh benchmark (`benches/inline_mesh.rs`
//! includes this file), so that both index the same torus.

use grasp_orient::msg::{Mesh, MeshTriangle, Point};

/// A closed inline mesh of `2 × rings × sides` triangles, in metres: a torus whose tube (25 mm in
/// radius) runs through the origin along x, its axis parallel to z through (0, -0.06, 0).
pub fn torus(rings: u32, sides: u32) -> Mesh {
    let mut vertices = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let u = std::f64::consts::TAU * f64::from(i) / f64::from(rings);
            let v = std::f64::consts::TAU * f64::from(j) / f64::from(sides);
            let rho = 0.06 + 0.025 * v.cos();
            vertices.push(Point {
                x: rho * u.sin(),
                y: rho * u.cos() - 0.06,
                z: 0.025 * v.sin(),
            });
        }
    }
    let at = |i: u32, j: u32| (i % rings) * sides + j % sides;
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            triangles.push(MeshTriangle {
                vertex_indices: [a, b, c],
            });
            triangles.push(MeshTriangle {
                vertex_indices: [a, c, d],
            });
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}
