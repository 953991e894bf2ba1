//! The forces of an answer, one type whichever solver gave them: at the recommended orientation,
//! at the current pose, and the nominal object's objective. Each solver's recommendation
//! (planar, planar robust, spatial robust; a spatial one carries its planar answer) becomes a
//! [`Forces`] here, and [`Forces::write`] is the one place they become the wire fields of
//! `GripRecommendation`.

use crate::msg::GripRecommendation;
use crate::solver::{planar, spatial};

/// The forces of one answer, N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Forces {
    /// The objective at the recommendation (for a robust answer, its worst case), N.
    pub(crate) gripping_power: f64,
    /// The squeeze each finger adds along the contact line there (robust: worst case), N.
    pub(crate) internal_force: f64,
    /// `(N1, F1, N2, F2)` there, N, in the candidate's labelling (robust: the nominal object's).
    pub(crate) contact_forces: [f64; 4],
    /// The larger push along the contact line either finger gives there (robust: worst case), N.
    pub(crate) finger_force: f64,
    /// The objective at the current pose, N (`+∞` where the pose cannot hold the grasp).
    pub(crate) gripping_power_current: f64,
    /// The squeeze at the current pose, N.
    pub(crate) internal_force_current: f64,
    /// The finger force at the current pose, N.
    pub(crate) finger_force_current: f64,
    /// The nominal object's objective at the recommendation, N (`gripping_power` when there
    /// are no tolerances).
    pub(crate) gripping_power_nominal: f64,
}

impl Forces {
    /// No answer: every force NaN.
    pub(crate) const NONE: Forces = Forces {
        gripping_power: f64::NAN,
        internal_force: f64::NAN,
        contact_forces: [f64::NAN; 4],
        finger_force: f64::NAN,
        gripping_power_current: f64::NAN,
        internal_force_current: f64::NAN,
        finger_force_current: f64::NAN,
        gripping_power_nominal: f64::NAN,
    };

    /// No orientation holds the grasp: no forces, and the current pose needs infinite ones.
    pub(crate) const NO_CLOSURE: Forces = Forces {
        gripping_power_current: f64::INFINITY,
        internal_force_current: f64::INFINITY,
        finger_force_current: f64::INFINITY,
        ..Forces::NONE
    };

    /// Every force but the nominal object's (`contact_forces`, `gripping_power_nominal`) times
    /// `k`: a heavier object at the same pose (every force is proportional to the mass).
    pub(crate) fn scaled(self, k: f64) -> Forces {
        Forces {
            gripping_power: self.gripping_power * k,
            internal_force: self.internal_force * k,
            finger_force: self.finger_force * k,
            gripping_power_current: self.gripping_power_current * k,
            internal_force_current: self.internal_force_current * k,
            finger_force_current: self.finger_force_current * k,
            ..self
        }
    }

    /// The wire fields of `reply` that carry forces, set from these.
    pub(crate) fn write(&self, reply: &mut GripRecommendation) {
        reply.gripping_power = self.gripping_power;
        reply.internal_force = self.internal_force;
        reply.contact_forces = self.contact_forces;
        reply.finger_force = self.finger_force;
        reply.gripping_power_current = self.gripping_power_current;
        reply.internal_force_current = self.internal_force_current;
        reply.finger_force_current = self.finger_force_current;
        reply.gripping_power_nominal = self.gripping_power_nominal;
    }
}

impl From<&planar::Recommendation> for Forces {
    fn from(r: &planar::Recommendation) -> Self {
        Forces {
            gripping_power: r.gripping_power,
            internal_force: r.internal_force,
            contact_forces: r.contact_forces,
            finger_force: r.finger_force,
            gripping_power_current: r.gripping_power_current,
            internal_force_current: r.internal_force_current,
            finger_force_current: r.finger_force_current,
            gripping_power_nominal: r.gripping_power,
        }
    }
}

impl From<&planar::robust::Recommendation> for Forces {
    fn from(r: &planar::robust::Recommendation) -> Self {
        Forces {
            gripping_power: r.gripping_power,
            internal_force: r.internal_force,
            contact_forces: r.contact_forces,
            finger_force: r.finger_force,
            gripping_power_current: r.gripping_power_current,
            internal_force_current: r.internal_force_current,
            finger_force_current: r.finger_force_current,
            gripping_power_nominal: r.gripping_power_nominal,
        }
    }
}

impl From<&spatial::robust::Recommendation> for Forces {
    fn from(r: &spatial::robust::Recommendation) -> Self {
        Forces {
            gripping_power: r.gripping_power,
            internal_force: r.internal_force,
            contact_forces: r.contact_forces,
            finger_force: r.finger_force,
            gripping_power_current: r.gripping_power_current,
            internal_force_current: r.internal_force_current,
            finger_force_current: r.finger_force_current,
            gripping_power_nominal: r.gripping_power_nominal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn distinct() -> Forces {
        Forces {
            gripping_power: 1.0,
            internal_force: 2.0,
            contact_forces: [3.0, 4.0, 5.0, 6.0],
            finger_force: 7.0,
            gripping_power_current: 8.0,
            internal_force_current: 9.0,
            finger_force_current: 10.0,
            gripping_power_nominal: 11.0,
        }
    }

    /// Every force field of the reply comes from the `Forces`, each from its own field, and
    /// nothing else of the reply changes.
    #[test]
    fn write_fills_each_wire_force_from_its_own_field() {
        let mut reply = GripRecommendation::default();
        distinct().write(&mut reply);
        let f = distinct();
        let wire = [
            reply.gripping_power,
            reply.internal_force,
            reply.finger_force,
            reply.gripping_power_current,
            reply.internal_force_current,
            reply.finger_force_current,
            reply.gripping_power_nominal,
        ];
        let ours = [
            f.gripping_power,
            f.internal_force,
            f.finger_force,
            f.gripping_power_current,
            f.internal_force_current,
            f.finger_force_current,
            f.gripping_power_nominal,
        ];
        assert_eq!(wire, ours);
        assert_eq!(reply.contact_forces, f.contact_forces);
        let mut rest = reply.clone();
        Forces {
            contact_forces: [0.0; 4],
            ..Forces::NONE
        }
        .write(&mut rest);
        let mut blank = GripRecommendation::default();
        Forces {
            contact_forces: [0.0; 4],
            ..Forces::NONE
        }
        .write(&mut blank);
        // NaN != NaN: compare the rest of the message through its debug text.
        assert_eq!(format!("{rest:?}"), format!("{blank:?}"));
    }

    /// A heavier object at the same pose: every force times `k` but the nominal object's.
    #[test]
    fn scaled_leaves_the_nominal_object_alone() {
        let s = distinct().scaled(2.0);
        assert_eq!(s.gripping_power, 2.0);
        assert_eq!(s.internal_force, 4.0);
        assert_eq!(s.finger_force, 14.0);
        assert_eq!(s.gripping_power_current, 16.0);
        assert_eq!(s.internal_force_current, 18.0);
        assert_eq!(s.finger_force_current, 20.0);
        assert_eq!(s.contact_forces, [3.0, 4.0, 5.0, 6.0]);
        assert_eq!(s.gripping_power_nominal, 11.0);
    }

    /// The nominal answer's own objective is its nominal objective.
    #[test]
    fn a_planar_answer_is_its_own_nominal() {
        let c = crate::solver::table_1::table_1('c');
        let Ok(planar::Verdict::Recommended(r)) =
            planar::solve(&c, &crate::solver::Settings::default())
        else {
            panic!("case (c) holds");
        };
        let f = Forces::from(&*r);
        assert_eq!(f.gripping_power_nominal, r.gripping_power);
        assert_eq!(f.contact_forces, r.contact_forces);
        assert_eq!(f.finger_force_current, r.finger_force_current);
    }
}
