//! One spatial grasp of a batch (`crate::batch`): [`super::solve`]'s steps, with the storage of
//! the planar envelope's pieces handed from one grasp to the next and the answer not boxed. A
//! centre of mass on the contact axis (a search over planes, `on_axis.rs`) goes to the single
//! path as it is.

use super::answer::{AxisRelation, CurrentPose, Miss, NoForceClosure, Recommendation, Verdict};
use super::plane::{Basis, Geometry, PlaneSolve};
use super::{on_axis, Candidate, NEAR_AXIS, ON_AXIS};
use crate::planar::analysis::{Analysis, Pieces};
use crate::planar::frame::GraspFrame;
use crate::{InvalidInput, Settings};

/// What the batch answers for one spatial grasp: what [`super::solve`] answers, with `Ok(Ok(r))`
/// for `Ok(Verdict::Recommended(r))` (not boxed) and `Ok(Err(why))` for
/// `Ok(Verdict::NoForceClosure(why))`.
pub type SpatialAnswer = Result<Result<Recommendation, NoForceClosure>, InvalidInput>;

/// `spatial::solve(c, settings)`, keeping the pieces' storage in `pieces` for the next grasp.
pub(crate) fn solve(c: &Candidate, settings: &Settings, pieces: &mut Pieces) -> SpatialAnswer {
    let geometry = Geometry::new(c, settings.friction_safety_factor)?;
    if geometry.offset <= ON_AXIS {
        return on_axis::solve(&geometry, settings).map(|v| match v {
            Verdict::Recommended(r) => Ok(*r),
            Verdict::NoForceClosure(why) => Err(why),
        });
    }
    let axis = if geometry.offset < NEAR_AXIS {
        AxisRelation::NearAxis
    } else {
        AxisRelation::OffAxis
    };
    let basis = Basis::through_center_of_mass(&geometry);
    let plane = match PlaneSolve::new(&geometry, &basis, geometry.planar_points(&basis)) {
        Ok(p) => p,
        Err(Ok(misses)) => return Ok(Err(misses)),
        Err(Err(invalid)) => return Err(invalid),
    };
    // `plane.solve` (`planar_outcome` in `plane.rs`), with the pieces handed on.
    let frame = GraspFrame::from_valid(&plane.candidate, 1.0);
    let planar = match Analysis::reusing(&frame, settings.objective, std::mem::take(pieces)) {
        Ok(analysis) => {
            let r = analysis.recommend(&settings.range);
            *pieces = analysis.into_pieces();
            r?
        }
        Err(crate::planar::NoForceClosure { misses, .. }) => {
            return Ok(Err(NoForceClosure {
                misses: misses.into_iter().map(Miss::Cone).collect(),
                friction_safety_factor: geometry.safety,
            }))
        }
    };
    let current_pose = match geometry.out_of_plane(&basis, geometry.in_plane_tolerance()) {
        Some(out_of_plane) => CurrentPose::Swings { out_of_plane },
        None => CurrentPose::Held,
    };
    Ok(Ok(plane.assemble(planar, current_pose, axis)))
}
