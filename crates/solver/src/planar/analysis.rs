//! The exact minimisation: the upper envelope of the bounds, the objective piece by piece, its
//! least value over the allowed range and its local minima over the graspable range
//! (`docs/theory.md#exact-minimisation`).
//!
//! On each piece of the envelope the active bound is one sinusoid `f(θ)`, and
//! - `norm2`: `P² ∝ Σ (T_i + w_i max(f, 0))²` is a quadratic form in `(sin θ, cos θ)`, whose
//!   stationary points are closed forms;
//! - `norm1`: `P ∝ Σ |T_i + w_i α*|` with `α*` one of `f`, or the zero of a friction force, is a
//!   positive sinusoid between the zeros of its terms, hence concave: its minima lie at breakpoints;
//! - `internal_force`: `P ∝ max(f, 0)` is a sinusoid or zero.
//!
//! So the minimiser is one of a short list of closed-form angles, each of which is evaluated.

use super::answer::{
    CandidateC, ConeMiss, GraspCase, LocalMinimum, NoForceClosure, PaperCandidate, Recommendation,
};
use super::curve::{self, AtMostTwo, Curve, Piece, SAME_ANGLE};
use super::finger;
use super::frame::GraspFrame;
use super::paper::{self, FORCE_SCALE};
use crate::sinusoid::{next_periodic, rising_zeros, wrap_angle, Angle, QuadForm, Sinusoid};
use crate::{AllowedRange, InvalidInput, Objective};
use smallvec::{smallvec, SmallVec};
use std::f64::consts::TAU;

/// Two angles closer than this (rad) are the same point, for labels and duplicates.
/// Objective values closer than this, relative to themselves or to the weight, tie; the smaller
/// wrist rotation wins.
const TIE: f64 = 1e-12;
/// Range bounds beyond this magnitude (rad) are reduced by whole turns before use.
const FAR_BOUND: f64 = 1e3;
/// Bounds larger than this many times the scale are ignored in tie-breaks of the envelope.
const ENVELOPE_TIE: f64 = 1e-12;

/// The allowed range's intervals inside the graspable range: one for the named ranges, at most
/// five for explicit bounds (kept inline, not on the heap, up to three).
type Intervals = SmallVec<[(f64, f64); 3]>;

/// One interval of θ on which the objective is a single [`Curve`].
///
/// Its ends and minima are kept as [`Angle`]s, sine and cosine included: the walk that finds
/// them, the local minima and the recommendation all evaluate shapes there, and each angle's
/// `sin_cos` is computed once (the same value each time, so the answers are what they were when
/// each use computed its own).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    lo: Angle,
    hi: Angle,
    shape: Curve,
    /// Stationary minima of the shape strictly inside `(lo, hi)` (at most two).
    minima: [Angle; 2],
    /// How many of `minima` are set.
    n_minima: usize,
}

impl Segment {
    fn new(lo: Angle, hi: Angle, shape: Curve) -> Self {
        let mut found = AtMostTwo::default();
        shape.minima_between(lo.theta, hi.theta, &mut found);
        let mut minima = [lo; 2];
        for (m, &t) in minima.iter_mut().zip(&found.values[..found.len]) {
            *m = Angle::new(t);
        }
        Self {
            lo,
            hi,
            shape,
            minima,
            n_minima: found.len,
        }
    }

    fn minima(&self) -> &[Angle] {
        &self.minima[..self.n_minima]
    }
}

impl Piece for Segment {
    fn lo(&self) -> Angle {
        self.lo
    }

    fn hi(&self) -> Angle {
        self.hi
    }

    fn curve(&self) -> &Curve {
        &self.shape
    }

    fn minima(&self) -> impl Iterator<Item = Angle> + '_ {
        Segment::minima(self).iter().copied()
    }
}

/// The objective at one orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointValue {
    /// `α_min(θ)`, the least feasible internal-force parameter (normalised units).
    pub alpha_min: f64,
    /// The α the objective chooses.
    pub alpha: f64,
    /// Objective value, N.
    pub power: f64,
    /// Squeeze force each finger adds, N.
    pub internal_force: f64,
    /// `(N1, F1, N2, F2)`, N, paper labelling and paper tangents.
    pub forces: [f64; 4],
}

/// A grasp with force closure, analysed for one objective.
#[derive(Debug, Clone)]
pub struct Analysis {
    frame: GraspFrame,
    objective: Objective,
    /// `α_1 .. α_6`.
    alphas: [Sinusoid; 6],
    /// `F_T / FORCE_SCALE`.
    particular: [Sinusoid; 4],
    /// `F_N / FORCE_SCALE`.
    internal: [f64; 4],
    graspable: (f64, f64),
    from_above: (f64, f64),
    /// `θ_36`, `θ_34`, `θ_45`: where `α_3` rises through `α_6`, `α_4` through `α_3` and `α_5`
    /// through `α_4` (eqs. 36, 42, 39 up to 2π; see `paper::candidate_angles`).
    crossings: [Option<f64>; 3],
    segments: Vec<Segment>,
}

/// The storage of an analysis's pieces, handed from one analysis to the next (a batch's).
#[derive(Debug, Default)]
pub(crate) struct Pieces(Vec<Segment>);

impl Analysis {
    /// Checks force closure and builds the objective over the graspable range.
    pub(crate) fn new(frame: &GraspFrame, objective: Objective) -> Result<Self, NoForceClosure> {
        Self::reusing(frame, objective, Pieces::default())
    }

    /// [`Analysis::new`], its pieces stored in `pieces` (emptied first): the same arithmetic.
    pub(crate) fn reusing(
        frame: &GraspFrame,
        objective: Objective,
        Pieces(mut segments): Pieces,
    ) -> Result<Self, NoForceClosure> {
        let misses = paper::closure_misses(frame);
        if misses.iter().any(Option::is_some) {
            return Err(NoForceClosure {
                misses: misses
                    .iter()
                    .enumerate()
                    .filter_map(|(i, m)| {
                        m.map(|(half_angle, angle_to_other)| ConeMiss {
                            contact: frame.candidate_contact(i == 0),
                            half_angle,
                            angle_to_other,
                        })
                    })
                    .collect(),
                friction_safety_factor: frame.friction_safety_factor,
            });
        }
        // Two to four pieces on most grasps; a larger reservation (16: 2 kB) took mimalloc's
        // slower path for blocks over 1 kB on every grasp. (Storage handed on keeps its room.)
        segments.clear();
        segments.reserve_exact(4);
        let (graspable, from_above) = paper::ranges(frame);
        let mut analysis = Self {
            frame: *frame,
            objective,
            alphas: paper::alpha_bounds(frame),
            particular: paper::balance_particular(frame),
            internal: paper::balance_internal(frame),
            graspable,
            from_above,
            crossings: [None; 3],
            segments,
        };
        analysis.build_segments();
        Ok(analysis)
    }

    /// The storage of the pieces, for the next [`Analysis::reusing`].
    pub(crate) fn into_pieces(self) -> Pieces {
        Pieces(self.segments)
    }

    /// The six bounds `α_1 .. α_6` at gravity angle `theta` (normalised units: lengths over the
    /// contact distance).
    pub fn alphas_at(&self, theta: f64) -> [f64; 6] {
        let at = Angle::new(theta);
        self.alphas.map(|a| a.value(&at))
    }

    /// The paper's candidate angles (Table 2) from its closed forms, in the paper's labelling.
    pub fn candidate_angles(&self) -> paper::CandidateAngles {
        paper::candidate_angles(&self.frame)
    }

    /// The graspable range `(θ_min, θ_max)`, rad.
    pub fn graspable_range(&self) -> (f64, f64) {
        self.graspable
    }

    /// The from-above range, rad.
    pub fn from_above_range(&self) -> (f64, f64) {
        self.from_above
    }

    /// The bounds whose envelope is the objective's α: `α_3 .. α_6`, and zero where the objective
    /// never asks for a negative squeeze.
    fn envelope_functions(&self) -> ([Sinusoid; 5], usize) {
        let [_, _, a3, a4, a5, a6] = self.alphas;
        let n = match self.objective {
            Objective::Norm1 => 4,
            Objective::Norm2 | Objective::InternalForce => 5,
        };
        ([a3, a4, a5, a6, Sinusoid::ZERO], n)
    }

    /// Walks the upper envelope over the graspable range and turns each piece into segments of
    /// the objective.
    fn build_segments(&mut self) {
        let (funcs, n) = self.envelope_functions();
        let funcs = &funcs[..n];
        let (lo, hi) = self.graspable;
        let scale = funcs
            .iter()
            .map(|f| f.a.abs().max(f.b.abs()))
            .fold(0.0, f64::max);
        let tol = ENVELOPE_TIE * scale.max(f64::MIN_POSITIVE);
        // Where `funcs[j]` rises through `funcs[i]`, for every pair: one atan2 per pair, since
        // `funcs[i]` rises through `funcs[j]` half a turn later. (Computing them only when the
        // walk asks saved 1.5 of the 10 per grasp and cost as much in bookkeeping.)
        let mut pairs = [(0, 0); 10];
        let mut differences = [Sinusoid::ZERO; 10];
        let mut m = 0;
        for i in 0..n {
            for j in (i + 1)..n {
                (pairs[m], differences[m]) = ((i, j), funcs[j].minus(&funcs[i]));
                m += 1;
            }
        }
        let mut zeros = [None; 10];
        rising_zeros(&differences[..m], &mut zeros[..m]);
        let mut rise = [[None::<f64>; 5]; 5];
        for (&(i, j), zero) in pairs[..m].iter().zip(zeros) {
            if let Some(r) = zero {
                rise[i][j] = Some(r);
                rise[j][i] = Some(r + std::f64::consts::PI);
            }
        }
        // funcs = [α3, α4, α5, α6, 0]: B, C, D are where α3 rises through α6, α4 through α3,
        // α5 through α4.
        self.crossings = [rise[3][0], rise[0][1], rise[1][2]];
        let mut t = Angle::new(lo);
        let mut active = top_at(funcs, &t, tol);
        // Each step moves to a crossing of the active bound; there are at most two crossings per
        // pair in a range shorter than 2π, so this bound is never reached on real input.
        for _ in 0..64 {
            let next = rise[active][..n]
                .iter()
                .flatten()
                .map(|&r| next_periodic(r, TAU, t.theta))
                .fold(f64::INFINITY, f64::min);
            let end = Angle::new(next.min(hi));
            if end.theta > t.theta {
                self.push_piece(t, end, &funcs[active]);
            }
            if next >= hi {
                break;
            }
            t = end;
            active = top_at(funcs, &t, tol);
        }
    }

    /// Adds the objective's segments for one envelope piece `[lo, hi]` with active bound `f`.
    fn push_piece(&mut self, lo: Angle, hi: Angle, f: &Sinusoid) {
        let t = &self.particular;
        let w = &self.internal;
        match self.objective {
            Objective::Norm2 => {
                let terms: [Sinusoid; 4] = std::array::from_fn(|i| t[i].plus_scaled(w[i], f));
                self.segments.push(Segment::new(
                    lo,
                    hi,
                    Curve::Quad(QuadForm::sum_of_squares(&terms)),
                ));
            }
            Objective::InternalForce => self.segments.push(Segment::new(lo, hi, Curve::Sin(*f))),
            Objective::Norm1 => {
                // Breakpoints inside the piece: where a friction force at α = f changes sign,
                // and where the two friction zeros cross (r1 = r2 ⇔ c2 T_F1 - c1 T_F2 = 0).
                let (l, h) = (lo.theta, hi.theta);
                let mut cuts = Vec::with_capacity(8);
                t[1].plus_scaled(w[1], f).zeros_between(l, h, &mut cuts);
                t[3].plus_scaled(w[3], f).zeros_between(l, h, &mut cuts);
                if w[1] != 0.0 && w[3] != 0.0 {
                    t[1].scaled(w[3])
                        .minus(&t[3].scaled(w[1]))
                        .zeros_between(l, h, &mut cuts);
                }
                cuts.sort_by(f64::total_cmp);
                let inner = cuts.iter().map(|&c| Angle::new(c));
                let mut a = lo;
                for b in inner.chain(std::iter::once(hi)) {
                    if b.theta > a.theta {
                        let shape = Curve::Sin(self.norm1_piece(f, 0.5 * (a.theta + b.theta)));
                        self.segments.push(Segment::new(a, b, shape));
                        a = b;
                    }
                }
            }
        }
    }

    /// The friction-force zero `r_i = -T_Fi / c_i` as a sinusoid (`i` = 1 or 3 in `(N1,F1,N2,F2)`).
    fn friction_zero(&self, i: usize) -> Option<Sinusoid> {
        (self.internal[i] != 0.0).then(|| self.particular[i].scaled(-1.0 / self.internal[i]))
    }

    /// The α the 1-norm chooses at `at` given `α_min` there, and its sinusoid on the piece.
    fn norm1_alpha(&self, f: &Sinusoid, at: &Angle) -> (f64, Sinusoid) {
        let alpha_min = f.value(at);
        let mut best = (self.norm1_at(alpha_min, at), alpha_min, *f);
        for i in [1, 3] {
            if let Some(r) = self.friction_zero(i) {
                let alpha = r.value(at);
                if alpha > alpha_min {
                    let v = self.norm1_at(alpha, at);
                    if v < best.0 {
                        best = (v, alpha, r);
                    }
                }
            }
        }
        (best.1, best.2)
    }

    /// `Σ |T_i + α w_i|` at one angle.
    fn norm1_at(&self, alpha: f64, at: &Angle) -> f64 {
        (0..4)
            .map(|i| (self.particular[i].value(at) + alpha * self.internal[i]).abs())
            .sum()
    }

    /// The 1-norm as one sinusoid on a stretch where signs and choices do not change.
    fn norm1_piece(&self, f: &Sinusoid, mid: f64) -> Sinusoid {
        let at = Angle::new(mid);
        let (_, alpha) = self.norm1_alpha(f, &at);
        (0..4).fold(Sinusoid::ZERO, |acc, i| {
            let term = self.particular[i].plus_scaled(self.internal[i], &alpha);
            let sign = if term.value(&at) < 0.0 { -1.0 } else { 1.0 };
            acc.plus_scaled(sign, &term)
        })
    }

    /// `P` in newtons of a piece's `shape` at `at`.
    fn power(&self, shape: &Curve, at: &Angle) -> f64 {
        shape.power(at, self.frame.weight * FORCE_SCALE)
    }

    /// The objective and the forces at any gravity angle, computed point-wise.
    pub fn evaluate(&self, theta: f64) -> PointValue {
        self.evaluate_at(&Angle::new(theta))
    }

    /// [`Analysis::evaluate`] at an angle whose sine and cosine are known.
    fn evaluate_at(&self, at: &Angle) -> PointValue {
        let [_, _, a3, a4, a5, a6] = self.alphas;
        let alpha_min = [a3, a4, a5, a6]
            .iter()
            .map(|a| a.value(at))
            .fold(f64::NEG_INFINITY, f64::max);
        let alpha = match self.objective {
            Objective::Norm2 | Objective::InternalForce => alpha_min.max(0.0),
            Objective::Norm1 => {
                let f = Sinusoid::new(alpha_min * at.sin, alpha_min * at.cos);
                self.norm1_alpha(&f, at).0
            }
        };
        let scale = self.frame.weight * FORCE_SCALE;
        // In units of the weight first, then in newtons: squares of newtons would underflow
        // for a weight near the smallest double.
        let unit_forces: [f64; 4] =
            std::array::from_fn(|i| self.particular[i].value(at) + alpha * self.internal[i]);
        let forces = unit_forces.map(|v| scale * v);
        let power = scale
            * match self.objective {
                Objective::Norm2 => unit_forces.iter().map(|v| v * v).sum::<f64>().sqrt(),
                Objective::Norm1 => unit_forces.iter().map(|v| v.abs()).sum(),
                Objective::InternalForce => alpha,
            };
        PointValue {
            alpha_min,
            alpha,
            power,
            internal_force: scale * alpha,
            forces,
        }
    }

    /// `θ` shifted by a multiple of 2π into `[θ_min, θ_min + 2π)`.
    fn representative(&self, theta: f64) -> f64 {
        let lo = self.graspable.0;
        lo + (theta - lo).rem_euclid(TAU)
    }

    /// The paper's candidates A–E that fall in the graspable range, with their angles, in the
    /// paper's labelling; `None` where a candidate is outside the range.
    fn labelled_angles(&self) -> [Option<(PaperCandidate, f64)>; 5] {
        let (lo, hi) = self.graspable;
        let inside = |label, theta: Option<f64>| {
            let t = next_periodic(theta?, TAU, lo - SAME_ANGLE);
            (t <= hi + SAME_ANGLE).then_some((label, t))
        };
        let [b, c, d] = self.crossings;
        [
            Some((PaperCandidate::A, lo)),
            inside(PaperCandidate::B, b),
            inside(PaperCandidate::C, c),
            inside(PaperCandidate::D, d),
            Some((PaperCandidate::E, hi)),
        ]
    }

    /// The paper's candidates A–E inside the graspable range with their angles, in the
    /// candidate's labelling.
    pub fn paper_candidates(&self) -> Vec<(PaperCandidate, f64)> {
        self.labelled_angles()
            .into_iter()
            .flatten()
            .map(|(l, t)| {
                (
                    if self.frame.swapped {
                        l.relabelled()
                    } else {
                        l
                    },
                    t,
                )
            })
            .collect()
    }

    fn label_of(
        &self,
        labels: &[Option<(PaperCandidate, f64)>],
        theta: f64,
    ) -> Option<PaperCandidate> {
        labels
            .iter()
            .flatten()
            .find(|(_, t)| (t - theta).abs() <= SAME_ANGLE)
            .map(|(l, _)| {
                if self.frame.swapped {
                    l.relabelled()
                } else {
                    *l
                }
            })
    }

    /// Every local minimum of the objective over the closed graspable range, with its label
    /// among `labels` (the paper's candidates).
    fn local_minima(&self, labels: &[Option<(PaperCandidate, f64)>]) -> Vec<LocalMinimum> {
        curve::local_minima(
            &self.segments,
            |at, shape| self.power(shape, at),
            |theta| self.label_of(labels, theta),
        )
    }

    /// The allowed range as intervals inside the graspable range.
    fn allowed_intervals(&self, range: &AllowedRange) -> Result<Intervals, InvalidInput> {
        let (glo, ghi) = self.graspable;
        match *range {
            AllowedRange::FromAbove => Ok(smallvec![self.from_above_range()]),
            AllowedRange::Graspable => Ok(smallvec![(glo, ghi)]),
            AllowedRange::Bounds { lo, hi } => {
                let (given_lo, given_hi) = (lo, hi);
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(InvalidInput::RangeBounds { lo, hi });
                }
                // A full turn or more allows every angle (`hi - lo` may overflow to +inf).
                if hi - lo >= TAU {
                    return Ok(smallvec![(glo, ghi)]);
                }
                // Far bounds are first brought within a turn of the range; the reduction is
                // exact modulo the double nearest 2π, so the bounds keep the precision they had.
                let (lo, hi) = if lo.abs().max(hi.abs()) > FAR_BOUND {
                    let near = glo + (lo - glo).rem_euclid(TAU);
                    (near, near + (hi - lo))
                } else {
                    (lo, hi)
                };
                // Angles are periodic: meet every 2π shift of the bounds with the range. Both
                // spans are at most a turn, so this is at most five shifts.
                let mut out = Intervals::new();
                let first = ((glo - hi) / TAU).floor() as i64;
                let last = ((ghi - lo) / TAU).ceil() as i64;
                for k in first..=last.min(first + 4) {
                    let shift = TAU * k as f64;
                    let (a, b) = ((lo + shift).max(glo), (hi + shift).min(ghi));
                    if a <= b {
                        out.push((a, b));
                    }
                }
                let (lo, hi) = (given_lo, given_hi);
                if out.is_empty() {
                    Err(InvalidInput::RangeOutsideGraspable {
                        lo,
                        hi,
                        graspable_lo: glo,
                        graspable_hi: ghi,
                    })
                } else {
                    Ok(out)
                }
            }
        }
    }

    /// The orientation of least objective over `range`, with everything the answer reports.
    pub fn recommend(&self, range: &AllowedRange) -> Result<Recommendation, InvalidInput> {
        let allowed = self.allowed_intervals(range)?;
        let current = self.representative(self.frame.current_theta);
        let rotation_to = |theta: f64| wrap_angle(current - theta).abs();
        let weight = self.frame.weight;
        // (angle, objective) of the best point so far.
        let mut best: Option<(Angle, f64)> = None;
        let mut consider = |at: Angle, power: f64| {
            let better = match best {
                None => true,
                Some((bt, bp)) => {
                    // Relative to the weight too: a plateau at zero must tie with rounding residue.
                    let tie = (power - bp).abs() <= TIE * bp.abs().max(power.abs()).max(weight);
                    if tie {
                        rotation_to(at.theta) < rotation_to(bt.theta)
                    } else {
                        power < bp
                    }
                }
            };
            if better {
                best = Some((at, power));
            }
        };
        // An end of a segment that an allowed interval cuts is a new angle; the others are known.
        // Bits, not `==`: a cut at -0.0 of an end at +0.0 is evaluated at the -0.0 it names.
        let clipped = |theta: f64, end: &Angle| {
            if theta.to_bits() == end.theta.to_bits() {
                *end
            } else {
                Angle::new(theta)
            }
        };
        for seg in &self.segments {
            for &(a, b) in &allowed {
                let (lo, hi) = (seg.lo.theta.max(a), seg.hi.theta.min(b));
                if lo > hi {
                    continue;
                }
                let (lo_at, hi_at) = (clipped(lo, &seg.lo), clipped(hi, &seg.hi));
                let inside = seg.minima().iter().filter(|t| t.theta > lo && t.theta < hi);
                let plateau = seg
                    .shape
                    .is_constant()
                    .then(|| Angle::new(current.clamp(lo, hi)));
                for at in [lo_at, hi_at]
                    .into_iter()
                    .chain(inside.copied())
                    .chain(plateau)
                {
                    let p = self.power(&seg.shape, &at);
                    consider(at, p);
                }
            }
        }
        // The allowed intervals lie inside the graspable range, which the segments cover.
        let (at, _) = best.unwrap_or_else(|| (Angle::new(allowed[0].0), f64::NAN));
        Ok(self.report(&at, current, &allowed))
    }

    /// Everything the answer reports for the recommended angle `best`.
    fn report(&self, best: &Angle, current: f64, allowed: &[(f64, f64)]) -> Recommendation {
        let f = &self.frame;
        let theta = best.theta;
        let at_best = self.evaluate_at(best);
        let at_current = self.evaluate(current);
        let labels = self.labelled_angles();
        let minima = self.local_minima(&labels);
        let recommended_label = self.label_of(&labels, theta);
        let c_angle = labels[2].map(|(_, t)| t);
        let candidate_c = match c_angle {
            Some(tc)
                if allowed
                    .iter()
                    .any(|&(a, b)| tc >= a - SAME_ANGLE && tc <= b + SAME_ANGLE) =>
            {
                if recommended_label == Some(PaperCandidate::C) {
                    CandidateC::Recommended
                } else if minima
                    .iter()
                    .any(|m| (m.gravity_angle - tc).abs() <= SAME_ANGLE)
                {
                    CandidateC::Beaten
                } else {
                    CandidateC::NotAMinimum
                }
            }
            _ => CandidateC::OutOfRange,
        };
        let cones = paper::cones_contain_center_of_mass(f);
        let cones = if f.swapped {
            [cones[1], cones[0]]
        } else {
            cones
        };
        let grasp_case = match cones {
            [true, true] => GraspCase::A,
            [true, false] => GraspCase::B,
            [false, true] => GraspCase::C,
            [false, false] => GraspCase::D,
        };
        // Paper tangent at contact 1 is minus "inward normal turned +90°"; at contact 2 it is the
        // same. Then put the contacts back in the candidate's order.
        let [n1, f1, n2, f2] = at_best.forces;
        let contact_forces = if f.swapped {
            [n2, f2, n1, -f1]
        } else {
            [n1, -f1, n2, f2]
        };
        Recommendation {
            objective: self.objective,
            gravity_angle: theta,
            wrist_rotation: wrap_angle(current - theta),
            gravity_direction: f.gravity_direction_at(best.sin, best.cos),
            gripping_power: at_best.power,
            internal_force: at_best.internal_force,
            contact_forces,
            gripping_power_current: at_current.power,
            internal_force_current: at_current.internal_force,
            current_gravity_angle: current,
            grasp_case,
            local_minima: minima,
            recommended_label,
            candidate_c,
            finger_force: finger::finger_force(f, &at_best.forces),
            finger_force_current: finger::finger_force(f, &at_current.forces),
        }
    }
}

impl Analysis {
    /// The objective piece by piece, `(lo, hi, curve)` in increasing θ, tiling the graspable
    /// range.
    pub(crate) fn pieces(&self) -> impl Iterator<Item = (f64, f64, Curve)> + '_ {
        self.segments
            .iter()
            .map(|s| (s.lo.theta, s.hi.theta, s.shape))
    }
}

/// Index of the largest function at `at`; near-ties go to the steeper one (it stays on top).
fn top_at(funcs: &[Sinusoid], at: &Angle, tol: f64) -> usize {
    let top = funcs
        .iter()
        .map(|f| f.value(at))
        .fold(f64::NEG_INFINITY, f64::max);
    let mut best = 0;
    let mut best_slope = f64::NEG_INFINITY;
    for (i, f) in funcs.iter().enumerate() {
        if f.value(at) >= top - tol {
            let s = f.slope(at);
            if s > best_slope {
                best = i;
                best_slope = s;
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planar::candidate::Candidate;
    use crate::table_1::{paper_grasp, table_1};
    use crate::Settings;
    use approx::{abs_diff_eq, assert_abs_diff_eq};

    fn analysis(c: &Candidate, objective: Objective) -> Analysis {
        let f = GraspFrame::new(c, 1.0).expect("valid");
        Analysis::new(&f, objective).expect("force closure")
    }

    /// The segments tile the graspable range and each one's shape matches the point-wise value.
    #[test]
    fn segments_tile_the_range_and_agree_with_pointwise_values() {
        let c = paper_grasp((5.0, 4.0), -3.0, (0.785, 0.785), (1.5, 2.5));
        for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
            let a = analysis(&c, objective);
            let (lo, hi) = a.graspable_range();
            assert_eq!(a.segments[0].lo.theta, lo);
            assert_eq!(a.segments.last().map(|s| s.hi.theta), Some(hi));
            for w in a.segments.windows(2) {
                assert_eq!(w[0].hi, w[1].lo);
            }
            for seg in &a.segments {
                // Each end and minimum carries its own sine and cosine.
                for at in [seg.lo, seg.hi].iter().chain(seg.minima()) {
                    assert_eq!(*at, Angle::new(at.theta));
                }
                let (lo, hi) = (seg.lo.theta, seg.hi.theta);
                for k in 1..10 {
                    let t = lo + (hi - lo) * k as f64 / 10.0;
                    let shape = a.power(&seg.shape, &Angle::new(t));
                    let point = a.evaluate(t).power;
                    assert!(
                        abs_diff_eq!(shape, point, epsilon = 1e-12 * point.abs().max(1.0)),
                        "{objective:?} at {t}: {shape} vs {point}"
                    );
                }
            }
        }
    }

    /// Bounds are gravity angles: any span of a turn or more is the whole graspable range, far
    /// bounds are the near ones shifted by whole turns, and neither costs more than a few
    /// intervals.
    #[test]
    fn wide_and_far_bounds_cost_no_more_than_near_ones() {
        let c = paper_grasp((5.0, 4.0), -3.0, (0.785, 0.785), (1.5, 2.5));
        let a = analysis(&c, Objective::Norm2);
        let (glo, ghi) = a.graspable_range();
        for (lo, hi) in [
            (-1e308, 1e308),
            (-f64::MAX, f64::MAX),
            (-1e12, 1e12),
            (0.0, TAU),
        ] {
            let got = a.allowed_intervals(&AllowedRange::Bounds { lo, hi });
            assert_eq!(got, Ok(smallvec![(glo, ghi)]), "[{lo}, {hi}]");
        }
        for (lo, hi) in [(-0.5, 0.5), (2.0, 3.5), (-3.0, 2.9)] {
            let near = a
                .allowed_intervals(&AllowedRange::Bounds { lo, hi })
                .expect("meets the range");
            assert!(near.len() <= 3);
            for turns in [1e3, -1e6, 1e9] {
                let shift = TAU * turns;
                let far = a
                    .allowed_intervals(&AllowedRange::Bounds {
                        lo: lo + shift,
                        hi: hi + shift,
                    })
                    .expect("meets the range");
                assert_eq!(far.len(), near.len(), "{turns} turns");
                // As close as the shifted bounds themselves can be (their rounding).
                let tol = 4.0 * f64::EPSILON * shift.abs();
                for ((a0, b0), (a1, b1)) in near.iter().zip(&far) {
                    assert!((a0 - a1).abs() <= tol && (b0 - b1).abs() <= tol, "{turns}");
                }
            }
        }
        let r = a.recommend(&AllowedRange::Bounds {
            lo: -1e308,
            hi: 1e308,
        });
        assert_eq!(r, a.recommend(&AllowedRange::Graspable));
    }

    #[test]
    fn recommendation_is_no_worse_than_a_fine_scan() {
        let c = table_1('c');
        for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
            let a = analysis(&c, objective);
            let r = a
                .recommend(&Settings::default().range)
                .expect("valid range");
            let (lo, hi) = a.from_above_range();
            for k in 0..=20_000 {
                let t = lo + (hi - lo) * k as f64 / 20_000.0;
                assert!(
                    a.evaluate(t).power >= r.gripping_power - 1e-12,
                    "{objective:?} {t}"
                );
            }
        }
    }

    /// Mean push = internal force and difference = the weight along the line, at every angle of
    /// the graspable range, for every objective (norm1 may choose α above α_min).
    #[test]
    fn mean_push_is_the_internal_force_and_the_difference_the_weight_along_the_line() {
        let grasps = [
            table_1('a'),
            table_1('b'),
            table_1('c'),
            table_1('d'),
            paper_grasp((5.0, 4.0), -3.0, (0.785, 0.785), (1.5, 2.5)),
        ];
        for c in &grasps {
            let frame = GraspFrame::new(c, 1.0).expect("valid");
            for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
                let a = Analysis::new(&frame, objective).expect("force closure");
                let (lo, hi) = a.graspable_range();
                for k in 0..=50 {
                    let theta = lo + (hi - lo) * k as f64 / 50.0;
                    let p = a.evaluate(theta);
                    let [a1, a2] = finger::pushes(&frame, &p.forces);
                    let tol = 1e-12 * frame.weight;
                    assert_abs_diff_eq!(0.5 * (a1 + a2), p.internal_force, epsilon = tol);
                    assert_abs_diff_eq!(a1 - a2, frame.weight * theta.sin(), epsilon = tol);
                    assert_abs_diff_eq!(
                        finger::finger_force(&frame, &p.forces),
                        p.internal_force + 0.5 * (frame.weight * theta.sin()).abs(),
                        epsilon = tol
                    );
                }
            }
        }
    }
}
