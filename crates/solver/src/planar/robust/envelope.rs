//! The upper envelope of the region's curves over the gravity angle, piece by piece, and its
//! exact minimum (module docs of `planar::robust`, section 6).

use crate::planar::curve::{self, Curve, Piece};
use crate::planar::LocalMinimum;
use crate::sinusoid::{wrap_angle, Angle};
use std::f64::consts::TAU;

/// Objective values closer than this, relative to themselves or to the weight, tie; the smaller
/// wrist rotation wins (as in the nominal analysis).
const TIE: f64 = 1e-12;
/// Curves closer than this, relative to the largest, are level on the envelope; the steeper
/// one goes on top.
const ENVELOPE_TIE: f64 = 1e-12;

/// One piece of the worst-case curve: on `[lo, hi]` vertex `vertex` is on top with `curve`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TopPiece {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) vertex: usize,
    pub(crate) curve: Curve,
    /// The curve's stationary minima strictly inside `(lo, hi)` (at most two in a piece shorter
    /// than 2π), set once the piece is complete.
    pub(crate) minima: [f64; 2],
    /// How many of `minima` are set.
    pub(crate) n_minima: usize,
}

impl TopPiece {
    pub(crate) fn minima(&self) -> &[f64] {
        &self.minima[..self.n_minima]
    }
}

impl Piece for TopPiece {
    fn lo(&self) -> Angle {
        Angle::new(self.lo)
    }

    fn hi(&self) -> Angle {
        Angle::new(self.hi)
    }

    fn curve(&self) -> &Curve {
        &self.curve
    }

    fn minima(&self) -> impl Iterator<Item = Angle> + '_ {
        TopPiece::minima(self).iter().map(|&t| Angle::new(t))
    }
}

/// The upper envelope of finitely many objects' curves over an interval of gravity angles, piece
/// by piece (module docs, section 6), and its exact minimum.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Envelope {
    /// The pieces in increasing angle, tiling the interval.
    pub(crate) pieces: Vec<TopPiece>,
}

impl Envelope {
    /// The envelope over `[lo, hi]` of the curves `tracks[k]`, each given piece by piece and
    /// covering `[lo, hi]`.
    pub(crate) fn new(tracks: &[Vec<(f64, f64, Curve)>], lo: f64, hi: f64) -> Self {
        Self {
            pieces: envelope(tracks, lo, hi),
        }
    }

    /// The value on top at `theta` (inside the interval), N, for curves scaled by `k`.
    pub(crate) fn value(&self, theta: f64, k: f64) -> f64 {
        let piece = self
            .pieces
            .iter()
            .find(|p| theta <= p.hi)
            .or(self.pieces.last());
        piece.map_or(f64::NAN, |p| p.curve.power(&Angle::new(theta), k))
    }

    /// The gravity angle of least value over the closed intervals `allowed` (inside the
    /// envelope's interval), for curves scaled by `k` (objective = `k sqrt(Q)` or `k S`); ties
    /// within `TIE` (relative to the values or to `weight`) go to the angle nearer `current`
    /// (module docs, section 6).
    pub(crate) fn least(&self, allowed: &[(f64, f64)], current: f64, k: f64, weight: f64) -> f64 {
        let rotation_to = |theta: f64| wrap_angle(current - theta).abs();
        let mut best: Option<(f64, f64)> = None;
        let mut consider = |theta: f64, power: f64| {
            let better = match best {
                None => true,
                Some((bt, bp)) => {
                    let tie = (power - bp).abs() <= TIE * bp.abs().max(power.abs()).max(weight);
                    if tie {
                        rotation_to(theta) < rotation_to(bt)
                    } else {
                        power < bp
                    }
                }
            };
            if better {
                best = Some((theta, power));
            }
        };
        let mut points = Vec::with_capacity(6);
        for piece in &self.pieces {
            for &(a, b) in allowed {
                let (lo, hi) = (piece.lo.max(a), piece.hi.min(b));
                if lo > hi {
                    continue;
                }
                points.clear();
                points.extend([lo, hi]);
                points.extend(piece.minima().iter().filter(|&&t| t > lo && t < hi));
                if piece.curve.is_constant() {
                    points.push(current.clamp(lo, hi));
                }
                for &t in &points {
                    consider(t, piece.curve.power(&Angle::new(t), k));
                }
            }
        }
        // The allowed intervals lie inside the graspable range, which the envelope covers.
        best.map_or(allowed[0].0, |(t, _)| t)
    }

    /// The highest value on `[a, b]` (inside the envelope's interval), for curves scaled by
    /// `k`: the largest of the values at `a`, `b`, the piece boundaries between them and the
    /// pieces' stationary maxima between them (each piece is one curve, so its maximum over an
    /// interval is at an end or a stationary point).
    pub(crate) fn highest_between(&self, a: f64, b: f64, k: f64) -> f64 {
        let mut top = f64::NEG_INFINITY;
        let mut inside = Vec::with_capacity(2);
        for piece in self.pieces.iter().filter(|p| p.hi >= a && p.lo <= b) {
            let (lo, hi) = (piece.lo.max(a), piece.hi.min(b));
            inside.clear();
            piece.curve.maxima_between(lo, hi, &mut inside);
            for &t in [lo, hi].iter().chain(inside.iter()) {
                top = top.max(piece.curve.power(&Angle::new(t), k));
            }
        }
        top
    }

    /// Every local minimum of the envelope over its whole interval, for curves scaled by `k`,
    /// unlabelled (the paper's candidates belong to one object).
    pub(crate) fn local_minima(&self, k: f64) -> Vec<LocalMinimum> {
        curve::local_minima(&self.pieces, |at, c| c.power(at, k), |_| None)
    }
}

/// `[lo, hi]` shifted by every multiple of 2π, met with `[glo, ghi]`.
pub(crate) fn periodic_meet(lo: f64, hi: f64, glo: f64, ghi: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(3);
    let first = ((glo - hi) / TAU).floor() as i64;
    let last = ((ghi - lo) / TAU).ceil() as i64;
    for k in first..=last {
        let shift = TAU * k as f64;
        let (a, b) = ((lo + shift).max(glo), (hi + shift).min(ghi));
        if a <= b {
            out.push((a, b));
        }
    }
    out
}

/// Index of the highest curve at `t` among the vertices' current pieces; near-ties go to the
/// steeper one (it stays on top).
pub(crate) fn top_at(tracks: &[Vec<(f64, f64, Curve)>], idx: &[usize], t: f64) -> usize {
    let at = Angle::new(t);
    let value = |k: usize| tracks[k][idx[k]].2.value(&at);
    let top = (0..tracks.len())
        .map(value)
        .fold(f64::NEG_INFINITY, f64::max);
    // The rounding of a value is relative to the coefficients, not to the value: at a crossing
    // computed in closed form a steep curve can come out below a flat one by that much.
    let scale = (0..tracks.len())
        .map(|k| tracks[k][idx[k]].2.coefficient_scale())
        .fold(0.0, f64::max);
    let tol = ENVELOPE_TIE * scale.max(f64::MIN_POSITIVE);
    let mut best = 0;
    let mut best_slope = f64::NEG_INFINITY;
    for k in 0..tracks.len() {
        if value(k) >= top - tol {
            let s = tracks[k][idx[k]].2.slope(&at);
            if s > best_slope {
                best = k;
                best_slope = s;
            }
        }
    }
    best
}

/// The upper envelope over `[lo, hi]` of the vertices' curves, each given piece by piece
/// (`tracks[k]`, covering `[lo, hi]`), walked from `lo` (module docs, section 6).
///
/// Each step ends at the next end of any vertex's piece or the next point where another
/// vertex's curve rises through the top one. In a range shorter than 2π two pieces cross at
/// most twice, so the steps number at most `(2V + 1) n + 1` for `V` vertices with `n` pieces in
/// all; the loop's bound is never reached.
pub(crate) fn envelope(tracks: &[Vec<(f64, f64, Curve)>], lo: f64, hi: f64) -> Vec<TopPiece> {
    if tracks.iter().any(Vec::is_empty) || lo >= hi {
        return Vec::new();
    }
    let n_pieces: usize = tracks.iter().map(Vec::len).sum();
    let mut idx: Vec<usize> = tracks
        .iter()
        .map(|tr| tr.iter().position(|p| p.1 > lo).unwrap_or(tr.len() - 1))
        .collect();
    let mut out: Vec<TopPiece> = Vec::with_capacity(2 * tracks.len() + 4);
    let mut t = lo;
    let mut top = top_at(tracks, &idx, t);
    // `overtake[j]`: the next point after `t` where vertex j's piece rises through the top
    // piece, kept while neither piece changes (`NaN`: to be computed).
    let mut overtake = vec![f64::NAN; tracks.len()];
    for _ in 0..(2 * tracks.len() + 1) * n_pieces + 2 {
        let (_, top_hi, top_curve) = tracks[top][idx[top]];
        let mut next = hi.min(top_hi);
        for (j, tr) in tracks.iter().enumerate() {
            if j == top {
                continue;
            }
            let (_, j_hi, j_curve) = tr[idx[j]];
            next = next.min(j_hi);
            if overtake[j].is_nan() || overtake[j] <= t {
                overtake[j] = top_curve
                    .next_overtaken(&j_curve, t)
                    .unwrap_or(f64::INFINITY);
            }
            next = next.min(overtake[j]);
        }
        match out.last_mut() {
            Some(last) if last.vertex == top && last.curve == top_curve && last.hi == t => {
                last.hi = next;
            }
            _ => out.push(TopPiece {
                lo: t,
                hi: next,
                vertex: top,
                curve: top_curve,
                minima: [0.0; 2],
                n_minima: 0,
            }),
        }
        if next >= hi {
            break;
        }
        t = next;
        let mut top_moved = false;
        for (k, tr) in tracks.iter().enumerate() {
            while idx[k] + 1 < tr.len() && tr[idx[k]].1 <= t {
                idx[k] += 1;
                overtake[k] = f64::NAN;
                top_moved |= k == top;
            }
        }
        let new_top = top_at(tracks, &idx, t);
        if top_moved || new_top != top {
            overtake.fill(f64::NAN);
        }
        top = new_top;
    }
    let mut found = Vec::with_capacity(2);
    for piece in &mut out {
        found.clear();
        piece.curve.minima_between(piece.lo, piece.hi, &mut found);
        piece.n_minima = found.len().min(2);
        piece.minima[..piece.n_minima].copy_from_slice(&found[..piece.n_minima]);
    }
    out
}
