//! The message kinds the node answers. A kind is a request and its answer: a grasp candidate
//! and its recommendation, a candidate set and its ranked answer, a pose candidate and its
//! answer, a pose set and its ranked answer. Each is declared once here, as an `impl` of
//! [`Kind`], and the layers that carry messages go through the trait instead of naming the
//! types: the recording's channels and their counts ([`crate::record`]), reading a recording
//! back ([`Streams`], in [`crate::record::bag::Bag`]), and pairing a recorded request with its
//! recorded answer ([`Kind::request_key`], in [`crate::replay`]).
//!
//! To add a kind: its `.msg` files and wire structs (`src/msg/`), a unit struct with its
//! `impl Kind`, its field in [`Streams`] and its line in `each`; `docs/architecture.md` shows
//! the steps.

use crate::msg::{
    clip, GraspCandidate, GraspCandidateSet, GraspObject, GripRecommendation,
    GripRecommendationSet, Header, PoseCandidate, PoseCandidateSet, PoseRecommendation,
    PoseRecommendationSet, RosMessage, Vector3,
};
use serde::{de::DeserializeOwned, Serialize};
use std::fmt::Debug;

/// What a message of a kind must be: a ROS message that is encoded as CDR, compared, cloned and
/// sent between threads.
pub trait Wire:
    RosMessage + Serialize + DeserializeOwned + Clone + Debug + PartialEq + Default + Send + Sync
{
}

impl<T> Wire for T where
    T: RosMessage
        + Serialize
        + DeserializeOwned
        + Clone
        + Debug
        + PartialEq
        + Default
        + Send
        + Sync
{
}

/// The key that pairs an answer with its request: the request's id and header, cut to the
/// length an answer carries them at ([`clip`]).
pub(crate) type Key<'a> = (&'a str, i32, u32, &'a str);

/// [`Key`] of an id and a header.
pub(crate) fn key<'a>(id: &'a str, header: &'a Header) -> Key<'a> {
    (
        clip(id),
        header.stamp.sec,
        header.stamp.nanosec,
        clip(&header.frame_id),
    )
}

/// One message kind: a request, its answer, and where both go.
pub trait Kind: Sized + 'static {
    /// What is asked.
    type Request: Wire;
    /// What is answered.
    type Answer: Wire;
    /// Its place in `each`'s order; the recording's channels of the kind are
    /// `Channel::request` and `Channel::answer` of it.
    const INDEX: usize;
    /// The node's topics of its requests and answers, relative to the node's namespace.
    const TOPICS: [&'static str; 2];
    /// Its requests in a report: "candidates", "pose sets".
    const PLURAL: &'static str;
    /// One request in a message: "a candidate", "a pose set".
    const ONE: &'static str;
    /// Whether a recording makes its channels when the file is created (the node always has
    /// them); the others' channels are made by their first message, as rosbag2 adds a topic when
    /// it first sees a publisher.
    const AT_START: bool;
    /// Its streams in a recording read back.
    fn stream(streams: &Streams) -> &Stream<Self>;
    /// [`Kind::stream`], to fill.
    fn stream_mut(streams: &mut Streams) -> &mut Stream<Self>;
    /// The key its answer is paired with.
    fn request_key(request: &Self::Request) -> Key<'_>;
    /// The key of the request it answers.
    fn answer_key(answer: &Self::Answer) -> Key<'_>;
}

/// Where a kind's requests hold their frames: what the node turns by TF (`crate::tf::resolve`),
/// through this one trait for every kind.
pub(crate) trait Framing: Kind {
    /// Hands `visit` every part of `request` that holds its own gravity, with the header it is
    /// given against, and its object where it has one: one for a candidate and a pose
    /// candidate, one per member of a candidate set (each member has its own header), one for a
    /// pose set (its header, gravity and object).
    fn framed(request: &mut Self::Request, visit: &mut dyn FnMut(Framed<'_>));
    /// The frame the request's object pose is given in (`object.frame_id`); empty for a kind
    /// without an object, and for an object given in the header frame.
    fn object_frame(request: &Self::Request) -> &str;
}

/// One part of a request as [`Framing::framed`] hands it out: a gravity and, where the kind has
/// one, an object, both given against `header`.
#[derive(Debug)]
pub(crate) struct Framed<'a> {
    /// The frame and stamp the gravity (and the object's pose, once in the header frame) are
    /// expressed at.
    pub(crate) header: &'a Header,
    /// Gravitational acceleration, m/s², in `header.frame_id`.
    pub(crate) gravity: &'a mut Vector3,
    /// The object, whose pose is in `object.frame_id` (empty: `header.frame_id`).
    pub(crate) object: Option<&'a mut GraspObject>,
}

/// A grasp candidate (`GraspCandidate`) and its answer (`GripRecommendation`).
#[derive(Debug, Clone, Copy)]
pub struct Candidates;

/// A candidate set (`GraspCandidateSet`, a topic or a call of `~/recommend`) and its answer
/// (`GripRecommendationSet`).
#[derive(Debug, Clone, Copy)]
pub struct Sets;

/// A pose candidate (`PoseCandidate`) and its answer (`PoseRecommendation`).
#[derive(Debug, Clone, Copy)]
pub struct Poses;

/// A pose set (`PoseCandidateSet`, a topic or a call of `~/recommend_poses`) and its answer
/// (`PoseRecommendationSet`).
#[derive(Debug, Clone, Copy)]
pub struct PoseSets;

impl Kind for Candidates {
    type Request = GraspCandidate;
    type Answer = GripRecommendation;
    const INDEX: usize = 0;
    const TOPICS: [&'static str; 2] = ["grasp_candidates", "grip_recommendations"];
    const PLURAL: &'static str = "candidates";
    const ONE: &'static str = "a candidate";
    const AT_START: bool = true;
    fn stream(streams: &Streams) -> &Stream<Self> {
        &streams.candidates
    }
    fn stream_mut(streams: &mut Streams) -> &mut Stream<Self> {
        &mut streams.candidates
    }
    fn request_key(r: &GraspCandidate) -> Key<'_> {
        key(&r.id, &r.header)
    }
    fn answer_key(a: &GripRecommendation) -> Key<'_> {
        key(&a.candidate_id, &a.header)
    }
}

impl Kind for Sets {
    type Request = GraspCandidateSet;
    type Answer = GripRecommendationSet;
    const INDEX: usize = 1;
    const TOPICS: [&'static str; 2] = ["grasp_candidate_sets", "grip_recommendation_sets"];
    const PLURAL: &'static str = "candidate sets";
    const ONE: &'static str = "a set";
    const AT_START: bool = false;
    fn stream(streams: &Streams) -> &Stream<Self> {
        &streams.sets
    }
    fn stream_mut(streams: &mut Streams) -> &mut Stream<Self> {
        &mut streams.sets
    }
    fn request_key(r: &GraspCandidateSet) -> Key<'_> {
        key(&r.id, &r.header)
    }
    fn answer_key(a: &GripRecommendationSet) -> Key<'_> {
        key(&a.set_id, &a.header)
    }
}

impl Kind for Poses {
    type Request = PoseCandidate;
    type Answer = PoseRecommendation;
    const INDEX: usize = 2;
    const TOPICS: [&'static str; 2] = ["pose_candidates", "pose_recommendations"];
    const PLURAL: &'static str = "pose candidates";
    const ONE: &'static str = "a pose candidate";
    const AT_START: bool = false;
    fn stream(streams: &Streams) -> &Stream<Self> {
        &streams.poses
    }
    fn stream_mut(streams: &mut Streams) -> &mut Stream<Self> {
        &mut streams.poses
    }
    fn request_key(r: &PoseCandidate) -> Key<'_> {
        key(&r.id, &r.header)
    }
    fn answer_key(a: &PoseRecommendation) -> Key<'_> {
        key(&a.recommendation.candidate_id, &a.recommendation.header)
    }
}

impl Kind for PoseSets {
    type Request = PoseCandidateSet;
    type Answer = PoseRecommendationSet;
    const INDEX: usize = 3;
    const TOPICS: [&'static str; 2] = ["pose_candidate_sets", "pose_recommendation_sets"];
    const PLURAL: &'static str = "pose sets";
    const ONE: &'static str = "a pose set";
    const AT_START: bool = false;
    fn stream(streams: &Streams) -> &Stream<Self> {
        &streams.pose_sets
    }
    fn stream_mut(streams: &mut Streams) -> &mut Stream<Self> {
        &mut streams.pose_sets
    }
    fn request_key(r: &PoseCandidateSet) -> Key<'_> {
        key(&r.id, &r.header)
    }
    fn answer_key(a: &PoseRecommendationSet) -> Key<'_> {
        key(&a.set_id, &a.header)
    }
}

impl Framing for Candidates {
    fn framed(r: &mut GraspCandidate, visit: &mut dyn FnMut(Framed<'_>)) {
        visit(Framed {
            header: &r.header,
            gravity: &mut r.gravity,
            object: None,
        });
    }
    fn object_frame(_: &GraspCandidate) -> &str {
        ""
    }
}

impl Framing for Sets {
    fn framed(r: &mut GraspCandidateSet, visit: &mut dyn FnMut(Framed<'_>)) {
        for c in &mut r.candidates {
            Candidates::framed(c, visit);
        }
    }
    fn object_frame(_: &GraspCandidateSet) -> &str {
        ""
    }
}

impl Framing for Poses {
    fn framed(r: &mut PoseCandidate, visit: &mut dyn FnMut(Framed<'_>)) {
        visit(Framed {
            header: &r.header,
            gravity: &mut r.gravity,
            object: Some(&mut r.object),
        });
    }
    fn object_frame(r: &PoseCandidate) -> &str {
        &r.object.frame_id
    }
}

impl Framing for PoseSets {
    fn framed(r: &mut PoseCandidateSet, visit: &mut dyn FnMut(Framed<'_>)) {
        visit(Framed {
            header: &r.header,
            gravity: &mut r.gravity,
            object: Some(&mut r.object),
        });
    }
    fn object_frame(r: &PoseCandidateSet) -> &str {
        &r.object.frame_id
    }
}

/// How many kinds there are.
pub(crate) const COUNT: usize = 4;

/// Something done once for every kind ([`each`]).
pub(crate) trait Visit {
    /// Done for kind `K`.
    fn kind<K: Kind>(&mut self);
}

/// Calls `visit` for every kind, in [`Kind::INDEX`] order. The one list of the kinds.
pub(crate) fn each(visit: &mut impl Visit) {
    visit.kind::<Candidates>();
    visit.kind::<Sets>();
    visit.kind::<Poses>();
    visit.kind::<PoseSets>();
}

/// A message with the times it was recorded at, ns since the epoch.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded<T> {
    /// The message.
    pub message: T,
    /// Receive time.
    pub log_time: u64,
    /// Send time.
    pub publish_time: u64,
}

/// The requests and answers of one kind in a recording, each in file order.
pub struct Stream<K: Kind> {
    /// Every request.
    pub requests: Vec<Recorded<K::Request>>,
    /// Every answer.
    pub answers: Vec<Recorded<K::Answer>>,
}

impl<K: Kind> Default for Stream<K> {
    fn default() -> Self {
        Self {
            requests: Vec::new(),
            answers: Vec::new(),
        }
    }
}

impl<K: Kind> Debug for Stream<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stream")
            .field("requests", &self.requests)
            .field("answers", &self.answers)
            .finish()
    }
}

impl<K: Kind> PartialEq for Stream<K> {
    fn eq(&self, other: &Self) -> bool {
        self.requests == other.requests && self.answers == other.answers
    }
}

impl<K: Kind> Stream<K> {
    /// Appends `next`, which follows `self`.
    pub(crate) fn append(&mut self, next: Self) {
        self.requests.extend(next.requests);
        self.answers.extend(next.answers);
    }

    /// How many messages it holds.
    pub(crate) fn len(&self) -> u64 {
        (self.requests.len() + self.answers.len()) as u64
    }
}

/// The messages of every kind in a recording.
#[derive(Debug, Default, PartialEq)]
pub struct Streams {
    /// Grasp candidates and their recommendations.
    pub candidates: Stream<Candidates>,
    /// Candidate sets and their answers.
    pub sets: Stream<Sets>,
    /// Pose candidates and their answers.
    pub poses: Stream<Poses>,
    /// Pose sets and their answers.
    pub pose_sets: Stream<PoseSets>,
}

impl Streams {
    /// The stream of kind `K`.
    pub(crate) fn of<K: Kind>(&self) -> &Stream<K> {
        K::stream(self)
    }

    /// Appends `next`, which follows `self`.
    pub(crate) fn append(&mut self, mut next: Streams) {
        struct Append<'a>(&'a mut Streams, &'a mut Streams);
        impl Visit for Append<'_> {
            fn kind<K: Kind>(&mut self) {
                K::stream_mut(self.0).append(std::mem::take(K::stream_mut(self.1)));
            }
        }
        each(&mut Append(self, &mut next));
    }

    /// How many messages they hold.
    pub(crate) fn len(&self) -> u64 {
        struct Count<'a>(&'a Streams, u64);
        impl Visit for Count<'_> {
            fn kind<K: Kind>(&mut self) {
                self.1 += K::stream(self.0).len();
            }
        }
        let mut count = Count(self, 0);
        each(&mut count);
        count.1
    }

    /// How many requests of each kind they hold, by [`Kind::INDEX`].
    pub(crate) fn request_counts(&self) -> [usize; COUNT] {
        struct Count<'a>(&'a Streams, [usize; COUNT]);
        impl Visit for Count<'_> {
            fn kind<K: Kind>(&mut self) {
                self.1[K::INDEX] = K::stream(self.0).requests.len();
            }
        }
        let mut count = Count(self, [0; COUNT]);
        each(&mut count);
        count.1
    }

    /// The requests alone.
    pub(crate) fn requests_only(mut self) -> Streams {
        struct Drop<'a>(&'a mut Streams);
        impl Visit for Drop<'_> {
            fn kind<K: Kind>(&mut self) {
                K::stream_mut(self.0).answers = Vec::new();
            }
        }
        each(&mut Drop(&mut self));
        self
    }
}

/// The plural name of each kind's requests ([`Kind::PLURAL`]), by [`Kind::INDEX`].
pub(crate) fn plurals() -> [&'static str; COUNT] {
    struct Names([&'static str; COUNT]);
    impl Visit for Names {
        fn kind<K: Kind>(&mut self) {
            self.0[K::INDEX] = K::PLURAL;
        }
    }
    let mut names = Names([""; COUNT]);
    each(&mut names);
    names.0
}

/// The request types of every kind, as a recording names them, in a sentence: "a, b, c or d".
pub(crate) fn request_types() -> String {
    let names: Vec<&str> = Channel::all()
        .iter()
        .filter(|(c, _, _)| c.side == Side::Request)
        .map(|(_, name, _)| *name)
        .collect();
    match names.split_last() {
        Some((last, [])) => (*last).to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// Which side of a kind a message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Side {
    /// What is asked.
    Request,
    /// What is answered.
    Answer,
}

/// One side of one kind: a channel of a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Channel {
    /// The kind's [`Kind::INDEX`].
    pub(crate) kind: usize,
    /// Which side.
    pub(crate) side: Side,
}

impl Channel {
    /// How many there are.
    pub(crate) const COUNT: usize = 2 * COUNT;

    /// The requests of `K`.
    pub(crate) fn request<K: Kind>() -> Self {
        Self {
            kind: K::INDEX,
            side: Side::Request,
        }
    }

    /// The answers of `K`.
    pub(crate) fn answer<K: Kind>() -> Self {
        Self {
            kind: K::INDEX,
            side: Side::Answer,
        }
    }

    /// Its place among the [`Channel::COUNT`] channels: a kind's request, then its answer.
    pub(crate) fn slot(self) -> usize {
        2 * self.kind + usize::from(self.side == Side::Answer)
    }

    /// Every channel, in [`Channel::slot`] order, with its type name and whether it is made at
    /// the start of a recording ([`Kind::AT_START`]).
    pub(crate) fn all() -> [(Channel, &'static str, bool); Channel::COUNT] {
        struct Table([(Channel, &'static str, bool); Channel::COUNT]);
        impl Visit for Table {
            fn kind<K: Kind>(&mut self) {
                let request = Channel::request::<K>();
                let answer = Channel::answer::<K>();
                self.0[request.slot()] = (request, K::Request::TYPE_NAME, K::AT_START);
                self.0[answer.slot()] = (answer, K::Answer::TYPE_NAME, K::AT_START);
            }
        }
        let unset = (Channel::request::<Candidates>(), "", false);
        let mut table = Table([unset; Channel::COUNT]);
        each(&mut table);
        table.0
    }

    /// The channel whose type is `package`/`name`, if one is.
    pub(crate) fn of_type(package: &str, name: &str) -> Option<Channel> {
        Channel::all()
            .into_iter()
            .find_map(|(channel, type_name, _)| {
                let (p, n) = crate::msg::definitions::split_type_name(type_name)?;
                (p == package && n == name).then_some(channel)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind's index is its place in `each`, and its channels' slots are distinct and fill
    /// 0..Channel::COUNT: the tables built from `each` depend on both.
    #[test]
    fn each_visits_every_kind_once_in_index_order() {
        struct Order(Vec<usize>);
        impl Visit for Order {
            fn kind<K: Kind>(&mut self) {
                self.0.push(K::INDEX);
            }
        }
        let mut order = Order(Vec::new());
        each(&mut order);
        assert_eq!(order.0, (0..COUNT).collect::<Vec<_>>());
        let slots: Vec<usize> = Channel::all().iter().map(|(c, _, _)| c.slot()).collect();
        assert_eq!(slots, (0..Channel::COUNT).collect::<Vec<_>>());
        let names: std::collections::HashSet<_> =
            Channel::all().iter().map(|(_, n, _)| *n).collect();
        assert_eq!(names.len(), Channel::COUNT, "a type on two channels");
    }

    #[test]
    fn the_request_types_are_named_in_a_sentence() {
        assert_eq!(
            request_types(),
            "grasp_orient/msg/GraspCandidate, grasp_orient/msg/GraspCandidateSet, \
             grasp_orient/msg/PoseCandidate or grasp_orient/msg/PoseCandidateSet"
        );
    }

    #[test]
    fn a_type_name_finds_its_channel() {
        assert_eq!(
            Channel::of_type("grasp_orient", "PoseCandidateSet"),
            Some(Channel::request::<PoseSets>())
        );
        assert_eq!(
            Channel::of_type("grasp_orient", "GripRecommendation"),
            Some(Channel::answer::<Candidates>())
        );
        assert_eq!(Channel::of_type("grasp_orient", "Mesh"), None);
    }
}
