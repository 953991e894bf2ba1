//! The answering loop without DDS: one call per received candidate gives the answer, the markers
//! and the lines to log, and keeps the counts and the recording. The node's DDS glue only
//! receives, publishes what [`Answerer::handle`] returns, and then hands it back to
//! [`Answerer::record`]; unit tests drive it directly.

use super::markers;
use super::params::Shared;
use crate::msg::{answer, short_id, GraspCandidate, GripRecommendation, MarkerArray};
use crate::record::lifecycle::{Recording, Wanted};
use crate::record::{Payload, RecordError, Topics};
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
        let (settings, markers_on, record) = {
            let live = self.shared.lock();
            (
                live.settings,
                live.config.publish_markers,
                live.config.record,
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
            answer(&candidate, &settings)
        };
        match reply.status {
            GripRecommendation::STATUS_OK => {}
            GripRecommendation::STATUS_NO_FORCE_CLOSURE => self.counts.no_closure += 1,
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
                undecodable: 1
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
