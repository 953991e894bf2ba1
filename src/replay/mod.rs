//! Replaying recordings: every recorded candidate is solved again, with the settings in force
//! when it was recorded ([`Plan`]), and compared, field by field, with the recommendation
//! recorded for it; every recorded set likewise (`sets`). Only the fields the recording has are
//! compared: a recording made before a message grew decodes with the new trailing fields at their
//! defaults, which say nothing.

mod compare;
mod plan;
mod poses;
mod sets;

#[cfg(test)]
pub(crate) use compare::differences;
pub(crate) use compare::{compare_one, pair, TOLERANCE};
pub use compare::{Summary, RECORDED_BEHIND_TANGENT};
use plan::objective_like;
pub(crate) use plan::Override;
pub use plan::{Plan, ReplayError};

use crate::answer::Answering;
use crate::kind::{Candidates, Streams};
use crate::msg::{short_id, GraspCandidate, GripRecommendation};
use crate::record::bag::{Bag, Recorded};
use crate::record::channels::RecordedFields;

/// Solves every candidate and every set of `bag` again as `plan` says and compares. The work is
/// shared among the machine's cores; `progress` hears of every 4096 candidates done.
pub fn replay(
    bag: &Bag,
    plan: &Plan,
    progress: impl Fn(u64) + Sync,
) -> Result<Summary, ReplayError> {
    let (mut summary, _) = replay_on_cores(bag, plan, false, &progress)?;
    summary.merge(sets::replay_sets(bag, plan, false).0);
    summary.merge(poses::replay_poses(bag, plan, false)?.0);
    Ok(summary)
}

/// [`replay`], also returning the new answers: each kind's in its stream's `answers`, one per
/// recorded request in the requests' order, each with its request's times.
pub(crate) fn replay_with_answers(
    bag: &Bag,
    plan: &Plan,
    progress: impl Fn(u64) + Sync,
) -> Result<(Summary, Streams), ReplayError> {
    let (mut summary, recommendations) = replay_on_cores(bag, plan, true, &progress)?;
    let (of_sets, sets) = sets::replay_sets(bag, plan, true);
    summary.merge(of_sets);
    let (of_poses, poses) = poses::replay_poses(bag, plan, true)?;
    summary.merge(of_poses);
    let mut answers = Streams::default();
    answers.candidates.answers = recommendations;
    answers.sets.answers = sets;
    answers.poses.answers = poses.recommendations;
    answers.pose_sets.answers = poses.sets;
    Ok((summary, answers))
}

/// One share of the candidates per core; the answers are kept only when asked for, since a
/// replay of millions of candidates need not hold them all. A share that fails fails the
/// replay: its counts and answers must not silently go missing.
fn replay_on_cores(
    bag: &Bag,
    plan: &Plan,
    keep: bool,
    progress: &(impl Fn(u64) + Sync),
) -> Result<(Summary, Vec<Recorded<GripRecommendation>>), ReplayError> {
    let (pairs, unmatched) = pair(&bag.streams.candidates);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = bag
        .streams
        .candidates
        .requests
        .len()
        .div_ceil(threads)
        .max(1);
    type Part = (Vec<Recorded<GripRecommendation>>, Summary);
    let parts: Result<Vec<Part>, ReplayError> = std::thread::scope(|scope| {
        let handles: Vec<_> = bag
            .streams
            .candidates
            .requests
            .chunks(chunk)
            .zip(pairs.chunks(chunk))
            .map(|(cands, pairs)| {
                scope.spawn(move || {
                    let mut part = Summary::default();
                    let mut answers = Vec::with_capacity(if keep { cands.len() } else { 0 });
                    for (k, (c, p)) in cands.iter().zip(pairs).enumerate() {
                        let theirs = p.map(|i| &bag.streams.candidates.answers[i].message);
                        let with = plan.answering_at(c.log_time);
                        let from_answer = plan.objective_from_answer;
                        let ours = check(
                            &c.message,
                            with,
                            from_answer,
                            theirs,
                            &bag.fields,
                            &mut part,
                        );
                        if keep {
                            answers.push(Recorded {
                                message: ours,
                                log_time: c.log_time,
                                publish_time: c.publish_time,
                            });
                        }
                        if (k + 1) % 4096 == 0 {
                            progress(4096);
                        }
                    }
                    (answers, part)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .map_err(|e| ReplayError::Worker(panic_words(e.as_ref())))
            })
            .collect()
    });
    let parts = parts?;
    let mut summary = Summary {
        unmatched_recommendations: unmatched,
        ..Summary::default()
    };
    let mut answers = Vec::with_capacity(if keep {
        bag.streams.candidates.requests.len()
    } else {
        0
    });
    for (a, part) in parts {
        answers.extend(a);
        summary.merge(part);
    }
    Ok((summary, answers))
}

/// What a panicking thread said.
fn panic_words(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "it panicked".to_string())
}

/// Solves one candidate again and compares it with its recorded answer, if any.
fn check(
    candidate: &GraspCandidate,
    with: &Answering,
    objective_from_answer: bool,
    theirs: Option<&GripRecommendation>,
    fields: &RecordedFields,
    summary: &mut Summary,
) -> GripRecommendation {
    summary.candidates += 1;
    let recorded = theirs.filter(|_| objective_from_answer);
    let ours = solve_like(candidate, with, recorded);
    if let Some(theirs) = theirs {
        let label = || format!("candidate {:?}", short_id(&candidate.id));
        compare_one(label, &ours, theirs, fields, summary);
    }
    ours
}

/// Answers `with` its settings and rules, and with the objective `recorded` names, if given.
fn solve_like(
    candidate: &GraspCandidate,
    with: &Answering,
    recorded: Option<&GripRecommendation>,
) -> GripRecommendation {
    match recorded {
        None => with.answer::<Candidates>(candidate),
        Some(r) => with
            .with_settings(objective_like(with.settings(), Some(r)))
            .answer::<Candidates>(candidate),
    }
}

#[cfg(test)]
mod tests {
    use super::compare::answered_behind_tangent;
    use super::*;
    use crate::answer::answer;
    use crate::record::settings::METADATA_NAME;
    use crate::solver::Settings;
    use serde_yaml_ng::Value;

    #[test]
    fn equal_answers_have_no_differences_and_changed_ones_are_named() {
        let c = crate::msg::paper_cases().swap_remove(0);
        let a = answer(&c, &Settings::default());
        assert!(differences(&a, &a.clone()).is_empty());
        let mut b = a.clone();
        b.gripping_power *= 1.0 + 1e-6;
        b.local_minima_labels[0] = "X".into();
        let d = differences(&a, &b);
        assert!(d
            .iter()
            .any(|(f, g)| *f == "gripping_power" && *g > TOLERANCE));
        assert!(d.iter().any(|(f, _)| *f == "local_minima_labels"));
        let nan = answer(&GraspCandidate::default(), &Settings::default());
        assert!(
            differences(&nan, &nan.clone()).is_empty(),
            "NaN equals NaN here"
        );
    }

    /// `docs/recordings.md`, *Refusals answered now*: a recorded refusal of an inline mesh
    /// beyond `max_inline_mesh_triangles` in 0.1.0's words (with the mesh's count) is today's
    /// refusal under the same bound, and not one under another bound nor other words.
    #[test]
    fn a_recorded_inline_refusal_in_older_words_is_todays_under_the_same_bound() {
        let m = GraspCandidate {
            id: "inline".into(),
            ..GraspCandidate::default()
        };
        let refusal = |why: &str| crate::msg::convert::invalid(&m, &why);
        let fields = RecordedFields::default();
        let pairs = [
            (
                "object.inline_mesh has more triangles than max_inline_mesh_triangles (200); send a coarser mesh",
                "object.inline_mesh has 220 triangles, more than max_inline_mesh_triangles (200); send a coarser mesh",
                false,
            ),
            (
                "object.inline_mesh has more vertices than 3 x max_inline_mesh_triangles (600)",
                "object.inline_mesh has 5000000 vertices, more than 3 x max_inline_mesh_triangles (600)",
                false,
            ),
            (
                "object.inline_mesh has more triangles than max_inline_mesh_triangles (200); send a coarser mesh",
                "object.inline_mesh has 220 triangles, more than max_inline_mesh_triangles (300); send a coarser mesh",
                true,
            ),
            (
                "object.inline_mesh has more triangles than max_inline_mesh_triangles (200); send a coarser mesh",
                "object.inline_mesh has 220 vertices, more than max_inline_mesh_triangles (200); send a coarser mesh",
                true,
            ),
            (
                "object.inline_mesh has more triangles than max_inline_mesh_triangles (200); send a coarser mesh",
                "object.inline_mesh has many triangles, more than max_inline_mesh_triangles (200); send a coarser mesh",
                true,
            ),
        ];
        for (today, recorded, differs) in pairs {
            let mut summary = Summary::default();
            let (ours, theirs) = (refusal(today), refusal(recorded));
            assert_eq!(
                compare_one(String::new, &ours, &theirs, &fields, &mut summary),
                differs,
                "{recorded}"
            );
            assert_eq!(summary.differing, u64::from(differs));
        }
    }

    /// `docs/recordings.md`, *Refusals answered now*: today's answer stands for exactly the
    /// recorded refusal of a centre of mass behind a tangent, and for nothing else.
    #[test]
    fn a_recorded_behind_tangent_refusal_accepts_only_todays_answer() {
        let mut m = crate::msg::paper_cases().swap_remove(2);
        let (p1, n1) = (m.contact_1.clone(), m.normal_1.clone());
        m.center_of_mass.x = p1.x - 0.5 * n1.x + 0.3 * n1.y;
        m.center_of_mass.y = p1.y - 0.5 * n1.y - 0.3 * n1.x;
        let ours = answer(&m, &Settings::default());
        assert_eq!(
            ours.status,
            GripRecommendation::STATUS_OK,
            "{}",
            ours.message
        );
        let refusal = |contact: &str| {
            let mut r = crate::msg::convert::invalid(
                &m,
                &format!("center_of_mass lies outside the object: behind the surface tangent at {contact}"),
            );
            r.objective = "norm2".into();
            r
        };
        let theirs = refusal("contact_1");
        assert!(answered_behind_tangent(&ours, &theirs));
        let mut summary = Summary::default();
        let fields = RecordedFields::default();
        assert!(!compare_one(
            String::new,
            &ours,
            &theirs,
            &fields,
            &mut summary
        ));
        assert_eq!((summary.compared, summary.differing), (1, 0));
        assert_eq!(summary.answered_behind_tangent, 1);
        // The other contact, another status, other words, a refusal today, another candidate or
        // objective: differences as ever.
        assert!(!answered_behind_tangent(&ours, &refusal("contact_2")));
        let mut other = theirs.clone();
        other.status = GripRecommendation::STATUS_NO_FORCE_CLOSURE;
        assert!(!answered_behind_tangent(&ours, &other));
        let mut other = theirs.clone();
        other.message = other.message.replace("lies outside", "is outside").into();
        assert!(!answered_behind_tangent(&ours, &other));
        assert!(!answered_behind_tangent(&theirs, &theirs));
        let mut other = theirs.clone();
        other.candidate_id = "another".into();
        assert!(!answered_behind_tangent(&ours, &other));
        let mut other = theirs.clone();
        other.objective = "norm1".into();
        assert!(!answered_behind_tangent(&ours, &other));
        assert!(compare_one(
            String::new,
            &ours,
            &other,
            &fields,
            &mut summary
        ));
        assert_eq!(summary.differing, 1);
        // Without the note (an answer for another reason), it is a difference too.
        let mut plain = ours.clone();
        plain.message = "".into();
        assert!(!answered_behind_tangent(&plain, &theirs));
    }

    /// Every kind through replay's one path: a recording holding, of each kind, a request and
    /// the answer `Answering` gives it replays with every answer paired and compared and none
    /// differing; with each answer replaced by another (`Default`), each kind's answer differs.
    #[test]
    fn every_kind_replays_through_its_pair_and_answer() {
        use crate::answer::{each, Answer, VisitAnswer};
        struct Fill(Bag, bool);
        impl VisitAnswer for Fill {
            fn kind<K: Answer>(&mut self) {
                let request = K::Request::default();
                let answer = if self.1 {
                    Answering::from_env().answer::<K>(&request)
                } else {
                    K::Answer::default()
                };
                fn at<T>(message: T) -> Recorded<T> {
                    Recorded {
                        message,
                        log_time: 10,
                        publish_time: 10,
                    }
                }
                let stream = K::stream_mut(&mut self.0.streams);
                stream.requests.push(at(request));
                stream.answers.push(at(answer));
            }
        }
        let replayed = |answered: bool| {
            let mut fill = Fill(Bag::default(), answered);
            each(&mut fill);
            let plan = Plan::fixed(Settings::default());
            replay(&fill.0, &plan, |_| {}).expect("replays")
        };
        let same = replayed(true);
        assert_eq!(
            (
                same.candidates,
                same.pose_candidates,
                same.sets,
                same.pose_sets
            ),
            (2, 1, 2, 1),
            "one candidate and one pose candidate, one set and one pose set: {same:?}"
        );
        assert_eq!((same.compared, same.sets_compared), (2, 2), "{same:?}");
        assert_eq!((same.differing, same.sets_differing), (0, 0), "{same:?}");
        assert_eq!(
            (same.unmatched_recommendations, same.unmatched_set_answers),
            (0, 0)
        );
        let other = replayed(false);
        assert_eq!((other.compared, other.sets_compared), (2, 2), "{other:?}");
        assert_eq!((other.differing, other.sets_differing), (2, 2), "{other:?}");
    }

    #[test]
    fn a_failing_worker_fails_the_replay() {
        let cases = crate::msg::paper_cases();
        let mut bag = Bag::default();
        bag.streams.candidates.requests = (0..8192)
            .map(|i| Recorded {
                message: cases[i % 4].clone(),
                log_time: i as u64,
                publish_time: i as u64,
            })
            .collect();
        let plan = Plan::fixed(Settings::default());
        let calls = std::sync::atomic::AtomicU64::new(0);
        let result = replay_with_answers(&bag, &plan, |_| {
            if calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst) == 0 {
                panic!("a worker fails");
            }
        });
        match result {
            Err(ReplayError::Worker(why)) => assert_eq!(why, "a worker fails"),
            Err(e) => panic!("expected a worker failure, got {e}"),
            Ok((summary, answers)) => panic!(
                "a failed worker went unnoticed: {} candidates, {} answers",
                summary.candidates,
                answers.candidates.answers.len()
            ),
        }
        let (summary, answers) = replay_with_answers(&bag, &plan, |_| {}).expect("replays");
        assert_eq!(
            (summary.candidates, answers.candidates.answers.len()),
            (8192, 8192)
        );
    }

    #[test]
    fn each_candidate_gets_the_settings_in_force_at_its_time() {
        use crate::config::Config;
        use crate::record::settings::SettingsRecord;
        let record = |since, fsf| {
            let config = Config {
                friction_safety_factor: fsf,
                ..Config::default()
            };
            let entries = SettingsRecord {
                since,
                node: "/grasp_orient".into(),
                reason: "test".into(),
                config,
            }
            .to_metadata();
            (METADATA_NAME.to_string(), entries)
        };
        let bag = Bag {
            // In file order the later record comes first: time decides, not position.
            metadata: vec![record(100, 2.0), record(0, 1.5)],
            ..Bag::default()
        };
        let plan = Plan::for_bag(&bag, &Config::default(), &[]).expect("a plan");
        assert!(plan.settings_recorded());
        assert_eq!(plan.answering_at(0).settings().friction_safety_factor, 1.5);
        assert_eq!(plan.answering_at(99).settings().friction_safety_factor, 1.5);
        assert_eq!(
            plan.answering_at(100).settings().friction_safety_factor,
            2.0
        );
        assert_eq!(
            plan.answering_at(u64::MAX)
                .settings()
                .friction_safety_factor,
            2.0
        );
        let overrides = [(
            "friction_safety_factor".to_string(),
            Value::Number(1.25.into()),
        )];
        let plan = Plan::for_bag(&bag, &Config::default(), &overrides).expect("a plan");
        assert_eq!(plan.answering_at(0).settings().friction_safety_factor, 1.25);
        assert_eq!(
            plan.answering_at(200).settings().friction_safety_factor,
            1.25
        );
        assert_eq!(plan.overridden, ["friction_safety_factor"]);
        let plan = Plan::for_bag(&Bag::default(), &Config::default(), &[]).expect("a plan");
        assert!(!plan.settings_recorded());
        assert_eq!(*plan.answering_at(5).settings(), Settings::default());
    }
}
