//! How long a 100,000-triangle mesh takes to parse, and to load and index; how long 1,000 poses
//! take to cast on it; and, in the same run, the 3D solve of the 1,000 contacts they give, for
//! the ratio "poses on a mesh" : "the same set given as contacts".
//!
//! `cargo bench -p grasp_orient_geometry --bench cast` prints the numbers (medians of repeats).

use std::hint::black_box;
use std::io::Write;
use std::sync::Arc;
use std::time::{Duration, Instant};

use grasp_orient_geometry::{
    cast_fingers, center_of_mass, load, parse, AmentIndex, ClosingAxis, GripperPose, Mesh,
    MeshCache, Object, Shape,
};
use grasp_orient_solver::{spatial, Settings};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A torus of `rings × sides` quads (two triangles each), in millimetres, as binary STL.
fn write_torus_stl(path: &std::path::Path, rings: u32, sides: u32) -> usize {
    let (big, small) = (60.0f64, 25.0f64);
    let vertex = |i: u32, j: u32| -> [f32; 3] {
        let u = std::f64::consts::TAU * f64::from(i % rings) / f64::from(rings);
        let v = std::f64::consts::TAU * f64::from(j % sides) / f64::from(sides);
        let rho = big + small * v.cos();
        [
            (rho * u.cos()) as f32,
            (rho * u.sin()) as f32,
            (small * v.sin()) as f32,
        ]
    };
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    let mut bytes = vec![0u8; 80];
    bytes.extend((triangles.len() as u32).to_le_bytes());
    for t in &triangles {
        bytes.extend([0u8; 12]);
        for v in t {
            for x in v {
                bytes.extend(x.to_le_bytes());
            }
        }
        bytes.extend([0u8; 2]);
    }
    let mut file = std::fs::File::create(path).expect("create the STL file");
    file.write_all(&bytes).expect("write the STL file");
    triangles.len()
}

fn median(mut samples: Vec<Duration>) -> Duration {
    samples.sort();
    samples[samples.len() / 2]
}

fn time<T>(repeats: usize, mut f: impl FnMut() -> T) -> Duration {
    median(
        (0..repeats)
            .map(|_| {
                let start = Instant::now();
                black_box(f());
                start.elapsed()
            })
            .collect(),
    )
}

fn random_rotation(rng: &mut impl Rng) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(
        rng.gen_range(-3.2..3.2),
        rng.gen_range(-1.6..1.6),
        rng.gen_range(-3.2..3.2),
    )
}

/// 1,000 poses on the torus's tube, as a planner would give them: the tool's centre on the tube's
/// centre line, closing across the tube (vertically or radially, tilted by up to 0.3 rad), the
/// rest of the orientation random about the closing axis.
fn poses(rng: &mut impl Rng, frame: &Isometry3<f64>) -> Vec<GripperPose> {
    (0..1000)
        .map(|_| {
            let u: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let centre = Point3::new(0.06 * u.cos(), 0.06 * u.sin(), 0.0);
            let across = if rng.gen_bool(0.5) {
                Vector3::z()
            } else {
                Vector3::new(u.cos(), u.sin(), 0.0)
            };
            let tilt = UnitQuaternion::from_scaled_axis(Vector3::new(
                rng.gen_range(-0.3..0.3),
                rng.gen_range(-0.3..0.3),
                rng.gen_range(-0.3..0.3),
            ));
            let b = tilt * across;
            let spin = UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(b),
                rng.gen_range(0.0..std::f64::consts::TAU),
            );
            let to_b = UnitQuaternion::rotation_between(&Vector3::y(), &b)
                .unwrap_or_else(UnitQuaternion::identity);
            GripperPose {
                tool_pose: Isometry3::from_parts(
                    Translation3::from((frame * centre).coords),
                    frame.rotation * spin * to_b,
                ),
                width: 0.08,
                closing_axis: ClosingAxis::Y,
            }
        })
        .collect()
}

/// Parse alone, load and index, indexing alone, and the cache hit; the mesh, shared.
fn time_loading(path: &std::path::Path, triangles: usize) -> Arc<Mesh> {
    let resource = path.display().to_string();
    let index = AmentIndex::default();
    let scale = [0.001; 3];
    let parse_only = time(5, || parse(&resource, path).expect("parses"));
    let load_index = time(5, || load(&resource, scale, &index).expect("loads"));
    let (vertices, faces) = parse(&resource, path).expect("parses");
    let index_only = time(5, || {
        Mesh::from_triangles(&resource, &vertices, &faces, scale).expect("indexes")
    });
    let cache = MeshCache::new(index, 256 << 20);
    let mesh = cache.get(&resource, scale).expect("loads");
    let hit = time(5, || {
        for _ in 0..1000 {
            black_box(cache.get(&resource, scale).expect("kept"));
        }
    });
    println!(
        "mesh: {triangles} triangles, {} vertices after merging, {:.1} MB held, closed: {}",
        mesh.vertex_count(),
        mesh.bytes() as f64 / 1e6,
        mesh.is_closed()
    );
    println!("parse only (read + mesh-loader): {:.1} ms", ms(parse_only));
    println!(
        "load + index (parse, merge, closedness, volume, BVH, triangles at each vertex): {:.1} ms; indexing alone {:.1} ms",
        ms(load_index),
        ms(index_only)
    );
    println!("cache hit (resolve + lookup): {:.2} µs", ms(hit));
    mesh
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The contacts of each pose that touches, as the 3D solver's candidates.
fn cast_all(set: &[GripperPose], object: &Object) -> Vec<spatial::Candidate> {
    let com = center_of_mass(&object.pose, &object.shape, None).expect("closed");
    set.iter()
        .filter_map(|g| cast_fingers(g, object).ok())
        .map(|[c1, c2]| spatial::Candidate {
            contact_1: c1.point.coords,
            contact_2: c2.point.coords,
            normal_1: c1.normal.into_inner(),
            normal_2: c2.normal.into_inner(),
            friction_1: 0.5,
            friction_2: 0.5,
            center_of_mass: com.coords,
            mass: 0.3,
            gravity: Vector3::new(0.0, 0.0, -9.81),
        })
        .collect()
}

fn main() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("torus.stl");
    let triangles = write_torus_stl(&path, 250, 200);
    let mesh = time_loading(&path, triangles);

    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let frame = Isometry3::from_parts(Translation3::new(0.5, -0.2, 0.3), random_rotation(&mut rng));
    let object = Object {
        pose: frame,
        shape: Shape::Mesh(mesh),
    };
    let set = poses(&mut rng, &frame);
    let candidates = cast_all(&set, &object);
    let cast = time(9, || cast_all(&set, &object));
    println!(
        "cast 1,000 poses: {:.2} ms, {:.2} µs a pose ({} with two contacts)",
        ms(cast),
        ms(cast),
        candidates.len()
    );

    let settings = Settings::default();
    let contacts: Vec<spatial::Candidate> = candidates.iter().cycle().take(1000).copied().collect();
    let recommended = contacts
        .iter()
        .filter(|c| {
            matches!(
                spatial::solve(c, &settings),
                Ok(spatial::Verdict::Recommended(_))
            )
        })
        .count();
    let solve = time(9, || {
        contacts
            .iter()
            .filter(|c| spatial::solve(c, &settings).is_ok())
            .count()
    });
    println!("({recommended} of the 1,000 contact candidates have force closure)");
    println!(
        "3D solve of 1,000 contact candidates: {:.2} ms, {:.2} µs each",
        ms(solve),
        ms(solve)
    );
    println!(
        "poses : contacts = (cast + solve) / solve = {:.2} (target ≤ 3)",
        (cast + solve).as_secs_f64() / solve.as_secs_f64()
    );
}
