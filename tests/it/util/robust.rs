//! The reference's view of an uncertain object: the region of possible centres of
//! mass, sampled densely, and the worst case over it and over the mass interval, each object
//! evaluated with [`Reference`]. Shares no code with `crates/solver/src/planar/robust/mod.rs`: the region is cut
//! here by intersecting lines directly (not by polygon clipping), and nothing assumes that the
//! worst case lies at a vertex; the vertices are simply among the points sampled.

use super::{RefObjective, RefPoint, RefRange, Reference};
use grasp_orient::solver::planar::Candidate;
use nalgebra::{Matrix2, Vector2};
use rand::Rng;
use std::f64::consts::TAU;

fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Points of the region of possible centres of mass: the box around `c.center_of_mass` with
/// half-widths `half`, less what lies behind either surface tangent.
pub struct RefRegion {
    /// Box corners inside the object, points where a box edge meets a tangent line, and the
    /// tangents' meeting point if it lies in the box.
    pub extreme: Vec<Vector2<f64>>,
    /// A lattice of `(n + 1)²` points over the box (fewer along an axis of zero width), those
    /// inside the object.
    pub grid: Vec<Vector2<f64>>,
    /// Points every `spacing` along the region's boundary: the box edges inside the object and
    /// the tangent lines inside the box.
    pub boundary: Vec<Vector2<f64>>,
}

/// Whether `q` lies on the inner side of both surface tangents, to rounding.
pub fn inside_object(c: &Candidate, q: Vector2<f64>) -> bool {
    [(c.contact_1, c.normal_1), (c.contact_2, c.normal_2)]
        .iter()
        .all(|(p, n)| n.normalize().dot(&(q - p)) >= -1e-12 * (q.norm() + p.norm()))
}

fn inside_box(center: Vector2<f64>, half: Vector2<f64>, q: Vector2<f64>) -> bool {
    let d = q - center;
    let slack = 1e-12 * (half.x.max(half.y) + center.norm());
    d.x.abs() <= half.x + slack && d.y.abs() <= half.y + slack
}

type Tangent = (Vector2<f64>, Vector2<f64>);

impl RefRegion {
    pub fn new(c: &Candidate, half: Vector2<f64>, n: usize, spacing: f64) -> Self {
        let o = c.center_of_mass;
        let corners = [
            o + Vector2::new(-half.x, -half.y),
            o + Vector2::new(half.x, -half.y),
            o + Vector2::new(half.x, half.y),
            o + Vector2::new(-half.x, half.y),
        ];
        let tangents = [
            (c.contact_1, c.normal_1.normalize()),
            (c.contact_2, c.normal_2.normalize()),
        ];
        let mut extreme: Vec<Vector2<f64>> = corners
            .iter()
            .copied()
            .filter(|&q| inside_object(c, q))
            .collect();
        let mut boundary = Vec::new();
        for k in 0..4 {
            box_edge(
                c,
                (corners[k], corners[(k + 1) % 4]),
                &tangents,
                spacing,
                &mut extreme,
                &mut boundary,
            );
        }
        for i in 0..2 {
            tangent_line(
                o,
                half,
                tangents[i],
                tangents[1 - i],
                spacing,
                &mut boundary,
            );
        }
        // The tangents' meeting point.
        let (t1, t2) = (tangents[0], tangents[1]);
        let m = Matrix2::new(t1.1.x, t1.1.y, t2.1.x, t2.1.y);
        if let Some(inv) = m.try_inverse() {
            let q = inv * Vector2::new(t1.1.dot(&t1.0), t2.1.dot(&t2.0));
            if inside_box(o, half, q) {
                extreme.push(q);
            }
        }
        Self {
            extreme,
            grid: lattice(c, half, n),
            boundary,
        }
    }

    /// Whether `q` belongs to the region (to rounding).
    pub fn contains(c: &Candidate, half: Vector2<f64>, q: Vector2<f64>) -> bool {
        inside_object(c, q) && inside_box(c.center_of_mass, half, q)
    }
}

/// One edge `(a, b)` of the box: where the tangents cut it (into `extreme`, if the cut point is
/// inside the object) and the part of it inside the object, every `spacing` (into `boundary`).
fn box_edge(
    c: &Candidate,
    (a, b): (Vector2<f64>, Vector2<f64>),
    tangents: &[Tangent; 2],
    spacing: f64,
    extreme: &mut Vec<Vector2<f64>>,
    boundary: &mut Vec<Vector2<f64>>,
) {
    // The part of this edge inside the object: [s_lo, s_hi] of a + s (b - a).
    let (mut s_lo, mut s_hi) = (0.0f64, 1.0f64);
    for &(p, nrm) in tangents {
        let (da, db) = (nrm.dot(&(a - p)), nrm.dot(&(b - p)));
        if da != db {
            let s = da / (da - db);
            if (0.0..=1.0).contains(&s) {
                let q = a + (b - a) * s;
                if inside_object(c, q) {
                    extreme.push(q);
                }
            }
            if da < db {
                s_lo = s_lo.max(s);
            } else {
                s_hi = s_hi.min(s);
            }
        } else if da < 0.0 {
            s_hi = -1.0;
        }
    }
    let len = (b - a).norm();
    if s_hi > s_lo && len > 0.0 {
        let steps = ((s_hi - s_lo) * len / spacing).ceil().max(1.0) as usize;
        for i in 0..=steps {
            boundary.push(a + (b - a) * (s_lo + (s_hi - s_lo) * i as f64 / steps as f64));
        }
    }
}

/// The tangent line `(p, n)` where it bounds the region (inside the box, on the inner side of
/// the other tangent), every `spacing`, into `boundary`.
fn tangent_line(
    o: Vector2<f64>,
    half: Vector2<f64>,
    (p, nrm): Tangent,
    (p2, n2): Tangent,
    spacing: f64,
    boundary: &mut Vec<Vector2<f64>>,
) {
    let dir = Vector2::new(-nrm.y, nrm.x);
    let reach = (p - o).norm() + half.norm();
    let steps = ((2.0 * reach / spacing).ceil() as usize).min(200_000);
    for k in 0..=steps {
        let q = p + dir * (-reach + 2.0 * reach * k as f64 / steps.max(1) as f64);
        if inside_box(o, half, q) && n2.dot(&(q - p2)) >= 0.0 {
            boundary.push(q);
        }
    }
}

/// `(n + 1)²` points over the box (one along an axis of zero width), those inside the object.
fn lattice(c: &Candidate, half: Vector2<f64>, n: usize) -> Vec<Vector2<f64>> {
    let steps = |w: f64| if w > 0.0 { n } else { 0 };
    let (nx, ny) = (steps(half.x), steps(half.y));
    let at = |i: usize, n: usize| {
        if n == 0 {
            0.0
        } else {
            2.0 * i as f64 / n as f64 - 1.0
        }
    };
    let mut grid = Vec::with_capacity((nx + 1) * (ny + 1));
    for i in 0..=nx {
        for j in 0..=ny {
            let q = c.center_of_mass + Vector2::new(at(i, nx) * half.x, at(j, ny) * half.y);
            if inside_object(c, q) {
                grid.push(q);
            }
        }
    }
    grid
}

/// Points of the region within `offset` of the contact line, on both sides of it: the part of
/// the line inside the box and both tangent half-planes, sampled at `n + 1` points and moved off
/// the line both ways (those that stay in the region).
pub fn near_contact_line(
    c: &Candidate,
    half: Vector2<f64>,
    n: usize,
    offset: f64,
) -> Vec<Vector2<f64>> {
    let (p2, along) = (c.contact_2, c.contact_1 - c.contact_2);
    let o = c.center_of_mass;
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    // Box slabs: |p2 + t along - o| <= half, per axis.
    for k in 0..2 {
        let (a, lo, hi) = (along[k], o[k] - half[k] - p2[k], o[k] + half[k] - p2[k]);
        if a == 0.0 {
            if lo > 0.0 || hi < 0.0 {
                t1 = f64::NEG_INFINITY;
            }
        } else {
            let (u, v) = (lo / a, hi / a);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
    }
    // Tangent half-planes: n · (p2 + t along - p) >= 0.
    for (p, nrm) in [(c.contact_1, c.normal_1), (c.contact_2, c.normal_2)] {
        let (a, b) = (nrm.dot(&along), nrm.dot(&(p2 - p)));
        if a > 0.0 {
            t0 = t0.max(-b / a);
        } else if a < 0.0 {
            t1 = t1.min(-b / a);
        } else if b < 0.0 {
            t1 = f64::NEG_INFINITY;
        }
    }
    let mut out = Vec::new();
    let side = Vector2::new(-along.y, along.x).normalize() * offset;
    // Where the segment between two extreme points on opposite sides crosses the line (a region
    // of zero width has no other points near it), moved along that segment both ways.
    let extreme = RefRegion::new(c, half, 1, f64::INFINITY).extreme;
    for a in &extreme {
        for b in &extreme {
            let (sa, sb) = (side_of_contact_line(c, *a), side_of_contact_line(c, *b));
            if sa > 0.0 && sb < 0.0 {
                let (da, db) = (cross(along, a - p2), cross(along, b - p2));
                let q = a + (b - a) * (da / (da - db));
                let u = (b - a).normalize() * offset;
                out.extend([q + u, q - u]);
            }
        }
    }
    if t0 <= t1 {
        for i in 0..=n {
            let q = p2 + along * (t0 + (t1 - t0) * i as f64 / n as f64);
            for r in [q + side, q - side] {
                if RefRegion::contains(c, half, r) {
                    out.push(r);
                }
            }
        }
    }
    out
}

/// One object of the uncertainty set, with its reference.
pub struct RefObject {
    pub center_of_mass: Vector2<f64>,
    pub reference: Reference,
}

impl RefObject {
    pub fn new(
        c: &Candidate,
        center_of_mass: Vector2<f64>,
        mass: f64,
        safety: f64,
        objective: RefObjective,
    ) -> Self {
        let object = Candidate {
            center_of_mass,
            mass,
            ..*c
        };
        Self {
            center_of_mass,
            reference: Reference::new(&object, safety, objective),
        }
    }
}

/// The push of each finger along the line between the contacts, into the object, from the
/// reference's forces `(N1, F1, N2, F2)` (friction along the inward normal turned +90°).
pub fn finger_pushes(c: &Candidate, point: &RefPoint) -> [f64; 2] {
    let turn = |v: Vector2<f64>| Vector2::new(-v.y, v.x);
    let (n1, n2) = (c.normal_1.normalize(), c.normal_2.normalize());
    let f1 = n1 * point.forces[0] + turn(n1) * point.forces[1];
    let f2 = n2 * point.forces[2] + turn(n2) * point.forces[3];
    let u = (c.contact_2 - c.contact_1).normalize();
    [f1.dot(&u), f2.dot(&-u)]
}

/// The worst case over `objects` at rotation `omega`: `(power, internal force, finger force)`,
/// each the largest over the objects, and the index of the object of largest power.
pub fn worst_at(c: &Candidate, objects: &[RefObject], omega: f64) -> (f64, f64, f64, usize) {
    let mut out = (f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, 0);
    for (i, o) in objects.iter().enumerate() {
        let p = o
            .reference
            .at(omega)
            .expect("force closure holds at every pose");
        if p.power > out.0 {
            out.0 = p.power;
            out.3 = i;
        }
        out.1 = out.1.max(p.internal_force);
        let [a1, a2] = finger_pushes(c, &p);
        out.2 = out.2.max(a1.max(a2));
    }
    out
}

/// The worst power and its slope at `omega` (the slope of the object on top).
fn worst_with_slope(objects: &[RefObject], omega: f64) -> (f64, f64) {
    let mut best = (f64::NEG_INFINITY, 0.0);
    for o in objects {
        let (p, s) = o
            .reference
            .at_with_slope(omega)
            .expect("force closure holds at every pose");
        if p.power > best.0 {
            best = (p.power, s);
        }
    }
    best
}

/// The least worst case over the rotations `[start, start + len]`: a scan of `samples + 1`
/// points with the worst power and its slope, every sign change of the slope from - to +
/// bisected to rounding (a "V" where two objects' curves cross is found so too). Between two
/// samples a dip could still hide without a sign change; where the slopes at the ends allow one
/// below the best so far (`h/2 · max(|s_a|, |s_b|) > min(p_a, p_b) - best`), the interval is
/// scanned again 16 times finer, three levels deep. Returns the best `(rotation, power)` and
/// how far below it a dip could still reach by that estimate (the slopes at the samples stand
/// for the slope between them).
pub fn minimise_worst(
    objects: &[RefObject],
    start: f64,
    len: f64,
    samples: usize,
) -> ((f64, f64), f64) {
    let mut best = (start, f64::INFINITY);
    let unseen = scan_worst(objects, start, start + len, samples, 3, &mut best);
    (best, unseen)
}

fn scan_worst(
    objects: &[RefObject],
    a: f64,
    b: f64,
    n: usize,
    depth: u32,
    best: &mut (f64, f64),
) -> f64 {
    let grid: Vec<(f64, f64, f64)> = (0..=n)
        .map(|k| {
            let w = a + (b - a) * k as f64 / n as f64;
            let (p, s) = worst_with_slope(objects, w);
            (w, p, s)
        })
        .collect();
    for &(w, p, _) in &grid {
        if p < best.1 {
            *best = (w, p);
        }
    }
    for pair in grid.windows(2) {
        let ((mut lo, _, sa), (mut hi, _, sb)) = (pair[0], pair[1]);
        if sa < 0.0 && sb >= 0.0 {
            for _ in 0..100 {
                let m = 0.5 * (lo + hi);
                if m <= lo || m >= hi {
                    break;
                }
                if worst_with_slope(objects, m).1 < 0.0 {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            for w in [lo, hi] {
                let p = worst_with_slope(objects, w).0;
                if p < best.1 {
                    *best = (w, p);
                }
            }
        }
    }
    let h = (b - a) / n as f64;
    let mut unseen = 0.0f64;
    for pair in grid.windows(2) {
        let ((wa, pa, sa), (wb, pb, sb)) = (pair[0], pair[1]);
        let dip = 0.5 * h * sa.abs().max(sb.abs()) - (pa.min(pb) - best.1);
        if dip > 0.0 && !(sa < 0.0 && sb >= 0.0) {
            unseen = unseen.max(if depth > 0 {
                scan_worst(objects, wa, wb, 16, depth - 1, best)
            } else {
                dip
            });
        }
    }
    unseen
}

/// Whether rotation `omega` lies in the arc `(start, len)`, to `slack` rad.
pub fn in_arc(arc: (f64, f64), omega: f64, slack: f64) -> bool {
    let into = (omega - arc.0).rem_euclid(TAU);
    into <= arc.1 + slack || into >= TAU - slack
}

/// The arc of every object's allowed rotations (`Reference::arc`).
pub fn arcs(objects: &[RefObject], range: RefRange, gravity: Vector2<f64>) -> Vec<(f64, f64)> {
    objects
        .iter()
        .map(|o| o.reference.arc(range, gravity))
        .collect()
}

/// Random tolerances for a grasp: half-widths up to 40 % of the contact distance (zero along
/// an axis one time in five), mass tolerance up to 90 % of the mass (zero one time in four);
/// never all zero.
pub fn random_tolerances(rng: &mut impl Rng, c: &Candidate) -> (Vector2<f64>, f64) {
    let d = (c.contact_1 - c.contact_2).norm();
    loop {
        let mut width = || {
            if rng.gen_bool(0.2) {
                0.0
            } else {
                rng.gen_range(0.0..0.4) * d
            }
        };
        let half = Vector2::new(width(), width());
        let mass = if rng.gen_bool(0.25) {
            0.0
        } else {
            rng.gen_range(0.0..0.9) * c.mass
        };
        if half.x > 0.0 || half.y > 0.0 || mass > 0.0 {
            return (half, mass);
        }
    }
}

/// Which side of the contact line `q` lies on (sign of the cross product), 0 on it.
pub fn side_of_contact_line(c: &Candidate, q: Vector2<f64>) -> f64 {
    let v = cross(c.contact_1 - c.contact_2, q - c.contact_2);
    if v.abs() <= 1e-12 * (c.contact_1 - c.contact_2).norm() * (q - c.contact_2).norm() {
        0.0
    } else {
        v.signum()
    }
}

/// `x` rotated by a quarter turn `k` times (exact for the coordinates).
pub fn quarter_turns(v: Vector2<f64>, k: u8) -> Vector2<f64> {
    match k % 4 {
        0 => v,
        1 => Vector2::new(-v.y, v.x),
        2 => Vector2::new(-v.x, -v.y),
        _ => Vector2::new(v.y, -v.x),
    }
}
