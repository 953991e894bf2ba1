//! The worked example of `docs/uncertainty.md`: a bottle whose centre of mass is known to ±2 cm.
//!
//! `cargo run --example robust_bottle`

use grasp_orient::solver::{
    planar::{self, robust::Uncertainty, Candidate, Verdict},
    Settings,
};
use nalgebra::{Rotation2, Vector2};

fn main() {
    // A 1 L water bottle standing upright (x across, y up its axis, m), 8 cm across, pinched at
    // its sides 6 cm above the centre of mass; one rubber pad (μ 0.8), one worn (μ 0.5).
    let bottle = Candidate {
        contact_1: Vector2::new(0.04, 0.16),
        contact_2: Vector2::new(-0.04, 0.16),
        normal_1: Vector2::new(-1.0, 0.0),
        normal_2: Vector2::new(1.0, 0.0),
        friction_1: 0.8,
        friction_2: 0.5,
        center_of_mass: Vector2::new(0.0, 0.10),
        mass: 1.05,
        gravity: Vector2::new(0.0, -9.81),
    };
    let settings = Settings::default();
    let Ok(Verdict::Recommended(nominal)) = planar::solve(&bottle, &settings) else {
        panic!("the bottle can be held");
    };
    let tolerance = Uncertainty {
        center_of_mass_tolerance: Vector2::new(0.02, 0.02),
        mass_tolerance: 0.0,
    };
    let Ok(planar::robust::Verdict::Recommended(robust)) =
        planar::robust::solve(&bottle, &tolerance, &settings)
    else {
        panic!("every bottle in the box can be held from above");
    };
    // The worst case if the wrist turns to the nominal recommendation instead: the bottle posed
    // there, its current pose's worst case.
    let posed = Candidate {
        gravity: Rotation2::new(-nominal.wrist_rotation) * bottle.gravity,
        ..bottle
    };
    let Ok(planar::robust::Verdict::Recommended(at_nominal)) =
        planar::robust::solve(&posed, &tolerance, &settings)
    else {
        panic!("every bottle in the box can be held from above");
    };
    let deg = |r: f64| r.to_degrees();
    println!(
        "nominal bottle, its best pose: turn {:+.1}°, gripping power {:.2} N, squeeze {:.2} N",
        deg(nominal.wrist_rotation),
        nominal.gripping_power,
        nominal.internal_force
    );
    println!("±2 cm box, turned as for the nominal bottle: worst gripping power {:.2} N, worst squeeze {:.2} N",
        at_nominal.gripping_power_current, at_nominal.internal_force_current);
    println!("±2 cm box, its best pose: turn {:+.1}°, worst gripping power {:.2} N (at {}), worst squeeze {:.2} N, worst finger push {:.2} N; nominal bottle there {:.2} N",
        deg(robust.wrist_rotation), robust.gripping_power, robust.gripping_power_at,
        robust.internal_force, robust.finger_force, robust.gripping_power_nominal);
    println!(
        "held upright (no turn): worst gripping power {:.2} N, worst squeeze {:.2} N",
        robust.gripping_power_current, robust.internal_force_current
    );
}
