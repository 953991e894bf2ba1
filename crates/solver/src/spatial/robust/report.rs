//! What is reported (module docs §7): the answer at the least worst case and at the current
//! tilt, the nominal object's forces there, and one local minimum per fan.

use super::problem::Problem;
use super::region::RegionPoint;
use crate::planar::analysis::Analysis;
use crate::planar::frame::GraspFrame;
use crate::planar::paper::FORCE_SCALE;
use crate::planar::robust::Envelope;
use crate::planar::LocalMinimum;
use crate::Objective;
use nalgebra::{Vector2, Vector3};

/// Two local minima of the sampled worst case are one (a fan) when the envelope between them
/// rises above the higher by at most this fraction of the weight at the largest mass: 1e-5
/// `m_max |g|`, 9.8e-5 N for 1 kg (module docs §7, *One minimum per fan*).
pub const FAN_BARRIER: f64 = 1e-5;

/// The answer when a tolerance is not zero and every object in it can be held. "Worst" is the
/// largest over the region (the box cut by the object's tangent planes) and the mass interval.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialRobustRecommendation")]
pub struct Recommendation {
    /// The objective minimised (its worst case).
    pub objective: Objective,
    /// The recommended gravity angle θ*, rad in `[−π/2, π/2]`: `sin θ* = ĝ · a`, the tilt of the
    /// contact axis; every object hangs at θ* in its own plane (module docs §1).
    pub gravity_angle: f64,
    /// Unit vector, candidate frame: the recommended gravity at which the nominal object hangs at
    /// rest, `sin θ* a + cos θ* v_0`. Any rotation of the wrist about the contact axis from
    /// there gives the same hang.
    pub gravity_direction: Vector3<f64>,
    /// Unit axis, candidate frame, of the smallest rotation of the object taking the current
    /// gravity to `gravity_direction`.
    pub rotation_axis: Vector3<f64>,
    /// Angle of that rotation, rad in `[0, π]`.
    pub rotation_angle: f64,
    /// Worst objective value at the recommended tilt, N.
    pub gripping_power: f64,
    /// Where in the region it is attained (at the largest mass).
    pub gripping_power_at: RegionPoint,
    /// Worst squeeze at the recommended tilt, N.
    pub internal_force: f64,
    /// Where in the region it is attained (at the largest mass).
    pub internal_force_at: RegionPoint,
    /// Worst push of the harder-pushing finger along the contact axis, N: `internal_force +
    /// m_max |g| |sin θ*| / 2`.
    pub finger_force: f64,
    /// The certified bound: no tilt in the allowed range has a worst objective below
    /// `gripping_power − optimality_gap`, N (module docs §5).
    pub optimality_gap: f64,
    /// Worst objective after every object swings at the current pose, N.
    pub gripping_power_current: f64,
    /// Worst squeeze there, N.
    pub internal_force_current: f64,
    /// Worst finger force there, N.
    pub finger_force_current: f64,
    /// The gravity angle every object hangs at from the current pose, `asin(ĝ_0 · a)`, rad.
    pub current_gravity_angle: f64,
    /// The nominal object's objective value at rest at the recommended tilt, N.
    pub gripping_power_nominal: f64,
    /// The nominal object's squeeze there, N.
    pub internal_force_nominal: f64,
    /// The nominal object's `(N1, F1, N2, F2)` there, N, split as
    /// [`crate::spatial::Recommendation`] splits them (in the nominal's plane).
    pub contact_forces: [f64; 4],
    /// The nominal object's contact forces there as 3D vectors, candidate frame, N.
    pub force_vectors: [Vector3<f64>; 2],
    /// Local minima of the worst case over the allowed range, one per fan of minima separated by
    /// less than [`FAN_BARRIER`] (module docs §7), in increasing angle, unlabelled.
    pub local_minima: Vec<LocalMinimum>,
    /// The allowed gravity angles for every object, rad, as closed intervals in `[−π/2, π/2]`.
    pub allowed: Vec<(f64, f64)>,
    /// The vertices of the region of centres of mass.
    pub region: Vec<RegionPoint>,
    /// The region's points on the contact axis, as a segment, if it meets the axis.
    pub axis_segment: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The largest mass, kg.
    pub mass_worst: f64,
    /// How many points the exchange method used (module docs §5).
    pub samples: usize,
    /// How many pieces of edges the certified maximisations split in all (module docs §4): the
    /// work of this answer, bounded (module docs §4).
    pub splits: usize,
    /// The nominal object's own answer.
    pub nominal: crate::spatial::Recommendation,
}

impl Problem {
    /// Everything the answer reports (module docs §7).
    pub(super) fn recommend(
        &self,
        allowed: Vec<(f64, f64)>,
        nominal: crate::spatial::Recommendation,
    ) -> Recommendation {
        let (theta, gap, envelope, samples) = self.exchange(&allowed);
        let w = self.weight;
        let power = self.worst(false, theta);
        let squeeze = self.worst(true, theta);
        let power_now = self.worst(false, self.current);
        let squeeze_now = self.worst(true, self.current);
        let finger = |sq: f64, at: f64| w * (sq + 0.5 * at.sin().abs());
        let in_range = envelope
            .local_minima(FORCE_SCALE)
            .into_iter()
            .filter(|m| {
                allowed
                    .iter()
                    .any(|&(a, b)| m.gravity_angle >= a && m.gravity_angle <= b)
            })
            .collect();
        let local_minima = one_per_fan(&envelope, in_range)
            .into_iter()
            .map(|m| LocalMinimum {
                power: w * self.worst(false, m.gravity_angle).value,
                ..m
            })
            .collect();
        let (n, v) = (&self.view, self.reference);
        let v3 = n.b1 * v.x + n.b2 * v.y;
        let (s, k) = theta.sin_cos();
        let direction = n.a * s + v3 * k;
        let (rotation_axis, rotation_angle) = rotation(&direction, &self.g0, &n.a.cross(&v3));
        let (nominal_values, contact_forces, force_vectors) = self.nominal_at(theta, &nominal);
        Recommendation {
            objective: self.objective,
            gravity_angle: theta,
            gravity_direction: direction,
            rotation_axis,
            rotation_angle,
            gripping_power: w * power.value,
            gripping_power_at: self.region_point(&power.point),
            internal_force: w * squeeze.value,
            internal_force_at: self.region_point(&squeeze.point),
            finger_force: finger(squeeze.value, theta),
            optimality_gap: w * gap,
            gripping_power_current: w * power_now.value,
            internal_force_current: w * squeeze_now.value,
            finger_force_current: finger(squeeze_now.value, self.current),
            current_gravity_angle: self.current,
            gripping_power_nominal: nominal_values.power,
            internal_force_nominal: nominal_values.internal_force,
            contact_forces,
            force_vectors,
            local_minima,
            allowed,
            region: self.region.vertices.clone(),
            axis_segment: match self.axis_points.as_slice() {
                [a, b] => Some((n.position(a), n.position(b))),
                _ => None,
            },
            mass_worst: self.mass_worst,
            samples,
            splits: self.splits.get(),
            nominal,
        }
    }

    /// The nominal object at rest at tilt `theta` in its plane: its values (N), its contact
    /// forces split as the nominal answer splits them, and as 3D vectors.
    pub(super) fn nominal_at(
        &self,
        theta: f64,
        nominal: &crate::spatial::Recommendation,
    ) -> (crate::planar::PointValue, [f64; 4], [Vector3<f64>; 2]) {
        let frame = GraspFrame {
            weight: self.nominal_weight,
            ..self.frame_at(&self.center, Some(self.reference))
        };
        let value = match Analysis::new(&frame, self.objective) {
            Ok(a) => a.evaluate(theta),
            Err(_) => crate::planar::PointValue {
                alpha_min: f64::NAN,
                alpha: f64::NAN,
                power: f64::NAN,
                internal_force: f64::NAN,
                forces: [f64::NAN; 4],
            },
        };
        // Paper frame (e_x, e_y) = (a, −v): the paper's normals and tangents (`planar/paper.rs`).
        let [n1, f1, n2, f2] = value.forces;
        let p1 = Vector2::new(
            -frame.s1 * n1 - frame.c1 * f1,
            -frame.c1 * n1 + frame.s1 * f1,
        );
        let p2 = Vector2::new(
            frame.s2 * n2 + frame.c2 * f2,
            -frame.c2 * n2 + frame.s2 * f2,
        );
        let v3 = self.view.b1 * self.reference.x + self.view.b2 * self.reference.y;
        let lift = |q: Vector2<f64>| self.view.a * q.x - v3 * q.y;
        let vectors = [lift(p1), lift(p2)];
        let split = |i: usize| {
            (
                vectors[i].dot(&nominal.normal_directions[i]),
                vectors[i].dot(&nominal.friction_directions[i]),
            )
        };
        let ((a, b), (c, d)) = (split(0), split(1));
        (value, [a, b, c, d], vectors)
    }
}

/// The local minima of `R_S` (`minima`, in increasing angle, values in units of the weight), one
/// per fan (module docs §7, *One minimum per fan*): each joins the last one kept when the
/// envelope between the two rises above the higher of them by at most [`FAN_BARRIER`]; a fan
/// keeps its lowest (the first of equals).
fn one_per_fan(envelope: &Envelope, minima: Vec<LocalMinimum>) -> Vec<LocalMinimum> {
    let mut kept: Vec<LocalMinimum> = Vec::with_capacity(minima.len());
    for m in minima {
        if let Some(last) = kept.last_mut() {
            let higher = last.power.max(m.power);
            let barrier =
                envelope.highest_between(last.gravity_angle, m.gravity_angle, FORCE_SCALE);
            if barrier - higher <= FAN_BARRIER {
                if m.power < last.power {
                    *last = m;
                }
                continue;
            }
        }
        kept.push(m);
    }
    kept
}

/// The smallest rotation of the object taking the current gravity `g0` to `d` (both unit), as
/// (unit axis, angle in `[0, π]`); `fallback` when they are parallel (spatial module docs §4).
fn rotation(d: &Vector3<f64>, g0: &Vector3<f64>, fallback: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let cross = d.cross(g0);
    let norm = cross.norm();
    let angle = norm.atan2(d.dot(g0));
    if norm > 0.0 {
        (cross / norm, angle)
    } else {
        (fallback.normalize(), angle)
    }
}
