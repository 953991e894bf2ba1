//! Validation of a spatial candidate, the plane Π, the sliced cones (module docs §2), the planar
//! candidate in Π and the way back to 3D (§3, §4).

use super::answer::{self, AxisRelation, CurrentPose, Miss, NoForceClosure, IN_PLANE_TOLERANCE};
use super::candidate;
use crate::limits::{
    MAX_COORDINATE, MAX_FRICTION, MAX_GRAVITY, MAX_MASS, MAX_NORMAL_COMPONENT, MAX_SAFETY_FACTOR,
    MIN_FRICTION, MIN_WEIGHT,
};
use crate::planar::analysis::Analysis;
use crate::planar::frame::GraspFrame;
use crate::planar::frame::{friction, positive, times_pow2, vector};
use crate::{
    planar::{Candidate, ConeMiss, Recommendation},
    Contact, InvalidInput, Settings,
};
use nalgebra::{Vector2, Vector3};

/// Contacts closer than this fraction of their reach from the centre of mass coincide (as in the
/// planar model).
const COINCIDENT_FRACTION: f64 = 1e-9;
/// A normal whose projection into the plane is shorter than this fraction of it has no planar
/// direction.
const PERPENDICULAR_FRACTION: f64 = 1e-12;

/// The friction coefficient of a cone of coefficient `mu` (after the safety factor) sliced by a
/// plane its axis is tilted out of by `β`, given `tan_tilt = tan β = |n · ν| / |n_∥|`; `None`
/// when `β >= ξ` (the slice is at most a ray).
///
/// # Formula
/// `μ' = sqrt((1 + μ²) cos²β − 1) = sqrt((μ − t)(μ + t) / (1 + t²))`, `t = tan β` (module docs §2:
/// `cos ξ' = cos ξ / cos β`). With `t = 0` it returns `mu` exactly.
pub fn sliced_friction(mu: f64, tan_tilt: f64) -> Option<f64> {
    if tan_tilt >= mu {
        return None;
    }
    Some(((mu - tan_tilt) * (mu + tan_tilt) / (1.0 + tan_tilt * tan_tilt)).sqrt())
}

/// Magnitudes whose products of up to four factors neither underflow nor overflow: the squares
/// in a norm, and the norm of a cross product of two differences of points.
const PRODUCT_SAFE: std::ops::RangeInclusive<f64> = 1e-70..=1e70;

/// The power of two `2^k` that brings `m` (> 0, finite) to about 1, as `k`; 0 when `m` already
/// lies in [`PRODUCT_SAFE`], so that the arithmetic there is what it always was.
///
/// # Why
/// Multiplying by a power of two is exact, so a scene and any power-of-two multiple of it come
/// out bit for bit the same (`tests/it/magnitudes.rs`), and no length the contract admits, from the
/// smallest subnormal up, underflows when squared: a contact distance of 1e-82 m squared twice
/// (the norm of Π's cross product) would be 1e-328, below the smallest double.
fn scale_exponent(m: f64) -> i32 {
    if PRODUCT_SAFE.contains(&m) || !m.is_finite() || m == 0.0 {
        0
    } else {
        -(m.log2().floor() as i32)
    }
}

/// `v · 2^k`, component by component, exact.
fn times_pow2_3(v: &Vector3<f64>, k: i32) -> Vector3<f64> {
    if k == 0 {
        *v
    } else {
        v.map(|x| times_pow2(x, k))
    }
}

/// The Euclidean length of `v`, without squaring a component out of range.
pub(super) fn length(v: &Vector3<f64>) -> f64 {
    let k = scale_exponent(v.amax());
    times_pow2(times_pow2_3(v, k).norm(), -k)
}

/// The weight `mass × |gravity|` (N) of a spatial candidate, refused as
/// [`InvalidInput::WeightTooSmall`] naming `mass_field` where the solver refuses it: for a
/// caller whose mass reaches the solver under another name (a pose candidate's `object.mass`).
/// `mass` and `gravity` are taken as checked (finite, within their limits).
pub fn check_weight(
    mass_field: &'static str,
    mass: f64,
    gravity: &Vector3<f64>,
) -> Result<f64, InvalidInput> {
    let weight = mass * length(gravity);
    if weight < MIN_WEIGHT {
        Err(InvalidInput::WeightTooSmall {
            mass: mass_field,
            weight,
        })
    } else {
        Ok(weight)
    }
}

/// The unit vector along `v`, scale-free; the zero vector is refused naming `field`.
fn direction(field: &'static str, v: &Vector3<f64>) -> Result<Vector3<f64>, InvalidInput> {
    let w = times_pow2_3(v, scale_exponent(v.amax()));
    let n = w.norm();
    if n > 0.0 {
        Ok(w * (1.0 / n))
    } else {
        Err(InvalidInput::ZeroVector { field })
    }
}

/// Whether every field is within its limits (NaN and infinities are not): the common case, in
/// one pass; [`validate`] names the field otherwise.
fn within_limits(c: &candidate::Candidate) -> bool {
    let all = |v: &Vector3<f64>, limit: f64| v.iter().all(|x| x.abs() <= limit);
    let positive = |x: f64, limit: f64| x > 0.0 && x <= limit;
    all(&c.contact_1, MAX_COORDINATE)
        && all(&c.contact_2, MAX_COORDINATE)
        && all(&c.center_of_mass, MAX_COORDINATE)
        && all(&c.normal_1, MAX_NORMAL_COMPONENT)
        && all(&c.normal_2, MAX_NORMAL_COMPONENT)
        && all(&c.gravity, MAX_GRAVITY)
        && (MIN_FRICTION..=MAX_FRICTION).contains(&c.friction_1)
        && (MIN_FRICTION..=MAX_FRICTION).contains(&c.friction_2)
        && positive(c.mass, MAX_MASS)
}

/// Checks every field of a spatial candidate, naming the first one at fault, in the planar
/// model's order.
fn validate(c: &candidate::Candidate) -> Result<(), InvalidInput> {
    vector(
        ["contact_1.x", "contact_1.y", "contact_1.z"],
        &c.contact_1,
        MAX_COORDINATE,
        " m",
    )?;
    vector(
        ["contact_2.x", "contact_2.y", "contact_2.z"],
        &c.contact_2,
        MAX_COORDINATE,
        " m",
    )?;
    vector(
        ["normal_1.x", "normal_1.y", "normal_1.z"],
        &c.normal_1,
        MAX_NORMAL_COMPONENT,
        "",
    )?;
    vector(
        ["normal_2.x", "normal_2.y", "normal_2.z"],
        &c.normal_2,
        MAX_NORMAL_COMPONENT,
        "",
    )?;
    // The planar model's domain, for the same reason (see `MIN_FRICTION`).
    friction("friction_1", c.friction_1)?;
    friction("friction_2", c.friction_2)?;
    vector(
        ["center_of_mass.x", "center_of_mass.y", "center_of_mass.z"],
        &c.center_of_mass,
        MAX_COORDINATE,
        " m",
    )?;
    positive("mass", c.mass, MAX_MASS, " kg")?;
    vector(
        ["gravity.x", "gravity.y", "gravity.z"],
        &c.gravity,
        MAX_GRAVITY,
        " m/s^2",
    )?;
    Ok(())
}

/// A validated spatial candidate.
#[derive(Debug, Clone, Copy)]
pub(super) struct Geometry {
    /// Contact points, m (times an exact power of two when the scene is tiny: lengths here are
    /// in a unit of their own, and only their ratios are used).
    pub p: [Vector3<f64>; 2],
    /// Centre of mass, in the unit of `p`.
    pub c: Vector3<f64>,
    /// Normals as given (for exact planar coordinates), times an exact power of two when tiny.
    pub n_raw: [Vector3<f64>; 2],
    /// Unit inward normals.
    pub n: [Vector3<f64>; 2],
    /// Friction coefficients after the safety factor.
    pub mu: [f64; 2],
    /// The safety factor.
    pub safety: f64,
    /// Unit current gravity direction.
    pub g0: Vector3<f64>,
    /// `m |g|`, N.
    pub weight: f64,
    /// Contact distance, in the unit of `p`.
    pub d: f64,
    /// Unit contact axis, contact 2 → contact 1.
    pub a: Vector3<f64>,
    /// Distance of the centre of mass from the axis over the contact distance.
    pub offset: f64,
    /// Largest magnitude among the coordinates and the reach, in the unit of `p`: the scale of
    /// their rounding.
    pub magnitude: f64,
}

impl Geometry {
    /// Validates `c` and divides friction by `safety`.
    pub fn new(c: &candidate::Candidate, safety: f64) -> Result<Self, InvalidInput> {
        if !(1.0..=MAX_SAFETY_FACTOR).contains(&safety) {
            return Err(InvalidInput::SafetyFactor { value: safety });
        }
        if !within_limits(c) {
            validate(c)?;
        }
        let n = [
            direction("normal_1", &c.normal_1)?,
            direction("normal_2", &c.normal_2)?,
        ];
        let g0 = direction("gravity", &c.gravity)?;
        // As in the planar model: below the smallest normal double the weight has lost its
        // precision, and the forces (in units of it) cannot be given in newtons.
        let weight = c.mass * length(&c.gravity);
        if weight < MIN_WEIGHT {
            return Err(InvalidInput::WeightTooSmall {
                mass: "mass",
                weight,
            });
        }
        // Lengths do not change the answer: a scene of tiny coordinates is brought to about 1 by
        // an exact power of two (see `scale_exponent`).
        let k = scale_exponent(
            c.contact_1
                .amax()
                .max(c.contact_2.amax())
                .max(c.center_of_mass.amax()),
        );
        let p = [times_pow2_3(&c.contact_1, k), times_pow2_3(&c.contact_2, k)];
        let com = times_pow2_3(&c.center_of_mass, k);
        let d = (p[0] - p[1]).norm();
        let to_com = [com - p[0], com - p[1]];
        let dist = [to_com[0].norm(), to_com[1].norm()];
        let reach = dist[0].max(dist[1]);
        if d == 0.0 || d <= COINCIDENT_FRACTION * reach {
            return Err(InvalidInput::CoincidentContacts);
        }
        for (i, contact) in [Contact::First, Contact::Second].into_iter().enumerate() {
            let (pi, qi, ni) = (p[i], p[1 - i], n[i]);
            // The other contact lies where the inward normal points. The centre of mass may lie
            // behind the tangent plane (an object that is not convex): the reduction to the
            // plane and its statics never needed convexity (`docs/theory.md`).
            if ni.dot(&(qi - pi)) < 0.0 {
                return Err(InvalidInput::NormalOutward { contact });
            }
            if dist[i] <= COINCIDENT_FRACTION * d {
                return Err(InvalidInput::CenterOfMassAtContact { contact });
            }
        }
        let inv_d = 1.0 / d;
        let a = (p[0] - p[1]) * inv_d;
        // Offset of the centre of mass from the axis, measured from the nearer contact.
        let r = if dist[0] < dist[1] {
            to_com[0]
        } else {
            to_com[1]
        };
        let offset = (r - a * r.dot(&a)).norm() * inv_d;
        let magnitude = [p[0], p[1], com]
            .iter()
            .map(|v| v.amax())
            .fold(reach, f64::max);
        Ok(Self {
            p,
            c: com,
            n_raw: [&c.normal_1, &c.normal_2].map(|n| times_pow2_3(n, scale_exponent(n.amax()))),
            n,
            mu: [c.friction_1 / safety, c.friction_2 / safety],
            safety,
            g0,
            weight,
            d,
            a,
            offset,
            magnitude,
        })
    }

    /// Contacts and centre of mass in the coordinates of `basis`: as given (exact for a grasp in
    /// the x-y plane) when they fit the planar model's limits, else halved until they do.
    ///
    /// # Why halving
    /// A coordinate in Π can exceed the limit by up to √3 while each of the three it comes from
    /// fits. Halving is exact, and the planar model gives a power-of-two multiple of a scene the
    /// same answer bit for bit, so the answer does not depend on which side of the limit a scene
    /// falls (`tests/it/magnitudes.rs`, the spatial scaling property). Re-centring on the centre
    /// of mass instead rounds, and a scene and its double then differed in the last bit.
    pub fn planar_points(&self, basis: &Basis) -> [Vector2<f64>; 3] {
        let mut q = [self.p[0], self.p[1], self.c].map(|q| basis.in_plane(&q));
        // Each coordinate is finite and at most √3 × MAX_COORDINATE: one halving does. The bound
        // only keeps a contract broken elsewhere from looping; the planar model then refuses.
        for _ in 0..4 {
            if q.iter().all(|q| q.amax() <= MAX_COORDINATE) {
                break;
            }
            q = q.map(|q| q * 0.5);
        }
        q
    }

    /// How far out of Π (rad) the current gravity may be and still count as in it:
    /// [`IN_PLANE_TOLERANCE`], plus the uncertainty of Π's normal from
    /// rounding coordinates of this magnitude at the centre of mass's distance from the axis
    /// (`64 ε M / dist`; 1e-9 rad at a millionth of the contact distance).
    pub fn in_plane_tolerance(&self) -> f64 {
        IN_PLANE_TOLERANCE + 64.0 * f64::EPSILON * self.magnitude / (self.offset * self.d)
    }

    /// The angle between the current gravity and the plane of `basis` (rad in `[0, π/2]`) when
    /// it exceeds `tolerance`, else `None`.
    pub fn out_of_plane(&self, basis: &Basis, tolerance: f64) -> Option<f64> {
        // `g0` is a unit vector: its component across the plane is the sine of the angle. Compare
        // sines (`t − t³/6` is sin t to 1e-22 for the small tolerances that occur), and take the
        // angle only when it is reported.
        let across = self.g0.dot(&basis.normal).abs();
        let t = tolerance.min(std::f64::consts::FRAC_PI_2);
        let sin_t = if t < 1e-4 {
            t - t * t * t / 6.0
        } else {
            t.sin()
        };
        (across > sin_t).then(|| across.atan2(basis.in_plane(&self.g0).norm()))
    }
}

/// An orthonormal right-handed basis `(x, y, normal)` of a plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Basis {
    /// `e_x`.
    pub x: Vector3<f64>,
    /// `e_y`.
    pub y: Vector3<f64>,
    /// `ν = e_x × e_y`.
    pub normal: Vector3<f64>,
}

impl Basis {
    /// The plane through both contacts and the centre of mass, oriented as in module docs §3.
    ///
    /// # Formula
    /// With `ν` oriented so that `ν_z >= 0` and `k = 1/(1 + ν_z)`, the rotation taking `+z` to `ν`
    /// (about `z × ν`) takes `+x` to `(1 − k ν_x², −k ν_x ν_y, −ν_x)` and `+y` to
    /// `(−k ν_x ν_y, 1 − k ν_y², −ν_y)`.
    pub fn through_center_of_mass(g: &Geometry) -> Self {
        // Divided, not multiplied by the inverse: a grasp in the x-y plane gets ν = +z exactly.
        let mut nu = (g.p[0] - g.c).cross(&(g.p[1] - g.c)).normalize();
        let flip = nu.z < 0.0 || (nu.z == 0.0 && (nu.y < 0.0 || (nu.y == 0.0 && nu.x < 0.0)));
        if flip {
            nu = -nu;
        }
        let k = 1.0 / (1.0 + nu.z);
        Self {
            x: Vector3::new(1.0 - k * nu.x * nu.x, -k * nu.x * nu.y, -nu.x),
            y: Vector3::new(-k * nu.x * nu.y, 1.0 - k * nu.y * nu.y, -nu.y),
            normal: nu,
        }
    }

    /// Components of `v` along `e_x` and `e_y`.
    pub fn in_plane(&self, v: &Vector3<f64>) -> Vector2<f64> {
        v2(v.dot(&self.x), v.dot(&self.y))
    }

    /// The 3D vector with components `v` along `e_x` and `e_y`.
    pub fn lift(&self, v: &Vector2<f64>) -> Vector3<f64> {
        self.x * v.x + self.y * v.y
    }
}

/// When a normal is tilted beyond its friction angle, the other contact's sliced cone (if any,
/// `sliced > 0`) is checked in the plane too, so that the answer names every contact at fault:
/// it misses when the angle between its normal and the direction to the other contact reaches
/// its half-angle (eq. 3).
fn cones_missing(
    points: &[Vector2<f64>; 3],
    normals: &[Vector2<f64>; 2],
    sliced: &[f64; 2],
) -> Vec<Miss> {
    (0..2)
        .filter(|&i| sliced[i] > 0.0)
        .filter_map(|i| {
            let to_other = points[1 - i] - points[i];
            let u = normals[i];
            let angle = (u.x * to_other.y - u.y * to_other.x)
                .abs()
                .atan2(u.dot(&to_other));
            (angle >= sliced[i].atan()).then(|| {
                Miss::Cone(ConeMiss {
                    contact: [Contact::First, Contact::Second][i],
                    half_angle: sliced[i].atan(),
                    angle_to_other: angle,
                })
            })
        })
        .collect()
}

/// The planar problem in one plane: the planar candidate (unit weight) and what maps its answer
/// back to 3D.
#[derive(Debug, Clone)]
pub(super) struct PlaneSolve<'a> {
    pub basis: Basis,
    pub candidate: Candidate,
    /// Unit projected inward normals `û_i`, 3D.
    pub normals: [Vector3<f64>; 2],
    /// `tan β_i` of the tilts.
    pub tilt_tangent: [f64; 2],
    /// Sliced coefficients `μ'_i`.
    pub sliced: [f64; 2],
    pub geometry: &'a Geometry,
}

impl<'a> PlaneSolve<'a> {
    /// The planar candidate in the plane of `basis` with contacts and centre of mass at `points`
    /// (`[p1, p2, c]` in its coordinates). `Err(Ok(_))` is no force closure (a normal tilted
    /// beyond its friction angle); `Err(Err(_))` is a normal perpendicular to the plane.
    pub fn new(
        g: &'a Geometry,
        basis: &Basis,
        points: [Vector2<f64>; 3],
    ) -> Result<Self, Result<NoForceClosure, InvalidInput>> {
        let mut normals2 = [Vector2::zeros(); 2];
        let mut normals = [Vector3::zeros(); 2];
        let mut tilt_tangent = [0.0; 2];
        let mut sliced = [0.0; 2];
        let mut misses = Vec::new();
        for i in 0..2 {
            let raw = &g.n_raw[i];
            let along = basis.in_plane(raw);
            let across = raw.dot(&basis.normal).abs();
            let in_plane = along.norm();
            // The unit normal's part in the plane, against PERPENDICULAR_FRACTION.
            if in_plane <= PERPENDICULAR_FRACTION * (in_plane + across) {
                return Err(Err(InvalidInput::NormalPerpendicularToGraspPlane {
                    field: ["normal_1", "normal_2"][i],
                }));
            }
            // Keep the raw components when they fit the planar model's limits (exact for a
            // grasp in the x-y plane); only the direction matters.
            normals2[i] = if along.x.abs().max(along.y.abs()) <= MAX_NORMAL_COMPONENT {
                along
            } else {
                along / in_plane
            };
            let inv = 1.0 / in_plane;
            normals[i] = basis.lift(&(along * inv));
            tilt_tangent[i] = across * inv;
            match sliced_friction(g.mu[i], tilt_tangent[i]) {
                Some(mu) => sliced[i] = mu,
                None => misses.push(Miss::Tilted {
                    contact: [Contact::First, Contact::Second][i],
                    tilt: across.atan2(in_plane),
                    half_angle: g.mu[i].atan(),
                }),
            }
        }
        if !misses.is_empty() {
            misses.extend(cones_missing(&points, &normals2, &sliced));
            return Err(Ok(NoForceClosure {
                misses,
                friction_safety_factor: g.safety,
            }));
        }
        let g2 = basis.in_plane(&g.g0);
        let g2_norm = g2.norm();
        let gravity = if g2_norm > 0.0 {
            g2 * (1.0 / g2_norm)
        } else {
            // Gravity is perpendicular to the plane: every direction in it is a quarter turn
            // away, so any will do for the planar tie-break.
            v2(0.0, -1.0)
        };
        Ok(Self {
            basis: *basis,
            candidate: Candidate {
                contact_1: points[0],
                contact_2: points[1],
                normal_1: normals2[0],
                normal_2: normals2[1],
                friction_1: sliced[0],
                friction_2: sliced[1],
                center_of_mass: points[2],
                mass: 1.0,
                gravity,
            },
            normals,
            tilt_tangent,
            sliced,
            geometry: g,
        })
    }

    /// The planar solver's answer in this plane, for unit weight.
    pub fn solve(&self, settings: &Settings) -> Result<PlanarOutcome, InvalidInput> {
        planar_outcome(&self.candidate, settings, self.geometry.safety)
    }

    /// The smallest rotation taking the recommended gravity of `planar` to the current gravity,
    /// as (unit axis, angle in `[0, π]`) in the candidate frame (module docs §4).
    pub fn rotation(&self, planar: &Recommendation) -> (Vector3<f64>, f64) {
        let b = &self.basis;
        let d = planar.gravity_direction;
        let g = b.in_plane(&self.geometry.g0);
        let g_normal = self.geometry.g0.dot(&b.normal);
        // `g_∥ sin ω` and `g_∥ cos ω`: the planar rotation ω turns the unit `u = g / g_∥` (the
        // planar candidate's gravity) into `d`, so `d × u = sin ω` and `d · u = cos ω`.
        let (par_sin, par_cos) = if g.x == 0.0 && g.y == 0.0 {
            (0.0, 0.0)
        } else {
            (d.x * g.y - d.y * g.x, d.dot(&g))
        };
        let cross = Vector3::new(d.y * g_normal, -d.x * g_normal, par_sin);
        let norm = cross.norm();
        let angle = norm.atan2(par_cos);
        let axis = if norm > 0.0 {
            (b.x * cross.x + b.y * cross.y + b.normal * cross.z) / norm
        } else {
            b.normal
        };
        (axis, angle)
    }

    /// The full answer from this plane's planar answer (unit weight).
    pub fn assemble(
        &self,
        mut planar: Recommendation,
        current_pose: CurrentPose,
        axis: AxisRelation,
    ) -> answer::Recommendation {
        let (rotation_axis, rotation_angle) = self.rotation(&planar);
        let w = self.geometry.weight;
        planar.gripping_power *= w;
        planar.internal_force *= w;
        // The pushes along the contact line (which lies in Π) are those of the planar forces.
        planar.finger_force *= w;
        for f in planar.contact_forces.iter_mut() {
            *f *= w;
        }
        for m in planar.local_minima.iter_mut() {
            m.power *= w;
        }
        match current_pose {
            CurrentPose::Held => {
                planar.gripping_power_current *= w;
                planar.internal_force_current *= w;
                planar.finger_force_current *= w;
            }
            CurrentPose::Swings { .. } => {
                planar.gripping_power_current = f64::INFINITY;
                planar.internal_force_current = f64::INFINITY;
                planar.finger_force_current = f64::INFINITY;
            }
        }
        let b = &self.basis;
        let friction_directions = self.normals.map(|u| b.normal.cross(&u));
        let [n1, f1, n2, f2] = planar.contact_forces;
        let force_vectors = [
            self.normals[0] * n1 + friction_directions[0] * f1,
            self.normals[1] * n2 + friction_directions[1] * f2,
        ];
        answer::Recommendation {
            gravity_direction: b.lift(&planar.gravity_direction),
            plane_x: b.x,
            plane_y: b.y,
            plane_normal: b.normal,
            rotation_axis,
            rotation_angle,
            force_vectors,
            normal_directions: self.normals,
            friction_directions,
            sliced_friction: self.sliced,
            tilt_tangent: self.tilt_tangent,
            current_pose,
            axis,
            center_of_mass_offset: self.geometry.offset,
            plane_candidate: Candidate {
                mass: w,
                ..self.candidate
            },
            planar,
        }
    }
}

/// The planar verdict of one plane: the recommendation (unit weight) or the misses, mapped into
/// spatial terms.
type PlanarOutcome = Result<crate::planar::Recommendation, NoForceClosure>;

/// Runs the planar solver on a planar candidate built by the reduction and maps "no force
/// closure" into spatial terms. The 3D input has been validated, so the planar checks are not run
/// again; the friction coefficients are already divided by the safety factor `safety`.
fn planar_outcome(
    candidate: &crate::planar::Candidate,
    settings: &Settings,
    safety: f64,
) -> Result<PlanarOutcome, InvalidInput> {
    let frame = GraspFrame::from_valid(candidate, 1.0);
    Ok(match Analysis::new(&frame, settings.objective) {
        Ok(analysis) => Ok(analysis.recommend(&settings.range)?),
        Err(crate::planar::NoForceClosure { misses, .. }) => Err(NoForceClosure {
            misses: misses.into_iter().map(Miss::Cone).collect(),
            friction_safety_factor: safety,
        }),
    })
}

/// A 2D vector's components, for building planar candidates.
fn v2(x: f64, y: f64) -> Vector2<f64> {
    Vector2::new(x, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A deterministic sequence in [0, 1) for the tests (no rand in the library).
    fn uniform(k: u64) -> f64 {
        let x = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }

    /// §2 checked against membership in the 3D cone: directions in the plane z = 0 inside the
    /// sliced planar cone are exactly those inside the 3D cone around a normal tilted by β.
    #[test]
    fn slice_matches_cone_membership() {
        let mut k = 0;
        for case in 0..200 {
            let mu = 0.05 + 3.0 * uniform(k);
            let xi = mu.atan();
            let beta = (2.0 * uniform(k + 1) - 1.0) * 0.999 * xi;
            k += 2;
            let n = Vector3::new(beta.cos(), 0.0, beta.sin()); // projected normal +x, tilt β
            let mu_s = sliced_friction(mu, beta.tan().abs()).expect("tilt below ξ");
            let xi_s = mu_s.atan();
            assert!(
                (xi_s.cos() - xi.cos() / beta.cos()).abs() < 1e-12,
                "case {case}: cos ξ' = cos ξ / cos β"
            );
            for j in 0..400 {
                let phi = -PI + 2.0 * PI * j as f64 / 400.0;
                let f = Vector3::new(phi.cos(), phi.sin(), 0.0);
                let in_3d = f.dot(&n) - xi.cos();
                let in_2d = xi_s - phi.abs();
                // Away from the boundary the two memberships agree.
                if in_3d.abs() > 1e-9 && in_2d.abs() > 1e-9 {
                    assert_eq!(in_3d > 0.0, in_2d > 0.0, "case {case} phi {phi}");
                }
            }
        }
    }

    #[test]
    fn slice_is_empty_beyond_the_friction_angle_and_exact_in_plane() {
        assert_eq!(sliced_friction(0.5, 0.5), None);
        assert_eq!(sliced_friction(0.5, 0.7), None);
        for mu in [1e-3, 0.3, 1.0, 7.0, 1e3] {
            assert_eq!(sliced_friction(mu, 0.0), Some(mu));
        }
        // μ'² = μ² cos²β − sin²β.
        let (mu, beta) = (0.8f64, 0.3f64);
        let want = (mu * mu * beta.cos().powi(2) - beta.sin().powi(2)).sqrt();
        let got = sliced_friction(mu, beta.tan()).expect("inside");
        assert!((got - want).abs() < 1e-15);
    }

    #[test]
    fn basis_is_orthonormal_right_handed_and_identity_for_z() {
        for k in 0..500u64 {
            let v = Vector3::new(
                2.0 * uniform(3 * k) - 1.0,
                2.0 * uniform(3 * k + 1) - 1.0,
                2.0 * uniform(3 * k + 2) - 1.0,
            );
            let g = Geometry {
                p: [v, Vector3::new(0.3, -0.2, 0.1)],
                c: Vector3::zeros(),
                n_raw: [Vector3::x(); 2],
                n: [Vector3::x(); 2],
                mu: [1.0; 2],
                safety: 1.0,
                g0: -Vector3::z(),
                weight: 1.0,
                d: 1.0,
                a: Vector3::x(),
                offset: 1.0,
                magnitude: 1.0,
            };
            let b = Basis::through_center_of_mass(&g);
            assert!(b.normal.z >= 0.0);
            assert!((b.x.norm() - 1.0).abs() < 1e-14 && (b.y.norm() - 1.0).abs() < 1e-14);
            assert!(b.x.dot(&b.y).abs() < 1e-14);
            assert!((b.x.cross(&b.y) - b.normal).norm() < 1e-14);
            assert!(b.normal.dot(&g.p[0]).abs() < 1e-14 * g.p[0].norm());
        }
        let g = Geometry {
            p: [Vector3::new(1.0, 2.0, 5.0), Vector3::new(-3.0, 1.0, 5.0)],
            c: Vector3::new(0.0, -1.0, 5.0),
            n_raw: [Vector3::x(); 2],
            n: [Vector3::x(); 2],
            mu: [1.0; 2],
            safety: 1.0,
            g0: -Vector3::y(),
            weight: 1.0,
            d: 1.0,
            a: Vector3::x(),
            offset: 1.0,
            magnitude: 1.0,
        };
        let b = Basis::through_center_of_mass(&g);
        assert_eq!(b.x, Vector3::x());
        assert_eq!(b.y, Vector3::y());
        assert_eq!(b.normal, Vector3::z());
    }
}
