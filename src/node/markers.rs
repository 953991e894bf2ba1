//! Markers for RViz and Foxglove, in the candidate's frame: the contacts, their friction cones,
//! the contact forces at the recommended pose, the centre of mass, and gravity now and after the
//! recommended rotation.

use crate::msg::{
    ColorRgba, GraspCandidate, GripRecommendation, Marker, MarkerArray, Point, Pose, Quaternion,
    Vector3,
};

/// Namespaces of the markers, one marker id each.
pub const NAMESPACES: [&str; 6] = [
    "contacts",
    "friction_cones",
    "contact_forces",
    "center_of_mass",
    "gravity_current",
    "gravity_recommended",
];

fn colour(r: f32, g: f32, b: f32) -> ColorRgba {
    ColorRgba { r, g, b, a: 1.0 }
}

fn at(x: f64, y: f64) -> Point {
    Point { x, y, z: 0.0 }
}

fn marker(candidate: &GraspCandidate, ns: &str, kind: i32, size: f64, c: ColorRgba) -> Marker {
    Marker {
        header: candidate.header.clone(),
        ns: ns.to_string(),
        id: 0,
        kind,
        action: Marker::ADD,
        pose: Pose {
            position: at(0.0, 0.0),
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

fn unit(x: f64, y: f64) -> (f64, f64) {
    let n = x.hypot(y);
    (x / n, y / n)
}

/// The markers for one answered candidate (status OK). Lengths scale with the contact distance;
/// force arrows scale so that the weight `m |g|` is one contact distance long.
pub fn build(candidate: &GraspCandidate, answer: &GripRecommendation) -> MarkerArray {
    let p = [&candidate.contact_1, &candidate.contact_2];
    let com = &candidate.center_of_mass;
    let span = (p[0].x - p[1].x).hypot(p[0].y - p[1].y);
    let thin = 0.02 * span;
    let weight = candidate.mass * candidate.gravity.x.hypot(candidate.gravity.y);

    let mut contacts = marker(
        candidate,
        "contacts",
        Marker::SPHERE_LIST,
        0.06 * span,
        colour(0.1, 0.4, 0.9),
    );
    contacts.points = p.iter().map(|q| at(q.x, q.y)).collect();

    let cones = friction_cones(candidate, span, thin);
    let forces = contact_forces(candidate, answer, span / weight, thin);

    let mut centre = marker(
        candidate,
        "center_of_mass",
        Marker::SPHERE,
        0.08 * span,
        colour(0.1, 0.1, 0.1),
    );
    centre.pose.position = at(com.x, com.y);

    let arrow = |ns: &str, (dx, dy): (f64, f64), c: ColorRgba| {
        let mut m = marker(candidate, ns, Marker::ARROW, thin, c);
        m.scale = Vector3 {
            x: thin,
            y: 2.0 * thin,
            z: 3.0 * thin,
        };
        m.points = vec![at(com.x, com.y), at(com.x + span * dx, com.y + span * dy)];
        m
    };
    let now = unit(candidate.gravity.x, candidate.gravity.y);
    let then = (answer.gravity_direction.x, answer.gravity_direction.y);
    MarkerArray {
        markers: vec![
            contacts,
            cones,
            forces,
            centre,
            arrow("gravity_current", now, colour(0.5, 0.5, 0.5)),
            arrow("gravity_recommended", then, colour(0.8, 0.1, 0.8)),
        ],
    }
}

/// Both friction cones: two edges each, half a contact distance long.
fn friction_cones(candidate: &GraspCandidate, span: f64, thin: f64) -> Marker {
    let p = [&candidate.contact_1, &candidate.contact_2];
    let n = [&candidate.normal_1, &candidate.normal_2];
    let mu = [candidate.friction_1, candidate.friction_2];
    let mut cones = marker(
        candidate,
        "friction_cones",
        Marker::LINE_LIST,
        thin,
        colour(0.2, 0.7, 0.2),
    );
    for i in 0..2 {
        let (nx, ny) = unit(n[i].x, n[i].y);
        let half = mu[i].atan();
        for side in [-half, half] {
            let (s, c) = side.sin_cos();
            let (dx, dy) = (c * nx - s * ny, s * nx + c * ny);
            cones.points.push(at(p[i].x, p[i].y));
            cones
                .points
                .push(at(p[i].x + 0.5 * span * dx, p[i].y + 0.5 * span * dy));
        }
    }
    cones
}

/// The forces the fingers apply, `force_scale` metres per newton: normal along the inward
/// normal, friction along it turned +90°.
fn contact_forces(
    candidate: &GraspCandidate,
    answer: &GripRecommendation,
    force_scale: f64,
    thin: f64,
) -> Marker {
    let p = [&candidate.contact_1, &candidate.contact_2];
    let n = [&candidate.normal_1, &candidate.normal_2];
    let mut forces = marker(
        candidate,
        "contact_forces",
        Marker::LINE_LIST,
        thin,
        colour(0.9, 0.2, 0.1),
    );
    for i in 0..2 {
        let (nx, ny) = unit(n[i].x, n[i].y);
        let (normal, friction) = (
            answer.contact_forces[2 * i],
            answer.contact_forces[2 * i + 1],
        );
        let fx = normal * nx - friction * ny;
        let fy = normal * ny + friction * nx;
        forces.points.push(at(p[i].x, p[i].y));
        forces
            .points
            .push(at(p[i].x + force_scale * fx, p[i].y + force_scale * fy));
    }
    forces
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Settings;

    #[test]
    fn markers_are_in_the_candidate_frame_and_finite() {
        let c = crate::msg::paper_cases().remove(0);
        let a = crate::msg::answer(&c, &Settings::default());
        let m = build(&c, &a);
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
}
