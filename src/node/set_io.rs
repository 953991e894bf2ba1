//! A set as it came and its answer, of any set kind, as the set thread and the node hand them
//! over ([`SetInput`], [`SetReply`], [`SetOutcome`]). Each holds its kind's message behind one
//! interface, so that the queue, the set thread, the counts and the recording are the same code
//! for every kind ([`NodeSet`]).

use super::set_kinds::{NodeSet, SetEndpoints, Solving};
use crate::answer::{Answering, Rules, SetAnswer};
use crate::config::objects::ObjectTable;
use crate::msg::{CompactString, GripRecommendation, MarkerArray};
use crate::record::Payload;
use crate::tf::{self, Gravity, TfBuffer, TfFailure, ToolFrame};
use futures::future::LocalBoxFuture;
use ros2_client::RmwRequestId;
#[cfg(test)]
use std::any::Any;
use std::time::Duration;

/// Where a set came from, and so where its answer goes.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Via {
    /// The topic `grasp_candidate_sets`; `taken`: from the set's arrival in the DDS reader to the
    /// node's thread taking it.
    Topic {
        /// From arrival to taken.
        taken: Duration,
    },
    /// A call of `~/recommend` (a candidate set) or of `~/recommend_poses` (a pose set),
    /// answered to this request.
    Service(RmwRequestId),
    /// A call of `~/rank_grasps` (or an object of the grasp planner proxy's), answered as a pose
    /// set and mapped onto its grasps.
    Grasps(super::grasps::Caller),
}

/// A set as it came, of any set kind: from its topic or a call of its service.
#[derive(Debug)]
pub(crate) struct SetInput(Box<dyn HeldSet>);

/// What the set thread does with a set, whatever its kind.
trait HeldSet: std::fmt::Debug + Send {
    #[cfg(test)]
    fn id(&self) -> &str;
    fn members(&self) -> usize;
    fn busy(&self, rules: &Rules, max_queued: usize) -> SetReply;
    fn echo(&self) -> SetReply;
    fn solve(&self, s: &Solving) -> (SetReply, Option<MarkerArray>);
    fn needs_tf(&self, gravity: &Gravity) -> bool;
    fn resolve(&self, buffer: &TfBuffer, gravity: &Gravity) -> Result<SetInput, TfFailure>;
    fn refused(&self, with: &Answering, why: &str) -> SetReply;
    fn fill(&mut self, table: &ObjectTable) -> bool;
    fn payload(self: Box<Self>) -> Payload;
    #[cfg(test)]
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

/// A set of kind `K`, and the frame its answer's tool poses go into once it was turned by TF
/// with `gravity_frame` set (`None`: the header frame, or a kind without tool poses).
struct Held<K: NodeSet>(K::Request, Option<ToolFrame>);

impl<K: NodeSet> std::fmt::Debug for Held<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {:?}", K::ONE, K::set_id(&self.0))
    }
}

impl<K: NodeSet> HeldSet for Held<K> {
    #[cfg(test)]
    fn id(&self) -> &str {
        K::set_id(&self.0)
    }
    fn members(&self) -> usize {
        K::members(&self.0)
    }
    fn busy(&self, rules: &Rules, max_queued: usize) -> SetReply {
        SetReply::new::<K>(K::busy(&self.0, rules, max_queued))
    }
    fn echo(&self) -> SetReply {
        SetReply::new::<K>(K::echo(&self.0))
    }
    fn solve(&self, s: &Solving) -> (SetReply, Option<MarkerArray>) {
        let (mut reply, markers) = K::solve(s, &self.0);
        if let Some(frame) = &self.1 {
            K::express(&mut reply, frame);
        }
        (SetReply::new::<K>(reply), markers)
    }
    fn needs_tf(&self, gravity: &Gravity) -> bool {
        tf::needs::<K>(gravity, &self.0)
    }
    fn resolve(&self, buffer: &TfBuffer, gravity: &Gravity) -> Result<SetInput, TfFailure> {
        let turned = tf::resolve::<K>(buffer, gravity, &self.0)?;
        // The same pair of frames at the same stamp as the gravity's: found when it was.
        let frame = match K::tool_header(&self.0) {
            Some(header) => tf::tool_frame(buffer, &gravity.frame, header).transpose()?,
            None => None,
        };
        Ok(SetInput(Box::new(Held::<K>(turned, frame))))
    }
    fn refused(&self, with: &Answering, why: &str) -> SetReply {
        SetReply::new::<K>(K::refused(with, &self.0, why))
    }
    fn fill(&mut self, table: &ObjectTable) -> bool {
        K::object_mut(&mut self.0).is_some_and(|o| table.fill(o))
    }
    fn payload(self: Box<Self>) -> Payload {
        Payload::request::<K>(self.0)
    }
    #[cfg(test)]
    fn as_any_mut(&mut self) -> &mut dyn Any {
        &mut self.0
    }
}

impl SetInput {
    /// A set of kind `K`.
    pub(crate) fn new<K: NodeSet>(set: K::Request) -> Self {
        Self(Box::new(Held::<K>(set, None)))
    }

    /// The set's id (the test hook's trigger).
    #[cfg(test)]
    pub(crate) fn id(&self) -> &str {
        self.0.id()
    }

    /// How many members it has.
    pub(crate) fn members(&self) -> usize {
        self.0.members()
    }

    /// `STATUS_BUSY` (or the set's own refusal), nothing solved.
    pub(crate) fn busy(&self, rules: &Rules, max_queued: usize) -> SetReply {
        self.0.busy(rules, max_queued)
    }

    /// Status 2 (`STATUS_INVALID_INPUT`) saying `why`, nothing solved, no recommendations.
    pub(crate) fn failed(&self, rules: &Rules, why: &str) -> SetReply {
        let mut reply = self.busy(rules, 0);
        reply.0.refuse(why);
        reply
    }

    /// An empty answer per member, nothing solved (echo mode).
    pub(crate) fn echo(&self) -> SetReply {
        self.0.echo()
    }

    /// The set's answer, solved, and its best member's markers ([`NodeSet::solve`]).
    pub(crate) fn solve(&self, s: &Solving) -> (SetReply, Option<MarkerArray>) {
        self.0.solve(s)
    }

    /// Whether it needs TF ([`tf::needs`]).
    pub(crate) fn needs_tf(&self, gravity: &Gravity) -> bool {
        self.0.needs_tf(gravity)
    }

    /// It turned by TF ([`tf::resolve`]), or the first transform missing.
    pub(crate) fn resolve(
        &self,
        buffer: &TfBuffer,
        gravity: &Gravity,
    ) -> Result<SetInput, TfFailure> {
        self.0.resolve(buffer, gravity)
    }

    /// The set refused whole with status 2, `invalid input: {why}`, nothing solved
    /// ([`crate::answer::Answer::refused`]).
    pub(crate) fn refused(&self, with: &Answering, why: &str) -> SetReply {
        self.0.refused(with, why)
    }

    /// Its object's mass and friction filled from `table` where it has a mesh resource in it
    /// and gives none ([`ObjectTable::fill`]); whether any was.
    pub(crate) fn fill(&mut self, table: &ObjectTable) -> bool {
        self.0.fill(table)
    }

    /// The message for the recording.
    pub(super) fn payload(self) -> Payload {
        self.0.payload()
    }

    /// The set, when it is of kind `K` (tests).
    #[cfg(test)]
    pub(crate) fn get_mut<K: NodeSet>(&mut self) -> Option<&mut K::Request> {
        self.0.as_any_mut().downcast_mut()
    }
}

/// A set's answer, of the kind of its set.
#[derive(Debug)]
pub(crate) struct SetReply(Box<dyn HeldReply>);

/// What the node does with a set's answer, whatever its kind.
trait HeldReply: std::fmt::Debug + Send {
    fn answer(&self) -> &dyn SetAnswer;
    fn refuse(&mut self, why: &str);
    fn payload(self: Box<Self>) -> Payload;
    fn clone_box(&self) -> Box<dyn HeldReply>;
    fn send<'a>(
        self: Box<Self>,
        endpoints: &'a SetEndpoints,
        via: Via,
    ) -> LocalBoxFuture<'a, Result<(), String>>;
    #[cfg(test)]
    fn as_any(&self) -> &dyn Any;
}

/// An answer of kind `K`.
struct Replied<K: NodeSet>(K::Answer);

impl<K: NodeSet> std::fmt::Debug for Replied<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl<K: NodeSet> HeldReply for Replied<K> {
    fn answer(&self) -> &dyn SetAnswer {
        &self.0
    }
    fn refuse(&mut self, why: &str) {
        self.0.refuse(why);
    }
    fn payload(self: Box<Self>) -> Payload {
        Payload::answer::<K>(self.0)
    }
    fn clone_box(&self) -> Box<dyn HeldReply> {
        Box::new(Replied::<K>(self.0.clone()))
    }
    fn send<'a>(
        self: Box<Self>,
        endpoints: &'a SetEndpoints,
        via: Via,
    ) -> LocalBoxFuture<'a, Result<(), String>> {
        let endpoint = K::endpoint(endpoints);
        Box::pin(async move {
            match via {
                Via::Topic { .. } => endpoint
                    .topic
                    .answers
                    .async_publish(self.0)
                    .await
                    .map_err(|e| format!("cannot publish {} answer: {e:?}", K::ONE)),
                Via::Service(id) => endpoint
                    .service
                    .async_send_response(id, K::response(self.0))
                    .await
                    .map_err(|e| format!("cannot send a {} response: {e:?}", K::SERVICE)),
                Via::Grasps(id) => match K::pose_answer(self.0) {
                    Some(answer) => endpoints.grasps.respond(id, answer).await,
                    None => Err(format!("{} answer for a rank_grasps call", K::ONE)),
                },
            }
        })
    }
    #[cfg(test)]
    fn as_any(&self) -> &dyn Any {
        &self.0
    }
}

impl Clone for SetReply {
    fn clone(&self) -> Self {
        Self(self.0.clone_box())
    }
}

impl SetReply {
    /// An answer of kind `K`.
    pub(crate) fn new<K: NodeSet>(answer: K::Answer) -> Self {
        Self(Box::new(Replied::<K>(answer)))
    }

    /// The set's id.
    pub(crate) fn set_id(&self) -> &CompactString {
        self.0.answer().set_id()
    }

    /// The set's status.
    pub(crate) fn status(&self) -> u8 {
        self.0.answer().status()
    }

    /// Why, when the status is not OK.
    pub(crate) fn message(&self) -> &str {
        self.0.answer().message()
    }

    /// The members' recommendations, in order.
    pub(crate) fn members(&self) -> Vec<&GripRecommendation> {
        self.0.answer().members()
    }

    /// How many members are ranked, and by which field.
    pub(crate) fn ranked(&self) -> (usize, &str) {
        self.0.answer().ranked()
    }

    /// Sends it where its set came from: its kind's topic, or the response to its call.
    pub(crate) async fn send(self, endpoints: &SetEndpoints, via: Via) -> Result<(), String> {
        self.0.send(endpoints, via).await
    }

    /// The message for the recording.
    pub(super) fn payload(self) -> Payload {
        self.0.payload()
    }

    /// The answer, when it is of kind `K` (tests).
    #[cfg(test)]
    pub(crate) fn get<K: NodeSet>(&self) -> Option<&K::Answer> {
        self.0.as_any().downcast_ref()
    }

    /// The answer to a candidate set (tests).
    #[cfg(test)]
    pub(crate) fn candidates(&self) -> &crate::msg::GripRecommendationSet {
        self.get::<crate::kind::Sets>()
            .expect("a candidate set's answer")
    }
}

/// The answer to one set, to publish (or send as the service's response) in this order:
/// `reply`, then `markers`.
#[derive(Debug)]
pub(crate) struct SetOutcome {
    /// The answer to the set.
    pub(crate) reply: SetReply,
    /// The markers of the best candidate, when they are on and one can be held.
    pub(crate) markers: Option<MarkerArray>,
    /// What goes to the recording once the answer is out.
    pub(crate) recorded: RecordedSet,
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
