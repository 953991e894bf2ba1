//! One field at a time set to an extreme value (±1e±300, ±infinity, NaN, -0.0, subnormals) in an
//! otherwise good `GraspCandidate` (planar and spatial) or `PoseCandidate` (on a mesh and on a
//! primitive): the answer is either not a refusal, or a refusal (status 2) whose message names
//! the field given the extreme value, as the message's own path (`object.friction`, not the
//! `friction_1` of the spatial candidate a pose makes; `object.scale.x`, not `normal_1.x`).

use grasp_orient::answer::{Answering, PoseAnswerer, Rules};
use grasp_orient::kind::{Candidates, Poses};
use grasp_orient::msg::{
    GraspCandidate, GraspObject, Mesh, MeshTriangle, Point, Pose, PoseCandidate, Quaternion,
    SolidPrimitive, Vector3,
};
use grasp_orient::solver::Settings;
use grasp_orient_geometry::{AmentIndex, ClosingAxis};

/// The values each field is given in turn.
const EXTREMES: [f64; 12] = [
    1e300,
    -1e300,
    1e-300,
    -1e-300,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
    -0.0,
    5e-324,
    -5e-324,
    f64::MAX,
    1e-310,
];

/// A field by its path in the message, and where it lives.
type Field<T> = (&'static str, fn(&mut T) -> &mut f64);

fn grasp_fields() -> Vec<Field<GraspCandidate>> {
    vec![
        ("contact_1.x", |c| &mut c.contact_1.x),
        ("contact_1.y", |c| &mut c.contact_1.y),
        ("contact_1.z", |c| &mut c.contact_1.z),
        ("contact_2.x", |c| &mut c.contact_2.x),
        ("contact_2.y", |c| &mut c.contact_2.y),
        ("contact_2.z", |c| &mut c.contact_2.z),
        ("normal_1.x", |c| &mut c.normal_1.x),
        ("normal_1.y", |c| &mut c.normal_1.y),
        ("normal_1.z", |c| &mut c.normal_1.z),
        ("normal_2.x", |c| &mut c.normal_2.x),
        ("normal_2.y", |c| &mut c.normal_2.y),
        ("normal_2.z", |c| &mut c.normal_2.z),
        ("friction_1", |c| &mut c.friction_1),
        ("friction_2", |c| &mut c.friction_2),
        ("center_of_mass.x", |c| &mut c.center_of_mass.x),
        ("center_of_mass.y", |c| &mut c.center_of_mass.y),
        ("center_of_mass.z", |c| &mut c.center_of_mass.z),
        ("mass", |c| &mut c.mass),
        ("gravity.x", |c| &mut c.gravity.x),
        ("gravity.y", |c| &mut c.gravity.y),
        ("gravity.z", |c| &mut c.gravity.z),
        ("center_of_mass_tolerance.x", |c| {
            &mut c.center_of_mass_tolerance.x
        }),
        ("center_of_mass_tolerance.y", |c| {
            &mut c.center_of_mass_tolerance.y
        }),
        ("center_of_mass_tolerance.z", |c| {
            &mut c.center_of_mass_tolerance.z
        }),
        ("mass_tolerance", |c| &mut c.mass_tolerance),
    ]
}

fn pose_fields() -> Vec<Field<PoseCandidate>> {
    vec![
        ("grasp_pose.position.x", |c| &mut c.grasp_pose.position.x),
        ("grasp_pose.position.y", |c| &mut c.grasp_pose.position.y),
        ("grasp_pose.position.z", |c| &mut c.grasp_pose.position.z),
        ("grasp_pose.orientation.x", |c| {
            &mut c.grasp_pose.orientation.x
        }),
        ("grasp_pose.orientation.y", |c| {
            &mut c.grasp_pose.orientation.y
        }),
        ("grasp_pose.orientation.z", |c| {
            &mut c.grasp_pose.orientation.z
        }),
        ("grasp_pose.orientation.w", |c| {
            &mut c.grasp_pose.orientation.w
        }),
        ("width", |c| &mut c.width),
        ("object.pose.position.x", |c| &mut c.object.pose.position.x),
        ("object.pose.position.y", |c| &mut c.object.pose.position.y),
        ("object.pose.position.z", |c| &mut c.object.pose.position.z),
        ("object.pose.orientation.x", |c| {
            &mut c.object.pose.orientation.x
        }),
        ("object.pose.orientation.y", |c| {
            &mut c.object.pose.orientation.y
        }),
        ("object.pose.orientation.z", |c| {
            &mut c.object.pose.orientation.z
        }),
        ("object.pose.orientation.w", |c| {
            &mut c.object.pose.orientation.w
        }),
        ("object.scale.x", |c| &mut c.object.scale.x),
        ("object.scale.y", |c| &mut c.object.scale.y),
        ("object.scale.z", |c| &mut c.object.scale.z),
        ("object.mass", |c| &mut c.object.mass),
        ("object.friction", |c| &mut c.object.friction),
        ("object.center_of_mass.x", |c| {
            &mut c.object.center_of_mass.x
        }),
        ("object.center_of_mass.y", |c| {
            &mut c.object.center_of_mass.y
        }),
        ("object.center_of_mass.z", |c| {
            &mut c.object.center_of_mass.z
        }),
        ("gravity.x", |c| &mut c.gravity.x),
        ("gravity.y", |c| &mut c.gravity.y),
        ("gravity.z", |c| &mut c.gravity.z),
    ]
}

fn point(x: f64, y: f64, z: f64) -> Point {
    Point { x, y, z }
}

fn vector(x: f64, y: f64, z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

/// Table 1 (a) of the paper, planar; and a spatial grasp across a bar, both answered with status 0.
fn grasp_bases() -> Vec<(&'static str, GraspCandidate)> {
    let planar = GraspCandidate {
        id: "planar".into(),
        contact_1: point(5.0 * 3f64.sqrt(), 5.0, 0.0),
        contact_2: point(-5.0 * 3f64.sqrt(), 5.0, 0.0),
        normal_1: vector(-3f64.sqrt(), -1.0, 0.0),
        normal_2: vector(3f64.sqrt(), -1.0, 0.0),
        friction_1: 1.5,
        friction_2: 1.0,
        center_of_mass: point(0.0, 0.0, 0.0),
        mass: 1.0,
        gravity: vector(0.0, -9.81, 0.0),
        center_of_mass_tolerance: vector(0.001, 0.001, 0.001),
        mass_tolerance: 0.01,
        ..GraspCandidate::default()
    };
    let spatial = GraspCandidate {
        id: "spatial".into(),
        contact_1: point(0.0, -0.03, 0.05),
        contact_2: point(0.0, 0.03, 0.05),
        normal_1: vector(0.0, 1.0, 0.0),
        normal_2: vector(0.0, -1.0, 0.0),
        friction_1: 0.8,
        friction_2: 0.8,
        center_of_mass: point(0.01, 0.0, 0.0),
        mass: 0.3,
        gravity: vector(0.0, 0.0, -9.81),
        model: GraspCandidate::MODEL_SPATIAL,
        center_of_mass_tolerance: vector(0.001, 0.001, 0.001),
        mass_tolerance: 0.01,
        ..GraspCandidate::default()
    };
    vec![("planar", planar), ("spatial", spatial)]
}

fn identity(x: f64, y: f64, z: f64) -> Pose {
    Pose {
        position: point(x, y, z),
        orientation: Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        },
    }
}

/// A 40 × 60 × 80 mm block centred on its origin, in millimetres (`meshes/block_mm.obj`).
fn block_mm() -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            let s = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            point(20.0 * s(4), 30.0 * s(2), 40.0 * s(1))
        })
        .collect();
    let faces: [[u32; 3]; 12] = [
        [0, 1, 3],
        [0, 3, 2],
        [4, 6, 7],
        [4, 7, 5],
        [0, 4, 5],
        [0, 5, 1],
        [2, 3, 7],
        [2, 7, 6],
        [0, 2, 6],
        [0, 6, 4],
        [1, 5, 7],
        [1, 7, 3],
    ];
    Mesh {
        vertices,
        triangles: faces
            .into_iter()
            .map(|vertex_indices| MeshTriangle { vertex_indices })
            .collect(),
    }
}

/// The block given inline at scale 0.001 with a given centre of mass, and a 6 cm box primitive,
/// each grasped across (closing along y) 10 cm open, both answered with status 0.
fn pose_bases() -> Vec<(&'static str, PoseCandidate)> {
    let mesh = PoseCandidate {
        id: "mesh".into(),
        grasp_pose: identity(0.003, 0.0, 0.01),
        width: 0.1,
        object: GraspObject {
            pose: identity(0.0, 0.0, 0.0),
            inline_mesh: block_mm(),
            scale: vector(0.001, 0.001, 0.001),
            mass: 0.2,
            friction: 0.8,
            has_center_of_mass: true,
            center_of_mass: point(0.002, 0.0, -0.003),
            ..GraspObject::default()
        },
        gravity: vector(0.0, 0.0, -9.81),
        ..PoseCandidate::default()
    };
    let mut primitive = mesh.clone();
    primitive.id = "primitive".into();
    primitive.object.inline_mesh = Mesh::default();
    primitive.object.scale = vector(1.0, 1.0, 1.0);
    primitive.object.primitive = SolidPrimitive {
        kind: 1,
        dimensions: vec![0.06, 0.06, 0.06],
    };
    vec![("mesh", mesh), ("primitive", primitive)]
}

/// Whether `message` names `field` (or says what is wrong with it in other words the docs use):
/// its path; for a field of a `GraspCandidate`'s vector or of `gravity`, the vector, which the solver checks as a
/// whole (`normal_1 does not point into the object`, `gravity is the zero vector`); a quaternion
/// that is zero, by its path; the opening for `width`; the scale vector for `object.scale.*`
/// (the geometry states the scale it refuses).
fn names(field: &str, value: f64, message: &str, grasp: bool) -> bool {
    let parent = field.rsplit_once('.').map_or(field, |(p, _)| p);
    message.contains(field)
        || ((grasp || parent == "gravity") && message.contains(parent))
        || (field.contains(".orientation.")
            && value == 0.0
            && message.contains(&format!("{parent} is not a rotation: its norm is 0")))
        || (field == "width" && message.contains("the opening is narrower"))
        || (field.starts_with("object.scale.") && message.contains("scale ["))
}

/// What a refusal that does not name its field, or states its value unreadably, says.
fn misnamed(
    base: &str,
    field: &str,
    value: f64,
    r: &grasp_orient::msg::GripRecommendation,
    grasp: bool,
) -> Option<String> {
    let message = r.message.as_str();
    let wrong = r.status == 2 && !names(field, value, message, grasp);
    // A value is written as `-1e-300`, not as three hundred zeros.
    (wrong || message.contains("0000000000"))
        .then(|| format!("{base}: {field} = {value:e}: {message:?}"))
}

#[test]
fn every_extreme_value_is_refused_naming_its_own_field() {
    let settings = Settings::default();
    let rules = Rules::default();
    let mut wrong = Vec::new();
    let with = Answering::new(
        settings,
        rules,
        PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()),
    );
    for (base_name, base) in grasp_bases() {
        let r = with.answer::<Candidates>(&base);
        assert_eq!(r.status, 0, "{base_name}: {}", r.message);
        for (field, at) in grasp_fields() {
            for value in EXTREMES {
                let mut c = base.clone();
                *at(&mut c) = value;
                let r = with.answer::<Candidates>(&c);
                wrong.extend(misnamed(base_name, field, value, &r, true));
            }
        }
    }
    for (base_name, base) in pose_bases() {
        let r = with.answer::<Poses>(&base).recommendation;
        assert_eq!(r.status, 0, "{base_name}: {}", r.message);
        for (field, at) in pose_fields() {
            // A primitive's scale must be 1: any other is refused naming `object.scale`.
            let field_named = if base_name == "primitive" && field.starts_with("object.scale") {
                "object.scale"
            } else {
                field
            };
            for value in EXTREMES {
                let mut c = base.clone();
                *at(&mut c) = value;
                let r = with.answer::<Poses>(&c).recommendation;
                wrong.extend(misnamed(base_name, field_named, value, &r, false));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "{} refusals name another cause than the field given an extreme value:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}
