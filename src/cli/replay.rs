//! `grasp_orient replay BAG...`: re-solve every recorded candidate and compare with the
//! recorded recommendations; non-zero exit on any difference beyond tolerance.

use super::SolveOptions;
use anyhow::{bail, Context};
use grasp_orient::msg::{GraspCandidate, GraspCandidateSet, GripRecommendation, RosMessage};
use grasp_orient::record::bag;
use grasp_orient::record::{BagWriter, Entry, Payload, SetTopics, Topics};
use grasp_orient::replay::{replay, replay_with_answers, Answers, Summary, TOLERANCE};
use grasp_orient::sets::Rules;
use grasp_orient::solver::Settings;
use std::path::{Path, PathBuf};

/// Arguments of `replay`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// MCAP files (ours, or any rosbag2 MCAP with a grasp_orient/msg/GraspCandidate topic).
    #[arg(required = true)]
    pub bags: Vec<PathBuf>,
    /// Also write a fresh recording of the replay: the candidates and the new recommendations.
    #[arg(long, value_name = "OUT.mcap")]
    pub write: Option<PathBuf>,
    #[command(flatten)]
    pub options: SolveOptions,
}

/// Replays every bag and prints a summary.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (_, settings, rules) = args.options.configured()?;
    let started = std::time::Instant::now();
    let mut summary = Summary::default();
    let mut writer = args.write.as_deref().map(create_writer).transpose()?;
    for path in &args.bags {
        summary.merge(replay_file(path, &settings, &rules, writer.as_mut())?);
    }
    if let (Some(w), Some(path)) = (writer, &args.write) {
        let written = w.finish()?;
        println!(
            "wrote {} candidates, {} recommendations, {} candidate sets and {} set answers to {}",
            written.candidates,
            written.recommendations,
            written.candidate_sets,
            written.recommendation_sets,
            path.display()
        );
    }
    report(&summary, started.elapsed().as_secs_f64())
}

/// The recording `--write` makes.
fn create_writer(path: &Path) -> anyhow::Result<BagWriter> {
    let topics = Topics {
        candidates: "/grasp_candidates".into(),
        recommendations: "/grip_recommendations".into(),
        markers: None,
        sets: Some(SetTopics::default_names()),
    };
    BagWriter::create(path, &topics, 100)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Replays one bag, writing its candidates and the new answers to `writer` if given.
fn replay_file(
    path: &Path,
    settings: &Settings,
    rules: &Rules,
    writer: Option<&mut BagWriter>,
) -> anyhow::Result<Summary> {
    let bag = bag::read(path)?;
    if bag.candidates.is_empty() && bag.candidate_sets.is_empty() {
        bail!(
            "{}: no {} or {} messages (cdr) in it",
            path.display(),
            GraspCandidate::TYPE_NAME,
            GraspCandidateSet::TYPE_NAME
        );
    }
    let missing = bag.fields.missing::<GripRecommendation>();
    if !missing.is_empty() {
        println!(
            "{}: recorded before {} were added to {}: not compared",
            path.display(),
            missing.join(", "),
            GripRecommendation::TYPE_NAME
        );
    }
    if bag.undecodable_count > 0 {
        log::warn!(
            "{}: {} messages did not decode, e.g. {}",
            path.display(),
            bag.undecodable_count,
            bag.undecodable.first().map_or("", String::as_str)
        );
    }
    let bar = indicatif::ProgressBar::new(bag.candidates.len() as u64);
    if bag.candidates.len() < 100_000 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let progress = |n| bar.inc(n);
    let summary = match writer {
        Some(w) => {
            let (summary, answers) = replay_with_answers(&bag, settings, rules, progress);
            write_answers(w, &bag, answers)?;
            summary
        }
        None => replay(&bag, settings, rules, progress),
    };
    bar.finish_and_clear();
    println!(
        "{}: {} candidates, {} recorded recommendations",
        path.display(),
        bag.candidates.len(),
        bag.recommendations.len()
    );
    if !bag.candidate_sets.is_empty() || !bag.recommendation_sets.is_empty() {
        println!(
            "{}: {} candidate sets, {} recorded set answers",
            path.display(),
            bag.candidate_sets.len(),
            bag.recommendation_sets.len()
        );
    }
    Ok(summary)
}

/// Writes the bag's sets and candidates with the new answers.
fn write_answers(w: &mut BagWriter, bag: &bag::Bag, answers: Answers) -> anyhow::Result<()> {
    let entry = |payload, log_time, publish_time| Entry {
        payload,
        log_time,
        publish_time,
    };
    for (s, a) in bag.candidate_sets.iter().zip(answers.sets) {
        let set = Payload::CandidateSet(Box::new(s.message.clone()));
        w.write(&entry(set, s.log_time, s.publish_time))?;
        let answer = Payload::RecommendationSet(Box::new(a.message));
        w.write(&entry(answer, a.log_time, a.publish_time))?;
    }
    for (c, a) in bag.candidates.iter().zip(answers.recommendations) {
        let candidate = Payload::Candidate(Box::new(c.message.clone()));
        w.write(&entry(candidate, c.log_time, c.publish_time))?;
        let answer = Payload::Recommendation(Box::new(a.message));
        w.write(&entry(answer, a.log_time, a.publish_time))?;
    }
    Ok(())
}

/// Prints the summary; an error when any answer differs or is unmatched.
fn report(summary: &Summary, secs: f64) -> anyhow::Result<()> {
    println!(
        "replayed {} candidates in {secs:.2} s ({:.0} per second): {} compared with a recorded \
         recommendation, {} differ beyond {TOLERANCE:e}, {} recorded recommendations unmatched",
        summary.candidates,
        summary.candidates as f64 / secs.max(1e-9),
        summary.compared,
        summary.differing,
        summary.unmatched_recommendations
    );
    if summary.sets > 0 || summary.unmatched_set_answers > 0 {
        println!(
            "replayed {} sets (their candidates counted above): {} compared with a recorded \
             answer, {} differ, {} recorded set answers unmatched",
            summary.sets,
            summary.sets_compared,
            summary.sets_differing,
            summary.unmatched_set_answers
        );
    }
    if !summary.largest.is_empty() {
        println!("largest difference per field:");
        for (field, gap) in &summary.largest {
            println!("  {field:<24} {gap:.3e}");
        }
    }
    for example in &summary.examples {
        println!("  differs: {example}");
    }
    if summary.differing > 0 {
        bail!(
            "{} of {} compared recommendations differ",
            summary.differing,
            summary.compared
        );
    }
    if summary.unmatched_recommendations > 0 {
        bail!(
            "{} recorded recommendations answer no recorded candidate",
            summary.unmatched_recommendations
        );
    }
    if summary.sets_differing > 0 {
        bail!(
            "{} of {} compared set answers differ",
            summary.sets_differing,
            summary.sets_compared
        );
    }
    if summary.unmatched_set_answers > 0 {
        bail!(
            "{} recorded set answers answer no recorded set",
            summary.unmatched_set_answers
        );
    }
    Ok(())
}
