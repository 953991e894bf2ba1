//! Markers for RViz and Foxglove, in the candidate's frame: the contacts, their friction cones,
//! the contact forces at the recommended pose, the centre of mass, and gravity now and after the
//! recommended rotation.
//!
//! A planar candidate is drawn in the x-y plane (z = 0, as the planar model reads it). A spatial
//! one is drawn in 3D: the contacts and the centre of mass where they are, each friction cone as
//! its slice by the grasp plane Π (the two edges at `±atan μ'` about the projected normal, the
//! cone the planar problem in Π uses), the 3D contact forces, the current gravity and the
//! recommended one (which lies in Π).
//!
//! A pose answer (`build_pose`) adds the object (its mesh as triangles, or its primitive) and the
//! fingers' closing line to the markers of the spatial candidate its fingers make.
//!
//! The box of possible centres of mass (`center_of_mass_tolerance`, the node's where the
//! candidate gives none) is drawn as its edges around the centre of mass, in z = 0 for a planar
//! candidate (whose model ignores z); with no box the marker is a DELETE, so that a box drawn for
//! an earlier candidate does not stay on screen.

use crate::msg::{
    ColorRgba, GraspCandidate, GripRecommendation, Marker, MarkerArray, Point, Pose, PoseCandidate,
    PoseRecommendation, Quaternion, Vector3,
};
use crate::solver::{spatial, Settings};
use grasp_orient_geometry::{ClosingAxis, Object, Primitive, Shape};
use nalgebra::{UnitQuaternion, Vector3 as V3};

#[cfg(test)]
/// Namespaces of the markers, one marker id each.
pub(crate) const NAMESPACES: [&str; 7] = [
    "contacts",
    "friction_cones",
    "contact_forces",
    "center_of_mass",
    "gravity_current",
    "gravity_recommended",
    "center_of_mass_box",
];

fn colour(r: f32, g: f32, b: f32) -> ColorRgba {
    ColorRgba { r, g, b, a: 1.0 }
}

fn at(v: &V3<f64>) -> Point {
    Point {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn marker(candidate: &GraspCandidate, ns: &str, kind: i32, size: f64, c: ColorRgba) -> Marker {
    Marker {
        header: candidate.header.clone(),
        ns: ns.to_string(),
        id: 0,
        kind,
        action: Marker::ADD,
        pose: Pose {
            position: at(&V3::zeros()),
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        },
        scale: Vector3 {
            x: size,
            y: size,
            z: size,
        },
        color: c,
        ..Marker::default()
    }
}

/// What is drawn, in the candidate's frame: points in m, forces in N, directions as unit vectors.
struct Scene {
    contacts: [V3<f64>; 2],
    center_of_mass: V3<f64>,
    /// The two edges of each contact's friction cone.
    cone_edges: [[V3<f64>; 2]; 2],
    /// The contact forces at the recommended pose.
    forces: [V3<f64>; 2],
    gravity_now: V3<f64>,
    gravity_then: V3<f64>,
    /// Contact distance, m: the length of everything drawn.
    span: f64,
    /// `m |g|`, N: drawn one contact distance long.
    weight: f64,
}

impl Scene {
    /// The planar model: the x-y components, z = 0; the cones of the given coefficients about
    /// the normals, the forces `N` along the inward normal and `F` along it turned +90°.
    fn planar(c: &GraspCandidate, answer: &GripRecommendation) -> Self {
        let flat = |x: f64, y: f64| V3::new(x, y, 0.0);
        let unit = |x: f64, y: f64| {
            let n = x.hypot(y);
            flat(x / n, y / n)
        };
        let p = [&c.contact_1, &c.contact_2];
        let n = [
            unit(c.normal_1.x, c.normal_1.y),
            unit(c.normal_2.x, c.normal_2.y),
        ];
        let mu = [c.friction_1, c.friction_2];
        let turned = |v: &V3<f64>, angle: f64| {
            let (s, cos) = angle.sin_cos();
            flat(cos * v.x - s * v.y, s * v.x + cos * v.y)
        };
        let edges = |i: usize| {
            let half = mu[i].atan();
            [turned(&n[i], -half), turned(&n[i], half)]
        };
        let force = |i: usize| {
            let (normal, friction) = (
                answer.contact_forces[2 * i],
                answer.contact_forces[2 * i + 1],
            );
            flat(
                normal * n[i].x - friction * n[i].y,
                normal * n[i].y + friction * n[i].x,
            )
        };
        Self {
            contacts: p.map(|q| flat(q.x, q.y)),
            center_of_mass: flat(c.center_of_mass.x, c.center_of_mass.y),
            cone_edges: [edges(0), edges(1)],
            forces: [force(0), force(1)],
            gravity_now: unit(c.gravity.x, c.gravity.y),
            gravity_then: flat(answer.gravity_direction.x, answer.gravity_direction.y),
            span: (p[0].x - p[1].x).hypot(p[0].y - p[1].y),
            weight: c.mass * c.gravity.x.hypot(c.gravity.y),
        }
    }

    /// The spatial model: everything in 3D, the cones sliced by Π (module docs of
    /// `solver::spatial`, §2–3).
    fn spatial(c: &GraspCandidate, r: &spatial::Recommendation) -> Self {
        let point = |p: &Point| V3::new(p.x, p.y, p.z);
        let gravity = V3::new(c.gravity.x, c.gravity.y, c.gravity.z);
        let contacts = [point(&c.contact_1), point(&c.contact_2)];
        // Lengths by `hypot`, as in the planar model: no square underflows for tiny gravity or
        // contact distances (a gravity of 1e-284 m/s² squared is 0).
        let length = |v: V3<f64>| v.x.hypot(v.y).hypot(v.z);
        let g = length(gravity);
        let edges = |i: usize| {
            let (s, cos) = r.sliced_friction[i].atan().sin_cos();
            let (u, t) = (r.normal_directions[i], r.friction_directions[i]);
            [u * cos - t * s, u * cos + t * s]
        };
        Self {
            contacts,
            center_of_mass: point(&c.center_of_mass),
            cone_edges: [edges(0), edges(1)],
            forces: r.force_vectors,
            gravity_now: gravity / g,
            gravity_then: r.gravity_direction,
            span: length(contacts[0] - contacts[1]),
            weight: c.mass * g,
        }
    }
}

/// The markers for one answered candidate (status OK): `spatial` is the spatial solver's answer
/// for a spatial candidate, `None` for a planar one. Lengths scale with the contact distance;
/// force arrows scale so that the weight `m |g|` is one contact distance long.
pub fn build(
    candidate: &GraspCandidate,
    answer: &GripRecommendation,
    spatial: Option<&spatial::Recommendation>,
) -> MarkerArray {
    let scene = match spatial {
        Some(r) => Scene::spatial(candidate, r),
        None => Scene::planar(candidate, answer),
    };
    draw(candidate, &scene)
}

fn draw(candidate: &GraspCandidate, s: &Scene) -> MarkerArray {
    let span = s.span;
    let thin = 0.02 * span;
    let line_list = |ns: &str, c: ColorRgba, segments: Vec<(V3<f64>, V3<f64>)>| {
        let mut m = marker(candidate, ns, Marker::LINE_LIST, thin, c);
        m.points = segments
            .iter()
            .flat_map(|(from, to)| [at(from), at(to)])
            .collect();
        m
    };
    let mut contacts = marker(
        candidate,
        "contacts",
        Marker::SPHERE_LIST,
        0.06 * span,
        colour(0.1, 0.4, 0.9),
    );
    contacts.points = s.contacts.iter().map(at).collect();
    // Both friction cones: two edges each, half a contact distance long.
    let cones = line_list(
        "friction_cones",
        colour(0.2, 0.7, 0.2),
        (0..2)
            .flat_map(|i| {
                let p = s.contacts[i];
                s.cone_edges[i].map(|d| (p, p + d * (0.5 * span)))
            })
            .collect(),
    );
    // The forces the fingers apply, span / weight metres per newton.
    let force_scale = span / s.weight;
    let forces = line_list(
        "contact_forces",
        colour(0.9, 0.2, 0.1),
        (0..2)
            .map(|i| (s.contacts[i], s.contacts[i] + s.forces[i] * force_scale))
            .collect(),
    );
    let mut centre = marker(
        candidate,
        "center_of_mass",
        Marker::SPHERE,
        0.08 * span,
        colour(0.1, 0.1, 0.1),
    );
    centre.pose.position = at(&s.center_of_mass);
    let arrow = |ns: &str, d: &V3<f64>, c: ColorRgba| {
        let mut m = marker(candidate, ns, Marker::ARROW, thin, c);
        m.scale = Vector3 {
            x: thin,
            y: 2.0 * thin,
            z: 3.0 * thin,
        };
        let com = s.center_of_mass;
        m.points = vec![at(&com), at(&(com + d * span))];
        m
    };
    let box_edges = com_box_edges(candidate, &s.center_of_mass);
    let mut com_box = line_list("center_of_mass_box", colour(0.1, 0.1, 0.1), box_edges);
    if com_box.points.is_empty() {
        com_box.action = Marker::DELETE;
    }
    MarkerArray {
        markers: vec![
            contacts,
            cones,
            forces,
            centre,
            arrow("gravity_current", &s.gravity_now, colour(0.5, 0.5, 0.5)),
            arrow(
                "gravity_recommended",
                &s.gravity_then,
                colour(0.8, 0.1, 0.8),
            ),
            com_box,
        ],
    }
}

#[cfg(test)]
/// Namespaces of the markers a pose answer adds, one marker id each.
pub(crate) const POSE_NAMESPACES: [&str; 2] = ["object", "fingers"];

/// How many sides a cone is drawn with.
const CONE_SIDES: usize = 32;

/// The markers for one answered pose candidate (status OK), in its header frame: those of the
/// spatial candidate its fingers make ([`build`], with the 3D solution solved again for the
/// drawing), then the object (`object`: a TRIANGLE_LIST for a mesh, inline or not, and for a
/// cone; CUBE, SPHERE or CYLINDER for those primitives; none when `object` is `None`) and the
/// fingers' closing line (a LINE_LIST from finger 1's start to finger 2's, the tool frame's
/// `closing_axis` at the opening `width`). The contacts are the `contacts` marker of [`build`].
pub(crate) fn build_pose(
    pose: &PoseCandidate,
    object: Option<&Object>,
    closing_axis: ClosingAxis,
    answer: &PoseRecommendation,
    settings: &Settings,
) -> MarkerArray {
    let candidate = GraspCandidate {
        header: pose.header.clone(),
        id: pose.id.clone(),
        contact_1: answer.contact_1.clone(),
        contact_2: answer.contact_2.clone(),
        normal_1: answer.normal_1.clone(),
        normal_2: answer.normal_2.clone(),
        friction_1: pose.object.friction,
        friction_2: pose.object.friction,
        center_of_mass: answer.center_of_mass.clone(),
        mass: pose.object.mass,
        gravity: pose.gravity.clone(),
        model: GraspCandidate::MODEL_SPATIAL,
        ..GraspCandidate::default()
    };
    let spatial = super::answer_in_full(&candidate, settings).spatial;
    let mut array = build(&candidate, &answer.recommendation, spatial.as_deref());
    if let Some(object) = object {
        array.markers.push(object_marker(&candidate, object));
    }
    array
        .markers
        .push(fingers_marker(&candidate, pose, closing_axis));
    array
}

/// The fingers' closing line: finger 1 starts at `c − (w/2)·b`, finger 2 at `c + (w/2)·b`
/// (docs/poses.md, "The fingers").
fn fingers_marker(candidate: &GraspCandidate, pose: &PoseCandidate, axis: ClosingAxis) -> Marker {
    let (p, o) = (&pose.grasp_pose.position, &pose.grasp_pose.orientation);
    let rotation = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o.w, o.x, o.y, o.z));
    let centre = V3::new(p.x, p.y, p.z);
    let half = rotation * axis.unit().into_inner() * (0.5 * pose.width);
    let mut m = marker(
        candidate,
        "fingers",
        Marker::LINE_LIST,
        0.01 * pose.width,
        colour(0.9, 0.6, 0.0),
    );
    m.points = vec![at(&(centre - half)), at(&(centre + half))];
    m
}

/// The object where it is: its pose, and its shape in the object frame.
fn object_marker(candidate: &GraspCandidate, object: &Object) -> Marker {
    let grey = ColorRgba {
        r: 0.6,
        g: 0.6,
        b: 0.65,
        a: 0.5,
    };
    let mut m = marker(candidate, "object", Marker::TRIANGLE_LIST, 1.0, grey);
    m.pose = Pose::from(&object.pose);
    let scale = |x: f64, y: f64, z: f64| Vector3 { x, y, z };
    match &object.shape {
        Shape::Mesh(mesh) => {
            m.points = mesh
                .corners()
                .flat_map(|t| t.map(|[x, y, z]| Point { x, y, z }))
                .collect();
        }
        Shape::Primitive(Primitive::Box { x, y, z }) => {
            m.kind = Marker::CUBE;
            m.scale = scale(*x, *y, *z);
        }
        Shape::Primitive(Primitive::Sphere { radius }) => {
            m.kind = Marker::SPHERE;
            m.scale = scale(2.0 * radius, 2.0 * radius, 2.0 * radius);
        }
        Shape::Primitive(Primitive::Cylinder { height, radius }) => {
            m.kind = Marker::CYLINDER;
            m.scale = scale(2.0 * radius, 2.0 * radius, *height);
        }
        Shape::Primitive(Primitive::Cone { height, radius }) => {
            m.points = cone_triangles(*height, *radius);
        }
    }
    m
}

/// A cone of [`CONE_SIDES`] sides as triangles wound outward: base disc at `z = −height/2`, tip
/// at `+height/2` (docs/poses.md, "Shapes").
fn cone_triangles(height: f64, radius: f64) -> Vec<Point> {
    let base = |i: usize| {
        let angle = std::f64::consts::TAU * (i % CONE_SIDES) as f64 / CONE_SIDES as f64;
        let (s, c) = angle.sin_cos();
        Point {
            x: radius * c,
            y: radius * s,
            z: -0.5 * height,
        }
    };
    let tip = Point {
        x: 0.0,
        y: 0.0,
        z: 0.5 * height,
    };
    let centre = Point {
        x: 0.0,
        y: 0.0,
        z: -0.5 * height,
    };
    (0..CONE_SIDES)
        .flat_map(|i| {
            [
                base(i),
                base(i + 1),
                tip.clone(),
                centre.clone(),
                base(i + 1),
                base(i),
            ]
        })
        .collect()
}

/// The edges of the box of possible centres of mass around `centre`: a rectangle in z = 0 for a
/// planar candidate, a box for a spatial one (degenerate sides drawn once); none without a
/// tolerance or with one that is not a finite non-negative number.
fn com_box_edges(candidate: &GraspCandidate, centre: &V3<f64>) -> Vec<(V3<f64>, V3<f64>)> {
    let t = &candidate.center_of_mass_tolerance;
    let planar = candidate.model == GraspCandidate::MODEL_PLANAR;
    let half = V3::new(t.x, t.y, if planar { 0.0 } else { t.z });
    if !half.iter().all(|h| h.is_finite() && *h >= 0.0) || half == V3::zeros() {
        return Vec::new();
    }
    let corner = |i: usize| {
        let sign = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
        centre + V3::new(sign(1) * half.x, sign(2) * half.y, sign(4) * half.z)
    };
    let mut edges = Vec::with_capacity(12);
    for i in 0..8usize {
        for bit in [1usize, 2, 4] {
            let j = i | bit;
            if i & bit == 0 && corner(i) != corner(j) && (!planar || i & 4 == 0) {
                edges.push((corner(i), corner(j)));
            }
        }
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Settings;

    /// The box around the centre of mass: a rectangle of the half-widths in z = 0 for a planar
    /// candidate; a DELETE without a tolerance.
    #[test]
    fn the_centre_of_mass_box_is_drawn_with_a_tolerance_only() {
        let mut c = crate::msg::paper_cases().remove(2);
        let a = crate::answer::answer(&c, &Settings::default());
        let plain = build(&c, &a, None);
        let find = |m: &MarkerArray| {
            m.markers
                .iter()
                .find(|x| x.ns == "center_of_mass_box")
                .cloned()
                .expect("the box marker")
        };
        assert_eq!(find(&plain).action, Marker::DELETE);
        c.center_of_mass_tolerance = Vector3 {
            x: 0.002,
            y: 0.001,
            z: 0.5,
        };
        let a = crate::answer::answer(&c, &Settings::default());
        let boxed = find(&build(&c, &a, None));
        assert_eq!(boxed.action, Marker::ADD);
        assert_eq!(boxed.points.len(), 8, "four edges");
        let com = &c.center_of_mass;
        for p in &boxed.points {
            assert_eq!(p.z, 0.0);
            assert!(((p.x - com.x).abs() - 0.002).abs() < 1e-15, "{p:?}");
            assert!(((p.y - com.y).abs() - 0.001).abs() < 1e-15, "{p:?}");
        }
    }

    #[test]
    fn markers_are_in_the_candidate_frame_and_finite() {
        let c = crate::msg::paper_cases().remove(0);
        let a = crate::answer::answer(&c, &Settings::default());
        let m = build(&c, &a, None);
        assert_eq!(m.markers.len(), NAMESPACES.len());
        for (marker, ns) in m.markers.iter().zip(NAMESPACES) {
            assert_eq!(marker.ns, ns);
            assert_eq!(marker.header.frame_id, "object");
            assert!(marker
                .points
                .iter()
                .all(|p| p.x.is_finite() && p.y.is_finite()));
        }
        // The forces balance the weight: their sum points against gravity with the weight.
        let f = &m.markers[2].points;
        let span = (c.contact_1.x - c.contact_2.x).hypot(c.contact_1.y - c.contact_2.y);
        let weight = c.mass * 9.80665;
        let sum_y = (f[1].y - f[0].y) + (f[3].y - f[2].y);
        let sum_x = (f[1].x - f[0].x) + (f[3].x - f[2].x);
        let g = (a.gravity_direction.x, a.gravity_direction.y);
        assert!((sum_x * weight / span + weight * g.0).abs() < 1e-9);
        assert!((sum_y * weight / span + weight * g.1).abs() < 1e-9);
    }

    /// A tilted grasp in a turned frame: the paper's case (c) square stood up, normal 1 tilted
    /// 0.35 rad out of its plane, everything turned by a rotation about a skew axis.
    fn spatial_candidate() -> GraspCandidate {
        use nalgebra::{Rotation3, Unit};
        let turn = Rotation3::from_axis_angle(&Unit::new_normalize(V3::new(0.3, -1.0, 0.7)), 0.9);
        let point = |x, y, z| {
            let v = turn * V3::new(x, y, z) + V3::new(0.5, -0.2, 1.5);
            Point {
                x: v.x,
                y: v.y,
                z: v.z,
            }
        };
        let vector = |x, y, z| {
            let v = turn * V3::new(x, y, z);
            Vector3 {
                x: v.x,
                y: v.y,
                z: v.z,
            }
        };
        GraspCandidate {
            header: crate::msg::Header {
                frame_id: "camera".into(),
                ..Default::default()
            },
            id: "tilted".into(),
            contact_1: point(0.0, 0.1, 0.1),
            contact_2: point(0.0, -0.1, 0.1),
            normal_1: vector(0.35f64.sin(), -(0.35f64.cos()), 0.0),
            normal_2: vector(0.0, 1.0, 0.0),
            friction_1: 3f64.sqrt(),
            friction_2: 1.0 / 3f64.sqrt(),
            center_of_mass: point(0.0, 0.0, 0.0),
            mass: 2.0,
            gravity: vector(0.0, 0.2, -9.81),
            model: GraspCandidate::MODEL_SPATIAL,
            ..GraspCandidate::default()
        }
    }

    fn v3(p: &Point) -> V3<f64> {
        V3::new(p.x, p.y, p.z)
    }

    /// Spatial markers against the 3D physics, not the solver's own quantities: the forces balance
    /// the weight in 3D; each cone edge lies in the plane of the contacts and the centre of mass
    /// and on the true 3D cone (at the friction angle from the normal); each force lies inside
    /// its 3D cone.
    #[test]
    fn spatial_markers_are_drawn_in_3d_on_the_true_cones() {
        let c = spatial_candidate();
        let settings = Settings::default();
        let crate::answer::Answered { reply, spatial } =
            crate::answer::answer_in_full(&c, &settings);
        assert_eq!(
            reply.status,
            GripRecommendation::STATUS_OK,
            "{}",
            reply.message
        );
        let m = build(&c, &reply, spatial.as_deref());
        assert_eq!(m.markers.len(), NAMESPACES.len());
        for (marker, ns) in m.markers.iter().zip(NAMESPACES) {
            assert_eq!(
                (marker.ns.as_str(), marker.header.frame_id.as_str()),
                (ns, "camera")
            );
        }
        let (p1, p2, com) = (v3(&c.contact_1), v3(&c.contact_2), v3(&c.center_of_mass));
        let span = (p1 - p2).norm();
        let gravity = V3::new(c.gravity.x, c.gravity.y, c.gravity.z);
        let weight = c.mass * gravity.norm();
        assert_eq!(
            m.markers[0].points.iter().map(v3).collect::<Vec<_>>(),
            [p1, p2]
        );
        assert_eq!(v3(&m.markers[3].pose.position), com);
        // The forces: from the contacts, balancing the weight along the recommended gravity.
        let f = m.markers[2].points.iter().map(v3).collect::<Vec<_>>();
        assert_eq!((f[0], f[2]), (p1, p2));
        let forces = [(f[1] - f[0]) * weight / span, (f[3] - f[2]) * weight / span];
        let d = V3::new(
            reply.gravity_direction.x,
            reply.gravity_direction.y,
            reply.gravity_direction.z,
        );
        assert!((forces[0] + forces[1] + d * weight).norm() < 1e-12 * weight);
        // The cones: in the plane through the contacts and the centre of mass, at the friction
        // angle from the 3D normal (a slice of the 3D cone lies on its surface).
        let plane = (p1 - com).cross(&(p2 - com)).normalize();
        let cones = m.markers[1].points.iter().map(v3).collect::<Vec<_>>();
        assert_eq!(cones.len(), 8);
        let normals = [&c.normal_1, &c.normal_2].map(|n| V3::new(n.x, n.y, n.z).normalize());
        let mu = [c.friction_1, c.friction_2];
        for (k, edge) in cones.chunks(2).enumerate() {
            let i = k / 2;
            assert_eq!(edge[0], [p1, p2][i]);
            let e = (edge[1] - edge[0]) / (0.5 * span);
            assert!((e.norm() - 1.0).abs() < 1e-12);
            assert!(
                e.dot(&plane).abs() < 1e-12,
                "edge {k} leaves the grasp plane"
            );
            let cos_xi = 1.0 / (1.0 + mu[i] * mu[i]).sqrt();
            assert!(
                (e.dot(&normals[i]) - cos_xi).abs() < 1e-12,
                "edge {k} off the 3D cone"
            );
        }
        // The forces lie in their 3D cones and in the plane; gravity arrows along the unit
        // directions, the recommended one in the plane.
        for i in 0..2 {
            let cos = forces[i].dot(&normals[i]) / forces[i].norm();
            assert!(
                cos >= 1.0 / (1.0 + mu[i] * mu[i]).sqrt() - 1e-12,
                "force {i} outside"
            );
            assert!(forces[i].dot(&plane).abs() < 1e-12 * weight);
        }
        let arrow = |k: usize| {
            let pts = m.markers[k].points.iter().map(v3).collect::<Vec<_>>();
            assert_eq!(pts[0], com);
            (pts[1] - pts[0]) / span
        };
        assert!((arrow(4) - gravity.normalize()).norm() < 1e-12);
        assert!((arrow(5) - d).norm() < 1e-12);
        assert!(d.dot(&plane).abs() < 1e-12);
        // A z component is really drawn.
        assert!(m
            .markers
            .iter()
            .flat_map(|x| &x.points)
            .any(|p| p.z.abs() > 0.1));
    }

    /// A pose candidate on `object` (JSON) at (0.5, 0, 0.1), the tool at the same place turned
    /// by `yaw` about z, opening 0.09 m.
    fn pose_on(object: &str, yaw: f64) -> PoseCandidate {
        let (s, c) = (0.5 * yaw).sin_cos();
        let line = format!(
            r#"{{"header": {{"frame_id": "base_link"}}, "id": "p", "grasp_pose": {{"position": {{"x": 0.5, "y": 0.0, "z": 0.1}}, "orientation": {{"x": 0.0, "y": 0.0, "z": {s}, "w": {c}}}}}, "width": 0.09, "object": {{"pose": {{"position": {{"x": 0.5, "y": 0.0, "z": 0.1}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}, {object}, "mass": 0.25, "friction": 0.5}}, "gravity": {{"x": 0.0, "y": 0.0, "z": -9.81}}}}"#
        );
        serde_json::from_str(&line).expect("a PoseCandidate")
    }

    /// The pose answered, and its markers.
    fn pose_markers(pose: &PoseCandidate) -> (PoseRecommendation, MarkerArray) {
        let answerer = crate::answer::PoseAnswerer::new(ClosingAxis::Y, Default::default());
        let settings = Settings::default();
        let answer = answerer.answer(pose, &settings, &crate::answer::Rules::default());
        assert_eq!(answer.recommendation.status, 0, "{answer:?}");
        let object = answerer.object(&pose.object).expect("an object");
        let m = build_pose(pose, Some(&object), ClosingAxis::Y, &answer, &settings);
        (answer, m)
    }

    fn find<'a>(m: &'a MarkerArray, ns: &str) -> &'a Marker {
        m.markers
            .iter()
            .find(|x| x.ns == ns)
            .unwrap_or_else(|| panic!("no {ns} marker"))
    }

    /// A box: a CUBE of its sides at the object's pose; the fingers' closing line from
    /// `c − (w/2)·b` to `c + (w/2)·b` with `b` the tool's y turned by the yaw; the contacts where
    /// the answer puts them; every marker in the header frame.
    #[test]
    fn a_pose_on_a_box_draws_the_box_the_closing_line_and_the_contacts() {
        let yaw = 0.3_f64;
        let pose = pose_on(
            r#""primitive": {"type": 1, "dimensions": [0.04, 0.06, 0.08]}"#,
            yaw,
        );
        let (answer, m) = pose_markers(&pose);
        let names: Vec<&str> = m.markers.iter().map(|x| x.ns.as_str()).collect();
        assert!(NAMESPACES
            .iter()
            .chain(&POSE_NAMESPACES)
            .all(|n| names.contains(n)));
        assert!(m.markers.iter().all(|x| x.header.frame_id == "base_link"));
        let object = find(&m, "object");
        assert_eq!(object.kind, Marker::CUBE);
        assert_eq!(
            (object.scale.x, object.scale.y, object.scale.z),
            (0.04, 0.06, 0.08)
        );
        assert_eq!((object.pose.position.x, object.pose.position.z), (0.5, 0.1));
        let fingers = find(&m, "fingers");
        assert_eq!(fingers.kind, Marker::LINE_LIST);
        let b = V3::new(-yaw.sin(), yaw.cos(), 0.0);
        let want = [
            V3::new(0.5, 0.0, 0.1) - b * 0.045,
            V3::new(0.5, 0.0, 0.1) + b * 0.045,
        ];
        assert_eq!(fingers.points.len(), 2);
        for (p, w) in fingers.points.iter().zip(want) {
            assert!((V3::new(p.x, p.y, p.z) - w).norm() < 1e-12, "{p:?} vs {w}");
        }
        let contacts = find(&m, "contacts");
        let c1 = &answer.contact_1;
        assert_eq!(
            (
                contacts.points[0].x,
                contacts.points[0].y,
                contacts.points[0].z
            ),
            (c1.x, c1.y, c1.z)
        );
        // The contacts lie on the closing line, on the box's faces y = ±0.03.
        for p in &contacts.points {
            assert!(((p.y).abs() - 0.03).abs() < 1e-12, "{p:?}");
        }
    }

    /// A sphere and a cylinder take their marker types, scaled to their diameters and height.
    #[test]
    fn spheres_and_cylinders_are_their_marker_types() {
        let sphere = pose_on(r#""primitive": {"type": 2, "dimensions": [0.035]}"#, 0.0);
        let object = find(&pose_markers(&sphere).1, "object").clone();
        assert_eq!(object.kind, Marker::SPHERE);
        assert_eq!((object.scale.x, object.scale.z), (0.07, 0.07));
        let cylinder = pose_on(
            r#""primitive": {"type": 3, "dimensions": [0.12, 0.033]}"#,
            0.0,
        );
        let object = find(&pose_markers(&cylinder).1, "object").clone();
        assert_eq!(object.kind, Marker::CYLINDER);
        assert_eq!(
            (object.scale.x, object.scale.y, object.scale.z),
            (0.066, 0.066, 0.12)
        );
    }

    /// A cone is a TRIANGLE_LIST: its tip at +height/2, its base disc at −height/2 within the
    /// radius, each triangle wound outward (its normal away from the axis or down).
    #[test]
    fn a_cone_is_drawn_as_triangles_wound_outward() {
        let cone = pose_on(
            r#""primitive": {"type": 4, "dimensions": [0.1, 0.04]}"#,
            0.0,
        );
        let object = find(&pose_markers(&cone).1, "object").clone();
        assert_eq!(object.kind, Marker::TRIANGLE_LIST);
        assert_eq!(object.points.len(), 6 * CONE_SIDES);
        let v = |p: &Point| V3::new(p.x, p.y, p.z);
        for t in object.points.chunks(3) {
            let [a, b, c] = [v(&t[0]), v(&t[1]), v(&t[2])];
            for p in [a, b, c] {
                assert!(p.z == 0.05 || (p.z == -0.05 && p.xy().norm() <= 0.04 + 1e-15));
            }
            let normal = (b - a).cross(&(c - a));
            let centroid = (a + b + c) / 3.0;
            assert!(
                normal.dot(&(centroid - V3::new(0.0, 0.0, 0.0))) > 0.0,
                "{t:?}"
            );
        }
    }

    /// An inline mesh is a TRIANGLE_LIST of its triangles' corners, scaled into metres, at the
    /// object's pose.
    #[test]
    fn a_mesh_is_drawn_as_its_triangles_in_metres() {
        let corners: Vec<String> = (0..8)
            .map(|i| {
                let c = |bit: usize, h: f64| if i & bit == 0 { -h } else { h };
                format!(
                    r#"{{"x": {}, "y": {}, "z": {}}}"#,
                    c(4, 20.0),
                    c(2, 30.0),
                    c(1, 40.0)
                )
            })
            .collect();
        let faces = [
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
        let triangles: Vec<String> = faces
            .iter()
            .map(|f| format!(r#"{{"vertex_indices": [{}, {}, {}]}}"#, f[0], f[1], f[2]))
            .collect();
        let mesh = format!(
            r#""inline_mesh": {{"vertices": [{}], "triangles": [{}]}}, "scale": {{"x": 0.001, "y": 0.001, "z": 0.001}}"#,
            corners.join(", "),
            triangles.join(", ")
        );
        let (_, m) = pose_markers(&pose_on(&mesh, 0.0));
        let object = find(&m, "object");
        assert_eq!(object.kind, Marker::TRIANGLE_LIST);
        assert_eq!(object.points.len(), 36);
        assert!(object
            .points
            .iter()
            .all(|p| (p.x.abs(), p.y.abs(), p.z.abs()) == (0.02, 0.03, 0.04)));
        assert_eq!((object.pose.position.x, object.pose.position.z), (0.5, 0.1));
    }
}
