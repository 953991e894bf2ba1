//! `grasp_orient replay BAG...`: re-solve every recorded candidate with the settings it was
//! recorded with, and compare with the recorded recommendations.
//!
//! The outcome, for `main` to turn into an exit code: `Ok` when every candidate was compared
//! and none differs; [`Negative`] when an answer differs, is missing or answers no candidate;
//! any other error (a damaged bag, messages that do not decode, bad options) is trouble.

use super::{Negative, SolveOptions};
use crate::config::Config;
use crate::kind::{self, Kind, Streams, Visit};
use crate::msg::{GripRecommendation, PoseRecommendation, RosMessage};
use crate::record::bag::{self, Bag, Recorded};
use crate::record::output::{Pending, Replacement};
use crate::record::{BagWriter, Entry, Payload, Topics};
use crate::replay::{replay, replay_with_answers, Override, Plan, Summary, TOLERANCE};
use anyhow::{bail, Context};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `replay`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// MCAP files (ours, or any rosbag2 MCAP with a grasp_orient/msg/GraspCandidate or
    /// GraspCandidateSet topic).
    #[arg(required = true)]
    pub(crate) bags: Vec<PathBuf>,
    /// Also write a fresh recording of the replay: the candidates, the new recommendations and
    /// the settings used. Written beside OUT.mcap and renamed into place when complete; never
    /// one of the BAGs.
    #[arg(long, value_name = "OUT.mcap")]
    pub(crate) write: Option<PathBuf>,
    /// Solve the candidates without comparing, for bags that hold no recorded answers (with
    /// --write, to make them). Without it, a candidate with no recorded answer fails the replay.
    #[arg(long)]
    pub(crate) no_compare: bool,
    /// Each candidate is solved with the settings the bag recorded for its time; these options
    /// override them (and the built-in config, for bags that recorded none).
    #[command(flatten)]
    pub(crate) options: SolveOptions,
}

/// Replays every bag and prints a summary.
pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    let base = Config::load(None, "grasp_orient")?;
    let overrides = args.options.overrides()?;
    // Bad options are refused before any bag is read.
    args.options.config()?;
    let started = std::time::Instant::now();
    let mut summary = Summary::default();
    let mut trouble = Vec::new();
    let mut output = args
        .write
        .as_deref()
        .map(|path| Output::create(path, &args.bags))
        .transpose()?;
    for path in &args.bags {
        let part = replay_file(path, &base, &overrides, args, output.as_mut(), &mut trouble)?;
        summary.merge(part);
    }
    if let Some(output) = output {
        output.finish()?;
    }
    report(&summary, started.elapsed().as_secs_f64(), args.no_compare)?;
    if !trouble.is_empty() {
        bail!("{}", trouble.join("; "));
    }
    verdict(&summary, args.no_compare)
}

/// The recording `--write` makes, under a temporary name until it is complete.
struct Output {
    path: PathBuf,
    writer: BagWriter,
    pending: Pending,
}

impl Output {
    fn create(path: &Path, inputs: &[PathBuf]) -> anyhow::Result<Self> {
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        let replacement = Replacement::create(path, &inputs)?;
        let temp = replacement.temporary_path().to_path_buf();
        let (file, pending) = replacement.into_parts();
        let topics = Topics::default_names();
        let writer = BagWriter::on_file(file, &temp, &topics, 100)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            pending,
        })
    }

    fn finish(self) -> anyhow::Result<()> {
        let written = self.writer.finish()?;
        self.pending
            .commit()
            .with_context(|| format!("cannot write {}", self.path.display()))?;
        writeln!(
            std::io::stdout(),
            "wrote {} candidates, {} recommendations, {} candidate sets and {} set answers to {}",
            written.requests::<crate::kind::Candidates>(),
            written.answers::<crate::kind::Candidates>(),
            written.requests::<crate::kind::Sets>(),
            written.answers::<crate::kind::Sets>(),
            self.path.display()
        )?;
        if written.requests::<crate::kind::Poses>() + written.requests::<crate::kind::PoseSets>()
            > 0
        {
            writeln!(
                std::io::stdout(),
                "wrote {} pose candidates, {} pose answers, {} pose sets and {} pose set answers \
                 to {}",
                written.requests::<crate::kind::Poses>(),
                written.answers::<crate::kind::Poses>(),
                written.requests::<crate::kind::PoseSets>(),
                written.answers::<crate::kind::PoseSets>(),
                self.path.display()
            )?;
        }
        Ok(())
    }
}

/// Replays one bag, writing its candidates, the new answers and the settings used to `output`
/// if given. Undecodable messages are noted in `trouble`.
fn replay_file(
    path: &Path,
    base: &Config,
    overrides: &[Override],
    args: &Args,
    output: Option<&mut Output>,
    trouble: &mut Vec<String>,
) -> anyhow::Result<Summary> {
    let mut bag = bag::read(path)?;
    if bag.streams.request_counts().iter().all(|n| *n == 0) {
        bail!(
            "{}: no {} messages (cdr) in it",
            path.display(),
            kind::request_types()
        );
    }
    let missing = [
        (
            bag.fields.missing::<GripRecommendation>(),
            GripRecommendation::TYPE_NAME,
        ),
        (
            bag.fields.missing::<PoseRecommendation>(),
            PoseRecommendation::TYPE_NAME,
        ),
    ];
    for (missing, type_name) in missing {
        if !missing.is_empty() {
            writeln!(
                std::io::stdout(),
                "{}: recorded before {} were added to {type_name}: not compared",
                path.display(),
                missing.join(", "),
            )?;
        }
    }
    if bag.undecodable_count > 0 {
        trouble.push(format!(
            "{}: {} messages of grasp_orient's types do not decode, e.g. {}",
            path.display(),
            bag.undecodable_count,
            bag.undecodable.first().map_or("", String::as_str)
        ));
    }
    let plan = Plan::for_bag(&bag, base, overrides)
        .with_context(|| format!("{}: cannot replay", path.display()))?;
    let recorded = bag.streams.candidates.answers.len();
    let recorded_sets = bag.streams.sets.answers.len();
    if args.no_compare {
        bag = Bag {
            streams: std::mem::take(&mut bag.streams).requests_only(),
            ..Bag::default()
        };
    }
    let bar = indicatif::ProgressBar::new(bag.streams.candidates.requests.len() as u64);
    if bag.streams.candidates.requests.len() < 100_000 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let progress = |n| bar.inc(n);
    let summary = match output {
        Some(out) => {
            let (summary, answers) = replay_with_answers(&bag, &plan, progress)?;
            write_replay(&mut out.writer, &bag, &plan, answers)?;
            summary
        }
        None => replay(&bag, &plan, progress)?,
    };
    bar.finish_and_clear();
    writeln!(
        std::io::stdout(),
        "{}: {} candidates, {recorded} recorded recommendations; {}",
        path.display(),
        bag.streams.candidates.requests.len(),
        settings_words(&plan)
    )?;
    if !bag.streams.sets.requests.is_empty() || recorded_sets > 0 {
        writeln!(
            std::io::stdout(),
            "{}: {} candidate sets, {recorded_sets} recorded set answers",
            path.display(),
            bag.streams.sets.requests.len(),
        )?;
    }
    if !bag.streams.poses.requests.is_empty() || !bag.streams.pose_sets.requests.is_empty() {
        writeln!(
            std::io::stdout(),
            "{}: {} pose candidates, {} recorded pose answers, {} pose sets, {} recorded pose set \
             answers",
            path.display(),
            bag.streams.poses.requests.len(),
            bag.streams.poses.answers.len(),
            bag.streams.pose_sets.requests.len(),
            bag.streams.pose_sets.answers.len(),
        )?;
    }
    Ok(summary)
}

/// Where the settings came from, for the summary.
fn settings_words(plan: &Plan) -> String {
    let source = if plan.settings_recorded() {
        let n = plan.recorded.len();
        format!(
            "solved with the settings it recorded ({n} settings record{})",
            if n == 1 { "" } else { "s" }
        )
    } else {
        "it recorded no settings: solved with the built-in config and the objective each \
         recorded answer names"
            .to_string()
    };
    if plan.overridden.is_empty() {
        source
    } else {
        format!(
            "{source}, overridden from the command line: {}",
            plan.overridden.join(", ")
        )
    }
}

/// Writes the settings used, then, kind by kind, every recorded request followed by its new
/// answer, each at its own times.
fn write_replay(w: &mut BagWriter, bag: &Bag, plan: &Plan, answers: Streams) -> anyhow::Result<()> {
    for record in &plan.recorded {
        w.write(&Entry {
            payload: Payload::settings(record.clone()),
            log_time: record.since,
            publish_time: record.since,
        })?;
    }
    struct Pairs<'a> {
        w: &'a mut BagWriter,
        bag: &'a Bag,
        answers: Streams,
        result: anyhow::Result<()>,
    }
    impl Visit for Pairs<'_> {
        fn kind<K: Kind>(&mut self) {
            let asked = &self.bag.streams.of::<K>().requests;
            let answers = std::mem::take(&mut K::stream_mut(&mut self.answers).answers);
            for (q, a) in asked.iter().zip(answers) {
                if self.result.is_err() {
                    return;
                }
                self.result = write_pair::<K>(self.w, q, a);
            }
        }
    }
    let mut pairs = Pairs {
        w,
        bag,
        answers,
        result: Ok(()),
    };
    kind::each(&mut pairs);
    pairs.result
}

/// Writes a recorded request and then its new answer, each at its own times.
fn write_pair<K: Kind>(
    w: &mut BagWriter,
    asked: &Recorded<K::Request>,
    answer: Recorded<K::Answer>,
) -> anyhow::Result<()> {
    w.write(&Entry {
        payload: Payload::request::<K>(asked.message.clone()),
        log_time: asked.log_time,
        publish_time: asked.publish_time,
    })?;
    w.write(&Entry {
        payload: Payload::answer::<K>(answer.message),
        log_time: answer.log_time,
        publish_time: answer.publish_time,
    })?;
    Ok(())
}

/// Prints the summary.
fn report(summary: &Summary, secs: f64, no_compare: bool) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "replayed {} candidates in {secs:.2} s ({:.0} per second): {} compared with a recorded \
         recommendation, {} differ beyond {TOLERANCE:e}, {} recorded recommendations unmatched{}",
        summary.candidates,
        summary.candidates as f64 / secs.max(1e-9),
        summary.compared,
        summary.differing,
        summary.unmatched_recommendations,
        if no_compare {
            " (--no-compare: nothing was compared)"
        } else {
            ""
        }
    )?;
    if summary.answered_behind_tangent > 0 {
        writeln!(
            out,
            "{} recorded refusals for a centre of mass behind a tangent are answered now (not \
             differences: docs/recordings.md)",
            summary.answered_behind_tangent
        )?;
    }
    if summary.sets > 0 || summary.unmatched_set_answers > 0 {
        writeln!(
            out,
            "replayed {} sets (their candidates counted above): {} compared with a recorded \
             answer, {} differ, {} recorded set answers unmatched{}",
            summary.sets,
            summary.sets_compared,
            summary.sets_differing,
            summary.unmatched_set_answers,
            if summary.in_refused_sets > 0 {
                format!(
                    "; {} candidates in sets refused as a whole, compared through the set's \
                     status and message",
                    summary.in_refused_sets
                )
            } else {
                String::new()
            }
        )?;
    }
    if summary.pose_candidates + summary.pose_sets > 0 {
        writeln!(
            out,
            "{} of the candidates were pose candidates and {} of the sets pose sets: their \
             contacts, normals and centres of mass cast again from the recorded poses and objects",
            summary.pose_candidates, summary.pose_sets
        )?;
    }
    if !summary.largest.is_empty() {
        writeln!(out, "largest difference per field:")?;
        for (field, gap) in &summary.largest {
            writeln!(out, "  {field:<24} {gap:.3e}")?;
        }
    }
    for example in &summary.examples {
        writeln!(out, "  differs: {example}")?;
    }
    Ok(())
}

/// `Ok` when every candidate was compared and nothing differs; [`Negative`] otherwise.
fn verdict(summary: &Summary, no_compare: bool) -> anyhow::Result<()> {
    let mut no = Vec::new();
    if summary.differing > 0 {
        no.push(format!(
            "{} of {} compared recommendations differ",
            summary.differing, summary.compared
        ));
    }
    if summary.unmatched_recommendations > 0 {
        no.push(format!(
            "{} recorded recommendations answer no recorded candidate",
            summary.unmatched_recommendations
        ));
    }
    if summary.sets_differing > 0 {
        no.push(format!(
            "{} of {} compared set answers differ",
            summary.sets_differing, summary.sets_compared
        ));
    }
    if summary.unmatched_set_answers > 0 {
        no.push(format!(
            "{} recorded set answers answer no recorded set",
            summary.unmatched_set_answers
        ));
    }
    let uncompared = summary
        .candidates
        .saturating_sub(summary.compared + summary.in_refused_sets);
    if !no_compare && uncompared > 0 {
        no.push(format!(
            "{uncompared} of {} candidates have no recorded recommendation to compare with \
             (--no-compare solves bags of candidates alone)",
            summary.candidates
        ));
    }
    if no.is_empty() {
        Ok(())
    } else {
        Err(Negative(no.join("; ")).into())
    }
}
