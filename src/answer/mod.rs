//! The answer layer: the policy that turns a candidate or a set into its answer, between the wire
//! types (`crate::msg`) and the mathematics (`crate::solver`), below the node, the command line
//! and replay, which all answer through it.
//!
//! - [`answer`] and [`answer_in_full`] (`candidate.rs`): which solver answers one candidate
//!   (planar or spatial, nominal or robust), with which tolerances, and the refusals.
//! - [`answer_one`], [`answer_set`] and [`rank`] (`sets.rs`): the grip force a gripper is set to,
//!   the gripper's limit, the node's default tolerances, and sets answered and ranked.
//! - [`PoseAnswerer`] (`pose/`): a gripper pose on an object (a pose candidate or a set of
//!   them) → contacts, normals and centre of mass (`grasp_orient_geometry`) → the spatial
//!   candidate they make, answered and ranked as above.
//! - [`markers`]: an answer drawn for RViz and Foxglove.
//!
//! - [`Forces`] (`forces.rs`): the forces of an answer, whichever solver gave them, and the one
//!   place they become wire fields; `reply.rs` builds the published reply from a solver's answer.
//!
//! To add an output field: fill it here (or in the solver), declare it in `msg/*.msg` and the wire
//! struct (`crate::msg`), and map it in `reply.rs` (a force: in `forces.rs`).

mod answering;
mod candidate;
mod forces;
pub mod markers;
mod pose;
mod reply;
mod sets;

pub(crate) use answering::SetKind;
#[cfg(test)]
pub(crate) use answering::{each, VisitAnswer};
pub use answering::{Answer, Answering};
#[cfg(test)]
pub(crate) use candidate::answer;
pub(crate) use candidate::BEHIND_TANGENT_NOTE;
pub use candidate::{answer_in_full, Answered};
pub(crate) use pose::{uncast, without_geometry, Refused};
pub use pose::{PoseAnswerer, MESH_CACHE_BYTES};
pub(crate) use sets::SetAnswer;
pub(crate) use sets::{
    answer_one, answer_one_in_full, answer_set, answer_set_on, answer_set_within, cut_like,
    is_sorted_by, DEFAULT_MAX_SET_SIZE, PARALLEL_FROM,
};
pub use sets::{
    busy, rank, solver_pool, DefaultTolerances, GripperDrive, Halt, Interrupt, PoolRefused, RankBy,
    Rules,
};
