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
//! frame ([`GraspFrame::new`] of the candidate) with the nominal's axes and labelling, only the
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
//! behind (by more than [`BEHIND_TANGENT`] of its distance from the contact) shows that the object
//! is not convex at that contact, so it cuts nothing; one the nominal lies on (to that rounding)
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

use super::analysis::Analysis;
use super::curve::Curve;
use super::frame::{length, unit, GraspFrame, BEHIND_TANGENT, MAX_COORDINATE};
use super::paper::{self, FORCE_SCALE};
use super::sinusoid::{wrap_angle, Angle};
use super::{
    AllowedRange, Candidate, Contact, InvalidInput, LocalMinimum, NoForceClosure, Objective,
    Settings,
};
use nalgebra::Vector2;
use std::f64::consts::TAU;
use std::fmt;

mod envelope;

pub(crate) use envelope::{periodic_meet, Envelope};

/// Objective values closer than this, relative to themselves or to the weight, tie; the smaller
/// wrist rotation wins (as in the nominal analysis).
const TIE: f64 = 1e-12;
/// Curves closer than this, relative to the largest, are level on the envelope; the steeper
/// one goes on top.
const ENVELOPE_TIE: f64 = 1e-12;
/// A vertex this far (in contact distances) on the far side of the contact line counts as on it.
const ON_LINE: f64 = 1e-12;
/// Region vertices closer than this fraction of the contact distance and the box are one.
const SAME_POINT: f64 = 1e-12;

/// How well the object is known. Zero everywhere means exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Uncertainty {
    /// Half-widths of a box around `center_of_mass` along the x and y axes of the candidate
    /// frame, m, each `>= 0`.
    pub center_of_mass_tolerance: Vector2<f64>,
    /// The mass lies in `mass ± mass_tolerance`, kg, in `[0, mass)`.
    pub mass_tolerance: f64,
}

impl Uncertainty {
    /// No uncertainty: the nominal problem.
    pub const EXACT: Uncertainty = Uncertainty {
        center_of_mass_tolerance: Vector2::new(0.0, 0.0),
        mass_tolerance: 0.0,
    };

    /// Whether every tolerance is zero.
    pub fn is_exact(&self) -> bool {
        self.center_of_mass_tolerance.x == 0.0
            && self.center_of_mass_tolerance.y == 0.0
            && self.mass_tolerance == 0.0
    }

    /// Checks the tolerances against the candidate's mass, naming the field at fault.
    fn validate(&self, mass: f64) -> Result<(), InvalidInput> {
        let t = &self.center_of_mass_tolerance;
        check_tolerance("center_of_mass_tolerance.x", t.x, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.y", t.y, MAX_COORDINATE, " m")?;
        check_tolerance("mass_tolerance", self.mass_tolerance, mass, " kg")
    }
}

/// One tolerance: finite and in `[0, limit)` (`unit` names the limit's unit in the message), or
/// the error naming `field`. The planar and the spatial tolerances are checked with it.
pub(crate) fn check_tolerance(
    field: &'static str,
    value: f64,
    limit: f64,
    unit: &'static str,
) -> Result<(), InvalidInput> {
    if !value.is_finite() {
        Err(InvalidInput::NotFinite { field })
    } else if !(0.0..limit).contains(&value) {
        Err(InvalidInput::Tolerance {
            field,
            value,
            limit,
            unit,
        })
    } else {
        Ok(())
    }
}

/// A point of the region of possible centres of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxPoint {
    /// Position in the candidate frame, m.
    pub position: Vector2<f64>,
    /// Which point it is.
    pub kind: BoxPointKind,
}

/// Which point of the region a [`BoxPoint`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxPointKind {
    /// A corner of the box: the signs of its offset from `center_of_mass` along x and y
    /// (`0` along an axis whose tolerance is zero; both `0` is the nominal centre of mass).
    Corner {
        /// `-1`, `0` or `1`.
        x: i8,
        /// `-1`, `0` or `1`.
        y: i8,
    },
    /// Where an edge of the box meets the surface tangent at a contact: the box reaches out of
    /// the object there and is cut (module docs, section 3).
    Cut {
        /// The contact whose tangent cuts.
        contact: Contact,
    },
    /// A point on an edge of the region between two vertices (module docs, section 5).
    Edge,
}

impl fmt::Display for BoxPoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (px, py) = (self.position.x, self.position.y);
        let sign = |s: i8| if s < 0 { '-' } else { '+' };
        match self.kind {
            BoxPointKind::Corner { x: 0, y: 0 } => {
                write!(f, "the centre of mass ({px:.6}, {py:.6}) m")
            }
            BoxPointKind::Corner { x, y: 0 } => {
                write!(f, "corner ({}x) of the box, ({px:.6}, {py:.6}) m", sign(x))
            }
            BoxPointKind::Corner { x: 0, y } => {
                write!(f, "corner ({}y) of the box, ({px:.6}, {py:.6}) m", sign(y))
            }
            BoxPointKind::Corner { x, y } => write!(
                f,
                "corner ({}x, {}y) of the box, ({px:.6}, {py:.6}) m",
                sign(x),
                sign(y)
            ),
            BoxPointKind::Cut { contact } => write!(
                f,
                "({px:.6}, {py:.6}) m, where the box meets the surface tangent at {contact}"
            ),
            BoxPointKind::Edge => write!(f, "({px:.6}, {py:.6}) m on the edge of the box"),
        }
    }
}

/// Why no orientation suits every object in the region (to be answered with status 1).
#[derive(Debug, Clone, PartialEq)]
pub enum NoCommonOrientation {
    /// The region reaches across the contact line: `point` lies on the other side of it from the
    /// nominal centre of mass (module docs, section 4).
    AcrossContactLine {
        /// A vertex across the line.
        point: BoxPoint,
    },
    /// Two vertices allow no common orientation: `first` allows only gravity angles from `lo`
    /// on, `second` only up to `hi < lo`.
    Disjoint {
        /// The vertex whose range starts last.
        first: BoxPoint,
        /// Its range's start, rad.
        lo: f64,
        /// The vertex whose range ends first.
        second: BoxPoint,
        /// Its range's end, rad.
        hi: f64,
    },
    /// Explicit bounds miss the orientations that every object in the region can take.
    BoundsMissed {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
        /// The region's graspable range, rad.
        common: (f64, f64),
        /// The vertex whose graspable range starts last.
        first: BoxPoint,
        /// The vertex whose graspable range ends first.
        second: BoxPoint,
    },
}

impl fmt::Display for NoCommonOrientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no orientation in the allowed range suits every object in the tolerances: ")?;
        match self {
            NoCommonOrientation::AcrossContactLine { point } => write!(
                f,
                "the centre of mass may lie on either side of the line through the contacts \
                 ({point} is across it)"
            ),
            NoCommonOrientation::Disjoint {
                first,
                lo,
                second,
                hi,
            } => write!(
                f,
                "with the centre of mass at {first} the gravity angle must be at least {lo:.6} \
                 rad, at {second} at most {hi:.6} rad"
            ),
            NoCommonOrientation::BoundsMissed {
                lo,
                hi,
                common,
                first,
                second,
            } => write!(
                f,
                "the range bounds [{lo:.6}, {hi:.6}] rad miss [{:.6}, {:.6}] rad, the gravity \
                 angles graspable for every centre of mass (its ends are set by {first} and \
                 {second})",
                common.0, common.1
            ),
        }
    }
}

/// The answer when the tolerances are not all zero and every object in them can be held.
///
/// "Worst" is the largest over the region of centres of mass (the box cut by the object) and
/// the mass interval, with friction `μ / s`.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "RobustRecommendation")]
pub struct Recommendation {
    /// The objective minimised (its worst case).
    pub objective: Objective,
    /// Recommended gravity angle θ, rad, in the nominal object's paper frame.
    pub gravity_angle: f64,
    /// Rotation of the object about +z of the candidate frame, rad in (-π, π], that takes the
    /// current pose to the recommended one.
    pub wrist_rotation: f64,
    /// Unit vector: where gravity points in the candidate frame after that rotation.
    pub gravity_direction: Vector2<f64>,
    /// Worst objective value at the recommended pose, N.
    pub gripping_power: f64,
    /// Where in the region `gripping_power` is attained (at the largest mass).
    pub gripping_power_at: BoxPoint,
    /// Worst squeeze force at the recommended pose, N.
    pub internal_force: f64,
    /// Where in the region `internal_force` is attained (at the largest mass; at the smallest
    /// where the squeeze is negative, which only the 1-norm's can be).
    pub internal_force_at: BoxPoint,
    /// Worst push of the harder-pushing finger along the contact line there, N:
    /// `internal_force + m_max |g| |sin θ| / 2` (module docs, section 7).
    pub finger_force: f64,
    /// Worst objective value at the current pose, N.
    pub gripping_power_current: f64,
    /// Worst squeeze force at the current pose, N.
    pub internal_force_current: f64,
    /// Worst finger force at the current pose, N.
    pub finger_force_current: f64,
    /// Gravity angle of the current pose, rad, paper frame, in `[θ_lo, θ_lo + 2π)` of the
    /// region's graspable range.
    pub current_gravity_angle: f64,
    /// The nominal object's objective value at the recommended pose, N.
    pub gripping_power_nominal: f64,
    /// The nominal object's squeeze force at the recommended pose, N.
    pub internal_force_nominal: f64,
    /// The nominal object's `(N1, F1, N2, F2)` at the recommended pose, N, candidate's
    /// labelling (conventions of [`crate`]).
    pub contact_forces: [f64; 4],
    /// Every local minimum of the worst objective over the region's graspable range, in
    /// increasing angle, unlabelled (the paper's candidates A–E belong to one object).
    pub local_minima: Vec<LocalMinimum>,
    /// The allowed gravity angles for every object in the region, rad, as closed intervals.
    pub allowed: Vec<(f64, f64)>,
    /// The gravity angles graspable (8) for every object in the region, rad.
    pub graspable: (f64, f64),
    /// The vertices of the region of centres of mass, in order around it.
    pub region: Vec<BoxPoint>,
    /// The largest mass, kg.
    pub mass_worst: f64,
    /// The nominal object's own answer (its own optimum).
    pub nominal: super::Recommendation,
}

impl Recommendation {
    /// The answer in the fields of today's [`Recommendation`] (a proposal for the message
    /// stage): the pose is the robust one; `gripping_power`, `internal_force` and their
    /// `_current` values are the worst cases; `contact_forces` are the nominal object's there;
    /// `local_minima` are the worst case's, unlabelled; `recommended_label` is `None` (the
    /// recommendation is no paper candidate of one object); `grasp_case` and `candidate_c`
    /// describe the nominal object (Theorem 1); `finger_force` and its `_current` value are the
    /// worst cases.
    pub fn to_recommendation(&self) -> super::Recommendation {
        super::Recommendation {
            objective: self.objective,
            gravity_angle: self.gravity_angle,
            wrist_rotation: self.wrist_rotation,
            gravity_direction: self.gravity_direction,
            gripping_power: self.gripping_power,
            internal_force: self.internal_force,
            contact_forces: self.contact_forces,
            gripping_power_current: self.gripping_power_current,
            internal_force_current: self.internal_force_current,
            current_gravity_angle: self.current_gravity_angle,
            grasp_case: self.nominal.grasp_case,
            local_minima: self.local_minima.clone(),
            recommended_label: None,
            candidate_c: self.nominal.candidate_c,
            finger_force: self.finger_force,
            finger_force_current: self.finger_force_current,
        }
    }
}

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

/// The region of possible centres of mass: the box cut by both surface tangents (module docs,
/// section 3), its vertices in order around it, duplicates merged.
///
/// Sutherland–Hodgman against each tangent half-plane `n_i · (q - p_i) >= min(0, n_i · (c - p_i))`
/// (the bound gives way by the rounding of a nominal `c` on the tangent, so `c` stays inside); a
/// tangent the nominal `c` lies behind ([`BEHIND_TANGENT`]) cuts nothing (module docs, section 3).
fn region(c: &Candidate, u: &Uncertainty, contact_distance: f64) -> Vec<BoxPoint> {
    let t = u.center_of_mass_tolerance;
    let sign = |s: i8, half_width: f64| if half_width > 0.0 { s } else { 0 };
    let mut poly: Vec<BoxPoint> = [(-1i8, -1i8), (1, -1), (1, 1), (-1, 1)]
        .iter()
        .map(|&(sx, sy)| BoxPoint {
            position: c.center_of_mass + Vector2::new(f64::from(sx) * t.x, f64::from(sy) * t.y),
            kind: BoxPointKind::Corner {
                x: sign(sx, t.x),
                y: sign(sy, t.y),
            },
        })
        .collect();
    for (contact, p, n) in [
        (Contact::First, c.contact_1, c.normal_1),
        (Contact::Second, c.contact_2, c.normal_2),
    ] {
        // Scale-free: a normal whose square underflows still has its direction (`validate`
        // accepted it, so it is not zero).
        let n = unit(&n).unwrap_or_else(Vector2::zeros);
        if unit(&(c.center_of_mass - p)).is_some_and(|u| n.dot(&u) < -BEHIND_TANGENT) {
            // The object is not convex at this contact: its tangent bounds nothing.
            continue;
        }
        let limit = n.dot(&(c.center_of_mass - p)).min(0.0);
        let side = |q: &Vector2<f64>| n.dot(&(q - p)) - limit;
        let mut cut = Vec::with_capacity(poly.len() + 1);
        for (i, a) in poly.iter().enumerate() {
            let b = &poly[(i + 1) % poly.len()];
            let (da, db) = (side(&a.position), side(&b.position));
            if da >= 0.0 {
                cut.push(*a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let s = da / (da - db);
                cut.push(BoxPoint {
                    position: a.position + (b.position - a.position) * s,
                    kind: BoxPointKind::Cut { contact },
                });
            }
        }
        poly = cut;
    }
    let eps = SAME_POINT * contact_distance.max(t.x).max(t.y);
    let mut out: Vec<BoxPoint> = Vec::with_capacity(poly.len());
    for q in poly {
        if out
            .last()
            .is_none_or(|l| (l.position - q.position).norm() > eps)
        {
            out.push(q);
        }
    }
    while out.len() > 1 && (out[0].position - out[out.len() - 1].position).norm() <= eps {
        out.pop();
    }
    if out.is_empty() {
        // Each cut keeps the nominal centre of mass (its bound gives way to it), so only
        // rounding can leave nothing, when the box is within rounding of a tangent: the region
        // is then the nominal point.
        out.push(BoxPoint {
            position: c.center_of_mass,
            kind: BoxPointKind::Corner { x: 0, y: 0 },
        });
    }
    out
}

/// Why the robust answer is not a recommendation.
enum Refusal {
    NoCommon(NoCommonOrientation),
    NoClosure(NoForceClosure),
}

/// A closed interval of angles and the vertices that bound it.
#[derive(Debug, Clone, Copy)]
struct Common {
    lo: f64,
    lo_vertex: usize,
    hi: f64,
    hi_vertex: usize,
}

impl Common {
    /// The intersection of intervals, with which one sets each end.
    fn of(ranges: impl Iterator<Item = (f64, f64)>) -> Self {
        let mut c = Common {
            lo: f64::NEG_INFINITY,
            lo_vertex: 0,
            hi: f64::INFINITY,
            hi_vertex: 0,
        };
        for (i, (lo, hi)) in ranges.enumerate() {
            if lo > c.lo {
                (c.lo, c.lo_vertex) = (lo, i);
            }
            if hi < c.hi {
                (c.hi, c.hi_vertex) = (hi, i);
            }
        }
        c
    }
}

/// The region's vertices analysed at the largest mass, and their upper envelope.
struct Worst {
    objective: Objective,
    /// The nominal frame (axes, labelling, current pose).
    nominal_frame: GraspFrame,
    /// The nominal centre of mass, candidate frame, m.
    center_of_mass: Vector2<f64>,
    region: Vec<BoxPoint>,
    frames: Vec<GraspFrame>,
    analyses: Vec<Analysis>,
    graspable: (f64, f64),
    allowed: Vec<(f64, f64)>,
    envelope: Envelope,
    /// `m_max |g|`, N.
    weight: f64,
    /// `m_min / m_max`: a negative squeeze (the 1-norm's, module docs section 5) is largest at
    /// the smallest mass.
    mass_ratio: f64,
}

impl Worst {
    /// Builds every vertex's frame and analysis, the allowed range for the whole region, and the
    /// envelope over the region's graspable range (module docs, sections 2, 4 and 6).
    fn new(
        frame: &GraspFrame,
        candidate: &Candidate,
        region: &[BoxPoint],
        (mass_least, mass_worst): (f64, f64),
        settings: &Settings,
    ) -> Result<Self, Refusal> {
        let weight = mass_worst * length(&candidate.gravity);
        let mut frames = Vec::with_capacity(region.len());
        for p in region {
            let f = vertex_frame(frame, candidate.center_of_mass, p.position, weight);
            if f.y < -ON_LINE {
                return Err(Refusal::NoCommon(NoCommonOrientation::AcrossContactLine {
                    point: *p,
                }));
            }
            frames.push(GraspFrame {
                y: f.y.max(0.0),
                ..f
            });
        }
        let analyses = frames
            .iter()
            .map(|f| Analysis::new(f, settings.objective))
            .collect::<Result<Vec<_>, _>>()
            .map_err(Refusal::NoClosure)?;
        // `paper::ranges` of each vertex's frame.
        let graspable = Common::of(analyses.iter().map(Analysis::graspable_range));
        let from_above = Common::of(analyses.iter().map(Analysis::from_above_range));
        let allowed = match settings.range {
            AllowedRange::FromAbove | AllowedRange::Graspable => {
                let c = if settings.range == AllowedRange::FromAbove {
                    from_above
                } else {
                    graspable
                };
                if c.lo > c.hi {
                    return Err(Refusal::NoCommon(NoCommonOrientation::Disjoint {
                        first: region[c.lo_vertex],
                        lo: c.lo,
                        second: region[c.hi_vertex],
                        hi: c.hi,
                    }));
                }
                vec![(c.lo, c.hi)]
            }
            AllowedRange::Bounds { lo, hi } => {
                let out = periodic_meet(lo, hi, graspable.lo, graspable.hi);
                if out.is_empty() {
                    return Err(Refusal::NoCommon(NoCommonOrientation::BoundsMissed {
                        lo,
                        hi,
                        common: (graspable.lo, graspable.hi),
                        first: region[graspable.lo_vertex],
                        second: region[graspable.hi_vertex],
                    }));
                }
                out
            }
        };
        let tracks: Vec<Vec<(f64, f64, Curve)>> =
            analyses.iter().map(|a| a.pieces().collect()).collect();
        let envelope = Envelope::new(&tracks, graspable.lo, graspable.hi);
        Ok(Self {
            objective: settings.objective,
            nominal_frame: *frame,
            center_of_mass: candidate.center_of_mass,
            region: region.to_vec(),
            frames,
            analyses,
            graspable: (graspable.lo, graspable.hi),
            allowed,
            envelope,
            weight,
            mass_ratio: mass_least / mass_worst,
        })
    }

    /// `k` of the curves: objective = `k sqrt(Q)` or `k S`.
    fn scale(&self) -> f64 {
        self.weight * FORCE_SCALE
    }

    /// The gravity angle of least worst case over the allowed range (module docs, section 6).
    fn minimiser(&self, current: f64) -> f64 {
        self.envelope
            .least(&self.allowed, current, self.scale(), self.weight)
    }

    /// Every local minimum of the worst case over the region's graspable range.
    fn local_minima(&self) -> Vec<LocalMinimum> {
        self.envelope.local_minima(self.scale())
    }

    /// A force proportional to the mass at `m_max`, made the largest over the mass interval: at
    /// `m_max` if it is positive, at `m_min` if it is negative.
    fn over_masses(&self, force: f64) -> f64 {
        if force < 0.0 {
            force * self.mass_ratio
        } else {
            force
        }
    }

    /// The worst objective and internal force at `theta` (the internal force at `m_max`; see
    /// [`Worst::over_masses`]), and where they are attained.
    fn worst_at(&self, theta: f64) -> ((f64, BoxPoint), (f64, BoxPoint)) {
        let mut power = (f64::NEG_INFINITY, self.region[0]);
        let mut internal = (f64::NEG_INFINITY, self.region[0]);
        for (a, p) in self.analyses.iter().zip(&self.region) {
            let v = a.evaluate(theta);
            if v.power > power.0 {
                power = (v.power, *p);
            }
            if v.internal_force > internal.0 {
                internal = (v.internal_force, *p);
            }
        }
        if self.objective == Objective::Norm1 {
            for (position, f) in self.norm1_edge_points(theta) {
                if let Ok(a) = Analysis::new(&f, Objective::Norm1) {
                    let v = a.evaluate(theta).internal_force;
                    if v > internal.0 {
                        internal = (
                            v,
                            BoxPoint {
                                position,
                                kind: BoxPointKind::Edge,
                            },
                        );
                    }
                }
            }
        }
        (power, internal)
    }

    /// Where the line `β_1 = β_2` (the two friction forces' zeros in α, each affine in `c`)
    /// crosses the region's edge at `theta`, with the frames there (module docs, section 5).
    fn norm1_edge_points(&self, theta: f64) -> Vec<(Vector2<f64>, GraspFrame)> {
        let at = Angle::new(theta);
        let w = paper::balance_internal(&self.frames[0]);
        let mut out = Vec::new();
        if w[1] == 0.0 || w[3] == 0.0 || self.frames.len() < 2 {
            return out;
        }
        let gap: Vec<f64> = self
            .frames
            .iter()
            .map(|f| {
                let t = paper::balance_particular(f);
                t[3].value(&at) / w[3] - t[1].value(&at) / w[1]
            })
            .collect();
        let n = self.frames.len();
        for i in 0..n {
            let j = (i + 1) % n;
            if (gap[i] < 0.0) != (gap[j] < 0.0) && gap[i] != gap[j] {
                let s = gap[i] / (gap[i] - gap[j]);
                let (a, b) = (self.region[i].position, self.region[j].position);
                let position = a + (b - a) * s;
                let f = vertex_frame(
                    &self.nominal_frame,
                    self.center_of_mass,
                    position,
                    self.weight,
                );
                out.push((
                    position,
                    GraspFrame {
                        y: f.y.max(0.0),
                        ..f
                    },
                ));
            }
        }
        out
    }

    /// Everything the answer reports.
    fn recommend(
        &self,
        nominal_analysis: &Analysis,
        nominal: super::Recommendation,
        mass_worst: f64,
    ) -> Recommendation {
        let f = &self.nominal_frame;
        let lo = self.graspable.0;
        let current = lo + (f.current_theta - lo).rem_euclid(TAU);
        let theta = self.minimiser(current);
        // Internal and finger force are proportional to the mass at one centre of mass, and
        // the centre of mass of the largest internal force gives the largest finger force
        // (`W_line` does not depend on it); each is then made the largest over the masses.
        let finger =
            |internal: f64, t: f64| self.over_masses(internal + 0.5 * self.weight * t.sin().abs());
        let ((power, power_at), (internal, internal_at)) = self.worst_at(theta);
        let ((power_now, _), (internal_now, _)) = self.worst_at(current);
        let at_nominal = nominal_analysis.evaluate(theta);
        Recommendation {
            objective: self.objective,
            gravity_angle: theta,
            wrist_rotation: wrap_angle(current - theta),
            gravity_direction: f.gravity_direction(theta),
            gripping_power: power,
            gripping_power_at: power_at,
            internal_force: self.over_masses(internal),
            internal_force_at: internal_at,
            finger_force: finger(internal, theta),
            gripping_power_current: power_now,
            internal_force_current: self.over_masses(internal_now),
            finger_force_current: finger(internal_now, current),
            current_gravity_angle: current,
            gripping_power_nominal: at_nominal.power,
            internal_force_nominal: at_nominal.internal_force,
            contact_forces: candidate_labelling(f, at_nominal.forces),
            local_minima: self.local_minima(),
            allowed: self.allowed.clone(),
            graspable: self.graspable,
            region: self.region.clone(),
            mass_worst,
            nominal,
        }
    }
}

/// The frame of the object with its centre of mass moved from `from` to `to` (candidate frame)
/// and weight `weight`, with `frame`'s axes and labelling (module docs, section 2). `y` may come
/// out negative: the point lies across the contact line.
fn vertex_frame(
    frame: &GraspFrame,
    from: Vector2<f64>,
    to: Vector2<f64>,
    weight: f64,
) -> GraspFrame {
    let delta = (to - from) / frame.contact_distance;
    let (dx, dy) = (delta.dot(&frame.e_x), delta.dot(&frame.e_y));
    GraspFrame {
        x1: frame.x1 - dx,
        x2: frame.x2 + dx,
        y: frame.y - dy,
        weight,
        ..*frame
    }
}

/// Paper labelling and paper tangents to the candidate's labelling (conventions of
/// [`crate`]): the paper's tangent at contact 1 is minus "inward normal turned +90°".
fn candidate_labelling(f: &GraspFrame, forces: [f64; 4]) -> [f64; 4] {
    let [n1, f1, n2, f2] = forces;
    if f.swapped {
        [n2, f2, n1, -f1]
    } else {
        [n1, -f1, n2, f2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planar::curve::quad_rising_zero;
    use crate::sinusoid::QuadForm;
    use std::f64::consts::FRAC_PI_2;
    use std::f64::consts::PI;

    fn square_case_c() -> Candidate {
        Candidate {
            contact_1: Vector2::new(1.0, 1.0),
            contact_2: Vector2::new(-1.0, 1.0),
            normal_1: Vector2::new(-1.0, 0.0),
            normal_2: Vector2::new(1.0, 0.0),
            friction_1: 3f64.sqrt(),
            friction_2: 1.0 / 3f64.sqrt(),
            center_of_mass: Vector2::zeros(),
            mass: 1.0,
            gravity: Vector2::new(0.0, -1.0),
        }
    }

    fn tolerance(x: f64, y: f64, m: f64) -> Uncertainty {
        Uncertainty {
            center_of_mass_tolerance: Vector2::new(x, y),
            mass_tolerance: m,
        }
    }

    fn recommended(c: &Candidate, u: &Uncertainty, s: &Settings) -> Recommendation {
        match solve(c, u, s) {
            Ok(Verdict::Recommended(r)) => *r,
            other => panic!("expected a recommendation, got {other:?}"),
        }
    }

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

    #[test]
    fn region_is_the_box_cut_by_the_tangents() {
        let c = square_case_c();
        // Inside: the four corners, in order.
        let r = region(&c, &tolerance(0.5, 0.25, 0.0), 2.0);
        assert_eq!(r.len(), 4);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: -1, y: -1 });
        assert_eq!(r[2].position, Vector2::new(0.5, 0.25));
        // Past the tangent at contact 1 (x = 1): cut there, two new vertices.
        let r = region(&c, &tolerance(1.5, 0.25, 0.0), 2.0);
        assert_eq!(r.len(), 4);
        assert!(r.iter().all(|p| p.position.x.abs() <= 1.0 + 1e-15));
        assert_eq!(
            r.iter()
                .filter(|p| p.kind
                    == BoxPointKind::Cut {
                        contact: Contact::First
                    })
                .count(),
            2
        );
        // One axis only: a segment with two ends.
        let r = region(&c, &tolerance(0.5, 0.0, 0.0), 2.0);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: -1, y: 0 });
        // Mass only: the nominal point.
        let r = region(&c, &tolerance(0.0, 0.0, 0.1), 2.0);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].kind, BoxPointKind::Corner { x: 0, y: 0 });
    }

    #[test]
    fn zero_tolerance_is_the_nominal_solver() {
        let c = square_case_c();
        let s = Settings::default();
        assert_eq!(
            super::solve(&c, &Uncertainty::EXACT, &s),
            crate::planar::solve(&c, &s).map(super::Verdict::Exact)
        );
    }

    #[test]
    fn mass_only_scales_the_nominal_answer() {
        let c = square_case_c();
        let r = recommended(&c, &tolerance(0.0, 0.0, 0.25), &Settings::default());
        assert!((r.gravity_angle - r.nominal.gravity_angle).abs() < 1e-12);
        assert!((r.gripping_power - 1.25 * r.nominal.gripping_power).abs() < 1e-12);
        assert!((r.gripping_power_nominal - r.nominal.gripping_power).abs() < 1e-12);
    }

    /// Found by `tests/fuzz.rs`: normals and gravity of any length the validation accepts, down to
    /// 1e-200 whose squares underflow, give the same answer as unit ones (the region's tangents
    /// and the weight are computed scale-free), and never an empty region.
    #[test]
    fn tiny_normals_and_gravity_give_the_answer_of_unit_ones() {
        let c = square_case_c();
        let u = tolerance(0.1, 0.2, 0.1);
        let want = recommended(&c, &u, &Settings::default());
        for k in [1e-200, 1e-160, 1e-100, 1e3] {
            // Forces scale with the weight, so with the gravity's length; the angle does not.
            let scaled = Candidate {
                normal_1: c.normal_1 * k,
                normal_2: c.normal_2 * k,
                gravity: c.gravity * k,
                ..c
            };
            let got = recommended(&scaled, &u, &Settings::default());
            assert_eq!(got.gravity_angle, want.gravity_angle, "scale {k:e}");
            let power = got.gripping_power / k;
            assert!(
                (power - want.gripping_power).abs() <= 1e-12 * want.gripping_power,
                "scale {k:e}: {power} against {}",
                want.gripping_power
            );
        }
    }

    #[test]
    fn tolerances_are_checked() {
        let c = square_case_c();
        let s = Settings::default();
        let refused = |u: Uncertainty| super::solve(&c, &u, &s).expect_err("refused");
        assert_eq!(
            refused(tolerance(-0.1, 0.0, 0.0)),
            InvalidInput::Tolerance {
                field: "center_of_mass_tolerance.x",
                value: -0.1,
                limit: MAX_COORDINATE,
                unit: " m"
            }
        );
        assert_eq!(
            refused(tolerance(0.0, f64::NAN, 0.0)),
            InvalidInput::NotFinite {
                field: "center_of_mass_tolerance.y"
            }
        );
        assert!(matches!(
            refused(tolerance(0.0, 0.0, 1.0)),
            InvalidInput::Tolerance {
                field: "mass_tolerance",
                ..
            }
        ));
        let message = refused(tolerance(0.0, 0.0, 2.0)).to_string();
        assert!(message.contains("mass_tolerance"), "{message}");
    }

    #[test]
    fn across_the_contact_line_has_no_common_orientation() {
        // The contact line is y = 1; a box reaching past it.
        let c = square_case_c();
        match super::solve(&c, &tolerance(0.1, 1.5, 0.0), &Settings::default()) {
            Ok(super::Verdict::NoCommonOrientation {
                reason: NoCommonOrientation::AcrossContactLine { point },
                nominal,
            }) => {
                assert!(point.position.y > 1.0);
                assert_eq!(
                    Some(*nominal),
                    match crate::planar::solve(&c, &Settings::default()) {
                        Ok(crate::planar::Verdict::Recommended(r)) => Some(*r),
                        _ => None,
                    }
                );
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_box_wider_than_the_grip_cannot_hang_from_above_everywhere() {
        // Contacts 0.2 apart on an object whose tangents slope outward, box 1.0 wide below.
        let c = Candidate {
            contact_1: Vector2::new(0.1, 0.0),
            contact_2: Vector2::new(-0.1, 0.0),
            normal_1: Vector2::new(-0.2, -1.0),
            normal_2: Vector2::new(0.2, -1.0),
            friction_1: 10.0,
            friction_2: 10.0,
            center_of_mass: Vector2::new(0.0, -1.0),
            mass: 1.0,
            gravity: Vector2::new(0.0, -9.81),
        };
        match super::solve(&c, &tolerance(1.0, 0.1, 0.0), &Settings::default()) {
            Ok(super::Verdict::NoCommonOrientation {
                reason: NoCommonOrientation::Disjoint { lo, hi, .. },
                ..
            }) => assert!(lo > hi),
            other => panic!("{other:?}"),
        }
    }

    /// Module docs, section 4: the wide box below a short segment. Straight up (θ = π) is
    /// graspable for every corner, but the box's middle then rests on the fingers, so it must
    /// not be allowed; the interval intersection excludes it.
    #[test]
    fn graspable_range_is_the_hull_not_the_union() {
        let c = Candidate {
            contact_1: Vector2::new(1.0, 0.0),
            contact_2: Vector2::new(-1.0, 0.0),
            normal_1: Vector2::new(-0.11, -0.99),
            normal_2: Vector2::new(0.11, -0.99),
            friction_1: 20.0,
            friction_2: 20.0,
            center_of_mass: Vector2::new(0.0, -1.0),
            mass: 1.0,
            gravity: Vector2::new(0.0, -9.81),
        };
        let settings = Settings {
            range: AllowedRange::Graspable,
            ..Settings::default()
        };
        let r = recommended(&c, &tolerance(3.0, 0.5, 0.0), &settings);
        // Every corner allows θ = π on its own (its excluded arc is narrow).
        assert_eq!(r.region.len(), 4);
        let f0 = GraspFrame::new(&c, 1.0).expect("valid");
        for p in &r.region {
            let f = vertex_frame(&f0, c.center_of_mass, p.position, 1.0);
            let ((lo, hi), _) = paper::ranges(&f);
            let up = lo + (PI - lo).rem_euclid(TAU);
            assert!(up <= hi, "corner {p} allows straight up");
        }
        // The nominal centre does not, and neither does the region's range.
        let ((lo, hi), _) = paper::ranges(&f0);
        assert!(lo + (PI - lo).rem_euclid(TAU) > hi);
        let (glo, ghi) = r.graspable;
        assert!(glo + (PI - glo).rem_euclid(TAU) > ghi);
        assert!(glo <= -FRAC_PI_2 && ghi >= FRAC_PI_2);
    }

    #[test]
    fn bounds_meet_the_region_graspable_range() {
        let c = square_case_c();
        let u = tolerance(0.5, 0.0, 0.0);
        let graspable = Settings {
            range: AllowedRange::Graspable,
            ..Settings::default()
        };
        let r = recommended(&c, &u, &graspable);
        // The corners at x = ±0.5 narrow [-3π/4, 3π/4] to ±(π - atan2(0.75, 0.5)).
        let end = PI - 0.75f64.atan2(0.5);
        assert!((r.graspable.0 + end).abs() < 1e-12 && (r.graspable.1 - end).abs() < 1e-12);
        // Bounds that cover it, shifted by a turn, give the same answer.
        let bounds = Settings {
            range: AllowedRange::Bounds {
                lo: -3.0 + TAU,
                hi: 3.0 + TAU,
            },
            ..Settings::default()
        };
        let b = recommended(&c, &u, &bounds);
        assert_eq!(b.allowed, vec![r.graspable]);
        assert_eq!(b.gravity_angle, r.gravity_angle);
        // Bounds the nominal object accepts but some corner does not.
        let narrow = Settings {
            range: AllowedRange::Bounds { lo: 2.3, hi: 2.35 },
            ..Settings::default()
        };
        match super::solve(&c, &u, &narrow) {
            Ok(super::Verdict::NoCommonOrientation {
                reason: reason @ NoCommonOrientation::BoundsMissed { .. },
                ..
            }) => {
                let text = reason.to_string();
                assert!(
                    text.contains("corner (+x)") && text.contains("corner (-x)"),
                    "{text}"
                );
            }
            other => panic!("{other:?}"),
        }
        // Bounds that miss the nominal object's range are bad input, as today.
        let outside = Settings {
            range: AllowedRange::Bounds { lo: 2.5, hi: 2.6 },
            ..Settings::default()
        };
        assert!(matches!(
            super::solve(&c, &u, &outside),
            Err(InvalidInput::RangeOutsideGraspable { .. })
        ));
    }

    /// Module docs, section 5: the 1-norm's squeeze is `max(α_min, h)` with `h` set by the
    /// friction zeros and the slopes `s1 + s2 ± |c1| ± |c2|`, which depend on neither `c` nor θ.
    #[test]
    fn norm1_squeeze_is_alpha_min_or_a_friction_zero() {
        let mut checked = [0usize; 2];
        for k in 0..400 {
            let u = f64::from(k);
            let phi1 = 0.2 + 1.2 * (0.5 + 0.5 * (u * 0.37).sin());
            let phi2 = 0.2 + 1.2 * (0.5 + 0.5 * (u * 0.73).cos());
            let c = Candidate {
                contact_1: Vector2::new(0.5, 0.3 + 0.2 * (u * 0.11).sin()),
                contact_2: Vector2::new(-0.5, 0.3 + 0.2 * (u * 0.11).sin()),
                normal_1: Vector2::new(-phi1.sin(), -phi1.cos()),
                normal_2: Vector2::new(phi2.sin(), -phi2.cos()),
                friction_1: 1.5 + (u * 0.29).sin(),
                friction_2: 1.5 + (u * 0.53).cos(),
                center_of_mass: Vector2::new(0.3 * (u * 0.91).sin(), 0.0),
                mass: 1.0,
                gravity: Vector2::new(0.0, -1.0),
            };
            let Ok(f) = GraspFrame::new(&c, 1.0) else {
                continue;
            };
            let Ok(a) = Analysis::new(&f, Objective::Norm1) else {
                continue;
            };
            let w = paper::balance_internal(&f);
            let t = paper::balance_particular(&f);
            let (s, c1, c2) = (w[0] + w[2], w[1].abs(), w[3].abs());
            let (d0, d1, d2) = (s - c1 - c2, s + c1 - c2, s - c1 + c2);
            for i in 0..50 {
                let theta = -3.0 + 0.12 * f64::from(i);
                let at = Angle::new(theta);
                let (b1, b2) = (-t[1].value(&at) / w[1], -t[3].value(&at) / w[3]);
                // s_i + |c_i| >= 1 >= |c_j| and s_j > 0: passing one zero always suffices.
                assert!(d1 > 0.0 && d2 > 0.0);
                let (h, case) = if d0 >= 0.0 {
                    (f64::NEG_INFINITY, 0)
                } else {
                    (b1.min(b2), 1)
                };
                let v = a.evaluate(theta);
                let want = v.alpha_min.max(h);
                assert!(
                    (v.alpha - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "θ {theta}: solver's α {} vs max(α_min, h) {want}",
                    v.alpha
                );
                checked[case] += 1;
            }
        }
        assert!(
            checked.iter().all(|&n| n > 0),
            "every case met: {checked:?}"
        );
    }

    /// The envelope tiles the region's graspable range and is the largest vertex curve there.
    fn assert_envelope_is_the_maximum(c: &Candidate, u: &Uncertainty, objective: Objective) {
        let settings = Settings {
            objective,
            range: AllowedRange::Graspable,
            ..Settings::default()
        };
        let frame = GraspFrame::new(c, 1.0).expect("valid");
        let region = region(c, u, frame.contact_distance);
        let masses = (c.mass - u.mass_tolerance, c.mass + u.mass_tolerance);
        let w = match Worst::new(&frame, c, &region, masses, &settings) {
            Ok(w) => w,
            Err(_) => panic!("the box is on one side of the contact line"),
        };
        let env = &w.envelope.pieces;
        assert_eq!(env[0].lo, w.graspable.0);
        assert_eq!(env.last().map(|p| p.hi), Some(w.graspable.1));
        for pair in env.windows(2) {
            assert_eq!(pair[0].hi, pair[1].lo);
        }
        assert!(env.iter().any(|p| p.vertex != env[0].vertex));
        for piece in env {
            for k in 0..=50 {
                let t = piece.lo + (piece.hi - piece.lo) * f64::from(k) / 50.0;
                let on_top = piece.curve.power(&Angle::new(t), w.scale());
                let max = w
                    .analyses
                    .iter()
                    .map(|a| a.evaluate(t).power)
                    .fold(f64::NEG_INFINITY, f64::max);
                assert!(
                    (on_top - max).abs() <= 1e-9 * max.abs().max(w.weight),
                    "{objective:?} at {t}: envelope {on_top}, max {max}"
                );
            }
        }
    }

    #[test]
    fn envelope_is_the_pointwise_maximum() {
        let c = Candidate {
            contact_1: Vector2::new(5.0, 4.0),
            contact_2: Vector2::new(-3.0, 4.0),
            normal_1: Vector2::new(-(0.785f64).sin(), -(0.785f64).cos()),
            normal_2: Vector2::new((0.785f64).sin(), -(0.785f64).cos()),
            friction_1: 1.5,
            friction_2: 2.5,
            center_of_mass: Vector2::zeros(),
            mass: 1.0,
            gravity: Vector2::new(0.0, -1.0),
        };
        for objective in [Objective::Norm2, Objective::Norm1, Objective::InternalForce] {
            assert_envelope_is_the_maximum(&c, &tolerance(1.0, 1.5, 0.2), objective);
        }
    }

    /// A vertex whose curve is huge rises steeply through a small one just after its own zero:
    /// at the crossing, the steep curve's rounding (relative to its coefficients, about 1e9)
    /// exceeds the small curve's value scale. The walk once stayed on the small curve there and
    /// missed the crossing (found by `tests/it/robust.rs`).
    #[test]
    fn envelope_takes_a_steep_crossing() {
        let c = Candidate {
            contact_1: Vector2::new(-1.7624265088373754, -6.033809603302954),
            contact_2: Vector2::new(-2.7162526087026224, -2.9868505067375284),
            normal_1: Vector2::new(3.1306820733503704, 4.556693109138684),
            normal_2: Vector2::new(1.1847306785850145, -0.890422040105583),
            friction_1: 1.2744341947159041,
            friction_2: 1.2929923720774528,
            center_of_mass: Vector2::new(2.449061861343098, -3.0458989187266146),
            mass: 5.06024162164664,
            gravity: Vector2::new(-6.324178599348415, 5.314653069558688),
        };
        let u = tolerance(0.0, 0.9136421215780067, 3.0496289962400778);
        assert_envelope_is_the_maximum(&c, &u, Objective::Norm2);
        let r = recommended(&c, &u, &Settings::default());
        // The worst case falls towards the start of the allowed range, which is the answer.
        assert_eq!(r.gravity_angle, r.allowed[0].0);
    }

    /// The forces in the candidate's labelling agree with the nominal solver's own report.
    #[test]
    fn contact_forces_use_the_solver_conventions() {
        for swap in [false, true] {
            let mut c = square_case_c();
            if swap {
                std::mem::swap(&mut c.contact_1, &mut c.contact_2);
                std::mem::swap(&mut c.normal_1, &mut c.normal_2);
                std::mem::swap(&mut c.friction_1, &mut c.friction_2);
            }
            let r = recommended(&c, &tolerance(0.0, 0.0, 0.5), &Settings::default());
            for k in 0..4 {
                assert!((r.contact_forces[k] - r.nominal.contact_forces[k]).abs() < 1e-12);
            }
        }
    }
}
