//! The independent reference: it shares no code with the crate. Plain Möller–Trumbore over every
//! triangle, closed-form ray casts on the primitives written as intersections of intervals, and
//! the divergence-theorem volume and centroid.

use nalgebra::{Point3, Vector3};

/// A solid in its own frame, as the reference sees it.
#[derive(Debug, Clone)]
pub enum Solid {
    Box {
        half: Vector3<f64>,
    },
    Sphere {
        r: f64,
    },
    /// Axis z, centred.
    Cylinder {
        half_height: f64,
        r: f64,
    },
    /// Axis z, base at -h/2, tip at +h/2.
    Cone {
        h: f64,
        r: f64,
    },
    /// Closed, outward-wound (the reference checks the sign of its volume).
    Mesh {
        vertices: Vec<Point3<f64>>,
        triangles: Vec<[usize; 3]>,
    },
}

/// What a ray from a finger's start does.
#[derive(Debug, Clone, Copy)]
pub enum Outcome {
    /// Starts inside, at least `depth` (along ±direction) from the surface.
    Inside,
    /// Meets the surface first at `t`, with this inward unit normal.
    Hit {
        t: f64,
        inward: Vector3<f64>,
    },
    Miss,
}

const EPS: f64 = 1e-300;

impl Solid {
    /// The ray `o + t d` (`d` unit), `t` in `[0, max]`.
    pub fn cast(&self, o: Point3<f64>, d: Vector3<f64>, max: f64) -> Outcome {
        let (inside, entry) = match self {
            Solid::Box { half } => slab_box(*half, o, d),
            Solid::Sphere { r } => ball(*r, o, d),
            Solid::Cylinder { half_height, r } => cylinder(*half_height, *r, o, d),
            Solid::Cone { h, r } => cone(*h, *r, o, d),
            Solid::Mesh {
                vertices,
                triangles,
            } => return mesh_cast(vertices, triangles, o, d, max),
        };
        if inside {
            return Outcome::Inside;
        }
        match entry {
            Some((t, inward)) if t <= max => Outcome::Hit { t, inward },
            _ => Outcome::Miss,
        }
    }

    /// How far (along the ray's line, either way) the start is from the surface: used to skip
    /// the starts that touch the surface to within rounding.
    pub fn clearance(&self, o: Point3<f64>, d: Vector3<f64>) -> f64 {
        match self {
            Solid::Mesh {
                vertices,
                triangles,
            } => {
                let forward = all_crossings(vertices, triangles, o, d);
                let backward = all_crossings(vertices, triangles, o, -d);
                forward
                    .iter()
                    .chain(backward.iter())
                    .map(|(t, _)| *t)
                    .fold(f64::INFINITY, f64::min)
            }
            _ => {
                let f = self.boundary_distances(o, d);
                let b = self.boundary_distances(o, -d);
                f.min(b)
            }
        }
    }

    fn boundary_distances(&self, o: Point3<f64>, d: Vector3<f64>) -> f64 {
        match self.cast(o, d, f64::INFINITY) {
            Outcome::Hit { t, .. } => t,
            Outcome::Miss => f64::INFINITY,
            Outcome::Inside => {
                // From inside: the exit along d, by casting back from far away.
                let far = o + d * 1e3;
                match self.cast(far, -d, f64::INFINITY) {
                    Outcome::Hit { t, .. } => 1e3 - t,
                    _ => f64::INFINITY,
                }
            }
        }
    }

    /// The centroid (uniform density) in the solid's frame.
    pub fn centroid(&self) -> Point3<f64> {
        match self {
            Solid::Cone { h, .. } => Point3::new(0.0, 0.0, -h / 2.0 + h / 4.0),
            Solid::Mesh {
                vertices,
                triangles,
            } => divergence_volume_centroid(vertices, triangles).1,
            _ => Point3::origin(),
        }
    }
}

/// Interval of `t` where a linear function `p + q t` lies in `[lo, hi]`.
fn linear_interval(p: f64, q: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if q.abs() < EPS {
        return (p >= lo && p <= hi).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (a, b) = ((lo - p) / q, (hi - p) / q);
    Some((a.min(b), a.max(b)))
}

/// The slab method: the entry is the latest of the three slabs' entries.
fn slab_box(
    half: Vector3<f64>,
    o: Point3<f64>,
    d: Vector3<f64>,
) -> (bool, Option<(f64, Vector3<f64>)>) {
    let inside = (0..3).all(|i| o[i].abs() < half[i]);
    let mut enter = f64::NEG_INFINITY;
    let mut leave = f64::INFINITY;
    let mut axis = 0;
    for i in 0..3 {
        let Some((a, b)) = linear_interval(o[i], d[i], -half[i], half[i]) else {
            return (inside, None);
        };
        if a > enter {
            enter = a;
            axis = i;
        }
        leave = leave.min(b);
    }
    if enter > leave || enter < 0.0 {
        return (inside, None);
    }
    let mut inward = Vector3::zeros();
    inward[axis] = d[axis].signum();
    (inside, Some((enter, inward)))
}

fn ball(r: f64, o: Point3<f64>, d: Vector3<f64>) -> (bool, Option<(f64, Vector3<f64>)>) {
    let inside = o.coords.norm() < r;
    // |o + t d|² = r²  →  t² + 2 (o·d) t + |o|² − r² = 0
    let half_b = o.coords.dot(&d);
    let c = o.coords.norm_squared() - r * r;
    let disc = half_b * half_b - c;
    if disc < 0.0 {
        return (inside, None);
    }
    let t = -half_b - disc.sqrt();
    if t < 0.0 {
        return (inside, None);
    }
    let p = o + d * t;
    (inside, Some((t, -p.coords / r)))
}

/// Where `a t² + 2 b t + c ≤ 0` (the quadratic's "inside"), as one interval when `a > 0`.
fn quadratic_le_zero(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    if a.abs() < 1e-300 {
        // Linear: 2 b t + c ≤ 0.
        if b.abs() < 1e-300 {
            return (c <= 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
        }
        let t = -c / (2.0 * b);
        return Some(if b > 0.0 {
            (f64::NEG_INFINITY, t)
        } else {
            (t, f64::INFINITY)
        });
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (t1, t2) = ((-b - s) / a, (-b + s) / a);
    Some((t1.min(t2), t1.max(t2)))
}

/// The intersection of a radial interval (infinite cylinder) and the height slab.
fn cylinder(
    half_height: f64,
    r: f64,
    o: Point3<f64>,
    d: Vector3<f64>,
) -> (bool, Option<(f64, Vector3<f64>)>) {
    let inside = o.x * o.x + o.y * o.y < r * r && o.z.abs() < half_height;
    let a = d.x * d.x + d.y * d.y;
    let b = o.x * d.x + o.y * d.y;
    let c = o.x * o.x + o.y * o.y - r * r;
    let radial = if a < 1e-300 {
        (c <= 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY))
    } else {
        quadratic_le_zero(a, b, c)
    };
    let (Some((r0, r1)), Some((z0, z1))) =
        (radial, linear_interval(o.z, d.z, -half_height, half_height))
    else {
        return (inside, None);
    };
    let enter = r0.max(z0);
    if enter > r1.min(z1) || enter < 0.0 {
        return (inside, None);
    }
    let p = o + d * enter;
    let inward = if r0 >= z0 {
        -Vector3::new(p.x, p.y, 0.0) / r
    } else {
        Vector3::new(0.0, 0.0, -p.z.signum())
    };
    (inside, Some((enter, inward)))
}

/// The nappe solid `ρ ≤ k u`, `0 ≤ u ≤ h`, `u = h/2 − z`, as the intersection of the quadratic's
/// interval and the height slab; the mirror nappe's interval is dropped by the slab.
fn cone(h: f64, r: f64, o: Point3<f64>, d: Vector3<f64>) -> (bool, Option<(f64, Vector3<f64>)>) {
    let k = r / h;
    let u0 = h / 2.0 - o.z;
    let rho0 = (o.x * o.x + o.y * o.y).sqrt();
    let inside = u0 > 0.0 && u0 < h && rho0 < k * u0;
    // ρ² − k² u² ≤ 0 with u = u0 − t d_z.
    let a = d.x * d.x + d.y * d.y - k * k * d.z * d.z;
    let b = o.x * d.x + o.y * d.y + k * k * u0 * d.z;
    let c = o.x * o.x + o.y * o.y - k * k * u0 * u0;
    let Some((u_lo, u_hi)) = linear_interval(u0, -d.z, 0.0, h) else {
        return (inside, None);
    };
    // The double cone's "inside" is one interval (a < 0 means outside the roots: two rays).
    let pieces: Vec<(f64, f64)> = if a > 1e-300 {
        quadratic_le_zero(a, b, c).into_iter().collect()
    } else if a < -1e-300 {
        match quadratic_le_zero(-a, -b, -c) {
            // −q ≤ 0 between the roots means q ≤ 0 outside them.
            Some((t1, t2)) => vec![(f64::NEG_INFINITY, t1), (t2, f64::INFINITY)],
            None => vec![(f64::NEG_INFINITY, f64::INFINITY)],
        }
    } else {
        quadratic_le_zero(0.0, b, c).into_iter().collect()
    };
    let mut best: Option<(f64, bool)> = None;
    for (s0, s1) in pieces {
        let enter = s0.max(u_lo);
        let leave = s1.min(u_hi);
        // The piece on the real nappe has its midpoint at u ≥ 0.
        let mid = if enter.is_finite() && leave.is_finite() {
            (enter + leave) / 2.0
        } else {
            enter
        };
        if enter <= leave && enter >= 0.0 && u0 - mid * d.z >= 0.0 {
            let on_base = u_lo >= s0 && d.z > 0.0;
            if best.is_none_or(|(t, _)| enter < t) {
                best = Some((enter, on_base));
            }
        }
    }
    let Some((t, on_base)) = best else {
        return (inside, None);
    };
    let p = o + d * t;
    let inward = if on_base {
        Vector3::new(0.0, 0.0, 1.0)
    } else {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        -Vector3::new(p.x / rho, p.y / rho, k).normalize()
    };
    (inside, Some((t, inward)))
}

/// Möller–Trumbore: the `t ≥ 0` where the ray crosses a triangle, if it does.
pub fn moller_trumbore(
    o: Point3<f64>,
    d: Vector3<f64>,
    a: Point3<f64>,
    b: Point3<f64>,
    c: Point3<f64>,
) -> Option<f64> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = d.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(&q) * inv;
    (t >= 0.0).then_some(t)
}

/// Every crossing `t ≥ 0` and the crossed triangle's outward unit normal.
fn all_crossings(
    vertices: &[Point3<f64>],
    triangles: &[[usize; 3]],
    o: Point3<f64>,
    d: Vector3<f64>,
) -> Vec<(f64, Vector3<f64>)> {
    let sign = divergence_volume_centroid(vertices, triangles).0.signum();
    triangles
        .iter()
        .filter_map(|t| {
            let (a, b, c) = (vertices[t[0]], vertices[t[1]], vertices[t[2]]);
            moller_trumbore(o, d, a, b, c).map(|s| (s, (b - a).cross(&(c - a)).normalize() * sign))
        })
        .collect()
}

fn mesh_cast(
    vertices: &[Point3<f64>],
    triangles: &[[usize; 3]],
    o: Point3<f64>,
    d: Vector3<f64>,
    max: f64,
) -> Outcome {
    let crossings = all_crossings(vertices, triangles, o, d);
    // Parity: an odd number of crossings to infinity means the start is inside.
    if crossings.len() % 2 == 1 {
        return Outcome::Inside;
    }
    match crossings.iter().min_by(|p, q| p.0.total_cmp(&q.0)) {
        Some(&(t, outward)) if t <= max => Outcome::Hit {
            t,
            inward: -outward,
        },
        _ => Outcome::Miss,
    }
}

/// Divergence theorem: `V = Σ a·(b × c)/6` and `∫x dV = Σ (a·(b × c)/6)(a + b + c)/4`, with the
/// origin as the reference point.
pub fn divergence_volume_centroid(
    vertices: &[Point3<f64>],
    triangles: &[[usize; 3]],
) -> (f64, Point3<f64>) {
    let mut volume = 0.0;
    let mut moment = Vector3::zeros();
    for t in triangles {
        let (a, b, c) = (
            vertices[t[0]].coords,
            vertices[t[1]].coords,
            vertices[t[2]].coords,
        );
        let v = a.dot(&b.cross(&c)) / 6.0;
        volume += v;
        moment += (a + b + c) * (v / 4.0);
    }
    (volume, Point3::from(moment / volume))
}
