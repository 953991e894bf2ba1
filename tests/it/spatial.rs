//! Spatial candidates against the independent 3D reference of
//! `tests/it/util/spatial.rs` (two 3D force vectors, circular cones, SOCP by Clarabel), on random
//! grasps in random 3D frames: tilted normals, tilts near the friction angle, centres of mass on
//! and near the contact axis.
//!
//! The long version of the scans (2,000 grasps; a few minutes on one core, 12 minutes on a busy
//! shared machine) runs with `cargo test --release --test it spatial::no_reference -- --ignored --nocapture`.

use crate::util::spatial::{
    random_spatial_grasp, random_spatial_grasp_behind, Held, Kind, RefRange, SpatialReference,
};
use crate::util::{random_grasp, wrap};
use grasp_orient::solver::{
    planar::{self, Recommendation, Verdict},
    spatial::{self, AxisRelation, CurrentPose},
    AllowedRange, Contact, InvalidInput, Objective, Settings,
};
use nalgebra::{Rotation3, Unit, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;

/// Agreement with the SOCP reference: its accuracy.
const SOCP_TOL: f64 = 1e-7;

/// Every kind, with how many of each in a block of 20 grasps.
const MIX: [(Kind, usize); 7] = [
    (Kind::InPlane, 3),
    (Kind::Tilted, 5),
    (Kind::NearLimitTilt, 2),
    (Kind::NearAxis, 3),
    (Kind::OnAxis, 4),
    (Kind::OnAxisSymmetric, 1),
    (Kind::OnAxisCoplanar, 2),
];

fn kinds(count: usize) -> impl Iterator<Item = Kind> {
    MIX.iter()
        .flat_map(|&(k, n)| std::iter::repeat_n(k, n))
        .cycle()
        .take(count)
}

fn spatial(c: &spatial::Candidate, s: &Settings) -> spatial::Recommendation {
    match spatial::solve(c, s) {
        Ok(spatial::Verdict::Recommended(r)) => *r,
        other => panic!("spatial solver refused a force-closure grasp {c:?}: {other:?}"),
    }
}

/// Worst errors per kind of grasp.
#[derive(Debug, Default, Clone, Copy)]
struct Worst {
    grasps: usize,
    power: f64,
    current: f64,
    balance: f64,
    rotation: f64,
    swings: usize,
    /// Clarabel's optimum against the polished one, and how often it gave none.
    clarabel: f64,
    clarabel_failed: usize,
}

/// Rodrigues: the rotation about unit `k` by `angle` applied to `v`.
fn rotate(k: &Vector3<f64>, angle: f64, v: &Vector3<f64>) -> Vector3<f64> {
    let (s, c) = angle.sin_cos();
    v * c + k.cross(v) * s + k * (k.dot(v) * (1.0 - c))
}

/// Everything checkable at the solver's own answer: the reference's power there, the solver's
/// forces against the 3D balance and cones, the rotation, and the current pose; one block of
/// checks per part of the answer, in the answer's order, each with the tolerance it needs.
fn check_answer(c: &spatial::Candidate, s: &Settings, worst: &mut Worst) {
    let r = spatial(c, s);
    let reference = SpatialReference::new(c, s.friction_safety_factor);
    let weight = c.mass * c.gravity.norm();
    let scale = r.planar.gripping_power.max(weight);
    // 1. The reference's least power with gravity where the solver puts it.
    let held = reference.at(&r.gravity_direction);
    let Held::Yes {
        power,
        clarabel,
        squeeze,
        forces,
    } = held
    else {
        panic!("reference: {held:?} at the solver's pose; grasp {c:?}, answer {r:?}");
    };
    note_clarabel(worst, clarabel, power, scale, c);
    // The objective at the solver's pose, and the squeeze there (which the reference's least-norm
    // forces share with the solver's: both take the least squeeze not below zero).
    let want = match s.objective {
        Objective::Norm2 => power,
        Objective::InternalForce => squeeze,
        Objective::Norm1 => panic!("the reference minimises the 2-norm or the squeeze"),
    };
    let err = ((want - r.planar.gripping_power).abs() / scale)
        .max((squeeze - r.planar.internal_force).abs() / scale);
    assert!(
        err <= SOCP_TOL,
        "objective at the solver's pose: solver {} (squeeze {}) reference {want} (squeeze \
         {squeeze}) ({err:e}); grasp {c:?}",
        r.planar.gripping_power,
        r.planar.internal_force
    );
    worst.power = worst.power.max(err);
    // The finger force: the larger push of the reference's forces along the contact line.
    let finger = pushes(c, &forces);
    let finger_err = (finger - r.planar.finger_force).abs() / scale;
    assert!(
        finger_err <= SOCP_TOL,
        "finger force: solver {} reference {finger} ({finger_err:e}); grasp {c:?}",
        r.planar.finger_force
    );
    worst.power = worst.power.max(finger_err);
    // 2. The solver's own forces hold the object in 3D, inside the true cones.
    let balance = balance_error(c, s, &r, scale);
    assert!(balance <= 1e-9, "solver's forces: {balance:e}; grasp {c:?}");
    worst.balance = worst.balance.max(balance);
    // 3. The rotation turns the current gravity into the recommended one, and is the smallest.
    let rot_err = rotation_error(c, &r);
    assert!(
        rot_err <= 1e-9 && (0.0..=std::f64::consts::PI).contains(&r.rotation_angle),
        "rotation: {rot_err:e}; grasp {c:?}, answer {r:?}"
    );
    worst.rotation = worst.rotation.max(rot_err);
    // 4. The current pose: held with the reference's power, or the reference cannot hold it.
    match (r.current_pose, reference.at(&c.gravity)) {
        (CurrentPose::Held, held @ Held::Yes { .. }) => {
            let power = match s.objective {
                Objective::InternalForce => held.squeeze(),
                _ => held.power(),
            }
            .expect("held");
            let err = (power - r.planar.gripping_power_current).abs()
                / r.planar.gripping_power_current.max(1e-3 * weight);
            assert!(
                err <= SOCP_TOL,
                "current power: solver {} reference {power}; grasp {c:?}",
                r.planar.gripping_power_current
            );
            let Held::Yes { forces, .. } = held else {
                unreachable!("matched above")
            };
            let finger = pushes(c, &forces);
            let finger_err = (finger - r.planar.finger_force_current).abs()
                / r.planar.finger_force_current.max(1e-3 * weight);
            assert!(
                finger_err <= SOCP_TOL,
                "current finger force: solver {} reference {finger}; grasp {c:?}",
                r.planar.finger_force_current
            );
            worst.current = worst.current.max(err).max(finger_err);
        }
        (CurrentPose::Swings { out_of_plane }, Held::No) => {
            assert!(r.planar.gripping_power_current.is_infinite());
            assert!(r.planar.finger_force_current.is_infinite());
            assert!(out_of_plane > 0.0);
            worst.swings += 1;
        }
        (pose, held) => panic!("current pose {pose:?} but the reference says {held:?}; {c:?}"),
    }
    worst.grasps += 1;
}

/// Clarabel's own optimum agrees with its polished one, relative to `scale` (or Clarabel failed,
/// which is counted).
fn note_clarabel(
    worst: &mut Worst,
    clarabel: Option<f64>,
    power: f64,
    scale: f64,
    c: &spatial::Candidate,
) {
    match clarabel {
        Some(p) => {
            let gap = (p - power).abs() / scale;
            assert!(
                gap <= 1e-5,
                "Clarabel {p} and its polish {power} disagree; {c:?}"
            );
            worst.clarabel = worst.clarabel.max(gap);
        }
        None => worst.clarabel_failed += 1,
    }
}

/// How far the solver's 3D contact forces are from holding the object inside the true cones, in
/// units of the weight (and, under the 2-norm, how far their norm is from the reported power,
/// relative to `scale`).
fn balance_error(
    c: &spatial::Candidate,
    s: &Settings,
    r: &spatial::Recommendation,
    scale: f64,
) -> f64 {
    let weight = c.mass * c.gravity.norm();
    let [f1, f2] = r.force_vectors;
    let w = r.gravity_direction * weight;
    let d = (c.contact_1 - c.contact_2).norm();
    let force = (f1 + f2 + w).norm() / weight;
    let moment = ((c.contact_1 - c.center_of_mass).cross(&f1)
        + (c.contact_2 - c.center_of_mass).cross(&f2))
    .norm()
        / (weight * d);
    let mut balance = force.max(moment);
    for (f, n, mu) in [
        (f1, c.normal_1, c.friction_1),
        (f2, c.normal_2, c.friction_2),
    ] {
        let mu = mu / s.friction_safety_factor;
        let n = n.normalize();
        let along = f.dot(&n);
        let across = (f - n * along).norm();
        // Outside the cone by this much of the weight (negative inside).
        balance = balance.max((across - mu * along) / (weight * (1.0 + mu)));
    }
    let norm = (f1.norm_squared() + f2.norm_squared()).sqrt();
    if s.objective == Objective::Norm2 {
        balance = balance.max((norm - r.planar.gripping_power).abs() / scale);
    }
    balance
}

/// How far the reported rotation is from turning the current gravity into the recommended one by
/// the smallest angle, about a unit axis.
fn rotation_error(c: &spatial::Candidate, r: &spatial::Recommendation) -> f64 {
    let g0 = c.gravity.normalize();
    let k = r.rotation_axis;
    let turned = rotate(&k, -r.rotation_angle, &g0);
    let smallest = g0
        .cross(&r.gravity_direction)
        .norm()
        .atan2(g0.dot(&r.gravity_direction));
    (turned - r.gravity_direction)
        .norm()
        .max((smallest - r.rotation_angle).abs())
        .max((k.norm() - 1.0).abs())
}

/// The larger push of two 3D contact forces along the contact line, into the object, N: what
/// `finger_force` reports (`crates/solver/src/planar/finger.rs`), computed here from the forces themselves.
fn pushes(c: &spatial::Candidate, forces: &[Vector3<f64>; 2]) -> f64 {
    let line = (c.contact_2 - c.contact_1).normalize();
    forces[0].dot(&line).max(-forces[1].dot(&line))
}

fn report(title: &str, tally: &BTreeMap<String, Worst>) {
    println!("{title}");
    let mut total = 0;
    for (kind, w) in tally {
        total += w.grasps;
        println!(
            "  {kind:<16} {:>5} grasps: power vs reference {:.1e}, current {:.1e} ({} swing), \
             forces {:.1e}, rotation {:.1e}; Clarabel before polishing {:.1e} ({} without answer)",
            w.grasps,
            w.power,
            w.current,
            w.swings,
            w.balance,
            w.rotation,
            w.clarabel,
            w.clarabel_failed
        );
    }
    println!("  total {total}");
}

fn run_pose_checks(seed: u64, count: usize, settings: &Settings) -> usize {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut tally: BTreeMap<String, Worst> = BTreeMap::new();
    for kind in kinds(count) {
        let c = random_spatial_grasp(&mut rng, kind);
        check_answer(&c, settings, tally.entry(format!("{kind:?}")).or_default());
    }
    report(&format!("{settings:?}"), &tally);
    tally.values().map(|w| w.grasps).sum()
}

/// The solver's power at its own pose equals the reference's on 2,000 random spatial grasps of
/// every kind, with its 3D forces, rotation and current pose checked too.
#[test]
fn power_at_the_solvers_pose_matches_the_reference_on_2000_grasps() {
    let n = run_pose_checks(11, 2000, &Settings::default());
    assert_eq!(n, 2000);
}

/// The same with the graspable range, the internal-force objective and a friction safety factor
/// (which slices `μ / s`).
#[test]
fn graspable_range_internal_force_and_safety_factor_match_the_reference() {
    let settings = Settings {
        range: AllowedRange::Graspable,
        friction_safety_factor: 1.0,
        ..Settings::default()
    };
    run_pose_checks(12, 300, &settings);
    let settings = Settings {
        objective: Objective::InternalForce,
        ..settings
    };
    run_pose_checks(14, 300, &settings);
    // A safety factor loses some grasps; the rest must still match.
    let settings = Settings {
        friction_safety_factor: 1.2,
        ..Settings::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let (mut held, mut lost) = (0, 0);
    let mut worst = Worst::default();
    for kind in kinds(400) {
        let c = random_spatial_grasp(&mut rng, kind);
        match spatial::solve(&c, &settings) {
            Ok(spatial::Verdict::Recommended(_)) => {
                check_answer(&c, &settings, &mut worst);
                held += 1;
            }
            Ok(spatial::Verdict::NoForceClosure(why)) => {
                // Every miss is what it says: a tilt beyond the friction angle, or a sliced cone
                // that misses the other contact.
                for m in &why.misses {
                    match m {
                        spatial::Miss::Tilted {
                            tilt, half_angle, ..
                        } => assert!(tilt >= half_angle),
                        spatial::Miss::Cone(m) => assert!(m.angle_to_other >= m.half_angle),
                    }
                }
                lost += 1;
            }
            Err(e) => panic!("valid grasp refused: {e}"),
        }
    }
    println!(
        "safety factor 1.2: {held} held (worst power error {:.1e}), {lost} lost",
        worst.power
    );
    assert!(lost > 0 && held > 0);
}

/// `spatial::analyse` (what `plot` draws for a spatial candidate) is the objective over Π: its
/// recommendation is `spatial::solve`'s, and its power at every gravity angle of the graspable range
/// equals the reference's with gravity along that angle's direction in Π (the paper frame of Π is
/// right-handed about `plane_normal`, so the direction at `θ` is the recommended one turned by
/// `θ − θ*` about it).
#[test]
fn analysis_in_the_plane_is_the_objective_over_the_plane() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let settings = Settings::default();
    let mut worst = 0f64;
    for kind in kinds(60) {
        let c = random_spatial_grasp(&mut rng, kind);
        let (analysis, r) = match spatial::analyse(&c, &settings) {
            Ok(Ok(pair)) => pair,
            other => panic!("spatial::analyse refused a force-closure grasp {c:?}: {other:?}"),
        };
        assert_eq!(r, spatial(&c, &settings));
        let again = analysis.recommend(&settings.range).expect("the same range");
        let weight = c.mass * c.gravity.norm();
        let scale = r.planar.gripping_power.max(weight);
        assert!((again.gripping_power - r.planar.gripping_power).abs() <= 1e-12 * scale);
        assert!((again.gravity_angle - r.planar.gravity_angle).abs() <= 1e-12);
        let reference = SpatialReference::new(&c, 1.0);
        let (lo, hi) = analysis.graspable_range();
        for k in 1..8 {
            let theta = lo + (hi - lo) * k as f64 / 8.0;
            let dir = rotate(
                &r.plane_normal,
                theta - r.planar.gravity_angle,
                &r.gravity_direction,
            );
            let want = reference
                .at(&dir)
                .power()
                .unwrap_or_else(|| panic!("{kind:?}: the reference cannot hold θ = {theta}"));
            let got = analysis.evaluate(theta).power;
            // Relative to the power compared: near the friction angle it reaches 1e5 weights.
            let err = (got - want).abs() / want.max(scale);
            assert!(
                err <= SOCP_TOL,
                "{kind:?} θ = {theta}: analysis {got}, reference {want} ({err:e}); {c:?}"
            );
            worst = worst.max(err);
        }
    }
    println!("analysis over Π against the reference: worst {worst:.1e}");
}

/// No gravity direction the reference finds, scanning the allowed directions of the plane (or
/// the sphere, on the axis) and refining, is lower than the solver's answer.
fn run_scans(
    seed: u64,
    count: usize,
    settings: &Settings,
    plane: (usize, usize),
    sphere: (usize, usize, usize),
) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let range = match settings.range {
        AllowedRange::FromAbove => RefRange::FromAbove,
        AllowedRange::Graspable => RefRange::Graspable,
        AllowedRange::Bounds { .. } => panic!("the reference scans the named ranges"),
    };
    let mut tally: BTreeMap<String, (usize, f64, f64)> = BTreeMap::new();
    let fresh = (0, f64::NEG_INFINITY, 0.0);
    for kind in kinds(count) {
        let c = random_spatial_grasp(&mut rng, kind);
        let (below, angle) = scan_one(&c, settings, range, plane, sphere);
        let e = tally.entry(format!("{kind:?}")).or_insert(fresh);
        e.0 += 1;
        e.1 = e.1.max(below);
        e.2 = e.2.max(angle);
    }
    println!("{settings:?}");
    for (kind, (n, below, angle)) in &tally {
        println!(
            "  {kind:<16} {n:>5} grasps: solver above the reference's best by at most {below:.1e} \
             (negative: below); directions up to {angle:.1e} rad apart"
        );
    }
}

/// The reference's scan of one grasp against the solver's answer: how far the solver's objective
/// lies above the reference's best (relative to it or the weight; at most `SOCP_TOL`, asserted)
/// and the angle between their directions.
fn scan_one(
    c: &spatial::Candidate,
    settings: &Settings,
    range: RefRange,
    plane: (usize, usize),
    sphere: (usize, usize, usize),
) -> (f64, f64) {
    let squeeze = settings.objective == Objective::InternalForce;
    let r = spatial(c, settings);
    let reference = SpatialReference::new(c, 1.0);
    let (dir, best) = if r.axis == AxisRelation::OnAxis {
        assert!(reference.on_axis());
        reference.scan_sphere(squeeze, sphere.0, sphere.1, sphere.2)
    } else {
        reference.scan_plane(range, squeeze, plane.0, plane.1)
    };
    let weight = c.mass * c.gravity.norm();
    let scale = best.max(weight);
    let below = (r.planar.gripping_power - best) / scale;
    assert!(
        below <= SOCP_TOL,
        "reference found {best} at {dir:?}, below the solver's {} at {:?} ({:?} there); \
         grasp {c:?}",
        r.planar.gripping_power,
        r.gravity_direction,
        reference.at(&r.gravity_direction),
    );
    let angle = dir
        .cross(&r.gravity_direction)
        .norm()
        .atan2(dir.dot(&r.gravity_direction));
    (below, angle)
}

/// The 360 grasps of the tests below, drawn once for the three (a grasp with the centre of mass
/// behind both tangents takes many draws): each with its kind and sides.
fn grasps_behind_a_tangent() -> &'static [(Kind, [bool; 2], spatial::Candidate)] {
    static GRASPS: std::sync::OnceLock<Vec<(Kind, [bool; 2], spatial::Candidate)>> =
        std::sync::OnceLock::new();
    GRASPS.get_or_init(|| {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        let sides = [[true, false], [false, true], [true, true]];
        let kinds = [Kind::InPlane, Kind::Tilted, Kind::NearLimitTilt];
        (0..360)
            .map(|k| {
                let (kind, behind) = (kinds[(k / 3) % 3], sides[k % 3]);
                (
                    kind,
                    behind,
                    random_spatial_grasp_behind(&mut rng, kind, behind),
                )
            })
            .collect()
    })
}

/// Objects that are not convex: the centre of mass behind the tangent plane at contact 1, at
/// contact 2, or at both (`docs/theory.md#a-centre-of-mass-behind-a-tangent`), off the axis. The
/// solver answers all 360 and agrees with the 3D reference at its own pose (the objective, the
/// finger force, its forces in the true cones, the rotation, the current pose: `check_answer`);
/// and on 90 of them no direction the reference's scan finds is lower (`scan_one`), from above
/// and graspable, for the 2-norm and the squeeze.
///
/// The three sides are three tests, `k % 3 == part`, so that the test harness runs them side by
/// side, on the grasps drawn once for the three.
fn center_of_mass_behind_a_tangent_part(part: usize) {
    let graspable = Settings {
        range: AllowedRange::Graspable,
        ..Settings::default()
    };
    let squeeze = Settings {
        objective: Objective::InternalForce,
        ..graspable
    };
    let mut tally: BTreeMap<String, Worst> = BTreeMap::new();
    let (mut scanned, mut worst_below) = (0, f64::NEG_INFINITY);
    for (k, (kind, behind, c)) in grasps_behind_a_tangent().iter().enumerate() {
        let (kind, behind) = (*kind, *behind);
        if k % 3 != part {
            continue;
        }
        let settings = [Settings::default(), graspable, squeeze][(k / 9) % 3];
        let label = format!("{kind:?} behind {behind:?}");
        check_answer(c, &settings, tally.entry(label).or_default());
        if k % 4 == 0 {
            let range = match settings.range {
                AllowedRange::FromAbove => RefRange::FromAbove,
                _ => RefRange::Graspable,
            };
            let (below, _) = scan_one(c, &settings, range, (48, 2), (8, 16, 2));
            worst_below = worst_below.max(below);
            scanned += 1;
        }
    }
    report("centre of mass behind a tangent", &tally);
    println!("  scanned {scanned}: solver above the reference's best by at most {worst_below:.1e}");
    assert_eq!(tally.values().map(|w| w.grasps).sum::<usize>(), 120);
    assert_eq!(scanned, 30);
}

#[test]
fn center_of_mass_behind_finger_1s_tangent_matches_the_reference() {
    center_of_mass_behind_a_tangent_part(0);
}

#[test]
fn center_of_mass_behind_finger_2s_tangent_matches_the_reference() {
    center_of_mass_behind_a_tangent_part(1);
}

#[test]
fn center_of_mass_behind_both_tangents_matches_the_reference() {
    center_of_mass_behind_a_tangent_part(2);
}

#[test]
fn no_reference_point_is_lower_on_a_sample() {
    run_scans(21, 140, &Settings::default(), (48, 2), (8, 16, 2));
}

#[test]
fn no_reference_point_has_less_squeeze_on_a_sample() {
    let squeeze = Settings {
        objective: Objective::InternalForce,
        range: AllowedRange::Graspable,
        ..Settings::default()
    };
    run_scans(23, 60, &squeeze, (48, 2), (8, 16, 2));
}

#[test]
#[ignore = "long: cargo test --release --test it spatial::no_reference -- --ignored --nocapture"]
fn no_reference_point_is_lower_on_2000_grasps() {
    run_scans(22, 2000, &Settings::default(), (96, 3), (12, 24, 3));
}

/// Off the axis, the reference cannot hold gravity out of the plane through the contacts and the
/// centre of mass (module docs §1); on the axis it holds every direction.
#[test]
fn gravity_out_of_the_plane_cannot_be_held() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let (mut off, mut on) = (0, 0);
    for kind in kinds(200) {
        let c = random_spatial_grasp(&mut rng, kind);
        let r = spatial(&c, &Settings::default());
        let reference = SpatialReference::new(&c, 1.0);
        let nu = r.plane_normal;
        for tilt in [1e-3, 0.1, 1.0] {
            let g = rotate(
                &r.gravity_direction.cross(&nu).normalize(),
                tilt,
                &r.gravity_direction,
            );
            let held = reference.at(&g);
            if r.axis == AxisRelation::OnAxis {
                assert!(
                    matches!(held, Held::Yes { .. }),
                    "on the axis every direction holds: {held:?} at {g:?}; {c:?}"
                );
                on += 1;
            } else {
                assert_eq!(held, Held::No, "{tilt} rad out of the plane; {c:?}");
                off += 1;
            }
        }
    }
    println!("{off} directions out of the plane infeasible, {on} on-axis directions held");
}

/// A grasp given as spatial but lying in the x-y plane (all z equal, normals and gravity in the
/// plane) gives the planar answer to 1e-12.
#[test]
fn planar_candidates_given_as_spatial_give_the_planar_answer() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let mut worst: f64 = 0.0;
    let mut count = 0;
    for k in 0..2000 {
        let p = random_grasp(&mut rng);
        let z = (k as f64 * 0.37).sin() * 3.0;
        let lift = |v: nalgebra::Vector2<f64>, z: f64| Vector3::new(v.x, v.y, z);
        let c = spatial::Candidate {
            contact_1: lift(p.contact_1, z),
            contact_2: lift(p.contact_2, z),
            normal_1: lift(p.normal_1, 0.0),
            normal_2: lift(p.normal_2, 0.0),
            friction_1: p.friction_1,
            friction_2: p.friction_2,
            center_of_mass: lift(p.center_of_mass, z),
            mass: p.mass,
            gravity: lift(p.gravity, 0.0),
        };
        let settings = Settings {
            objective: [Objective::Norm2, Objective::Norm1, Objective::InternalForce][k % 3],
            range: [AllowedRange::FromAbove, AllowedRange::Graspable][(k / 3) % 2],
            friction_safety_factor: [1.0, 1.0, 1.1][k % 3],
        };
        let planar = match planar::solve(&p, &settings) {
            Ok(Verdict::Recommended(r)) => *r,
            Ok(Verdict::NoForceClosure(_)) => {
                assert!(matches!(
                    spatial::solve(&c, &settings),
                    Ok(spatial::Verdict::NoForceClosure(_))
                ));
                continue;
            }
            Err(e) => panic!("{e}"),
        };
        let s = spatial(&c, &settings);
        worst = worst.max(planar_gap(&planar, &s, p.mass * p.gravity.norm()));
        count += 1;
    }
    println!("{count} planar grasps as spatial: largest difference {worst:.1e}");
    assert!(count > 1500);
    assert!(worst <= 1e-12, "planar and spatial differ by {worst:e}");
}

/// The largest difference between a planar answer and a spatial one of the same grasp (angles in
/// rad, forces relative to the weight), failing on any difference in labels.
fn planar_gap(p: &Recommendation, s: &spatial::Recommendation, weight: f64) -> f64 {
    let q = &s.planar;
    assert_eq!(s.plane_normal, Vector3::z());
    assert_ne!(s.axis, AxisRelation::OnAxis);
    assert_eq!(s.current_pose, CurrentPose::Held);
    assert_eq!(p.grasp_case, q.grasp_case);
    assert_eq!(p.recommended_label, q.recommended_label);
    assert_eq!(p.candidate_c, q.candidate_c);
    assert_eq!(p.local_minima.len(), q.local_minima.len());
    let mut angles = vec![
        (p.gravity_angle, q.gravity_angle),
        (p.wrist_rotation, q.wrist_rotation),
        (p.current_gravity_angle, q.current_gravity_angle),
        // The signed planar rotation about +z is the spatial (axis, angle).
        (p.wrist_rotation, s.rotation_axis.z * s.rotation_angle),
    ];
    let mut values = vec![
        (p.gripping_power, q.gripping_power),
        (p.internal_force, q.internal_force),
        (p.gripping_power_current, q.gripping_power_current),
        (p.internal_force_current, q.internal_force_current),
        (p.finger_force, q.finger_force),
        (p.finger_force_current, q.finger_force_current),
    ];
    for (m, n) in p.local_minima.iter().zip(&q.local_minima) {
        assert_eq!(m.label, n.label);
        angles.push((m.gravity_angle, n.gravity_angle));
        values.push((m.power, n.power));
    }
    for k in 0..4 {
        values.push((p.contact_forces[k], q.contact_forces[k]));
    }
    let gap = angles
        .iter()
        .map(|(a, b)| wrap(a - b).abs())
        .chain(values.iter().map(|(a, b)| (a - b).abs() / weight))
        .fold(0.0, f64::max);
    let d = Vector3::new(p.gravity_direction.x, p.gravity_direction.y, 0.0);
    gap.max((d - s.gravity_direction).norm())
}

/// On the axis, the plane search (Pareto arcs and the curve of candidates C for the 2-norm and
/// the internal force; the grid and golden-section search for the 1-norm) is no worse than the
/// planar solver run on 3,600 planes round the axis.
#[test]
fn on_axis_search_beats_a_dense_scan_of_planes() {
    let mut rng = ChaCha8Rng::seed_from_u64(51);
    let bounded = |lo, hi| AllowedRange::Bounds { lo, hi };
    for (objective, range) in [
        (Objective::Norm2, AllowedRange::FromAbove),
        (Objective::InternalForce, AllowedRange::FromAbove),
        (Objective::Norm1, AllowedRange::FromAbove),
        (Objective::Norm2, bounded(0.2, 0.6)),
        (Objective::Norm2, bounded(-1.2, -0.1)),
        (Objective::InternalForce, bounded(-0.3, 0.9)),
    ] {
        let settings = Settings {
            objective,
            range,
            ..Settings::default()
        };
        let mut worst: f64 = f64::NEG_INFINITY;
        for k in 0..60 {
            let kind = [Kind::OnAxis, Kind::OnAxisCoplanar, Kind::OnAxisSymmetric][k % 3];
            let c = random_spatial_grasp(&mut rng, kind);
            let r = spatial(&c, &settings);
            assert_eq!(r.axis, AxisRelation::OnAxis);
            let weight = c.mass * c.gravity.norm();
            // Planes through the axis, each solved alone: rotate the candidate's gravity about
            // the axis so that its plane sweeps round, then take the plane's best orientation.
            let a = (c.contact_1 - c.contact_2).normalize();
            let side = a.cross(&Vector3::new(0.3, -0.7, 0.5)).normalize();
            let mut scan = f64::INFINITY;
            for j in 0..3600 {
                let psi = std::f64::consts::TAU * j as f64 / 3600.0;
                let g = rotate(&a, psi, &side) * c.gravity.norm();
                let probe = spatial::Candidate { gravity: g, ..c };
                let plane = spatial_plane_best(&probe, &settings, &a);
                scan = scan.min(plane);
            }
            let above = (r.planar.gripping_power - scan) / scan.max(1e-3 * weight);
            assert!(
                above <= 1e-12,
                "{objective:?}: solver {} above the scan's {scan}; grasp {c:?}",
                r.planar.gripping_power
            );
            worst = worst.max(above);
        }
        println!(
            "{objective:?} {range:?}: solver minus the best of 3,600 planes, at most {worst:.1e} \
             (relative)"
        );
    }
}

/// The best power in the plane through the axis and `probe.gravity`: the planar problem of that
/// plane, set up by hand (paper frame, y = 0) from the 3D data.
fn spatial_plane_best(probe: &spatial::Candidate, settings: &Settings, a: &Vector3<f64>) -> f64 {
    let g = probe.gravity.normalize();
    let v = -(g - a * g.dot(a)).normalize();
    let w = a.cross(&v);
    let c = probe.center_of_mass;
    let d = (probe.contact_1 - probe.contact_2).norm();
    let planar_normal = |n: &Vector3<f64>| nalgebra::Vector2::new(n.dot(a), n.dot(&v));
    let slice = |n: &Vector3<f64>, mu: f64| {
        let n = n.normalize();
        let cos_beta = (1.0 - n.dot(&w).powi(2)).sqrt();
        let mu = mu / settings.friction_safety_factor;
        ((1.0 + mu * mu) * cos_beta * cos_beta - 1.0).sqrt()
    };
    let planar = grasp_orient::solver::planar::Candidate {
        contact_1: nalgebra::Vector2::new((probe.contact_1 - c).dot(a) / d, 0.0),
        contact_2: nalgebra::Vector2::new((probe.contact_2 - c).dot(a) / d, 0.0),
        normal_1: planar_normal(&probe.normal_1),
        normal_2: planar_normal(&probe.normal_2),
        friction_1: slice(&probe.normal_1, probe.friction_1),
        friction_2: slice(&probe.normal_2, probe.friction_2),
        center_of_mass: nalgebra::Vector2::zeros(),
        mass: probe.mass,
        gravity: nalgebra::Vector2::new(g.dot(a), g.dot(&v)) * probe.gravity.norm(),
    };
    let one = Settings {
        friction_safety_factor: 1.0,
        ..*settings
    };
    match planar::solve(&planar, &one) {
        Ok(Verdict::Recommended(r)) => r.gripping_power,
        other => panic!("plane refused: {other:?}"),
    }
}

fn base() -> spatial::Candidate {
    spatial::Candidate {
        contact_1: Vector3::new(0.0, 1.0, 1.0),
        contact_2: Vector3::new(0.0, -1.0, 1.0),
        normal_1: Vector3::new(0.0, -1.0, 0.0),
        normal_2: Vector3::new(0.0, 1.0, 0.0),
        friction_1: 0.8,
        friction_2: 0.6,
        center_of_mass: Vector3::new(0.3, 0.0, 0.0),
        mass: 1.0,
        gravity: Vector3::new(0.0, 0.0, -9.81),
    }
}

fn refused(c: &spatial::Candidate) -> InvalidInput {
    match spatial::solve(c, &Settings::default()) {
        Err(e) => e,
        other => panic!("accepted: {other:?}"),
    }
}

/// Bad input names the field; grasps without force closure name the contact and the reason.
///
/// Longer than a screen: the catalogue of refusals, one case each, in one table-like list.
#[test]
fn refusals_name_the_field_and_the_contact() {
    assert!(matches!(
        spatial(&base(), &Settings::default()).axis,
        AxisRelation::OffAxis
    ));
    let mut c = base();
    c.contact_2.z = f64::NAN;
    assert_eq!(
        refused(&c),
        InvalidInput::NotFinite {
            field: "contact_2.z"
        }
    );
    let mut c = base();
    c.center_of_mass.z = 2e6;
    assert!(matches!(
        refused(&c),
        InvalidInput::OutOfRange {
            field: "center_of_mass.z",
            ..
        }
    ));
    let mut c = base();
    c.gravity.z = f64::INFINITY;
    assert_eq!(refused(&c), InvalidInput::NotFinite { field: "gravity.z" });
    let mut c = base();
    c.normal_1 = Vector3::zeros();
    assert_eq!(refused(&c), InvalidInput::ZeroVector { field: "normal_1" });
    let mut c = base();
    c.gravity = Vector3::zeros();
    assert_eq!(refused(&c), InvalidInput::ZeroVector { field: "gravity" });
    let mut c = base();
    c.contact_2 = c.contact_1;
    assert_eq!(refused(&c), InvalidInput::CoincidentContacts);
    let mut c = base();
    c.center_of_mass = c.contact_1;
    assert_eq!(
        refused(&c),
        InvalidInput::CenterOfMassAtContact {
            contact: Contact::First
        }
    );
    let mut c = base();
    c.normal_2 = -c.normal_2;
    assert_eq!(
        refused(&c),
        InvalidInput::NormalOutward {
            contact: Contact::Second
        }
    );
    // Behind the tangent plane at contact 1 (an object that is not convex): answered.
    let mut c = base();
    c.center_of_mass = Vector3::new(0.0, 0.0, 3.0) + Vector3::new(0.0, 5.0, 0.0);
    assert!(matches!(
        spatial::solve(&c, &Settings::default()),
        Ok(spatial::Verdict::Recommended(_))
    ));
    // Π is the plane x-y... here the plane through the contacts and (0.3, 0, 0): a normal along
    // its normal has no planar direction.
    let mut c = base();
    let nu = (c.contact_1 - c.center_of_mass).cross(&(c.contact_2 - c.center_of_mass));
    c.normal_1 = nu;
    assert_eq!(
        refused(&c),
        InvalidInput::NormalPerpendicularToGraspPlane { field: "normal_1" }
    );
    let s = Settings {
        friction_safety_factor: 0.5,
        ..Settings::default()
    };
    assert_eq!(
        spatial::solve(&base(), &s),
        Err(InvalidInput::SafetyFactor { value: 0.5 })
    );
    // The planar model's domain: friction from 1e-6, a safety factor up to 1000.
    let s = Settings {
        friction_safety_factor: 1001.0,
        ..Settings::default()
    };
    assert_eq!(
        spatial::solve(&base(), &s),
        Err(InvalidInput::SafetyFactor { value: 1001.0 })
    );
    let mut c = base();
    c.friction_2 = 1e-7;
    assert_eq!(
        refused(&c),
        InvalidInput::BelowMinimum {
            field: "friction_2",
            value: 1e-7,
            minimum: 1e-6
        }
    );
}

/// A normal tilted out of Π beyond its friction angle, or an on-axis cone that misses the other
/// contact: no force closure, naming the contact and the reason.
#[test]
fn no_force_closure_names_the_contact_and_the_reason() {
    let mut c = base();
    let nu = (c.contact_1 - c.center_of_mass)
        .cross(&(c.contact_2 - c.center_of_mass))
        .normalize();
    c.normal_2 = Vector3::new(0.0, 1.0, 0.0) * 0.5f64.cos() + nu * 0.5f64.sin();
    c.friction_2 = 0.5f64.tan() * 0.99;
    match spatial::solve(&c, &Settings::default()) {
        Ok(spatial::Verdict::NoForceClosure(why)) => {
            assert!(matches!(
                why.misses[..],
                [spatial::Miss::Tilted {
                    contact: Contact::Second,
                    ..
                }]
            ));
            let text = why.to_string();
            assert!(
                text.contains("contact_2 is tilted out of the grasp plane"),
                "{text}"
            );
        }
        other => panic!("{other:?}"),
    }
    // Just inside the friction angle it holds.
    c.friction_2 = 0.5f64.tan() * 1.01;
    assert!(matches!(
        spatial::solve(&c, &Settings::default()),
        Ok(spatial::Verdict::Recommended(_))
    ));
    // On the axis, a cone that misses the other contact.
    let mut c = base();
    c.center_of_mass = Vector3::new(0.0, 0.2, 1.0);
    c.normal_1 = Vector3::new(0.0, -1.0, 1.0);
    match spatial::solve(&c, &Settings::default()) {
        Ok(spatial::Verdict::NoForceClosure(why)) => {
            assert!(
                matches!(why.misses[..], [spatial::Miss::Cone(m)] if m.contact == Contact::First)
            );
        }
        other => panic!("{other:?}"),
    }
}

/// A ball gripped through its centre (normals along the axis, centre of mass on it): every plane
/// through the axis is equally good, so the answer turns the object within the plane of the
/// axis and the current gravity. The least power is the weight itself, with the contact axis
/// vertical and the lower finger carrying everything (a vertical pinch); of the two vertical
/// poses the nearer one wins.
#[test]
fn a_ball_gripped_through_its_centre_turns_in_its_current_plane() {
    let c = spatial::Candidate {
        contact_1: Vector3::new(0.05, 0.0, 0.0),
        contact_2: Vector3::new(-0.05, 0.0, 0.0),
        normal_1: Vector3::new(-1.0, 0.0, 0.0),
        normal_2: Vector3::new(1.0, 0.0, 0.0),
        friction_1: 0.5,
        friction_2: 0.5,
        center_of_mass: Vector3::zeros(),
        mass: 0.2,
        gravity: Vector3::new(2.0, -3.0, -9.0),
    };
    let r = spatial(&c, &Settings::default());
    assert_eq!(r.axis, AxisRelation::OnAxis);
    assert!(r.axis.is_sensitive());
    // The rotation axis is perpendicular to the contact axis and to the current gravity.
    assert!(r.rotation_axis.x.abs() < 1e-12);
    assert!(r.rotation_axis.dot(&c.gravity).abs() < 1e-12 * c.gravity.norm());
    let weight = c.mass * c.gravity.norm();
    assert!((r.planar.gripping_power - weight).abs() < 1e-12 * weight);
    assert!((r.gravity_direction - Vector3::x()).norm() < 1e-12, "{r:?}");
    let reference = SpatialReference::new(&c, 1.0);
    let (_, best) = reference.scan_sphere(false, 12, 24, 3);
    assert!(r.planar.gripping_power <= best * (1.0 + SOCP_TOL));
    // Across the axis (contact axis horizontal) it needs a squeeze: (2.5)^(1/2) weights.
    let across = reference.power(&Vector3::new(0.0, -1.0, 0.0));
    assert!((across - 2.5f64.sqrt() * weight).abs() < SOCP_TOL * across);
}

/// `rotation_axis`, `rotation_angle` and the quaternion agree.
#[test]
fn quaternion_is_the_axis_angle() {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    for kind in kinds(100) {
        let c = random_spatial_grasp(&mut rng, kind);
        let r = spatial(&c, &Settings::default());
        let [x, y, z, w] = r.quaternion();
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let by_axis =
            Rotation3::from_axis_angle(&Unit::new_normalize(r.rotation_axis), r.rotation_angle);
        let v = Vector3::new(0.3, -0.4, 0.8);
        assert!((q * v - by_axis * v).norm() < 1e-12);
    }
}

/// On the axis the optimal plane is located to better than 1e-9 rad: about the recommended
/// gravity, the best power of the planes turned by ±δ and ±δ/2 about the axis (each plane solved
/// by the planar solver from 3D data set up by hand) gives the slope (Richardson-extrapolated,
/// free of the cubic term) and curvature of the power over planes, whose ratio is the distance
/// from the solver's plane to the true minimum. (δ = 1e-3: smaller steps drown the slope in
/// rounding, about 4 ε P / δ.)
#[test]
fn on_axis_plane_is_located_to_1e9_rad() {
    let mut rng = ChaCha8Rng::seed_from_u64(71);
    let settings = Settings::default();
    let delta = 1e-3;
    let (mut worst, mut fitted, mut flat) = (0.0f64, 0, 0);
    for k in 0..400 {
        let kind = [Kind::OnAxis, Kind::OnAxisCoplanar][k % 2];
        let c = random_spatial_grasp(&mut rng, kind);
        let r = spatial(&c, &settings);
        let a = (c.contact_1 - c.contact_2).normalize();
        let g = r.gravity_direction;
        if g.cross(&a).norm() < 1e-6 {
            continue; // gravity along the axis: every plane holds it
        }
        let at = |psi: f64| {
            let probe = spatial::Candidate {
                gravity: rotate(&a, psi, &g) * c.gravity.norm(),
                ..c
            };
            spatial_plane_best(&probe, &settings, &a)
        };
        let (p0, plus, minus) = (at(0.0), at(delta), at(-delta));
        let (half_plus, half_minus) = (at(0.5 * delta), at(-0.5 * delta));
        assert!(
            (p0 - r.planar.gripping_power).abs() <= 1e-12 * p0,
            "the recommendation's own plane gives {p0}, not {}",
            r.planar.gripping_power
        );
        assert!(plus >= p0 * (1.0 - 1e-12) && minus >= p0 * (1.0 - 1e-12));
        let curvature = (plus + minus - 2.0 * p0) / (delta * delta);
        if curvature <= 1e-3 * p0 {
            flat += 1; // a flat or one-sided minimum: no vertex to fit
            continue;
        }
        let slope_full = (plus - minus) / (2.0 * delta);
        let slope_half = (half_plus - half_minus) / delta;
        let vertex = (4.0 * slope_half - slope_full) / 3.0 / curvature;
        worst = worst.max(vertex.abs());
        fitted += 1;
    }
    println!("on-axis plane: vertex within {worst:.1e} rad on {fitted} grasps ({flat} flat)");
    assert!(fitted > 100);
    assert!(worst <= 1e-9, "plane located only to {worst:e} rad");
}
