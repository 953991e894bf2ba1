//! The robust planar solve (a box around the centre of mass plus a mass tolerance)
//! against today's nominal solve, on the same grasps, in one process. Prints ns per grasp for
//! both and their ratio, per objective and range. Target: the robust solve within 10× the
//! nominal one.
//!
//! `cargo bench --bench robust`
//!
//! The grasps are random force-closure grasps (`tests/it/util`) with box half-widths between 5 %
//! and 30 % of the contact distance along both axes and a mass tolerance between 5 % and 50 %.
//! Only those whose robust answer is a recommendation are timed (the full path: every vertex
//! analysed, the envelope walked, the answer evaluated); the share refused because the box
//! reaches across the contact line, which answer sooner, is printed too.

#[path = "../tests/it/util/mod.rs"]
#[allow(dead_code, unused_imports)] // a benchmark uses a part of the tests' helpers
mod common;

use common::random_grasp;
use grasp_orient::solver::{
    planar::{self, robust::Uncertainty, Candidate},
    AllowedRange, Objective, Settings,
};
use nalgebra::Vector2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

/// Nominal and robust timed in alternation, `rounds` times over the set: the best ns per grasp
/// of each, and the median of the rounds' ratios (alternation shares any load from other
/// processes between the two).
fn time_pair(rounds: usize, n: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64, f64) {
    let (mut best_a, mut best_b, mut ratios) = (f64::INFINITY, f64::INFINITY, Vec::new());
    for _ in 0..rounds {
        let t = Instant::now();
        a();
        let ta = t.elapsed().as_nanos() as f64 / n as f64;
        let t = Instant::now();
        b();
        let tb = t.elapsed().as_nanos() as f64 / n as f64;
        best_a = best_a.min(ta);
        best_b = best_b.min(tb);
        ratios.push(tb / ta);
    }
    ratios.sort_by(f64::total_cmp);
    (best_a, best_b, ratios[ratios.len() / 2])
}

/// Longer than a screen: it reads top to bottom as the report it prints, one measurement after
/// another, each with its baseline.
fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(2027);
    let mut cases: Vec<(Candidate, Uncertainty)> = Vec::new();
    let mut refused = 0;
    let mut tried = 0;
    while cases.len() < 5_000 {
        let c = random_grasp(&mut rng);
        let d = (c.contact_1 - c.contact_2).norm();
        let u = Uncertainty {
            center_of_mass_tolerance: Vector2::new(
                rng.gen_range(0.05..0.3) * d,
                rng.gen_range(0.05..0.3) * d,
            ),
            mass_tolerance: rng.gen_range(0.05..0.5) * c.mass,
        };
        tried += 1;
        match planar::robust::solve(&c, &u, &Settings::default()) {
            Ok(planar::robust::Verdict::Recommended(_)) => cases.push((c, u)),
            _ => refused += 1,
        }
    }
    println!(
        "robust (box + mass) vs nominal solve, per grasp, one core ({} grasps; {} of {} drawn \
         were refused from above because the box reaches across the contact line or no \
         orientation suits it, and are not timed)",
        cases.len(),
        refused,
        tried
    );
    println!(
        "{:<28}{:>14}{:>14}{:>10}{:>16}",
        "objective, range", "nominal ns", "robust ns", "ratio", "mean vertices"
    );
    for (name, objective, range) in [
        (
            "norm2, from above",
            Objective::Norm2,
            AllowedRange::FromAbove,
        ),
        (
            "norm2, graspable",
            Objective::Norm2,
            AllowedRange::Graspable,
        ),
        (
            "norm1, from above",
            Objective::Norm1,
            AllowedRange::FromAbove,
        ),
        (
            "internal_force, from above",
            Objective::InternalForce,
            AllowedRange::FromAbove,
        ),
    ] {
        let settings = Settings {
            objective,
            range,
            ..Settings::default()
        };
        let mut vertices = 0usize;
        let mut timed = 0usize;
        for (c, u) in &cases {
            if let Ok(planar::robust::Verdict::Recommended(r)) =
                planar::robust::solve(c, u, &settings)
            {
                vertices += r.region.len();
                timed += 1;
            }
        }
        let n = cases.len();
        let (nominal, robust, ratio) = time_pair(
            9,
            n,
            || {
                for (c, _) in &cases {
                    black_box(planar::solve(black_box(c), &settings).ok());
                }
            },
            || {
                for (c, u) in &cases {
                    black_box(planar::robust::solve(black_box(c), black_box(u), &settings).ok());
                }
            },
        );
        println!(
            "{name:<28}{nominal:>14.0}{robust:>14.0}{ratio:>10.2}{:>16.2}",
            vertices as f64 / timed.max(1) as f64
        );
    }
    println!(
        "(ns: best of 9 rounds over the set; ratio: median over the rounds, nominal and robust \
         timed in turn; target: ratio <= 10)"
    );
}
