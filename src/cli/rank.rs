//! `grasp_orient rank [FILE]`: JSON lines of candidates answered as one set, ranked by the force
//! they need; a table a person reads at a glance, or (`--json`) the set's answer. The lines are
//! GraspCandidates and PoseCandidates, or one pose set (`docs/poses.md`).

use super::SolveOptions;
use crate::answer::{PoseAnswerer, RankBy, Rules};
use crate::geometry::ClosingAxis;
use crate::jsonl::{is_pose_candidate, is_pose_set};
use crate::kind::{Kind, PoseSets, Sets};
use crate::msg::{
    invalid, short_id, GraspCandidate, GraspCandidateSet, GripRecommendation,
    GripRecommendationSet, PoseCandidate,
};
use anyhow::{bail, Context};
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;

/// Arguments of `rank`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// File of JSON lines, one GraspCandidate or PoseCandidate per line (as `solve` reads them),
    /// taken as one set; or a single line holding a pose set (docs/poses.md),
    /// whose --json answer is a PoseRecommendationSet. Standard input when absent or "-".
    pub(crate) file: Option<PathBuf>,
    /// The axis of the gripper's tool frame that the fingers of a pose candidate close along:
    /// x, y or z (parameter closing_axis, default y).
    #[arg(long, value_name = "AXIS", value_parser = super::parse_name::<ClosingAxis>)]
    pub(crate) closing_axis: Option<ClosingAxis>,
    /// Print the set's answer (a GripRecommendationSet, one JSON line) instead of the table.
    #[arg(long)]
    pub(crate) json: bool,
    /// What ranks the candidates, least first: grip_force (the one --gripper-drive picks) or
    /// objective (gripping_power).
    #[arg(long, value_name = "WHAT", value_parser = super::parse_name::<RankBy>)]
    pub(crate) rank_by: Option<RankBy>,
    /// The most candidates the set may hold (>= 1); a larger one is refused.
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = super::parameter::<i64>("max_set_size"))]
    pub(crate) max_set_size: Option<i64>,
    #[command(flatten)]
    pub(crate) options: SolveOptions,
}

/// Longest id the table shows, characters.
const ID_CHARS: usize = 32;

/// Reads the lines into a set (a line that is no candidate is kept as an empty one and answered
/// with status 2 and its line number; a pose candidate the geometry refuses, with its refusal),
/// answers it, and prints the table or the JSON answer.
pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    let (_, with) = args.options.answering(args.closing_axis)?;
    let mut rules = *with.rules();
    if let Some(r) = args.rank_by {
        rules.rank_by = r;
    }
    if let Some(n) = args.max_set_size {
        rules.max_set_size = usize::try_from(n).unwrap_or(usize::MAX);
    }
    let with = with.with_rules(rules);
    let (set, reply) = match read_input(args, with.poses())? {
        Input::Candidates(set, replaced) => {
            let mut reply = with.answer::<Sets>(&set);
            for (index, answer) in replaced {
                if let Some(r) = reply.recommendations.get_mut(index) {
                    *r = answer;
                }
            }
            if args.json {
                return print(&reply, reply.status, &reply.message);
            }
            (set, reply)
        }
        Input::PoseSet(pose_set) => {
            let reply = with.answer::<PoseSets>(&pose_set);
            if args.json {
                return print(&reply, reply.status, &reply.message);
            }
            let set = GraspCandidateSet {
                max_grip_force: pose_set.max_grip_force,
                ..GraspCandidateSet::default()
            };
            let reply = GripRecommendationSet {
                recommendations: reply
                    .recommendations
                    .into_iter()
                    .map(|p| p.recommendation)
                    .collect(),
                header: reply.header,
                set_id: reply.set_id,
                ranking: reply.ranking,
                ranked_by: reply.ranked_by,
                status: reply.status,
                message: reply.message,
            };
            (set, reply)
        }
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    if reply.status == GripRecommendationSet::STATUS_OK {
        out.write_all(table(&set, &reply, &rules).as_bytes())
            .context("cannot write the table")?;
    }
    out.flush().context("cannot write the answer")?;
    if reply.status != GripRecommendationSet::STATUS_OK {
        bail!("the set is refused: {}", reply.message);
    }
    Ok(())
}

/// Prints a set's answer as one JSON line; an error when the set is refused.
fn print(reply: &impl serde::Serialize, status: u8, message: &str) -> anyhow::Result<()> {
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    serde_json::to_writer(&mut out, reply).context("cannot write the answer")?;
    out.write_all(b"\n").context("cannot write the answer")?;
    out.flush().context("cannot write the answer")?;
    if status != GripRecommendationSet::STATUS_OK {
        bail!("the set is refused: {message}");
    }
    Ok(())
}

/// What the file holds: candidates (with the answers that replace those of lines that are no
/// candidate, by index), or one pose set.
enum Input {
    Candidates(GraspCandidateSet, Vec<(usize, GripRecommendation)>),
    PoseSet(Box<<PoseSets as Kind>::Request>),
}

/// The candidates of the file, or its pose set.
fn read_input(args: &Args, poses: &PoseAnswerer) -> anyhow::Result<Input> {
    let (input, name): (Box<dyn BufRead>, String) = match &args.file {
        Some(path) if path.as_os_str() != "-" => (
            Box::new(BufReader::new(
                std::fs::File::open(path)
                    .with_context(|| format!("cannot open {}", path.display()))?,
            )),
            path.display().to_string(),
        ),
        _ => (Box::new(std::io::stdin().lock()), "stdin".to_string()),
    };
    let mut lines = Vec::new();
    for (index, line) in input.lines().enumerate() {
        let number = index + 1;
        let line = line.with_context(|| format!("cannot read line {number}"))?;
        if !line.trim().is_empty() {
            lines.push((number, line));
        }
    }
    if let Some((number, _)) = lines.iter().find(|(_, l)| is_pose_set(l)) {
        if lines.len() != 1 {
            bail!(
                "line {number} is a pose set: rank reads one, alone in its input, or \
                 candidate lines"
            );
        }
        let set = crate::jsonl::parse::<<PoseSets as Kind>::Request>(&lines[0].1)
            .with_context(|| format!("line {number}: not a pose set"))?;
        return Ok(Input::PoseSet(Box::new(set)));
    }
    let mut set = GraspCandidateSet {
        id: name.into(),
        ..GraspCandidateSet::default()
    };
    let mut replaced = Vec::new();
    for (number, line) in lines {
        let index = set.candidates.len();
        let read = if is_pose_candidate(&line) {
            crate::jsonl::parse::<PoseCandidate>(&line).map(|p| poses.spatial_candidate(&p))
        } else {
            crate::jsonl::parse::<GraspCandidate>(&line).map(Ok)
        };
        let refusal = match read {
            Ok(Ok(c)) => {
                set.candidates.push(c);
                continue;
            }
            // As `solve` answers a line that is no candidate.
            Err(e) => invalid(&crate::jsonl::partial(&line), &e),
            Ok(Err(refused)) => *refused,
        };
        let mut refusal = refusal;
        if refusal.status == GripRecommendation::STATUS_INVALID_INPUT {
            refusal.message = compact_str::format_compact!("line {number}: {}", refusal.message);
        }
        replaced.push((index, refusal));
        set.candidates.push(GraspCandidate::default());
    }
    Ok(Input::Candidates(set, replaced))
}

/// The status in words.
fn status_name(status: u8) -> &'static str {
    match status {
        GripRecommendation::STATUS_OK => "ok",
        GripRecommendation::STATUS_NO_FORCE_CLOSURE => "no force closure",
        GripRecommendation::STATUS_INVALID_INPUT => "invalid input",
        GripRecommendation::STATUS_EXCEEDS_GRIPPER => "exceeds gripper",
        _ => "unknown",
    }
}

/// A number for the table, or "-" when there is none.
fn number(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        "-".to_string()
    }
}

/// The wrist rotation, rad, with its axis when that is not +z (a spatial candidate's).
fn rotation(r: &GripRecommendation) -> String {
    let angle = number(r.wrist_rotation, 4);
    let k = &r.rotation_axis;
    if !r.wrist_rotation.is_finite() || (k.x, k.y, k.z) == (0.0, 0.0, 1.0) {
        angle
    } else {
        format!("{angle} about ({:.3}, {:.3}, {:.3})", k.x, k.y, k.z)
    }
}

/// The table: the ranked candidates first, least force first, then the others in file order.
fn table(set: &GraspCandidateSet, reply: &GripRecommendationSet, rules: &Rules) -> String {
    let recs = &reply.recommendations;
    let limit = if set.max_grip_force > 0.0 {
        set.max_grip_force
    } else {
        rules.max_grip_force
    };
    let mut text = format!(
        "{} candidates, {} ranked by {} (gripper_drive {}{})\n",
        recs.len(),
        reply.ranking.len(),
        reply.ranked_by,
        rules.drive.name(),
        if limit > 0.0 {
            format!(", max_grip_force {limit} N")
        } else {
            String::new()
        }
    );
    let mut rows: Vec<[String; 7]> = vec![[
        "rank".into(),
        "id".into(),
        format!("grip force N ({})", rules.drive.field()),
        "gripping power N".into(),
        "wrist rotation rad".into(),
        "status".into(),
        "reason".into(),
    ]];
    let ranked = reply
        .ranking
        .iter()
        .enumerate()
        .map(|(k, &i)| (Some(k + 1), i as usize));
    let mut in_ranking = vec![false; recs.len()];
    for &i in &reply.ranking {
        if let Some(seen) = in_ranking.get_mut(i as usize) {
            *seen = true;
        }
    }
    let others = (0..recs.len())
        .filter(|&i| !in_ranking[i])
        .map(|i| (None, i));
    for (place, i) in ranked.chain(others) {
        let Some(r) = recs.get(i) else { continue };
        rows.push([
            place.map_or("-".into(), |k| k.to_string()),
            short(&r.candidate_id),
            number(rules.drive.grip_force(r), 3),
            number(r.gripping_power, 3),
            rotation(r),
            status_name(r.status).into(),
            r.message.to_string(),
        ]);
    }
    let widths: Vec<usize> = (0..7)
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    for row in &rows {
        let mut line = String::new();
        for (c, cell) in row.iter().enumerate() {
            let right = matches!(c, 0 | 2 | 3 | 4);
            let pad = widths[c] - cell.chars().count();
            if c == 6 {
                line.push_str(cell);
            } else if right {
                let _ = write!(line, "{}{cell}  ", " ".repeat(pad));
            } else {
                let _ = write!(line, "{cell}{}  ", " ".repeat(pad));
            }
        }
        text.push_str(line.trim_end());
        text.push('\n');
    }
    text
}

/// An id cut for the table.
fn short(id: &str) -> String {
    let cut = short_id(id);
    match cut.char_indices().nth(ID_CHARS) {
        Some((end, _)) => format!("{}…", &cut[..end]),
        None => cut.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Settings;

    #[test]
    fn the_table_lists_ranked_candidates_first_then_the_rest() {
        let lines = include_str!("../../examples/paper_cases.jsonl");
        let mut set = GraspCandidateSet::default();
        for l in lines.lines() {
            set.candidates
                .push(serde_json::from_str(l).expect("a candidate"));
        }
        set.candidates[1].mass = -1.0;
        // Case (c) as a spatial candidate too, stood up in the y-z plane: it turns about x.
        let mut spatial = set.candidates[2].clone();
        spatial.model = GraspCandidate::MODEL_SPATIAL;
        spatial.id = "paper-c-spatial".into();
        for p in [
            &mut spatial.contact_1,
            &mut spatial.contact_2,
            &mut spatial.center_of_mass,
        ] {
            (p.x, p.y, p.z) = (p.z, p.x, p.y);
        }
        for v in [
            &mut spatial.normal_1,
            &mut spatial.normal_2,
            &mut spatial.gravity,
        ] {
            (v.x, v.y, v.z) = (v.z, v.x, v.y);
        }
        set.candidates.push(spatial);
        let rules = Rules::default();
        let reply = crate::answer::answer_set(&set, &Settings::default(), &rules);
        let text = table(&set, &reply, &rules);
        let lines: Vec<&str> = text.lines().collect();
        let row = |id: &str| {
            *lines
                .iter()
                .find(|l| l.contains(&format!(" {id} ")))
                .expect("a row")
        };
        assert!(row("paper-c").contains(" 0.2618  ok"), "{text}");
        assert!(
            row("paper-c-spatial").contains(" 0.2618 about (1.000, 0.000, 0.000)  ok"),
            "{text}"
        );
        set.candidates.pop();
        let reply = crate::answer::answer_set(&set, &Settings::default(), &rules);
        let text = table(&set, &reply, &rules);
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines[0].starts_with("4 candidates, 3 ranked by internal_force"),
            "{text}"
        );
        assert!(lines[1].starts_with("rank  id"), "{text}");
        assert!(lines[2].trim_start().starts_with("1  paper-"), "{text}");
        assert!(
            lines[5].starts_with("   -  paper-b") || lines[5].starts_with("-"),
            "{text}"
        );
        assert!(
            lines[5].contains("invalid input") && lines[5].contains("mass"),
            "{text}"
        );
    }
}
