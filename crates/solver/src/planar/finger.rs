//! The force a parallel gripper is set to: each finger's push along the line between the contacts
//! (`docs/theory.md#finger-force`).
//!
//! # Derivation (paper frame, module conventions of [`crate`])
//! Contact 1 sits at `(x1, y)`, contact 2 at `(-x2, y)`: the contact line is the x axis, and the
//! closing line of a parallel gripper is that line. The force contact `i` puts on the object is
//! `N_i n_i + F_i t_i` with the inward normals `n_1 = (-s1, -c1)`, `n_2 = (s2, -c2)` and the
//! paper's tangents `t_1 = (-c1, s1)`, `t_2 = (c2, s2)` (`balance_particular`, eq. 18).
//! "Into the object along the line" is `-x` at contact 1 and `+x` at contact 2, so the pushes are
//!
//! ```text
//! a_1 = -(N1 n_1 + F1 t_1)·x = N1 s1 + F1 c1
//! a_2 = +(N2 n_2 + F2 t_2)·x = N2 s2 + F2 c2
//! ```
//!
//! - **Mean (coupled fingers).** `F = F_T + α F_N` with `F_N = (Mg/2D) (s1, c1, s2, c2)` (eq. 20)
//!   and `F_T ⟂ F_N` (the least-norm solution is orthogonal to the kernel). `a_1 + a_2 = F·(s1,
//!   c1, s2, c2)`, so `F_T` adds nothing to it and `(a_1 + a_2)/2 = α Mg/(2D) · (s1² + c1²) =
//!   α Mg/(2D)`: exactly the internal force. A gripper whose fingers are coupled (one motor through
//!   a rack, pinion or linkage) carries only this common-mode squeeze.
//! - **Difference (independent fingers).** Force balance along x: `-a_1 + a_2 + W_x = 0`, where
//!   `W = M g` is the weight and `W_x = Mg sin θ` its component along the line (gravity points
//!   along `(sin θ, -cos θ)`). So `a_1 - a_2 = W_x`: the finger the weight leans on pushes more,
//!   `a_i = internal force ± W_x/2`, and the larger push is `internal force + |W_x|/2`.
//!
//! [`pushes`] computes `a_1, a_2` from the forces themselves (the definition); the unit test
//! `mean_push_is_the_internal_force_and_the_difference_the_weight_along_the_line` in
//! `analysis.rs`, which reports the finger force, holds the two identities to the solver's own
//! forces, and `tests/it/reference.rs` holds the result to the independent reference's contact
//! forces projected on the line in the candidate's frame (code shared with nothing here).

use super::frame::GraspFrame;

/// The pushes `(a_1, a_2)` of the two contacts along the contact line, into the object, N, in the
/// paper's labelling, from the forces `(N1, F1, N2, F2)` in N with the paper's tangents.
///
/// # Formula
/// `a_1 = N1 s1 + F1 c1`, `a_2 = N2 s2 + F2 c2` (module doc).
pub(crate) fn pushes(f: &GraspFrame, forces: &[f64; 4]) -> [f64; 2] {
    let [n1, f1, n2, f2] = *forces;
    [n1 * f.s1 + f1 * f.c1, n2 * f.s2 + f2 * f.c2]
}

/// The larger of the two pushes, N: what each independently driven finger must be able to give.
pub(crate) fn finger_force(f: &GraspFrame, forces: &[f64; 4]) -> f64 {
    let [a1, a2] = pushes(f, forces);
    a1.max(a2)
}
