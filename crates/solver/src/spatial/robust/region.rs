//! The region of possible centres of mass in 3D: the box cut by the two tangent planes (module
//! docs §3), as the segments that hold its edges, its points on the contact axis, and the least
//! elevation of its points seen from a contact (module docs §6).

use crate::{Contact, BEHIND_TANGENT};
use nalgebra::Vector3;
use std::fmt;

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

/// Lengths closer than this fraction of the scene's size are equal.
const SAME: f64 = 1e-12;

/// A plane `n · x = offset`.
#[derive(Debug, Clone, Copy)]
struct Plane {
    n: Vector3<f64>,
    offset: f64,
}

/// The box `center ± half` cut by the half-spaces `n_i · x >= offset_i`.
#[derive(Debug, Clone)]
pub(super) struct Region {
    center: Vector3<f64>,
    half: Vector3<f64>,
    cuts: Vec<(Contact, Plane)>,
    /// A length below which two points coincide, m.
    eps: f64,
    /// Segments that contain every edge of the region (some may be single points).
    pub segments: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// The region's vertices.
    pub vertices: Vec<RegionPoint>,
}

impl Region {
    /// The box around `center` with half-widths `half`, cut by the tangent plane at each contact
    /// `(contact, point, unit inward normal)` where the box reaches past it. The bound gives way
    /// to keep `center` inside, as the planar region's does; a tangent `center` lies behind
    /// ([`BEHIND_TANGENT`]: the object is not convex there) cuts nothing (module docs §3).
    pub fn new(
        center: Vector3<f64>,
        half: Vector3<f64>,
        tangents: [(Contact, Vector3<f64>, Vector3<f64>); 2],
        scale: f64,
    ) -> Self {
        let eps = SAME * (scale + center.amax() + half.amax());
        let mut region = Self {
            center,
            half,
            cuts: Vec::with_capacity(2),
            eps,
            segments: Vec::new(),
            vertices: Vec::new(),
        };
        for (contact, p, n) in tangents {
            if n.dot(&(center - p)) < -BEHIND_TANGENT * (center - p).norm() {
                continue;
            }
            let offset = n.dot(&p) + n.dot(&(center - p)).min(0.0);
            let plane = Plane { n, offset };
            if region.corners().iter().any(|c| n.dot(c) < offset) {
                region.cuts.push((contact, plane));
            }
        }
        region.build();
        region
    }

    /// The box's corners (repeated where a half-width is zero).
    fn corners(&self) -> [Vector3<f64>; 8] {
        std::array::from_fn(|k| {
            let s = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
            self.center + Vector3::new(s(1) * self.half.x, s(2) * self.half.y, s(4) * self.half.z)
        })
    }

    /// The planes that bound the region: each face of the box (one plane for a zero width), and
    /// the cutting planes.
    fn planes(&self) -> Vec<Plane> {
        let mut out = Vec::with_capacity(8);
        for j in 0..3 {
            let n = Vector3::ith(j, 1.0);
            out.push(Plane {
                n,
                offset: self.center[j] - self.half[j],
            });
            if self.half[j] > 0.0 {
                out.push(Plane {
                    n,
                    offset: self.center[j] + self.half[j],
                });
            }
        }
        out.extend(self.cuts.iter().map(|(_, p)| *p));
        out
    }

    /// The part `[τ0, τ1]` of the line `o + τ dir` (τ in `[from, ∞)`) inside the region, if any.
    pub fn clip(&self, o: &Vector3<f64>, dir: &Vector3<f64>, from: f64) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (from, f64::INFINITY);
        let mut keep = |a: f64, b: f64, rate: f64, at: f64| {
            // a <= at + τ rate <= b.
            if rate.abs() <= f64::MIN_POSITIVE {
                return at >= a - self.eps && at <= b + self.eps;
            }
            let (x, y) = ((a - self.eps - at) / rate, (b + self.eps - at) / rate);
            lo = lo.max(x.min(y));
            hi = hi.min(x.max(y));
            true
        };
        for j in 0..3 {
            let (a, b) = (self.center[j] - self.half[j], self.center[j] + self.half[j]);
            if !keep(a, b, dir[j], o[j]) {
                return None;
            }
        }
        for (_, p) in &self.cuts {
            if !keep(p.offset, f64::INFINITY, p.n.dot(dir), p.n.dot(o)) {
                return None;
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Every segment where two bounding planes meet inside the region: the region's edges lie in
    /// these (a polytope's edge lies where two of its facets meet).
    fn build(&mut self) {
        let planes = self.planes();
        for (i, p) in planes.iter().enumerate() {
            for q in &planes[i + 1..] {
                let dir = p.n.cross(&q.n);
                let len2 = dir.norm_squared();
                if len2 <= 1e-24 {
                    continue;
                }
                // The point of both planes in span(n_p, n_q).
                let pq = p.n.dot(&q.n);
                let o = (p.n * (p.offset * q.n.norm_squared() - q.offset * pq)
                    + q.n * (q.offset * p.n.norm_squared() - p.offset * pq))
                    / len2;
                if let Some((t0, t1)) = self.clip(&o, &dir, f64::NEG_INFINITY) {
                    self.push_segment(o + dir * t0, o + dir * t1);
                }
            }
        }
        if self.segments.is_empty() {
            self.segments.push((self.center, self.center));
        }
        let mut vertices: Vec<Vector3<f64>> = Vec::with_capacity(16);
        for &(a, b) in &self.segments {
            for x in [a, b] {
                if vertices.iter().all(|v| (v - x).norm() > self.eps) {
                    vertices.push(x);
                }
            }
        }
        self.vertices = vertices.into_iter().map(|x| self.classify(x)).collect();
    }

    fn push_segment(&mut self, a: Vector3<f64>, b: Vector3<f64>) {
        let same = |x: &Vector3<f64>, y: &Vector3<f64>| (x - y).norm() <= self.eps;
        let known = self
            .segments
            .iter()
            .any(|(p, q)| (same(p, &a) && same(q, &b)) || (same(p, &b) && same(q, &a)));
        if !known {
            self.segments.push((a, b));
        }
    }

    /// A vertex named: a corner of the box, or where a tangent plane cuts it.
    fn classify(&self, x: Vector3<f64>) -> RegionPoint {
        let off = x - self.center;
        let corner = (0..3).all(|j| (off[j].abs() - self.half[j]).abs() <= self.eps);
        let sign = |j: usize| -> i8 {
            if self.half[j] == 0.0 {
                0
            } else if off[j] < 0.0 {
                -1
            } else {
                1
            }
        };
        let kind = if corner {
            RegionPointKind::Corner {
                x: sign(0),
                y: sign(1),
                z: sign(2),
            }
        } else {
            let on = self
                .cuts
                .iter()
                .find(|(_, p)| (p.n.dot(&x) - p.offset).abs() <= self.eps * p.n.norm())
                .map(|(c, _)| *c);
            match on {
                Some(contact) => RegionPointKind::Cut { contact },
                None => RegionPointKind::Edge,
            }
        };
        RegionPoint { position: x, kind }
    }

    /// The least elevation `asin(û · dir)` over the region of the unit direction `û` from `apex`
    /// to a point of it, and the point (module docs §6). `dir` is a unit vector.
    ///
    /// # Formula
    /// If the ray from `apex` along `−dir` meets the region, `−π/2`. Otherwise the least lies at a
    /// vertex or on an edge: seen from `apex`, an edge sweeps a great-circle arc `û(φ) = cos φ ê0 +
    /// sin φ ê1`, `φ ∈ [0, φ1]`, on which `û · dir = A cos φ + B sin φ` has its least value
    /// `−hypot(A, B)` at `φ = atan2(B, A) + π` when that lies inside the arc.
    pub fn least_elevation(&self, apex: &Vector3<f64>, dir: &Vector3<f64>) -> (f64, RegionPoint) {
        if let Some((t0, _)) = self.clip(apex, &-dir, 0.0) {
            return (-std::f64::consts::FRAC_PI_2, self.on_edge(apex - dir * t0));
        }
        let elevation = |x: &Vector3<f64>| {
            let u = x - apex;
            (u.dot(dir) / u.norm()).clamp(-1.0, 1.0).asin()
        };
        let mut best = (f64::INFINITY, self.vertices[0]);
        for v in &self.vertices {
            let e = elevation(&v.position);
            if e < best.0 {
                best = (e, *v);
            }
        }
        for &(p0, p1) in &self.segments {
            let (u0, u1) = (p0 - apex, p1 - apex);
            let (n0, n1) = (u0.norm(), u1.norm());
            if n0 <= self.eps || n1 <= self.eps {
                continue;
            }
            let e0 = u0 / n0;
            let w = u1 / n1 - e0 * e0.dot(&(u1 / n1));
            if w.norm() <= 1e-12 {
                continue;
            }
            let e1 = w.normalize();
            let phi1 = u1.dot(&e1).atan2(u1.dot(&e0));
            let (a, b) = (e0.dot(dir), e1.dot(dir));
            let phi = (b.atan2(a) + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
            if phi > 0.0 && phi < phi1 {
                // The point of the edge seen along û(φ), in the plane coordinates (ê0, ê1).
                let (dx, dy) = (u1.dot(&e0) - n0, u1.dot(&e1));
                let (s, c) = phi.sin_cos();
                let t = (n0 * s / (dy * c - dx * s)).clamp(0.0, 1.0);
                let x = p0 + (p1 - p0) * t;
                let e = elevation(&x);
                if e < best.0 {
                    best = (e, self.on_edge(x));
                }
            }
        }
        best
    }

    /// A point of the region that is not a vertex.
    fn on_edge(&self, x: Vector3<f64>) -> RegionPoint {
        match self
            .vertices
            .iter()
            .find(|v| (v.position - x).norm() <= self.eps)
        {
            Some(v) => *v,
            None => RegionPoint {
                position: x,
                kind: RegionPointKind::Edge,
            },
        }
    }
}
