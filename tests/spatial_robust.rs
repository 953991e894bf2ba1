//! The spatial robust solver (`src/solver/spatial/robust/`, work in progress) against the
//! independent 3D reference of `tests/common/spatial.rs` (Clarabel SOCP on the true circular
//! cones; no grasp planes, no sliced cones), at the recommended tilt θ*.
//!
//! The solver's model (its module docs §1): after the swing about the contact axis every object
//! of the region hangs in its own plane through the axis and its centre of mass `c`, at the same
//! tilt, so its gravity is `ĝ(c) = sin θ* a + cos θ* v(c)` with `a` the unit contact axis and
//! `v(c)` the unit direction from the axis to `c`. The reference is given only that direction,
//! the contacts, normals, friction and `c` with the largest mass; it solves the 3D problem on its
//! own. Checked, on random off-axis grasps with random boxes:
//! - the reported worst `gripping_power` equals the reference's value at the reported worst point
//!   (relative 1e-7, the reference's accuracy after polishing);
//! - no centre of mass of a dense grid over the box (those inside both tangent half-spaces, i.e.
//!   possible for a convex object) needs more than the reported worst case.
//!
//! What this does not check: that θ* is the least worst case over the allowed range, and the
//! swing model itself (it is the solver's reading of the problem, used by both sides here).

mod common;

use common::spatial::{random_spatial_grasp, Kind, SpatialReference};
use grasp_orient::solver::{
    solve_spatial_robust, Settings, SpatialCandidate, SpatialRobustVerdict, SpatialUncertainty,
};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The gravity under which an object whose centre of mass is at `c` hangs at tilt `theta`;
/// `None` on the axis.
fn hang(c: &SpatialCandidate, at: &Vector3<f64>, theta: f64) -> Option<Vector3<f64>> {
    let a = (c.contact_1 - c.contact_2).normalize();
    let r = at - c.contact_2;
    let across = r - a * r.dot(&a);
    if across.norm() <= 1e-9 * (c.contact_1 - c.contact_2).norm() {
        return None;
    }
    Some(a * theta.sin() + across.normalize() * theta.cos())
}

/// Whether `q` lies on the inner side of both tangent planes (a convex object can have its centre
/// of mass there).
fn possible(c: &SpatialCandidate, q: &Vector3<f64>) -> bool {
    c.normal_1.dot(&(q - c.contact_1)) >= 0.0 && c.normal_2.dot(&(q - c.contact_2)) >= 0.0
}

#[test]
fn worst_case_at_the_recommended_tilt_against_the_3d_reference() {
    let mut rng = ChaCha8Rng::seed_from_u64(1313);
    let settings = Settings::default();
    let (mut checked, mut samples, mut worst_gap) = (0, 0usize, 0f64);
    let mut worst_excess = f64::NEG_INFINITY;
    for k in 0..60 {
        let kind = if k % 2 == 0 {
            Kind::InPlane
        } else {
            Kind::Tilted
        };
        let c = random_spatial_grasp(&mut rng, kind);
        let d = (c.contact_1 - c.contact_2).norm();
        let t = Vector3::new(
            rng.gen_range(0.01..0.15) * d,
            rng.gen_range(0.01..0.15) * d,
            rng.gen_range(0.01..0.15) * d,
        );
        let u = SpatialUncertainty {
            center_of_mass_tolerance: t,
            mass_tolerance: rng.gen_range(0.0..0.3) * c.mass,
        };
        let Ok(SpatialRobustVerdict::Recommended(r)) = solve_spatial_robust(&c, &u, &settings)
        else {
            continue;
        };
        let heavy = SpatialCandidate {
            mass: r.mass_worst,
            ..c
        };
        let at = r.gripping_power_at.position;
        let reference = |q: &Vector3<f64>| {
            let object = SpatialCandidate {
                center_of_mass: *q,
                ..heavy
            };
            hang(&c, q, r.gravity_angle).map(|g| SpatialReference::new(&object, 1.0).power(&g))
        };
        if let Some(p) = reference(&at) {
            let gap = (p - r.gripping_power).abs() / r.gripping_power;
            worst_gap = worst_gap.max(gap);
            assert!(
                gap <= 1e-7,
                "grasp {k}: reported worst {} at {}, reference there {p}",
                r.gripping_power,
                r.gripping_power_at
            );
        }
        let n = 6;
        for i in 0..=n {
            for j in 0..=n {
                for l in 0..=n {
                    let s = |m: usize| 2.0 * m as f64 / n as f64 - 1.0;
                    let q = c.center_of_mass + Vector3::new(s(i) * t.x, s(j) * t.y, s(l) * t.z);
                    if !possible(&c, &q) {
                        continue;
                    }
                    let Some(p) = reference(&q) else { continue };
                    samples += 1;
                    let excess = (p - r.gripping_power) / r.gripping_power;
                    worst_excess = worst_excess.max(excess);
                    assert!(
                        excess <= 1e-7,
                        "grasp {k}: the centre of mass at {q:?} needs {p} N, more than the \
                         reported worst {} N",
                        r.gripping_power
                    );
                }
            }
        }
        checked += 1;
    }
    println!(
        "{checked} grasps, {samples} sampled centres of mass: reported worst vs reference at its \
         point {worst_gap:e} relative; the highest sample relative to it {worst_excess:e}"
    );
    assert!(
        checked >= 20,
        "only {checked} grasps could be held: the test is too weak"
    );
}
