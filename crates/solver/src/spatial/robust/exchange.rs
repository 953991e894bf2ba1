//! The least worst case by an exchange method with a certificate (module docs §5, *Iteration
//! bounds*): the envelope of a growing sample of the region's points, minimised exactly, until
//! the certified worst case at its least is within the tolerance of it.

use super::problem::Problem;
use super::worst::AxisPoint;
use crate::planar::curve::Curve;
use crate::planar::paper::FORCE_SCALE;
use crate::planar::robust::Envelope;
use crate::sinusoid::Angle;

/// Stop adding points when the certified gap is at most this fraction of the worst case, plus
/// [`EXCHANGE_ABS`] (module docs §5).
pub const EXCHANGE: f64 = 1e-9;
/// The absolute part of the exchange method's tolerance, a fraction of the weight at the largest
/// mass: 1e-10 `m_max |g|`, 9.8e-10 N for 1 kg (module docs, *Tolerances*).
pub const EXCHANGE_ABS: f64 = 1e-10;
/// Most points added by the exchange method; past it the gap reached is reported.
pub const MAX_EXCHANGES: usize = 60;

impl Problem {
    /// The exchange method (module docs §5): the tilt, its certified gap, the final envelope
    /// and the number of points used.
    pub(super) fn exchange(&self, allowed: &[(f64, f64)]) -> (f64, f64, Envelope, usize) {
        let (lo, hi) = (allowed[0].0, allowed[allowed.len() - 1].1);
        let mut points: Vec<AxisPoint> = if self.point_region {
            vec![self.center]
        } else {
            self.region
                .vertices
                .iter()
                .map(|v| self.view.coordinates(&v.position))
                .chain(self.axis_points.iter().copied())
                .collect()
        };
        let mut tracks: Vec<Vec<_>> = points
            .iter()
            .filter_map(|p| self.analysis(p))
            .map(|a| a.pieces().collect())
            .collect();
        let mut rounds = 0;
        let mut last: Option<(usize, f64)> = None;
        loop {
            let envelope = Envelope::new(&tracks, lo, hi);
            let theta = envelope.least(allowed, self.current, FORCE_SCALE, 1.0);
            let lower = envelope.value(theta, FORCE_SCALE);
            let worst = self.worst(false, theta);
            let gap = (worst.bound - lower).max(0.0);
            if gap <= EXCHANGE * worst.value + EXCHANGE_ABS || rounds >= MAX_EXCHANGES {
                return (theta, gap, envelope, points.len());
            }
            let Some(track) = self
                .analysis(&worst.point)
                .map(|a| a.pieces().collect::<Vec<_>>())
            else {
                return (theta, gap, envelope, points.len());
            };
            // A point already sampled, or one whose curve does not rise above the envelope at
            // θ_S, leaves the envelope's least at θ_S: every later round would be this one
            // again. What is left of the gap is the rounding of the closed form of §2 against
            // the envelope's curves and its ties (module docs §5, *Iteration bounds*).
            let value = track_value(&track, theta);
            if points.contains(&worst.point) || value - lower <= (worst.value - value).abs() {
                return (theta, gap, envelope, points.len());
            }
            rounds += 1;
            // A curve nowhere on top of the envelope stays below every later one (points are
            // only added): it is dropped from the walks of later rounds.
            if !envelope.pieces.is_empty() {
                let mut on_top = vec![false; tracks.len()];
                for p in &envelope.pieces {
                    on_top[p.vertex] = true;
                }
                let mut k = 0;
                tracks.retain(|_| {
                    k += 1;
                    on_top[k - 1]
                });
            }
            points.push(worst.point);
            tracks.push(track);
            if let (Some(i), Some((j, t_last))) = (worst.segment, last) {
                if i == j {
                    self.neighbours(i, worst.t, worst.t - t_last, &mut points, &mut tracks);
                }
            }
            last = worst.segment.map(|i| (i, worst.t));
        }
    }

    /// Where the worst point moves along one edge as the exchange goes on (by `step` of the
    /// edge's parameter in the last round), the points of that edge half a step either side of
    /// it: their curves touch `R` on both sides of `θ_S`, where the single worst point's curve
    /// alone lets the next `θ_S` land (module docs §5, *Iteration bounds*). Every point of the
    /// region gives a curve below `R`, so they only tighten `R_S`.
    pub(super) fn neighbours(
        &self,
        segment: usize,
        t: f64,
        step: f64,
        points: &mut Vec<AxisPoint>,
        tracks: &mut Vec<Vec<(f64, f64, Curve)>>,
    ) {
        let s = &self.segments[segment];
        for u in [t - 0.5 * step, t + 0.5 * step] {
            let u = u.clamp(0.0, 1.0);
            if u == t || !u.is_finite() {
                continue;
            }
            let p = AxisPoint {
                xi: s.start.xi + u * (s.end.xi - s.start.xi),
                across: s.start.across + (s.end.across - s.start.across) * u,
            };
            if let Some(a) = self.analysis(&p) {
                points.push(p);
                tracks.push(a.pieces().collect());
            }
        }
    }
}

/// The value at `theta` of one object's curve given piece by piece, in the envelope's scale
/// ([`Envelope::value`]).
fn track_value(track: &[(f64, f64, Curve)], theta: f64) -> f64 {
    track
        .iter()
        .find(|p| theta <= p.1)
        .or(track.last())
        .map_or(f64::NAN, |p| p.2.power(&Angle::new(theta), FORCE_SCALE))
}
