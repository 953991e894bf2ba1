//! The answering loop without DDS: one call per received candidate gives the answer, the markers
//! and the lines to log, and keeps the counts and the recording. The node's DDS glue only
//! receives, publishes what [`Answerer::handle`] returns, and then hands it back to
//! [`Answerer::record`]; unit tests drive it directly.

use super::markers;
use super::params::Shared;
use crate::msg::{
    short_id, GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet,
    MarkerArray,
};
use crate::record::lifecycle::{Recording, Wanted};
use crate::record::{Payload, RecordError, Topics};
use crate::sets::{answer_one, answer_set_on, echo_set};
use log::Level;
use std::path::Path;

/// A line for the log (stderr and `/rosout`).
pub type Note = (Level, String);

/// What the node has done, for its last words.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Candidates answered.
    pub answered: u64,
    /// Answered with status 2 (invalid input).
    pub invalid: u64,
    /// Answered with status 1 (no force closure).
    pub no_closure: u64,
    /// Messages on the candidates topic that did not decode.
    pub undecodable: u64,
    /// Answered with status 3 (more grip force than `max_grip_force`).
    pub exceeds_gripper: u64,
    /// Sets answered (on the topic or the service); their candidates count above too.
    pub sets: u64,
    /// Sets refused as a whole (too large, or bad fields of their own).
    pub sets_refused: u64,
}

/// The answer to one candidate, to publish in this order: `reply`, then `markers`.
#[derive(Debug)]
pub struct Outcome {
    /// The recommendation.
    pub reply: GripRecommendation,
    /// The markers, when they are on and the answer has status 0.
    pub markers: Option<MarkerArray>,
    /// Lines to log.
    pub notes: Vec<Note>,
    /// What goes to the recording once the answer is out.
    pub recorded: Recorded,
}

/// The messages of one answer for the recording, with the candidate's times.
#[derive(Debug)]
pub struct Recorded {
    candidate: GraspCandidate,
    received: u64,
    sent: u64,
    reply: Option<GripRecommendation>,
    markers: Option<MarkerArray>,
}

/// The answer to one set, to publish (or send as the service's response) in this order:
/// `reply`, then `markers`.
#[derive(Debug)]
pub struct SetOutcome {
    /// The answer to the set.
    pub reply: GripRecommendationSet,
    /// The markers of the best candidate, when they are on and one can be held.
    pub markers: Option<MarkerArray>,
    /// Lines to log.
    pub notes: Vec<Note>,
    /// What goes to the recording once the answer is out.
    pub recorded: RecordedSet,
}

/// The messages of one set's answer for the recording, with the set's times.
#[derive(Debug)]
pub struct RecordedSet {
    set: GraspCandidateSet,
    received: u64,
    sent: u64,
    reply: Option<GripRecommendationSet>,
    markers: Option<MarkerArray>,
}

/// Answers candidates with the live settings; counts; records.
#[derive(Debug)]
pub struct Answerer {
    shared: Shared,
    echo: bool,
    counts: Counts,
    recording: Recording,
}

impl Answerer {
    /// Answers with `shared`'s settings (or, with `echo`, an empty answer carrying the header
    /// and id), recording on `topics` with QoS depth `qos_depth` in the recording's metadata.
    pub fn new(shared: Shared, echo: bool, topics: Topics, qos_depth: i64) -> Self {
        Self {
            shared,
            echo,
            counts: Counts::default(),
            recording: Recording::new(topics, qos_depth),
        }
    }

    /// What has been done so far.
    pub fn counts(&self) -> Counts {
        self.counts
    }

    /// Starts recording if `record` says so (never in echo mode); a failure here is an error.
    pub fn start(&mut self) -> Result<Vec<Note>, RecordError> {
        if self.echo {
            return Ok(vec![(
                Level::Warn,
                "echo mode: answers are empty, nothing is solved".to_string(),
            )]);
        }
        let mut notes = Vec::new();
        self.follow_record(&mut notes)?;
        Ok(notes)
    }

    fn follow_record(&mut self, notes: &mut Vec<Note>) -> Result<(), RecordError> {
        let config = self.shared.lock().config.clone();
        let wanted = Wanted {
            record: config.record,
            dir: Path::new(&config.record_dir),
            markers: config.record_markers,
        };
        if let Some(change) = self.recording.follow(wanted)? {
            let level = if change.is_failure() {
                Level::Error
            } else {
                Level::Info
            };
            notes.push((level, change.to_string()));
        }
        Ok(())
    }

    /// The answer to one candidate, received at `received` and sent at `sent` (ns since the
    /// epoch). The `record` parameter takes effect here, before the answer.
    pub fn handle(&mut self, candidate: GraspCandidate, received: u64, sent: u64) -> Outcome {
        let mut notes = Vec::new();
        let (settings, markers_on, record, rules) = {
            let live = self.shared.lock();
            (
                live.settings,
                live.config.publish_markers,
                live.config.record,
                live.config.rules(),
            )
        };
        if !self.echo && self.recording.must_follow(record) {
            if let Err(e) = self.follow_record(&mut notes) {
                let e = anyhow::Error::new(e).context("recording is off");
                notes.push((Level::Error, format!("{e:#}")));
            }
        }
        let reply = if self.echo {
            GripRecommendation {
                header: candidate.header.clone(),
                candidate_id: candidate.id.clone(),
                ..GripRecommendation::default()
            }
        } else {
            answer_one(&candidate, &settings, &rules)
        };
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
        let markers = (markers_on && !self.echo && reply.status == GripRecommendation::STATUS_OK)
            .then(|| markers::build(&candidate, &reply));
        let recorded = Recorded {
            reply: self.recording.is_on().then(|| reply.clone()),
            markers: markers
                .as_ref()
                .filter(|_| self.recording.records_markers())
                .cloned(),
            candidate,
            received,
            sent,
        };
        Outcome {
            reply,
            markers,
            notes,
            recorded,
        }
    }

    /// Records an answer that went out at `answered` (ns since the epoch): its markers, the
    /// candidate with its own times, and the recommendation.
    pub fn record(&mut self, recorded: Recorded, answered: u64) {
        let Recorded {
            candidate,
            received,
            sent,
            reply,
            markers,
        } = recorded;
        if let Some(array) = markers {
            self.recording
                .record(Payload::Markers(Box::new(array)), answered, answered);
        }
        self.recording
            .record(Payload::Candidate(Box::new(candidate)), received, sent);
        if let Some(r) = reply {
            self.recording
                .record(Payload::Recommendation(Box::new(r)), answered, answered);
        }
    }

    /// The answer to one set, received at `received` and sent at `sent` (ns since the epoch), by
    /// the same rules as [`Answerer::handle`]: markers for the best candidate, one log line for
    /// the set when some of its candidates or the set itself are refused.
    pub fn handle_set(&mut self, set: GraspCandidateSet, received: u64, sent: u64) -> SetOutcome {
        let mut notes = Vec::new();
        let (settings, markers_on, record, rules) = {
            let live = self.shared.lock();
            (
                live.settings,
                live.config.publish_markers,
                live.config.record,
                live.config.rules(),
            )
        };
        if !self.echo && self.recording.must_follow(record) {
            if let Err(e) = self.follow_record(&mut notes) {
                let e = anyhow::Error::new(e).context("recording is off");
                notes.push((Level::Error, format!("{e:#}")));
            }
        }
        let reply = if self.echo {
            echo_set(&set)
        } else {
            // A large set is shared among the cores: the DDS threads are idle while it is solved.
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            answer_set_on(&set, &settings, &rules, threads)
        };
        self.count_set(&reply, &mut notes);
        let best = reply.ranking.first().map(|&i| i as usize);
        let markers = best.filter(|_| markers_on && !self.echo).and_then(|i| {
            Some(markers::build(
                set.candidates.get(i)?,
                reply.recommendations.get(i)?,
            ))
        });
        let recorded = RecordedSet {
            reply: self.recording.is_on().then(|| reply.clone()),
            markers: markers
                .as_ref()
                .filter(|_| self.recording.records_markers())
                .cloned(),
            set,
            received,
            sent,
        };
        SetOutcome {
            reply,
            markers,
            notes,
            recorded,
        }
    }

    /// Counts a set's answer, and says what was refused in it.
    fn count_set(&mut self, reply: &GripRecommendationSet, notes: &mut Vec<Note>) {
        self.counts.sets += 1;
        if reply.status != GripRecommendationSet::STATUS_OK {
            self.counts.sets_refused += 1;
            notes.push((
                Level::Warn,
                format!("set {:?}: {}", short_id(&reply.set_id), reply.message),
            ));
            return;
        }
        let (mut invalid, mut no_closure, mut exceeds) = (0u64, 0u64, 0u64);
        for r in &reply.recommendations {
            match r.status {
                GripRecommendation::STATUS_OK => {}
                GripRecommendation::STATUS_NO_FORCE_CLOSURE => no_closure += 1,
                GripRecommendation::STATUS_EXCEEDS_GRIPPER => exceeds += 1,
                _ => invalid += 1,
            }
        }
        self.counts.answered += reply.recommendations.len() as u64;
        self.counts.invalid += invalid;
        self.counts.no_closure += no_closure;
        self.counts.exceeds_gripper += exceeds;
        if invalid > 0 {
            notes.push((
                Level::Warn,
                format!(
                    "set {:?}: {invalid} of {} candidates refused as invalid, e.g. {} ({} refused \
                     so far)",
                    short_id(&reply.set_id),
                    reply.recommendations.len(),
                    reply
                        .recommendations
                        .iter()
                        .find(|r| r.status == GripRecommendation::STATUS_INVALID_INPUT)
                        .map_or("", |r| r.message.as_str()),
                    self.counts.invalid
                ),
            ));
        }
    }

    /// Records a set's answer that went out at `answered` (ns since the epoch): its markers, the
    /// set with its own times, and the answer.
    pub fn record_set(&mut self, recorded: RecordedSet, answered: u64) {
        let RecordedSet {
            set,
            received,
            sent,
            reply,
            markers,
        } = recorded;
        if let Some(array) = markers {
            self.recording
                .record(Payload::Markers(Box::new(array)), answered, answered);
        }
        self.recording
            .record(Payload::CandidateSet(Box::new(set)), received, sent);
        if let Some(r) = reply {
            self.recording
                .record(Payload::RecommendationSet(Box::new(r)), answered, answered);
        }
    }

    /// Counts a message on `topic` that did not decode; the line to log.
    pub fn undecodable(&mut self, topic: &str, error: &dyn std::fmt::Debug) -> Note {
        self.counts.undecodable += 1;
        (
            Level::Warn,
            format!(
                "a message on {topic} could not be decoded ({error:?}); {} so far",
                self.counts.undecodable
            ),
        )
    }

    /// The last words: the counts, and the recording closed.
    pub fn finish(&mut self) -> Vec<Note> {
        let c = self.counts;
        let mut notes = vec![(
            Level::Info,
            format!(
                "answered {} candidates: {} refused as invalid, {} without force closure, {} \
                 undecodable",
                c.answered, c.invalid, c.no_closure, c.undecodable
            ),
        )];
        if c.exceeds_gripper + c.sets > 0 {
            notes.push((
                Level::Info,
                format!(
                    "{} candidates needed more than max_grip_force; {} sets answered, {} of them \
                     refused whole",
                    c.exceeds_gripper, c.sets, c.sets_refused
                ),
            ));
        }
        if let Some(change) = self.recording.stop() {
            let level = if change.is_failure() {
                Level::Error
            } else {
                Level::Info
            };
            notes.push((level, change.to_string()));
        }
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    fn paper_case_a() -> GraspCandidate {
        crate::msg::paper_cases().remove(0)
    }

    fn answerer(config: Config, echo: bool) -> Answerer {
        let settings = config.solver_settings().expect("valid");
        let topics = Topics {
            candidates: "/grasp_candidates".into(),
            recommendations: "/grip_recommendations".into(),
            markers: Some("/grip_markers".into()),
            sets: Some(crate::record::SetTopics::default_names()),
        };
        Answerer::new(Shared::new(config, settings), echo, topics, 100)
    }

    fn no_recording() -> Config {
        Config {
            record: false,
            ..Config::default()
        }
    }

    #[test]
    fn answers_count_and_mark_without_dds() {
        let mut a = answerer(no_recording(), false);
        assert!(a.start().expect("nothing to start").is_empty());
        let case = paper_case_a();
        let out = a.handle(case.clone(), 10, 5);
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
            id: "x".repeat(100),
            ..case.clone()
        };
        let out = a.handle(bad, 11, 6);
        assert_eq!(out.reply.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert!(out.markers.is_none());
        let (level, text) = &out.notes[0];
        assert_eq!(*level, Level::Warn);
        assert!(text.contains(&"x".repeat(64)) && !text.contains(&"x".repeat(65)));
        assert!(text.ends_with("(1 refused so far)"), "{text}");

        let note = a.undecodable("/grasp_candidates", &"bad CDR");
        assert!(note.1.contains("/grasp_candidates") && note.1.ends_with("1 so far"));
        assert_eq!(
            a.counts(),
            Counts {
                answered: 2,
                invalid: 1,
                no_closure: 0,
                undecodable: 1,
                ..Counts::default()
            }
        );
        let last = a.finish();
        assert_eq!(
            last[0].1,
            "answered 2 candidates: 1 refused as invalid, 0 without force closure, 1 undecodable"
        );
    }

    #[test]
    fn settings_changes_apply_to_the_next_candidate() {
        let a_config = no_recording();
        let mut a = answerer(a_config, false);
        let shared = a.shared.clone();
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
        let out = a.handle(paper_case_a(), 0, 0);
        assert_eq!(out.reply.objective, "norm1");
        assert!(out.markers.is_none());
    }

    #[test]
    fn echo_answers_empty_with_header_and_id() {
        let mut a = answerer(Config::default(), true);
        let notes = a.start().expect("echo records nothing");
        assert_eq!(notes[0].0, Level::Warn);
        let case = paper_case_a();
        let out = a.handle(case.clone(), 0, 0);
        assert_eq!(out.reply.candidate_id, case.id);
        assert_eq!(out.reply.header, case.header);
        assert_eq!(out.reply.objective, "");
        assert!(out.markers.is_none() && out.recorded.reply.is_none());
    }

    #[test]
    fn records_what_was_answered_while_record_is_on() {
        let dir = std::env::temp_dir().join(format!("grasp_orient_answer_{}", std::process::id()));
        let config = Config {
            record_dir: dir.display().to_string(),
            record_markers: true,
            ..Config::default()
        };
        let mut a = answerer(config, false);
        let started = a.start().expect("starts");
        assert!(started[0].1.starts_with("recording to "), "{started:?}");
        let out = a.handle(paper_case_a(), 3, 2);
        assert!(out.recorded.reply.is_some() && out.recorded.markers.is_some());
        a.record(out.recorded, 4);
        let shared = a.shared.clone();
        (shared.set_action())("record", &ros2_client::ParameterValue::Boolean(false))
            .expect("valid");
        let out = a.handle(paper_case_a(), 5, 4);
        let closed = &out.notes[0].1;
        assert!(
            closed.ends_with("closed: 1 candidates, 1 recommendations, 1 marker arrays"),
            "{closed}"
        );
        assert!(out.recorded.reply.is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
