//! The exact solver against a numerical baseline, on the same grasps, in one process:
//! the baseline scans the gravity angle at 1e-3 rad over the from-above range and solves the
//! 2-norm problem at each angle as a second-order cone program with Clarabel. Both are scored
//! against the independent reference of `tests/it/util` (dense scan with analytic slopes,
//! bisected to rounding). Prints ns per grasp, errors, and the ratios.
//!
//! `cargo bench --bench compare` (add `-- N` for N baseline grasps; default 40).

#[path = "../tests/it/util/mod.rs"]
#[allow(dead_code, unused_imports)] // a benchmark uses a part of the tests' helpers
mod common;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SecondOrderConeT, SolverStatus,
    SupportedConeT, ZeroConeT,
};
use common::{random_grasp, wrap, RefObjective, RefRange, Reference};
use grasp_orient::solver::{
    planar::{self, Candidate, Verdict},
    Settings,
};
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

fn rot(v: Vector2<f64>, a: f64) -> Vector2<f64> {
    let (s, c) = a.sin_cos();
    Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// The baseline's best rotation and power: scan at `step` rad, one SOCP per angle.
fn baseline(c: &Candidate, step: f64) -> (f64, f64) {
    let reference = Reference::new(c, 1.0, RefObjective::Norm2);
    let (start, len) = reference.arc(RefRange::FromAbove, c.gravity);
    let n1 = c.normal_1.normalize();
    let n2 = c.normal_2.normalize();
    let t1 = rot(n1, std::f64::consts::FRAC_PI_2);
    let t2 = rot(n2, std::f64::consts::FRAC_PI_2);
    let r1 = c.contact_1 - c.center_of_mass;
    let r2 = c.contact_2 - c.center_of_mass;
    let cross = |a: Vector2<f64>, b: Vector2<f64>| a.x * b.y - a.y * b.x;
    let (mu1, mu2) = (c.friction_1, c.friction_2);
    // Variables (t, N1, F1, N2, F2); minimise t with ||F|| <= t.
    let p = CscMatrix::<f64>::zeros((5, 5));
    let q = vec![1.0, 0.0, 0.0, 0.0, 0.0];
    let a = CscMatrix::from(&[
        // L F = b (zero cone)
        [0.0, n1.x, t1.x, n2.x, t2.x],
        [0.0, n1.y, t1.y, n2.y, t2.y],
        [
            0.0,
            cross(r1, n1),
            cross(r1, t1),
            cross(r2, n2),
            cross(r2, t2),
        ],
        // -a·F + s = 0, s >= 0 (nonnegative cone)
        [0.0, -1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, -1.0, 0.0],
        [0.0, -mu1, 1.0, 0.0, 0.0],
        [0.0, -mu1, -1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, -mu2, 1.0],
        [0.0, 0.0, 0.0, -mu2, -1.0],
        // -(t, F) + s = 0, s in the second-order cone
        [-1.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, -1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, -1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, -1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, -1.0],
    ]);
    let cones: [SupportedConeT<f64>; 3] = [ZeroConeT(3), NonnegativeConeT(6), SecondOrderConeT(5)];
    let steps = (len / step).ceil() as usize;
    let mut best = (start, f64::INFINITY);
    for k in 0..=steps {
        let w = start + len * k as f64 / steps as f64;
        let g = rot(c.gravity * c.mass, -w);
        let mut b = vec![0.0; 14];
        b[0] = -g.x;
        b[1] = -g.y;
        let settings = DefaultSettings {
            verbose: false,
            ..DefaultSettings::default()
        };
        let Ok(mut solver) = DefaultSolver::new(&p, &q, &a, &b, &cones, settings) else {
            continue;
        };
        solver.solve();
        if matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        ) && solver.solution.obj_val < best.1
        {
            best = (w, solver.solution.obj_val);
        }
    }
    best
}

fn main() {
    let n_base: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(40);
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let grasps: Vec<Candidate> = (0..10_000).map(|_| random_grasp(&mut rng)).collect();
    let settings = Settings::default();

    // Exact solver: time over the whole set, several rounds, best round.
    let mut exact_ns = f64::INFINITY;
    for _ in 0..7 {
        let t = Instant::now();
        for g in &grasps {
            black_box(planar::solve(black_box(g), &settings).ok());
        }
        exact_ns = exact_ns.min(t.elapsed().as_nanos() as f64 / grasps.len() as f64);
    }

    // Baseline on the first n_base grasps.
    let t = Instant::now();
    let base: Vec<(f64, f64)> = grasps[..n_base].iter().map(|g| baseline(g, 1e-3)).collect();
    let base_ns = t.elapsed().as_nanos() as f64 / n_base as f64;

    // Errors of both against the reference, on the same grasps.
    let (mut e_angle, mut e_power, mut b_angle, mut b_power) = (0f64, 0f64, 0f64, 0f64);
    for (g, (bw, bp)) in grasps[..n_base].iter().zip(&base) {
        let reference = Reference::new(g, 1.0, RefObjective::Norm2);
        let (rw, rp) = reference.minimise(RefRange::FromAbove, g.gravity, 20_000);
        let Ok(Verdict::Recommended(r)) = planar::solve(g, &settings) else {
            panic!("force-closure grasp refused")
        };
        e_angle = e_angle.max(wrap(r.wrist_rotation - rw).abs());
        e_power = e_power.max((r.gripping_power - rp).abs() / rp);
        b_angle = b_angle.max(wrap(bw - rw).abs());
        b_power = b_power.max((bp - rp).abs() / rp);
    }
    // An error below rounding is reported as one ulp of the angle, so ratios stay finite.
    let floor = f64::EPSILON;
    println!(
        "grasp_orient exact solver vs scan + SOCP (Clarabel) baseline, 2-norm, from-above range"
    );
    println!("{:<34}{:>16}{:>16}{:>14}", "", "exact", "baseline", "ratio");
    println!(
        "{:<34}{:>16.0}{:>16.0}{:>14.0}",
        "time per grasp, ns",
        exact_ns,
        base_ns,
        base_ns / exact_ns
    );
    println!(
        "{:<34}{:>16.2e}{:>16.2e}{:>14.2e}",
        "worst angle error vs reference, rad",
        e_angle,
        b_angle,
        b_angle / e_angle.max(floor)
    );
    println!(
        "{:<34}{:>16.2e}{:>16.2e}{:>14.2e}",
        "worst power error, relative",
        e_power,
        b_power,
        b_power / e_power.max(floor)
    );
    println!(
        "(exact timed on {} grasps, best of 7 rounds, one core; baseline and errors on {} grasps)",
        grasps.len(),
        n_base
    );
}
