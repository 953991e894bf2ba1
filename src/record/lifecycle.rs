//! The node's recording over a run: started, stopped and restarted as the `record` parameter
//! says, one file per switch-on, and what each file holds when it closes.

use super::{Entry, Payload, RecordError, Recorder, Topics, Written};
use std::fmt;
use std::path::{Path, PathBuf};

/// What the `record*` parameters ask for.
#[derive(Debug, Clone, Copy)]
pub struct Wanted<'a> {
    /// Record at all (`record`).
    pub record: bool,
    /// The folder for new files (`record_dir`).
    pub dir: &'a Path,
    /// Record the markers too (`record_markers`); fixed for a file when it starts.
    pub markers: bool,
}

/// A change of the recording, for the log.
#[derive(Debug)]
pub enum Change {
    /// A file was started.
    Started(PathBuf),
    /// A file was finished.
    Closed {
        /// The file.
        path: PathBuf,
        /// What it holds.
        written: Written,
    },
    /// Finishing a file failed.
    Failed(RecordError),
}

impl Change {
    /// Whether it reports a failure.
    pub fn is_failure(&self) -> bool {
        matches!(self, Change::Failed(_))
    }
}

impl fmt::Display for Change {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Change::Started(path) => write!(f, "recording to {}", path.display()),
            Change::Closed { path, written } => {
                write!(
                    f,
                    "recording {} closed: {} candidates, {} recommendations, {} marker arrays",
                    path.display(),
                    written.candidates,
                    written.recommendations,
                    written.markers
                )?;
                if written.candidate_sets + written.recommendation_sets > 0 {
                    write!(
                        f,
                        ", {} candidate sets, {} set answers",
                        written.candidate_sets, written.recommendation_sets
                    )?;
                }
                Ok(())
            }
            Change::Failed(e) => write!(f, "recording failed: {e}"),
        }
    }
}

/// The recording of one node run.
#[derive(Debug)]
pub struct Recording {
    topics: Topics,
    qos_depth: i64,
    active: Option<Recorder>,
    /// Whether the active recording has a markers channel (fixed when it starts).
    markers: bool,
    /// Whether a start failed for the current settings (not retried for every candidate).
    failed: bool,
}

impl Recording {
    /// Nothing recorded yet; files will have the channels `topics` (markers if asked for).
    pub fn new(topics: Topics, qos_depth: i64) -> Self {
        Self {
            topics,
            qos_depth,
            active: None,
            markers: false,
            failed: false,
        }
    }

    /// Whether `record` asks for a start or a stop (a failed start is not retried until
    /// `record` goes false).
    pub fn must_follow(&self, record: bool) -> bool {
        match (self.active.is_some(), record) {
            (false, true) => !self.failed,
            (true, false) => true,
            (false, false) => self.failed,
            (true, true) => false,
        }
    }

    /// Starts or stops recording to match `wanted`. `Err` when a start failed: recording is
    /// then off.
    pub fn follow(&mut self, wanted: Wanted<'_>) -> Result<Option<Change>, RecordError> {
        match (&self.active, wanted.record) {
            (None, true) if !self.failed => {
                let topics = Topics {
                    markers: wanted
                        .markers
                        .then(|| self.topics.markers.clone())
                        .flatten(),
                    ..self.topics.clone()
                };
                match Recorder::start(wanted.dir, topics, self.qos_depth) {
                    Ok(r) => {
                        let path = r.path().to_path_buf();
                        self.markers = wanted.markers;
                        self.active = Some(r);
                        Ok(Some(Change::Started(path)))
                    }
                    Err(e) => {
                        self.failed = true;
                        Err(e)
                    }
                }
            }
            (Some(_), false) => Ok(self.stop()),
            (None, false) => {
                self.failed = false;
                Ok(None)
            }
            _ => Ok(None),
        }
    }

    /// Whether a file is being written.
    pub fn is_on(&self) -> bool {
        self.active.is_some()
    }

    /// Whether the file being written takes markers.
    pub fn records_markers(&self) -> bool {
        self.is_on() && self.markers
    }

    /// Hands one message to the file, if one is being written.
    pub fn record(&self, payload: Payload, log_time: u64, publish_time: u64) {
        if let Some(r) = &self.active {
            if !r.record(Entry {
                payload,
                log_time,
                publish_time,
            }) {
                log::error!(
                    "the recording {} stopped; see its error",
                    r.path().display()
                );
            }
        }
    }

    /// Finishes the file, if any, and says what it holds.
    pub fn stop(&mut self) -> Option<Change> {
        let r = self.active.take()?;
        let path = r.path().to_path_buf();
        Some(match r.finish() {
            Ok(written) => Change::Closed { path, written },
            Err(e) => Change::Failed(e),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topics() -> Topics {
        Topics {
            candidates: "/grasp_candidates".into(),
            recommendations: "/grip_recommendations".into(),
            markers: Some("/grip_markers".into()),
            sets: None,
        }
    }

    #[test]
    fn follows_the_record_parameter_one_file_per_switch_on() {
        let dir =
            std::env::temp_dir().join(format!("grasp_orient_lifecycle_{}", std::process::id()));
        let wanted = |record| Wanted {
            record,
            dir: &dir,
            markers: false,
        };
        let mut rec = Recording::new(topics(), 100);
        assert!(rec.must_follow(true) && !rec.must_follow(false));
        let started = rec.follow(wanted(true)).expect("starts");
        assert!(matches!(started, Some(Change::Started(_))), "{started:?}");
        assert!(rec.is_on() && !rec.records_markers());
        rec.record(Payload::Candidate(Box::default()), 1, 1);
        assert!(!rec.must_follow(true) && rec.must_follow(false));
        match rec.follow(wanted(false)).expect("stops") {
            Some(Change::Closed { written, .. }) => assert_eq!(written.candidates, 1),
            other => panic!("expected a closed file, got {other:?}"),
        }
        assert!(!rec.is_on() && rec.stop().is_none());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_failed_start_waits_for_record_to_go_false() {
        let file =
            std::env::temp_dir().join(format!("grasp_orient_not_a_dir_{}", std::process::id()));
        std::fs::write(&file, b"x").expect("a file where the folder should be");
        let mut rec = Recording::new(topics(), 100);
        let wanted = |record| Wanted {
            record,
            dir: &file,
            markers: true,
        };
        let e = rec
            .follow(wanted(true))
            .expect_err("cannot start in a file");
        assert!(matches!(e, RecordError::Create { .. }), "{e}");
        assert!(!rec.must_follow(true), "retried for every candidate");
        assert!(rec.must_follow(false));
        assert!(rec.follow(wanted(false)).expect("resets").is_none());
        assert!(rec.must_follow(true));
        std::fs::remove_file(&file).ok();
    }
}
