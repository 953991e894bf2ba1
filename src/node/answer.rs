//! The answering loop without DDS: one call per received candidate gives the answer, the markers
//! and the lines to log, and keeps the counts and the recording. The node's DDS glue only
//! receives, publishes what [`Answerer::handle`] returns, and then hands it back to
//! [`Answerer::record`]; unit tests drive it directly. Sets are solved on the set thread
//! (`set_worker.rs`); their answers come back here to be counted ([`Answerer::count_set`]) and
//! recorded ([`Answerer::record_set`]).

use super::params::Shared;
use super::params::Version;
pub(crate) use super::pose_work::{load_time, PoseWork, INLINE_OFF_THREAD_TRIANGLES};
pub(crate) use super::set_io::{RecordedSet, SetInput, SetOutcome, SetReply};
use crate::answer::markers;
use crate::answer::{Answered, Answering};
use crate::kind::{Candidates, Poses};
use crate::msg::{
    short_id, GraspCandidate, GripRecommendation, GripRecommendationSet, MarkerArray,
    PoseCandidate, PoseRecommendation,
};
use crate::record::lifecycle::{Change, Recording, Wanted};
use crate::record::settings::SettingsRecord;
use crate::record::{Entry, OnStop, Payload, RecordError, Topics};
use crate::tf::Gravity;
use grasp_orient_geometry::MeshCache;
use log::Level;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// A line for the log (stderr and `/rosout`).
pub(crate) type Note = (Level, String);

/// What the node has done, for its last words.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Counts {
    /// Candidates answered.
    pub(crate) answered: u64,
    /// Answered with status 2 (invalid input).
    pub(crate) invalid: u64,
    /// Answered with status 1 (no force closure).
    pub(crate) no_closure: u64,
    /// Messages on the candidates topic that did not decode.
    pub(crate) undecodable: u64,
    /// Sets (on their topic or as service requests) that did not decode; not candidates.
    pub(crate) undecodable_sets: u64,
    /// Answered with status 3 (more grip force than `max_grip_force`).
    pub(crate) exceeds_gripper: u64,
    /// Sets answered (on the topic or the service); their candidates count above too.
    pub(crate) sets: u64,
    /// Sets refused as a whole (too large, bad fields of their own, or the node busy).
    pub(crate) sets_refused: u64,
    /// Sets answered in part: their time ran out, or the node was stopping.
    pub(crate) sets_incomplete: u64,
    /// Candidates of those sets not solved (status 4); not counted as answered.
    pub(crate) not_solved: u64,
    /// Marker arrays built (for a subscriber of `grip_markers` or for a recording that takes
    /// them).
    pub(crate) markers_built: u64,
    /// Marker arrays published on `grip_markers` (only while it has a subscriber).
    pub(crate) markers_published: u64,
}

/// The answer to one candidate or pose candidate (`A`: its answer's type), to publish in this
/// order: `reply`, then `markers`.
#[derive(Debug)]
pub(crate) struct Outcome<A> {
    /// The answer.
    pub(crate) reply: A,
    /// The markers, when they are on, wanted ([`Answerer::draws`]) and the answer has status 0.
    pub(crate) markers: Option<MarkerArray>,
    /// Lines to log.
    pub(crate) notes: Vec<Note>,
    /// What goes to the recording once the answer is out.
    pub(crate) recorded: Recorded,
}

/// The messages of one answer for the recording (a candidate or a pose candidate, and its
/// answer), with the candidate's times.
#[derive(Debug)]
pub(crate) struct Recorded {
    candidate: Payload,
    received: u64,
    sent: u64,
    reply: Option<Payload>,
    markers: Option<MarkerArray>,
}

/// Answers candidates with the settings in force when each was received; counts; records.
#[derive(Debug)]
pub(crate) struct Answerer {
    shared: Shared,
    echo: bool,
    node: String,
    /// The candidates topics (of candidates and of pose candidates), whose undecodable messages
    /// count as candidates.
    candidates_topics: [String; 2],
    /// The node's meshes, loaded once per resource and scale (shared with the set thread).
    meshes: Arc<MeshCache>,
    counts: Counts,
    recording: Recording,
    /// The newest settings version the recording has heard of.
    seen_version: u64,
    /// Sets of the recording parameters acted on.
    seen_recording_sets: u64,
    /// The last answers sent, which `~/grip` may send to the gripper.
    recent: super::grip::Recent,
}

impl Answerer {
    /// Answers with `shared`'s settings (or, with `echo`, an empty answer carrying the header
    /// and id) as node `node` (its full name), recording on `topics` with QoS depth
    /// `qos_depth` in the recording's metadata. `on_stop` hears from the recording's writer
    /// thread when it stops on a failure (then [`Answerer::refresh`] reports it).
    pub(crate) fn new(
        shared: Shared,
        echo: bool,
        node: &str,
        topics: Topics,
        qos_depth: i64,
        on_stop: OnStop,
        meshes: Arc<MeshCache>,
    ) -> Self {
        Self {
            shared,
            echo,
            node: node.to_string(),
            candidates_topics: [
                topics
                    .requests::<Candidates>()
                    .unwrap_or_default()
                    .to_string(),
                topics.requests::<Poses>().unwrap_or_default().to_string(),
            ],
            meshes,
            counts: Counts::default(),
            recording: Recording::new(node, topics, qos_depth, on_stop),
            seen_version: 0,
            seen_recording_sets: 0,
            recent: super::grip::Recent::default(),
        }
    }

    /// The last answers sent (noted as they go out), for `~/grip`.
    pub(crate) fn recent(&self) -> &super::grip::Recent {
        &self.recent
    }

    /// What has been done so far.
    #[cfg(test)]
    pub(crate) fn counts(&self) -> Counts {
        self.counts
    }

    /// Starts recording if `record` says so (never in echo mode); a failure here is an error.
    /// What the parameters were set to before (ros2-client sets every declared parameter once
    /// when the node is made) is taken as the start.
    pub(crate) fn start(&mut self) -> Result<Vec<Note>, RecordError> {
        {
            let live = self.shared.lock();
            self.seen_recording_sets = live.recording_sets();
            self.seen_version = live.last_seq();
        }
        if self.echo {
            return Ok(vec![(
                Level::Warn,
                "echo mode: answers are empty, nothing is solved".to_string(),
            )]);
        }
        let mut notes = Vec::new();
        for change in self.follow_record() {
            if let Change::StartFailed(e) = change {
                return Err(e);
            }
            notes.push(note(&change));
        }
        Ok(notes)
    }

    /// Acts on what changed since the last call: writes the new settings into the recording,
    /// follows the `record` parameters when one was set (a start that failed is retried), and
    /// reports a recording whose writer stopped on a failure. Called when a parameter is set
    /// and when the writer stops, so that each takes effect at once.
    pub(crate) fn refresh(&mut self) -> Vec<Note> {
        let mut notes = Vec::new();
        if let Some(change) = self.recording.check() {
            notes.push(note(&change));
        }
        if self.echo {
            return notes;
        }
        let (new_versions, sets) = {
            let live = self.shared.lock();
            let new: Vec<Version> = live.versions_after(self.seen_version).cloned().collect();
            (new, live.recording_sets())
        };
        for v in &new_versions {
            self.record_settings(v);
            self.seen_version = v.seq;
        }
        if sets != self.seen_recording_sets {
            self.seen_recording_sets = sets;
            notes.extend(self.follow_record().iter().map(note));
        }
        notes
    }

    /// Starts, stops or restarts the recording as the current parameters say; a new file
    /// gets every settings version kept (a candidate received before a change may still be
    /// answered after it).
    fn follow_record(&mut self) -> Vec<Change> {
        let config = self.shared.lock().config.clone();
        let changes = self.recording.follow(Wanted {
            record: config.record,
            dir: Path::new(&config.record_dir),
            markers: config.record_markers,
        });
        if changes.iter().any(|c| matches!(c, Change::Started(_))) {
            let versions: Vec<Version> = self.shared.lock().versions().cloned().collect();
            for v in &versions {
                self.record_settings(v);
                self.seen_version = self.seen_version.max(v.seq);
            }
        }
        changes
    }

    /// Writes a settings version into the recording, if one is being written.
    fn record_settings(&self, version: &Version) {
        let reason = match &version.changed {
            Some(name) => format!("parameter {name} set"),
            None => "start".to_string(),
        };
        let record = SettingsRecord {
            since: version.since,
            node: self.node.clone(),
            reason,
            config: version.config.clone(),
        };
        self.recording
            .record(Payload::settings(record), version.since, version.since);
    }

    /// Whether an answer's markers are built: `publish_markers` (`markers_on`) and somebody
    /// takes them, a subscriber of `grip_markers` (`audience`, which the node asks DDS for each
    /// answer) or the recording (`record_markers`); never in echo mode. Building, serializing
    /// and publishing a marker array per candidate costs about as much as the answer itself, and
    /// nobody sees markers published to no subscriber (the topic keeps no history for late ones).
    pub(crate) fn draws(&self, markers_on: bool, audience: bool) -> bool {
        markers_on && !self.echo && (audience || self.recording.records_markers())
    }

    /// The answer to one candidate, received at `received` and sent at `sent` (ns since the
    /// epoch), with the settings in force when it was received; its markers if [`Self::draws`]
    /// says so (`audience`: whether `grip_markers` has a subscriber now).
    pub(crate) fn handle(
        &mut self,
        candidate: GraspCandidate,
        received: u64,
        sent: u64,
        audience: bool,
    ) -> Outcome<GripRecommendation> {
        let mut notes = Vec::new();
        let (with, markers_on) = {
            let live = self.shared.lock();
            let version = live.version_at(received);
            (
                version.answering(&self.meshes),
                version.config.publish_markers,
            )
        };
        let Answered { reply, spatial } = if self.echo {
            Answered {
                reply: GripRecommendation {
                    header: candidate.header.clone(),
                    candidate_id: candidate.id.clone(),
                    ..GripRecommendation::default()
                },
                spatial: None,
            }
        } else {
            with.candidate_in_full(&candidate)
        };
        self.count_one(&reply, &mut notes);
        let draw = self.draws(markers_on, audience);
        let markers = (draw && reply.status == GripRecommendation::STATUS_OK).then(|| {
            markers::build(
                &with.rules().tolerances.apply(&candidate),
                &reply,
                spatial.as_deref(),
            )
        });
        let recorded = self.readied(
            Payload::request::<Candidates>(candidate),
            || Payload::answer::<Candidates>(reply.clone()),
            markers.as_ref(),
            received,
            sent,
        );
        Outcome {
            reply,
            markers,
            notes,
            recorded,
        }
    }

    /// What the node turns requests received at `received` by (the parameters `gravity_frame`
    /// and `gravity`), and how long one waits for its transforms (`tf_timeout`).
    pub(crate) fn tf_settings(&self, received: u64) -> (Gravity, Duration) {
        let live = self.shared.lock();
        let config = &live.version_at(received).config;
        let gravity = Gravity {
            frame: config.gravity_frame.as_str().into(),
            vector: config.gravity,
        };
        // Within [0, 10] s, checked when set.
        let timeout = Duration::try_from_secs_f64(config.tf_timeout).unwrap_or_default();
        (gravity, timeout)
    }

    /// What requests received at `received` are answered with.
    pub(crate) fn answering_at(&self, received: u64) -> Answering {
        self.shared
            .lock()
            .version_at(received)
            .answering(&self.meshes)
    }

    /// Counts a candidate's answer given without solving it (a refusal the node makes itself)
    /// and readies what is recorded of it.
    pub(crate) fn account_candidate(
        &mut self,
        candidate: GraspCandidate,
        reply: GripRecommendation,
        received: u64,
        sent: u64,
    ) -> Outcome<GripRecommendation> {
        let mut notes = Vec::new();
        self.count_one(&reply, &mut notes);
        let recorded = self.readied(
            Payload::request::<Candidates>(candidate),
            || Payload::answer::<Candidates>(reply.clone()),
            None,
            received,
            sent,
        );
        Outcome {
            reply,
            markers: None,
            notes,
            recorded,
        }
    }

    /// Counts one answer; a line for a refusal as invalid.
    fn count_one(&mut self, reply: &GripRecommendation, notes: &mut Vec<Note>) {
        match reply.status {
            GripRecommendation::STATUS_OK => {}
            GripRecommendation::STATUS_NO_FORCE_CLOSURE => self.counts.no_closure += 1,
            GripRecommendation::STATUS_EXCEEDS_GRIPPER => self.counts.exceeds_gripper += 1,
            _ => {
                self.counts.invalid += 1;
                notes.push((
                    Level::Warn,
                    format!(
                        "candidate {:?}: {} ({} refused so far)",
                        short_id(&reply.candidate_id),
                        reply.message,
                        self.counts.invalid
                    ),
                ));
            }
        }
        self.counts.answered += 1;
    }

    /// The answer to one pose candidate, received at `received` and sent at `sent` (ns since the
    /// epoch), with the settings in force when it was received (`closing_axis` among them), on
    /// the calling thread: [`Answerer::pose_work`], run, then [`Answerer::account_pose`]
    /// (tests; the node runs the work where [`Answerer::answers_off_thread`] says).
    #[cfg(test)]
    pub(crate) fn handle_pose(
        &mut self,
        candidate: PoseCandidate,
        received: u64,
        sent: u64,
        audience: bool,
    ) -> Outcome<PoseRecommendation> {
        let work = self.pose_work(received, audience);
        let (reply, markers) = work.run(&candidate);
        self.account_pose(candidate, reply, markers, received, sent)
    }

    /// What answering a pose candidate received at `received` needs (the settings then in force,
    /// whether its markers are wanted ([`Self::draws`]) and the node's meshes), to run on any
    /// thread ([`PoseWork::run`]).
    pub(crate) fn pose_work(&self, received: u64, audience: bool) -> PoseWork {
        let live = self.shared.lock();
        let version = live.version_at(received);
        PoseWork {
            with: version.answering(&self.meshes),
            markers_on: self.draws(version.config.publish_markers, audience),
            echo: self.echo,
            load_time: load_time(version.config.max_mesh_load_time),
            tool_frame: None,
        }
    }

    /// Whether answering `candidate` is worth a hop to another thread: it would load a mesh file
    /// first ([`Answerer::loads_a_mesh`]), or index an inline mesh of at least
    /// [`INLINE_OFF_THREAD_TRIANGLES`] triangles.
    pub(crate) fn answers_off_thread(&self, candidate: &PoseCandidate) -> bool {
        let inline = candidate.object.inline_mesh.triangles.len();
        self.loads_a_mesh(candidate) || (!self.echo && inline >= INLINE_OFF_THREAD_TRIANGLES)
    }

    /// Whether answering `candidate` would load a mesh file first (one named by resource and not
    /// in the node's cache yet).
    pub(crate) fn loads_a_mesh(&self, candidate: &PoseCandidate) -> bool {
        let o = &candidate.object;
        !self.echo
            && !o.mesh.is_empty()
            && !self
                .meshes
                .holds(&o.mesh, [o.scale.x, o.scale.y, o.scale.z])
    }

    /// Counts a pose candidate's answer and readies what is recorded of it.
    pub(crate) fn account_pose(
        &mut self,
        candidate: PoseCandidate,
        reply: PoseRecommendation,
        markers: Option<MarkerArray>,
        received: u64,
        sent: u64,
    ) -> Outcome<PoseRecommendation> {
        let mut notes = Vec::new();
        self.count_one(&reply.recommendation, &mut notes);
        let recorded = self.readied(
            Payload::request::<Poses>(candidate),
            || Payload::answer::<Poses>(reply.clone()),
            markers.as_ref(),
            received,
            sent,
        );
        Outcome {
            reply,
            markers,
            notes,
            recorded,
        }
    }

    /// Counts the markers built for one answer, and readies what the recording keeps of it: the
    /// candidate with its times, a copy of the `reply` while recording, the `markers` when they
    /// are recorded too.
    fn readied(
        &mut self,
        candidate: Payload,
        reply: impl FnOnce() -> Payload,
        markers: Option<&MarkerArray>,
        received: u64,
        sent: u64,
    ) -> Recorded {
        self.counts.markers_built += u64::from(markers.is_some());
        Recorded {
            reply: self.recording.is_on().then(reply),
            markers: markers
                .filter(|_| self.recording.records_markers())
                .cloned(),
            candidate,
            received,
            sent,
        }
    }

    /// Records an answer that went out at `answered` (ns since the epoch): its markers, the
    /// candidate with its own times, and the recommendation. Says so if the recording's writer
    /// has stopped on a failure.
    pub(crate) fn record(&mut self, recorded: Recorded, answered: u64) -> Vec<Note> {
        let Recorded {
            candidate,
            received,
            sent,
            reply,
            markers,
        } = recorded;
        let entry = |payload, log_time, publish_time| Entry {
            payload,
            log_time,
            publish_time,
        };
        let mut entries = Vec::with_capacity(3);
        if let Some(array) = markers {
            entries.push(entry(Payload::markers(array), answered, answered));
        }
        entries.push(entry(candidate, received, sent));
        if let Some(r) = reply {
            entries.push(entry(r, answered, answered));
        }
        // Together: a flush (and so a file cut short by a kill or a full disk) never holds a
        // candidate without its answer.
        self.recording.record_all(entries);
        self.recording.check().iter().map(note).collect()
    }

    /// Whether a set's answer is to be recorded, and its markers: asked when the set is taken,
    /// so that the set thread clones only what the recording takes.
    pub(crate) fn records_sets(&self) -> (bool, bool) {
        (self.recording.is_on(), self.recording.records_markers())
    }

    /// Counts a marker array published on `grip_markers`.
    pub(crate) fn count_published_markers(&mut self) {
        self.counts.markers_published += 1;
    }

    /// Counts a set's answer (`drawn`: with markers of its best candidate); the lines that say
    /// what was refused or left unsolved in it.
    pub(crate) fn count_set(&mut self, reply: &SetReply, drawn: bool) -> Vec<Note> {
        let mut notes = Vec::new();
        self.counts.sets += 1;
        self.counts.markers_built += u64::from(drawn);
        let (status, set_id, message) = (reply.status(), reply.set_id(), reply.message());
        let members = reply.members();
        let incomplete = status == GripRecommendationSet::STATUS_INCOMPLETE;
        if status != GripRecommendationSet::STATUS_OK && !incomplete {
            self.counts.sets_refused += 1;
            notes.push((
                Level::Warn,
                format!("set {:?}: {}", short_id(set_id), message),
            ));
            return notes;
        }
        let (mut invalid, mut no_closure, mut exceeds, mut unsolved) = (0u64, 0u64, 0u64, 0u64);
        for r in &members {
            match r.status {
                GripRecommendation::STATUS_OK => {}
                GripRecommendation::STATUS_NO_FORCE_CLOSURE => no_closure += 1,
                GripRecommendation::STATUS_EXCEEDS_GRIPPER => exceeds += 1,
                GripRecommendation::STATUS_NOT_SOLVED => unsolved += 1,
                _ => invalid += 1,
            }
        }
        self.counts.answered += members.len() as u64 - unsolved;
        self.counts.invalid += invalid;
        self.counts.no_closure += no_closure;
        self.counts.exceeds_gripper += exceeds;
        self.counts.not_solved += unsolved;
        if incomplete {
            self.counts.sets_incomplete += 1;
            notes.push((
                Level::Warn,
                format!("set {:?}: {}", short_id(set_id), message),
            ));
        }
        if invalid > 0 {
            notes.push((
                Level::Warn,
                format!(
                    "set {:?}: {invalid} of {} candidates refused as invalid, e.g. {} ({} refused \
                     so far)",
                    short_id(set_id),
                    members.len(),
                    members
                        .iter()
                        .find(|r| r.status == GripRecommendation::STATUS_INVALID_INPUT)
                        .map_or("", |r| r.message.as_str()),
                    self.counts.invalid
                ),
            ));
        }
        notes
    }

    /// Records a set's answer that went out at `answered` (ns since the epoch): its markers, the
    /// set with its own times, and the answer, together. Says so if the recording's writer has
    /// stopped on a failure.
    pub(crate) fn record_set(&mut self, recorded: RecordedSet, answered: u64) -> Vec<Note> {
        let RecordedSet {
            set,
            received,
            sent,
            reply,
            markers,
        } = recorded;
        let entry = |payload, log_time, publish_time| Entry {
            payload,
            log_time,
            publish_time,
        };
        let mut entries = Vec::with_capacity(3);
        if let Some(array) = markers {
            entries.push(entry(Payload::markers(array), answered, answered));
        }
        entries.push(entry(set.payload(), received, sent));
        if let Some(r) = reply {
            entries.push(entry(r.payload(), answered, answered));
        }
        self.recording.record_all(entries);
        self.recording.check().iter().map(note).collect()
    }

    /// Counts a message on `topic` that did not decode (a candidate on the candidates topic, a
    /// set on any other topic or the service); the line to log.
    pub(crate) fn undecodable(&mut self, topic: &str, error: &dyn std::fmt::Debug) -> Note {
        let (count, what) = if self.candidates_topics.iter().any(|t| t == topic) {
            (&mut self.counts.undecodable, "")
        } else {
            (&mut self.counts.undecodable_sets, " sets")
        };
        *count += 1;
        (
            Level::Warn,
            format!("a message on {topic} could not be decoded ({error:?}); {count}{what} so far"),
        )
    }

    /// The last words: the counts, and the recording closed.
    pub(crate) fn finish(&mut self) -> Vec<Note> {
        let c = self.counts;
        let mut notes = vec![(
            Level::Info,
            format!(
                "answered {} candidates: {} refused as invalid, {} without force closure, {} \
                 undecodable",
                c.answered, c.invalid, c.no_closure, c.undecodable
            ),
        )];
        if c.exceeds_gripper + c.sets + c.undecodable_sets > 0 {
            notes.push((
                Level::Info,
                format!(
                    "{} candidates needed more than max_grip_force; {} sets answered, {} of them \
                     refused whole, {} incomplete ({} candidates not solved); {} sets \
                     undecodable",
                    c.exceeds_gripper,
                    c.sets,
                    c.sets_refused,
                    c.sets_incomplete,
                    c.not_solved,
                    c.undecodable_sets
                ),
            ));
        }
        notes.push((
            Level::Info,
            format!(
                "markers: {} arrays built, {} published",
                c.markers_built, c.markers_published
            ),
        ));
        notes.extend(self.recording.stop().iter().map(note));
        notes
    }
}

/// The log line of a change of the recording: an error for a failure.
fn note(change: &Change) -> Note {
    let level = if change.is_failure() {
        Level::Error
    } else {
        Level::Info
    };
    (level, change.to_string())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::config::Config;

    fn paper_case_a() -> GraspCandidate {
        let line = include_str!("../../examples/paper_cases.jsonl")
            .lines()
            .next();
        serde_json::from_str(line.expect("a case")).expect("a GraspCandidate")
    }

    pub(crate) fn answerer(config: Config, echo: bool) -> Answerer {
        let settings = config.solver_settings().expect("valid");
        let topics = Topics::default_names().with_markers("/grip_markers");
        Answerer::new(
            Shared::new(config, settings),
            echo,
            "/grasp_orient",
            topics,
            100,
            std::sync::Arc::new(|| {}),
            std::sync::Arc::new(MeshCache::new(
                grasp_orient_geometry::AmentIndex::default(),
                1 << 20,
            )),
        )
    }

    pub(crate) fn no_recording() -> Config {
        Config {
            record: false,
            ..Config::default()
        }
    }

    /// Recording into `dir`, markers included.
    fn recording_markers(dir: &std::path::Path) -> Config {
        Config {
            record_dir: dir.display().to_string(),
            record_markers: true,
            ..Config::default()
        }
    }

    #[test]
    fn answers_count_and_mark_without_dds() {
        let mut a = answerer(no_recording(), false);
        assert!(a.start().expect("nothing to start").is_empty());
        let case = paper_case_a();
        let out = a.handle(case.clone(), 10, 5, true);
        assert_eq!(out.reply.status, GripRecommendation::STATUS_OK);
        assert_eq!(out.reply.candidate_id, case.id);
        assert_eq!(out.reply.objective, "norm2");
        assert!(out.markers.as_ref().is_some_and(|m| !m.markers.is_empty()));
        assert!(out.notes.is_empty(), "{:?}", out.notes);
        assert!(
            out.recorded.reply.is_none(),
            "cloned for a recording that is off"
        );

        let bad = GraspCandidate {
            mass: f64::NAN,
            id: "x".repeat(100).into(),
            ..case.clone()
        };
        let out = a.handle(bad, 11, 6, true);
        assert_eq!(out.reply.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert!(out.markers.is_none());
        let (level, text) = &out.notes[0];
        assert_eq!(*level, Level::Warn);
        assert!(text.contains(&"x".repeat(64)) && !text.contains(&"x".repeat(65)));
        assert!(text.ends_with("(1 refused so far)"), "{text}");

        let note = a.undecodable("/grasp_candidates", &"bad CDR");
        assert!(note.1.contains("/grasp_candidates") && note.1.ends_with("1 so far"));
        // A set that does not decode is no candidate: counted apart, on the line of the sets.
        let note = a.undecodable("/grasp_candidate_sets", &"bad CDR");
        assert!(note.1.ends_with("; 1 sets so far"), "{}", note.1);
        a.undecodable("recommend", &"bad CDR");
        assert_eq!(
            a.counts(),
            Counts {
                answered: 2,
                invalid: 1,
                no_closure: 0,
                undecodable: 1,
                undecodable_sets: 2,
                markers_built: 1,
                ..Counts::default()
            }
        );
        let last = a.finish();
        assert_eq!(
            last[0].1,
            "answered 2 candidates: 1 refused as invalid, 0 without force closure, 1 undecodable"
        );
        assert_eq!(
            last[1].1,
            "0 candidates needed more than max_grip_force; 0 sets answered, 0 of them refused \
             whole, 0 incomplete (0 candidates not solved); 2 sets undecodable"
        );
        assert_eq!(last[2].1, "markers: 1 arrays built, 0 published");
    }

    /// With nobody subscribed to `grip_markers` and no recording of markers, no marker array is
    /// built (nor counted); a subscriber gets them from the next answer on; a recording that
    /// takes markers gets them with no subscriber.
    #[test]
    fn markers_are_built_only_for_a_subscriber_or_a_recording() {
        let mut a = answerer(no_recording(), false);
        let out = a.handle(paper_case_a(), 10, 5, false);
        assert_eq!(out.reply.status, GripRecommendation::STATUS_OK);
        assert!(out.markers.is_none(), "built for nobody");
        let boxed = r#""primitive": {"type": 1, "dimensions": [0.04, 0.06, 0.08]}"#;
        let pose = a.handle_pose(pose_on("box", boxed), 11, 6, false);
        assert_eq!(pose.reply.recommendation.status, 0, "{:?}", pose.reply);
        assert!(pose.markers.is_none(), "built for nobody");
        let (reply, markers) = a.pose_work(12, false).run(&pose_on("box", boxed));
        assert!(markers.is_none() && reply.recommendation.status == 0);
        assert_eq!(a.counts().markers_built, 0);

        // A subscriber came: the next answer is drawn.
        let out = a.handle(paper_case_a(), 13, 8, true);
        assert!(out.markers.as_ref().is_some_and(|m| !m.markers.is_empty()));
        let pose = a.handle_pose(pose_on("box", boxed), 14, 9, true);
        assert!(pose.markers.is_some());
        a.count_published_markers();
        let c = a.counts();
        assert_eq!((c.markers_built, c.markers_published), (2, 1));
        assert!(!a.draws(false, true), "publish_markers false wins");

        // Recorded markers are built with no subscriber, and recorded.
        let dir = tempfile::tempdir().expect("a temporary folder");
        let config = recording_markers(dir.path());
        let mut a = answerer(config, false);
        a.start().expect("starts");
        assert!(a.draws(true, false));
        let out = a.handle(paper_case_a(), 3, 2, false);
        assert!(out.markers.is_some() && out.recorded.markers.is_some());
        assert!(a.record(out.recorded, 4).is_empty());
        let notes = a.finish();
        assert!(
            notes
                .iter()
                .any(|n| n.1 == "markers: 1 arrays built, 0 published"),
            "{notes:?}"
        );
        assert!(
            notes.iter().any(|n| n
                .1
                .ends_with("closed: 1 candidates, 1 recommendations, 1 marker arrays")),
            "{notes:?}"
        );

        // Echo mode draws nothing, whoever listens.
        let a = answerer(Config::default(), true);
        assert!(!a.draws(true, true));
    }

    #[test]
    fn settings_changes_apply_to_candidates_received_after_them() {
        let mut a = answerer(no_recording(), false);
        let shared = a.shared.clone();
        let before = crate::record::now_ns();
        let set = shared.set_action();
        set(
            "objective",
            &ros2_client::ParameterValue::String("norm1".into()),
        )
        .expect("valid");
        set(
            "publish_markers",
            &ros2_client::ParameterValue::Boolean(false),
        )
        .expect("valid");
        let after = crate::record::now_ns();
        let out = a.handle(paper_case_a(), after, after, true);
        assert_eq!(out.reply.objective, "norm1");
        assert!(out.markers.is_none());
        // Received before the set, answered after it: the settings of its time.
        let out = a.handle(paper_case_a(), before, before, true);
        assert_eq!(out.reply.objective, "norm2");
        assert!(out.markers.is_some());
    }

    #[test]
    fn echo_answers_empty_with_header_and_id() {
        let mut a = answerer(Config::default(), true);
        let notes = a.start().expect("echo records nothing");
        assert_eq!(notes[0].0, Level::Warn);
        let case = paper_case_a();
        let out = a.handle(case.clone(), 0, 0, true);
        assert_eq!(out.reply.candidate_id, case.id);
        assert_eq!(out.reply.header, case.header);
        assert_eq!(out.reply.objective, "");
        assert!(out.markers.is_none() && out.recorded.reply.is_none());
    }

    #[test]
    fn record_switches_and_settings_take_effect_when_set() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let config = recording_markers(dir.path());
        let mut a = answerer(config, false);
        let started = a.start().expect("starts");
        assert!(started[0].1.starts_with("recording to "), "{started:?}");
        let out = a.handle(paper_case_a(), 3, 2, false);
        assert!(out.recorded.reply.is_some() && out.recorded.markers.is_some());
        assert!(a.record(out.recorded, 4).is_empty());
        let set = a.shared.set_action();
        set(
            "friction_safety_factor",
            &ros2_client::ParameterValue::Double(1.5),
        )
        .expect("valid");
        assert!(
            a.refresh().is_empty(),
            "a settings change is written, not logged"
        );
        // Off and on again with no candidate in between: closed and a new file at once.
        set("record", &ros2_client::ParameterValue::Boolean(false)).expect("valid");
        let notes = a.refresh();
        assert!(
            notes[0]
                .1
                .ends_with("closed: 1 candidates, 1 recommendations, 1 marker arrays"),
            "{notes:?}"
        );
        set("record", &ros2_client::ParameterValue::Boolean(true)).expect("valid");
        let notes = a.refresh();
        assert!(notes[0].1.starts_with("recording to "), "{notes:?}");
        a.finish();

        let mut files: Vec<_> = std::fs::read_dir(dir.path())
            .expect("the folder")
            .map(|e| e.expect("an entry").path())
            .collect();
        files.sort();
        assert_eq!(files.len(), 2, "{files:?}");
        let first = crate::record::bag::read(&files[0]).expect("whole");
        let settings: Vec<SettingsRecord> = first
            .metadata
            .iter()
            .map(|(name, entries)| {
                assert_eq!(name, crate::record::settings::METADATA_NAME);
                SettingsRecord::from_metadata(entries).expect("reads")
            })
            .collect();
        assert_eq!(settings.len(), 3, "at start and at each change");
        assert_eq!(
            (settings[0].since, settings[0].reason.as_str()),
            (0, "start")
        );
        assert_eq!(settings[1].reason, "parameter friction_safety_factor set");
        assert_eq!(settings[2].reason, "parameter record set");
        assert!(!settings[2].config.record && settings[2].since >= settings[1].since);
        assert_eq!(settings[1].config.friction_safety_factor, 1.5);
        assert!(settings[1].since > 0 && settings.iter().all(|s| s.node == "/grasp_orient"));
        // The new file carries every version, each from its own time.
        let second = crate::record::bag::read(&files[1]).expect("whole");
        assert!(second.metadata.len() >= 2, "{:?}", second.metadata.len());
    }

    /// A pose candidate on a box (or with `shape` instead), the tool across it.
    pub(crate) fn pose_on(id: &str, shape: &str) -> PoseCandidate {
        let line = format!(
            r#"{{"header": {{"frame_id": "base_link"}}, "id": "{id}", "grasp_pose": {{"position": {{"x": 0.0, "y": 0.0, "z": 0.0}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}, "width": 0.09, "object": {{"pose": {{"position": {{"x": 0.0, "y": 0.0, "z": 0.0}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}, {shape}, "mass": 0.25, "friction": 0.5}}, "gravity": {{"x": 0.0, "y": 0.0, "z": -9.81}}}}"#
        );
        serde_json::from_str(&line).expect("a PoseCandidate")
    }

    /// A 10 MiB `object.mesh` is refused in an answer and a log line of a few hundred bytes
    /// (before, the resource was echoed whole into both: 21 MB each).
    #[test]
    fn a_mesh_resource_of_10_mib_is_echoed_neither_in_the_answer_nor_in_the_log() {
        let mut a = answerer(no_recording(), false);
        let resource = format!("package://pkg/{}.stl", "a".repeat(10 << 20));
        let mut candidate = pose_on("long", r#""mesh": "x.stl""#);
        candidate.object.mesh = resource.as_str().into();
        let out = a.handle_pose(candidate, 10, 5, true);
        let m = &out.reply.recommendation.message;
        assert_eq!(
            out.reply.recommendation.status,
            2,
            "{}",
            &m[..m.len().min(300)]
        );
        assert!(m.len() < 400, "{} bytes: {}", m.len(), &m[..400]);
        assert!(m.contains("longer than 4096 bytes"), "{m}");
        assert_eq!(out.notes.len(), 1);
        for (_, line) in &out.notes {
            assert!(line.len() < 600, "{} bytes: {}", line.len(), &line[..600]);
        }
        let bytes = crate::msg::cdr::encode(&out.reply).expect("encodes");
        assert!(bytes.len() < 2048, "an answer of {} bytes", bytes.len());
    }

    /// Pose candidates are answered, counted and drawn as candidates are; a mesh file not yet
    /// loaded is told apart (the node answers such a candidate off its thread), and is kept
    /// once answered.
    #[test]
    fn pose_candidates_answer_count_and_mark_without_dds() {
        let mut a = answerer(no_recording(), false);
        let out = a.handle_pose(
            pose_on(
                "box",
                r#""primitive": {"type": 1, "dimensions": [0.04, 0.06, 0.08]}"#,
            ),
            10,
            5,
            true,
        );
        assert_eq!(out.reply.recommendation.status, 0, "{:?}", out.reply);
        assert_eq!(out.reply.contact_1.y, -0.03);
        let names: Vec<&str> = out
            .markers
            .as_ref()
            .expect("markers")
            .markers
            .iter()
            .map(|m| m.ns.as_str())
            .collect();
        assert!(
            names.contains(&"object") && names.contains(&"fingers"),
            "{names:?}"
        );
        let refused = a.handle_pose(
            pose_on(
                "type 7",
                r#""primitive": {"type": 7, "dimensions": [0.04]}"#,
            ),
            11,
            6,
            true,
        );
        assert_eq!(refused.reply.recommendation.status, 2);
        assert!(refused.markers.is_none());
        assert_eq!(refused.notes.len(), 1, "{:?}", refused.notes);
        let c = a.counts();
        assert_eq!((c.answered, c.invalid), (2, 1));

        let dir = tempfile::tempdir().expect("a temporary folder");
        let obj = dir.path().join("block.obj");
        let text: String = [
            "v -20 -30 -40",
            "v -20 -30 40",
            "v -20 30 -40",
            "v -20 30 40",
            "v 20 -30 -40",
            "v 20 -30 40",
            "v 20 30 -40",
            "v 20 30 40",
            "f 1 2 4",
            "f 1 4 3",
            "f 5 7 8",
            "f 5 8 6",
            "f 1 5 6",
            "f 1 6 2",
            "f 3 4 8",
            "f 3 8 7",
            "f 1 3 7",
            "f 1 7 5",
            "f 2 6 8",
            "f 2 8 4",
        ]
        .map(|l| format!("{l}\n"))
        .concat();
        std::fs::write(&obj, text).expect("write");
        let shape = format!(
            r#""mesh": "{}", "scale": {{"x": 0.001, "y": 0.001, "z": 0.001}}"#,
            obj.display()
        );
        let block = pose_on("block", &shape);
        assert!(a.loads_a_mesh(&block), "not loaded yet");
        assert!(a.answers_off_thread(&block), "not loaded yet");
        let work = a.pose_work(12, true);
        let (reply, markers) = work.run(&block);
        assert_eq!(reply.recommendation.status, 0, "{reply:?}");
        assert!(!a.loads_a_mesh(&block), "kept once answered");
        let out = a.account_pose(block, reply, markers, 12, 7);
        assert!(out.markers.is_some());
        assert_eq!(a.counts().answered, 3);
        let inline = pose_on(
            "inline",
            r#""inline_mesh": {"vertices": [], "triangles": []}"#,
        );
        assert!(!a.loads_a_mesh(&inline), "no file to load");
        assert!(!a.answers_off_thread(&inline), "nothing to index");
    }

    /// A closed inline mesh of `2 × rings × sides` triangles, in metres: a torus about an axis
    /// parallel to z through (0, -0.06, 0), its tube 25 mm in radius, whose centre line passes
    /// through the origin along x, so that [`pose_on`]'s fingers close across the tube.
    pub(crate) fn torus_inline(rings: u32, sides: u32) -> String {
        let mut vertices = Vec::new();
        for i in 0..rings {
            for j in 0..sides {
                let u = std::f64::consts::TAU * f64::from(i) / f64::from(rings);
                let v = std::f64::consts::TAU * f64::from(j) / f64::from(sides);
                let rho = 0.06 + 0.025 * v.cos();
                let (x, y, z) = (rho * u.sin(), rho * u.cos() - 0.06, 0.025 * v.sin());
                vertices.push(format!(r#"{{"x": {x}, "y": {y}, "z": {z}}}"#));
            }
        }
        let at = |i: u32, j: u32| (i % rings) * sides + j % sides;
        let mut triangles = Vec::new();
        for i in 0..rings {
            for j in 0..sides {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                triangles.push(format!(r#"{{"vertex_indices": [{a}, {b}, {c}]}}"#));
                triangles.push(format!(r#"{{"vertex_indices": [{a}, {c}, {d}]}}"#));
            }
        }
        format!(
            r#""inline_mesh": {{"vertices": [{}], "triangles": [{}]}}"#,
            vertices.join(", "),
            triangles.join(", ")
        )
    }

    /// A single pose candidate with an inline mesh of [`INLINE_OFF_THREAD_TRIANGLES`] triangles
    /// or more is answered off the node's thread, every time (it is indexed anew each time); one
    /// with fewer, on it. The answer off the thread is the one on it.
    #[test]
    fn a_large_inline_mesh_is_answered_off_the_thread_and_a_small_one_on_it() {
        let mut a = answerer(no_recording(), false);
        // 2 × 10 × 5 = 100 triangles; 2 × 8 × 6 = 96.
        let large = pose_on("large", &torus_inline(10, 5));
        let small = pose_on("small", &torus_inline(8, 6));
        assert_eq!(
            large.object.inline_mesh.triangles.len(),
            INLINE_OFF_THREAD_TRIANGLES
        );
        assert!(small.object.inline_mesh.triangles.len() < INLINE_OFF_THREAD_TRIANGLES);
        assert!(a.answers_off_thread(&large));
        assert!(!a.answers_off_thread(&small));
        let work = a.pose_work(20, true);
        let sent = large.clone();
        let run = std::thread::spawn(move || work.run(&sent));
        let (reply, markers) = run.join().expect("answered on another thread");
        assert_eq!(reply.recommendation.status, 0, "{reply:?}");
        let off = a.account_pose(large.clone(), reply, markers, 20, 9);
        assert!(a.answers_off_thread(&large), "an inline mesh is not kept");
        let on = a.handle_pose(large, 21, 10, true);
        assert_eq!(format!("{:?}", off.reply), format!("{:?}", on.reply));
        let echo = answerer(no_recording(), true);
        assert!(!echo.answers_off_thread(&pose_on("echoed", &torus_inline(10, 5))));
    }
}
