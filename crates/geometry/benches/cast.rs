//! How long a 100,000-triangle mesh takes to parse, and to load and index; how long 1,000 poses
//! take to cast on it; and, in the same run, the 3D solve of the 1,000 contacts they give, for
//! the ratio "poses on a mesh" : "the same set given as contacts".
//!
//! `cargo bench -p grasp_orient_geometry --bench cast` prints the numbers (medians of repeats).

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use grasp_orient_geometry::{
    cast_fingers, center_of_mass, load, parse, AmentIndex, GripperPose, Mesh, MeshCache, Object,
    Shape,
};
use grasp_orient_solver::{spatial, Settings};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[path = "shared/torus.rs"]
mod torus;
use torus::{poses, random_rotation, write_torus_stl};

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
