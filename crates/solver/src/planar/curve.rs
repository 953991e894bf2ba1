//! The objective on one piece of a curve over the gravity angle, and the walk that finds the
//! local minima of a curve made of such pieces (`docs/theory.md#exact-minimisation`).
//!
//! With `k = weight · FORCE_SCALE`, the objective is `k · sqrt(Q)` on a [`Curve::Quad`] piece (the
//! 2-norm; `Q` a quadratic form in `(sin θ, cos θ)`) and `k · S` on a [`Curve::Sin`] piece (the
//! 1-norm and the internal force; `S` a sinusoid). Both are monotone in `Q` or `S`, so the sign of
//! `Q`'s or `S`'s slope is the objective's. The nominal analysis (`analysis.rs`) and the robust
//! envelope (`robust/envelope.rs`) are both made of such pieces and share this walk.

use super::answer::{LocalMinimum, PaperCandidate};
use crate::sinusoid::{next_periodic, Angle, QuadForm, Sinusoid};
use std::f64::consts::{PI, TAU};

/// Two local minima closer than this, rad, are one.
pub(crate) const SAME_ANGLE: f64 = 1e-9;

/// `Q` or `S` of one piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Curve {
    /// `Q`, a quadratic form in `(sin θ, cos θ)` (the 2-norm squared).
    Quad(QuadForm),
    /// `S`, a sinusoid (the 1-norm, the internal force).
    Sin(Sinusoid),
}

impl Curve {
    /// `Q` or `S` at `at`; monotone in the objective.
    pub(crate) fn value(&self, at: &Angle) -> f64 {
        match self {
            Curve::Quad(q) => q.value(at),
            Curve::Sin(s) => s.value(at),
        }
    }

    /// Sign-faithful derivative of `Q` or `S`: the sign of the objective's slope.
    pub(crate) fn slope(&self, at: &Angle) -> f64 {
        match self {
            Curve::Quad(q) => q.slope(at),
            Curve::Sin(s) => s.slope(at),
        }
    }

    /// The objective in newtons, `k sqrt(Q)` or `k S`.
    pub(crate) fn power(&self, at: &Angle, k: f64) -> f64 {
        match self {
            Curve::Quad(q) => k * q.value(at).max(0.0).sqrt(),
            Curve::Sin(s) => k * s.value(at),
        }
    }

    /// The size of the coefficients, which bounds the rounding of a value.
    pub(crate) fn coefficient_scale(&self) -> f64 {
        match self {
            Curve::Quad(q) => q.p.abs() + q.q.abs() + q.r.abs(),
            Curve::Sin(s) => s.a.abs() + s.b.abs(),
        }
    }

    /// Whether `Q` or `S` is constant (then every point of the piece is a minimum).
    pub(crate) fn is_constant(&self) -> bool {
        match self {
            Curve::Quad(q) => q.is_constant(),
            Curve::Sin(s) => s.is_zero(),
        }
    }

    /// Stationary minima strictly inside `(lo, hi)`, appended to `out`.
    pub(crate) fn minima_between(&self, lo: f64, hi: f64, out: &mut impl Extend<f64>) {
        match self {
            Curve::Quad(q) => q.minima_between(lo, hi, out),
            Curve::Sin(s) => s.minima_between(lo, hi, out),
        }
    }

    /// Stationary maxima strictly inside `(lo, hi)`, appended to `out`: the minima of `-Q` or
    /// `-S`.
    pub(crate) fn maxima_between(&self, lo: f64, hi: f64, out: &mut impl Extend<f64>) {
        match self {
            Curve::Quad(q) => QuadForm {
                p: -q.p,
                q: -q.q,
                r: -q.r,
            }
            .minima_between(lo, hi, out),
            Curve::Sin(s) => s.scaled(-1.0).minima_between(lo, hi, out),
        }
    }

    /// The first angle strictly after `after` where `other` rises through `self`, if any
    /// (module docs of `robust`, section 6).
    ///
    /// # Formula
    /// Sinusoids: `other - self` rises through zero at `-atan2(b, a) (mod 2π)`.
    /// Quadratic forms: `other - self = m + ρ cos(2θ - φ)` rises through zero at
    /// `θ = (φ - acos(-m/ρ)) / 2 (mod π)` when `|m| <= ρ`.
    pub(crate) fn next_overtaken(&self, other: &Curve, after: f64) -> Option<f64> {
        match (self, other) {
            (Curve::Sin(s), Curve::Sin(o)) => o
                .minus(s)
                .rising_zero()
                .map(|r| next_periodic(r, TAU, after)),
            (Curve::Quad(s), Curve::Quad(o)) => quad_rising_zero(&QuadForm {
                p: o.p - s.p,
                q: o.q - s.q,
                r: o.r - s.r,
            })
            .map(|r| next_periodic(r, PI, after)),
            // One objective gives one kind of curve to every vertex.
            _ => None,
        }
    }
}

/// The angle, mod π, where the quadratic form rises through zero; `None` where it never does.
///
/// # Formula
/// `p sin²θ + q cos²θ + r sin θ cos θ = m + A cos 2θ + B sin 2θ = m + ρ cos(2θ - φ)` with
/// `m = (p+q)/2`, `A = (q-p)/2`, `B = r/2`, `ρ = hypot(A, B)`, `φ = atan2(B, A)`. Its slope is
/// `-2ρ sin(2θ - φ)`, positive where `2θ - φ ∈ (-π, 0)`, so the rising zero is
/// `2θ - φ = -acos(-m/ρ)`.
pub(crate) fn quad_rising_zero(d: &QuadForm) -> Option<f64> {
    let m = 0.5 * (d.p + d.q);
    let (a, b) = (0.5 * (d.q - d.p), 0.5 * d.r);
    let rho = (a * a + b * b).sqrt();
    if rho == 0.0 || m.abs() > rho {
        return None;
    }
    Some(0.5 * (b.atan2(a) - (-m / rho).acos()))
}

/// One piece of a curve: `curve` on `[lo, hi]`, with its stationary minima inside.
pub(crate) trait Piece {
    /// Where the piece starts.
    fn lo(&self) -> Angle;
    /// Where it ends.
    fn hi(&self) -> Angle;
    /// `Q` or `S` on it.
    fn curve(&self) -> &Curve;
    /// Its stationary minima strictly inside `(lo, hi)`, in increasing angle.
    fn minima(&self) -> impl Iterator<Item = Angle> + '_;
}

/// Every local minimum of the curve made of `pieces` (in increasing angle, tiling its interval),
/// in increasing angle:
/// - a piece's start where the slope turns from `<= 0` to `>= 0` (the interval's start counts
///   as reached falling: a curve that rises from it has a minimum there);
/// - each piece's stationary minima;
/// - the interval's end where the curve falls into it.
///
/// Minima closer than `SAME_ANGLE` (1e-9 rad) to the one before are one. A piece narrower than
/// `SAME_ANGLE` is left out: where two breakpoints are the same angle (the start of the range and
/// a paper candidate, say), rounding can leave a sliver between them whose curve has the other
/// slope, and its start would be a minimum in one frame of the same scene and not in another.
/// `power` gives the objective of a minimum in newtons, and `label` the paper's candidate it
/// coincides with.
pub(crate) fn local_minima<P: Piece>(
    pieces: &[P],
    power: impl Fn(&Angle, &Curve) -> f64,
    label: impl Fn(f64) -> Option<PaperCandidate>,
) -> Vec<LocalMinimum> {
    let wide = |p: &&P| p.hi().theta - p.lo().theta >= SAME_ANGLE;
    let slivers_only = !pieces.iter().any(|p| wide(&p));
    let mut found: Vec<LocalMinimum> = Vec::with_capacity(8);
    let mut push = |at: &Angle, curve: &Curve| {
        let theta = at.theta;
        if found
            .last()
            .is_none_or(|m| (theta - m.gravity_angle).abs() > SAME_ANGLE)
        {
            found.push(LocalMinimum {
                gravity_angle: theta,
                power: power(at, curve),
                label: label(theta),
            });
        }
    };
    let mut before: Option<&P> = None;
    for piece in pieces.iter().filter(|p| slivers_only || wide(p)) {
        let lo = piece.lo();
        let right = piece.curve().slope(&lo);
        let left = before.map_or(f64::NEG_INFINITY, |b| b.curve().slope(&lo));
        if left <= 0.0 && right >= 0.0 {
            push(&lo, piece.curve());
        }
        for t in piece.minima() {
            push(&t, piece.curve());
        }
        before = Some(piece);
    }
    if let Some(last) = before {
        let hi = last.hi();
        if last.curve().slope(&hi) <= 0.0 {
            push(&hi, last.curve());
        }
    }
    found
}

/// Up to two angles, collected without allocating (a piece shorter than 2π has at most two
/// stationary minima).
#[derive(Debug, Default)]
pub(crate) struct AtMostTwo {
    pub(crate) values: [f64; 2],
    pub(crate) len: usize,
}

impl Extend<f64> for AtMostTwo {
    fn extend<I: IntoIterator<Item = f64>>(&mut self, iter: I) {
        for v in iter {
            if self.len < 2 {
                self.values[self.len] = v;
                self.len += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_rising_zero_is_a_rising_zero() {
        for &(p, q, r) in &[
            (1.0, -2.0, 0.5),
            (-0.3, 0.2, 1.0),
            (0.0, 0.0, -1.0),
            (2.0, -0.1, -3.0),
        ] {
            let d = QuadForm { p, q, r };
            let t = quad_rising_zero(&d).expect("crosses zero");
            let at = Angle::new(t);
            assert!(d.value(&at).abs() < 1e-12, "{p} {q} {r}: {}", d.value(&at));
            assert!(d.slope(&at) > 0.0);
        }
        assert_eq!(
            quad_rising_zero(&QuadForm {
                p: 1.0,
                q: 2.0,
                r: 0.1
            }),
            None
        );
    }
}
