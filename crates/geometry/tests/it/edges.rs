//! The edge and vertex rule: a contact on an edge or a vertex takes the pseudo-normal (the mean of
//! the faces' normals, angle-weighted at a vertex), and says so.

use grasp_orient_geometry::{
    cast_fingers, ClosingAxis, Contact, Feature, GripperPose, Mesh, Object, Primitive, Shape,
};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use crate::agreement::angle_between;
use crate::objects::{faceted_cylinder, TestMesh};

/// A gripper closing along `b` through `through`, `width` open.
fn closing_through(through: Point3<f64>, b: Vector3<f64>, width: f64) -> GripperPose {
    let rotation = UnitQuaternion::rotation_between(&Vector3::y(), &b).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    GripperPose {
        tool_pose: Isometry3::from_parts(Translation3::from(through.coords), rotation),
        width,
        closing_axis: ClosingAxis::Y,
    }
}

fn contacts(shape: Shape, gripper: &GripperPose) -> [Contact; 2] {
    let object = Object {
        pose: Isometry3::identity(),
        shape,
    };
    cast_fingers(gripper, &object).expect("both fingers touch")
}

fn assert_normal(c: &Contact, expected: Vector3<f64>, feature: Feature) {
    let angle = angle_between(&c.normal, &expected.normalize());
    assert!(angle < 1e-12, "normal {:?} is {angle:e} rad off", c.normal);
    assert_eq!(c.feature, feature);
}

/// A unit cube centred on the origin, each face split along a diagonal.
fn cube_mesh() -> TestMesh {
    let vertices = (0..8)
        .map(|i| {
            [
                f64::from(i & 1) - 0.5,
                f64::from((i >> 1) & 1) - 0.5,
                f64::from((i >> 2) & 1) - 0.5,
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    TestMesh {
        vertices,
        triangles,
    }
}

fn cube_shapes() -> [Shape; 2] {
    let m = cube_mesh();
    [
        Primitive::Box {
            x: 1.0,
            y: 1.0,
            z: 1.0,
        }
        .into(),
        Mesh::from_triangles("cube", &m.vertices, &m.triangles, [1.0; 3])
            .expect("a cube")
            .into(),
    ]
}

#[test]
fn a_box_edge_takes_the_mean_of_its_two_faces() {
    // The closing line runs along x = y through the edge x = 0.5, y = 0.5 (finger 1 meets it).
    for shape in cube_shapes() {
        let b = Vector3::new(-1.0, -1.0, 0.0).normalize();
        let gripper = closing_through(Point3::new(0.0, 0.0, 0.1), b, 4.0);
        let [c1, c2] = contacts(shape, &gripper);
        assert_normal(&c1, Vector3::new(-1.0, -1.0, 0.0), Feature::Edge);
        assert_normal(&c2, Vector3::new(1.0, 1.0, 0.0), Feature::Edge);
        assert!((c1.point - Point3::new(0.5, 0.5, 0.1)).norm() < 1e-12);
    }
}

#[test]
fn a_box_corner_takes_the_mean_of_its_three_faces() {
    for shape in cube_shapes() {
        let gripper = closing_through(
            Point3::origin(),
            Vector3::new(1.0, 1.0, 1.0).normalize(),
            4.0,
        );
        let [c1, c2] = contacts(shape, &gripper);
        assert_normal(&c1, Vector3::new(1.0, 1.0, 1.0), Feature::Vertex);
        assert_normal(&c2, Vector3::new(-1.0, -1.0, -1.0), Feature::Vertex);
    }
}

#[test]
fn a_mesh_face_diagonal_is_not_an_edge() {
    // Through the centre of the faces x = ±0.5, on the diagonal that splits them.
    let [_, mesh] = cube_shapes();
    let gripper = closing_through(Point3::new(0.0, 0.1, 0.1), Vector3::x(), 3.0);
    let [c1, c2] = contacts(mesh, &gripper);
    assert_normal(&c1, Vector3::x(), Feature::Face);
    assert_normal(&c2, -Vector3::x(), Feature::Face);
}

#[test]
fn a_cylinder_rim_takes_the_mean_of_cap_and_side() {
    let cylinder = Primitive::Cylinder {
        height: 2.0,
        radius: 1.0,
    };
    // Along (1, 0, 1) through the rim points (1, 0, 1) and (−1, 0, −1).
    let b = Vector3::new(-1.0, 0.0, -1.0).normalize();
    let gripper = closing_through(Point3::new(1.0, 0.0, 1.0) + b, b, 2.0 * 2f64.sqrt() + 1.0);
    let [c1, c2] = contacts(cylinder.into(), &gripper);
    assert!((c1.point - Point3::new(1.0, 0.0, 1.0)).norm() < 1e-12);
    assert_normal(&c1, Vector3::new(-1.0, 0.0, -1.0), Feature::Edge);
    assert!((c2.point - Point3::new(-1.0, 0.0, -1.0)).norm() < 1e-12);
    assert_normal(&c2, Vector3::new(1.0, 0.0, 1.0), Feature::Edge);
}

#[test]
fn a_cone_tip_takes_the_axis_and_its_base_rim_the_mean() {
    let cone = Primitive::Cone {
        height: 2.0,
        radius: 1.0,
    };
    // Down the axis: the tip (0, 0, 1), then the base's centre.
    let gripper = closing_through(Point3::origin(), -Vector3::z(), 4.0);
    let [c1, c2] = contacts(cone.into(), &gripper);
    assert!((c1.point - Point3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
    assert_normal(&c1, -Vector3::z(), Feature::Vertex);
    assert_normal(&c2, Vector3::z(), Feature::Face);
    // Through the base rim at (−1, 0, −1), horizontally: the side's outward normal there is
    // (−2, 0, 1)/√5 and the base's (0, 0, −1).
    let gripper = closing_through(Point3::new(0.0, 0.0, -1.0), Vector3::x(), 4.0);
    let [c1, _] = contacts(cone.into(), &gripper);
    let side = Vector3::new(-2.0, 0.0, 1.0).normalize();
    assert_normal(&c1, -(side + Vector3::new(0.0, 0.0, -1.0)), Feature::Edge);
}

#[test]
fn a_faceted_cylinder_vertex_takes_the_angle_weighted_mean() {
    // The top cap's centre vertex: the cap's triangles all face +z, so the normal is unique.
    let m = faceted_cylinder(1.0, 2.0, 16);
    let mesh: Shape = Mesh::from_triangles("cylinder", &m.vertices, &m.triangles, [1.0; 3])
        .expect("closed")
        .into();
    let gripper = closing_through(Point3::origin(), Vector3::z(), 4.0);
    let [c1, c2] = contacts(mesh.clone(), &gripper);
    assert_normal(&c1, Vector3::z(), Feature::Face);
    assert_normal(&c2, -Vector3::z(), Feature::Face);
    // A rim vertex at angle 0, (1, 0, 1): two side facets (π/2 each, their normals at ±π/16
    // about +x) and the cap (the polygon's angle, +z) meet there, so the normal lies strictly
    // between +x and +z, in the plane y = 0 by symmetry.
    let b = Vector3::new(-1.0, 0.0, -1.0).normalize();
    let gripper = closing_through(Point3::new(1.0, 0.0, 1.0) + b, b, 4.5);
    let [c1, _] = contacts(mesh, &gripper);
    assert_eq!(c1.feature, Feature::Vertex);
    assert!((c1.point - Point3::new(1.0, 0.0, 1.0)).norm() < 1e-12);
    let inward = c1.normal.into_inner();
    assert!(inward.x < -0.1 && inward.z < -0.1 && inward.y.abs() < 1e-12);
}

/// A finger starting on the surface, or inside it by less than the tolerance (1e-10 of the
/// size), touches it at once; deeper is inside. Contact-GraspNet's poses start finger 1 exactly
/// at the predicted contact.
#[test]
fn a_finger_starting_on_the_surface_touches_it_at_once() {
    for shape in cube_shapes() {
        for depth in [0.0, 1e-13, -1e-13] {
            // Finger 1 starts at x = −0.5 + depth, closing along +x through a face's inside.
            let gripper = GripperPose {
                tool_pose: Isometry3::translation(0.5 + depth, 0.1, 0.2),
                width: 2.0,
                closing_axis: ClosingAxis::X,
            };
            let [c1, c2] = contacts(shape.clone(), &gripper);
            assert!(c1.travel <= 1e-12, "depth {depth}: travel {}", c1.travel);
            assert!((c1.point.x + 0.5).abs() <= 1e-12);
            assert_normal(&c1, Vector3::x(), Feature::Face);
            assert_normal(&c2, -Vector3::x(), Feature::Face);
        }
        let gripper = GripperPose {
            tool_pose: Isometry3::translation(0.5 + 1e-6, 0.1, 0.2),
            width: 2.0,
            closing_axis: ClosingAxis::X,
        };
        let object = Object {
            pose: Isometry3::identity(),
            shape: shape.clone(),
        };
        assert!(matches!(
            cast_fingers(&gripper, &object),
            Err(grasp_orient_geometry::GeometryError::StartsInside { .. })
        ));
    }
}

/// A closing line that grazes a convex edge of a closed mesh, leaving through the other face at
/// once, touches the solid at one point only. Rounding decides whether the finger touches the edge
/// or closes on nothing; it never starts inside, though the first triangle met may be a back face.
#[test]
fn a_line_grazing_an_edge_touches_it_or_nothing() {
    let [box_shape, mesh] = cube_shapes();
    let mut touched = 0;
    for shape in [box_shape, mesh] {
        for along in [Vector3::new(-1.0, 0.5, 0.0), Vector3::new(0.5, -1.0, 0.0)] {
            let edge = Point3::new(0.5, 0.5, 0.1);
            let gripper = closing_through(edge, along.normalize(), 1.0);
            let object = Object {
                pose: Isometry3::identity(),
                shape: shape.clone(),
            };
            match cast_fingers(&gripper, &object) {
                Ok(contacts) => {
                    for c in contacts {
                        assert!((c.point - edge).norm() < 1e-12, "{:?}", c.point);
                        assert_normal(&c, Vector3::new(-1.0, -1.0, 0.0), Feature::Edge);
                    }
                    touched += 1;
                }
                Err(e) => assert!(
                    matches!(
                        e,
                        grasp_orient_geometry::GeometryError::ClosesOnNothing { .. }
                    ),
                    "{e}"
                ),
            }
        }
    }
    eprintln!("{touched} of 4 grazing lines touched the edge");
}

/// An open mesh (a cube without its top) has no inside: the normal points away from the finger
/// whichever way its triangles are wound, and a finger may come in through the opening.
#[test]
fn an_open_mesh_normal_points_away_from_the_finger() {
    let mut m = cube_mesh();
    // The top face, z = +0.5, is the quad [4, 5, 7, 6]: its two triangles.
    m.triangles.retain(|t| *t != [4, 5, 7] && *t != [4, 7, 6]);
    assert_eq!(m.triangles.len(), 10);
    for flip in [false, true] {
        let triangles: Vec<[u32; 3]> = m
            .triangles
            .iter()
            .map(|t| if flip { [t[0], t[2], t[1]] } else { *t })
            .collect();
        let open: Shape = Mesh::from_triangles("open box", &m.vertices, &triangles, [1.0; 3])
            .expect("a mesh")
            .into();
        let gripper = closing_through(Point3::new(0.0, 0.1, 0.2), Vector3::x(), 3.0);
        let [c1, c2] = contacts(open.clone(), &gripper);
        assert_normal(&c1, Vector3::x(), Feature::Face);
        assert_normal(&c2, -Vector3::x(), Feature::Face);
        // Down through the opening: finger 1 (from above) meets the bottom's inner side.
        let gripper = closing_through(Point3::new(0.1, 0.2, 0.0), -Vector3::z(), 3.0);
        let [c1, _] = contacts(open, &gripper);
        assert!((c1.point.z + 0.5).abs() < 1e-12);
        assert_normal(&c1, -Vector3::z(), Feature::Face);
    }
}
