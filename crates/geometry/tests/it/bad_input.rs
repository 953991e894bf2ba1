//! Every refusal: status 2 with the resource and what is wrong, or status 1 for a finger that
//! closes on nothing.

use std::fs;

use grasp_orient_geometry::{
    cast_fingers, center_of_mass, grasp_from_pose, load, AmentIndex, ClosingAxis, Finger,
    GeometryError, GripperPose, Mesh, MeshCache, MeshDefect, Object, Primitive,
};
use nalgebra::{Isometry3, Point3};

use crate::files::write_binary_stl;
use crate::objects::l_prism;

fn load_err(resource: &str, scale: [f64; 3]) -> GeometryError {
    match load(resource, scale, &AmentIndex::default()) {
        Err(e) => e,
        Ok(_) => panic!("{resource} loaded"),
    }
}

fn assert_names(e: &GeometryError, words: &[&str]) {
    let text = e.to_string();
    for w in words {
        assert!(text.contains(w), "{text:?} does not name {w:?}");
    }
    assert_eq!(e.status(), 2, "{text}");
}

#[test]
fn unreadable_unknown_and_unparsable_files() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let missing = dir.path().join("missing.stl").display().to_string();
    let e = load_err(&missing, [1.0; 3]);
    assert!(matches!(e, GeometryError::Unreadable { .. }));
    assert_names(&e, &[&missing, "cannot read"]);

    let ply = dir.path().join("object.ply");
    fs::write(&ply, "ply\n").expect("write");
    let e = load_err(&ply.display().to_string(), [1.0; 3]);
    assert!(matches!(e, GeometryError::UnknownFormat { .. }));
    assert_names(&e, &["object.ply", "unknown mesh format"]);

    let dae = dir.path().join("broken.dae");
    fs::write(&dae, "<COLLADA><library_geometries>").expect("write");
    let e = load_err(&dae.display().to_string(), [1.0; 3]);
    assert!(matches!(e, GeometryError::Unparsable { .. }), "{e}");
    assert_names(&e, &["broken.dae", "cannot parse"]);

    let e = load_err("package://no_such_package/meshes/a.stl", [1.0; 3]);
    assert!(matches!(e, GeometryError::PackageNotFound { .. }));
    assert_names(&e, &["no_such_package", "not found"]);
}

#[test]
fn zero_and_negative_scales() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("l.stl");
    write_binary_stl(&path, &l_prism(64.0, 24.0));
    let resource = path.display().to_string();
    for scale in [
        [0.0, 0.001, 0.001],
        [0.001, -0.001, 0.001],
        [0.001, 0.001, f64::NAN],
    ] {
        let e = load_err(&resource, scale);
        assert!(matches!(e, GeometryError::BadScale { .. }));
        assert_names(&e, &["l.stl", "scale"]);
        let cache = MeshCache::new(AmentIndex::default(), 1 << 20);
        assert!(matches!(
            cache.get(&resource, scale),
            Err(GeometryError::BadScale { .. })
        ));
    }
}

#[test]
fn an_open_mesh_needs_a_given_centre_of_mass() {
    let mut m = l_prism(0.064, 0.024);
    m.triangles.pop();
    let mesh = Mesh::from_triangles("open_l.stl", &m.vertices, &m.triangles, [1.0; 3])
        .expect("an open mesh is still a mesh");
    assert!(!mesh.is_closed());
    let shape = mesh.into();
    let e = center_of_mass(&Isometry3::identity(), &shape, None).expect_err("open");
    assert!(matches!(
        e,
        GeometryError::NotClosed {
            defect: MeshDefect::EdgeUse { triangles: 1, .. },
            ..
        }
    ));
    assert_names(&e, &["open_l.stl", "open or non-manifold"]);
    let given = Point3::new(0.01, 0.01, 0.01);
    let frame = Isometry3::translation(1.0, 2.0, 3.0);
    let com = center_of_mass(&frame, &shape, Some(given)).expect("given");
    assert!((com - frame * given).norm() < 1e-15);
    // A whole pose candidate: the missing centre of mass is wrong input (status 2), even when
    // the fingers close on nothing too.
    let object = Object { pose: frame, shape };
    let away = GripperPose {
        tool_pose: Isometry3::translation(5.0, 5.0, 5.0),
        width: 0.1,
        closing_axis: ClosingAxis::Y,
    };
    let e = grasp_from_pose(&away, &object, None).expect_err("no centre of mass");
    assert!(matches!(e, GeometryError::NotClosed { .. }));
    let e = grasp_from_pose(&away, &object, Some(given)).expect_err("nothing to grasp");
    assert_eq!(e.status(), 1);
    let across = GripperPose {
        tool_pose: frame * Isometry3::translation(0.016, 0.016, 0.012),
        width: 0.1,
        closing_axis: ClosingAxis::X,
    };
    let grasp = grasp_from_pose(&across, &object, Some(given)).expect("a grasp");
    assert!((grasp.center_of_mass - frame * given).norm() < 1e-15);
    assert!((grasp.contacts[0].point - frame * Point3::new(0.0, 0.016, 0.012)).norm() < 1e-12);
    // Non-manifold: the same L twice, sharing every edge four times.
    let m = l_prism(0.064, 0.024);
    let twice: Vec<[u32; 3]> = m
        .triangles
        .iter()
        .chain(m.triangles.iter())
        .copied()
        .collect();
    let mesh = Mesh::from_triangles("double_l", &m.vertices, &twice, [1.0; 3]).expect("a mesh");
    assert!(matches!(
        mesh.volume(),
        Err(MeshDefect::EdgeUse { triangles: 4, .. })
    ));
}

#[test]
fn unknown_primitives_and_wrong_dimensions() {
    for (type_number, dims) in [(0u8, vec![0.1]), (5, vec![0.1]), (9, vec![])] {
        let e = Primitive::from_shape_msgs(type_number, &dims).expect_err("unknown");
        assert!(matches!(e, GeometryError::UnknownPrimitive { .. }));
        assert_names(&e, &["solid primitive", &type_number.to_string()]);
    }
    for (type_number, dims) in [
        (1u8, vec![0.1, 0.1]),
        (2, vec![0.0]),
        (3, vec![0.1, -0.02]),
        (4, vec![0.1, 0.02, 0.3]),
        (3, vec![f64::INFINITY, 0.02]),
    ] {
        let e = Primitive::from_shape_msgs(type_number, &dims).expect_err("wrong");
        assert!(matches!(e, GeometryError::PrimitiveDimensions { .. }));
        assert_names(&e, &["solid primitive", "dimensions", "expected"]);
    }
}

fn box_object() -> Object {
    Object {
        pose: Isometry3::translation(0.5, 0.0, 0.0),
        shape: Primitive::Box {
            x: 0.1,
            y: 0.06,
            z: 0.04,
        }
        .into(),
    }
}

#[test]
fn a_finger_that_closes_on_nothing_is_status_1() {
    let gripper = GripperPose {
        tool_pose: Isometry3::translation(0.5, 0.0, 0.1),
        width: 0.2,
        closing_axis: ClosingAxis::Y,
    };
    let e = cast_fingers(&gripper, &box_object()).expect_err("above the box");
    assert!(matches!(
        e,
        GeometryError::ClosesOnNothing {
            finger: Finger::One
        }
    ));
    assert_eq!(e.status(), 1);
    assert_eq!(e.to_string(), "finger 1 closes on nothing");
    // Pointing at the box but too short to reach it: also nothing.
    let gripper = GripperPose {
        tool_pose: Isometry3::translation(0.5, 0.2, 0.0),
        width: 0.1,
        closing_axis: ClosingAxis::Y,
    };
    let e = cast_fingers(&gripper, &box_object()).expect_err("short of the box");
    assert!(matches!(e, GeometryError::ClosesOnNothing { .. }));
}

#[test]
fn an_opening_narrower_than_the_object_is_status_2() {
    // The box is 6 cm along y; a 5 cm opening starts both fingers inside it.
    let gripper = GripperPose {
        tool_pose: Isometry3::translation(0.5, 0.0, 0.0),
        width: 0.05,
        closing_axis: ClosingAxis::Y,
    };
    let e = cast_fingers(&gripper, &box_object()).expect_err("too narrow");
    assert!(matches!(
        e,
        GeometryError::StartsInside {
            finger: Finger::One,
            ..
        }
    ));
    assert_names(&e, &["finger 1", "box", "narrower"]);
    // Off centre: only finger 2 starts inside.
    let gripper = GripperPose {
        tool_pose: Isometry3::translation(0.5, -0.04, 0.0),
        width: 0.07,
        closing_axis: ClosingAxis::Y,
    };
    let e = cast_fingers(&gripper, &box_object()).expect_err("too narrow");
    assert!(matches!(
        e,
        GeometryError::StartsInside {
            finger: Finger::Two,
            ..
        }
    ));
    // The same with a closed mesh.
    let m = l_prism(0.064, 0.024);
    let l = Object {
        pose: Isometry3::identity(),
        shape: Mesh::from_triangles("l", &m.vertices, &m.triangles, [1.0; 3])
            .expect("closed")
            .into(),
    };
    let gripper = GripperPose {
        tool_pose: Isometry3::translation(0.016, 0.016, 0.012),
        width: 0.01,
        closing_axis: ClosingAxis::X,
    };
    let e = cast_fingers(&gripper, &l).expect_err("inside the L");
    assert!(matches!(
        e,
        GeometryError::StartsInside {
            finger: Finger::One,
            ..
        }
    ));
}

#[test]
fn bad_numbers_are_refused() {
    let mut gripper = GripperPose {
        tool_pose: Isometry3::translation(0.5, 0.0, 0.0),
        width: 0.0,
        closing_axis: ClosingAxis::Y,
    };
    let e = cast_fingers(&gripper, &box_object()).expect_err("zero width");
    assert_names(&e, &["width"]);
    gripper.width = 0.2;
    gripper.tool_pose.translation.vector.x = f64::NAN;
    let e = cast_fingers(&gripper, &box_object()).expect_err("NaN pose");
    assert_names(&e, &["grasp_pose"]);
    assert_eq!(
        "q".parse::<ClosingAxis>().map_err(|e| e.to_string()),
        Err("\"q\" is not a closing axis (x, y or z)".to_owned())
    );
}
