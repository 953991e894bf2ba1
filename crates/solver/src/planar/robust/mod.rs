//! Uncertain mass and centre of mass, planar model: the orientation whose worst case,
//! over every object the stated uncertainty allows, needs the least gripping power. The sections
//! below are the derivation; `docs/theory.md#robust-worst-case-planar` gives it in prose.
//!
//! The candidate's `center_of_mass` is known to within a box of half-widths
//! `center_of_mass_tolerance` along the x and y axes of the candidate frame, and its `mass` to
//! within `± mass_tolerance`; friction is `μ / s` as everywhere (the safety factor). The answer
//! minimises, over the allowed orientations, the worst case of the objective over all of these
//! objects, and reports that worst case. With every tolerance zero, [`solve`] is
//! [`super::solve`] itself, so the answer is today's bit for bit.
//!
//! # 1. At one orientation the worst case lies at a vertex
//! Take moments about a point fixed in the object, not about the centre of mass `c`. At a fixed
//! gravity direction `u` (unit, object frame) the balance (4) reads
//!
//! ```text
//!     Σ f_i = -m|g| u,      Σ p_i × f_i = -c × (m|g| u)
//! ```
//!
//! linear in the contact forces `F = (N1, F1, N2, F2)` with a matrix `L` that depends on the
//! contacts only; `c` enters only the right-hand side `b(c, m)`, affinely (the moment row), and
//! `m` linearly. The contact conditions (11)–(16) are a fixed polyhedral cone `A F >= 0`. Under
//! force closure the squeeze direction `F_N` (the kernel of `L`) meets every condition strictly,
//! so every `c` and every `u` have feasible forces: force closure does not depend on `c`.
//! - **`norm2`, `norm1`**: `P(c) = min { ||F|| : L F = b(c), A F >= 0 }`. If `F_a`, `F_b` are
//!   optimal at `c_a`, `c_b`, then `λ F_a + (1-λ) F_b` is feasible at `λ c_a + (1-λ) c_b` (the
//!   equality is affine in `(F, c)`, the cone is convex), and its norm is at most
//!   `λ P(c_a) + (1-λ) P(c_b)` (triangle inequality and homogeneity). So `P` is convex in `c`.
//!   What this needs: the objective is a norm of `F` (any norm: the 2-norm and the 1-norm both
//!   qualify), `L` and `A` do not depend on `c`, and `b` is affine in `c`.
//! - **`internal_force`**: `F_T ⟂ F_N`, so the squeeze `α` of `F = F_T + α F_N` is the linear
//!   functional `⟨F, F_N⟩ / |F_N|²`, and `α_min(c)` is the value of a linear program with the same
//!   feasible set: convex by the same argument, with `|·|` replaced by a linear function.
//!   Directly: at fixed θ each bound `α_k` (eqs. 30–33) is affine in `(x1, x2, y)`, hence in `c`,
//!   and `α_min = max_k α_k` is a maximum of affine functions. `max(α_min, 0)` is convex too;
//!   it is also the internal force reported with `norm2`.
//! - **The internal force reported under `norm1`** is the squeeze of the 1-norm's optimal forces:
//!   an argmin, not a minimum value, and it is *not* convex in `c` (section 5).
//! - A convex function on a convex polygon is largest at a vertex. The region of centres of mass
//!   is a convex polygon (section 3), so the worst `P` at each orientation is the largest of the
//!   vertices' `P`. Every force is proportional to `m` at fixed `c` and `u` (`b` is linear in `m`
//!   and the conditions are a cone), so the worst mass is the largest, `m + Δm`, for every
//!   quantity that is positive; the 1-norm's squeeze can be negative, and is then largest at the
//!   smallest mass. A smaller
//!   friction coefficient shrinks the cone, so the worst friction is `μ / s`.
//!
//! Test: `tests/it/robust.rs` evaluates a dense grid of centres of mass over the region and masses
//! over the interval with the independent reference of `tests/it/util`; no grid point is worse
//! than the vertices (to 1e-9).
//!
//! # 2. One angle for every vertex
//! The paper frame of a grasp has its origin at the centre of mass but its axes fixed by the
//! contacts (`e_x` along the contact line from contact 2 to contact 1, `e_y` so that the contacts
//! have `y >= 0`): moving `c` moves the origin and keeps the axes, unless `c` crosses the contact
//! line, where the labelling swaps. Every vertex's frame is therefore built here from the nominal
//! frame (`GraspFrame::new` of the candidate) with the nominal's axes and labelling, only the
//! coordinates moving: for a vertex at `c + δ`, with `(δx', δy') = (δ·e_x, δ·e_y) / d`,
//! `x1' = x1 - δx'`, `x2' = x2 + δx'`, `y' = y - δy'`. Then one gravity angle θ is one
//! orientation of the object for every vertex, and the answer maps back to the candidate frame
//! exactly as the nominal's does (`wrist_rotation`, `gravity_direction`). A vertex with `y' < 0`
//! lies across the contact line from the nominal centre of mass: see section 4.
//!
//! # 3. The region: the box, cut by the object
//! The centre of mass of a convex object lies inside it, hence on the inner side of both surface
//! tangents at the contacts. Where the box reaches past a tangent line, no object convex there can
//! have its centre of mass there, so the region used is the box cut by the tangent half-planes: a
//! convex polygon of at most six vertices (each cut adds at most one). Objects need not be convex
//! (`docs/theory.md#a-centre-of-mass-behind-a-tangent`): a tangent the nominal centre of mass lies
//! behind (by more than [`BEHIND_TANGENT`](crate::BEHIND_TANGENT) of its distance from the
//! contact) shows that the object is not convex at that contact, so it cuts nothing; one the
//! nominal lies on (to that rounding)
//! gives way to it. Nothing below needs the cuts: the worst case (section 1) and the ranges
//! (section 4) hold for any convex polygon, but for one statement of section 4, which says so. This keeps every object the candidate allows and no
//! object it rules out, so the worst case is exact rather than over-cautious, and a node-wide
//! tolerance still works on thin objects, whose box would otherwise always stick out. Section 1
//! holds for any convex polygon. The vertices are reported as [`BoxPoint`]s: box corners, or
//! points where the box meets a tangent.
//!
//! # 4. The allowed range: every object in the region must allow the orientation
//! - **From above** (the object hangs below the fingers): for one `c`, gravity `u` is allowed when
//!   `c` lies in the half-strip `H_u` swept from the contact segment along `u`. `H_u` is convex,
//!   so the region lies in it exactly when its vertices do: the range is the intersection of the
//!   vertices' ranges `[-atan2(x1', y'), atan2(x2', y')]`, all inside `[-π/2, π/2]`.
//! - **Graspable** (8): for one `c`, the excluded directions are those from `c` into the contact
//!   segment. Over the region these are the directions of the convex set
//!   `{q - c : q on the segment, c in the region}`, an arc: the *angular hull* of the vertices'
//!   excluded arcs, not their union. The intersection of the vertices' ranges taken as intervals
//!   `[θ_min', θ_max']` on the paper's line (all contain `[-π/2, π/2]`, all excluded arcs lie in
//!   `(π/2, 3π/2)`) is exactly the complement of that hull, so it is the region's range. The
//!   intersection taken as sets on the circle is *not*: a wide box below a short segment leaves a
//!   gap straight up between its corners' arcs, where the box's middle rests on the fingers (test
//!   `graspable_range_is_the_hull_not_the_union`).
//! - **Bounds**: the bounds, shifted by multiples of 2π, met with the region's graspable range.
//! - **Across the contact line**: a region with vertices on both sides of the contact line meets
//!   the segment when both tangents cut it (it lies within both tangent half-planes, whose
//!   intersection with the line is the segment); a region a tangent does not cut may cross the line
//!   beyond a contact instead, and is refused all the same (cautious: objects beyond the contacts on
//!   the line could share an orientation). Then no orientation suits every object: objects on both sides hang below the
//!   fingers at no orientation, and for gravity with any component across the line the objects
//!   just beside the segment on one side rest on the fingers. Only gravity exactly along the line
//!   is left, one direction no wrist can hold to, so this is refused rather than handled: the
//!   answer is [`Verdict::NoCommonOrientation`], naming the vertex across the line;
//!   likewise when the vertices' ranges do not meet (naming the two that bound it) or the bounds
//!   miss the region's range. The nominal answer is given with it. (A vertex within 1e-12 of the
//!   contact distance across the line counts as on it.)
//!
//! # 5. The internal force under `norm1`
//! On the feasible ray `α >= α_min`, `||F_T + α F_N||_1` has slope `s1 + s2 + |c1| σ1 + |c2| σ2`,
//! where `σ_i = ±1` says whether α is past `β_i`, the zero of friction force `i`
//! (`β_i = -T_Fi / c_i`; the normal forces' zeros are `α_1, α_2 <= α_min`). These slopes depend
//! on neither `c` nor θ. Past one zero the slope is positive (`s_i + |c_i| >= 1 >= |c_j|` and
//! `s_j > 0`), so the 1-norm's squeeze is `max(α_min, h)` with `h = -∞` when
//! `s1 + s2 >= |c1| + |c2|` and `h = min(β_1, β_2)` otherwise: concave in `c`, each `β_i` being
//! affine in `c` (test `norm1_squeeze_is_alpha_min_or_a_friction_zero`). So
//! `max over the region of max(α_min, h) = max(max α_min, max h)` is attained at a vertex or
//! where the line `β_1 = β_2` crosses the region's edge (at most two points, the pieces of `h`
//! being affine on either side), and those points are evaluated. On random grasps whose normals
//! lean far from the contact line the worst squeeze lies inside an edge, up to a fifth above
//! every vertex (`tests/it/robust.rs`, `norm1_internal_force_worst_case_over_the_region`).
//!
//! # 6. The exact minimisation
//! The worst-case objective `R(θ) = max_v P_v(θ)` is the upper envelope of the vertices' curves.
//! Each `P_v` is already known in closed form piece by piece ([`Analysis`]): `k sqrt(Q)` with `Q`
//! a quadratic form in `(sin θ, cos θ)` for `norm2`, `k S` with `S` a sinusoid otherwise (`k` is
//! the same for every vertex, `m_max |g| / 2`). The envelope is walked from the start of the
//! region's graspable range: the vertex on top stays on top until the end of its piece, the end
//! of another vertex's piece, or the first point where another vertex's curve rises through it,
//! a closed form:
//! - two sinusoids: their difference is a sinusoid, rising through zero at `-atan2(b, a)`;
//! - two quadratic forms: `Q_j - Q_i = m + A cos 2θ + B sin 2θ = m + ρ cos(2θ - φ)` with
//!   `m = (p+q)/2`, `A = (q-p)/2`, `B = r/2`, `φ = atan2(B, A)`, `ρ = hypot(A, B)`; it rises
//!   through zero at `θ = (φ - acos(-m/ρ)) / 2 (mod π)` when `|m| <= ρ`, and never otherwise.
//!
//! On each piece of the envelope one vertex's curve is on top. A minimum of `R` inside a piece is
//! a stationary minimum of *that* curve; a stationary point of a curve that is not on top is not
//! a point of `R` at all. A minimum of `R` at a piece boundary is either a kink of one vertex's
//! own curve or a crossing where one vertex's falling curve meets another's rising one, a "V"
//! whose bottom is no stationary point of either. So the least `R` over the allowed range is at a
//! piece boundary, a stationary minimum of a piece, or an end of the range; all are evaluated,
//! with the nominal solver's tie rule (the smaller wrist rotation wins). No grid, no iteration.
//!
//! At each step the vertex on top is the highest; curves level to within the rounding of their
//! values (relative to their coefficients, not to the values) go to the steeper one. A crossing
//! computed in closed form leaves a steep curve below a flat one by that rounding, and the walk
//! must still switch there (test `envelope_takes_a_steep_crossing`). Each crossing is computed
//! once and kept while neither of its two pieces changes.
//!
//! # 7. What is reported
//! At the recommended pose and at the current pose: the worst objective, the worst internal
//! force and the worst finger force over the region and the mass interval (and, at the
//! recommended pose, where in the region the first two are attained); the nominal object's
//! objective, internal force and contact forces at the recommended pose; the region's vertices,
//! its allowed and graspable ranges; the local minima of the worst case over the region's
//! graspable range; and the nominal object's own answer. With only the mass uncertain the region
//! is the nominal centre of mass and the answer is the nominal one with every force scaled by
//! `(m + Δm) / m`. [`Recommendation::to_recommendation`] proposes how the answer fills
//! today's message fields.
//!
//! The finger force is the push of the harder-pushing finger along the contact line
//! (`docs/theory.md`): with `a_i` the push of contact `i`, `(a_1 + a_2)/2` is the internal
//! force and `a_1 - a_2` the weight's component along the line, `W_line = m|g| sin θ`, which does
//! not depend on `c`. So the worst finger force is the worst internal force plus `m_max|g| |sin θ| / 2`.
//!
//! # Files
//! `uncertainty.rs` the tolerances and their checks; `region.rs` the region and its points
//! (section 3); `range.rs` the allowed range (section 4); `worst.rs` the vertices' frames
//! (section 2), their curves and the worst case at one orientation (sections 1 and 5);
//! `envelope.rs` the envelope and its exact minimum (section 6); `report.rs` what is reported
//! (section 7); `tests.rs` the tests of the whole solve.

mod envelope;
mod range;
mod region;
mod report;
mod uncertainty;
mod worst;

pub(crate) use envelope::{periodic_meet, Envelope};
pub use range::NoCommonOrientation;
pub use region::{BoxPoint, BoxPointKind};
pub use report::Recommendation;
pub(crate) use uncertainty::check_tolerance;
pub use uncertainty::Uncertainty;

use super::analysis::Analysis;
use super::frame::GraspFrame;
use super::{Candidate, InvalidInput, NoForceClosure, Settings};
use region::region;
use worst::{Refusal, Worst};

/// The robust solver's verdict on valid input.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "RobustVerdict")]
pub enum Verdict {
    /// Every tolerance is zero: exactly [`super::solve`]'s verdict.
    Exact(super::Verdict),
    /// Every object in the tolerances can be held: the orientation of least worst case.
    Recommended(Box<Recommendation>),
    /// No allowed orientation suits every object in the tolerances; the nominal answer is given.
    NoCommonOrientation {
        /// Which vertices fail.
        reason: NoCommonOrientation,
        /// The nominal object's answer.
        nominal: Box<super::Recommendation>,
    },
    /// No orientation holds the grasp at all (force closure does not depend on the centre of
    /// mass or the mass).
    NoForceClosure(NoForceClosure),
}

/// Solves one candidate whose centre of mass and mass are known only to within `uncertainty`:
/// the orientation of least worst-case objective and the forces it needs (module docs).
///
/// Bad input (the candidate's or the tolerances') is an `Err`. With every tolerance zero this
/// is [`super::solve`], unchanged.
///
/// # Example
/// The paper's case (c), a square held at the middle of two opposite sides, with its centre of
/// mass known to ±0.1 along x: the recommendation moves off `θ_34`, and the worst case needs more
/// than the nominal object.
/// ```
/// use grasp_orient_solver::{planar::{self, Candidate, robust::Uncertainty}, Settings};
/// use nalgebra::Vector2;
///
/// let grasp = Candidate {
///     contact_1: Vector2::new(1.0, 1.0),
///     contact_2: Vector2::new(-1.0, 1.0),
///     normal_1: Vector2::new(-1.0, 0.0),
///     normal_2: Vector2::new(1.0, 0.0),
///     friction_1: 3f64.sqrt(),
///     friction_2: 1.0 / 3f64.sqrt(),
///     center_of_mass: Vector2::zeros(),
///     mass: 1.0,
///     gravity: Vector2::new(0.0, -1.0),
/// };
/// let tolerance = Uncertainty {
///     center_of_mass_tolerance: Vector2::new(0.1, 0.0),
///     mass_tolerance: 0.0,
/// };
/// let Ok(planar::robust::Verdict::Recommended(r)) = planar::robust::solve(&grasp, &tolerance, &Settings::default())
/// else {
///     panic!("every object in the box can be held from above");
/// };
/// assert!(r.gripping_power > r.gripping_power_nominal);
/// assert!(r.gripping_power_nominal >= r.nominal.gripping_power);
/// assert!((r.gravity_angle - r.nominal.gravity_angle).abs() > 1e-3);
/// ```
#[doc(alias = "solve_robust")]
pub fn solve(
    candidate: &Candidate,
    uncertainty: &Uncertainty,
    settings: &Settings,
) -> Result<Verdict, InvalidInput> {
    if uncertainty.is_exact() {
        return super::solve(candidate, settings).map(Verdict::Exact);
    }
    // The nominal answer, exactly as `super::solve` computes it.
    let frame = GraspFrame::new(candidate, settings.friction_safety_factor)?;
    uncertainty.validate(candidate.mass)?;
    let nominal_analysis = match Analysis::new(&frame, settings.objective) {
        Ok(a) => a,
        Err(miss) => return Ok(Verdict::NoForceClosure(miss)),
    };
    let nominal = nominal_analysis.recommend(&settings.range)?;
    let mass_worst = candidate.mass + uncertainty.mass_tolerance;
    let region = region(candidate, uncertainty, frame.contact_distance);
    let masses = (candidate.mass - uncertainty.mass_tolerance, mass_worst);
    let worst = match Worst::new(&frame, candidate, &region, masses, settings) {
        Ok(w) => w,
        Err(Refusal::NoCommon(reason)) => {
            return Ok(Verdict::NoCommonOrientation {
                reason,
                nominal: Box::new(nominal),
            })
        }
        Err(Refusal::NoClosure(miss)) => return Ok(Verdict::NoForceClosure(miss)),
    };
    Ok(Verdict::Recommended(Box::new(worst.recommend(
        &nominal_analysis,
        nominal,
        mass_worst,
    ))))
}

#[cfg(test)]
mod tests;
