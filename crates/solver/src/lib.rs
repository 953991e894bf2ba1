//! The exact gripping-power solver: pure math, SI units, no ROS, no I/O.
//!
//! # Conventions
//! - **Candidate frame**: the planar frame a grasp arrives in (x-y plane of the message's
//!   `header.frame_id`). Angles are counter-clockwise about +z, in radians.
//! - **Paper frame** (Ito et al., Sect. 2.2; `docs/theory.md`): origin at the centre of mass,
//!   x axis along the contact line from contact 2 to contact 1, y axis such that both contacts
//!   have the same `y >= 0`; contact 1 at `(x1, y)`, contact 2 at `(-x2, y)`. The frame is always
//!   right-handed: when the candidate's labelling would make it left-handed, the two contacts are
//!   relabelled internally and every answer is relabelled back.
//! - **Normals** point into the object. In the paper frame the inward normals are
//!   `(-sin φ1, -cos φ1)` and `(sin φ2, -cos φ2)`.
//! - **Gravity** points along `(sin θ, -cos θ)` in the paper frame; `θ` is the *gravity angle*,
//!   the orientation to choose. It is reported in the paper's own interval: the graspable range
//!   `[θ_min, θ_max]` of eqs. (8)–(10), which may reach past `-π` when the centre of mass does not
//!   lie between the contacts.
//! - **Friction**: Coulomb, half-angle of the cone `ξ = atan(μ)`. A safety factor `s >= 1`
//!   divides both coefficients before anything else (`s = 1` is the paper).
//! - **Contact forces** `(N1, F1, N2, F2)`: normal force along the inward normal, friction along
//!   the inward normal turned by +90° about +z, in the candidate's labelling. (The paper's own
//!   tangent at contact 1 points the other way; the conversion happens at the boundary.)
//! - **Units**: metres, kilograms, m/s², newtons. Inside, lengths are scaled by the contact
//!   distance and forces by `m |g|`, which makes the answer exactly invariant to units.
//!
//! # What is computed
//! For each θ the force-balance solutions form a line `F = F_T + α F_N` (Appendix A); the six
//! contact inequalities bound α from below by `α_min(θ)`, the upper envelope of sinusoids. The
//! objective (gripping power) is `P(θ) = min ||F_T + α F_N||` over feasible α. The recommendation
//! is the exact minimiser of `P` over the allowed range, found from the envelope's breakpoints and
//! the closed-form stationary points of each piece.
//!
//! When the centre of mass and the mass are known only to within tolerances, [`planar::robust::solve`]
//! minimises the worst case of `P` over them instead (the mathematics is in
//! `planar/robust/mod.rs` and `docs/theory.md`).
//!
//! # Modules
//! [`planar`] answers a grasp in a plane ([`planar::solve`], [`planar::analyse`]) and [`spatial`]
//! one in 3D ([`spatial::solve`], [`spatial::analyse`]); each has a `robust` module for the worst
//! case over tolerances ([`planar::robust::solve`], [`spatial::robust::solve`]). The two mirror
//! each other: `Candidate`, `Recommendation`, `Verdict`, `NoForceClosure` in each, named by their
//! module. The root holds only what both share: [`Settings`], [`Objective`], [`AllowedRange`]
//! (`settings.rs`), [`Contact`] (`contact.rs`), [`InvalidInput`] (`invalid_input.rs`) and the
//! input limits (`limits.rs`), re-exported here. [`batch`] answers many planar or spatial
//! candidates in one call, each as the single path does, bit for bit. Each module's `mod.rs` holds its docs and entry
//! points; the types and steps lie in files below it, and no file uses one that uses it.

pub mod batch;
mod contact;
mod invalid_input;
mod limits;
pub mod planar;
mod settings;
mod sinusoid;
pub mod spatial;
pub mod table_1;

/// The README's example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExample;

pub use contact::Contact;
pub use invalid_input::{InvalidInput, Readable};
pub use limits::{
    MAX_COORDINATE, MAX_FRICTION, MAX_GRAVITY, MAX_MASS, MAX_SAFETY_FACTOR, MIN_FRICTION,
    MIN_WEIGHT,
};
/// Scaling by a power of two, exact: what the checks use to take lengths scale-free.
pub use planar::frame::times_pow2;
pub use planar::frame::{check_friction, check_mass, BEHIND_TANGENT, SQUARE_SAFE};
pub use settings::{AllowedRange, Objective, Settings, UnknownObjective};
