//! The centre of mass on the contact axis: the best orientation over every plane through the axis
//! (`docs/theory.md#centre-of-mass-on-the-contact-axis`).
//!
//! # Set-up
//! Lengths over the contact distance, forces over the weight. `a` is the unit axis (contact 2 →
//! contact 1), contact 1 at `x1 a`, contact 2 at `−x2 a` from the centre of mass `c`, `x1 + x2 = 1`.
//! `(b1, b2)` is an orthonormal basis across the axis with `a × b1 = b2`, and for a *plane angle*
//! `ψ`, `v(ψ) = cos ψ b1 + sin ψ b2`, `w(ψ) = a × v(ψ)`. The plane `ψ` is span(`a`, `v`) with basis
//! `(e_x, e_y, ν) = (a, v, w)`; its paper frame has `y = 0`, and its gravity angles
//! `θ ∈ [−π/2, π/2]` give the directions `ĝ = sin θ a − cos θ v(ψ)`. Every direction is reached
//! once (the poles `±a` by every plane), so the optimum over the sphere is the optimum over
//! `(θ, ψ)`.
//!
//! # Balance
//! With gravity `ĝ`, moments about `c` give `x1 f1⊥ = x2 f2⊥` across the axis, and forces
//! `f1⊥ + f2⊥ = −ĝ⊥`, so `f1⊥ = λ1 cos θ v`, `f2⊥ = λ2 cos θ v` with the shares `λ1 = x2`,
//! `λ2 = x1`: the forces lie in the plane of the axis and gravity. Along the axis only the sum is
//! fixed: contact 1 pushes `s1` toward contact 2 and contact 2 pushes `s2 = s1 − sin θ` toward
//! contact 1. So
//!
//! ```text
//!   P²  = s1² + (s1 − sin θ)² + (λ1² + λ2²) cos²θ                       (2-norm)
//!   IF  = s1 − sin θ / 2                                                 (internal force)
//! ```
//!
//! # The cones, per plane
//! `f1 = −s1 a + λ1 cos θ v` lies in the cone at contact 1 (unit inward normal `n̂1`, half-angle
//! `ξ1`) iff `s1 >= λ1 cos θ κ1(q1)`, where with `p = n̂ · (toward the other contact) = cos δ`
//! and `q = n̂ · v`, `κ = cot τ` is the edge of the cone in the half-plane (toward other, `v`):
//!
//! ```text
//!   p κ + q = cos ξ sqrt(1 + κ²)  (larger root)  ⇒
//!   κ = (cos ξ h − p q) / (p² − cos²ξ) = (cos²ξ − q²) / (cos ξ h + p q),  h = sqrt(p² + q² − cos²ξ)
//!   dκ/dq = −(p² + q²) / (h (q cos ξ + p h)) < 0
//! ```
//!
//! Force closure (each cone contains the other contact, in every plane through the axis) is
//! `δ < ξ`, i.e. `p > cos ξ`, which keeps `h > 0` and both denominators positive. Writing
//! `A1(ψ) = λ1 κ1`, `A2(ψ) = λ2 κ2`, the feasible pushes are
//! `s1 >= max(A1 cos θ, A2 cos θ + sin θ)`, and both objectives take the least `s1` not below
//! `sin θ / 2`: the planar problem of the plane with `α_3 ↔ A1`, `α_4 ↔ A2`, crossing at
//! `tan θ_34 = A1 − A2`.
//!
//! # Which planes can be optimal
//! `q_i(ψ) = sin δ_i cos(ψ − η_i)` with `η_i` the azimuth of `n̂_i`'s part across the axis. As
//! `κ` decreases with `q`, `A_i` is least at `ψ = η_i` and grows with the distance `|ψ − η_i|` on
//! the circle. For a fixed `θ` both objectives are non-decreasing in `max(A1, A2 + tan θ)`, so:
//! - only the *Pareto arcs* between `η1` and `η2` can be optimal (the shorter arc; both arcs when
//!   `η1` and `η2` are opposite): any other plane is matched by one on the arc with both `A_i`
//!   no larger;
//! - on an arc traversed from `η1` to `η2`, `A1` increases and `A2` decreases, so
//!   `D = A1 − A2` increases, and for `tan θ <= D(η1)` the best plane is `η1`, for
//!   `tan θ >= D(η2)` it is `η2`, and in between it is the plane with `D(ψ) = tan θ`, where both
//!   contacts are about to slip: the plane's own candidate C, `θ = atan D(ψ)`.
//!
//! Hence the optimum over the sphere is the least of: the planar optimum in plane `η1`, in plane
//! `η2`, and the minimum over the arc of the objective along the curve of candidates C,
//!
//! ```text
//!   P²(ψ) = (A1² + A2² + λ1² + λ2²) / (1 + D²)    if A1 + A2 >= 0, else (D²/2 + λ1² + λ2²) / (1 + D²)
//!   IF(ψ) = max(A1 + A2, 0) / (2 sqrt(1 + D²))
//! ```
//!
//! (with the allowed range of gravity angles, also at the arc's points where `atan D` meets a bound).
//! These are closed forms with closed-form derivatives; the minima over the arc are found by
//! evaluating the derivative on a grid of [`ARC_GRID`] intervals and bisecting every sign change
//! from − to + on the derivative's sign until the bracket stops shrinking (about 1e-16 rad, at most
//! `BISECT_STEPS` halvings; the root is then limited by rounding in the derivative, ~1e-13 rad for
//! a well-curved minimum; `tests/it/spatial.rs` measures the plane of 300 random on-axis answers
//! within 3e-11 rad of the minimum of the best power over planes, which is that measurement's own
//! resolution), and the best grid point is kept as well. Each plane so found is then solved exactly by the
//! planar solver, and the least answer wins (ties within 1e-12 relative go to the smaller
//! rotation). When `δ_i = 0` (the normal along the axis) `A_i` is the same in every plane and the
//! Pareto set shrinks to the other `η`, or to nothing when both are zero (a ball or a can gripped
//! through its centre): then every plane is equally good and the plane of the current gravity
//! keeps the rotation smallest, so that plane is always among the candidates.
//!
//! Guarantees: the value is exact to rounding except that two stationary points of `P(ψ)` closer
//! than the grid spacing could hide a third minimum between them; the best grid point bounds what
//! such a miss could cost, and the independent reference (`tests/it/spatial.rs`) finds no lower point
//! on thousands of random on-axis grasps. Where a whole region of the sphere is optimal (the
//! internal force is zero on a region; the 2-norm is flat when `x1 = x2` and no squeeze is
//! needed), the answer is the best of the candidate planes with the smallest rotation, which need
//! not be the smallest rotation over the whole region.
//!
//! # The 1-norm
//! The 1-norm of `(N1, F1, N2, F2)` depends on the plane's own split of each force (module docs
//! §3), so the monotonicity above does not hold. It is minimised over the planes by the planar
//! solver on a grid of [`NORM1_GRID`] planes round the axis and golden-section search in each
//! bracketing interval to 1e-10 rad (44 steps; at most `GOLDEN_STEPS`). The value is exact to
//! rounding at the point found, but a derivative-free search locates a smooth minimum only to about 1e-8 rad (values closer than
//! that agree to rounding).

use super::answer::{AxisRelation, CurrentPose, Miss, NoForceClosure, Verdict};
use super::plane::{Basis, Geometry, PlaneSolve};
use crate::{
    planar::{ConeMiss, Recommendation},
    AllowedRange, Contact, InvalidInput, Objective, Settings,
};
use nalgebra::{Vector2, Vector3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Intervals of the grid on each Pareto arc.
pub const ARC_GRID: usize = 48;
/// Planes in the grid round the axis for the 1-norm.
pub const NORM1_GRID: usize = 96;
/// Powers closer than this, relative to themselves and the weight, tie.
const TIE: f64 = 1e-12;
/// Rotations closer than this (rad) are equal in tie-breaks.
const SAME_ROTATION: f64 = 1e-12;
/// Opposite azimuths within this many radians of π give two Pareto arcs.
const OPPOSITE: f64 = 1e-12;

/// One contact as seen from the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AxisContact {
    /// `p = cos δ`: the unit inward normal's component toward the other contact.
    pub cos_delta: f64,
    /// `sin δ`: the length of the normal's part across the axis.
    pub sin_delta: f64,
    /// `η`: the azimuth of that part about the axis (0 when it is zero).
    pub azimuth: f64,
    /// `cos ξ` of the friction cone after the safety factor.
    pub cos_xi: f64,
    /// `λ`: the share of the weight's part across the axis this contact carries.
    pub share: f64,
}

impl AxisContact {
    /// `κ = cot τ` of the cone's edge in the half-plane where the unit normal's component across
    /// the axis is `q`, and `dκ/dq` (module docs). Needs `cos δ > cos ξ`.
    ///
    /// # Formula
    /// `κ = (cos²ξ − q²)/(cos ξ h + p q)` for `q >= 0`, `(cos ξ h − p q)/(p² − cos²ξ)` for `q < 0`
    /// (equal; each free of cancellation on its side), `h = sqrt(p² + q² − cos²ξ)`,
    /// `dκ/dq = −(p² + q²)/(h (q cos ξ + p h))`.
    pub(crate) fn edge(&self, q: f64) -> (f64, f64) {
        let (p, cx) = (self.cos_delta, self.cos_xi);
        let gap = (p - cx) * (p + cx);
        let h = (gap + q * q).sqrt();
        let kappa = if q >= 0.0 {
            (cx - q) * (cx + q) / (cx * h + p * q)
        } else {
            (cx * h - p * q) / gap
        };
        let slope = -(p * p + q * q) / (h * (q * cx + p * h));
        (kappa, slope)
    }

    /// `A(ψ) = λ κ(q(ψ))` and `dA/dψ`.
    pub(crate) fn bound(&self, psi: f64) -> (f64, f64) {
        let (s, c) = (psi - self.azimuth).sin_cos();
        let (k, dk) = self.edge(self.sin_delta * c);
        (self.share * k, -self.share * dk * self.sin_delta * s)
    }
}

/// A grasp whose centre of mass is on the contact axis.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AxisGrasp {
    /// Unit axis, contact 2 → contact 1.
    pub a: Vector3<f64>,
    /// Unit `b1 ⟂ a`.
    pub b1: Vector3<f64>,
    /// Unit `b2 = a × b1`.
    pub b2: Vector3<f64>,
    /// Contact 1 at `x[0] a`, contact 2 at `−x[1] a` from the centre of mass (over the contact
    /// distance).
    pub x: [f64; 2],
    /// The two contacts.
    pub contacts: [AxisContact; 2],
}

/// The objective along the curve of candidates C, and its slope in ψ (units of the weight).
fn along_curve(grasp: &AxisGrasp, objective: Objective, psi: f64) -> (f64, f64) {
    let (a1, da1) = grasp.contacts[0].bound(psi);
    let (a2, da2) = grasp.contacts[1].bound(psi);
    let (d, dd) = (a1 - a2, da1 - da2);
    let (s, ds) = (a1 + a2, da1 + da2);
    let den = 1.0 + d * d;
    match objective {
        Objective::InternalForce => {
            if s > 0.0 {
                let r = den.sqrt();
                (0.5 * s / r, 0.5 * (ds * den - s * d * dd) / (den * r))
            } else {
                (0.0, 0.0)
            }
        }
        Objective::Norm2 | Objective::Norm1 => {
            let spread = grasp.contacts[0].share.powi(2) + grasp.contacts[1].share.powi(2);
            let (num, dnum) = if s >= 0.0 {
                (a1 * a1 + a2 * a2 + spread, 2.0 * (a1 * da1 + a2 * da2))
            } else {
                (0.5 * d * d + spread, d * dd)
            };
            (num / den, (dnum * den - num * 2.0 * d * dd) / (den * den))
        }
    }
}

/// Most halvings in [`bisect`]: a bracket of width at most 2π (an arc, or `[0, 1]`) stops
/// shrinking after at most 56 halvings where its ends are away from zero (53 bits of mantissa
/// and 3 of the width), and after at most 1,077 at zero (the exponent range down to the
/// subnormals); 200 covers the first with room, and past it the bracket is narrower than 2π ×
/// 2^-200 rad, below any angle the solver tells apart.
const BISECT_STEPS: usize = 200;
/// The bracket width, rad, at which the golden-section search of the 1-norm stops (module docs,
/// *The 1-norm*).
const GOLDEN_WIDTH: f64 = 1e-10;
/// Most steps of that search: each shrinks the bracket by the golden ratio, from two grid steps
/// `2 · 2π/NORM1_GRID` (0.131 rad) to [`GOLDEN_WIDTH`] in `ceil(ln(0.131/1e-10) / ln 1.618) = 44`
/// steps; 64 leaves room for rounding and is never reached (a `NaN` value ends the search at
/// once, as `hi − lo` then compares false).
const GOLDEN_STEPS: usize = 64;

/// `(lo + hi)/2` after bisecting `[lo, hi]` on `after_root` (false at `lo`, true at `hi`) until
/// the bracket stops shrinking, at most [`BISECT_STEPS`] times.
fn bisect(mut lo: f64, mut hi: f64, after_root: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..BISECT_STEPS {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if after_root(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

impl AxisGrasp {
    /// The grasp seen from the axis, or the cones that miss the other contact.
    pub(super) fn new(g: &Geometry) -> Result<Self, Vec<ConeMiss>> {
        let a = g.a;
        // Orthonormal (b1, b2, a), right-handed (Duff et al. 2017, branchless ONB).
        let sign = 1f64.copysign(a.z);
        let k = -1.0 / (sign + a.z);
        let m = a.x * a.y * k;
        let b1 = Vector3::new(1.0 + sign * a.x * a.x * k, sign * m, -sign * a.x);
        let b2 = Vector3::new(m, sign + a.y * a.y * k, -a.y);
        let x = [(g.p[0] - g.c).dot(&a) / g.d, (g.c - g.p[1]).dot(&a) / g.d];
        let sum = x[0] + x[1];
        let mut misses = Vec::new();
        let mut contacts = [AxisContact {
            cos_delta: 0.0,
            sin_delta: 0.0,
            azimuth: 0.0,
            cos_xi: 0.0,
            share: 0.0,
        }; 2];
        for (i, contact) in [Contact::First, Contact::Second].into_iter().enumerate() {
            let toward = if i == 0 { -a } else { a };
            let n = g.n[i];
            let cos_delta = n.dot(&toward);
            let across = n - a * n.dot(&a);
            let sin_delta = across.norm();
            let mu = g.mu[i];
            let cos_xi = 1.0 / (1.0 + mu * mu).sqrt();
            if cos_delta <= cos_xi {
                misses.push(ConeMiss {
                    contact,
                    half_angle: mu.atan(),
                    angle_to_other: sin_delta.atan2(cos_delta),
                });
            }
            contacts[i] = AxisContact {
                cos_delta,
                sin_delta,
                azimuth: if sin_delta > 0.0 {
                    across.dot(&b2).atan2(across.dot(&b1))
                } else {
                    0.0
                },
                cos_xi,
                share: x[1 - i] / sum,
            };
        }
        if misses.is_empty() {
            Ok(Self {
                a,
                b1,
                b2,
                x,
                contacts,
            })
        } else {
            Err(misses)
        }
    }

    /// The basis `(a, v(ψ), w(ψ))` of the plane `ψ`.
    pub(super) fn basis(&self, psi: f64) -> Basis {
        let (s, c) = psi.sin_cos();
        Basis {
            x: self.a,
            y: self.b1 * c + self.b2 * s,
            normal: self.b2 * c - self.b1 * s,
        }
    }

    /// The plane angle of the current gravity (0 when gravity is along the axis).
    pub(crate) fn azimuth_of(&self, g: &Vector3<f64>) -> f64 {
        // ĝ = sin θ a − cos θ v: v points against gravity's part across the axis.
        let (gx, gy) = (g.dot(&self.b1), g.dot(&self.b2));
        if gx == 0.0 && gy == 0.0 {
            0.0
        } else {
            (-gy).atan2(-gx)
        }
    }

    /// The Pareto arcs as (start `η1`, signed length to `η2`); empty when at most one normal has
    /// a part across the axis.
    pub(crate) fn pareto_arcs(&self) -> Vec<(f64, f64)> {
        let [c1, c2] = self.contacts;
        if c1.sin_delta == 0.0 || c2.sin_delta == 0.0 {
            return Vec::new();
        }
        let gap = (c2.azimuth - c1.azimuth + PI).rem_euclid(TAU) - PI;
        if gap.abs() >= PI - OPPOSITE {
            vec![(c1.azimuth, PI), (c1.azimuth, -PI)]
        } else if gap == 0.0 {
            Vec::new()
        } else {
            vec![(c1.azimuth, gap)]
        }
    }

    /// Candidate planes on one Pareto arc for the 2-norm or the internal force: the minima of the
    /// objective along the curve of candidates C, the best grid point, and the points where the
    /// curve meets an edge of the allowed gravity angles `edges`.
    pub(crate) fn arc_candidates(
        &self,
        objective: Objective,
        (start, len): (f64, f64),
        edges: &[f64],
        out: &mut Vec<f64>,
    ) {
        let at = |u: f64| start + len * u;
        // Value and slope along the traversal (u from 0 at η1 to 1 at η2).
        let eval = |u: f64| {
            let (v, s) = along_curve(self, objective, at(u));
            (v, s * len)
        };
        let mut prev = eval(0.0);
        let mut best = (0.0, prev.0);
        for k in 1..=ARC_GRID {
            let u = k as f64 / ARC_GRID as f64;
            let next = eval(u);
            if next.0 < best.1 {
                best = (u, next.0);
            }
            if prev.1 < 0.0 && next.1 >= 0.0 {
                let lo = (k - 1) as f64 / ARC_GRID as f64;
                out.push(at(bisect(lo, u, |m| eval(m).1 >= 0.0)));
            }
            prev = next;
        }
        out.push(at(best.0));
        // D = A1 − A2 increases along the traversal: where tan θ_C = D meets an edge.
        let diff = |u: f64| {
            let psi = at(u);
            self.contacts[0].bound(psi).0 - self.contacts[1].bound(psi).0
        };
        let (d0, d1) = (diff(0.0), diff(1.0));
        for &theta in edges {
            let t = theta.tan();
            if d0 < t && t < d1 {
                out.push(at(bisect(0.0, 1.0, |m| diff(m) >= t)));
            }
        }
    }
}

/// Gravity angles strictly inside `(−π/2, π/2)` where the allowed range starts or ends (planes
/// through the axis have the graspable range `[−π/2, π/2]`).
fn range_edges(range: &AllowedRange) -> Vec<f64> {
    let AllowedRange::Bounds { lo, hi } = *range else {
        return Vec::new();
    };
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Vec::new(); // the planar solver refuses these
    }
    let mut out = Vec::new();
    let first = ((-FRAC_PI_2 - hi) / TAU).floor() as i64;
    let last = ((FRAC_PI_2 - lo) / TAU).ceil() as i64;
    for k in first..=last {
        let shift = TAU * k as f64;
        for t in [lo + shift, hi + shift] {
            if t > -FRAC_PI_2 && t < FRAC_PI_2 {
                out.push(t);
            }
        }
    }
    out
}

/// The planes worth solving for the 1-norm: a grid round the axis from the current plane, and a
/// golden-section search in each interval around a grid minimum.
fn norm1_candidates(
    psi0: f64,
    power: &mut dyn FnMut(f64) -> Result<f64, Stop>,
    out: &mut Vec<f64>,
) -> Result<(), Stop> {
    let step = TAU / NORM1_GRID as f64;
    let values = (0..NORM1_GRID)
        .map(|k| power(psi0 + step * k as f64))
        .collect::<Result<Vec<f64>, Stop>>()?;
    let mut minima: Vec<usize> = (0..NORM1_GRID)
        .filter(|&k| {
            let (l, r) = (
                values[(k + NORM1_GRID - 1) % NORM1_GRID],
                values[(k + 1) % NORM1_GRID],
            );
            values[k] <= l && values[k] <= r
        })
        .collect();
    // A plateau makes every point a grid minimum; refine the lowest few.
    minima.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
    minima.truncate(6);
    let golden = 0.5 * (5f64.sqrt() - 1.0);
    for k in minima {
        let centre = psi0 + step * k as f64;
        out.push(centre);
        let (mut lo, mut hi) = (centre - step, centre + step);
        let mut x1 = hi - golden * (hi - lo);
        let mut x2 = lo + golden * (hi - lo);
        let (mut f1, mut f2) = (power(x1)?, power(x2)?);
        for _ in 0..GOLDEN_STEPS {
            if hi - lo <= GOLDEN_WIDTH {
                break;
            }
            if f1 <= f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - golden * (hi - lo);
                f1 = power(x1)?;
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + golden * (hi - lo);
                f2 = power(x2)?;
            }
        }
        out.push(if f1 <= f2 { x1 } else { x2 });
    }
    Ok(())
}

/// Why the search over planes stopped early.
#[derive(Debug)]
enum Stop {
    Invalid(InvalidInput),
    NoClosure(NoForceClosure),
}

/// One solved plane.
struct Solved<'a> {
    plane: PlaneSolve<'a>,
    answer: Recommendation,
    rotation: f64,
}

/// Solves the plane `psi` exactly with the planar solver (unit weight).
fn solve_plane<'a>(
    g: &'a Geometry,
    grasp: &AxisGrasp,
    settings: &Settings,
    psi: f64,
) -> Result<Solved<'a>, Stop> {
    let points = [
        Vector2::new(grasp.x[0], 0.0),
        Vector2::new(-grasp.x[1], 0.0),
        Vector2::zeros(),
    ];
    let plane = PlaneSolve::new(g, &grasp.basis(psi), points).map_err(|e| match e {
        Ok(miss) => Stop::NoClosure(miss),
        Err(invalid) => Stop::Invalid(invalid),
    })?;
    let answer = match plane.solve(settings).map_err(Stop::Invalid)? {
        Ok(r) => r,
        Err(miss) => return Err(Stop::NoClosure(miss)),
    };
    let (_, rotation) = plane.rotation(&answer);
    Ok(Solved {
        plane,
        answer,
        rotation,
    })
}

/// The best orientation over every plane through the axis (module docs).
pub(super) fn solve(g: &Geometry, settings: &Settings) -> Result<Verdict, InvalidInput> {
    let grasp = match AxisGrasp::new(g) {
        Ok(grasp) => grasp,
        Err(misses) => {
            return Ok(Verdict::NoForceClosure(NoForceClosure {
                misses: misses.into_iter().map(Miss::Cone).collect(),
                friction_safety_factor: g.safety,
            }))
        }
    };
    match search(g, &grasp, settings) {
        Ok(r) => Ok(r),
        Err(Stop::Invalid(e)) => Err(e),
        Err(Stop::NoClosure(miss)) => Ok(Verdict::NoForceClosure(miss)),
    }
}

/// Solves the candidate planes and keeps the best (ties to the smaller rotation).
fn search(g: &Geometry, grasp: &AxisGrasp, settings: &Settings) -> Result<Verdict, Stop> {
    let psi0 = grasp.azimuth_of(&g.g0);
    // The plane of the current gravity: its current-pose answer, and the first candidate (so
    // that ties keep the object in it).
    let mut best = solve_plane(g, grasp, settings, psi0)?;
    let current = (
        best.answer.gripping_power_current,
        best.answer.internal_force_current,
        best.answer.finger_force_current,
    );
    let mut planes = Vec::with_capacity(8);
    match settings.objective {
        Objective::Norm1 => {
            let mut power =
                |psi: f64| solve_plane(g, grasp, settings, psi).map(|s| s.answer.gripping_power);
            norm1_candidates(psi0, &mut power, &mut planes)?;
        }
        Objective::Norm2 | Objective::InternalForce => {
            for c in &grasp.contacts {
                if c.sin_delta > 0.0 {
                    planes.push(c.azimuth);
                }
            }
            let edges = range_edges(&settings.range);
            for arc in grasp.pareto_arcs() {
                grasp.arc_candidates(settings.objective, arc, &edges, &mut planes);
            }
        }
    }
    for psi in planes {
        let s = solve_plane(g, grasp, settings, psi)?;
        if better(&s, &best) {
            best = s;
        }
    }
    let mut out = best
        .plane
        .assemble(best.answer, CurrentPose::Held, AxisRelation::OnAxis);
    // Every plane through the axis holds; the current pose is solved in its own plane.
    out.planar.gripping_power_current = current.0 * g.weight;
    out.planar.internal_force_current = current.1 * g.weight;
    out.planar.finger_force_current = current.2 * g.weight;
    Ok(Verdict::Recommended(Box::new(out)))
}

/// Whether `s` beats `b`: lower power, or a tie (1e-12 relative, unit weight) with a rotation
/// smaller by more than [`SAME_ROTATION`] (so that equal answers keep the earlier plane, the
/// current one first).
fn better(s: &Solved, b: &Solved) -> bool {
    let (p, q) = (s.answer.gripping_power, b.answer.gripping_power);
    if (p - q).abs() <= TIE * p.abs().max(q.abs()).max(1.0) {
        s.rotation < b.rotation - SAME_ROTATION
    } else {
        p < q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact(cos_delta: f64, mu: f64) -> AxisContact {
        AxisContact {
            cos_delta,
            sin_delta: (1.0 - cos_delta * cos_delta).sqrt(),
            azimuth: 0.3,
            cos_xi: 1.0 / (1.0 + mu * mu).sqrt(),
            share: 0.4,
        }
    }

    /// `κ` is the edge of the cone: the direction `κ·(toward) + v` is on the cone's surface, and
    /// slightly less push leaves it; its derivative matches a central difference.
    #[test]
    fn edge_lies_on_the_cone_and_its_slope_matches() {
        for (cos_delta, mu) in [(0.99, 0.5), (0.8, 1.2), (0.999_999, 0.01), (0.6, 3.0)] {
            let c = contact(cos_delta, mu);
            let (p, sd, cx) = (c.cos_delta, c.sin_delta, c.cos_xi);
            for k in 0..=40 {
                let q = -sd + 2.0 * sd * k as f64 / 40.0;
                let (kappa, slope) = c.edge(q);
                // Unit normal (p, q, r) in the frame (toward, v, w); the edge direction (κ, 1, 0).
                let len = (1.0 + kappa * kappa).sqrt();
                let cos_angle = (p * kappa + q) / len;
                assert!((cos_angle - cx).abs() < 1e-12, "{cos_delta} {mu} {q}");
                let h = 1e-6;
                let fd = (c.edge(q + h).0 - c.edge(q - h).0) / (2.0 * h);
                assert!((fd - slope).abs() < 1e-5 * slope.abs().max(1.0));
                // Less push leaves the cone.
                let k2 = kappa - 1e-6 * kappa.abs().max(1.0);
                assert!((p * k2 + q) / (1.0 + k2 * k2).sqrt() < cx);
            }
        }
    }

    #[test]
    fn along_curve_slope_matches_central_difference() {
        let grasp = AxisGrasp {
            a: Vector3::x(),
            b1: Vector3::y(),
            b2: Vector3::z(),
            x: [0.4, 0.6],
            contacts: [
                AxisContact {
                    azimuth: 0.2,
                    share: 0.6,
                    ..contact(0.9, 0.8)
                },
                AxisContact {
                    azimuth: 1.9,
                    share: 0.4,
                    ..contact(0.95, 0.6)
                },
            ],
        };
        for objective in [Objective::Norm2, Objective::InternalForce] {
            for k in 0..50 {
                let psi = -3.0 + 0.12 * k as f64;
                let (_, slope) = along_curve(&grasp, objective, psi);
                let h = 1e-6;
                let fd = (along_curve(&grasp, objective, psi + h).0
                    - along_curve(&grasp, objective, psi - h).0)
                    / (2.0 * h);
                assert!(
                    (fd - slope).abs() < 1e-6,
                    "{objective:?} {psi}: {fd} {slope}"
                );
            }
        }
    }
}
