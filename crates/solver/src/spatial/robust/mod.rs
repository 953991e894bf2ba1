//! Uncertain mass and centre of mass for spatial candidates: every
//! object hangs in its own plane, and the tilt of the contact axis whose worst case is least
//! (`docs/theory.md#robust-worst-case-spatial`).
//!
//! The centre of mass is known to within a box of half-widths `center_of_mass_tolerance` along
//! the x, y and z axes of the candidate frame around `center_of_mass`, the mass to within
//! `± mass_tolerance`; friction is `μ / s` as everywhere. With every tolerance zero,
//! [`solve`] is [`super::solve`] itself. Units inside: lengths over the contact
//! distance `d`, forces over the weight at the largest mass `W = m_max |g|`.
//!
//! # 1. The swing: what a gripper pose fixes
//! `a` is the unit contact axis (contact 2 → contact 1). Two point contacts exert no moment about
//! the axis (both forces act on it), so the object can be held only when the weight has none
//! either: gravity `ĝ` (in the object's frame) lies in the plane `Π(c)` through the axis and the
//! centre of mass `c` (the spatial module docs, §1). A pose of the gripper fixes where the contacts
//! are, hence the angle between the axis and gravity, `sin θ = ĝ · a`, and nothing else: the
//! object is free to turn about the axis. Turned by `φ` about it, its potential energy is
//! `U(φ) = −W ρ d cos θ cos(φ − φ_0) + const`, with `ρ d` the distance of `c` from the axis: two
//! equilibria, `c` straight below the axis (`ĝ = sin θ a + cos θ v`, `v` the unit direction from
//! the axis to `c`), a minimum of `U`, stable; and `c` straight above it, a maximum, unstable: any
//! error in the centre of mass out of the plane swings the object over. (Every plane is an
//! equilibrium only when `c` lies on the axis, or when the axis is vertical.) So:
//! - after the swing every object of the region hangs in its own plane `Π(c)` at the **same**
//!   gravity angle `θ ∈ [−π/2, π/2]`, measured in that plane's paper frame (`e_x = a`,
//!   `e_y = −v`, so that the contacts have `y = ρ >= 0`);
//! - the orientation to choose is one number, the tilt `θ` of the axis; the rotation of the wrist
//!   about the axis does not matter, since the object swings to the same place. The answer names
//!   the pose at which the nominal object hangs at rest, `d* = sin θ* a + cos θ* v_0`;
//! - gravity angles outside `[−π/2, π/2]` (the object balanced above the fingers) are never
//!   allowed with a centre-of-mass tolerance: `graspable` is `[−π/2, π/2]`, and explicit bounds are
//!   met with it;
//! - at the current pose every object swings to `θ_0 = asin(ĝ_0 · a)`; the current-pose values
//!   are those after the swing (statics: how the object gets there is not modelled).
//!
//! A centre of mass on the axis (`ρ = 0`) does not swing; its plane is set by the roll of the
//! gripper, which the answer leaves free, so every plane through the axis is taken for it.
//!
//! # 2. One object in closed form
//! In `Π(c)` write the contact forces `f_i = A_i a + B_i v`. With `ξ = (c − p_2)·a / d` (so
//! `x2 = ξ`, `x1 = 1 − ξ`), `s = sin θ`, `k = cos θ`, the forces balance the weight, and the moments
//! about `c` vanish (`x1 B1 − x2 B2 = ρ s`), when
//!
//! ```text
//!   B1 = ρ s − ξ k,      B2 = −((1 − ξ) k + ρ s),      push_2 = push_1 − s
//! ```
//!
//! where `push_1 = −A_1`, `push_2 = A_2` are the pushes along the axis into the object: the
//! across forces are fixed by the object and the tilt; only the squeeze is free. With
//! `p_i = cos δ_i` the unit inward normal's component toward the other contact and
//! `q_i = n̂_i · v`, the force `push e + B v` lies in the 3D cone exactly when
//! `push >= h_i(B) = max(B κ_i(q_i), −B κ_i(−q_i))`, where `κ_i(q)` is the cotangent of the cone's
//! edge in the half-plane (toward the other contact, `v`), [`on_axis`](super::on_axis):
//! `κ(q) = (cos ξ sqrt(p² − cos²ξ + q²) − p q)/(p² − cos²ξ)`, decreasing and convex in `q`
//! (`κ(q) + κ(−q) > 0`, so `h_i` is convex in `B`). Hence the least squeeze and the 2-norm:
//!
//! ```text
//!   IF = max(0, h_1(B1) − s/2, h_2(B2) + s/2),        P = sqrt(2 IF² + s²/2 + B1² + B2²)
//! ```
//!
//! This is the planar problem of `Π(c)` with the sliced cones (spatial module docs §2) in closed
//! form; the planar solver on that plane gives the same values (unit test
//! `closed_form_is_the_planar_problem_of_each_plane`), and the independent 3D reference agrees
//! with the worst case it gives (`tests/it/spatial_robust.rs`, see *Status* below). Force closure is
//! `p_i > cos ξ_i` at both contacts: it does not depend on `c`. Every force is proportional to the mass: the worst mass is the largest.
//! "From above" (the upward vertical through `c` meets the segment) is `B1 <= 0` and `B2 <= 0`.
//!
//! # 3. Where the worst object lies: on the region's edges, not only at its corners
//! The region is the box cut by the tangent planes at the contacts (a centre of mass lies inside a
//! convex object), a convex polytope; a tangent plane the nominal centre of mass lies behind (an
//! object that is not convex there, `docs/theory.md#a-centre-of-mass-behind-a-tangent`) cuts
//! nothing. Nothing below needs the cuts, only a convex polytope. Fix a half-plane `H_ψ` through the axis: on it `v` is fixed,
//! `(ξ, ρ)` are affine coordinates, `B1`, `B2` are affine and `h_i` convex, so `IF` and `P` are
//! convex on `H_ψ`. `H_ψ` meets the region in a convex polygon whose vertices lie on the region's
//! edges or on the axis. So the worst object over the region lies on an edge of the region, or on
//! the axis (every plane). **Corners do not suffice**: along an edge the plane turns, `q_i`
//! changes, and the worst can lie inside an edge, e.g. at `θ = 0` contact 1 needs
//! `ξ κ_1(−q_1(ψ))`, largest where the plane meets the normal's tilt (`ψ = η_1`); the unit test
//! `worst_is_at_least_every_sample_of_the_edges` finds such cases. (The counts and sizes of such
//! cases, and the claim that no point inside a face or the region beats the edges, are argued here
//! but not yet measured against the 3D reference: see *Status*.)
//!
//! # 4. The maximum along an edge, certified
//! Along an edge `c(t)`, `ξ` is affine, `ρ` convex, the direction `v` sweeps an arc shorter than
//! π (an edge through the axis is affine on each side of it, an edge along the axis affine), and
//! `κ_i` is monotone and convex in `q_i`: each ingredient has an exact range over a piece of the
//! edge, and so do the slopes `ρ'` (increasing), `ψ' = (c⊥ × e)/ρ²`, `q_i' = ψ' n⊥_i · v⊥` and
//! `κ'`. Interval arithmetic gives upper bounds of each term `T_j` (the four branches of `h_1`,
//! `h_2`) and of its slope; per piece the bound is the least of the interval bound and the
//! mean-value bound `F(mid) + sup|F'| w/2` (second order near a maximum; `P >= sqrt(1/2)` bounds
//! `1/P`; for the squeeze, `max(T, 0) <= max(T(mid) + sup|T'| w/2, 0)`). Branch and bound splits
//! the piece of highest bound (a heap) until no piece can exceed the best value found by more
//! than `worst::tolerance`: `worst::CERTIFY` (1e-12) of it plus `worst::CERTIFY_ABS` (1e-12 of
//! the weight; see *Tolerances*). The maximum is then known to that (to rounding: the intervals
//! are not rounded outward), and the reported point attains it.
//!
//! # 5. The least worst case: an exchange method with a certificate
//! `R(θ) = max over the region of P(θ, c)` is not an envelope of finitely many closed-form curves
//! (the worst point moves along an edge as θ changes). For a finite set `S` of points of the
//! region, `R_S(θ) = max over S of P(θ, c)` is: each point's curve is the planar solver's closed
//! form in its own plane ([`Analysis`](crate::planar::Analysis)), and their envelope is
//! minimised exactly as in the planar model (`planar/robust/mod.rs` §6), at `θ_S`. As
//! `R >= R_S` everywhere,
//!
//! ```text
//!   R_S(θ_S) <= min over the allowed range of R <= R(θ_S)
//! ```
//!
//! Start with the region's vertices (and its points on the axis); while `R(θ_S) − R_S(θ_S)` (with
//! `R(θ_S)` certified from above, §4) exceeds [`EXCHANGE`] (1e-9) of `R(θ_S)` plus
//! [`EXCHANGE_ABS`] (1e-10 of the weight, *Tolerances*), add the worst point at `θ_S` to `S`
//! (with two neighbours on its edge when it moved along one, *Iteration bounds*) and repeat (at most [`MAX_EXCHANGES`] times; sooner when no point can move `θ_S`, see *Iteration
//! bounds*). The answer is `θ_S`; its worst
//! case is exact (§4), and [`Recommendation::optimality_gap`] is the certified bound
//! of how far it can lie above the least worst case over the allowed range. (A stationary
//! minimum of `R` carried by a moving worst point is approached by curves that touch `R` from
//! below; the choice is checked by a scan of tilts against the 3D reference, see *Status*.)
//!
//! # 6. The allowed range
//! - **From above**: for one object, `θ ∈ [−atan2(x1, ρ), atan2(x2, ρ)]`, i.e. `θ` at most the
//!   elevation `atan2(ξ, ρ)` of `c` seen from contact 2 above the plane across the axis, and at
//!   least minus the elevation from contact 1. Over the region: the least elevation of its points,
//!   seen from each contact. If the ray from contact 2 along `−a` meets the region it is `−π/2`;
//!   otherwise the region seen from the contact is a convex spherical polygon whose boundary is
//!   made of the images of its edges (great-circle arcs), on which the least elevation is found
//!   in closed form (`region`).
//! - **Graspable**: `[−π/2, π/2]` (§1). **Bounds**: met with it, shifted by multiples of 2π.
//! - An empty range is [`NoCommonOrientation`], naming the points that bound it.
//!
//! # 7. What is reported
//! At the recommended tilt and at the current one (after the swing): the worst objective, the
//! worst squeeze and the worst finger force, `squeeze + W |sin θ| / 2` (the weight's part along
//! the axis, `W sin θ`, is the same for every object: `planar/finger.rs`'s definition), and where
//! the first two are attained; the nominal object's values and contact forces at rest in its
//! plane at that tilt; the certificate; the local minima of `R_S` over the allowed range (their
//! angles are those of the final sample set's envelope, their values the certified `R` there);
//! the region's vertices and its points on the axis. With only the mass uncertain the region is
//! the nominal centre of mass: the answer is the nominal object's over the tilts of §1 (for
//! `from_above`, the nominal answer with every force scaled by `(m + Δm)/m`).
//!
//! **One minimum per fan.** Where the exchange added points along one edge (§5, *Iteration
//! bounds*), their curves cross near the least worst case and `R_S` ripples there: a fan of
//! near-identical local minima (25 within 0.01 rad for the slowest candidate of
//! `benches/tail.rs`) that are minima of the finite sample, not of `R`, each of which cost a
//! certified maximisation. So the local minima of `R_S` over the allowed range are taken in
//! increasing angle, and each joins the last one kept when `R_S` between the two (its highest
//! value there: at the pieces' ends and stationary maxima) rises above the higher of them by at
//! most [`FAN_BARRIER`] `= 1e-5 W`; a group keeps its lowest and only it is certified. Two kept
//! minima are then separated by a barrier higher than that (the barrier to a group's lowest is at
//! least the barrier to its first member). `1e-5 W` is 9.8e-5 N for 1 kg: ten times below what
//! a gripper's force sensing resolves (about 1e-4 W, *Tolerances*), so a gripper cannot tell the
//! minima it merges apart, whether they are ripples of the sample or shallow minima of `R`; and
//! above the ripple of the fans of `benches/tail.rs` (the slowest's barriers rise 1e-12 to
//! 9.7e-6 W, 25 minima to 1; unit test `one_minimum_per_fan`). The answer's tilt is `R_S`'s least
//! over the allowed range (§5), unchanged: it is not taken from this list. The planar robust
//! solver does not merge: its worst case is the exact envelope of the region's vertices
//! (`planar/robust/mod.rs` §6), whose local minima are minima of `R` itself, each valued without
//! a maximisation.
//!
//! # Tolerances
//! Every force of §2 is proportional to the weight at the largest mass `W = m_max |g|`, and the
//! solve works in units of it, so each tolerance is relative to the value plus absolute in units
//! of `W`. That keeps the solve scale-free (grams and tonnes take the same steps; the unit test
//! `tiny_normals_and_gravity_give_the_answer_of_unit_ones`), where a fixed number of newtons
//! would be below the rounding of a heavy object's forces and above a light one's whole weight.
//! - The exchange (§5) stops at a gap of `1e-9 R(θ_S) + 1e-10 W`. `1e-10 W` is 9.8e-10 N for
//!   1 kg: six orders below what a gripper's force sensing resolves (about 1e-3 N, 1e-4 of that
//!   weight), and far above the rounding of forces of order `W` (1e-16 of them). With the
//!   relative part alone, a least worst squeeze near zero (the internal-force objective, where
//!   wide cones hold the across forces without squeezing) asked for a gap below rounding: the
//!   exchange ran to [`MAX_EXCHANGES`], every maximisation near its split limit, 13 s for the
//!   grasp of the unit test `near_zero_worst_squeeze_stops_at_the_absolute_tolerance`, which now
//!   answers in 2 exchanges and 271 splits with the same tilt (1e-13 rad) and squeeze (4.6e-13 N).
//!   The 2-norm is at least `W / sqrt(2)` (§2: `s²/2 + B1² + B2² >= (s² + k²)/2`), so there the
//!   absolute part adds at most 1.5e-10 of the value.
//! - The certified maximum (§4) stops at `1e-12 |value| + 1e-12 W`, a hundredth of the exchange's
//!   tolerance, so the certificate never decides when the exchange stops. Before, its absolute
//!   floor was `1e-15 W`, about the rounding of the terms themselves, which the interval bounds
//!   along a nearly flat edge reach only with pieces of 1e-8 of it.
//! - What a user sees: [`Recommendation::optimality_gap`] is at most
//!   `1e-9 gripping_power + 1e-10 W` unless an iteration bound ended the search (the gap then
//!   says how far it got).
//!
//! # Iteration bounds
//! - The certified maximum (§4): at most `worst::MAX_SPLITS` (5,000) pieces split per
//!   maximisation, each two evaluations and a heap operation; past it the largest bound left is
//!   reported, honest but looser. No candidate of `benches/tail.rs` (100,000) comes near it.
//! - The exchange (§5): at most [`MAX_EXCHANGES`] rounds. It also stops when the worst point at
//!   `θ_S` is already in `S`, or its curve rises above the envelope at `θ_S` by no more than the
//!   two evaluations of its value (the closed form of §2 and its planar curve) differ: `R_S` is
//!   then (nearly) unchanged at `θ_S`, and what is left of the gap is that disagreement, not a
//!   missing point. That happens near the friction limit, where values reach 1e6 `W` and the two
//!   (and the envelope's ties) differ by more than 1e-9 of the value; before, such a candidate
//!   added the same point until [`MAX_EXCHANGES`] (unit test
//!   `exchange_stops_when_no_point_can_move_its_tilt`: the same answer with 5 and 14 points added
//!   instead of 60).
//! - Where the worst point moves along one edge from round to round (a stationary minimum of `R`
//!   carried by a moving worst point), each point added alone lets `θ_S` jump from side to side
//!   of the minimum, halving the gap every two rounds. So the two points of that edge half the
//!   last step either side of the new one are added too (each round adds at most 3 points): any
//!   point of the region gives a curve below `R`, so the certificate is unchanged, and the gap
//!   halves every round (27 rounds to 14 for the slowest candidate of `benches/tail.rs`).
//! - So an answer makes at most `MAX_EXCHANGES + 4 + L` maximisations (`L` the local minima it
//!   reports, one per fan, §7), of at most `MAX_SPLITS` splits each; [`Recommendation::splits`]
//!   counts them. A maximisation depends only on the quantity and the tilt, so one at a tilt
//!   already maximised (the answer's tilt is the last exchange round's, and usually one of the
//!   local minima's) is taken from the earlier one, not made again. The envelope's walk is
//!   bounded in `planar/robust/envelope.rs`; a curve nowhere on top of a round's envelope is
//!   left out of the later rounds' walks (points are only added, so it stays below them).
//!
//! # Status: used by the product for spatial candidates with a centre-of-mass box
//! What is checked: the closed form of §2 against the planar solver on each object's own plane
//! (`closed_form_is_the_planar_problem_of_each_plane`, 2,000+ points, 1e-12), and the certified
//! edge maximum of §4 against dense samples of every edge (`worst_is_at_least_every_sample_of_the_edges`).
//! `tests/it/spatial_robust.rs` checks, against the independent 3D reference of `tests/it/util`
//! (Clarabel SOCP on the true cones):
//! - the worst case at the recommended tilt: on 60 random off-axis grasps with random boxes and
//!   mass tolerances, the reported worst `gripping_power` equals the reference's at the reported
//!   point to 4.9e-10 relative, and none of 19,235 grid centres of mass in the boxes needs more;
//! - the choice of tilt (§5) and the allowed range (§6): scanning 40 tilts across the allowed
//!   range on 20 random grasps (14 from above, 6 graspable; 226,000 reference SOCPs over samples
//!   of the region's edges, the axis segment with its worst plane, and this solver's worst point
//!   at each tilt, valued by the reference alone), no tilt has a sampled worst case below the
//!   reported least one (least margin −2.5e-15 relative); every sample is held, and hangs from
//!   above by the 3D definition, at every scanned tilt; the range's bounds exceed no dense
//!   sample's own (bisection on the definition) and lie within 2.6e-5 rad of the tightest
//!   sampled one. The `--ignored` variant (60 grasps × 120 tilts, 1.75 million SOCPs): margin
//!   −4.8e-14, bounds within 6.8e-9 rad. An offset of 0.01 rad on the chosen tilt fails it.
//!
//! What is not checked independently: the swing model of §1 (both sides of those tests take the
//! hang direction from it; it is the reading of the problem), points inside the region's faces
//! beyond the samples, and the squeeze and finger force against the reference (they come from
//! the same closed form as the objective). The message stage (`src/msg/convert.rs`) answers a
//! spatial candidate with a centre-of-mass box with [`solve`]; a mass tolerance
//! alone scales the nominal spatial answer.
//!
//! The 1-norm with a centre-of-mass tolerance is refused ([`InvalidInput::Norm1SpatialTolerance`]):
//! it depends on each plane's own split of the forces into normal and friction parts, which §3's
//! convexity on `H_ψ` survives but the edge bounds of §4 do not cover.
//!
//! # Files
//! `uncertainty.rs` the tolerances and their checks; `region.rs` the region, its points and the
//! least elevation seen from a contact (§3, §6); `worst.rs` one object in closed form and the
//! certified maximum along the edges (§2–§4); `problem.rs` the problem in axis coordinates, each
//! object's plane and the worst case at one tilt (§1–§4); `range.rs` the allowed range (§6);
//! `exchange.rs` the exchange method (§5, *Iteration bounds*); `report.rs` what is reported
//! (§7); `tests.rs` the tests of the whole solve.

mod exchange;
mod problem;
mod range;
mod region;
mod report;
mod uncertainty;
mod worst;

pub use exchange::{EXCHANGE, EXCHANGE_ABS, MAX_EXCHANGES};
pub use range::NoCommonOrientation;
pub use region::{RegionPoint, RegionPointKind};
pub use report::{Recommendation, FAN_BARRIER};
pub use uncertainty::Uncertainty;

use super::on_axis::AxisGrasp;
use super::plane::Geometry;
use crate::{InvalidInput, Objective, Settings};
use nalgebra::Vector3;
use problem::Problem;

/// The spatial robust solver's verdict on valid input.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialRobustVerdict")]
pub enum Verdict {
    /// Every tolerance is zero: exactly [`super::solve`]'s verdict.
    Exact(super::Verdict),
    /// Every object in the tolerances can be held: the tilt of least worst case.
    Recommended(Box<Recommendation>),
    /// No allowed tilt suits every object; the nominal answer is given.
    NoCommonOrientation {
        /// Which points fail.
        reason: NoCommonOrientation,
        /// The nominal object's answer.
        nominal: Box<super::Recommendation>,
    },
    /// No orientation holds the grasp (force closure does not depend on the centre of mass).
    NoForceClosure(super::NoForceClosure),
}

/// Solves one spatial candidate whose centre of mass and mass are known only to within
/// `uncertainty`: the tilt of the contact axis of least worst-case objective (module docs).
///
/// Bad input is an `Err`; with every tolerance zero this is [`super::solve`], unchanged.
///
/// # Example
/// The paper's case (c) square stood up in the y-z plane, its centre of mass known to ±0.1 along
/// x (out of the grasp plane) and y: every object hangs in its own plane, and the worst case
/// needs more than the nominal object.
/// ```
/// use grasp_orient_solver::{Settings, spatial};
/// use nalgebra::Vector3;
///
/// let grasp = spatial::Candidate {
///     contact_1: Vector3::new(0.0, 1.0, 1.0),
///     contact_2: Vector3::new(0.0, -1.0, 1.0),
///     normal_1: Vector3::new(0.0, -1.0, 0.0),
///     normal_2: Vector3::new(0.0, 1.0, 0.0),
///     friction_1: 3f64.sqrt(),
///     friction_2: 1.0 / 3f64.sqrt(),
///     center_of_mass: Vector3::zeros(),
///     mass: 1.0,
///     gravity: Vector3::new(0.0, 0.0, -1.0),
/// };
/// let tolerance = spatial::robust::Uncertainty {
///     center_of_mass_tolerance: Vector3::new(0.1, 0.1, 0.0),
///     mass_tolerance: 0.0,
/// };
/// let Ok(spatial::robust::Verdict::Recommended(r)) =
///     spatial::robust::solve(&grasp, &tolerance, &Settings::default())
/// else {
///     panic!("every object in the box can be held from above");
/// };
/// assert!(r.gripping_power > r.gripping_power_nominal);
/// assert!(r.optimality_gap <= 1e-9 * r.gripping_power);
/// ```
#[doc(alias = "solve_spatial_robust")]
pub fn solve(
    candidate: &super::Candidate,
    uncertainty: &Uncertainty,
    settings: &Settings,
) -> Result<Verdict, InvalidInput> {
    if uncertainty.is_exact() {
        return super::solve(candidate, settings).map(Verdict::Exact);
    }
    let nominal = super::solve(candidate, settings)?;
    uncertainty.validate(candidate.mass)?;
    let nominal = match nominal {
        super::Verdict::Recommended(r) => *r,
        super::Verdict::NoForceClosure(miss) => return Ok(Verdict::NoForceClosure(miss)),
    };
    if uncertainty.center_of_mass_tolerance != Vector3::zeros()
        && settings.objective == Objective::Norm1
    {
        return Err(InvalidInput::Norm1SpatialTolerance);
    }
    let geometry = Geometry::new(candidate, settings.friction_safety_factor)?;
    let axis = match AxisGrasp::new(&geometry) {
        Ok(axis) => axis,
        Err(misses) => {
            return Ok(Verdict::NoForceClosure(super::NoForceClosure {
                misses: misses.into_iter().map(super::Miss::Cone).collect(),
                friction_safety_factor: settings.friction_safety_factor,
            }))
        }
    };
    let problem = Problem::new(candidate, uncertainty, settings, &geometry, &axis, &nominal);
    Ok(match problem.allowed(&settings.range) {
        Err(reason) => Verdict::NoCommonOrientation {
            reason,
            nominal: Box::new(nominal),
        },
        Ok(allowed) => Verdict::Recommended(Box::new(problem.recommend(allowed, nominal))),
    })
}

#[cfg(test)]
mod tests;
