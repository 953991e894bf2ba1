//! The force a gripper is set to, against the independent reference (`tests/it/util`): the
//! reference's contact forces, built in the candidate's own frame, are projected on the line
//! between the contacts. Coupled fingers give the mean of the two pushes, which must be the
//! reported `internal_force`; independent fingers each give their own, the larger of which must be
//! the reported `finger_force`. Both at the recommended pose and at the current one, on random
//! force-closure grasps in random frames, for every objective.

use crate::util::{random_grasp, RefObjective, RefPoint, Reference};
use grasp_orient::solver::{
    planar::{self, Candidate, Verdict},
    AllowedRange, Objective, Settings,
};
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Agreement asked, relative to the larger of the force and the weight `m |g|` (as
/// `tests/it/reference.rs` asks of the power at the current pose).
const TOL: f64 = 1e-9;

/// The pushes of contact 1 and contact 2 along the line between them, into the object: each
/// contact force (normal along the unit inward normal, friction along it turned +90°) dotted with
/// the unit vector towards the other contact.
fn pushes(c: &Candidate, p: &RefPoint) -> [f64; 2] {
    let turn = |v: Vector2<f64>| Vector2::new(-v.y, v.x);
    let n1 = c.normal_1.normalize();
    let n2 = c.normal_2.normalize();
    let f1 = n1 * p.forces[0] + turn(n1) * p.forces[1];
    let f2 = n2 * p.forces[2] + turn(n2) * p.forces[3];
    let towards_2 = (c.contact_2 - c.contact_1).normalize();
    [f1.dot(&towards_2), f2.dot(&-towards_2)]
}

fn check(seed: u64, count: usize, settings: Settings, objective: RefObjective) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut worst_mean, mut worst_max) = (0.0f64, 0.0f64);
    for _ in 0..count {
        let c = random_grasp(&mut rng);
        let r = match planar::solve(&c, &settings) {
            Ok(Verdict::Recommended(r)) => r,
            other => panic!("a force-closure grasp was refused: {other:?}; grasp {c:?}"),
        };
        let reference = Reference::new(&c, settings.friction_safety_factor, objective);
        let weight = c.mass * c.gravity.norm();
        for (pose, omega, internal, finger) in [
            (
                "recommended",
                r.wrist_rotation,
                r.internal_force,
                r.finger_force,
            ),
            (
                "current",
                0.0,
                r.internal_force_current,
                r.finger_force_current,
            ),
        ] {
            let at = reference
                .at(omega)
                .unwrap_or_else(|| panic!("the reference cannot hold the {pose} pose of {c:?}"));
            let [a1, a2] = pushes(&c, &at);
            let scale = weight.max(a1.abs()).max(a2.abs());
            let mean_err = (0.5 * (a1 + a2) - internal).abs() / scale;
            let max_err = (a1.max(a2) - finger).abs() / scale;
            assert!(
                mean_err <= TOL && max_err <= TOL,
                "{pose} pose: reference pushes {a1}, {a2} (mean {}, max {}); solver internal force \
                 {internal}, finger force {finger}; grasp {c:?}",
                0.5 * (a1 + a2),
                a1.max(a2)
            );
            worst_mean = worst_mean.max(mean_err);
            worst_max = worst_max.max(max_err);
        }
    }
    (worst_mean, worst_max)
}

#[test]
fn both_grip_forces_match_the_reference_projected_on_the_contact_line() {
    let runs = [
        (11, Settings::default(), RefObjective::Norm2),
        (
            12,
            Settings {
                objective: Objective::Norm1,
                range: AllowedRange::Graspable,
                ..Settings::default()
            },
            RefObjective::Norm1,
        ),
        (
            13,
            Settings {
                objective: Objective::InternalForce,
                range: AllowedRange::Graspable,
                ..Settings::default()
            },
            RefObjective::InternalForce,
        ),
    ];
    for (seed, settings, objective) in runs {
        let (mean, max) = check(seed, 2_000, settings, objective);
        println!(
            "{objective:?}: 2000 grasps, worst error of the mean push {mean:.2e}, of the larger \
             push {max:.2e} (relative)"
        );
    }
}

/// The finger the weight leans on pushes more: with the weight along the line, the larger push
/// exceeds the mean by half the weight's component along the line (checked by the reference's own
/// forces, not by the solver's formula).
#[test]
fn pushes_differ_by_the_weight_along_the_line() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    for _ in 0..500 {
        let c = random_grasp(&mut rng);
        let reference = Reference::new(&c, 1.0, RefObjective::Norm2);
        let at = reference.at(0.0).expect("force closure holds every pose");
        let [a1, a2] = pushes(&c, &at);
        let towards_1 = (c.contact_1 - c.contact_2).normalize();
        let w_line = (c.gravity * c.mass).dot(&towards_1);
        let scale = (c.mass * c.gravity.norm()).max(a1.abs()).max(a2.abs());
        assert!(
            ((a1 - a2) - w_line).abs() <= TOL * scale,
            "a1 - a2 = {} but the weight along the line is {w_line}; grasp {c:?}",
            a1 - a2
        );
    }
}
