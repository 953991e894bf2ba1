//! Closed meshes as exporters write them, against checks that share no code with the crate:
//! the generalised winding number (the solid angle the triangles subtend at a point, over 4π:
//! 1 inside a closed outward surface, 0 outside, a fraction where the surface has a hole) and the
//! volume and centroid by a second form of the divergence theorem (each triangle projected on
//! the coordinate planes, not the crate's tetrahedra from a reference point).
//!
//! The meshes: a cube whose corners, as an STL file stores them (three apart per triangle),
//! differ between the triangles in their last single-precision bits; a cube with T-junctions (a
//! face split at points on its neighbours' edges); and the same cubes with a real hole, which the
//! crate still refuses as open.

use grasp_orient_geometry::{GeometryError, Mesh, MeshDefect};

type P = [f64; 3];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: P, b: P) -> P {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: P) -> f64 {
    dot(a, a).sqrt()
}

/// The generalised winding number of the triangles at `q`: Σ Ω_t / 4π, with the solid angle of
/// a triangle by Van Oosterom and Strackee's formula,
/// `tan(Ω/2) = a·(b × c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)`, `a, b, c` the corners
/// seen from `q`.
fn winding(corners: &[[P; 3]], q: P) -> f64 {
    let total: f64 = corners
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|p| sub(p, q));
            let (la, lb, lc) = (norm(a), norm(b), norm(c));
            let num = dot(a, cross(b, c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            2.0 * num.atan2(den)
        })
        .sum();
    total / (4.0 * std::f64::consts::PI)
}

/// Volume and centroid by `V = ∮ x n_x dA` and `∫ x dV = ½ ∮ x² n_x dA` (and the same in y and
/// z), with `∫_T x dA = A (x_a + x_b + x_c)/3` and
/// `∫_T x² dA = A (x_a² + x_b² + x_c² + x_a x_b + x_b x_c + x_c x_a)/6` over a flat triangle,
/// whose `n dA` integrates to `N/2`, `N = (b − a) × (c − a)`. The volume is the mean of the three
/// projections.
///
/// The coordinates are taken from the first corner (the integrals of a closed surface do not
/// depend on the origin, and far from it the squares would cancel to nothing).
fn volume_and_centroid(corners: &[[P; 3]]) -> (f64, P) {
    let r = corners[0][0];
    let mut volume = [0.0; 3];
    let mut moment = [0.0; 3];
    for t in corners {
        let [a, b, c] = t.map(|p| sub(p, r));
        let (a, b, c) = (&a, &b, &c);
        let n = cross(sub(*b, *a), sub(*c, *a));
        for k in 0..3 {
            let (x, y, z) = (a[k], b[k], c[k]);
            // A = |N|/2 and n_k = N_k/|N|: A·n_k = N_k/2.
            volume[k] += n[k] / 2.0 * (x + y + z) / 3.0;
            moment[k] += 0.5 * n[k] / 2.0 * (x * x + y * y + z * z + x * y + y * z + z * x) / 6.0;
        }
    }
    let v = (volume[0] + volume[1] + volume[2]) / 3.0;
    let mut centroid = moment.map(|m| m / v);
    for k in 0..3 {
        centroid[k] += r[k];
    }
    (v, centroid)
}

/// The cube `[o, o + s]³`: its corners and 12 outward triangles (corner `i` at bit 0: x, 1: y,
/// 2: z).
fn cube(o: P, s: f64) -> (Vec<P>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| [0, 1, 2].map(|k| o[k] + s * f64::from((i >> k) & 1)))
        .collect();
    let t = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    (v, t)
}

/// `x` moved by `k` units in the last place of its single-precision value (and read back as the
/// f64 a mesh file's f32 becomes).
fn ulps(x: f64, k: i32) -> f64 {
    let f = x as f32;
    f64::from(f32::from_bits((f.to_bits() as i32 + k) as u32))
}

/// The cube as an STL file stores it: three corners per triangle, each written as single
/// precision, moved by −3 to +3 units in the last place by triangle and corner (the seam).
fn seam_cube(o: P, s: f64) -> (Vec<P>, Vec<[u32; 3]>) {
    let (v, t) = cube(o, s);
    let mut out = Vec::new();
    for (i, tri) in t.iter().enumerate() {
        for (j, &k) in tri.iter().enumerate() {
            let p = v[k as usize];
            let shift = ((i * 3 + j) % 7) as i32 - 3;
            out.push([ulps(p[0], shift), ulps(p[1], -shift), ulps(p[2], shift / 2)]);
        }
    }
    let n = t.len() as u32;
    (out, (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect())
}

/// The unit cube at `o` with its top face (z = 1) split at the midpoints of its edges along y = 0
/// and x = 1, which its neighbours (the faces y = 0 and x = 1) do not have: two T-junctions.
fn t_junction_cube(o: P) -> (Vec<P>, Vec<[u32; 3]>) {
    let (mut v, t) = cube(o, 1.0);
    let m = v.len() as u32;
    v.push([o[0] + 0.5, o[1], o[2] + 1.0]); // on edge 4–5
    v.push([o[0] + 1.0, o[1] + 0.5, o[2] + 1.0]); // on edge 5–7
    let n = m + 1;
    let mut t: Vec<[u32; 3]> = t.into_iter().filter(|t| t[0] != 4 || t[1] == 4).collect();
    t.retain(|t| !(t == &[4, 5, 7] || t == &[4, 7, 6]));
    t.extend([[4, m, 6], [m, 5, n], [m, n, 7], [m, 7, 6]]);
    (v, t)
}

fn corners(v: &[P], t: &[[u32; 3]]) -> Vec<[P; 3]> {
    t.iter().map(|t| t.map(|k| v[k as usize])).collect()
}

/// The widest seam: the largest distance between two vertices that stand for the same point
/// (closer than 1e-3 of the cube's side `side`, and not equal).
fn gap(v: &[P], side: f64) -> f64 {
    let mut widest = 0.0f64;
    for p in v {
        for q in v {
            let d = norm(sub(*p, *q));
            if d < 1e-3 * side {
                widest = widest.max(d);
            }
        }
    }
    widest
}

/// The crate's mesh closed, with the independent volume and centroid, and the winding number 1
/// at the centre and 0 outside.
fn assert_closed(name: &str, v: &[P], t: &[[u32; 3]], volume: f64, centre: P) {
    let c = corners(v, t);
    let w_in = winding(&c, centre);
    let w_out = winding(&c, [centre[0] + 3.0 * volume.cbrt(), centre[1], centre[2]]);
    // A seam `g` wide leaves gaps of area about `g · s` on a cube of side `s`, which subtend
    // about `g/s` of the sphere at its centre: the winding number is 1 up to that.
    let bound = 20.0 * gap(v, volume.cbrt()) / volume.cbrt() + 1e-12;
    eprintln!(
        "{name}: winding {w_in} - 1 = {:e}, bound {bound:e}",
        w_in - 1.0
    );
    assert!(
        (w_in - 1.0).abs() < bound,
        "{name}: winding {w_in} at the centre"
    );
    assert!(w_out.abs() < bound, "{name}: winding {w_out} outside");
    // The volume and centroid, independently, of the triangles as given (seams and all), and
    // the crate's (welded), both against the exact cube, to the seam's relative width (exactly,
    // when there is no seam).
    let (vi, ci) = volume_and_centroid(&c);
    let mesh = Mesh::from_triangles(name, v, t, [1.0; 3]).expect("a mesh");
    let vm = mesh
        .volume()
        .unwrap_or_else(|d| panic!("{name}: refused as {d}"));
    let cm = mesh.centroid().expect("closed");
    let size = volume.cbrt();
    eprintln!(
        "{name}: volume {:e} (independently {:e}) relative to exact; centroid {:e} of the size",
        (vm - volume) / volume,
        (vi - volume) / volume,
        (0..3)
            .map(|k| (cm[k] - centre[k]).abs())
            .fold(0.0, f64::max)
            / size
    );
    assert!(
        (vi - volume).abs() <= bound * volume,
        "{name}: independent volume {vi}"
    );
    assert!(
        (vm - volume).abs() <= bound * volume,
        "{name}: volume {vm}, independently {vi}"
    );
    for k in 0..3 {
        assert!(
            (ci[k] - centre[k]).abs() <= bound * size,
            "{name}: independent centroid {ci:?}"
        );
        assert!(
            (cm[k] - centre[k]).abs() <= bound * size,
            "{name}: centroid {cm:?}, exactly {centre:?}"
        );
    }
}

/// The crate refuses it as open, and the winding number at the centre is not an integer.
fn assert_open(name: &str, v: &[P], t: &[[u32; 3]], centre: P, side: f64) {
    let w = winding(&corners(v, t), centre);
    let bound = 20.0 * gap(v, side) / side + 1e-12;
    eprintln!("{name}: winding {w}, bound {bound:e}");
    assert!(
        (w - w.round()).abs() > bound,
        "{name}: winding {w}: closed after all"
    );
    let mesh = Mesh::from_triangles(name, v, t, [1.0; 3]).expect("a mesh");
    let defect = mesh.volume().expect_err("open");
    assert!(
        matches!(defect, MeshDefect::EdgeUse { triangles: 1, .. }),
        "{name}: {defect}"
    );
    let err = grasp_orient_geometry::center_of_mass(
        &nalgebra::Isometry3::identity(),
        &std::sync::Arc::new(mesh).into(),
        None,
    )
    .expect_err("no centre of mass");
    assert!(matches!(err, GeometryError::NotClosed { .. }));
    assert!(err.to_string().contains("open or non-manifold"), "{err}");
}

const O: P = [0.1, -0.25, 0.3];

#[test]
fn a_single_precision_seam_is_closed_and_its_centroid_exact() {
    for (o, s) in [(O, 0.04), ([120.0, -35.0, 7.5], 0.04), ([-20.0; 3], 40.0)] {
        let (v, t) = seam_cube(o, s);
        // The seam is there: corners of the same cube corner differ.
        assert!(v.iter().any(|p| v
            .iter()
            .any(|q| p != q && norm(sub(*p, *q)) < 1e-6 * s.max(1.0) * 1e3)));
        let centre = o.map(|c| c + s / 2.0);
        assert_closed(
            &format!("seam cube {s} at {o:?}"),
            &v,
            &t,
            s * s * s,
            centre,
        );
    }
}

#[test]
fn a_t_junction_is_closed_and_its_centroid_exact() {
    let (v, t) = t_junction_cube(O);
    assert_closed("T-junction cube", &v, &t, 1.0, O.map(|c| c + 0.5));
}

#[test]
fn a_real_hole_is_still_refused() {
    let centre = O.map(|c| c + 0.02);
    let (v, mut t) = seam_cube(O, 0.04);
    t.remove(5);
    assert_open("seam cube with a hole", &v, &t, centre, 0.04);
    let (v, mut t) = t_junction_cube(O);
    // The face x = 0 loses a triangle: a hole away from the T-junctions.
    let at = t.iter().position(|t| t == &[0, 4, 6]).expect("there");
    t.remove(at);
    assert_open(
        "T-junction cube with a hole",
        &v,
        &t,
        O.map(|c| c + 0.5),
        1.0,
    );
    // A slit: the top face's split point moved off the edge by 1e-2 (far beyond the weld
    // tolerance of 1e-6 of the size) leaves a gap.
    let (mut v, t) = t_junction_cube(O);
    v[8][1] -= 1e-2;
    assert_open(
        "T-junction cube with a slit",
        &v,
        &t,
        O.map(|c| c + 0.5),
        1.0,
    );
}
