//! A pose candidate's answer apart from the node's counts and recording ([`PoseWork`]), so that
//! it can run on a loader thread (`loads.rs`).

use crate::answer::{markers, Answering};
use crate::msg::{
    GraspCandidate, GripRecommendation, MarkerArray, PoseCandidate, PoseRecommendation,
};
use crate::tf::ToolFrame;

/// The fewest triangles of an inline mesh (`object.inline_mesh`) for which a single pose candidate
/// is answered off the node's thread. An inline mesh is indexed anew for every candidate that
/// carries it (vertices merged, closedness and mass properties, the BVH): 0.5 to 1 µs a triangle.
/// `cargo bench --bench inline_mesh` measured, in one run each, a hop to smol's blocking pool and
/// back at 29 to 83 µs, and a whole answer on a 48- to 64-triangle mesh at 45 to 58 µs, on a
/// 100-triangle one at 64 to 66 µs, on a 1,000-triangle one at 0.55 to 0.64 ms: below 100
/// triangles the index costs about a hop or less, and the answer keeps its place among the pose
/// answers (docs/node.md).
pub(crate) const INLINE_OFF_THREAD_TRIANGLES: usize = 100;

/// `max_mesh_load_time` (s, checked in (0, 3600]) as a duration.
pub(crate) fn load_time(seconds: f64) -> std::time::Duration {
    std::time::Duration::try_from_secs_f64(seconds).unwrap_or(std::time::Duration::from_secs(3))
}

/// Answering one pose candidate, apart from the node's counts and recording: the settings in
/// force when it was received, whether its markers are wanted, and the node's meshes. It may run
/// on another thread.
#[derive(Debug, Clone)]
pub(crate) struct PoseWork {
    pub(super) with: Answering,
    pub(super) markers_on: bool,
    pub(super) echo: bool,
    /// `max_mesh_load_time`.
    pub(super) load_time: std::time::Duration,
    /// Where the answer's tool pose goes: `gravity_frame`, by the transform looked up when the
    /// candidate was turned by TF; `None`: it stays in the header frame.
    pub(super) tool_frame: Option<ToolFrame>,
}

impl PoseWork {
    /// The same work, its answer's tool pose re-expressed by `frame` (`None`: in the header
    /// frame).
    pub(crate) fn with_tool_frame(mut self, frame: Option<ToolFrame>) -> Self {
        self.tool_frame = frame;
        self
    }

    /// How long the answer waits for its mesh (`max_mesh_load_time`).
    pub(crate) fn load_time(&self) -> std::time::Duration {
        self.load_time
    }

    /// The answer at once, without a mesh loaded or indexed, when the candidate is refused
    /// before: an inline mesh beyond `max_inline_mesh_triangles`.
    pub(crate) fn refusal(&self, candidate: &PoseCandidate) -> Option<PoseRecommendation> {
        if self.echo {
            return None;
        }
        self.with
            .poses()
            .inline_too_large(&candidate.object)
            .map(|why| refused(candidate, &why.to_string()))
    }

    /// The answer, and its markers when they are on and wanted and the answer has status 0;
    /// its tool pose in [`PoseWork::with_tool_frame`]'s frame.
    pub(crate) fn run(
        &self,
        candidate: &PoseCandidate,
    ) -> (PoseRecommendation, Option<MarkerArray>) {
        let (mut reply, markers) = self.answer(candidate);
        if let Some(frame) = &self.tool_frame {
            frame.express(&mut reply.tool_pose);
        }
        (reply, markers)
    }

    /// [`PoseWork::run`] with the tool pose in the header frame.
    fn answer(&self, candidate: &PoseCandidate) -> (PoseRecommendation, Option<MarkerArray>) {
        if let Some(reply) = self.refusal(candidate) {
            return (reply, None);
        }
        if self.echo {
            let empty = GripRecommendation {
                header: candidate.header.clone(),
                candidate_id: candidate.id.clone(),
                ..GripRecommendation::default()
            };
            return (crate::answer::without_geometry(empty), None);
        }
        let (reply, object) = self.with.pose_with_object(candidate);
        let ok = reply.recommendation.status == GripRecommendation::STATUS_OK;
        let markers = (self.markers_on && ok).then(|| {
            let axis = self.with.poses().closing_axis();
            markers::build_pose(
                candidate,
                object.as_ref(),
                axis,
                &reply,
                self.with.settings(),
            )
        });
        (reply, markers)
    }
}

/// The status-2 answer to a pose candidate, saying `why`.
pub(crate) fn refused(candidate: &PoseCandidate, why: &str) -> PoseRecommendation {
    let stub = GraspCandidate {
        header: candidate.header.clone(),
        id: candidate.id.clone(),
        ..GraspCandidate::default()
    };
    crate::answer::without_geometry(crate::msg::invalid(&stub, &why))
}
