//! Property tests: the answer does not depend on the frame, the labelling or the units.

use crate::util::{random_grasp, wrap};
use approx::abs_diff_eq;
use grasp_orient::solver::{
    planar::{self, Candidate, GraspCase, Recommendation, Verdict},
    AllowedRange, Objective, Settings,
};
use nalgebra::{Rotation2, Vector2};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn solve(c: &Candidate, s: &Settings) -> Recommendation {
    match planar::solve(c, s) {
        Ok(Verdict::Recommended(r)) => *r,
        other => panic!("{other:?}"),
    }
}

fn grasp(seed: u64) -> Candidate {
    random_grasp(&mut ChaCha8Rng::seed_from_u64(seed))
}

fn settings(objective: u8, graspable: bool) -> Settings {
    Settings {
        objective: [Objective::Norm2, Objective::Norm1, Objective::InternalForce]
            [objective as usize % 3],
        range: if graspable {
            AllowedRange::Graspable
        } else {
            AllowedRange::FromAbove
        },
        friction_safety_factor: 1.0,
    }
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    abs_diff_eq!(a, b, epsilon = 1e-9 * scale.max(a.abs()).max(b.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Rotating and translating the whole scene (gravity included) changes nothing but the
    /// frame of the gravity direction.
    #[test]
    fn rigid_motion_of_the_scene(seed in any::<u64>(), angle in -3.2f64..3.2, dx in -5.0f64..5.0,
                                 dy in -5.0f64..5.0, objective in 0u8..3, graspable: bool) {
        let c = grasp(seed);
        let s = settings(objective, graspable);
        let rot = Rotation2::new(angle);
        let shift = Vector2::new(dx, dy);
        let moved = Candidate {
            contact_1: rot * c.contact_1 + shift,
            contact_2: rot * c.contact_2 + shift,
            normal_1: rot * c.normal_1,
            normal_2: rot * c.normal_2,
            center_of_mass: rot * c.center_of_mass + shift,
            gravity: rot * c.gravity,
            ..c
        };
        let (a, b) = (solve(&c, &s), solve(&moved, &s));
        let w = c.mass * c.gravity.norm();
        prop_assert!(wrap(a.wrist_rotation - b.wrist_rotation).abs() < 1e-7
            || close(a.gripping_power, b.gripping_power, w));
        prop_assert!(close(a.gripping_power, b.gripping_power, w));
        prop_assert!(close(a.gripping_power_current, b.gripping_power_current, w));
        prop_assert!((rot * a.gravity_direction - b.gravity_direction).norm() < 1e-7
            || close(a.gripping_power, b.gripping_power, w));
    }

    /// Swapping the labels of the two contacts swaps the forces and the labels that name a
    /// contact (A↔E, B↔D, case b↔c), and nothing else.
    #[test]
    fn relabelling_the_contacts(seed in any::<u64>(), objective in 0u8..3, graspable: bool) {
        let c = grasp(seed);
        let s = settings(objective, graspable);
        let swapped = Candidate {
            contact_1: c.contact_2,
            contact_2: c.contact_1,
            normal_1: c.normal_2,
            normal_2: c.normal_1,
            friction_1: c.friction_2,
            friction_2: c.friction_1,
            ..c
        };
        let (a, b) = (solve(&c, &s), solve(&swapped, &s));
        let w = c.mass * c.gravity.norm();
        prop_assert!(close(a.gripping_power, b.gripping_power, w));
        prop_assert!(wrap(a.wrist_rotation - b.wrist_rotation).abs() < 1e-9);
        prop_assert!(close(a.contact_forces[0], b.contact_forces[2], w));
        prop_assert!(close(a.contact_forces[1], b.contact_forces[3], w));
        prop_assert!(close(a.contact_forces[2], b.contact_forces[0], w));
        prop_assert!(close(a.contact_forces[3], b.contact_forces[1], w));
        prop_assert_eq!(a.local_minima.len(), b.local_minima.len());
        for (m, n) in a.local_minima.iter().zip(b.local_minima.iter()) {
            prop_assert_eq!(m.label, n.label.map(|l| l.relabelled()));
            prop_assert!(abs_diff_eq!(m.gravity_angle, n.gravity_angle, epsilon = 1e-9));
        }
        let swap_case = |g: GraspCase| match g {
            GraspCase::B => GraspCase::C,
            GraspCase::C => GraspCase::B,
            other => other,
        };
        prop_assert_eq!(a.grasp_case, swap_case(b.grasp_case));
    }

    /// Lengths in any unit give the same angles; forces scale with m |g|.
    #[test]
    fn units_and_weight(seed in any::<u64>(), length in 1e-3f64..1e3, weight in 1e-2f64..1e2,
                        objective in 0u8..3) {
        let c = grasp(seed);
        let s = settings(objective, false);
        let scaled = Candidate {
            contact_1: c.contact_1 * length,
            contact_2: c.contact_2 * length,
            center_of_mass: c.center_of_mass * length,
            mass: c.mass * weight,
            ..c
        };
        let (a, b) = (solve(&c, &s), solve(&scaled, &s));
        let w = c.mass * c.gravity.norm();
        prop_assert!(close(a.gripping_power * weight, b.gripping_power, w * weight));
        prop_assert!(close(a.internal_force * weight, b.internal_force, w * weight));
        prop_assert!(wrap(a.wrist_rotation - b.wrist_rotation).abs() < 1e-9
            || close(a.gripping_power * weight, b.gripping_power, w * weight));
        for k in 0..4 {
            prop_assert!(close(a.contact_forces[k] * weight, b.contact_forces[k], w * weight));
        }
    }

    /// The reported gravity direction is the current gravity turned by minus the wrist rotation,
    /// and the recommendation lies in the allowed range with its label rules.
    #[test]
    fn reported_quantities_agree(seed in any::<u64>(), objective in 0u8..3) {
        let c = grasp(seed);
        let r = solve(&c, &settings(objective, false));
        let turned = Rotation2::new(-r.wrist_rotation) * c.gravity.normalize();
        prop_assert!((turned - r.gravity_direction).norm() < 1e-12);
        prop_assert!(r.wrist_rotation > -std::f64::consts::PI && r.wrist_rotation <= std::f64::consts::PI);
        prop_assert!(r.gripping_power <= r.gripping_power_current * (1.0 + 1e-12)
            || !matches!(r.candidate_c, grasp_orient::solver::planar::CandidateC::OutOfRange));
    }
}
