//! Criterion benchmark of the exact solver on a fixed set of random force-closure grasps.

#[path = "../tests/it/util/mod.rs"]
#[allow(dead_code, unused_imports)] // a benchmark uses a part of the tests' helpers
mod common;

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use grasp_orient::solver::{planar, AllowedRange, Objective, Settings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn bench(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let grasps: Vec<_> = (0..1000).map(|_| common::random_grasp(&mut rng)).collect();
    let mut group = c.benchmark_group("solve_orientation");
    group.throughput(Throughput::Elements(grasps.len() as u64));
    for (name, settings) in [
        ("norm2_from_above", Settings::default()),
        (
            "norm2_graspable",
            Settings {
                range: AllowedRange::Graspable,
                ..Settings::default()
            },
        ),
        (
            "norm1_from_above",
            Settings {
                objective: Objective::Norm1,
                ..Settings::default()
            },
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                for g in &grasps {
                    black_box(planar::solve(black_box(g), &settings).ok());
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
