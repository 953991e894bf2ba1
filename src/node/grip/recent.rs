//! The answers `~/grip` can send: the last [`KEPT`] the node gave, by `candidate_id`.

use crate::answer::GripperDrive;
use crate::msg::{clip, CompactString, GripRecommendation};
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Mutex};

/// How many answers are kept (single candidates, pose candidates and each member of a set, in
/// the order they were sent): some 200 bytes each. A later answer with the same id replaces the
/// earlier one.
pub(crate) const KEPT: usize = 1024;

/// What `~/grip` needs of one answer.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Kept {
    /// The answer's status.
    pub(crate) status: u8,
    /// Its message (clipped).
    pub(crate) message: String,
    /// N, its `internal_force`.
    pub(crate) internal_force: f64,
    /// N, its `finger_force`.
    pub(crate) finger_force: f64,
}

impl Kept {
    /// The grip force `drive` picks, N.
    pub(crate) fn grip_force(&self, drive: GripperDrive) -> f64 {
        let r = GripRecommendation {
            internal_force: self.internal_force,
            finger_force: self.finger_force,
            ..GripRecommendation::default()
        };
        drive.grip_force(&r)
    }
}

/// The last [`KEPT`] answers, shared by the answering loop (which notes them as they are sent)
/// and `~/grip` (which reads them).
#[derive(Debug, Clone, Default)]
pub(crate) struct Recent(Arc<Mutex<Table>>);

#[derive(Debug, Default)]
struct Table {
    /// Each id's newest answer and its number.
    by_id: HashMap<CompactString, (u64, Kept)>,
    /// Every answer's number and id, oldest first; an entry whose number is not its id's in
    /// `by_id` was replaced by a later answer.
    order: VecDeque<(u64, CompactString)>,
    /// Answers noted so far.
    seq: u64,
}

impl Recent {
    /// Notes an answer as sent (one with an empty id cannot be asked for, and is not kept).
    pub(crate) fn note(&self, r: &GripRecommendation) {
        if r.candidate_id.is_empty() {
            return;
        }
        let kept = Kept {
            status: r.status,
            message: clip(&r.message).to_string(),
            internal_force: r.internal_force,
            finger_force: r.finger_force,
        };
        let mut t = self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        t.seq += 1;
        let seq = t.seq;
        t.by_id.insert(r.candidate_id.clone(), (seq, kept));
        t.order.push_back((seq, r.candidate_id.clone()));
        while t.order.len() > KEPT {
            let Some((old, id)) = t.order.pop_front() else {
                break;
            };
            if t.by_id.get(&id).is_some_and(|(n, _)| *n == old) {
                t.by_id.remove(&id);
            }
        }
    }

    /// Notes every answer of `answers`.
    pub(crate) fn note_all<'a>(&self, answers: impl IntoIterator<Item = &'a GripRecommendation>) {
        for r in answers {
            self.note(r);
        }
    }

    /// The newest kept answer to `id`.
    pub(crate) fn get(&self, id: &str) -> Option<Kept> {
        let t = self
            .0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        t.by_id.get(id).map(|(_, k)| k.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn answer(id: &str, force: f64) -> GripRecommendation {
        GripRecommendation {
            candidate_id: id.into(),
            internal_force: force,
            finger_force: 2.0 * force,
            ..GripRecommendation::default()
        }
    }

    #[test]
    fn keeps_the_last_answers_and_the_newest_of_an_id() {
        let recent = Recent::default();
        for i in 0..KEPT + 10 {
            recent.note(&answer(&format!("g{i}"), i as f64));
        }
        assert!(recent.get("g9").is_none(), "the oldest went");
        assert_eq!(
            recent.get("g10").map(|k| k.internal_force),
            Some(10.0),
            "the oldest kept"
        );
        recent.note(&answer("g10", 99.0));
        let k = recent.get("g10").expect("kept");
        assert_eq!(k.grip_force(GripperDrive::Coupled), 99.0);
        assert_eq!(k.grip_force(GripperDrive::Independent), 198.0);
        // The replaced entry's place in the order does not evict the new one.
        for i in 0..KEPT - 1 {
            recent.note(&answer(&format!("h{i}"), 1.0));
        }
        assert_eq!(recent.get("g10").map(|k| k.internal_force), Some(99.0));
        recent.note(&answer("h-last", 1.0));
        assert!(recent.get("g10").is_none());
        let t = recent.0.lock().expect("lock");
        assert!(t.by_id.len() <= KEPT && t.order.len() <= KEPT);
    }

    #[test]
    fn an_empty_id_is_not_kept() {
        let recent = Recent::default();
        recent.note(&answer("", 1.0));
        assert!(recent.get("").is_none());
    }
}
