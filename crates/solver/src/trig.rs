//! The sine, cosine and arctangent the solver evaluates, from one of two sources ([`Trig`]): the
//! C library's (the single path: `planar::solve`, `spatial::solve`, the robust solvers) or the
//! inline kernels below (the batch path, `crate::batch`), which the compiler inlines into the
//! walk of the envelope instead of calling out (the library's `sin_cos` and `atan2` were a
//! quarter of a grasp's time, `batch/mod.rs`).
//!
//! # The kernels
//! Both are the scalar form of the vector kernels of Agner Fog's vector class library (as the
//! `wide` crate has them, whose `atan2` the envelope's crossings already use, `sinusoid.rs`),
//! with the same constants:
//! - [`sin_cos`]: with `q` the integer nearest `|x| · 2/π`, the remainder
//!   `r = |x| - q π/2 ∈ [-π/4, π/4]` is computed in three steps, `π/2 = DP1 + DP2 + DP3`, each
//!   product `q · DPk` exact for the `q` here (`DP1` has 30 significant bits, `DP2` 32), so
//!   `r` carries the rounding of the last step alone (Cody and Waite). Then
//!   `sin r = r + r³ P(r²)` and `cos r = 1 - r²/2 + r⁴ Q(r²)` with minimax polynomials of
//!   degree 5 in `r²` (relative error below 2⁻⁵³ on `[-π/4, π/4]`), and
//!   `sin(|x|) = (sin r, cos r, -sin r, -cos r)[q mod 4]`, `cos(|x|) = (cos r, -sin r, -cos r,
//!   sin r)[q mod 4]`; the sign of `x` goes to the sine. Near a zero of the sine or cosine the
//!   value is `±r`, whose error is absolute (the rounding of `|x| - q·DP1 - q·DP2`, below
//!   `1e-22 |x|`) rather than relative. Beyond `|x| = 2²⁰` (never an angle of the
//!   solver's, whose ranges lie within a few turns of zero) the library's `sin_cos` is used.
//! - [`atan2`]: `(|x|, |y|)` is folded into the first octant (swapping when `|y| > |x|`), so that
//!   `t = min/max ∈ [0, 1]`; below `t = 0.66`, `atan t = atan z` with `z = t`, above it
//!   `atan t = π/4 + atan z` with `z = (t - 1)/(t + 1)` (`tan(a - π/4) = (t - 1)/(t + 1)`), so
//!   `|z| <= 0.66` where the rational minimax `atan z = z + z³ P(z²)/Q(z²)` (degrees 4 and 5)
//!   holds to below an ulp; `π/4` is added with its remainder `6.12e-17/2`. Then the octant is unfolded: `π/2 - a` after a swap, `π - a` for `x < 0`, and
//!   the sign of `y` (a zero `y` keeps its sign: `atan2(±0, x)` is `±0` or `±π`).
//!
//! Over the solver's angles both are within two ulps of the C library's (the sine and cosine
//! near their zeros within `1e-19 |x|`; the tests below measure it against `f64::sin_cos` and
//! `f64::atan2` over a million points), so an answer of the batch
//! differs from the single path's by a few roundings (`tests/batch.rs` holds it to 1e-15 of
//! `max(1, |value|)` per field).

/// Where the solver's trigonometric functions come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Trig {
    /// The C library's `sin_cos` and `atan2` (the single path).
    #[default]
    Libm,
    /// [`sin_cos`] and [`atan2`] of this module (the batch path).
    Inline,
}

impl Trig {
    /// `(sin x, cos x)`.
    #[inline]
    pub(crate) fn sin_cos(self, x: f64) -> (f64, f64) {
        match self {
            Trig::Libm => x.sin_cos(),
            Trig::Inline => sin_cos(x),
        }
    }

    /// `atan2(y, x)`, in `[-π, π]`.
    #[inline]
    pub(crate) fn atan2(self, y: f64, x: f64) -> f64 {
        match self {
            Trig::Libm => y.atan2(x),
            Trig::Inline => atan2(y, x),
        }
    }
}

/// `|x|` above which [`sin_cos`] hands over to the library (module docs).
const INLINE_SIN_COS_LIMIT: f64 = 1_048_576.0;

/// `(sin x, cos x)` within two ulps of the C library's for `|x| <= 2²⁰` (module docs).
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    const P: [f64; 6] = [
        -1.666_666_666_666_663_072_95E-1,
        8.333_333_333_322_118_588_78E-3,
        -1.984_126_982_958_953_859_96E-4,
        2.755_731_362_138_572_452_13E-6,
        -2.505_074_776_285_780_728_66E-8,
        1.589_623_015_765_465_680_60E-10,
    ];
    const Q: [f64; 6] = [
        4.166_666_666_666_659_292_18E-2,
        -1.388_888_888_887_305_641_16E-3,
        2.480_158_728_885_170_453_48E-5,
        -2.755_731_417_929_673_881_12E-7,
        2.087_570_084_197_473_167_78E-9,
        -1.135_853_652_138_768_173_00E-11,
    ];
    const DP1: f64 = 7.853_981_554_508_209_228_515_625E-1 * 2.0;
    const DP2: f64 = 7.946_627_356_147_928_367_14E-9 * 2.0;
    const DP3: f64 = 3.061_616_997_868_382_943_07E-17 * 2.0;
    let xa = x.abs();
    // Also NaN and the infinities, which the library answers with NaN.
    if !(xa <= INLINE_SIN_COS_LIMIT) {
        return x.sin_cos();
    }
    // Nearest integer, ties to even: below 2^52 adding and taking away 2^52 rounds to an integer.
    let q = (xa * std::f64::consts::FRAC_2_PI + 4_503_599_627_370_496.0) - 4_503_599_627_370_496.0;
    let r = ((xa - q * DP1) - q * DP2) - q * DP3;
    let r2 = r * r;
    let poly = |c: &[f64; 6]| {
        let mut acc = c[5];
        for k in (0..5).rev() {
            acc = acc * r2 + c[k];
        }
        acc
    };
    let s = (r * r2) * poly(&P) + r;
    let c = (r2 * r2) * poly(&Q) + (1.0 - 0.5 * r2);
    let (sin_abs, cos) = match (q as i64) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (
        if x.is_sign_negative() {
            -sin_abs
        } else {
            sin_abs
        },
        cos,
    )
}

/// `atan2(y, x)` within two ulps of the C library's (module docs); `atan2(±0, ±0)` as the
/// library gives it (`±0` or `±π`).
#[inline]
pub(crate) fn atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    const P: [f64; 5] = [
        -6.485_021_904_942_025_371_773E1,
        -1.228_866_684_490_136_173_410E2,
        -7.500_855_792_314_704_667_340E1,
        -1.615_753_718_733_365_076_637E1,
        -8.750_608_600_031_904_122_785E-1,
    ];
    const Q: [f64; 5] = [
        1.945_506_571_482_613_964_425E2,
        4.853_903_996_359_136_964_868E2,
        4.328_810_604_912_902_668_951E2,
        1.650_270_098_316_988_542_046E2,
        2.485_846_490_142_306_297_962E1,
    ];
    const MORE_BITS_O2: f64 = 6.123_233_995_736_765_886_130E-17 * 0.5;
    if !(x.is_finite() && y.is_finite()) {
        return y.atan2(x);
    }
    let (xa, ya) = (x.abs(), y.abs());
    let swap = ya > xa;
    let (num, den) = if swap { (xa, ya) } else { (ya, xa) };
    let a = if den == 0.0 {
        0.0 // both zero: the angle of ±0 along the x axis
    } else {
        let t = num / den; // in [0, 1]
        let (z, base) = if t >= 0.66 {
            ((t - 1.0) / (t + 1.0), FRAC_PI_4 + MORE_BITS_O2)
        } else {
            (t, 0.0)
        };
        let zz = z * z;
        let px = (((P[4] * zz + P[3]) * zz + P[2]) * zz + P[1]) * zz + P[0];
        let qx = ((((zz + Q[4]) * zz + Q[3]) * zz + Q[2]) * zz + Q[1]) * zz + Q[0];
        (px / qx) * (z * zz) + z + base
    };
    let a = if swap { FRAC_PI_2 - a } else { a };
    let a = if x.is_sign_negative() { PI - a } else { a };
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How many doubles lie between `a` and `b` (0 when equal; ±0 count as equal).
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        let key = |v: f64| {
            let bits = v.to_bits() as i64;
            if bits < 0 {
                i64::MIN - bits
            } else {
                bits
            }
        };
        key(a).abs_diff(key(b))
    }

    /// A deterministic walk over `[0, 1)`.
    fn walk(n: usize, seed: f64) -> impl Iterator<Item = f64> {
        let mut u = seed;
        (0..n).map(move |_| {
            u = (u * 3.987_654_321 + 0.314_159_265).fract();
            u
        })
    }

    #[test]
    fn sin_cos_is_within_two_ulps_of_the_library() {
        let special = [
            0.0,
            -0.0,
            1e-300,
            -1e-20,
            std::f64::consts::FRAC_PI_4,
            std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            -std::f64::consts::PI,
            std::f64::consts::TAU,
            3.0 * std::f64::consts::FRAC_PI_2,
            1e3,
            INLINE_SIN_COS_LIMIT,
            -INLINE_SIN_COS_LIMIT,
        ];
        // Angles of the solver (a few turns), then up to the limit, then near multiples of π/4.
        let points = special
            .into_iter()
            .chain(walk(600_000, 0.123).map(|u| 40.0 * u - 20.0))
            .chain(walk(200_000, 0.456).map(|u| (2.0 * u - 1.0) * INLINE_SIN_COS_LIMIT))
            .chain(walk(200_000, 0.789).map(|u| {
                let k = (u * 64.0).floor() - 32.0;
                k * std::f64::consts::FRAC_PI_4 + (u * 1e6).fract() * 1e-9
            }));
        let (mut worst, mut differing) = (0, 0usize);
        for x in points {
            let (s, c) = sin_cos(x);
            let (ws, wc) = x.sin_cos();
            // Near a zero of sin or cos the value is the remainder `r`, whose rounding is absolute
            // (an ulp of `|x| - q·DP1`, below 1e-22 |x|): counted in ulps of the tiny value it
            // can be many.
            let near = |got: f64, want: f64| {
                ulps(got, want) <= 2 || (got - want).abs() <= 1e-19 * x.abs().max(1.0)
            };
            assert!(
                near(s, ws) && near(c, wc),
                "{x:e}: ({s:e}, {c:e}) against ({ws:e}, {wc:e})"
            );
            if ws.abs() > 1e-3 && wc.abs() > 1e-3 {
                worst = worst.max(ulps(s, ws)).max(ulps(c, wc));
            }
            differing += usize::from(s != ws || c != wc);
        }
        assert!(worst <= 2, "worst {worst} ulps");
        assert!(differing > 0, "a test that cannot tell the two apart");
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
        assert_eq!(sin_cos(-0.0).0.to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn atan2_is_within_two_ulps_of_the_library() {
        let signed = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-300,
            -1e300,
            f64::MIN_POSITIVE,
            5e-324,
        ];
        let mut pairs: Vec<(f64, f64)> = signed
            .iter()
            .flat_map(|&y| signed.iter().map(move |&x| (y, x)))
            .collect();
        pairs.extend(
            walk(1_000_000, 0.321)
                .zip(walk(1_000_000, 0.654))
                .map(|(u, v)| {
                    let (s, c) = (std::f64::consts::TAU * u).sin_cos();
                    let r = 10f64.powf(40.0 * v - 20.0);
                    (r * s, r * c)
                }),
        );
        let (mut worst, mut differing) = (0, 0usize);
        for (y, x) in pairs {
            let (got, want) = (atan2(y, x), y.atan2(x));
            let gap = ulps(got, want);
            assert!(gap <= 2, "atan2({y:e}, {x:e}) = {got:e}, library {want:e}");
            worst = worst.max(gap);
            differing += usize::from(got.to_bits() != want.to_bits());
        }
        assert!(
            worst <= 2 && differing > 0,
            "worst {worst}, differing {differing}"
        );
        for (y, x) in [
            (f64::INFINITY, 1.0),
            (1.0, f64::NEG_INFINITY),
            (f64::NAN, 1.0),
        ] {
            assert_eq!(atan2(y, x).to_bits(), y.atan2(x).to_bits());
        }
    }
}
