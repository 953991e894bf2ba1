//! One planar grasp of a batch: [`crate::planar::solve`]'s steps, with the storage of the
//! envelope's pieces handed from one grasp to the next and the answer not boxed.

use crate::planar::analysis::{Analysis, Pieces};
use crate::planar::frame::GraspFrame;
use crate::planar::{Candidate, NoForceClosure, Recommendation};
use crate::{InvalidInput, Settings};

/// What the batch answers for one planar grasp: what [`crate::planar::solve`] answers, with
/// `Ok(Ok(r))` for `Ok(Verdict::Recommended(r))` (not boxed) and `Ok(Err(why))` for
/// `Ok(Verdict::NoForceClosure(why))`.
pub type PlanarAnswer = Result<Result<Recommendation, NoForceClosure>, InvalidInput>;

/// `planar::solve(c, settings)`, keeping the pieces' storage in `pieces` for the next grasp.
pub(super) fn solve(c: &Candidate, settings: &Settings, pieces: &mut Pieces) -> PlanarAnswer {
    let frame = GraspFrame::new(c, settings.friction_safety_factor)?;
    match Analysis::reusing(&frame, settings.objective, std::mem::take(pieces)) {
        Ok(analysis) => {
            let r = analysis.recommend(&settings.range);
            *pieces = analysis.into_pieces();
            Ok(Ok(r?))
        }
        Err(miss) => Ok(Err(miss)),
    }
}
