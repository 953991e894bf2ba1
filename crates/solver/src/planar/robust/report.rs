//! What is reported (module docs, section 7): the worst cases at the recommended and the
//! current pose, the nominal object's forces there, and the answer in today's message fields.

use super::region::BoxPoint;
use super::worst::Worst;
use crate::planar::analysis::Analysis;
use crate::planar::frame::GraspFrame;
use crate::planar::LocalMinimum;
use crate::sinusoid::wrap_angle;
use crate::Objective;
use nalgebra::Vector2;
use std::f64::consts::TAU;

/// The answer when the tolerances are not all zero and every object in them can be held.
///
/// "Worst" is the largest over the region of centres of mass (the box cut by the object) and
/// the mass interval, with friction `μ / s`.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "RobustRecommendation")]
pub struct Recommendation {
    /// The objective minimised (its worst case).
    pub objective: Objective,
    /// Recommended gravity angle θ, rad, in the nominal object's paper frame.
    pub gravity_angle: f64,
    /// Rotation of the object about +z of the candidate frame, rad in (-π, π], that takes the
    /// current pose to the recommended one.
    pub wrist_rotation: f64,
    /// Unit vector: where gravity points in the candidate frame after that rotation.
    pub gravity_direction: Vector2<f64>,
    /// Worst objective value at the recommended pose, N.
    pub gripping_power: f64,
    /// Where in the region `gripping_power` is attained (at the largest mass).
    pub gripping_power_at: BoxPoint,
    /// Worst squeeze force at the recommended pose, N.
    pub internal_force: f64,
    /// Where in the region `internal_force` is attained (at the largest mass; at the smallest
    /// where the squeeze is negative, which only the 1-norm's can be).
    pub internal_force_at: BoxPoint,
    /// Worst push of the harder-pushing finger along the contact line there, N:
    /// `internal_force + m_max |g| |sin θ| / 2` (module docs, section 7).
    pub finger_force: f64,
    /// Worst objective value at the current pose, N.
    pub gripping_power_current: f64,
    /// Worst squeeze force at the current pose, N.
    pub internal_force_current: f64,
    /// Worst finger force at the current pose, N.
    pub finger_force_current: f64,
    /// Gravity angle of the current pose, rad, paper frame, in `[θ_lo, θ_lo + 2π)` of the
    /// region's graspable range.
    pub current_gravity_angle: f64,
    /// The nominal object's objective value at the recommended pose, N.
    pub gripping_power_nominal: f64,
    /// The nominal object's squeeze force at the recommended pose, N.
    pub internal_force_nominal: f64,
    /// The nominal object's `(N1, F1, N2, F2)` at the recommended pose, N, candidate's
    /// labelling (conventions of [`crate`]).
    pub contact_forces: [f64; 4],
    /// Every local minimum of the worst objective over the region's graspable range, in
    /// increasing angle, unlabelled (the paper's candidates A–E belong to one object).
    pub local_minima: Vec<LocalMinimum>,
    /// The allowed gravity angles for every object in the region, rad, as closed intervals.
    pub allowed: Vec<(f64, f64)>,
    /// The gravity angles graspable (8) for every object in the region, rad.
    pub graspable: (f64, f64),
    /// The vertices of the region of centres of mass, in order around it.
    pub region: Vec<BoxPoint>,
    /// The largest mass, kg.
    pub mass_worst: f64,
    /// The nominal object's own answer (its own optimum).
    pub nominal: crate::planar::Recommendation,
}

impl Recommendation {
    /// The answer in the fields of today's [`crate::planar::Recommendation`] (a proposal for
    /// the message stage): the pose is the robust one; `gripping_power`, `internal_force` and their
    /// `_current` values are the worst cases; `contact_forces` are the nominal object's there;
    /// `local_minima` are the worst case's, unlabelled; `recommended_label` is `None` (the
    /// recommendation is no paper candidate of one object); `grasp_case` and `candidate_c`
    /// describe the nominal object (Theorem 1); `finger_force` and its `_current` value are the
    /// worst cases.
    pub fn to_recommendation(&self) -> crate::planar::Recommendation {
        crate::planar::Recommendation {
            objective: self.objective,
            gravity_angle: self.gravity_angle,
            wrist_rotation: self.wrist_rotation,
            gravity_direction: self.gravity_direction,
            gripping_power: self.gripping_power,
            internal_force: self.internal_force,
            contact_forces: self.contact_forces,
            gripping_power_current: self.gripping_power_current,
            internal_force_current: self.internal_force_current,
            current_gravity_angle: self.current_gravity_angle,
            grasp_case: self.nominal.grasp_case,
            local_minima: self.local_minima.clone(),
            recommended_label: None,
            candidate_c: self.nominal.candidate_c,
            finger_force: self.finger_force,
            finger_force_current: self.finger_force_current,
        }
    }
}

impl Worst {
    /// Everything the answer reports.
    pub(super) fn recommend(
        &self,
        nominal_analysis: &Analysis,
        nominal: crate::planar::Recommendation,
        mass_worst: f64,
    ) -> Recommendation {
        let f = &self.nominal_frame;
        let lo = self.graspable.0;
        let current = lo + (f.current_theta - lo).rem_euclid(TAU);
        let theta = self.minimiser(current);
        // Internal and finger force are proportional to the mass at one centre of mass, and
        // the centre of mass of the largest internal force gives the largest finger force
        // (`W_line` does not depend on it); each is then made the largest over the masses.
        let finger =
            |internal: f64, t: f64| self.over_masses(internal + 0.5 * self.weight * t.sin().abs());
        let ((power, power_at), (internal, internal_at)) = self.worst_at(theta);
        let ((power_now, _), (internal_now, _)) = self.worst_at(current);
        let at_nominal = nominal_analysis.evaluate(theta);
        Recommendation {
            objective: self.objective,
            gravity_angle: theta,
            wrist_rotation: wrap_angle(current - theta),
            gravity_direction: f.gravity_direction(theta),
            gripping_power: power,
            gripping_power_at: power_at,
            internal_force: self.over_masses(internal),
            internal_force_at: internal_at,
            finger_force: finger(internal, theta),
            gripping_power_current: power_now,
            internal_force_current: self.over_masses(internal_now),
            finger_force_current: finger(internal_now, current),
            current_gravity_angle: current,
            gripping_power_nominal: at_nominal.power,
            internal_force_nominal: at_nominal.internal_force,
            contact_forces: candidate_labelling(f, at_nominal.forces),
            local_minima: self.local_minima(),
            allowed: self.allowed.clone(),
            graspable: self.graspable,
            region: self.region.clone(),
            mass_worst,
            nominal,
        }
    }
}

/// Paper labelling and paper tangents to the candidate's labelling (conventions of
/// [`crate`]): the paper's tangent at contact 1 is minus "inward normal turned +90°".
fn candidate_labelling(f: &GraspFrame, forces: [f64; 4]) -> [f64; 4] {
    let [n1, f1, n2, f2] = forces;
    if f.swapped {
        [n2, f2, n1, -f1]
    } else {
        [n1, -f1, n2, f2]
    }
}
