//! A set as it came and its answer, of either set kind, as the set thread and the node hand them
//! over ([`SetInput`], [`SetReply`], [`SetOutcome`]).

use crate::kind::{PoseSets, Sets};
use crate::msg::{
    CompactString, GraspCandidateSet, GripRecommendation, GripRecommendationSet, MarkerArray,
    PoseCandidateSet, PoseRecommendationSet,
};
use crate::record::Payload;

/// A set as it came: of candidates (`grasp_candidate_sets`, `~/recommend`) or of gripper poses
/// (`pose_candidate_sets`, `~/recommend_poses`).
#[derive(Debug, Clone)]
pub(crate) enum SetInput {
    /// A `GraspCandidateSet`.
    Candidates(GraspCandidateSet),
    /// A `PoseCandidateSet` (boxed: its object is large).
    Poses(Box<PoseCandidateSet>),
}

impl SetInput {
    /// The message for the recording.
    pub(super) fn payload(self) -> Payload {
        match self {
            SetInput::Candidates(set) => Payload::request::<Sets>(set),
            SetInput::Poses(set) => Payload::request::<PoseSets>(*set),
        }
    }
}

/// A set's answer, of the kind of its set.
#[derive(Debug, Clone)]
pub(crate) enum SetReply {
    /// To a `GraspCandidateSet`.
    Candidates(GripRecommendationSet),
    /// To a `PoseCandidateSet`.
    Poses(PoseRecommendationSet),
}

impl SetReply {
    /// The set's id.
    pub(crate) fn set_id(&self) -> &CompactString {
        match self {
            SetReply::Candidates(r) => &r.set_id,
            SetReply::Poses(r) => &r.set_id,
        }
    }

    /// The set's status.
    pub(crate) fn status(&self) -> u8 {
        match self {
            SetReply::Candidates(r) => r.status,
            SetReply::Poses(r) => r.status,
        }
    }

    /// Why, when the status is not OK.
    pub(crate) fn message(&self) -> &str {
        match self {
            SetReply::Candidates(r) => &r.message,
            SetReply::Poses(r) => &r.message,
        }
    }

    /// The members' recommendations, in order.
    pub(crate) fn members(&self) -> Vec<&GripRecommendation> {
        match self {
            SetReply::Candidates(r) => r.recommendations.iter().collect(),
            SetReply::Poses(r) => r
                .recommendations
                .iter()
                .map(|p| &p.recommendation)
                .collect(),
        }
    }

    /// How many members are ranked, and by which field.
    pub(crate) fn ranked(&self) -> (usize, &str) {
        match self {
            SetReply::Candidates(r) => (r.ranking.len(), &r.ranked_by),
            SetReply::Poses(r) => (r.ranking.len(), &r.ranked_by),
        }
    }

    /// The message for the recording.
    pub(super) fn payload(self) -> Payload {
        match self {
            SetReply::Candidates(r) => Payload::answer::<Sets>(r),
            SetReply::Poses(r) => Payload::answer::<PoseSets>(r),
        }
    }

    /// The answer to a candidate set (tests).
    #[cfg(test)]
    pub(crate) fn candidates(&self) -> &GripRecommendationSet {
        match self {
            SetReply::Candidates(r) => r,
            SetReply::Poses(_) => panic!("a pose set's answer"),
        }
    }
}

/// The answer to one set, to publish (or send as the service's response) in this order:
/// `reply`, then `markers`.
#[derive(Debug)]
pub(crate) struct SetOutcome {
    /// The answer to the set.
    pub reply: SetReply,
    /// The markers of the best candidate, when they are on and one can be held.
    pub markers: Option<MarkerArray>,
    /// What goes to the recording once the answer is out.
    pub recorded: RecordedSet,
}

/// The messages of one set's answer for the recording, with the set's times.
#[derive(Debug)]
pub(crate) struct RecordedSet {
    pub(super) set: SetInput,
    pub(super) received: u64,
    pub(super) sent: u64,
    pub(super) reply: Option<SetReply>,
    pub(super) markers: Option<MarkerArray>,
}

impl RecordedSet {
    /// What to record of a set received at `received` and sent at `sent` (ns since the epoch):
    /// the set, and its answer and markers when they are recorded.
    pub(crate) fn new(
        reply: Option<SetReply>,
        markers: Option<MarkerArray>,
        set: SetInput,
        received: u64,
        sent: u64,
    ) -> Self {
        Self {
            set,
            received,
            sent,
            reply,
            markers,
        }
    }
}
