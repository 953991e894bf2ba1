//! `grasp_orient plot CANDIDATE.json -o OUT.svg`: the six bounds `α_k(θ)` and the gripping power
//! `P(θ)` over the graspable range, with the paper's candidates and the recommendation marked,
//! like the paper's Fig. 9. A spatial candidate is drawn in its grasp plane Π: the planar problem
//! the reduction solves there (sliced friction, gravity angles in the paper frame of Π).
//!
//! A planar candidate with tolerances (its own, or `--center-of-mass-tolerance` /
//! `--mass-tolerance` where it gives none) adds, on the power chart, each vertex's curve (the
//! object with its centre of mass at that vertex of the box cut by the object, at the largest
//! mass) and their upper envelope, the worst case that `planar::robust::solve` minimises (same θ for every
//! vertex: the paper frame's axes are the contacts', `crates/solver/src/planar/robust/mod.rs`
//! section 2), with the robust recommendation on it.
//!
//! A pose candidate (a file holding a `PoseCandidate`, a JSON object with `grasp_pose`,
//! `docs/poses.md`) is cast by the answer layer (`PoseAnswerer`, `src/answer/pose/`) into the
//! spatial candidate its fingers make, and that candidate is drawn; the figure's title and the
//! printed line name the pose and its derived contacts. A pose the geometry refuses is refused as
//! a candidate is, with the answer's message.

use super::SolveOptions;
use crate::answer::PoseAnswerer;
use crate::geometry::ClosingAxis;
use crate::msg::{GraspCandidate, GripRecommendation, MessageLimits, PoseCandidate};
use crate::record::output::Replacement;
use crate::solver::{
    planar::{self, analyse, robust::Uncertainty, Analysis, Candidate, Recommendation},
    spatial::{self, AxisRelation, CurrentPose, IN_PLANE_TOLERANCE},
    Settings,
};
use anyhow::{anyhow, Context};
use plotters::prelude::*;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `plot`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// One GraspCandidate as JSON (a single object; the fields of msg/GraspCandidate.msg), or one
    /// PoseCandidate (msg/PoseCandidate.msg: an object with grasp_pose; docs/poses.md), drawn as
    /// the spatial candidate its fingers make.
    pub(crate) candidate: PathBuf,
    /// The axis of the gripper's tool frame that the fingers of a pose candidate close along:
    /// x, y or z (parameter closing_axis, default y).
    #[arg(long, value_name = "AXIS", value_parser = super::parse_name::<ClosingAxis>)]
    pub(crate) closing_axis: Option<ClosingAxis>,
    /// Where to write the SVG.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Samples per curve, from 10 to 100000.
    #[arg(long, default_value_t = 2000, allow_negative_numbers = true,
          value_parser = super::integer_in(10, 100_000))]
    pub(crate) samples: i64,
    #[command(flatten)]
    pub(crate) options: SolveOptions,
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// What the figure shows: one planar problem, its answer, and the current pose when it lies on
/// the curve.
struct Figure {
    analysis: Analysis,
    best: Recommendation,
    /// `(gravity angle, power)` of the current pose, when it is a point of this plane's curve.
    current: Option<(f64, f64)>,
    /// Added to the power chart's caption.
    plane: &'static str,
    /// The line printed when the figure is written.
    summary: String,
    /// With tolerances: the worst case over the region of centres of mass.
    robust: Option<Robust>,
    /// Above both charts: the pose a candidate was cast from, and its contacts.
    title: Option<String>,
}

/// The worst case of a planar candidate with tolerances, for the power chart.
struct Robust {
    /// Each vertex's object (centre of mass there, the largest mass).
    corners: Vec<Analysis>,
    /// `(gravity angle, worst power)` recommended.
    best: (f64, f64),
}

/// Draws the figure.
pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    let (_, with) = args.options.answering(args.closing_axis)?;
    let (settings, rules) = (with.settings(), with.rules());
    let text = crate::config::read_text(&args.candidate, crate::config::MAX_FILE_BYTES)
        .with_context(|| format!("cannot read {}", args.candidate.display()))?;
    let (message, pose) = if crate::jsonl::is_pose_candidate(&text) {
        let (message, pose) = cast_pose(&text, args, with.poses())?;
        (message, Some(pose))
    } else {
        let message: GraspCandidate = crate::jsonl::parse(&text)
            .with_context(|| format!("{} is not a GraspCandidate", args.candidate.display()))?;
        (message, None)
    };
    let mut figure = match message.model {
        GraspCandidate::MODEL_PLANAR => planar_figure(&rules.tolerances.apply(&message), settings)?,
        GraspCandidate::MODEL_SPATIAL => spatial_figure(&message, settings)?,
        value => return Err(refused(MessageLimits::Model { value })),
    };
    if let Some(pose) = pose {
        figure.summary = format!("{}; {}", pose.summary, figure.summary);
        figure.title = Some(pose.title);
    }
    draw(&figure, args)?;
    writeln!(
        std::io::stdout(),
        "wrote {}: {}",
        args.output.display(),
        figure.summary
    )?;
    Ok(())
}

fn refused(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("invalid input: {e}")
}

/// What the figure says of the pose a candidate was cast from.
struct PoseNote {
    /// The figure's title: the pose's id and its contacts.
    title: String,
    /// Put before the printed line: the contacts, their inward normals, the centre of mass, and
    /// any contact on an edge or a vertex.
    summary: String,
}

/// A pose candidate's file cast into the spatial candidate its fingers make, through the answer
/// layer; a refused pose is the error its answer's message gives (status 2 words start with
/// "invalid input", as a refused candidate's here).
fn cast_pose(
    text: &str,
    args: &Args,
    answerer: &PoseAnswerer,
) -> anyhow::Result<(GraspCandidate, PoseNote)> {
    let pose: PoseCandidate = crate::jsonl::parse(text)
        .with_context(|| format!("{} is not a PoseCandidate", args.candidate.display()))?;
    let (candidate, notes) = answerer
        .spatial_candidate_noted(&pose)
        .map_err(|answer| refused_pose(&answer))?;
    // `+ 0.0` prints a negative zero as 0.
    let p = |x: f64, y: f64, z: f64| format!("({:.6}, {:.6}, {:.6})", x + 0.0, y + 0.0, z + 0.0);
    let (c1, c2) = (&candidate.contact_1, &candidate.contact_2);
    let (n1, n2) = (&candidate.normal_1, &candidate.normal_2);
    let com = &candidate.center_of_mass;
    let contacts = format!(
        "contact_1 {}, contact_2 {}",
        p(c1.x, c1.y, c1.z),
        p(c2.x, c2.y, c2.z)
    );
    let mut summary = format!(
        "pose {:?}: {contacts}, inward normals {} and {}, center_of_mass {}",
        pose.id.as_str(),
        p(n1.x, n1.y, n1.z),
        p(n2.x, n2.y, n2.z),
        p(com.x, com.y, com.z)
    );
    for note in notes {
        summary.push_str("; ");
        summary.push_str(&note);
    }
    let title = format!("pose {:?}: {contacts}", pose.id.as_str());
    Ok((candidate, PoseNote { title, summary }))
}

/// The error of a pose the geometry refuses: its answer's message, which starts with "invalid
/// input" for status 2 and names the finger for status 1.
fn refused_pose(answer: &GripRecommendation) -> anyhow::Error {
    anyhow!("{}", answer.message)
}

/// A planar candidate: its x-y plane.
fn planar_figure(message: &GraspCandidate, settings: &Settings) -> anyhow::Result<Figure> {
    let candidate = Candidate::try_from(message).map_err(refused)?;
    let analysis = analyse(&candidate, settings)
        .map_err(refused)?
        .map_err(|e| anyhow!("{e}"))?;
    let best = analysis.recommend(&settings.range).map_err(refused)?;
    let summary = format!(
        "recommended gravity angle {:.6} rad, wrist rotation {:.6} rad, {} {:.6} N",
        best.gravity_angle,
        best.wrist_rotation,
        best.objective.name(),
        best.gripping_power
    );
    let mut figure = Figure {
        current: Some((best.current_gravity_angle, best.gripping_power_current)),
        analysis,
        best,
        plane: "",
        summary,
        robust: None,
        title: None,
    };
    add_worst_case(&mut figure, message, &candidate, settings)?;
    Ok(figure)
}

/// With tolerances on a planar candidate: the vertices' curves, the robust recommendation and a
/// summary of both (or why no orientation suits every object).
fn add_worst_case(
    figure: &mut Figure,
    message: &GraspCandidate,
    candidate: &Candidate,
    settings: &Settings,
) -> anyhow::Result<()> {
    let t = &message.center_of_mass_tolerance;
    if t.x == 0.0 && t.y == 0.0 && message.mass_tolerance == 0.0 {
        return Ok(());
    }
    let uncertainty = Uncertainty {
        center_of_mass_tolerance: nalgebra::Vector2::new(t.x, t.y),
        mass_tolerance: message.mass_tolerance,
    };
    match planar::robust::solve(candidate, &uncertainty, settings).map_err(refused)? {
        planar::robust::Verdict::Recommended(r) => {
            // A vertex on a tangent line may be refused by the nominal checks; it is then left
            // out of the drawing (its value is still in the reported worst case).
            let corners: Vec<Analysis> = r
                .region
                .iter()
                .filter_map(|v| {
                    let corner = Candidate {
                        center_of_mass: v.position,
                        mass: r.mass_worst,
                        ..*candidate
                    };
                    analyse(&corner, settings).ok()?.ok()
                })
                .collect();
            figure.summary = format!(
                "worst case over {} vertices of the box and mass {:.6} kg: recommended gravity \
                 angle {:.6} rad, wrist rotation {:.6} rad, {} {:.6} N (nominal object there \
                 {:.6} N); nominal object alone: {}",
                r.region.len(),
                r.mass_worst,
                r.gravity_angle,
                r.wrist_rotation,
                r.objective.name(),
                r.gripping_power,
                r.gripping_power_nominal,
                figure.summary
            );
            figure.robust = Some(Robust {
                corners,
                best: (r.gravity_angle, r.gripping_power),
            });
        }
        planar::robust::Verdict::NoCommonOrientation { reason, .. } => {
            figure.summary = format!("{reason}; nominal object: {}", figure.summary);
        }
        planar::robust::Verdict::Exact(_) | planar::robust::Verdict::NoForceClosure(_) => {}
    }
    Ok(())
}

/// A spatial candidate: its grasp plane Π.
fn spatial_figure(message: &GraspCandidate, settings: &Settings) -> anyhow::Result<Figure> {
    let candidate = spatial::Candidate::try_from(message).map_err(refused)?;
    let (analysis, r) = spatial::analyse(&candidate, settings)
        .map_err(refused)?
        .map_err(|e| anyhow!("{e}"))?;
    // `+ 0.0` prints a negative zero as 0.
    let v = |v: &nalgebra::Vector3<f64>| {
        format!("({:.6}, {:.6}, {:.6})", v.x + 0.0, v.y + 0.0, v.z + 0.0)
    };
    let mut summary = format!(
        "grasp plane normal {}; recommended gravity angle {:.6} rad in the plane, direction {}; \
         rotation {:.6} rad about {}; {} {:.6} N",
        v(&r.plane_normal),
        r.planar.gravity_angle,
        v(&r.gravity_direction),
        r.rotation_angle,
        v(&r.rotation_axis),
        r.planar.objective.name(),
        r.planar.gripping_power
    );
    for note in [r.current_pose.note(), r.axis.note().map(str::to_string)]
        .into_iter()
        .flatten()
    {
        summary.push_str("; ");
        summary.push_str(&note);
    }
    Ok(Figure {
        current: current_in_plane(&candidate, &r),
        analysis,
        best: r.planar,
        plane: ", in the grasp plane",
        summary,
        robust: None,
        title: None,
    })
}

/// The current pose as a point of Π's curve, when gravity lies in Π: not when the object swings,
/// nor, on the contact axis, when the current gravity is in another plane than the one chosen.
fn current_in_plane(c: &spatial::Candidate, r: &spatial::Recommendation) -> Option<(f64, f64)> {
    let point = (
        r.planar.current_gravity_angle,
        r.planar.gripping_power_current,
    );
    match (r.current_pose, r.axis) {
        (CurrentPose::Swings { .. }, _) => None,
        (CurrentPose::Held, AxisRelation::OnAxis) => {
            let across = c.gravity.normalize().dot(&r.plane_normal).abs();
            (across <= IN_PLANE_TOLERANCE).then_some(point)
        }
        (CurrentPose::Held, _) => Some(point),
    }
}

/// The curves of the figure, sampled over the graspable range `[lo, hi]`.
struct Curves {
    lo: f64,
    hi: f64,
    /// `α_1..α_6`.
    alphas: Vec<Vec<(f64, f64)>>,
    /// Their upper envelope `α_min`.
    envelope: Vec<(f64, f64)>,
    /// The gripping power.
    power: Vec<(f64, f64)>,
    /// Each vertex's gripping power where that vertex's object is graspable.
    corners: Vec<Vec<(f64, f64)>>,
    /// Their upper envelope, the worst case, where every vertex's object is graspable.
    worst: Vec<(f64, f64)>,
}

impl Curves {
    fn sample(analysis: &Analysis, corners: &[Analysis], n: usize) -> Self {
        let (lo, hi) = analysis.graspable_range();
        let thetas: Vec<f64> = (0..=n)
            .map(|k| lo + (hi - lo) * k as f64 / n as f64)
            .collect();
        let alphas: Vec<[f64; 6]> = thetas.iter().map(|&t| analysis.alphas_at(t)).collect();
        let alpha_curves: Vec<Vec<(f64, f64)>> = (0..6)
            .map(|k| {
                thetas
                    .iter()
                    .zip(&alphas)
                    .map(|(&t, a)| (t, a[k]))
                    .collect()
            })
            .collect();
        let power: Vec<(f64, f64)> = thetas
            .iter()
            .map(|&t| (t, analysis.evaluate(t).power))
            .collect();
        let envelope: Vec<(f64, f64)> = thetas
            .iter()
            .map(|&t| (t, analysis.evaluate(t).alpha_min))
            .collect();
        let inside = |a: &Analysis, t: f64| {
            let (glo, ghi) = a.graspable_range();
            (glo..=ghi).contains(&t)
        };
        let corner_curves: Vec<Vec<(f64, f64)>> = corners
            .iter()
            .map(|a| {
                thetas
                    .iter()
                    .filter(|&&t| inside(a, t))
                    .map(|&t| (t, a.evaluate(t).power))
                    .collect()
            })
            .collect();
        let worst = if corners.is_empty() {
            Vec::new()
        } else {
            thetas
                .iter()
                .filter(|&&t| corners.iter().all(|a| inside(a, t)))
                .map(|&t| {
                    let top = corners
                        .iter()
                        .map(|a| a.evaluate(t).power)
                        .fold(0.0, f64::max);
                    (t, top)
                })
                .collect()
        };
        Self {
            lo,
            hi,
            alphas: alpha_curves,
            envelope,
            power,
            corners: corner_curves,
            worst,
        }
    }
}

/// The vertices' curves (thin, coloured), their envelope (the worst case, thick red) and the
/// robust recommendation on it.
fn draw_worst_case<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    curves: &Curves,
    robust: &Robust,
    (pmin, pmax): (f64, f64),
) -> anyhow::Result<()> {
    let err = drawing_failed;
    for (k, curve) in curves.corners.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let series = chart
            .draw_series(LineSeries::new(
                curve.iter().copied().filter(|p| p.1 >= pmin && p.1 <= pmax),
                colour.stroke_width(1),
            ))
            .map_err(err)?;
        if k == 0 {
            series
                .label("box vertices")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
    }
    let worst = RGBColor(200, 0, 0);
    chart
        .draw_series(LineSeries::new(
            curves.worst.iter().copied(),
            worst.stroke_width(3),
        ))
        .map_err(err)?
        .label("worst case (envelope)")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], worst));
    chart
        .draw_series(std::iter::once(Cross::new(
            robust.best,
            8,
            worst.stroke_width(3),
        )))
        .map_err(err)?
        .label("recommended for the worst case")
        .legend(move |(x, y)| Cross::new((x + 10, y), 5, worst.stroke_width(2)));
    Ok(())
}

/// The smallest and largest of `values`.
fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    })
}

fn drawing_failed(e: impl std::fmt::Debug) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// Draws into memory, then writes the SVG beside `args.output` and renames it into place.
fn draw(figure: &Figure, args: &Args) -> anyhow::Result<()> {
    let corners = figure.robust.as_ref().map_or(&[][..], |r| &r.corners[..]);
    let curves = Curves::sample(
        &figure.analysis,
        corners,
        usize::try_from(args.samples).unwrap_or(10).max(10),
    );
    let mut svg = String::new();
    {
        let height = if figure.title.is_some() { 600 } else { 560 };
        let root = SVGBackend::with_string(&mut svg, (1400, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let charts = match &figure.title {
            Some(title) => root
                .titled(title, ("sans-serif", 22))
                .map_err(drawing_failed)?,
            None => root.clone(),
        };
        let (left, right) = charts.split_horizontally(700);
        draw_bounds(&left, &curves)?;
        draw_power(&right, figure, &curves)?;
        root.present().map_err(drawing_failed)?;
    }
    let cannot = || format!("cannot write {}", args.output.display());
    let (mut file, pending) =
        Replacement::create(&args.output, &[args.candidate.as_path()])?.into_parts();
    file.write_all(svg.as_bytes()).with_context(cannot)?;
    drop(file);
    pending.commit().with_context(cannot)?;
    Ok(())
}

/// Left: the six bounds and their envelope.
fn draw_bounds(area: &Area<'_>, curves: &Curves) -> anyhow::Result<()> {
    let err = drawing_failed;
    let (amin, amax) = span(curves.envelope.iter().map(|p| p.1));
    let pad = 0.6 * (amax - amin).max(1e-9);
    let (amin, amax) = (amin - pad, amax + pad);
    let mut chart = ChartBuilder::on(area)
        .caption(
            "bounds α_k(θ) (lengths / contact distance)",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(curves.lo..curves.hi, amin..amax)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("gravity angle θ, rad")
        .y_desc("α")
        .draw()
        .map_err(err)?;
    for (k, curve) in curves.alphas.iter().enumerate() {
        let colour = COLOURS[k];
        chart
            .draw_series(LineSeries::new(
                curve.iter().copied().filter(|p| p.1 >= amin && p.1 <= amax),
                colour.stroke_width(2),
            ))
            .map_err(err)?
            .label(format!("α_{}", k + 1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart
        .draw_series(LineSeries::new(
            curves.envelope.iter().copied(),
            BLACK.stroke_width(1),
        ))
        .map_err(err)?
        .label("α_min")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    Ok(())
}

/// Right: the gripping power, the from-above range, the paper's candidates, the recommended and
/// the current orientation.
// About 90 lines: one chart drawn series by series, each a short builder chain; split, its
// pieces would only pass the chart's generic type around.
fn draw_power(area: &Area<'_>, figure: &Figure, curves: &Curves) -> anyhow::Result<()> {
    let (analysis, best) = (&figure.analysis, &figure.best);
    let err = drawing_failed;
    let (pmin, pmax) = span(curves.power.iter().chain(&curves.worst).map(|p| p.1));
    let (pmin, pmax) = (0f64.min(pmin), pmax + 0.1 * (pmax - pmin).max(1e-9));
    let objective = best.objective.name();
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("gripping power P(θ), {objective}{}", figure.plane),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(curves.lo..curves.hi, pmin..pmax)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("gravity angle θ, rad")
        .y_desc("P, N")
        .draw()
        .map_err(err)?;
    let (above_lo, above_hi) = analysis.from_above_range();
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(above_lo, pmin), (above_hi, pmax)],
            RGBColor(230, 240, 255).filled(),
        )))
        .map_err(err)?
        .label("from above")
        .legend(|(x, y)| {
            Rectangle::new(
                [(x, y - 5), (x + 20, y + 5)],
                RGBColor(200, 220, 255).filled(),
            )
        });
    chart
        .draw_series(LineSeries::new(
            curves.power.iter().copied(),
            BLACK.stroke_width(2),
        ))
        .map_err(err)?;
    if let Some(robust) = &figure.robust {
        draw_worst_case(&mut chart, curves, robust, (pmin, pmax))?;
    }
    for (label, theta) in analysis.paper_candidates() {
        let p = analysis.evaluate(theta).power;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(theta, pmin), (theta, pmax)],
                RGBColor(150, 150, 150),
            )))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                label.name().to_string(),
                (theta, p + 0.04 * (pmax - pmin)),
                ("sans-serif", 16),
            )))
            .map_err(err)?;
    }
    chart
        .draw_series(std::iter::once(Circle::new(
            (best.gravity_angle, best.gripping_power),
            6,
            RED.filled(),
        )))
        .map_err(err)?
        .label("recommended")
        .legend(|(x, y)| Circle::new((x + 10, y), 5, RED.filled()));
    if let Some(current) = figure.current {
        chart
            .draw_series(std::iter::once(Circle::new(current, 5, BLUE.filled())))
            .map_err(err)?
            .label("current")
            .legend(|(x, y)| Circle::new((x + 10, y), 4, BLUE.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    Ok(())
}
