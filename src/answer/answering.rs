//! The answering object: what every answer depends on, held once and handed around whole, so
//! that the node, the command line and replay answer alike. An [`Answering`] holds the solver's
//! settings (objective, range, friction safety factor), the gripper's rules (the default
//! tolerances, which force is the grip force and its limit, the ranking, the largest set) and
//! the poses' answerer (the closing axis and the mesh cache). Each message kind is answered
//! through it by its [`Answer`] impl; [`Answering::answer`] is the one entry point.

use super::pose::{pose_set_without_geometry, uncast, without_geometry};
use super::runs::answer_each;
use super::sets::{busy, echo_set, invalid_set, SetAnswer};
use super::{
    answer_one, answer_one_in_full, answer_set, answer_set_on, answer_set_within, Answered,
    Interrupt, PoseAnswerer, Rules,
};
use crate::geometry::ClosingAxis;
use crate::geometry::Object;
use crate::kind::{Candidates, Kind, PoseSets, Poses, Sets};
use crate::msg::{
    invalid, GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet,
    PoseCandidate, PoseRecommendation,
};
use crate::solver::Settings;

/// The settings, rules and meshes every answer is made with.
#[derive(Debug, Clone)]
pub struct Answering {
    settings: Settings,
    rules: Rules,
    poses: PoseAnswerer,
}

impl Answering {
    /// Answers with `settings` and `rules`, pose candidates by `poses`.
    pub fn new(settings: Settings, rules: Rules, poses: PoseAnswerer) -> Self {
        Self {
            settings,
            rules,
            poses,
        }
    }

    /// The library's defaults: the solver's default settings, no gripper limit, and pose
    /// candidates closing along y with `package://` resolved through `AMENT_PREFIX_PATH`.
    pub fn from_env() -> Self {
        Self::new(
            Settings::default(),
            Rules::default(),
            PoseAnswerer::from_env(ClosingAxis::default()),
        )
    }

    /// The solver's settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The gripper's rules.
    pub fn rules(&self) -> &Rules {
        &self.rules
    }

    /// The poses' answerer: the closing axis and the meshes.
    pub fn poses(&self) -> &PoseAnswerer {
        &self.poses
    }

    /// The same, with `settings`.
    pub fn with_settings(&self, settings: Settings) -> Self {
        Self {
            settings,
            ..self.clone()
        }
    }

    /// The same, with `rules`.
    pub(crate) fn with_rules(&self, rules: Rules) -> Self {
        Self {
            rules,
            ..self.clone()
        }
    }

    /// The answer to a request of kind `K`.
    pub fn answer<K: Answer>(&self, request: &K::Request) -> K::Answer {
        K::answer(self, request)
    }

    /// The answers to many requests of kind `K`, in order, each the one [`Answering::answer`]
    /// gives alone (bit for bit): for candidates, through the solver's batch path where it takes
    /// them, which costs less per candidate than one by one.
    pub fn answer_many<K: Answer>(&self, requests: &[K::Request]) -> Vec<K::Answer> {
        K::answer_many(self, requests)
    }

    /// A candidate's answer with its 3D solution when spatial (for its markers).
    pub(crate) fn candidate_in_full(&self, m: &GraspCandidate) -> Answered {
        answer_one_in_full(m, &self.settings, &self.rules)
    }

    /// A pose candidate's answer with the object it was cast onto (for its markers).
    pub(crate) fn pose_with_object(
        &self,
        m: &PoseCandidate,
    ) -> (PoseRecommendation, Option<Object>) {
        self.poses
            .answer_with_object(m, &self.settings, &self.rules)
    }

    /// A set's answer with its candidates shared among the threads of `pool` (the calling
    /// thread among them) when there is one, and sets smaller than a few hundred candidates
    /// answered on the calling thread whatever the pool: the same answer as
    /// [`Answering::answer`]'s.
    pub fn set_on(
        &self,
        set: &GraspCandidateSet,
        pool: Option<&rayon::ThreadPool>,
    ) -> GripRecommendationSet {
        answer_set_on(set, &self.settings, &self.rules, pool)
    }

    /// A set's answer on `pool`, stopped between two candidates once `interrupt` is raised
    /// (`max_set_time`, s, is the budget its message names): `answer_set_within`.
    pub fn set_within(
        &self,
        set: &GraspCandidateSet,
        pool: Option<&rayon::ThreadPool>,
        interrupt: &Interrupt,
        max_set_time: f64,
    ) -> GripRecommendationSet {
        answer_set_within(
            set,
            &self.settings,
            &self.rules,
            pool,
            interrupt,
            max_set_time,
        )
    }
}

/// Something done once for every kind, knowing how it is answered ([`each`]).
#[cfg(test)]
pub(crate) trait VisitAnswer {
    /// Done for kind `K`.
    fn kind<K: Answer>(&mut self);
}

/// Calls `visit` for every kind, in [`Kind::INDEX`] order, as [`crate::kind::each`] does, where
/// what is done needs the answer (a test holds the two lists to the same kinds).
#[cfg(test)]
pub(crate) fn each(visit: &mut impl VisitAnswer) {
    visit.kind::<Candidates>();
    visit.kind::<Sets>();
    visit.kind::<Poses>();
    visit.kind::<PoseSets>();
}

/// How a kind's request is answered.
pub trait Answer: Kind {
    /// The answer to `request` made `with` these settings, rules and meshes.
    fn answer(with: &Answering, request: &Self::Request) -> Self::Answer;

    /// The answers to `requests`, in order, each what [`Answer::answer`] gives for it alone; a
    /// kind overrides it where many at once cost less than one by one.
    fn answer_many(with: &Answering, requests: &[Self::Request]) -> Vec<Self::Answer> {
        requests.iter().map(|r| Self::answer(with, r)).collect()
    }

    /// The answer refusing `request` as a whole with status 2 (invalid input) and the message
    /// `invalid input: {why}`, nothing solved: what the node answers when a transform the
    /// request needs cannot be had (`docs/node.md#tf`). A set's members are left out, as for
    /// any set refused whole.
    fn refused(with: &Answering, request: &Self::Request, why: &str) -> Self::Answer;
}

/// A candidate: the node's tolerances where it gives none, the solver, then the gripper's limit
/// (`answer_one`).
impl Answer for Candidates {
    fn answer(with: &Answering, request: &Self::Request) -> Self::Answer {
        answer_one(request, &with.settings, &with.rules)
    }

    /// Through the solver's batch path in runs, the same answers bit for bit (`answer_each`).
    fn answer_many(with: &Answering, requests: &[GraspCandidate]) -> Vec<GripRecommendation> {
        answer_each(requests, &with.settings, &with.rules)
    }

    fn refused(_: &Answering, request: &Self::Request, why: &str) -> Self::Answer {
        invalid(request, &why)
    }
}

/// A set: each candidate as one is answered, with the set's own limit, then the ranking
/// (`answer_set`).
impl Answer for Sets {
    fn answer(with: &Answering, request: &Self::Request) -> Self::Answer {
        answer_set(request, &with.settings, &with.rules)
    }
    fn refused(with: &Answering, request: &Self::Request, why: &str) -> Self::Answer {
        invalid_set(request, &with.rules, why)
    }
}

/// A pose candidate: the fingers cast onto the object, then answered as a candidate
/// (`PoseAnswerer::answer`).
impl Answer for Poses {
    fn answer(with: &Answering, request: &Self::Request) -> Self::Answer {
        with.poses.answer(request, &with.settings, &with.rules)
    }
    fn refused(_: &Answering, request: &Self::Request, why: &str) -> Self::Answer {
        let stub = GraspCandidate {
            header: request.header.clone(),
            id: request.id.clone(),
            ..GraspCandidate::default()
        };
        without_geometry(invalid(&stub, &why))
    }
}

/// A pose set: every pose cast onto the one object, then answered and ranked as a set
/// (`PoseAnswerer::answer_set`).
impl Answer for PoseSets {
    fn answer(with: &Answering, request: &Self::Request) -> Self::Answer {
        with.poses.answer_set(request, &with.settings, &with.rules)
    }
    fn refused(with: &Answering, request: &Self::Request, why: &str) -> Self::Answer {
        pose_set_without_geometry(request, invalid_set(&uncast(request), &with.rules, why))
    }
}

/// A kind whose requests are sets: answered on the node's set thread within `max_set_time`,
/// or refused whole at once when too many wait.
pub(crate) trait SetKind: Answer<Answer: SetAnswer, Request: Send> {
    /// The set's id.
    fn set_id(set: &Self::Request) -> &str;
    /// How many members it has.
    fn members(set: &Self::Request) -> usize;
    /// `STATUS_BUSY` (or the set's own refusal, when it has one), nothing solved.
    fn busy(set: &Self::Request, rules: &Rules, max_queued: usize) -> Self::Answer;
    /// An empty answer per member, nothing solved (the node's echo mode).
    fn echo(set: &Self::Request) -> Self::Answer;
}

/// A candidate set.
impl SetKind for Sets {
    fn set_id(set: &Self::Request) -> &str {
        &set.id
    }
    fn members(set: &Self::Request) -> usize {
        set.candidates.len()
    }
    fn busy(set: &Self::Request, rules: &Rules, max_queued: usize) -> Self::Answer {
        busy(set, rules, max_queued)
    }
    fn echo(set: &Self::Request) -> Self::Answer {
        echo_set(set)
    }
}

/// A pose set: refused and echoed as the candidate set of its poses, without geometry.
impl SetKind for PoseSets {
    fn set_id(set: &Self::Request) -> &str {
        &set.id
    }
    fn members(set: &Self::Request) -> usize {
        set.poses.len()
    }
    fn busy(set: &Self::Request, rules: &Rules, max_queued: usize) -> Self::Answer {
        pose_set_without_geometry(set, busy(&uncast(set), rules, max_queued))
    }
    fn echo(set: &Self::Request) -> Self::Answer {
        pose_set_without_geometry(set, echo_set(&uncast(set)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::GripRecommendation;

    /// Every kind answers through `Answering::answer`, and its answer carries the request's key
    /// (so that replay pairs them): an empty candidate or pose candidate (zero friction, no
    /// object) is refused with status 2 and a message naming the input, an empty set or pose set is answered
    /// with no members; none panics.
    #[test]
    fn every_kind_answers_through_the_one_entry_point() {
        fn outcome<K: Answer>(with: &Answering) -> (bool, String, usize)
        where
            K::Answer: Statused,
        {
            let mut request = K::Request::default();
            let answer = with.answer::<K>(&request);
            let same_key = K::request_key(&request) == K::answer_key(&answer);
            request = K::Request::default();
            let again = with.answer::<K>(&request);
            // NaN fields: compared as printed.
            assert_eq!(format!("{again:?}"), format!("{answer:?}"), "deterministic");
            (same_key, answer.words(), answer.status_members().1)
        }
        let with = Answering::from_env();
        let c = outcome::<Candidates>(&with);
        let p = outcome::<Poses>(&with);
        let s = outcome::<Sets>(&with);
        let ps = outcome::<PoseSets>(&with);
        for (what, (same_key, words, _)) in [("candidate", &c), ("pose", &p)] {
            assert!(*same_key, "{what}");
            assert!(
                words.starts_with("invalid input"),
                "an empty {what}: {words}"
            );
        }
        assert!(s.0 && ps.0, "sets keep their key");
        assert_eq!((s.2, ps.2), (0, 0), "{s:?} {ps:?}");
    }

    /// The status, message and members of an answer, whichever its kind.
    trait Statused {
        fn words(&self) -> String;
        fn status_members(&self) -> (u8, usize);
    }
    impl Statused for GripRecommendation {
        fn words(&self) -> String {
            assert_eq!(self.status, Self::STATUS_INVALID_INPUT, "{}", self.message);
            self.message.to_string()
        }
        fn status_members(&self) -> (u8, usize) {
            (self.status, 1)
        }
    }
    impl Statused for crate::msg::PoseRecommendation {
        fn words(&self) -> String {
            self.recommendation.words()
        }
        fn status_members(&self) -> (u8, usize) {
            self.recommendation.status_members()
        }
    }
    impl Statused for crate::msg::GripRecommendationSet {
        fn words(&self) -> String {
            self.message.to_string()
        }
        fn status_members(&self) -> (u8, usize) {
            (self.status, self.recommendations.len())
        }
    }
    impl Statused for crate::msg::PoseRecommendationSet {
        fn words(&self) -> String {
            self.message.to_string()
        }
        fn status_members(&self) -> (u8, usize) {
            (self.status, self.recommendations.len())
        }
    }

    /// `each` here and `kind::each` visit the same kinds in the same order.
    #[test]
    fn every_kind_is_answerable() {
        struct Answered(Vec<usize>);
        impl VisitAnswer for Answered {
            fn kind<K: Answer>(&mut self) {
                self.0.push(K::INDEX);
            }
        }
        struct Listed(Vec<usize>);
        impl crate::kind::Visit for Listed {
            fn kind<K: Kind>(&mut self) {
                self.0.push(K::INDEX);
            }
        }
        let (mut answered, mut listed) = (Answered(Vec::new()), Listed(Vec::new()));
        each(&mut answered);
        crate::kind::each(&mut listed);
        assert_eq!(answered.0, listed.0);
    }

    /// The entry point gives what the functions it stands for give, under settings and rules
    /// that are not the defaults.
    #[test]
    fn answering_a_candidate_is_answer_one_with_its_settings_and_rules() {
        let settings = Settings {
            objective: crate::solver::Objective::Norm1,
            ..Settings::default()
        };
        let rules = Rules {
            max_grip_force: 5.0,
            ..Rules::default()
        };
        let with = Answering::from_env()
            .with_settings(settings)
            .with_rules(rules);
        for c in crate::msg::paper_cases() {
            assert_eq!(
                with.answer::<Candidates>(&c),
                answer_one(&c, &settings, &rules)
            );
        }
    }
}
