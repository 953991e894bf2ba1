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
//! form in its own plane ([`Analysis`]), and their envelope is minimised exactly as in the planar
//! model (`planar/robust/mod.rs` §6), at `θ_S`. As `R >= R_S` everywhere,
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
//!   in closed form ([`region`]).
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

mod region;
mod worst;

use super::on_axis::AxisGrasp;
use super::plane::Geometry;
use crate::planar::analysis::Analysis;
use crate::planar::curve::Curve;
use crate::planar::frame::{GraspFrame, MAX_COORDINATE};
use crate::planar::paper::FORCE_SCALE;
use crate::planar::robust::{check_tolerance, periodic_meet, Envelope};
use crate::sinusoid::Angle;
use crate::{planar::LocalMinimum, AllowedRange, Contact, InvalidInput, Objective, Settings};
use nalgebra::{Vector2, Vector3};
use region::Region;
use std::cell::{Cell, RefCell};
use std::f64::consts::FRAC_PI_2;
use std::fmt;
use worst::{AxisPoint, AxisView, Quantity, Segment};

/// Stop adding points when the certified gap is at most this fraction of the worst case, plus
/// [`EXCHANGE_ABS`] (module docs §5).
pub const EXCHANGE: f64 = 1e-9;
/// The absolute part of the exchange method's tolerance, a fraction of the weight at the largest
/// mass: 1e-10 `m_max |g|`, 9.8e-10 N for 1 kg (module docs, *Tolerances*).
pub const EXCHANGE_ABS: f64 = 1e-10;
/// Two local minima of the sampled worst case are one (a fan) when the envelope between them
/// rises above the higher by at most this fraction of the weight at the largest mass: 1e-5
/// `m_max |g|`, 9.8e-5 N for 1 kg (module docs §7, *One minimum per fan*).
pub const FAN_BARRIER: f64 = 1e-5;
/// Most points added by the exchange method; past it the gap reached is reported.
pub const MAX_EXCHANGES: usize = 60;

/// How well a spatial object is known. Zero everywhere means exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[doc(alias = "SpatialUncertainty")]
pub struct Uncertainty {
    /// Half-widths of a box around `center_of_mass` along the x, y and z axes of the candidate
    /// frame, m, each `>= 0`.
    pub center_of_mass_tolerance: Vector3<f64>,
    /// The mass lies in `mass ± mass_tolerance`, kg, in `[0, mass)`.
    pub mass_tolerance: f64,
}

impl Uncertainty {
    /// No uncertainty: the nominal problem.
    pub const EXACT: Uncertainty = Uncertainty {
        center_of_mass_tolerance: Vector3::new(0.0, 0.0, 0.0),
        mass_tolerance: 0.0,
    };

    /// Whether every tolerance is zero.
    pub fn is_exact(&self) -> bool {
        self.center_of_mass_tolerance == Vector3::zeros() && self.mass_tolerance == 0.0
    }

    /// Checks the tolerances against the candidate's mass, naming the field at fault.
    fn validate(&self, mass: f64) -> Result<(), InvalidInput> {
        let t = &self.center_of_mass_tolerance;
        check_tolerance("center_of_mass_tolerance.x", t.x, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.y", t.y, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.z", t.z, MAX_COORDINATE, " m")?;
        check_tolerance("mass_tolerance", self.mass_tolerance, mass, " kg")
    }
}

/// A point of the region of possible centres of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionPoint {
    /// Position in the candidate frame, m.
    pub position: Vector3<f64>,
    /// Which point it is.
    pub kind: RegionPointKind,
}

/// Which point of the region a [`RegionPoint`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegionPointKind {
    /// A corner of the box: the signs of its offset from `center_of_mass` along x, y and z (`0`
    /// along an axis whose tolerance is zero).
    Corner {
        /// `-1`, `0` or `1`.
        x: i8,
        /// `-1`, `0` or `1`.
        y: i8,
        /// `-1`, `0` or `1`.
        z: i8,
    },
    /// A vertex where the tangent plane at a contact cuts the box.
    Cut {
        /// The contact.
        contact: Contact,
    },
    /// A point inside an edge of the region (module docs §3).
    Edge,
    /// A point of the region on the contact axis: every plane through the axis is taken.
    Axis,
}

impl fmt::Display for RegionPoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.position;
        let at = format!("({:.6}, {:.6}, {:.6}) m", p.x, p.y, p.z);
        let sign = |s: i8| match s {
            -1 => "-",
            1 => "+",
            _ => "",
        };
        match self.kind {
            RegionPointKind::Corner { x: 0, y: 0, z: 0 } => write!(f, "the centre of mass {at}"),
            RegionPointKind::Corner { x, y, z } => {
                let names: Vec<String> = [(x, 'x'), (y, 'y'), (z, 'z')]
                    .iter()
                    .filter(|(s, _)| *s != 0)
                    .map(|(s, n)| format!("{}{n}", sign(*s)))
                    .collect();
                write!(f, "corner ({}) of the box, {at}", names.join(", "))
            }
            RegionPointKind::Cut { contact } => {
                write!(
                    f,
                    "{at}, where the box meets the tangent plane at {contact}"
                )
            }
            RegionPointKind::Edge => write!(f, "{at} on an edge of the region"),
            RegionPointKind::Axis => write!(f, "{at} on the contact axis"),
        }
    }
}

/// Why no tilt of the contact axis suits every object in the region (status 1).
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialNoCommonOrientation")]
pub enum NoCommonOrientation {
    /// Hanging from above: `first` needs the gravity angle at least `lo`, `second` at most
    /// `hi < lo`.
    Disjoint {
        /// The point whose range starts last.
        first: RegionPoint,
        /// Its range's start, rad.
        lo: f64,
        /// The point whose range ends first.
        second: RegionPoint,
        /// Its range's end, rad.
        hi: f64,
    },
    /// Explicit bounds miss `[−π/2, π/2]`, the tilts at which every object hangs (module docs §1).
    BoundsMissed {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
    },
}

impl fmt::Display for NoCommonOrientation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("no tilt of the contact axis suits every object in the tolerances: ")?;
        match self {
            NoCommonOrientation::Disjoint {
                first,
                lo,
                second,
                hi,
            } => write!(
                f,
                "to hang from above with the centre of mass at {first} the gravity angle must be \
                 at least {lo:.6} rad, at {second} at most {hi:.6} rad"
            ),
            NoCommonOrientation::BoundsMissed { lo, hi } => write!(
                f,
                "the range bounds [{lo:.6}, {hi:.6}] rad miss [-pi/2, pi/2], the gravity angles at \
                 which an object whose centre of mass is uncertain hangs below the contact axis"
            ),
        }
    }
}

/// The answer when a tolerance is not zero and every object in it can be held. "Worst" is the
/// largest over the region (the box cut by the object's tangent planes) and the mass interval.
#[derive(Debug, Clone, PartialEq)]
#[doc(alias = "SpatialRobustRecommendation")]
pub struct Recommendation {
    /// The objective minimised (its worst case).
    pub objective: Objective,
    /// The recommended gravity angle θ*, rad in `[−π/2, π/2]`: `sin θ* = ĝ · a`, the tilt of the
    /// contact axis; every object hangs at θ* in its own plane (module docs §1).
    pub gravity_angle: f64,
    /// Unit vector, candidate frame: the recommended gravity at which the nominal object hangs at
    /// rest, `sin θ* a + cos θ* v_0`. Any rotation of the wrist about the contact axis from
    /// there gives the same hang.
    pub gravity_direction: Vector3<f64>,
    /// Unit axis, candidate frame, of the smallest rotation of the object taking the current
    /// gravity to `gravity_direction`.
    pub rotation_axis: Vector3<f64>,
    /// Angle of that rotation, rad in `[0, π]`.
    pub rotation_angle: f64,
    /// Worst objective value at the recommended tilt, N.
    pub gripping_power: f64,
    /// Where in the region it is attained (at the largest mass).
    pub gripping_power_at: RegionPoint,
    /// Worst squeeze at the recommended tilt, N.
    pub internal_force: f64,
    /// Where in the region it is attained (at the largest mass).
    pub internal_force_at: RegionPoint,
    /// Worst push of the harder-pushing finger along the contact axis, N: `internal_force +
    /// m_max |g| |sin θ*| / 2`.
    pub finger_force: f64,
    /// The certified bound: no tilt in the allowed range has a worst objective below
    /// `gripping_power − optimality_gap`, N (module docs §5).
    pub optimality_gap: f64,
    /// Worst objective after every object swings at the current pose, N.
    pub gripping_power_current: f64,
    /// Worst squeeze there, N.
    pub internal_force_current: f64,
    /// Worst finger force there, N.
    pub finger_force_current: f64,
    /// The gravity angle every object hangs at from the current pose, `asin(ĝ_0 · a)`, rad.
    pub current_gravity_angle: f64,
    /// The nominal object's objective value at rest at the recommended tilt, N.
    pub gripping_power_nominal: f64,
    /// The nominal object's squeeze there, N.
    pub internal_force_nominal: f64,
    /// The nominal object's `(N1, F1, N2, F2)` there, N, split as [`super::Recommendation`]
    /// splits them (in the nominal's plane).
    pub contact_forces: [f64; 4],
    /// The nominal object's contact forces there as 3D vectors, candidate frame, N.
    pub force_vectors: [Vector3<f64>; 2],
    /// Local minima of the worst case over the allowed range, one per fan of minima separated by
    /// less than [`FAN_BARRIER`] (module docs §7), in increasing angle, unlabelled.
    pub local_minima: Vec<LocalMinimum>,
    /// The allowed gravity angles for every object, rad, as closed intervals in `[−π/2, π/2]`.
    pub allowed: Vec<(f64, f64)>,
    /// The vertices of the region of centres of mass.
    pub region: Vec<RegionPoint>,
    /// The region's points on the contact axis, as a segment, if it meets the axis.
    pub axis_segment: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The largest mass, kg.
    pub mass_worst: f64,
    /// How many points the exchange method used (module docs §5).
    pub samples: usize,
    /// How many pieces of edges the certified maximisations split in all (module docs §4): the
    /// work of this answer, bounded (module docs §4).
    pub splits: usize,
    /// The nominal object's own answer.
    pub nominal: super::Recommendation,
}

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

/// Everything the solve needs, in axis coordinates.
struct Problem {
    objective: Objective,
    quantity: Quantity,
    view: AxisView,
    region: Region,
    segments: Vec<Segment>,
    /// The region's points on the axis (the ends of that segment).
    axis_points: Vec<AxisPoint>,
    /// The nominal centre of mass.
    center: AxisPoint,
    /// Whether the region is that point alone (only the mass is uncertain).
    point_region: bool,
    /// The direction across the axis of the nominal object's plane (from the axis to `c`).
    reference: Vector2<f64>,
    /// Unit inward normals, friction after the safety factor, the safety factor.
    mu: [f64; 2],
    safety: f64,
    /// Current gravity angle after the swing.
    current: f64,
    /// Unit current gravity, candidate frame.
    g0: Vector3<f64>,
    /// `m_max |g|` and `m |g|`, N.
    weight: f64,
    nominal_weight: f64,
    mass_worst: f64,
    /// The splits of every maximisation so far (module docs §4).
    splits: Cell<usize>,
    /// The maximisations made so far, by quantity and tilt (the bits of θ): the last exchange
    /// round's tilt is the answer's, and usually one of the local minima's too, and a
    /// maximisation depends on nothing else, so each is made once.
    done: RefCell<Vec<(bool, u64, worst::Worst)>>,
}

impl Problem {
    fn new(
        candidate: &super::Candidate,
        uncertainty: &Uncertainty,
        settings: &Settings,
        g: &Geometry,
        axis: &AxisGrasp,
        nominal: &super::Recommendation,
    ) -> Self {
        let contacts = axis.contacts;
        let across = contacts.map(|c| Vector2::new(c.azimuth.cos(), c.azimuth.sin()) * c.sin_delta);
        let view = AxisView {
            p2: g.p[1],
            a: axis.a,
            b1: axis.b1,
            b2: axis.b2,
            d: g.d,
            contacts,
            across,
        };
        let region = Region::new(
            g.c,
            uncertainty.center_of_mass_tolerance,
            [
                (Contact::First, g.p[0], g.n[0]),
                (Contact::Second, g.p[1], g.n[1]),
            ],
            g.d,
        );
        let segments = region
            .segments
            .iter()
            .map(|(s, e)| Segment {
                start: view.coordinates(s),
                end: view.coordinates(e),
            })
            .collect();
        let axis_points = match region.clip(&g.p[1], &g.a, f64::NEG_INFINITY) {
            Some((t0, t1)) => [t0, t1]
                .iter()
                .map(|t| AxisPoint {
                    xi: t / g.d,
                    across: Vector2::zeros(),
                })
                .collect(),
            None => Vec::new(),
        };
        let c0 = view.coordinates(&g.c).across;
        let reference = if c0.norm() > 0.0 {
            c0 / c0.norm()
        } else {
            // On the axis: the nominal answer's plane, `v` along its gravity's part across.
            let y = nominal.plane_y;
            let v = -Vector2::new(y.dot(&axis.b1), y.dot(&axis.b2));
            if v.norm() > 0.0 {
                v / v.norm()
            } else {
                Vector2::x()
            }
        };
        let mass_worst = candidate.mass + uncertainty.mass_tolerance;
        // Scale-free: a gravity whose square underflows still has its length.
        let g_norm = super::plane::length(&candidate.gravity);
        Self {
            center: view.coordinates(&g.c),
            point_region: uncertainty.center_of_mass_tolerance == Vector3::zeros(),
            objective: settings.objective,
            quantity: match settings.objective {
                Objective::InternalForce => Quantity::Squeeze,
                _ => Quantity::Norm2,
            },
            view,
            region,
            segments,
            axis_points,
            reference,
            mu: g.mu,
            safety: g.safety,
            current: g.g0.dot(&g.a).clamp(-1.0, 1.0).asin(),
            g0: g.g0,
            weight: mass_worst * g_norm,
            nominal_weight: candidate.mass * g_norm,
            mass_worst,
            splits: Cell::new(0),
            done: RefCell::new(Vec::new()),
        }
    }
}

impl Problem {
    /// The gravity angles allowed for every object (module docs §6).
    fn allowed(&self, range: &AllowedRange) -> Result<Vec<(f64, f64)>, NoCommonOrientation> {
        match *range {
            AllowedRange::FromAbove => {
                let v = &self.view;
                let p1 = v.p2 + v.a * v.d;
                let (hi, second) = self.region.least_elevation(&v.p2, &v.a);
                let (low, first) = self.region.least_elevation(&p1, &-v.a);
                let lo = -low;
                if lo > hi {
                    return Err(NoCommonOrientation::Disjoint {
                        first,
                        lo,
                        second,
                        hi,
                    });
                }
                Ok(vec![(lo, hi)])
            }
            AllowedRange::Graspable => Ok(vec![(-FRAC_PI_2, FRAC_PI_2)]),
            AllowedRange::Bounds { lo, hi } => {
                let out = periodic_meet(lo, hi, -FRAC_PI_2, FRAC_PI_2);
                if out.is_empty() {
                    Err(NoCommonOrientation::BoundsMissed { lo, hi })
                } else {
                    Ok(out)
                }
            }
        }
    }

    /// The planar frame of the object at `p` in its own plane, in the shared convention of
    /// module docs §1–§2 (unit weight). On the axis, `across` picks the plane (`None`: the worst
    /// plane for each contact, which on the axis is `q_i = sin δ_i` for every tilt, `B_i <= 0`).
    fn frame_at(&self, p: &AxisPoint, across: Option<Vector2<f64>>) -> GraspFrame {
        let rho = p.across.norm();
        let v = if rho > 0.0 {
            Some(p.across / rho)
        } else {
            across
        };
        let contacts = self.view.contacts;
        let q: [f64; 2] = std::array::from_fn(|i| match v {
            Some(v) => self.view.across[i].dot(&v),
            None => contacts[i].sin_delta,
        });
        let plane: [(f64, f64, f64); 2] = std::array::from_fn(|i| {
            let (p, sd) = (contacts[i].cos_delta, contacts[i].sin_delta);
            let len = p.hypot(q[i]);
            let tilt = (sd * sd - q[i] * q[i]).max(0.0).sqrt() / len;
            let mu = super::sliced_friction(self.mu[i], tilt).unwrap_or(0.0);
            (p / len, q[i] / len, mu)
        });
        GraspFrame {
            x1: 1.0 - p.xi,
            x2: p.xi,
            y: rho,
            s1: plane[0].0,
            c1: plane[0].1,
            s2: plane[1].0,
            c2: plane[1].1,
            mu1: plane[0].2,
            mu2: plane[1].2,
            friction_safety_factor: self.safety,
            current_theta: self.current,
            weight: 1.0,
            contact_distance: self.view.d,
            swapped: false,
            e_x: Vector2::x(),
            e_y: Vector2::y(),
        }
    }

    /// The curve of the object at `p` over the gravity angles (module docs §5), if its frame
    /// has force closure (it has whenever the grasp has, §2).
    fn analysis(&self, p: &AxisPoint) -> Option<Analysis> {
        let plane = self.point_region.then_some(self.reference);
        Analysis::new(&self.frame_at(p, plane), self.objective).ok()
    }

    /// The worst objective (or squeeze) at `theta` over the region, units of the weight (module
    /// docs §4); for a region of one point, that object's own value.
    fn worst(&self, squeeze: bool, theta: f64) -> worst::Worst {
        if self.point_region {
            let value = self.analysis(&self.center).map_or(f64::NAN, |a| {
                let v = a.evaluate(theta);
                if squeeze {
                    v.internal_force
                } else {
                    v.power
                }
            });
            return worst::Worst {
                value,
                segment: None,
                t: 0.0,
                point: self.center,
                bound: value,
                splits: 0,
            };
        }
        let q = if squeeze {
            Quantity::Squeeze
        } else {
            self.quantity
        };
        let key = (squeeze, theta.to_bits());
        if let Some(&(_, _, w)) = self.done.borrow().iter().find(|d| (d.0, d.1) == key) {
            return w;
        }
        let worst = self.view.worst(q, theta, &self.segments, &self.axis_points);
        self.splits.set(self.splits.get() + worst.splits);
        self.done.borrow_mut().push((key.0, key.1, worst));
        worst
    }

    /// A point of the maximisation named as a point of the region.
    fn region_point(&self, p: &AxisPoint) -> RegionPoint {
        let position = self.view.position(p);
        if p.across == Vector2::zeros() {
            return RegionPoint {
                position,
                kind: RegionPointKind::Axis,
            };
        }
        let eps = 1e-9 * self.view.d;
        match self
            .region
            .vertices
            .iter()
            .find(|v| (v.position - position).norm() <= eps)
        {
            Some(v) => *v,
            None => RegionPoint {
                position,
                kind: RegionPointKind::Edge,
            },
        }
    }

    /// The exchange method (module docs §5): the tilt, its certified gap, the final envelope
    /// and the number of points used.
    fn exchange(&self, allowed: &[(f64, f64)]) -> (f64, f64, Envelope, usize) {
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
    fn neighbours(
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

    /// Everything the answer reports (module docs §7).
    fn recommend(
        &self,
        allowed: Vec<(f64, f64)>,
        nominal: super::Recommendation,
    ) -> Recommendation {
        let (theta, gap, envelope, samples) = self.exchange(&allowed);
        let w = self.weight;
        let power = self.worst(false, theta);
        let squeeze = self.worst(true, theta);
        let power_now = self.worst(false, self.current);
        let squeeze_now = self.worst(true, self.current);
        let finger = |sq: f64, at: f64| w * (sq + 0.5 * at.sin().abs());
        let in_range = envelope
            .local_minima(FORCE_SCALE)
            .into_iter()
            .filter(|m| {
                allowed
                    .iter()
                    .any(|&(a, b)| m.gravity_angle >= a && m.gravity_angle <= b)
            })
            .collect();
        let local_minima = one_per_fan(&envelope, in_range)
            .into_iter()
            .map(|m| LocalMinimum {
                power: w * self.worst(false, m.gravity_angle).value,
                ..m
            })
            .collect();
        let (n, v) = (&self.view, self.reference);
        let v3 = n.b1 * v.x + n.b2 * v.y;
        let (s, k) = theta.sin_cos();
        let direction = n.a * s + v3 * k;
        let (rotation_axis, rotation_angle) = rotation(&direction, &self.g0, &n.a.cross(&v3));
        let (nominal_values, contact_forces, force_vectors) = self.nominal_at(theta, &nominal);
        Recommendation {
            objective: self.objective,
            gravity_angle: theta,
            gravity_direction: direction,
            rotation_axis,
            rotation_angle,
            gripping_power: w * power.value,
            gripping_power_at: self.region_point(&power.point),
            internal_force: w * squeeze.value,
            internal_force_at: self.region_point(&squeeze.point),
            finger_force: finger(squeeze.value, theta),
            optimality_gap: w * gap,
            gripping_power_current: w * power_now.value,
            internal_force_current: w * squeeze_now.value,
            finger_force_current: finger(squeeze_now.value, self.current),
            current_gravity_angle: self.current,
            gripping_power_nominal: nominal_values.power,
            internal_force_nominal: nominal_values.internal_force,
            contact_forces,
            force_vectors,
            local_minima,
            allowed,
            region: self.region.vertices.clone(),
            axis_segment: match self.axis_points.as_slice() {
                [a, b] => Some((n.position(a), n.position(b))),
                _ => None,
            },
            mass_worst: self.mass_worst,
            samples,
            splits: self.splits.get(),
            nominal,
        }
    }

    /// The nominal object at rest at tilt `theta` in its plane: its values (N), its contact
    /// forces split as the nominal answer splits them, and as 3D vectors.
    fn nominal_at(
        &self,
        theta: f64,
        nominal: &super::Recommendation,
    ) -> (crate::planar::PointValue, [f64; 4], [Vector3<f64>; 2]) {
        let frame = GraspFrame {
            weight: self.nominal_weight,
            ..self.frame_at(&self.center, Some(self.reference))
        };
        let value = match Analysis::new(&frame, self.objective) {
            Ok(a) => a.evaluate(theta),
            Err(_) => crate::planar::PointValue {
                alpha_min: f64::NAN,
                alpha: f64::NAN,
                power: f64::NAN,
                internal_force: f64::NAN,
                forces: [f64::NAN; 4],
            },
        };
        // Paper frame (e_x, e_y) = (a, −v): the paper's normals and tangents (`planar/paper.rs`).
        let [n1, f1, n2, f2] = value.forces;
        let p1 = Vector2::new(
            -frame.s1 * n1 - frame.c1 * f1,
            -frame.c1 * n1 + frame.s1 * f1,
        );
        let p2 = Vector2::new(
            frame.s2 * n2 + frame.c2 * f2,
            -frame.c2 * n2 + frame.s2 * f2,
        );
        let v3 = self.view.b1 * self.reference.x + self.view.b2 * self.reference.y;
        let lift = |q: Vector2<f64>| self.view.a * q.x - v3 * q.y;
        let vectors = [lift(p1), lift(p2)];
        let split = |i: usize| {
            (
                vectors[i].dot(&nominal.normal_directions[i]),
                vectors[i].dot(&nominal.friction_directions[i]),
            )
        };
        let ((a, b), (c, d)) = (split(0), split(1));
        (value, [a, b, c, d], vectors)
    }
}

/// The local minima of `R_S` (`minima`, in increasing angle, values in units of the weight), one
/// per fan (module docs §7, *One minimum per fan*): each joins the last one kept when the
/// envelope between the two rises above the higher of them by at most [`FAN_BARRIER`]; a fan
/// keeps its lowest (the first of equals).
fn one_per_fan(envelope: &Envelope, minima: Vec<LocalMinimum>) -> Vec<LocalMinimum> {
    let mut kept: Vec<LocalMinimum> = Vec::with_capacity(minima.len());
    for m in minima {
        if let Some(last) = kept.last_mut() {
            let higher = last.power.max(m.power);
            let barrier =
                envelope.highest_between(last.gravity_angle, m.gravity_angle, FORCE_SCALE);
            if barrier - higher <= FAN_BARRIER {
                if m.power < last.power {
                    *last = m;
                }
                continue;
            }
        }
        kept.push(m);
    }
    kept
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

/// The smallest rotation of the object taking the current gravity `g0` to `d` (both unit), as
/// (unit axis, angle in `[0, π]`); `fallback` when they are parallel (spatial module docs §4).
fn rotation(d: &Vector3<f64>, g0: &Vector3<f64>, fallback: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let cross = d.cross(g0);
    let norm = cross.norm();
    let angle = norm.atan2(d.dot(g0));
    if norm > 0.0 {
        (cross / norm, angle)
    } else {
        (fallback.normalize(), angle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A deterministic sequence in [0, 1) (no rand in the library).
    fn uniform(k: u64) -> f64 {
        let x = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Contacts on the x axis at ±0.5, normals tilted off the axis within 0.9 of the friction
    /// angle, the centre of mass off the axis inside the object.
    fn grasp(k: u64) -> crate::spatial::Candidate {
        let r = |j: u64| uniform(97 * k + j);
        let mu = [0.3 + 1.2 * r(0), 0.3 + 1.2 * r(1)];
        let normal = |toward: f64, mu: f64, a: f64, b: f64| {
            let delta = 0.9 * mu.atan() * a;
            let eta = 2.0 * PI * b;
            Vector3::new(
                toward * delta.cos(),
                delta.sin() * eta.cos(),
                delta.sin() * eta.sin(),
            )
        };
        crate::spatial::Candidate {
            contact_1: Vector3::new(0.5, 0.0, 0.0),
            contact_2: Vector3::new(-0.5, 0.0, 0.0),
            normal_1: normal(-1.0, mu[0], r(2), r(3)),
            normal_2: normal(1.0, mu[1], r(4), r(5)),
            friction_1: mu[0],
            friction_2: mu[1],
            center_of_mass: Vector3::new(0.2 * (r(6) - 0.5), r(7) - 0.5, r(8) - 0.5),
            mass: 1.0,
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }

    fn problem(
        c: &crate::spatial::Candidate,
        t: Vector3<f64>,
        settings: &Settings,
    ) -> Option<Problem> {
        let g = Geometry::new(c, settings.friction_safety_factor).ok()?;
        let axis = AxisGrasp::new(&g).ok()?;
        let nominal = match crate::spatial::solve(c, settings).ok()? {
            crate::spatial::Verdict::Recommended(r) => *r,
            crate::spatial::Verdict::NoForceClosure(_) => return None,
        };
        let u = super::Uncertainty {
            center_of_mass_tolerance: t,
            mass_tolerance: 0.0,
        };
        Some(Problem::new(c, &u, settings, &g, &axis, &nominal))
    }

    /// As the planar `tiny_normals_and_gravity_give_the_answer_of_unit_ones`: normals and
    /// gravity of lengths whose squares underflow give the answer of unit ones, never a panic.
    #[test]
    fn tiny_normals_and_gravity_give_the_answer_of_unit_ones() {
        let u = super::Uncertainty {
            center_of_mass_tolerance: Vector3::new(0.02, 0.05, 0.05),
            mass_tolerance: 0.1,
        };
        let mut compared = 0;
        for k in 0..20 {
            let c = grasp(k);
            let Ok(super::Verdict::Recommended(want)) = super::solve(&c, &u, &Settings::default())
            else {
                continue;
            };
            for scale in [1e-200, 1e-160, 1e3] {
                let scaled = crate::spatial::Candidate {
                    normal_1: c.normal_1 * scale,
                    normal_2: c.normal_2 * scale,
                    gravity: c.gravity * scale,
                    ..c
                };
                let got = super::solve(&scaled, &u, &Settings::default());
                let Ok(super::Verdict::Recommended(got)) = got else {
                    panic!("grasp {k} at scale {scale:e}: {got:?}");
                };
                let power = got.gripping_power / scale;
                assert!(
                    (power - want.gripping_power).abs() <= 1e-9 * want.gripping_power,
                    "grasp {k} at scale {scale:e}: {power} against {}",
                    want.gripping_power
                );
            }
            compared += 1;
        }
        assert!(compared >= 5, "only {compared} grasps held");
    }

    /// Module docs §2: the closed form is the planar problem of each object's own plane with the
    /// sliced cones, at every tilt, for the 2-norm and the squeeze.
    #[test]
    fn closed_form_is_the_planar_problem_of_each_plane() {
        let settings = Settings::default();
        let mut checked = 0;
        for k in 0..200 {
            let c = grasp(k);
            let Some(p) = problem(&c, Vector3::new(0.1, 0.1, 0.1), &settings) else {
                continue;
            };
            for j in 0..20 {
                let q = AxisPoint {
                    xi: 0.5 + 0.6 * (uniform(1000 * k + j) - 0.5),
                    across: Vector2::new(uniform(2000 * k + j) - 0.5, uniform(3000 * k + j) - 0.5)
                        * if j == 0 { 0.0 } else { 1.0 },
                };
                let frame = p.frame_at(&q, None);
                let norm2 = Analysis::new(&frame, Objective::Norm2).expect("force closure");
                for i in 0..=12 {
                    let theta = -FRAC_PI_2 + PI * f64::from(i) / 12.0;
                    let held = p.view.held(worst::Tilt::new(theta), &q);
                    let v = norm2.evaluate(theta);
                    assert!(
                        (held.norm2 - v.power).abs() <= 1e-12 * v.power.max(1.0),
                        "grasp {k} point {j} θ {theta}: closed form {} planar {}",
                        held.norm2,
                        v.power
                    );
                    assert!((held.squeeze - v.internal_force).abs() <= 1e-12);
                }
                checked += 1;
            }
        }
        assert!(checked > 2000, "{checked}");
    }

    /// Module docs §4: the certified maximum is attained, is at least every sample of every
    /// segment, and its bound is within `worst::tolerance` of it.
    #[test]
    fn worst_is_at_least_every_sample_of_the_edges() {
        let settings = Settings::default();
        let mut inside = 0;
        for k in 0..60 {
            let c = grasp(k);
            let t = Vector3::new(0.05, 0.1 + 0.2 * uniform(k), 0.15);
            let Some(p) = problem(&c, t, &settings) else {
                continue;
            };
            for i in 0..=6 {
                let theta = -1.2 + 0.4 * f64::from(i);
                let tilt = worst::Tilt::new(theta);
                for q in [Quantity::Norm2, Quantity::Squeeze] {
                    let w = p.view.worst(q, theta, &p.segments, &p.axis_points);
                    assert!(
                        w.bound <= w.value + 2.0 * worst::tolerance(w.value),
                        "grasp {k} θ {theta} {q:?}: {} bound {}",
                        w.value,
                        w.bound
                    );
                    assert_eq!(p.view.held(tilt, &w.point).get(q), w.value);
                    let mut corners = f64::NEG_INFINITY;
                    for s in &p.segments {
                        for j in 0..=400 {
                            let u = f64::from(j) / 400.0;
                            let x = AxisPoint {
                                xi: s.start.xi + u * (s.end.xi - s.start.xi),
                                across: s.start.across + (s.end.across - s.start.across) * u,
                            };
                            let v = p.view.held(tilt, &x).get(q);
                            assert!(v <= w.value * (1.0 + 1e-12) + 1e-15, "{v} > {}", w.value);
                            if j == 0 || j == 400 {
                                corners = corners.max(v);
                            }
                        }
                    }
                    if w.value > corners * (1.0 + 1e-9) {
                        inside += 1;
                    }
                }
            }
        }
        assert!(inside > 0, "some worst case lies inside an edge");
    }

    /// A slow candidate of `benches/tail.rs` or of a search over grasps like those of `grasp`,
    /// with the answer the code before the absolute tolerances gave (tilt, rad; worst objective
    /// or squeeze, N; its optimality gap, N).
    struct Slow {
        candidate: crate::spatial::Candidate,
        uncertainty: super::Uncertainty,
        settings: Settings,
        theta: f64,
        worst: f64,
        gap: f64,
    }

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    fn settings(objective: Objective, range: AllowedRange) -> Settings {
        Settings {
            objective,
            range,
            friction_safety_factor: 1.0,
        }
    }

    /// Two grasps whose least worst squeeze is nearly zero (2.4e-12 N and 3.2e-12 N for 1 kg):
    /// before, 13.1 s and 3.4 s, 848,650 and 432,890 splits, 60 exchanges each.
    fn near_zero() -> [Slow; 2] {
        let on_x = |n1: Vector3<f64>, n2: Vector3<f64>, mu: [f64; 2], c: Vector3<f64>| {
            crate::spatial::Candidate {
                contact_1: v(0.5, 0.0, 0.0),
                contact_2: v(-0.5, 0.0, 0.0),
                normal_1: n1,
                normal_2: n2,
                friction_1: mu[0],
                friction_2: mu[1],
                center_of_mass: c,
                mass: 1.0,
                gravity: v(0.0, 0.0, -9.81),
            }
        };
        let box_only = |t: Vector3<f64>| super::Uncertainty {
            center_of_mass_tolerance: t,
            mass_tolerance: 0.0,
        };
        let squeeze = settings(Objective::InternalForce, AllowedRange::FromAbove);
        [
            Slow {
                candidate: on_x(
                    v(
                        -0.6815505217213076,
                        -0.07242003458118966,
                        0.7281787039818404,
                    ),
                    v(
                        0.9500655588463088,
                        -0.27151487552663317,
                        0.15380216598542368,
                    ),
                    [2.6557311296951367, 2.8237716723701576],
                    v(
                        -0.10530261081942052,
                        0.06744281348838999,
                        -0.25338512008042935,
                    ),
                ),
                uncertainty: box_only(v(
                    0.018852004023307157,
                    0.05779785540169908,
                    0.1334933618506316,
                )),
                settings: squeeze,
                theta: -0.20833619399952674,
                worst: 2.4107865703726363e-12,
                gap: 9.042170769802352e-15,
            },
            Slow {
                candidate: on_x(
                    v(-0.7737229617873674, 0.16951864688963342, 0.6104229736499862),
                    v(
                        0.9996627730722427,
                        0.015832826018956688,
                        -0.02058304529867066,
                    ),
                    [2.730273375802295, 2.8415419211549255],
                    v(0.18397766953444217, 0.0, -0.3732619286966661),
                ),
                uncertainty: box_only(v(
                    0.12533002197510593,
                    0.04859973371867802,
                    0.14544780395194531,
                )),
                settings: squeeze,
                theta: -0.2767464724034294,
                worst: 3.1955038615194554e-12,
                gap: 9.779493863340376e-15,
            },
        ]
    }

    /// Two random candidates of `benches/tail.rs` (#8792 and #7057 of 10,000) near their friction
    /// limits (worst cases of 6e6 and 3e4 weights), where the closed form and the envelope's
    /// curves differ by more than 1e-9 of the value: before, 60 exchanges each, the same point
    /// added again from the sixth and the ninth on (17 ms and 16 ms).
    fn stalled() -> [Slow; 2] {
        [
            Slow {
                candidate: crate::spatial::Candidate {
                    contact_1: v(
                        -1.1574751372189247,
                        -0.19217043114056687,
                        0.38937497679891575,
                    ),
                    contact_2: v(-0.6808526915378249, -1.2532419930319527, 0.470093511767125),
                    normal_1: v(5.6384536440844295, -1.5475668434245964, -4.178425842080429),
                    normal_2: v(-1.0439514926140983, 0.8059377811084422, 0.523303758841005),
                    friction_1: 1.8457809785157102,
                    friction_2: 0.7705562784004047,
                    center_of_mass: v(
                        -1.2149217611679903,
                        -1.263057387385236,
                        -0.05271830066805705,
                    ),
                    mass: 0.19478281224264662,
                    gravity: v(10.32822757158938, 2.6231222872542594, -3.533838044566626),
                },
                uncertainty: super::Uncertainty {
                    center_of_mass_tolerance: v(
                        0.3285526076281989,
                        0.29987471628323575,
                        0.15696614367656203,
                    ),
                    mass_tolerance: 0.02144190228808399,
                },
                settings: settings(Objective::Norm2, AllowedRange::Graspable),
                theta: -0.9058400928580875,
                worst: 1.2319644428713254e6,
                gap: 1.7167989416105476e-3,
            },
            Slow {
                candidate: crate::spatial::Candidate {
                    contact_1: v(
                        -0.35555005168395126,
                        -1.3960802994854324,
                        0.5316673674899104,
                    ),
                    contact_2: v(-0.24847967096433804, -1.511068468207179, 0.5008542388780519),
                    normal_1: v(0.20889315338557216, -0.9137321244483038, -2.011038268922028),
                    normal_2: v(-0.12522124598822784, 0.126065726927939, 0.01260070716404045),
                    friction_1: 1.5882557096741559,
                    friction_2: 0.12763932692758997,
                    center_of_mass: v(-0.3636958059404188, -1.4832912499306736, 0.537686013987476),
                    mass: 22.537203552058187,
                    gravity: v(9.043802656199327, 3.178870681810648, 3.5678849579373537),
                },
                uncertainty: super::Uncertainty {
                    center_of_mass_tolerance: v(
                        0.040722356533697934,
                        0.04132116257966973,
                        0.005015202613254787,
                    ),
                    mass_tolerance: 3.971054276253289,
                },
                settings: settings(Objective::InternalForce, AllowedRange::Graspable),
                theta: -0.6388369768524306,
                worst: 8.403534968804736e6,
                gap: 5.3825707519851634e-2,
            },
        ]
    }

    fn solved(s: &Slow) -> super::Recommendation {
        match super::solve(&s.candidate, &s.uncertainty, &s.settings) {
            Ok(super::Verdict::Recommended(r)) => *r,
            other => panic!("{other:?}"),
        }
    }

    /// The points the exchange method added to the region's vertices and axis points (the worst
    /// point of each round and its neighbours).
    fn exchanges(r: &super::Recommendation) -> usize {
        r.samples - r.region.len() - usize::from(r.axis_segment.is_some()) * 2
    }

    /// Module docs, *Tolerances*: a least worst squeeze near zero stops at the absolute
    /// tolerance, within the iteration counts of ordinary candidates (a few hundred splits, a
    /// few exchanges), at the tilt and squeeze of before to well within the tolerance.
    #[test]
    fn near_zero_worst_squeeze_stops_at_the_absolute_tolerance() {
        for (k, s) in near_zero().iter().enumerate() {
            let r = solved(s);
            let tol = EXCHANGE_ABS * r.mass_worst * s.candidate.gravity.norm();
            println!(
                "near zero {k}: θ {:.17} squeeze {:e} N gap {:e} N, {} splits, {} exchanges",
                r.gravity_angle,
                r.internal_force,
                r.optimality_gap,
                r.splits,
                exchanges(&r)
            );
            assert!(r.splits <= 2_000, "{k}: {} splits", r.splits);
            assert!(exchanges(&r) <= 10, "{k}: {} exchanges", exchanges(&r));
            assert!(r.optimality_gap <= tol, "{k}");
            // Within the tolerance (1e-10 of the weight, 9.8e-10 N here) of the answer before.
            assert!((r.internal_force - s.worst).abs() <= tol + s.gap, "{k}");
            assert!((r.gravity_angle - s.theta).abs() <= 1e-9, "{k}");
        }
    }

    /// Module docs §5, *Iteration bounds*: when the worst point at θ_S is already a sample, or
    /// its curve does not rise above the envelope there by more than its two evaluations differ,
    /// the exchange stops instead of adding it again until [`MAX_EXCHANGES`] (60 points before);
    /// the answer is the one of before.
    #[test]
    fn exchange_stops_when_no_point_can_move_its_tilt() {
        for (k, s) in stalled().iter().enumerate() {
            let r = solved(s);
            let value = match s.settings.objective {
                Objective::InternalForce => r.internal_force,
                _ => r.gripping_power,
            };
            println!(
                "stalled {k}: θ {:.17} worst {value:e} N gap {:e} N, {} splits, {} exchanges",
                r.gravity_angle,
                r.optimality_gap,
                r.splits,
                exchanges(&r)
            );
            assert!(exchanges(&r) <= 20, "{k}: {} exchanges", exchanges(&r));
            assert!(r.splits <= 2_000, "{k}: {} splits", r.splits);
            assert!(
                (value - s.worst).abs() <= 1e-9 * s.worst,
                "{k}: {value} {}",
                s.worst
            );
            assert!(r.optimality_gap <= s.gap.max(1e-9 * value), "{k}");
            assert!((r.gravity_angle - s.theta).abs() <= 1e-9, "{k}");
        }
    }

    /// Module docs §7, *One minimum per fan*: the slowest candidate of `benches/tail.rs`
    /// (#14833) reported 27 local minima, 25 of them a fan within 0.01 rad of the answer whose
    /// separating barriers rise at most 9.7e-6 of the weight, each valued by its own certified
    /// maximisation (2,765 splits in all). One per fan: the minimum 0.3 rad below it, the fan's
    /// lowest and the one across the range; the answer is the one of before.
    #[test]
    fn one_minimum_per_fan() {
        let s = Slow {
            candidate: crate::spatial::Candidate {
                contact_1: v(0.37579301970347456, 1.678390513028841, 0.28867764865079115),
                contact_2: v(0.3166935767251592, 2.3230553430081073, -0.7094528743328252),
                normal_1: v(
                    -0.04638894109481941,
                    0.10181071083527465,
                    -0.018378483100017443,
                ),
                normal_2: v(1.5148189627253503, -2.154160498127905, 2.2995217854345333),
                friction_1: 1.9447726842882251,
                friction_2: 0.7322443735890246,
                center_of_mass: v(0.3432331554470405, 2.0335597154983973, -0.2612246238803148),
                mass: 0.28647168020482605,
                gravity: v(5.03818004870848, -0.24842905177107885, 5.4974205787526635),
            },
            uncertainty: super::Uncertainty {
                center_of_mass_tolerance: v(
                    0.15020811588559219,
                    0.3258216811122028,
                    0.19660497230142177,
                ),
                mass_tolerance: 0.0413978533856024,
            },
            settings: settings(Objective::InternalForce, AllowedRange::FromAbove),
            theta: -0.636877542429512,
            worst: 6.666259049438088,
            gap: 2.8269938110932852e-9,
        };
        let r = solved(&s);
        println!(
            "fan: {} minima, {} splits, θ {:.17}",
            r.local_minima.len(),
            r.splits,
            r.gravity_angle
        );
        let angles: Vec<f64> = r.local_minima.iter().map(|m| m.gravity_angle).collect();
        assert_eq!(angles.len(), 3, "{angles:?}");
        assert!((angles[0] + 0.937).abs() < 1e-3, "{angles:?}");
        assert!((angles[1] - s.theta).abs() < 0.01, "{angles:?}");
        assert!((angles[2] - 0.703).abs() < 1e-3, "{angles:?}");
        // The fan's minimum is worth no more than the answer, to the exchange's tolerance.
        let tol = EXCHANGE * s.worst + EXCHANGE_ABS * r.mass_worst * s.candidate.gravity.norm();
        assert!(r.local_minima[1].power <= r.internal_force + tol);
        assert!((r.gravity_angle - s.theta).abs() <= 1e-12);
        assert!((r.internal_force - s.worst).abs() <= 1e-12 * s.worst);
        assert!(r.optimality_gap <= s.gap + tol);
        assert!(r.splits < 2_000, "{} splits", r.splits);
    }
}
