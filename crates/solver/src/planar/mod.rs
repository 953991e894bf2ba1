//! Planar grasps: the paper's problem, solved exactly (`docs/theory.md`).
//!
//! [`solve`] answers one [`Candidate`]; [`analyse`] gives the whole curve of gripping
//! power over the graspable range. The submodules hold the types and the steps: `candidate` the
//! grasp, `answer` the answer's types, `frame` the paper frame and the input checks, `paper` the
//! paper's closed forms, `analysis` the envelope and the objective on it, `curve` the objective's
//! pieces and the walk that finds their local minima, `finger` the force each finger must give,
//! and `robust` the worst case over a box of centres of mass and a mass tolerance.

pub(crate) mod analysis;
mod answer;
pub(crate) mod candidate;
pub(crate) mod curve;
pub(crate) mod finger;
pub(crate) mod frame;
pub(crate) mod paper;
pub mod robust;

pub use analysis::{Analysis, PointValue};
pub use answer::{
    CandidateC, ConeMiss, GraspCase, LocalMinimum, NoForceClosure, PaperCandidate, Recommendation,
    Verdict,
};
pub use candidate::Candidate;
pub use paper::CandidateAngles;

use crate::{InvalidInput, Settings};
use frame::GraspFrame;

/// Solves one candidate: the orientation of least gripping power and the forces it needs.
///
/// Bad input is an `Err`; a valid grasp that cannot be held is `Ok(Verdict::NoForceClosure)`.
///
/// # Example
/// The paper's case study (c) (Table 1): a square held at the middle of two opposite sides,
/// friction √3 and 1/√3, `Mg = 1`. The least gripping power is at candidate C,
/// `θ_34 = -π/12` (Table 2 prints +0.261: its sign is wrong, see `tests/it/paper.rs`).
/// ```
/// use grasp_orient_solver::{planar::{self, Candidate, PaperCandidate, Verdict}, Settings};
/// use nalgebra::Vector2;
///
/// let grasp = Candidate {
///     contact_1: Vector2::new(1.0, 1.0),
///     contact_2: Vector2::new(-1.0, 1.0),
///     normal_1: Vector2::new(-1.0, 0.0),
///     normal_2: Vector2::new(1.0, 0.0),
///     friction_1: 3f64.sqrt(),
///     friction_2: 1.0 / 3f64.sqrt(),
///     center_of_mass: Vector2::zeros(),
///     mass: 1.0,
///     gravity: Vector2::new(0.0, -1.0),
/// };
/// let Ok(Verdict::Recommended(r)) = planar::solve(&grasp, &Settings::default()) else {
///     panic!("the grasp has force closure");
/// };
/// assert!((r.gravity_angle + std::f64::consts::PI / 12.0).abs() < 1e-12);
/// assert_eq!(r.recommended_label, Some(PaperCandidate::C));
/// assert!((r.gripping_power - 1.0).abs() < 1e-12); // P = Mg here
/// ```
#[doc(alias = "solve_orientation")]
pub fn solve(candidate: &Candidate, settings: &Settings) -> Result<Verdict, InvalidInput> {
    // `analyse`, without the Result around its Result: the analysis is not moved once more.
    let frame = GraspFrame::new(candidate, settings.friction_safety_factor)?;
    match Analysis::new(&frame, settings.objective) {
        Ok(analysis) => Ok(Verdict::Recommended(Box::new(
            analysis.recommend(&settings.range)?,
        ))),
        Err(miss) => Ok(Verdict::NoForceClosure(miss)),
    }
}

/// The gripping power of one grasp over its whole graspable range, for plots and studies: what
/// [`solve`] minimises, with the paper's bounds and candidate angles. Uses the
/// objective and friction safety factor of `settings` (the range only matters to
/// [`Analysis::recommend`]).
///
/// Bad input is an `Err`; a valid grasp without force closure is `Ok(Err(NoForceClosure))`.
pub fn analyse(
    candidate: &Candidate,
    settings: &Settings,
) -> Result<Result<Analysis, NoForceClosure>, InvalidInput> {
    let frame = GraspFrame::new(candidate, settings.friction_safety_factor)?;
    Ok(Analysis::new(&frame, settings.objective))
}
