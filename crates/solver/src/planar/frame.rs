//! Validation of a candidate and its mapping into the paper's object frame
//! (`docs/theory.md#conventions`).

use super::candidate::Candidate;
use crate::contact::Contact;
use crate::invalid_input::InvalidInput;
use crate::limits::{
    MAX_COORDINATE, MAX_FRICTION, MAX_GRAVITY, MAX_MASS, MAX_NORMAL_COMPONENT, MAX_SAFETY_FACTOR,
    MIN_FRICTION, MIN_WEIGHT,
};
use nalgebra::{SVector, Vector2};

/// Contacts closer than this fraction of their distance to the centre of mass coincide.
const COINCIDENT_FRACTION: f64 = 1e-9;
/// A centre of mass lies behind the surface tangent at a contact when the unit vector from the
/// contact to it has an inward-normal component below minus this (the rounding of a centre of
/// mass on the tangent is not "behind"). Nothing is refused for it: the statics hold for any
/// object, convex or not (`docs/theory.md#a-centre-of-mass-behind-a-tangent`); the robust regions
/// take no cut from such a tangent (`robust/mod.rs` section 3).
pub const BEHIND_TANGENT: f64 = 1e-12;

/// A candidate expressed in the paper's object frame (module docs of [`crate`]).
///
/// Lengths are divided by the contact distance, so `x1 + x2 = 1`; forces computed from it are
/// in units of the weight `m |g|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GraspFrame {
    /// Contact 1 is at `(x1, y)`.
    pub(crate) x1: f64,
    /// Contact 2 is at `(-x2, y)`.
    pub(crate) x2: f64,
    /// Height of the contact line above the centre of mass, `>= 0`.
    pub(crate) y: f64,
    /// `sin φ1`, where the inward normal at contact 1 is `(-sin φ1, -cos φ1)`.
    pub(crate) s1: f64,
    /// `cos φ1`.
    pub(crate) c1: f64,
    /// `sin φ2`, where the inward normal at contact 2 is `(sin φ2, -cos φ2)`.
    pub(crate) s2: f64,
    /// `cos φ2`.
    pub(crate) c2: f64,
    /// Friction coefficient at contact 1 after the safety factor.
    pub(crate) mu1: f64,
    /// Friction coefficient at contact 2 after the safety factor.
    pub(crate) mu2: f64,
    /// The safety factor that divided the friction coefficients.
    pub(crate) friction_safety_factor: f64,
    /// Gravity angle of the current pose, rad in (-π, π].
    pub(crate) current_theta: f64,
    /// `m |g|` with the in-plane part of `g`, N.
    pub(crate) weight: f64,
    /// Distance between the contacts, m.
    pub(crate) contact_distance: f64,
    /// Whether the paper's contact 1 is the candidate's `contact_2`.
    pub(crate) swapped: bool,
    /// Paper x axis in the candidate frame.
    pub(crate) e_x: Vector2<f64>,
    /// Paper y axis in the candidate frame.
    pub(crate) e_y: Vector2<f64>,
}

/// `v` when it is finite.
fn finite(field: &'static str, v: f64) -> Result<f64, InvalidInput> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(InvalidInput::NotFinite { field })
    }
}

/// `v` when it is finite and at most `limit` in magnitude.
fn bounded(
    field: &'static str,
    v: f64,
    limit: f64,
    unit: &'static str,
) -> Result<f64, InvalidInput> {
    finite(field, v)?;
    if v.abs() > limit {
        Err(InvalidInput::OutOfRange {
            field,
            value: v,
            limit,
            unit,
        })
    } else {
        Ok(v)
    }
}

/// `v` when it is finite, positive and at most `limit`. The spatial model checks its input
/// with this and [`vector`] too.
pub(crate) fn positive(
    field: &'static str,
    v: f64,
    limit: f64,
    unit: &'static str,
) -> Result<f64, InvalidInput> {
    bounded(field, v, limit, unit)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(InvalidInput::NotPositive { field, value: v })
    }
}

/// Checks that every component of `v` is finite and within `limit`; the error names the field
/// of the first that is not.
pub(crate) fn vector<const N: usize>(
    fields: [&'static str; N],
    v: &SVector<f64, N>,
    limit: f64,
    unit: &'static str,
) -> Result<(), InvalidInput> {
    for (field, x) in fields.into_iter().zip(v.iter()) {
        bounded(field, *x, limit, unit)?;
    }
    Ok(())
}

/// Vectors whose largest component lies in this range are squared as they are: no square of
/// theirs can underflow or overflow.
pub const SQUARE_SAFE: std::ops::RangeInclusive<f64> = 1e-150..=1e150;

/// `x · 2^k`, exact (in steps, since one power of two covers only `2^-1022 ..= 2^1023`).
pub fn times_pow2(x: f64, mut k: i32) -> f64 {
    let mut out = x;
    while k != 0 {
        let step = k.clamp(-1000, 1000);
        out *= f64::from_bits(((step + 1023) as u64) << 52);
        k -= step;
    }
    out
}

/// `v` times `2^k` and `k`, with `k` chosen so that the largest component lies in
/// [`SQUARE_SAFE`] (`k = 0` when it already does); `None` for the zero vector.
///
/// # Formula
/// With `m = max(|v_x|, |v_y|)` outside the safe range, `k = -floor(log2 m)`, so `m 2^k` is
/// about 1. Multiplying by a power of two is exact, so a vector and any power-of-two multiple of
/// it come out bit for bit the same, and a vector already in range is left as it is (the same
/// arithmetic as squaring it directly): no length the contract admits, from the smallest
/// subnormal up, underflows or overflows when squared.
fn in_square_range(v: &Vector2<f64>) -> Option<(Vector2<f64>, i32)> {
    let m = v.x.abs().max(v.y.abs());
    if m.is_nan() || m == 0.0 {
        return None;
    }
    if SQUARE_SAFE.contains(&m) {
        return Some((*v, 0));
    }
    let k = -(m.log2().floor() as i32);
    Some((v.map(|c| times_pow2(c, k)), k))
}

/// The Euclidean length of `v`, without squaring a component out of range (see
/// [`in_square_range`]).
pub(crate) fn length(v: &Vector2<f64>) -> f64 {
    in_square_range(v).map_or(0.0, |(w, k)| times_pow2(w.norm(), -k))
}

/// The unit vector along `v`, computed scale-free (see [`in_square_range`]); `None` for the zero
/// vector.
pub(crate) fn unit(v: &Vector2<f64>) -> Option<Vector2<f64>> {
    in_square_range(v).map(|(w, _)| w / w.norm())
}

fn unit_in_plane(field: &'static str, v: &Vector2<f64>) -> Result<Vector2<f64>, InvalidInput> {
    unit(v).ok_or(InvalidInput::ZeroInPlane { field })
}

/// What [`validate`] measures on its way and the map into the paper frame needs again, each
/// computed once: the unit normals and gravity, the weight, the contact distance and the unit
/// vector from contact 2 to contact 1.
struct Measured {
    n1: Vector2<f64>,
    n2: Vector2<f64>,
    gravity: Vector2<f64>,
    weight: f64,
    d: f64,
    e_x: Vector2<f64>,
}

impl Measured {
    /// The same measures for a candidate known to be valid, unchecked (the zero vector where
    /// validation would have refused one).
    fn of_valid(c: &Candidate) -> Self {
        let unit_or_zero = |v: &Vector2<f64>| unit(v).unwrap_or_else(Vector2::zeros);
        Self {
            n1: unit_or_zero(&c.normal_1),
            n2: unit_or_zero(&c.normal_2),
            gravity: unit_or_zero(&c.gravity),
            weight: c.mass * length(&c.gravity),
            d: length(&(c.contact_1 - c.contact_2)),
            e_x: unit_or_zero(&(c.contact_1 - c.contact_2)),
        }
    }
}

/// Checks every field of a candidate, naming the first one at fault, and keeps what it measured
/// for the map into the paper frame.
fn validate(c: &Candidate) -> Result<Measured, InvalidInput> {
    vector(
        ["contact_1.x", "contact_1.y"],
        &c.contact_1,
        MAX_COORDINATE,
        " m",
    )?;
    vector(
        ["contact_2.x", "contact_2.y"],
        &c.contact_2,
        MAX_COORDINATE,
        " m",
    )?;
    vector(
        ["normal_1.x", "normal_1.y"],
        &c.normal_1,
        MAX_NORMAL_COMPONENT,
        "",
    )?;
    vector(
        ["normal_2.x", "normal_2.y"],
        &c.normal_2,
        MAX_NORMAL_COMPONENT,
        "",
    )?;
    friction("friction_1", c.friction_1)?;
    friction("friction_2", c.friction_2)?;
    vector(
        ["center_of_mass.x", "center_of_mass.y"],
        &c.center_of_mass,
        MAX_COORDINATE,
        " m",
    )?;
    positive("mass", c.mass, MAX_MASS, " kg")?;
    vector(
        ["gravity.x", "gravity.y"],
        &c.gravity,
        MAX_GRAVITY,
        " m/s^2",
    )?;
    let n1 = unit_in_plane("normal_1", &c.normal_1)?;
    let n2 = unit_in_plane("normal_2", &c.normal_2)?;
    let gravity = unit_in_plane("gravity", &c.gravity)?;
    let weight = c.mass * length(&c.gravity);
    if weight < MIN_WEIGHT {
        return Err(InvalidInput::WeightTooSmall {
            mass: "mass",
            weight,
        });
    }
    let d = length(&(c.contact_1 - c.contact_2));
    let reach =
        length(&(c.contact_1 - c.center_of_mass)).max(length(&(c.contact_2 - c.center_of_mass)));
    if d == 0.0 || d <= COINCIDENT_FRACTION * reach {
        return Err(InvalidInput::CoincidentContacts);
    }
    // From each contact towards the other: one unit vector, negated (`unit(-v)` is `-unit(v)` bit
    // for bit: the scaling by a power of two, the norm and the division all keep the sign apart).
    let to_first = unit(&(c.contact_1 - c.contact_2));
    let to_second = to_first.map(|u| -u);
    for (contact, towards_other, n) in [
        (Contact::First, to_second, n1),
        (Contact::Second, to_first, n2),
    ] {
        // The other contact lies where the inward normal points (the object is between the
        // fingers). The centre of mass may lie anywhere: behind a tangent is ordinary for an
        // object that is not convex, and the statics never needed convexity
        // (`docs/theory.md#a-centre-of-mass-behind-a-tangent`). Unit vectors: the signs do not
        // depend on the lengths' scale.
        if towards_other.is_some_and(|u| n.dot(&u) < 0.0) {
            return Err(InvalidInput::NormalOutward { contact });
        }
    }
    Ok(Measured {
        n1,
        n2,
        gravity,
        weight,
        d,
        e_x: to_first.unwrap_or_else(Vector2::zeros),
    })
}

/// A friction coefficient as the solver takes it (`friction`), the error naming `field` (a
/// pose candidate's `object.friction`, which becomes both `friction_1` and `friction_2`).
pub fn check_friction(field: &'static str, v: f64) -> Result<f64, InvalidInput> {
    friction(field, v)
}

/// A mass (kg) as the solver takes it: finite, positive and at most [`MAX_MASS`], the error
/// naming `field` (a pose candidate's `object.mass`).
pub fn check_mass(field: &'static str, v: f64) -> Result<f64, InvalidInput> {
    positive(field, v, MAX_MASS, " kg")
}

/// A friction coefficient in `[MIN_FRICTION, MAX_FRICTION]` (the spatial model's too).
pub(crate) fn friction(field: &'static str, v: f64) -> Result<f64, InvalidInput> {
    positive(field, v, MAX_FRICTION, "")?;
    if v < MIN_FRICTION {
        Err(InvalidInput::BelowMinimum {
            field,
            value: v,
            minimum: MIN_FRICTION,
        })
    } else {
        Ok(v)
    }
}

impl GraspFrame {
    /// Validates `c` and maps it into the paper frame, dividing friction by `safety`.
    pub fn new(c: &Candidate, safety: f64) -> Result<Self, InvalidInput> {
        if !(1.0..=MAX_SAFETY_FACTOR).contains(&safety) {
            return Err(InvalidInput::SafetyFactor { value: safety });
        }
        let measured = validate(c)?;
        Ok(Self::from_measured(c, &measured, safety))
    }

    /// The map of [`GraspFrame::new`] for a candidate [`validate`] accepts and a safety factor
    /// in `[1, MAX_SAFETY_FACTOR]`, without checking them again (the spatial reduction has checked the 3D input).
    pub(crate) fn from_valid(c: &Candidate, safety: f64) -> Self {
        Self::from_measured(c, &Measured::of_valid(c), safety)
    }

    /// The map itself, from the measures of `c`.
    fn from_measured(c: &Candidate, m: &Measured, safety: f64) -> Self {
        let (mut p1, mut p2, mut n1, mut n2) = (c.contact_1, c.contact_2, m.n1, m.n2);
        let (mut mu1, mut mu2) = (c.friction_1 / safety, c.friction_2 / safety);
        let com = c.center_of_mass;
        // `validate` has checked that the contacts do not coincide, so `d > 0`.
        let d = m.d;
        let mut e_x = m.e_x;
        let mut e_y = Vector2::new(-e_x.y, e_x.x);
        // Height of the contact line above the centre of mass, averaged over both contacts.
        let height = |e_y: &Vector2<f64>, p1: &Vector2<f64>, p2: &Vector2<f64>| {
            0.5 * ((p1 - com).dot(e_y) + (p2 - com).dot(e_y)) / d
        };
        let mut y = height(&e_y, &p1, &p2);
        let swapped = y < 0.0;
        if swapped {
            std::mem::swap(&mut p1, &mut p2);
            std::mem::swap(&mut n1, &mut n2);
            std::mem::swap(&mut mu1, &mut mu2);
            e_x = -e_x;
            e_y = -e_y;
            y = height(&e_y, &p1, &p2);
        }
        let x1 = (p1 - com).dot(&e_x) / d;
        let x2 = -(p2 - com).dot(&e_x) / d;
        // Unit vectors (`Measured`): `validate` has checked that none of the three is zero.
        let to_paper = |u: &Vector2<f64>| Vector2::new(u.dot(&e_x), u.dot(&e_y));
        let n1p = to_paper(&n1);
        let n2p = to_paper(&n2);
        let gp = to_paper(&m.gravity);
        Self {
            x1,
            x2,
            y: y.max(0.0),
            s1: -n1p.x,
            c1: -n1p.y,
            s2: n2p.x,
            c2: -n2p.y,
            mu1,
            mu2,
            friction_safety_factor: safety,
            current_theta: gp.x.atan2(-gp.y),
            weight: m.weight,
            contact_distance: d,
            swapped,
            e_x,
            e_y,
        }
    }

    /// The contact of the candidate's labelling that is the paper's contact `paper_index` (1 or 2).
    pub fn candidate_contact(&self, paper_first: bool) -> Contact {
        match (paper_first, self.swapped) {
            (true, false) | (false, true) => Contact::First,
            _ => Contact::Second,
        }
    }

    /// Gravity direction in the candidate frame for gravity angle `theta`.
    pub fn gravity_direction(&self, theta: f64) -> Vector2<f64> {
        let (s, c) = theta.sin_cos();
        self.gravity_direction_at(s, c)
    }

    /// [`GraspFrame::gravity_direction`] from the angle's sine and cosine.
    pub(crate) fn gravity_direction_at(&self, sin: f64, cos: f64) -> Vector2<f64> {
        self.e_x * sin - self.e_y * cos
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use std::f64::consts::FRAC_PI_3;

    /// Table 1 (a): a circle of radius 10, contacts at ±60° from the top, gravity along -y.
    fn circle_case_a() -> Candidate {
        crate::table_1::table_1('a')
    }

    #[test]
    fn paper_frame_of_table_1_a() {
        let f = GraspFrame::new(&circle_case_a(), 1.0).expect("valid");
        let d = 10.0 * 3f64.sqrt();
        assert!(!f.swapped);
        assert_abs_diff_eq!(f.x1, 5.0 * 3f64.sqrt() / d, epsilon = 1e-15);
        assert_abs_diff_eq!(f.y, 5.0 / d, epsilon = 1e-15);
        assert_abs_diff_eq!(f.s1, FRAC_PI_3.sin(), epsilon = 1e-15);
        assert_abs_diff_eq!(f.c1, FRAC_PI_3.cos(), epsilon = 1e-15);
        assert_abs_diff_eq!(f.s2, FRAC_PI_3.sin(), epsilon = 1e-15);
        assert_abs_diff_eq!(f.c2, FRAC_PI_3.cos(), epsilon = 1e-15);
        assert_eq!(f.current_theta, 0.0);
    }

    /// Lengths and directions without squaring the vector: exact under power-of-two scaling,
    /// and right for the smallest and largest doubles.
    #[test]
    fn lengths_and_units_are_scale_free() {
        let v = Vector2::new(3.0, -4.0);
        assert_eq!(length(&v), 5.0);
        for k in [-1020, -600, 0, 600, 1020] {
            let s = 2f64.powi(k);
            let w = v * s;
            assert_eq!(length(&w), 5.0 * s, "2^{k}");
            assert_eq!(unit(&w), unit(&v), "2^{k}");
            // `validate` takes the way back as the negated unit vector: the same bits.
            assert_eq!(unit(&-w), unit(&w).map(|u| -u), "2^{k}");
        }
        for w in [
            Vector2::new(0.1, 0.7),
            Vector2::new(-1e-310, 3e-305),
            Vector2::new(7e200, -1.0),
        ] {
            assert_eq!(unit(&-w), unit(&w).map(|u| -u), "{w:?}");
        }
        // The smallest subnormals: 3 and -4 of them, exact.
        let tiny = f64::from_bits(1);
        assert_eq!(unit(&(v * tiny)), unit(&v));
        assert_eq!(length(&(v * tiny)), 5.0 * tiny);
        assert_eq!(length(&Vector2::new(f64::MAX, f64::MAX)), f64::INFINITY);
        assert_eq!(unit(&Vector2::zeros()), None);
    }

    #[test]
    fn left_handed_labelling_is_swapped() {
        let mut c = circle_case_a();
        std::mem::swap(&mut c.contact_1, &mut c.contact_2);
        std::mem::swap(&mut c.normal_1, &mut c.normal_2);
        let f = GraspFrame::new(&c, 1.0).expect("valid");
        assert!(f.swapped);
        assert_abs_diff_eq!(f.mu1, 1.0, epsilon = 1e-15);
        assert_abs_diff_eq!(f.mu2, 1.5, epsilon = 1e-15);
        assert!(f.y > 0.0);
    }

    #[test]
    fn validation_names_the_field() {
        let mut c = circle_case_a();
        c.mass = f64::NAN;
        assert_eq!(
            GraspFrame::new(&c, 1.0),
            Err(InvalidInput::NotFinite { field: "mass" })
        );
        let mut c = circle_case_a();
        c.contact_1.x = 1e300;
        assert!(matches!(
            GraspFrame::new(&c, 1.0),
            Err(InvalidInput::OutOfRange {
                field: "contact_1.x",
                ..
            })
        ));
        let mut c = circle_case_a();
        c.normal_2 = -c.normal_2;
        assert_eq!(
            GraspFrame::new(&c, 1.0),
            Err(InvalidInput::NormalOutward {
                contact: Contact::Second
            })
        );
        let mut c = circle_case_a();
        c.contact_2 = c.contact_1;
        assert_eq!(
            GraspFrame::new(&c, 1.0),
            Err(InvalidInput::CoincidentContacts)
        );
        let mut c = circle_case_a();
        c.gravity = Vector2::zeros();
        assert_eq!(
            GraspFrame::new(&c, 1.0),
            Err(InvalidInput::ZeroInPlane { field: "gravity" })
        );
        // Behind both tangents (above the circle's top): answered, not refused.
        let mut c = circle_case_a();
        c.center_of_mass = Vector2::new(0.0, 30.0);
        assert!(GraspFrame::new(&c, 1.0).is_ok());
        assert_eq!(
            GraspFrame::new(&circle_case_a(), 0.5),
            Err(InvalidInput::SafetyFactor { value: 0.5 })
        );
    }
}
