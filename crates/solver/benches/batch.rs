//! The batch path against the single path on the same grasps, in the same process: 1,000 and
//! 10,000 random planar grasps with force closure (norm2, from above), and as many random
//! spatial grasps off the contact axis, each answered one by one with `planar::solve` / `spatial::solve` (the answers
//! collected in a vector, as a caller of many grasps keeps them) and as one batch, on the calling thread alone and on the cores the machine has, in interleaved rounds
//! (the order turned each round, so that a slow moment slows all alike). Prints the median
//! time per grasp of each over the rounds and the ratios batch / single.
//!
//! `cargo bench -p grasp_orient_solver --bench batch` (an optional first argument: the number of
//! rounds of 1,000 grasps, 101 unless given; a tenth as many of 10,000).

#[path = "../tests/support/random.rs"]
#[allow(dead_code)] // the benchmark takes the grasps with force closure only
mod random;

use grasp_orient_solver::batch::{self, Threads};
use grasp_orient_solver::{planar, spatial, Settings};
use std::hint::black_box;
use std::time::Instant;

/// Grasps a batch holds: a set's size in the node's benchmarks, and ten times that (longer than
/// the scheduler takes to spread two busy threads over two cores).
const SIZES: [usize; 2] = [1_000, 10_000];

/// Nanoseconds per grasp of one call of `f` over `n` grasps.
fn per_grasp(n: usize, f: &mut dyn FnMut()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_nanos() as f64 / n as f64
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Times the three ways over `rounds` interleaved rounds and prints their medians and ratios.
fn compare(name: &str, n: usize, rounds: usize, ways: &mut [(&str, &mut dyn FnMut())]) {
    let mut times = vec![Vec::with_capacity(rounds); ways.len()];
    for round in 0..rounds {
        for k in 0..ways.len() {
            let k = (k + round) % ways.len();
            times[k].push(per_grasp(n, &mut *ways[k].1));
        }
    }
    let medians: Vec<f64> = times.iter_mut().map(|t| median(t)).collect();
    print!("{name}:");
    for ((label, _), m) in ways.iter().zip(&medians) {
        print!("  {label} {m:.0} ns/grasp");
    }
    println!();
    for ((label, _), m) in ways.iter().zip(&medians).skip(1) {
        println!("  {name} {label} / single = {:.3}", m / medians[0]);
    }
}

fn main() {
    let rounds = std::env::args()
        .skip(1)
        .find_map(|a| a.parse::<usize>().ok())
        .unwrap_or(101);
    let settings = Settings::default();
    let mut rng = random::Rng::new(42);
    let planar_grasps: Vec<_> = (0..SIZES[1])
        .map(|_| random::planar_grasp(&mut rng))
        .collect();
    // Off the contact axis (the on-axis search is a different problem, 10 to 300 times slower).
    let off_axis = |c: &spatial::Candidate| {
        let (a, r) = (c.contact_1 - c.contact_2, c.center_of_mass - c.contact_2);
        a.cross(&r).norm() > 1e-3 * a.norm() * r.norm()
    };
    let spatial_grasps: Vec<_> = std::iter::repeat_with(|| random::spatial_grasp(&mut rng))
        .filter(off_axis)
        .take(SIZES[1])
        .collect();
    for n in SIZES {
        let rounds = (rounds * SIZES[0] / n).max(11);
        let threads = Threads::Available.for_batch(n);
        println!("{n} grasps a batch, {rounds} rounds, batch on up to {threads} threads");
        let grasps = &planar_grasps[..n];
        let mut single = Vec::with_capacity(n);
        let (mut one, mut all) = (Vec::with_capacity(n), Vec::with_capacity(n));
        compare(
            "planar",
            n,
            rounds,
            &mut [
                ("single", &mut || {
                    single.clear();
                    single.extend(
                        black_box(grasps)
                            .iter()
                            .map(|g| planar::solve(g, &settings)),
                    );
                    black_box(&single);
                }),
                ("batch_1_thread", &mut || {
                    one.clear();
                    batch::planar_with(black_box(grasps), &settings, Threads::ONE, &mut one);
                    black_box(&one);
                }),
                ("batch", &mut || {
                    all.clear();
                    batch::planar(black_box(grasps), &settings, &mut all);
                    black_box(&all);
                }),
            ],
        );
        let grasps = &spatial_grasps[..n];
        let mut single = Vec::with_capacity(n);
        let (mut one, mut all) = (Vec::with_capacity(n), Vec::with_capacity(n));
        compare(
            "spatial",
            n,
            rounds,
            &mut [
                ("single", &mut || {
                    single.clear();
                    single.extend(
                        black_box(grasps)
                            .iter()
                            .map(|g| spatial::solve(g, &settings)),
                    );
                    black_box(&single);
                }),
                ("batch_1_thread", &mut || {
                    one.clear();
                    batch::spatial_with(black_box(grasps), &settings, Threads::ONE, &mut one);
                    black_box(&one);
                }),
                ("batch", &mut || {
                    all.clear();
                    batch::spatial(black_box(grasps), &settings, &mut all);
                    black_box(&all);
                }),
            ],
        );
    }
}
