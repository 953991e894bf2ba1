//! What the planar solver answers: the recommendation with the paper's labels, its local
//! minima, and why a grasp has no force closure.

use crate::{Contact, Objective};
use nalgebra::Vector2;
use std::fmt;

/// One friction cone that misses the other contact (no force closure, eq. 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeMiss {
    /// The contact whose cone misses, in the candidate's labelling.
    pub contact: Contact,
    /// Half-angle of its cone after the safety factor, rad.
    pub half_angle: f64,
    /// Angle between its inward normal and the direction to the other contact, rad.
    pub angle_to_other: f64,
}

/// Why a grasp has no force closure: one or both cones miss the other contact.
#[derive(Debug, Clone, PartialEq)]
pub struct NoForceClosure {
    /// The cones that miss (one or two).
    pub misses: Vec<ConeMiss>,
    /// The safety factor that divided the friction coefficients.
    pub friction_safety_factor: f64,
}

impl fmt::Display for NoForceClosure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no force closure: ")?;
        for (i, m) in self.misses.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(
                f,
                "the friction cone at {} (half-angle {:.4} rad) misses {} by {:.4} rad",
                m.contact,
                m.half_angle,
                m.contact.other(),
                m.angle_to_other - m.half_angle
            )?;
        }
        if self.friction_safety_factor != 1.0 {
            write!(
                f,
                " (friction divided by safety factor {})",
                self.friction_safety_factor
            )?;
        }
        Ok(())
    }
}

/// Theorem 1's classification by which friction cones contain the centre of mass, in the
/// candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GraspCase {
    /// (a) both cones contain the centre of mass.
    A,
    /// (b) the cone at contact 1 contains it, the other does not.
    B,
    /// (c) the cone at contact 2 contains it, the other does not.
    C,
    /// (d) neither cone contains it.
    D,
}

impl GraspCase {
    /// `"a"` .. `"d"`.
    pub fn name(&self) -> &'static str {
        match self {
            GraspCase::A => "a",
            GraspCase::B => "b",
            GraspCase::C => "c",
            GraspCase::D => "d",
        }
    }
}

/// The paper's five candidate orientations (Theorem 1), in the candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperCandidate {
    /// Centre of mass above contact 2 (`θ_min`).
    A,
    /// Centre of mass and `p_ul` on one vertical (`θ_36`).
    B,
    /// Centre of mass below `p_uu` (`θ_34`), the paper's "meaningful" minimum.
    C,
    /// Centre of mass and `p_lu` on one vertical (`θ_45`).
    D,
    /// Centre of mass above contact 1 (`θ_max`).
    E,
}

impl PaperCandidate {
    /// `"A"` .. `"E"`.
    pub fn name(&self) -> &'static str {
        match self {
            PaperCandidate::A => "A",
            PaperCandidate::B => "B",
            PaperCandidate::C => "C",
            PaperCandidate::D => "D",
            PaperCandidate::E => "E",
        }
    }

    /// The same geometric candidate with the two contacts' labels exchanged.
    pub fn relabelled(self) -> Self {
        match self {
            PaperCandidate::A => PaperCandidate::E,
            PaperCandidate::B => PaperCandidate::D,
            PaperCandidate::C => PaperCandidate::C,
            PaperCandidate::D => PaperCandidate::B,
            PaperCandidate::E => PaperCandidate::A,
        }
    }
}

/// What became of the paper's candidate C (`θ_34`) for one grasp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CandidateC {
    /// Theorem 1 holds: `θ_34` is the recommendation.
    Recommended = 0,
    /// The objective passes through `θ_34` without a local minimum (Theorem 1 is wrong here).
    NotAMinimum = 1,
    /// `θ_34` is a local minimum, but another point of the allowed range is lower.
    Beaten = 2,
    /// `θ_34` lies outside the allowed range.
    OutOfRange = 3,
}

/// One local minimum of the objective over the graspable range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalMinimum {
    /// Gravity angle, rad (paper frame).
    pub gravity_angle: f64,
    /// Objective value there, N.
    pub power: f64,
    /// The paper's candidate it coincides with, if any (candidate's labelling).
    pub label: Option<PaperCandidate>,
}

/// The answer for a grasp with force closure.
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    /// The objective minimised.
    pub objective: Objective,
    /// Recommended gravity angle θ, rad, paper frame.
    pub gravity_angle: f64,
    /// Rotation of the object about +z of the candidate frame, rad in (-π, π], that takes the
    /// current pose to the recommended one.
    pub wrist_rotation: f64,
    /// Unit vector: where gravity points in the candidate frame after that rotation.
    pub gravity_direction: Vector2<f64>,
    /// Objective value at the recommendation, N.
    pub gripping_power: f64,
    /// Squeeze force each finger adds along the contact line there, N.
    pub internal_force: f64,
    /// `(N1, F1, N2, F2)` there, N, candidate's labelling (module conventions).
    pub contact_forces: [f64; 4],
    /// Objective value at the current pose, N.
    pub gripping_power_current: f64,
    /// Squeeze force needed at the current pose, N.
    pub internal_force_current: f64,
    /// Gravity angle of the current pose, rad, paper frame.
    pub current_gravity_angle: f64,
    /// Theorem 1's case.
    pub grasp_case: GraspCase,
    /// Every local minimum of the objective over the graspable range, in increasing angle.
    pub local_minima: Vec<LocalMinimum>,
    /// The paper's candidate the recommendation coincides with, if any.
    pub recommended_label: Option<PaperCandidate>,
    /// What became of candidate C.
    pub candidate_c: CandidateC,
    /// The larger push along the contact line that either finger gives at the recommendation, N:
    /// `internal_force + |W_line|/2`, with `W_line` the weight's component along the line. What
    /// each independently driven finger must give (coupled fingers give `internal_force`; the
    /// derivation is in `finger.rs`).
    pub finger_force: f64,
    /// The same at the current pose, N.
    pub finger_force_current: f64,
}

/// The solver's verdict on valid input.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The grasp can be held: here is the best orientation.
    Recommended(Box<Recommendation>),
    /// No orientation can hold the grasp.
    NoForceClosure(NoForceClosure),
}
