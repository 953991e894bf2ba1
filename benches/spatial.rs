//! Spatial candidates against planar ones, per grasp, in one process.
//!
//! - The same 10,000 random planar grasps, solved as planar candidates and as spatial ones (lifted
//!   to 3D: all z equal, normals and gravity in the plane): the cost of the reduction itself.
//! - 10,000 random 3D grasps in random frames (tilted normals, centres of mass off or near the
//!   axis), against the planar time above.
//! - Centres of mass on the contact axis (an optimum over planes), reported separately.
//!
//! `cargo bench --bench spatial`

#[path = "../tests/it/util/mod.rs"]
#[allow(dead_code, unused_imports)] // a benchmark uses a part of the tests' helpers
mod common;

use common::random_grasp;
use common::spatial::{random_spatial_grasp, Kind};
use grasp_orient::solver::{planar, spatial, Objective, Settings};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

/// Best of `rounds` passes over `items`, ns per item.
fn time_per<T>(items: &[T], rounds: usize, mut f: impl FnMut(&T)) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..rounds {
        let t = Instant::now();
        for item in items {
            f(black_box(item));
        }
        best = best.min(t.elapsed().as_nanos() as f64 / items.len() as f64);
    }
    best
}

/// Longer than a screen: it reads top to bottom as the report it prints, one kind of grasp after
/// another, each against the planar baseline.
fn main() {
    let settings = Settings::default();
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let planar: Vec<_> = (0..10_000).map(|_| random_grasp(&mut rng)).collect();
    let lifted: Vec<spatial::Candidate> = planar
        .iter()
        .map(|p| {
            let lift = |v: nalgebra::Vector2<f64>, z: f64| Vector3::new(v.x, v.y, z);
            spatial::Candidate {
                contact_1: lift(p.contact_1, 0.25),
                contact_2: lift(p.contact_2, 0.25),
                normal_1: lift(p.normal_1, 0.0),
                normal_2: lift(p.normal_2, 0.0),
                friction_1: p.friction_1,
                friction_2: p.friction_2,
                center_of_mass: lift(p.center_of_mass, 0.25),
                mass: p.mass,
                gravity: lift(p.gravity, 0.0),
            }
        })
        .collect();
    let kinds_3d = [
        Kind::InPlane,
        Kind::Tilted,
        Kind::NearLimitTilt,
        Kind::NearAxis,
    ];
    let spatial_3d: Vec<_> = (0..10_000)
        .map(|k| random_spatial_grasp(&mut rng, kinds_3d[k % kinds_3d.len()]))
        .collect();
    let on_axis_kinds = [Kind::OnAxis, Kind::OnAxisCoplanar, Kind::OnAxisSymmetric];
    let on_axis: Vec<_> = (0..3_000)
        .map(|k| random_spatial_grasp(&mut rng, on_axis_kinds[k % on_axis_kinds.len()]))
        .collect();

    // Planar, lifted and 3D runs interleave in chunks of 100 grasps, and each chunk keeps its
    // best of `rounds`: load from other processes then falls on all three alike.
    let rounds = 15;
    let chunk = 100;
    let (mut t_planar, mut t_lifted, mut t_3d) = (0.0, 0.0, 0.0);
    for start in (0..planar.len()).step_by(chunk) {
        let end = start + chunk;
        let (mut bp, mut bl, mut b3) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for _ in 0..rounds {
            bp = bp.min(time_per(&planar[start..end], 1, |g| {
                black_box(planar::solve(g, &settings).ok());
            }));
            bl = bl.min(time_per(&lifted[start..end], 1, |g| {
                black_box(spatial::solve(g, &settings).ok());
            }));
            b3 = b3.min(time_per(&spatial_3d[start..end], 1, |g| {
                black_box(spatial::solve(g, &settings).ok());
            }));
        }
        let share = chunk as f64 / planar.len() as f64;
        t_planar += bp * share;
        t_lifted += bl * share;
        t_3d += b3 * share;
    }
    let t_axis = time_per(&on_axis, 3, |g| {
        black_box(spatial::solve(g, &settings).ok());
    });
    let internal = Settings {
        objective: Objective::InternalForce,
        ..settings
    };
    let t_axis_internal = time_per(&on_axis, 3, |g| {
        black_box(spatial::solve(g, &internal).ok());
    });
    let norm1 = Settings {
        objective: Objective::Norm1,
        ..settings
    };
    let t_axis_norm1 = time_per(&on_axis[..300], 1, |g| {
        black_box(spatial::solve(g, &norm1).ok());
    });

    println!("grasp_orient: spatial candidates against planar ones (2-norm, from-above range)");
    println!("{:<58}{:>12}{:>12}", "", "ns/grasp", "vs planar");
    let row = |name: &str, ns: f64| println!("{name:<58}{ns:>12.0}{:>12.2}", ns / t_planar);
    row("planar: 10,000 random planar grasps", t_planar);
    row("spatial: the same grasps lifted to 3D", t_lifted);
    row("spatial: 10,000 random 3D grasps (tilted, near axis)", t_3d);
    row("spatial, centre of mass on the axis: 3,000 grasps", t_axis);
    row("  the same, internal-force objective", t_axis_internal);
    row("  the same, 1-norm objective (300 grasps)", t_axis_norm1);
    println!(
        "(chunks of {chunk} grasps interleaved, best of {rounds} per chunk, one core; on-axis best \
         of 3 rounds, 1-norm one round)"
    );
}
