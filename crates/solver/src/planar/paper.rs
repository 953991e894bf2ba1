//! The paper's closed forms (Ito et al., Appendices A–D), on a [`GraspFrame`]
//! (`docs/theory.md#force-balance` to `#ranges`).
//!
//! Everything here is in the frame's normalised units: lengths divided by the contact distance
//! (so `x1 + x2 = 1`) and forces by the weight `m |g|`. With `D = x1 + x2` the paper's force
//! scale is `Mg / (2D)`; [`FORCE_SCALE`] is that factor in these units.
//!
//! # Where the paper is wrong or loose
//! - Eq. (34)'s first equality drops a sign: `(c μ + s)/(s μ - c) = -tan(φ + ξ)`, not
//!   `+tan(φ + ξ)`. Eqs. (30)–(33) carry the right sign in their last form, and so does this code
//!   (test `ratio_is_minus_tan_phi_plus_xi`).
//! - Lemmas 1 and 2 hold for every force-closure grasp, not only for `x1, x2, y > 0`: `α_1` lies
//!   between `α_3` and `α_5`, and `α_2` between `α_4` and `α_6`, so `α_min` is the upper
//!   envelope of `α_3 .. α_6` alone (test `alpha_1_and_2_never_bind`).

use super::frame::GraspFrame;
use crate::sinusoid::Sinusoid;

/// `Mg / (2 (x1 + x2))` in units where `Mg = 1` and `x1 + x2 = 1`.
pub const FORCE_SCALE: f64 = 0.5;

/// The ratio `(c μ + s) / (s μ - c)` of eq. (30), equal to `-tan(φ + ξ)`; positive numerator
/// and denominator signs follow from force closure (3).
///
/// # Formula
/// `(c μ ± s) / (s μ ∓ c) = -tan(φ ± ξ)` with `tan ξ = μ` (eq. 34, sign corrected).
fn upper_ratio(s: f64, c: f64, mu: f64) -> f64 {
    (c * mu + s) / (s * mu - c)
}

/// The ratio `(c μ - s) / (s μ + c)` of eq. (32), equal to `-tan(φ - ξ)`.
fn lower_ratio(s: f64, c: f64, mu: f64) -> f64 {
    (c * mu - s) / (s * mu + c)
}

/// The six lower bounds `α_k(θ) = a_k sin θ + b_k cos θ`, `k = 1..6` (index `k - 1`).
///
/// # Formula
/// With `D = x1 + x2`:
/// - (26) `α_1 = -D s + 2 (x2 c - y s) cot φ1`
/// - (27) `α_2 = +D s + 2 (x1 c + y s) cot φ2`
/// - (30) `α_3 = -D s + 2 (x2 c - y s) (c1 μ1 + s1)/(s1 μ1 - c1)`
/// - (31) `α_4 = +D s + 2 (x1 c + y s) (c2 μ2 + s2)/(s2 μ2 - c2)`
/// - (32) `α_5 = -D s + 2 (x2 c - y s) (c1 μ1 - s1)/(s1 μ1 + c1)`
/// - (33) `α_6 = +D s + 2 (x1 c + y s) (c2 μ2 - s2)/(s2 μ2 + c2)`
///
/// `α_1, α_3, α_5` come from contact 1 (normal force, the two cone sides), `α_2, α_4, α_6`
/// from contact 2.
pub fn alpha_bounds(f: &GraspFrame) -> [Sinusoid; 6] {
    let d = f.x1 + f.x2;
    let one = |k: f64| Sinusoid::new(-d - 2.0 * f.y * k, 2.0 * f.x2 * k);
    let two = |k: f64| Sinusoid::new(d + 2.0 * f.y * k, 2.0 * f.x1 * k);
    [
        one(f.c1 / f.s1),
        two(f.c2 / f.s2),
        one(upper_ratio(f.s1, f.c1, f.mu1)),
        two(upper_ratio(f.s2, f.c2, f.mu2)),
        one(lower_ratio(f.s1, f.c1, f.mu1)),
        two(lower_ratio(f.s2, f.c2, f.mu2)),
    ]
}

/// `F_T / FORCE_SCALE`: the minimum-norm solution of the force balance (4), entries
/// `(N1, F1, N2, F2)` as sinusoids in θ. `F1`, `F2` along the paper's tangents `(-c1, s1)` and
/// `(c2, s2)`.
///
/// # Formula
/// (18) `F_T = Mg/(2D) [ D s1 s + 2(y s - x2 c) c1,  D c1 s - 2(y s - x2 c) s1,
///                      -D s2 s - 2(y s + x1 c) c2, -D c2 s + 2(y s + x1 c) s2 ]`
pub fn balance_particular(f: &GraspFrame) -> [Sinusoid; 4] {
    let d = f.x1 + f.x2;
    [
        Sinusoid::new(d * f.s1 + 2.0 * f.y * f.c1, -2.0 * f.x2 * f.c1),
        Sinusoid::new(d * f.c1 - 2.0 * f.y * f.s1, 2.0 * f.x2 * f.s1),
        Sinusoid::new(-d * f.s2 - 2.0 * f.y * f.c2, -2.0 * f.x1 * f.c2),
        Sinusoid::new(-d * f.c2 + 2.0 * f.y * f.s2, 2.0 * f.x1 * f.s2),
    ]
}

/// `F_N / FORCE_SCALE`: the internal-force direction, the kernel of the grasp matrix.
///
/// # Formula
/// (20) `F_N = Mg/(2D) [s1, c1, s2, c2]`; each finger then pushes `α Mg/(2D)` along the contact
/// line.
pub fn balance_internal(f: &GraspFrame) -> [f64; 4] {
    [f.s1, f.c1, f.s2, f.c2]
}

/// The angles that bound the analysis and the three crossings of Theorem 1, raw as the paper
/// defines them (`atan2` in `(-π, π]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateAngles {
    /// (9) `θ_min = -π + atan2(x2, y)`: candidate A.
    pub theta_min: f64,
    /// (10) `θ_max = π - atan2(x1, y)`: candidate E.
    pub theta_max: f64,
    /// (36) `θ_36 = atan2(B36, A36)`: candidate B.
    pub theta_36: f64,
    /// (42) `θ_34 = atan2(B34, A34)`: candidate C.
    pub theta_34: f64,
    /// (39) `θ_45 = atan2(B45, A45)`: candidate D.
    pub theta_45: f64,
}

/// Theorem 1's candidate angles.
///
/// # Formula
/// With `t_{i±} = tan(φ_i ± ξ_i)`:
/// - (37, 38) `A36 = y (t1+ + t2-) - D`, `B36 = x2 t1+ - x1 t2-`
/// - (43, 44) `A34 = D - y (t1+ + t2+)`, `B34 = x1 t2+ - x2 t1+`
/// - (40, 41) `A45 = y (t1- + t2+) - D`, `B45 = x2 t1- - x1 t2+`
pub fn candidate_angles(f: &GraspFrame) -> CandidateAngles {
    let d = f.x1 + f.x2;
    let t1p = -upper_ratio(f.s1, f.c1, f.mu1);
    let t1m = -lower_ratio(f.s1, f.c1, f.mu1);
    let t2p = -upper_ratio(f.s2, f.c2, f.mu2);
    let t2m = -lower_ratio(f.s2, f.c2, f.mu2);
    let (a36, b36) = (f.y * (t1p + t2m) - d, f.x2 * t1p - f.x1 * t2m);
    let (a34, b34) = (d - f.y * (t1p + t2p), f.x1 * t2p - f.x2 * t1p);
    let (a45, b45) = (f.y * (t1m + t2p) - d, f.x2 * t1m - f.x1 * t2p);
    let ((lo, hi), _) = ranges(f);
    CandidateAngles {
        theta_min: lo,
        theta_max: hi,
        theta_36: b36.atan2(a36),
        theta_34: b34.atan2(a34),
        theta_45: b45.atan2(a45),
    }
}

/// The graspable range (8) `(θ_min, θ_max)` and the from-above range, which share two angles.
///
/// # Formula
/// (9) `θ_min = -π + atan2(x2, y)`, (10) `θ_max = π - atan2(x1, y)`; from above
/// `[-atan2(x1, y), atan2(x2, y)]` (`docs/theory.md`): at its ends the centre of mass hangs
/// straight below contact 1 or contact 2, at the graspable range's ends it stands straight above
/// contact 2 or contact 1.
pub fn ranges(f: &GraspFrame) -> ((f64, f64), (f64, f64)) {
    use std::f64::consts::PI;
    let (t1, t2) = (f.x2.atan2(f.y), f.x1.atan2(f.y));
    ((-PI + t1, PI - t2), (-t2, t1))
}

/// Whether the friction cone at the paper's contact 1 and at contact 2 contain the centre of
/// mass (closed cones), for Theorem 1's cases.
pub fn cones_contain_center_of_mass(f: &GraspFrame) -> [bool; 2] {
    // Contact 1: normal (-s1, -c1), direction to the centre of mass (-x1, -y).
    let dot1 = f.s1 * f.x1 + f.c1 * f.y;
    let cross1 = f.s1 * f.y - f.c1 * f.x1;
    // Contact 2: normal (s2, -c2), direction to the centre of mass (x2, -y).
    let dot2 = f.s2 * f.x2 + f.c2 * f.y;
    let cross2 = f.c2 * f.x2 - f.s2 * f.y;
    [
        dot1 > 0.0 && cross1.abs() <= f.mu1 * dot1,
        dot2 > 0.0 && cross2.abs() <= f.mu2 * dot2,
    ]
}

/// Force closure (3): `s_i μ_i + c_i > 0` and `s_i μ_i - c_i > 0` at both contacts.
/// Returns, for the paper's contacts 1 and 2, `None` when the cone contains the other contact
/// and otherwise `Some((half_angle, angle_to_other))`.
pub fn closure_misses(f: &GraspFrame) -> [Option<(f64, f64)>; 2] {
    let one = |s: f64, c: f64, mu: f64| {
        if s * mu + c > 0.0 && s * mu - c > 0.0 {
            None
        } else {
            Some((mu.atan(), c.abs().atan2(s)))
        }
    };
    [one(f.s1, f.c1, f.mu1), one(f.s2, f.c2, f.mu2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sinusoid::Angle;
    use crate::table_1::paper_grasp;
    use approx::assert_abs_diff_eq;
    use nalgebra::Vector2;

    /// A frame straight from the paper's parameters (Table 1 style).
    fn frame(p1: (f64, f64), p2x: f64, phi: (f64, f64), mu: (f64, f64)) -> GraspFrame {
        GraspFrame::new(&paper_grasp(p1, p2x, phi, mu), 1.0).expect("valid")
    }

    #[test]
    fn ratio_is_minus_tan_phi_plus_xi() {
        for &(phi, mu) in &[(1.0f64, 0.8f64), (1.4, 0.3), (2.0, 1.5)] {
            let (s, c) = phi.sin_cos();
            let xi = mu.atan();
            assert_abs_diff_eq!(upper_ratio(s, c, mu), -(phi + xi).tan(), epsilon = 1e-12);
            assert_abs_diff_eq!(lower_ratio(s, c, mu), -(phi - xi).tan(), epsilon = 1e-12);
        }
    }

    #[test]
    fn particular_solution_balances_gravity_and_is_orthogonal_to_the_kernel() {
        let f = frame((0.7, 0.4), -0.3, (1.2, 1.1), (0.9, 0.7));
        let t = balance_particular(&f);
        let w = balance_internal(&f);
        let (x1, x2, y) = (f.x1, f.x2, f.y);
        for i in 0..20 {
            let at = Angle::new(-3.0 + 0.3 * i as f64);
            let v: Vec<f64> = t.iter().map(|s| FORCE_SCALE * s.value(&at)).collect();
            // Forces of contact 1 and 2 in the paper frame.
            let f1 = Vector2::new(-f.s1 * v[0] - f.c1 * v[1], -f.c1 * v[0] + f.s1 * v[1]);
            let f2 = Vector2::new(f.s2 * v[2] + f.c2 * v[3], -f.c2 * v[2] + f.s2 * v[3]);
            let sum = f1 + f2;
            assert_abs_diff_eq!(sum, Vector2::new(-at.sin, at.cos), epsilon = 1e-12);
            let moment = x1 * f1.y - y * f1.x + (-x2) * f2.y - y * f2.x;
            assert_abs_diff_eq!(moment, 0.0, epsilon = 1e-12);
            let dot: f64 = v.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
            assert_abs_diff_eq!(dot, 0.0, epsilon = 1e-12);
        }
    }

    #[test]
    fn alpha_1_and_2_never_bind() {
        for k in 0..200 {
            let u = k as f64;
            let f = frame(
                (0.2 + (u * 0.37).sin().abs(), 0.1 + (u * 0.71).cos().abs()),
                -(0.1 + (u * 0.13).sin().abs()),
                (1.2 + 0.3 * (u * 0.29).sin(), 1.3 + 0.2 * (u * 0.53).cos()),
                (0.8 + 0.5 * (u * 0.91).sin(), 0.9 + 0.4 * (u * 0.17).cos()),
            );
            if closure_misses(&f).iter().any(Option::is_some) {
                continue;
            }
            let a = alpha_bounds(&f);
            for i in 0..100 {
                let at = Angle::new(-3.5 + 0.07 * i as f64);
                let v: Vec<f64> = a.iter().map(|s| s.value(&at)).collect();
                assert!(v[0] <= v[2].max(v[4]) + 1e-12);
                assert!(v[1] <= v[3].max(v[5]) + 1e-12);
            }
        }
    }

    #[test]
    fn theta_34_is_the_rising_zero_of_alpha_4_minus_alpha_3() {
        let f = frame((5.0, 4.0), -3.0, (0.785, 0.785), (1.5, 2.5));
        let a = alpha_bounds(&f);
        let angles = candidate_angles(&f);
        let diff = a[3].minus(&a[2]);
        let z = diff.rising_zero().expect("non-zero");
        assert!((crate::sinusoid::wrap_angle(z - angles.theta_34)).abs() < 1e-12);
        let b = a[2].minus(&a[5]).rising_zero().expect("non-zero");
        assert!((crate::sinusoid::wrap_angle(b - angles.theta_36)).abs() < 1e-12);
        let d = a[4].minus(&a[3]).rising_zero().expect("non-zero");
        assert!((crate::sinusoid::wrap_angle(d - angles.theta_45)).abs() < 1e-12);
    }
}
