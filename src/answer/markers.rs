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
//! The box of possible centres of mass (`center_of_mass_tolerance`, the node's where the
//! candidate gives none) is drawn as its edges around the centre of mass, in z = 0 for a planar
//! candidate (whose model ignores z); with no box the marker is a DELETE, so that a box drawn for
//! an earlier candidate does not stay on screen.

use crate::msg::{
    ColorRgba, GraspCandidate, GripRecommendation, Marker, MarkerArray, Point, Pose, Quaternion,
    Vector3,
};
use crate::solver::spatial;
use nalgebra::Vector3 as V3;

/// Namespaces of the markers, one marker id each.
pub const NAMESPACES: [&str; 7] = [
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
}
