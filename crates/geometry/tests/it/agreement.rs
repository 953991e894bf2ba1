//! The crate against the independent reference on thousands of random poses on random objects in
//! random frames: contacts and centres of mass within 1e-9 of the object's size, normals within
//! 1e-9 rad, and the same refusals (a finger starting inside, closing on nothing).

use std::collections::BTreeMap;

use grasp_orient_geometry::{
    cast_fingers, center_of_mass, ClosingAxis, Contact, Finger, GeometryError, GripperPose, Mesh,
    Object, Primitive, Shape,
};
use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::objects::{faceted_cylinder, l_prism, mug, random_frame, random_rotation, TestMesh};
use crate::reference::{Outcome, Solid};

/// Agreement on lengths, as a fraction of the object's size.
const LENGTH: f64 = 1e-9;
/// Agreement on normals, rad.
const ANGLE: f64 = 1e-9;
/// Starts closer than this (fraction of the size) to the surface are skipped as ambiguous.
const CLEARANCE: f64 = 1e-7;

pub struct Case {
    pub kind: &'static str,
    pub shape: Shape,
    pub solid: Solid,
    /// Bounding box in the object frame.
    pub lo: Point3<f64>,
    pub hi: Point3<f64>,
}

impl Case {
    pub fn size(&self) -> f64 {
        (self.hi - self.lo).norm()
    }
}

fn primitive_case(kind: &'static str, p: Primitive, solid: Solid, half: Vector3<f64>) -> Case {
    Case {
        kind,
        shape: p.into(),
        solid,
        lo: Point3::from(-half),
        hi: Point3::from(half),
    }
}

pub fn mesh_case(kind: &'static str, mesh: &TestMesh, scale: f64) -> Case {
    let product = Mesh::from_triangles(kind, &mesh.vertices, &mesh.triangles, [scale; 3])
        .expect("a valid test mesh");
    let points = mesh.points(scale);
    let lo = points
        .iter()
        .fold(Point3::from([f64::INFINITY; 3]), |m, p| m.inf(p));
    let hi = points
        .iter()
        .fold(Point3::from([f64::NEG_INFINITY; 3]), |m, p| m.sup(p));
    Case {
        kind,
        shape: product.into(),
        solid: Solid::Mesh {
            vertices: points,
            triangles: mesh.indices(),
        },
        lo,
        hi,
    }
}

fn random_cases(rng: &mut impl Rng) -> Vec<Case> {
    let mut cases = Vec::new();
    let len = |rng: &mut dyn rand::RngCore| rng.gen_range(0.02..0.3);
    for _ in 0..6 {
        let (x, y, z) = (len(rng), len(rng), len(rng));
        let half = Vector3::new(x, y, z) / 2.0;
        cases.push(primitive_case(
            "box",
            Primitive::Box { x, y, z },
            Solid::Box { half },
            half,
        ));
        let r = len(rng) / 2.0;
        cases.push(primitive_case(
            "sphere",
            Primitive::Sphere { radius: r },
            Solid::Sphere { r },
            Vector3::repeat(r),
        ));
        let (h, r) = (len(rng), len(rng) / 2.0);
        cases.push(primitive_case(
            "cylinder",
            Primitive::Cylinder {
                height: h,
                radius: r,
            },
            Solid::Cylinder {
                half_height: h / 2.0,
                r,
            },
            Vector3::new(r, r, h / 2.0),
        ));
        let (h, r) = (len(rng), len(rng) / 2.0);
        cases.push(primitive_case(
            "cone",
            Primitive::Cone {
                height: h,
                radius: r,
            },
            Solid::Cone { h, r },
            Vector3::new(r, r, h / 2.0),
        ));
        let a = len(rng);
        cases.push(mesh_case(
            "L prism (non-convex)",
            &l_prism(a, len(rng)),
            1.0,
        ));
        let r = len(rng) / 2.0;
        cases.push(mesh_case(
            "mug (non-convex)",
            &mug(r, 0.15 * r, len(rng), 48),
            1.0,
        ));
        cases.push(mesh_case(
            "faceted cylinder",
            &faceted_cylinder(len(rng) / 2.0, len(rng), 256),
            1.0,
        ));
        // In millimetres, scale 0.001.
        let mm = 1000.0 * len(rng);
        cases.push(mesh_case(
            "mug in mm",
            &mug(mm / 2.0, mm / 12.0, 1000.0 * len(rng), 40),
            0.001,
        ));
    }
    cases
}

/// A random gripper pose around the object: the tool's centre near the object, a random
/// orientation and closing axis, an opening between a third and twice the object's size.
pub fn random_gripper(rng: &mut impl Rng, case: &Case, frame: &Isometry3<f64>) -> GripperPose {
    let margin = (case.hi - case.lo) * 0.15;
    let local = Point3::from(Vector3::from_fn(|i, _| {
        rng.gen_range(case.lo[i] - margin[i]..case.hi[i] + margin[i])
    }));
    let centre = frame * local;
    let closing_axis = [ClosingAxis::X, ClosingAxis::Y, ClosingAxis::Z][rng.gen_range(0..3)];
    GripperPose {
        tool_pose: Isometry3::from_parts(Translation3::from(centre.coords), random_rotation(rng)),
        width: case.size() * rng.gen_range(0.3..2.0),
        closing_axis,
    }
}

/// A finger's start and direction in the header frame.
pub fn finger_ray(gripper: &GripperPose, finger: Finger) -> (Point3<f64>, Vector3<f64>) {
    let axis = match gripper.closing_axis {
        ClosingAxis::X => Vector3::x(),
        ClosingAxis::Y => Vector3::y(),
        _ => Vector3::z(),
    };
    let b = gripper.tool_pose.rotation * axis;
    let c = Point3::from(gripper.tool_pose.translation.vector);
    match finger {
        Finger::One => (c - b * (gripper.width / 2.0), b),
        _ => (c + b * (gripper.width / 2.0), -b),
    }
}

/// The reference's outcome for one finger, in the header frame, and the start's clearance.
fn reference_finger(
    case: &Case,
    frame: &Isometry3<f64>,
    gripper: &GripperPose,
    finger: Finger,
) -> (Outcome, f64) {
    let (start, dir) = finger_ray(gripper, finger);
    let o = frame.inverse() * start;
    let d = frame.inverse() * dir;
    let outcome = match case.solid.cast(o, d, gripper.width) {
        Outcome::Hit { t, inward } => Outcome::Hit {
            t,
            inward: frame.rotation * inward,
        },
        other => other,
    };
    (outcome, case.solid.clearance(o, d))
}

fn assert_contact(
    case: &Case,
    gripper: &GripperPose,
    finger: Finger,
    got: &Contact,
    t: f64,
    inward: Vector3<f64>,
) {
    let (start, dir) = finger_ray(gripper, finger);
    let expected = start + dir * t;
    let size = case.size();
    let off = (got.point - expected).norm() / size;
    let angle = angle_between(&got.normal, &inward);
    assert!(
        off <= LENGTH && angle <= ANGLE,
        "{}: finger {finger}: contact off by {off:e} of the size, normal by {angle:e} rad",
        case.kind
    );
}

/// The angle between two vectors, accurate near 0 (unlike `acos` of the dot product).
pub fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// What a pose came to, when the crate and the reference agree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Agreed {
    Contacts,
    Inside,
    Nothing,
    /// A start within rounding of the surface: not compared.
    Skipped,
}

fn check_pose(case: &Case, frame: &Isometry3<f64>, gripper: &GripperPose) -> Agreed {
    let object = Object {
        pose: *frame,
        shape: case.shape.clone(),
    };
    let got = cast_fingers(gripper, &object);
    let mut hits = Vec::new();
    for finger in Finger::BOTH {
        let (outcome, clearance) = reference_finger(case, frame, gripper, finger);
        if clearance < CLEARANCE * case.size() {
            return Agreed::Skipped;
        }
        match outcome {
            Outcome::Inside => {
                assert!(
                    matches!(got, Err(GeometryError::StartsInside { finger: f, .. }) if f == finger),
                    "{}: finger {finger} starts inside, got {got:?}",
                    case.kind
                );
                return Agreed::Inside;
            }
            Outcome::Miss => {
                assert!(
                    matches!(got, Err(GeometryError::ClosesOnNothing { finger: f }) if f == finger),
                    "{}: finger {finger} closes on nothing, got {got:?}",
                    case.kind
                );
                return Agreed::Nothing;
            }
            Outcome::Hit { t, inward } => hits.push((t, inward)),
        }
    }
    let contacts = got.unwrap_or_else(|e| panic!("{}: both fingers touch, got {e}", case.kind));
    for (i, finger) in Finger::BOTH.into_iter().enumerate() {
        let (t, inward) = hits[i];
        assert_contact(case, gripper, finger, &contacts[i], t, inward);
    }
    Agreed::Contacts
}

#[test]
fn random_poses_agree_with_the_reference() {
    let mut rng = ChaCha8Rng::seed_from_u64(20261203);
    let cases = random_cases(&mut rng);
    let mut hits: BTreeMap<&str, usize> = BTreeMap::new();
    let mut outcomes: BTreeMap<Agreed, usize> = BTreeMap::new();
    for case in &cases {
        for _ in 0..120 {
            let frame = random_frame(&mut rng, 1.0);
            let gripper = random_gripper(&mut rng, case, &frame);
            let agreed = check_pose(case, &frame, &gripper);
            *outcomes.entry(agreed).or_default() += 1;
            if agreed == Agreed::Contacts {
                *hits.entry(case.kind).or_default() += 1;
            }
        }
    }
    let total: usize = hits.values().sum();
    eprintln!("poses with two contacts: {total} {hits:?}; all outcomes: {outcomes:?}");
    assert!(outcomes[&Agreed::Inside] >= 100 && outcomes[&Agreed::Nothing] >= 100);
    assert!(total >= 2000, "only {total} poses with two contacts");
    assert!(
        hits.values().all(|&n| n >= 100) && hits.len() == 8,
        "{hits:?}"
    );
}

#[test]
fn centres_of_mass_agree_with_the_divergence_theorem() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let cases = random_cases(&mut rng);
    for case in &cases {
        for _ in 0..20 {
            let frame = random_frame(&mut rng, 1.0);
            let got = center_of_mass(&frame, &case.shape, None).expect("closed objects");
            let expected = frame * case.solid.centroid();
            let off = (got - expected).norm() / case.size();
            assert!(
                off <= LENGTH,
                "{}: centre of mass off by {off:e}",
                case.kind
            );
        }
    }
}

/// The faceted cylinder against the exact one: within the faceting's error (the sagitta
/// `r (1 − cos(π/n))` along the surface normal, the facet angle `π/n` on the normal).
#[test]
fn a_faceted_cylinder_is_the_exact_one_within_its_faceting() {
    let (r, h, n) = (0.04, 0.12, 512);
    let faceted = mesh_case("faceted cylinder", &faceted_cylinder(r, h, n), 1.0);
    let exact = primitive_case(
        "cylinder",
        Primitive::Cylinder {
            height: h,
            radius: r,
        },
        Solid::Cylinder {
            half_height: h / 2.0,
            r,
        },
        Vector3::new(r, r, h / 2.0),
    );
    let sagitta = r * (1.0 - (std::f64::consts::PI / f64::from(n)).cos());
    let facet_angle = std::f64::consts::PI / f64::from(n);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut compared = 0;
    for _ in 0..3000 {
        let frame = random_frame(&mut rng, 1.0);
        let gripper = random_gripper(&mut rng, &exact, &frame);
        let object = |case: &Case| Object {
            pose: frame,
            shape: case.shape.clone(),
        };
        let (Ok(a), Ok(b)) = (
            cast_fingers(&gripper, &object(&faceted)),
            cast_fingers(&gripper, &object(&exact)),
        ) else {
            continue;
        };
        for (finger, (p, q)) in Finger::BOTH.into_iter().zip(a.iter().zip(b.iter())) {
            let (_, dir) = finger_ray(&gripper, finger);
            let incidence = q.normal.dot(&dir);
            let local = frame.inverse() * q.point;
            let near_rim = (local.z.abs() - h / 2.0).abs() < 0.01 * h
                && (local.xy().coords.norm() - r).abs() < 0.01 * r;
            if incidence < 0.3 || near_rim {
                continue;
            }
            let off = (p.point - q.point).norm();
            let bound = sagitta / (incidence - facet_angle);
            assert!(
                off <= bound,
                "finger {finger}: {off:e} > {bound:e} at {local} (incidence {incidence})"
            );
            assert!(angle_between(&p.normal, &q.normal) <= facet_angle + 1e-9);
            compared += 1;
        }
    }
    assert!(compared > 1000, "only {compared} contacts compared");
    let com = center_of_mass(&Isometry3::identity(), &faceted.shape, None).expect("closed");
    assert!(com.coords.norm() < 1e-12);
}

/// Turning the gripper half a turn about an axis across the closing axis swaps its fingers: the
/// contacts swap, the same to rounding.
#[test]
fn turning_the_gripper_over_swaps_the_fingers() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let cases = random_cases(&mut rng);
    let mut swapped = 0;
    for case in &cases {
        for _ in 0..20 {
            let frame = random_frame(&mut rng, 1.0);
            let gripper = random_gripper(&mut rng, case, &frame);
            let across = match gripper.closing_axis {
                ClosingAxis::X => Vector3::z_axis(),
                _ => Vector3::x_axis(),
            };
            let mut turned = gripper;
            turned.tool_pose.rotation *=
                nalgebra::UnitQuaternion::from_axis_angle(&across, std::f64::consts::PI);
            let object = Object {
                pose: frame,
                shape: case.shape.clone(),
            };
            let (Ok(a), Ok(b)) = (
                cast_fingers(&gripper, &object),
                cast_fingers(&turned, &object),
            ) else {
                continue;
            };
            for (p, q) in [(&a[0], &b[1]), (&a[1], &b[0])] {
                assert!(
                    (p.point - q.point).norm() <= 1e-12 * case.size().max(1.0),
                    "{}",
                    case.kind
                );
                assert!(angle_between(&p.normal, &q.normal) <= 1e-9, "{}", case.kind);
            }
            swapped += 1;
        }
    }
    assert!(swapped > 200, "only {swapped} poses compared");
}
