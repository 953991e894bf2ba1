//! The node's recording over a run: started, stopped and restarted as the `record`
//! parameters say, at the moment they are set; one new file per switch-on; a writer that
//! stopped on a failure (a full disk) taken down once, with its cause.

use super::{Entry, OnStop, Payload, RecordError, Recorder, Topics, Written};
use std::fmt;
use std::path::{Path, PathBuf};

/// What the `record*` parameters ask for.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Wanted<'a> {
    /// Record at all (`record`).
    pub(crate) record: bool,
    /// The folder for new files (`record_dir`).
    pub(crate) dir: &'a Path,
    /// Record the markers too (`record_markers`); fixed for a file when it starts.
    pub(crate) markers: bool,
}

/// A change of the recording, for the log.
#[derive(Debug)]
pub(crate) enum Change {
    /// A file was started.
    Started(PathBuf),
    /// A file was finished.
    Closed {
        /// The file.
        path: PathBuf,
        /// What it holds.
        written: Written,
    },
    /// A file could not be finished, or its writer stopped on a failure: recording is off.
    Failed(RecordError),
    /// A file could not be started: recording is off.
    StartFailed(RecordError),
}

impl Change {
    /// Whether it reports a failure.
    pub(crate) fn is_failure(&self) -> bool {
        matches!(self, Change::Failed(_) | Change::StartFailed(_))
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
                    written.requests::<crate::kind::Candidates>(),
                    written.answers::<crate::kind::Candidates>(),
                    written.markers
                )?;
                if written.requests::<crate::kind::Sets>() + written.answers::<crate::kind::Sets>()
                    > 0
                {
                    write!(
                        f,
                        ", {} candidate sets, {} set answers",
                        written.requests::<crate::kind::Sets>(),
                        written.answers::<crate::kind::Sets>()
                    )?;
                }
                let poses = written.requests::<crate::kind::Poses>()
                    + written.requests::<crate::kind::PoseSets>();
                if poses
                    + written.answers::<crate::kind::Poses>()
                    + written.answers::<crate::kind::PoseSets>()
                    > 0
                {
                    write!(
                        f,
                        ", {} pose candidates, {} pose answers, {} pose sets, {} pose set answers",
                        written.requests::<crate::kind::Poses>(),
                        written.answers::<crate::kind::Poses>(),
                        written.requests::<crate::kind::PoseSets>(),
                        written.answers::<crate::kind::PoseSets>()
                    )?;
                }
                Ok(())
            }
            Change::Failed(e) => write!(
                f,
                "{e}. Recording is off; set record to true to start a new file"
            ),
            Change::StartFailed(e) => {
                write!(f, "recording is off: {e}. Set record to true to try again")
            }
        }
    }
}

/// The file being written, and what it was started with.
#[derive(Debug)]
struct Active {
    recorder: Recorder,
    dir: PathBuf,
    markers: bool,
}

/// The recording of one node run.
pub(crate) struct Recording {
    node: String,
    topics: Topics,
    qos_depth: i64,
    on_stop: OnStop,
    active: Option<Active>,
}

impl fmt::Debug for Recording {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Recording")
            .field("node", &self.node)
            .field("active", &self.active)
            .finish_non_exhaustive()
    }
}

impl Recording {
    /// Nothing recorded yet; files of node `node` (its full name) will have the channels
    /// `topics` (markers if asked for). `on_stop` is called from the writer thread when writing
    /// fails, to have [`Recording::check`] called soon.
    pub(crate) fn new(node: &str, topics: Topics, qos_depth: i64, on_stop: OnStop) -> Self {
        Self {
            node: node.to_string(),
            topics,
            qos_depth,
            on_stop,
            active: None,
        }
    }

    /// Starts, stops or restarts recording to match `wanted`: a file in another folder or with
    /// other channels than asked for is closed and a new one started; with `record` true and
    /// no file (never started, stopped, or failed), a start is tried.
    pub(crate) fn follow(&mut self, wanted: Wanted<'_>) -> Vec<Change> {
        let mut changes = Vec::new();
        if let Some(a) = &self.active {
            if !wanted.record || a.dir != wanted.dir || a.markers != wanted.markers {
                changes.extend(self.stop());
            }
        }
        if self.active.is_none() && wanted.record {
            let topics = Topics {
                markers: wanted
                    .markers
                    .then(|| self.topics.markers.clone())
                    .flatten(),
                ..self.topics.clone()
            };
            let started = Recorder::start(
                wanted.dir,
                &self.node,
                topics,
                self.qos_depth,
                self.on_stop.clone(),
            );
            changes.push(match started {
                Ok(recorder) => {
                    let path = recorder.path().to_path_buf();
                    self.active = Some(Active {
                        recorder,
                        dir: wanted.dir.to_path_buf(),
                        markers: wanted.markers,
                    });
                    Change::Started(path)
                }
                Err(e) => Change::StartFailed(e),
            });
        }
        changes
    }

    /// Whether a file is being written.
    pub(crate) fn is_on(&self) -> bool {
        self.active.is_some()
    }

    /// Whether the file being written takes markers.
    pub(crate) fn records_markers(&self) -> bool {
        self.active.as_ref().is_some_and(|a| a.markers)
    }

    /// Hands one message to the file, if one is being written. A writer that has stopped takes
    /// nothing; [`Recording::check`] reports it.
    pub(crate) fn record(&self, payload: Payload, log_time: u64, publish_time: u64) {
        self.record_all(vec![Entry {
            payload,
            log_time,
            publish_time,
        }]);
    }

    /// Hands messages to the file to be written together, if one is being written.
    pub(crate) fn record_all(&self, entries: Vec<Entry>) {
        if let Some(a) = &self.active {
            a.recorder.record_all(entries);
        }
    }

    /// Takes down a writer that stopped on a failure: its cause, once.
    pub(crate) fn check(&mut self) -> Option<Change> {
        if self.active.as_ref()?.recorder.has_stopped() {
            return self.stop();
        }
        None
    }

    /// Finishes the file, if any, and says what it holds.
    pub(crate) fn stop(&mut self) -> Option<Change> {
        let r = self.active.take()?.recorder;
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
    use std::sync::Arc;

    fn topics() -> Topics {
        Topics::new("/grasp_candidates", "/grip_recommendations").with_markers("/grip_markers")
    }

    fn recording(node: &str) -> Recording {
        Recording::new(node, topics(), 100, Arc::new(|| {}))
    }

    fn started(changes: &[Change]) -> PathBuf {
        match changes.last() {
            Some(Change::Started(p)) => p.clone(),
            other => panic!("expected a start, got {other:?}"),
        }
    }

    #[test]
    fn one_new_file_per_switch_on_even_within_a_second() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let wanted = |record| Wanted {
            record,
            dir: dir.path(),
            markers: false,
        };
        let mut rec = recording("/grasp_orient");
        let first = started(&rec.follow(wanted(true)));
        assert!(rec.is_on() && !rec.records_markers());
        assert!(rec.follow(wanted(true)).is_empty(), "already recording");
        rec.record(
            Payload::request::<crate::kind::Candidates>(Default::default()),
            1,
            1,
        );
        match &rec.follow(wanted(false))[..] {
            [Change::Closed { written, path }] => {
                assert_eq!(written.requests::<crate::kind::Candidates>(), 1);
                assert_eq!(path, &first);
            }
            other => panic!("expected a closed file, got {other:?}"),
        }
        let second = started(&rec.follow(wanted(true)));
        assert!(rec.stop().is_some() && rec.stop().is_none());
        let third = started(&rec.follow(wanted(true)));
        rec.stop();
        let names: Vec<String> = [&first, &second, &third]
            .iter()
            .map(|p| {
                p.file_name()
                    .expect("a name")
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        assert!(
            names[0].starts_with("grasp_orient_2") && names[0].ends_with(".mcap"),
            "{names:?}"
        );
        assert!(
            names[1] != names[0] && names[2] != names[1] && names[2] != names[0],
            "{names:?}"
        );
        for p in [&first, &second, &third] {
            crate::record::bag::read(p).expect("each file is whole");
        }
    }

    #[test]
    fn two_nodes_in_one_folder_write_two_files() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let wanted = Wanted {
            record: true,
            dir: dir.path(),
            markers: true,
        };
        let mut left = recording("/left/grasp_orient");
        let mut right = recording("/right/grasp_orient");
        let a = started(&left.follow(wanted));
        let b = started(&right.follow(wanted));
        assert!(left.records_markers());
        let name = |p: &Path| {
            p.file_name()
                .expect("a name")
                .to_string_lossy()
                .into_owned()
        };
        assert!(name(&a).starts_with("left__grasp_orient_"), "{a:?}");
        assert!(name(&b).starts_with("right__grasp_orient_"), "{b:?}");
        left.record(
            Payload::request::<crate::kind::Candidates>(Default::default()),
            1,
            1,
        );
        for _ in 0..2 {
            right.record(
                Payload::request::<crate::kind::Candidates>(Default::default()),
                1,
                1,
            );
        }
        let closed = |c: Option<Change>| match c {
            Some(Change::Closed { written, .. }) => written.requests::<crate::kind::Candidates>(),
            other => panic!("{other:?}"),
        };
        assert_eq!((closed(left.stop()), closed(right.stop())), (1, 2));
        assert_eq!(
            crate::record::bag::read(&a)
                .expect("whole")
                .streams
                .candidates
                .requests
                .len(),
            1
        );
        assert_eq!(
            crate::record::bag::read(&b)
                .expect("whole")
                .streams
                .candidates
                .requests
                .len(),
            2
        );
    }

    #[test]
    fn a_failed_start_is_retried_at_the_next_follow() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let blocked = dir.path().join("runs");
        std::fs::write(&blocked, b"x").expect("a file where the folder should be");
        let mut rec = recording("/grasp_orient");
        let wanted = |record| Wanted {
            record,
            dir: &blocked,
            markers: true,
        };
        match &rec.follow(wanted(true))[..] {
            [c @ Change::StartFailed(RecordError::Create { .. })] => {
                assert!(c.is_failure());
                assert!(
                    c.to_string().starts_with("recording is off: cannot create"),
                    "{c}"
                );
            }
            other => panic!("expected a failed start, got {other:?}"),
        }
        assert!(!rec.is_on());
        std::fs::remove_file(&blocked).expect("unblocked");
        assert!(rec.follow(wanted(false)).is_empty());
        started(&rec.follow(wanted(true)));
        assert!(rec.is_on());
        rec.stop();
    }

    #[test]
    fn another_folder_or_other_channels_start_another_file() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        let mut rec = recording("/grasp_orient");
        let first = started(&rec.follow(Wanted {
            record: true,
            dir: &a,
            markers: false,
        }));
        let changes = rec.follow(Wanted {
            record: true,
            dir: &b,
            markers: false,
        });
        assert!(matches!(changes[0], Change::Closed { .. }), "{changes:?}");
        let second = started(&changes);
        assert_eq!(
            (first.parent(), second.parent()),
            (Some(a.as_path()), Some(b.as_path()))
        );
        let changes = rec.follow(Wanted {
            record: true,
            dir: &b,
            markers: true,
        });
        assert_eq!(changes.len(), 2, "{changes:?}");
        assert!(rec.records_markers());
        rec.stop();
    }
}
