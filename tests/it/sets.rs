//! Sets of candidates as a user meets them without DDS: `rank` (table and JSON), `solve` with the
//! gripper's limit, and recordings of sets written, replayed, tampered with and rewritten.

use crate::util::run::{bin, json_lines, paper_lines, paper_messages, run_fed, temp_dir};
use grasp_orient::answer::Rules;
use grasp_orient::msg::{GraspCandidateSet, GripRecommendation, GripRecommendationSet};
use grasp_orient::record::{bag, BagWriter, Entry, Payload, Topics};
use grasp_orient::solver::Settings;
use std::path::Path;
use std::process::Output;

/// Runs the binary with `input` on standard input.
fn run(args: &[&str], input: &str) -> Output {
    let mut cmd = bin();
    cmd.args(args);
    // A binary that exits before reading its input (a refused argument, a crash) closes the pipe:
    // the write then fails, and what the binary said is the better report, so it is returned for
    // the caller to judge (a refused `--rank-by` may or may not have exited before the write).
    let (out, written) = run_fed(cmd, input);
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => panic!(
            "writing to `grasp_orient {}` failed ({e}); it exited with {:?}: {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ),
        _ => out,
    }
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn rank_json_holds_solves_answers_and_a_sorted_ranking() {
    let mut input = paper_lines();
    input.push_str("not a candidate\n");
    let solved = json_lines(&run(&["solve"], &input));
    let out = run(&["rank", "--json"], &input);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let set = &json_lines(&out)[0];
    let recs = set["recommendations"].as_array().expect("a list");
    assert_eq!(
        recs, &solved,
        "each answer of the set is solve's answer to the line"
    );
    assert_eq!(set["ranked_by"], "internal_force");
    assert_eq!(set["status"], 0);
    let ranking: Vec<usize> = set["ranking"]
        .as_array()
        .expect("a list")
        .iter()
        .map(|v| v.as_u64().expect("an index") as usize)
        .collect();
    assert_eq!(ranking.len(), 4, "the bad line is left out");
    let forces: Vec<f64> = ranking
        .iter()
        .map(|&i| recs[i]["internal_force"].as_f64().expect("a number"))
        .collect();
    assert!(forces.windows(2).all(|w| w[0] <= w[1]), "{forces:?}");
}

#[test]
fn rank_options_pick_the_force_the_limit_and_the_order() {
    let input = paper_lines();
    let free = json_lines(&run(
        &["rank", "--json", "--gripper-drive", "independent"],
        &input,
    ));
    let recs = free[0]["recommendations"]
        .as_array()
        .expect("a list")
        .clone();
    assert_eq!(free[0]["ranked_by"], "finger_force");
    let mut fingers: Vec<f64> = recs
        .iter()
        .map(|r| r["finger_force"].as_f64().expect("a number"))
        .collect();
    fingers.sort_by(f64::total_cmp);
    let limit = format!("{}", 0.5 * (fingers[1] + fingers[2]));
    let args = [
        "rank",
        "--json",
        "--gripper-drive",
        "independent",
        "--max-grip-force",
        &limit,
    ];
    let limited = &json_lines(&run(&args, &input))[0];
    assert_eq!(limited["ranking"].as_array().map(Vec::len), Some(2));
    let statuses: Vec<u64> = limited["recommendations"]
        .as_array()
        .expect("a list")
        .iter()
        .map(|r| r["status"].as_u64().expect("a status"))
        .collect();
    assert_eq!(
        statuses.iter().filter(|s| **s == 3).count(),
        2,
        "{statuses:?}"
    );
    let by_power = &json_lines(&run(&["rank", "--json", "--rank-by", "objective"], &input))[0];
    assert_eq!(by_power["ranked_by"], "gripping_power");
    // The table says the same, one row per candidate, the limited ones unranked.
    let table = stdout(&run(
        &args[..1]
            .iter()
            .chain(&args[2..])
            .copied()
            .collect::<Vec<_>>(),
        &input,
    ));
    assert!(table.contains("2 ranked by finger_force"), "{table}");
    assert_eq!(table.matches("exceeds gripper").count(), 2, "{table}");
    assert_eq!(table.lines().count(), 6, "{table}");
    let bad = run(&["rank", "--rank-by", "cheapest"], &input);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--rank-by"));
}

#[test]
fn rank_refuses_a_set_larger_than_max_set_size() {
    let out = run(&["rank", "--max-set-size", "3"], &paper_lines());
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("4 candidates, more than max_set_size 3"),
        "{err}"
    );
    let out = run(&["rank", "--json"], "");
    let empty = &json_lines(&out)[0];
    assert!(out.status.success());
    assert_eq!(empty["recommendations"], serde_json::json!([]));
}

#[test]
fn solve_gives_status_3_over_max_grip_force() {
    let out = json_lines(&run(&["solve", "--max-grip-force", "0.47"], &paper_lines()));
    let statuses: Vec<u64> = out
        .iter()
        .map(|r| r["status"].as_u64().expect("a status"))
        .collect();
    // Coupled grip forces of the paper's cases: 1.294, 1.601, 0.483, 0.462 N.
    assert_eq!(statuses, [3, 3, 3, 0]);
    assert!(out[0]["message"]
        .as_str()
        .is_some_and(|m| m.contains("more than max_grip_force 0.47 N")));
    assert!(
        out[0]["gripping_power"].as_f64().is_some(),
        "every field still filled"
    );
}

/// JSON written before the grip force fields still reads: absent fields take their defaults.
#[test]
fn json_without_the_new_fields_reads_with_defaults() {
    let solved = json_lines(&run(&["solve"], &paper_lines()));
    let mut old = solved[0].clone();
    let map = old.as_object_mut().expect("an object");
    map.remove("finger_force");
    map.remove("finger_force_current");
    let r: GripRecommendation = serde_json::from_value(old).expect("reads");
    assert_eq!((r.finger_force, r.finger_force_current), (0.0, 0.0));
    let set: GraspCandidateSet = serde_json::from_str(r#"{"id": "s"}"#).expect("reads");
    assert!(set.candidates.is_empty() && set.max_grip_force == 0.0);
}

fn topics() -> Topics {
    Topics::new("/grasp_candidates", "/grip_recommendations")
        .with::<grasp_orient::kind::Sets>("/grasp_candidate_sets", "/grip_recommendation_sets")
}

/// A recording of three sets and their answers, `edit` applied to the answers first.
fn write_sets(path: &Path, edit: impl Fn(usize, &mut GripRecommendationSet)) {
    write_these_sets(path, three_sets(), edit);
}

/// Three sets: the paper's cases, the same with a bad one and a limit, and an empty one.
fn three_sets() -> Vec<GraspCandidateSet> {
    let mut cases = paper_messages();
    cases[1].mass = f64::NAN;
    vec![
        GraspCandidateSet {
            id: "all".into(),
            candidates: paper_messages(),
            ..GraspCandidateSet::default()
        },
        GraspCandidateSet {
            id: "with a bad one".into(),
            candidates: cases,
            max_grip_force: 1.0,
            ..GraspCandidateSet::default()
        },
        GraspCandidateSet {
            id: "empty".into(),
            ..GraspCandidateSet::default()
        },
    ]
}

/// A recording of `sets` and their answers as the writer of the node records them, `edit`
/// applied to the answers first.
fn write_these_sets(
    path: &Path,
    sets: Vec<GraspCandidateSet>,
    edit: impl Fn(usize, &mut GripRecommendationSet),
) {
    let mut w = BagWriter::create(path, &topics(), 100).expect("create");
    let n = sets.len() as u64;
    for (k, set) in sets.into_iter().enumerate() {
        let mut answer = crate::util::answering(&Settings::default(), &Rules::default())
            .answer::<grasp_orient::kind::Sets>(&set);
        edit(k, &mut answer);
        let t = 1_000 * (k as u64 + 1);
        w.write(&Entry {
            payload: Payload::request::<grasp_orient::kind::Sets>(set),
            log_time: t,
            publish_time: t - 1,
        })
        .expect("write");
        w.write(&Entry {
            payload: Payload::answer::<grasp_orient::kind::Sets>(answer),
            log_time: t + 1,
            publish_time: t + 1,
        })
        .expect("write");
    }
    let written = w.finish().expect("finish");
    assert_eq!(
        (
            written.requests::<grasp_orient::kind::Sets>(),
            written.answers::<grasp_orient::kind::Sets>()
        ),
        (n, n)
    );
}

fn replay(path: &Path) -> (bool, String) {
    let out = bin()
        .args(["replay", path.to_str().expect("utf-8")])
        .output()
        .expect("runs");
    (
        out.status.success(),
        stdout(&out) + &String::from_utf8_lossy(&out.stderr),
    )
}

#[test]
fn recorded_sets_read_back_and_replay_unchanged() {
    let dir = temp_dir("sets");
    let path = dir.path().join("sets.mcap");
    write_sets(&path, |_, _| {});
    let b = bag::read(&path).expect("reads");
    assert_eq!(
        (b.streams.sets.requests.len(), b.streams.sets.answers.len()),
        (3, 3)
    );
    assert!(b.fields.missing::<GripRecommendation>().is_empty());
    let (ok, text) = replay(&path);
    assert!(ok, "{text}");
    assert!(text.contains("replayed 3 sets (their candidates counted above): 3 compared with a recorded answer, 0 differ, 0 recorded set answers unmatched"), "{text}");
    assert!(text.contains("replayed 8 candidates"), "{text}");
    // replay --write: the sets and fresh answers, which replay again.
    let fresh = dir.path().join("fresh.mcap");
    let out = bin()
        .args([
            "replay",
            path.to_str().expect("utf-8"),
            "--write",
            fresh.to_str().expect("utf-8"),
        ])
        .output()
        .expect("runs");
    assert!(out.status.success());
    assert!(
        stdout(&out).contains("3 candidate sets and 3 set answers"),
        "{}",
        stdout(&out)
    );
    assert!(replay(&fresh).0);
}

#[test]
fn a_changed_member_a_changed_ranking_or_status_fails_the_replay() {
    let dir = temp_dir("sets_tampered");
    let member = dir.path().join("member.mcap");
    write_sets(&member, |k, a| {
        if k == 0 {
            a.recommendations[2].finger_force *= 1.0 + 1e-6;
        }
    });
    let (ok, text) = replay(&member);
    assert!(!ok, "{text}");
    assert!(
        text.contains("finger_force") && text.contains("paper-c"),
        "{text}"
    );
    let ranking = dir.path().join("ranking.mcap");
    write_sets(&ranking, |k, a| {
        if k == 0 {
            a.ranking.swap(0, 3);
        }
    });
    let (ok, text) = replay(&ranking);
    assert!(!ok, "{text}");
    assert!(text.contains("set \"all\": ranking"), "{text}");
    let limit = dir.path().join("limit.mcap");
    write_sets(&limit, |k, a| {
        if k == 1 {
            // As if the set's own max_grip_force had been ignored.
            for r in &mut a.recommendations {
                if r.status == GripRecommendation::STATUS_EXCEEDS_GRIPPER {
                    r.status = GripRecommendation::STATUS_OK;
                    r.message.clear();
                }
            }
        }
    });
    let (ok, text) = replay(&limit);
    assert!(!ok, "{text}");
    assert!(text.contains("status"), "{text}");
}

/// Sets the node refuses as a whole: too large, a negative `max_grip_force`, an id over the
/// limit; with the three ordinary ones.
fn with_refused_sets() -> Vec<GraspCandidateSet> {
    let mut sets = three_sets();
    let too_large = GraspCandidateSet {
        id: "too large".into(),
        candidates: (0..Rules::default().max_set_size + 1)
            .map(|k| paper_messages()[k % 4].clone())
            .collect(),
        ..GraspCandidateSet::default()
    };
    let negative = GraspCandidateSet {
        id: "negative limit".into(),
        candidates: paper_messages(),
        max_grip_force: -1.0,
        ..GraspCandidateSet::default()
    };
    let long_id = GraspCandidateSet {
        id: "x".repeat(2000).into(),
        candidates: paper_messages(),
        ..GraspCandidateSet::default()
    };
    sets.extend([too_large, negative, long_id]);
    sets
}

#[test]
fn sets_refused_as_a_whole_replay_and_their_refusal_is_compared() {
    let dir = temp_dir("refused_sets");
    let path = dir.path().join("refused.mcap");
    write_these_sets(&path, with_refused_sets(), |_, _| {});
    let recorded = bag::read(&path).expect("reads");
    let refused = recorded.streams.sets.answers[3..]
        .iter()
        .filter(|s| s.message.status != GripRecommendationSet::STATUS_OK)
        .count();
    assert_eq!(refused, 3, "the three are refused as a whole");
    let (ok, text) = replay(&path);
    assert!(ok, "{text}");
    assert!(text.contains("0 differ"), "{text}");
    // replay --write's own output replays too.
    let fresh = dir.path().join("fresh.mcap");
    let out = bin()
        .args(["replay", path.to_str().expect("utf-8")])
        .args(["--write", fresh.to_str().expect("utf-8")])
        .output()
        .expect("runs");
    assert!(out.status.success(), "{}", stdout(&out));
    let (ok, text) = replay(&fresh);
    assert!(ok, "{text}");
    // A refusal recorded with other words, or another status, is a difference.
    let worded = dir.path().join("worded.mcap");
    write_these_sets(&worded, with_refused_sets(), |k, a| {
        if k == 4 {
            a.message.push_str(" (changed)");
        }
    });
    let (ok, text) = replay(&worded);
    assert!(!ok, "{text}");
    assert!(text.contains("set message"), "{text}");
    let status = dir.path().join("status.mcap");
    write_these_sets(&status, with_refused_sets(), |k, a| {
        if k == 3 {
            a.status = GripRecommendationSet::STATUS_INVALID_INPUT;
        }
    });
    let (ok, text) = replay(&status);
    assert!(!ok, "{text}");
    assert!(text.contains("set status"), "{text}");
}

#[test]
fn a_set_member_answering_another_candidate_fails_the_replay() {
    let dir = temp_dir("sets_members");
    type Edit = fn(&mut GripRecommendation);
    let edits: [(&str, Edit); 3] = [
        ("candidate_id", |r| r.candidate_id = "paper-x".into()),
        ("header.frame_id", |r| {
            r.header.frame_id = "elsewhere".into()
        }),
        ("header.stamp", |r| r.header.stamp.nanosec += 1),
    ];
    for (field, edit) in edits {
        let path = dir.path().join(format!("{field}.mcap"));
        write_sets(&path, |k, a| {
            if k == 0 {
                edit(&mut a.recommendations[1]);
            }
        });
        let (ok, text) = replay(&path);
        assert!(!ok, "{field}: {text}");
        assert!(
            text.contains(field) && text.contains("paper-b"),
            "{field}: {text}"
        );
    }
}

/// A set the node refused as busy (its queue full) and one whose time ran out before any member
/// was solved, as the node answers them: replay compares what was solved, and passes.
#[test]
fn busy_and_cut_sets_replay_as_recorded() {
    use grasp_orient::answer::{busy, Halt, Interrupt};
    let dir = temp_dir("busy_sets");
    let path = dir.path().join("busy.mcap");
    let sets = three_sets();
    let (first, second) = (sets[0].clone(), sets[1].clone());
    write_these_sets(&path, sets, |k, a| {
        let rules = Rules::default();
        if k == 0 {
            *a = busy(&first, &rules, 16);
        } else if k == 1 {
            let late = Interrupt::default();
            late.raise(Halt::OutOfTime);
            *a = crate::util::answering(&Settings::default(), &rules)
                .set_within(&second, None, &late, 0.5);
        }
    });
    let recorded = bag::read(&path).expect("reads");
    let statuses: Vec<u8> = recorded
        .streams
        .sets
        .answers
        .iter()
        .map(|s| s.message.status)
        .collect();
    assert_eq!(
        statuses[..2],
        [
            GripRecommendationSet::STATUS_BUSY,
            GripRecommendationSet::STATUS_INCOMPLETE
        ]
    );
    let (ok, text) = replay(&path);
    assert!(ok, "{text}");
    assert!(text.contains("0 differ"), "{text}");
}
