//! One object in closed form after its swing, and the worst object of the region at one tilt of
//! the contact axis: a certified maximum over the region's edges (module docs §2–§4).
//!
//! Units: lengths over the contact distance, forces over the weight at the largest mass.

use super::super::on_axis::AxisContact;
use nalgebra::{Vector2, Vector3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Stop refining when no piece of an edge can exceed the best value found by more than this,
/// relative to it, plus [`CERTIFY_ABS`] (module docs §4).
pub(super) const CERTIFY: f64 = 1e-12;
/// The absolute part of the certification tolerance, units of the weight (module docs,
/// *Tolerances*): what a worst squeeze near zero is certified to. A hundredth of the exchange
/// method's absolute tolerance, so that the certification never decides when the exchange stops.
pub(super) const CERTIFY_ABS: f64 = 1e-12;
/// Most pieces split in one maximisation; past it the bound actually reached is reported (module
/// docs, *Iteration bounds*). The most of one whole answer over the 100,000 candidates of
/// `benches/tail.rs` is far below it.
pub(super) const MAX_SPLITS: usize = 5_000;
/// An edge whose line passes this close to the axis (in contact distances) passes through it.
const THROUGH_AXIS: f64 = 1e-12;

/// What is maximised over the region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Quantity {
    /// The 2-norm of the contact forces.
    Norm2,
    /// The least squeeze, `max(0, …)`.
    Squeeze,
}

/// The grasp seen from the contact axis.
#[derive(Debug, Clone, Copy)]
pub(super) struct AxisView {
    /// Contact 2, m.
    pub p2: Vector3<f64>,
    /// Unit axis, contact 2 → contact 1.
    pub a: Vector3<f64>,
    /// Unit `b1 ⟂ a`.
    pub b1: Vector3<f64>,
    /// Unit `b2 = a × b1`.
    pub b2: Vector3<f64>,
    /// Contact distance, m.
    pub d: f64,
    /// The cones as seen from the axis (`share` unused).
    pub contacts: [AxisContact; 2],
    /// The unit inward normals' parts across the axis in `(b1, b2)`, length `sin δ_i`.
    pub across: [Vector2<f64>; 2],
}

/// A point in axis coordinates: `ξ` along the axis from contact 2, `c⊥` across it (`(b1, b2)`),
/// both over the contact distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct AxisPoint {
    pub xi: f64,
    pub across: Vector2<f64>,
}

/// `sin θ`, `cos θ` of the tilt of the axis (`cos θ >= 0`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Tilt {
    pub s: f64,
    pub k: f64,
}

impl Tilt {
    pub fn new(theta: f64) -> Self {
        let (s, k) = theta.sin_cos();
        Self { s, k: k.max(0.0) }
    }
}

/// One object's forces at one tilt (module docs §2): the squeeze and the 2-norm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Held {
    pub squeeze: f64,
    pub norm2: f64,
}

impl Held {
    pub fn get(&self, q: Quantity) -> f64 {
        match q {
            Quantity::Norm2 => self.norm2,
            Quantity::Squeeze => self.squeeze,
        }
    }
}

impl AxisView {
    /// The axis coordinates of a point, m → contact distances.
    pub fn coordinates(&self, c: &Vector3<f64>) -> AxisPoint {
        let r = (c - self.p2) / self.d;
        AxisPoint {
            xi: r.dot(&self.a),
            across: Vector2::new(r.dot(&self.b1), r.dot(&self.b2)),
        }
    }

    /// The point back in the candidate frame, m.
    pub fn position(&self, p: &AxisPoint) -> Vector3<f64> {
        self.p2 + (self.a * p.xi + self.b1 * p.across.x + self.b2 * p.across.y) * self.d
    }

    /// `h_i(B) = max(B κ_i(q), −B κ_i(−q))`: the least push of contact `i` along the axis for
    /// an across force `B` along `v`, where `q = n̂_i · v` (module docs §2).
    fn least_push(&self, i: usize, b: f64, q: f64) -> f64 {
        let c = &self.contacts[i];
        (b * c.edge(q).0).max(-b * c.edge(-q).0)
    }

    /// The squeeze and 2-norm of an object at `c` after its swing (module docs §2), units of the
    /// weight. On the axis (`c⊥ = 0`) every plane through it is taken and the worst is given.
    pub fn held(&self, t: Tilt, c: &AxisPoint) -> Held {
        let rho = c.across.norm();
        let b1 = rho * t.s - c.xi * t.k;
        let b2 = -(1.0 - c.xi) * t.k - rho * t.s;
        let (h1, h2) = if rho > 0.0 {
            let v = c.across / rho;
            (
                self.least_push(0, b1, self.across[0].dot(&v)),
                self.least_push(1, b2, self.across[1].dot(&v)),
            )
        } else {
            // Every plane: `h_i` is monotone in `q`, so its largest is at `q = ±sin δ_i`.
            let worst = |i: usize, b: f64| {
                let sd = self.contacts[i].sin_delta;
                self.least_push(i, b, sd).max(self.least_push(i, b, -sd))
            };
            (worst(0, b1), worst(1, b2))
        };
        let squeeze = (h1 - 0.5 * t.s).max(h2 + 0.5 * t.s).max(0.0);
        let norm2 = (2.0 * squeeze * squeeze + 0.5 * t.s * t.s + b1 * b1 + b2 * b2).sqrt();
        Held { squeeze, norm2 }
    }
}

/// A closed interval of reals. No outward rounding: bounds are exact to rounding (module docs §4).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Iv {
    lo: f64,
    hi: f64,
}

impl Iv {
    fn new(a: f64, b: f64) -> Self {
        Self {
            lo: a.min(b),
            hi: a.max(b),
        }
    }
    fn point(x: f64) -> Self {
        Self { lo: x, hi: x }
    }
    fn add(self, o: Iv) -> Iv {
        Iv {
            lo: self.lo + o.lo,
            hi: self.hi + o.hi,
        }
    }
    fn scale(self, k: f64) -> Iv {
        Iv::new(self.lo * k, self.hi * k)
    }
    fn shift(self, k: f64) -> Iv {
        Iv {
            lo: self.lo + k,
            hi: self.hi + k,
        }
    }
    fn neg(self) -> Iv {
        Iv {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
    fn mul(self, o: Iv) -> Iv {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        Iv {
            lo: p.iter().copied().fold(f64::INFINITY, f64::min),
            hi: p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
    /// The largest magnitude.
    fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
    /// The least magnitude.
    fn mig(self) -> f64 {
        if self.lo <= 0.0 && self.hi >= 0.0 {
            0.0
        } else {
            self.lo.abs().min(self.hi.abs())
        }
    }
    fn max0(self) -> Iv {
        Iv {
            lo: self.lo.max(0.0),
            hi: self.hi.max(0.0),
        }
    }
}

/// An edge of the region in axis coordinates, `c(t) = start + t (end − start)`, `t ∈ [0, 1]`,
/// whose line misses the axis.
#[derive(Debug, Clone, Copy)]
struct Edge {
    xi0: f64,
    dxi: f64,
    u0: Vector2<f64>,
    e: Vector2<f64>,
    /// `u0 × e`: `ψ' = cross / ρ²`.
    cross: f64,
}

impl Edge {
    fn at(&self, t: f64) -> AxisPoint {
        AxisPoint {
            xi: self.xi0 + t * self.dxi,
            across: self.u0 + self.e * t,
        }
    }

    fn rho(&self, t: f64) -> f64 {
        (self.u0 + self.e * t).norm()
    }

    /// `dρ/dt = (c⊥ · e)/ρ`, increasing in `t` (ρ is convex).
    fn rho_slope(&self, t: f64) -> f64 {
        let c = self.u0 + self.e * t;
        c.dot(&self.e) / c.norm()
    }
}

/// The range of `w · v` as `v` sweeps the shorter arc from unit `v0` to unit `v1`: the ends, and
/// `±|w|` where `±w` lies inside the arc.
fn dot_over_arc(w: &Vector2<f64>, v0: &Vector2<f64>, v1: &Vector2<f64>) -> Iv {
    let mut r = Iv::new(w.dot(v0), w.dot(v1));
    let sweep = v0.perp(v1);
    let inside = |x: &Vector2<f64>| {
        x.dot(&(v0 + v1)) > 0.0 && v0.perp(x) * sweep >= 0.0 && x.perp(v1) * sweep >= 0.0
    };
    let n = w.norm();
    if n > 0.0 {
        if inside(w) {
            r.hi = n;
        }
        if inside(&-w) {
            r.lo = -n;
        }
    }
    r
}

/// Enclosures over `t ∈ [t0, t1]` of one edge's four terms `T_j` (module docs §2), their slopes,
/// and `B1`, `B2` with their slopes.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    terms: [Iv; 4],
    slopes: [Iv; 4],
    b: [Iv; 2],
    b_slopes: [Iv; 2],
}

impl AxisView {
    /// The four terms at a point: `T_{1±}`, `T_{2±}` (module docs §2).
    fn terms(&self, t: Tilt, c: &AxisPoint) -> ([f64; 4], [f64; 2]) {
        let rho = c.across.norm();
        let v = c.across / rho;
        let b1 = rho * t.s - c.xi * t.k;
        let b2 = -(1.0 - c.xi) * t.k - rho * t.s;
        let (q1, q2) = (self.across[0].dot(&v), self.across[1].dot(&v));
        let [k1, k2] = &self.contacts;
        (
            [
                b1 * k1.edge(q1).0 - 0.5 * t.s,
                -b1 * k1.edge(-q1).0 - 0.5 * t.s,
                b2 * k2.edge(q2).0 + 0.5 * t.s,
                -b2 * k2.edge(-q2).0 + 0.5 * t.s,
            ],
            [b1, b2],
        )
    }

    /// Interval enclosures of the terms and their slopes over `[t0, t1]` of `edge`.
    ///
    /// Every ingredient's range is exact: `ξ` is affine; `ρ` is convex (its least value at the
    /// foot of the perpendicular from the axis) and `ρ'` increasing; the direction `v` sweeps a
    /// known arc, so `q_i = n⊥_i · v` and `n⊥_i · v⊥` have exact ranges; `κ` is decreasing and
    /// convex in `q`, so `κ` and `κ'` take their extremes at the ends of `q`'s range. They are
    /// combined by interval arithmetic.
    fn bounds(&self, t: Tilt, edge: &Edge, t0: f64, t1: f64) -> Bounds {
        let xi = Iv::new(edge.xi0 + t0 * edge.dxi, edge.xi0 + t1 * edge.dxi);
        let e2 = edge.e.norm_squared();
        let foot = (-edge.u0.dot(&edge.e) / e2).clamp(t0, t1);
        let rho = Iv::new(edge.rho(foot), edge.rho(t0).max(edge.rho(t1)));
        let rho_slope = Iv::new(edge.rho_slope(t0), edge.rho_slope(t1));
        let (c0, c1) = (edge.at(t0).across, edge.at(t1).across);
        let (v0, v1) = (c0 / c0.norm(), c1 / c1.norm());
        // ψ' = (u0 × e)/ρ², and v' = ψ' v⊥ with v⊥ = v turned +90°.
        let psi_slope = Iv::new(
            edge.cross / (rho.lo * rho.lo),
            edge.cross / (rho.hi * rho.hi),
        );
        let b1 = rho.scale(t.s).add(xi.scale(-t.k));
        let b2 = xi.scale(t.k).shift(-t.k).add(rho.scale(-t.s));
        let b1_slope = rho_slope.scale(t.s).shift(-t.k * edge.dxi);
        let b2_slope = rho_slope.scale(-t.s).shift(t.k * edge.dxi);
        let mut terms = [Iv::point(0.0); 4];
        let mut slopes = [Iv::point(0.0); 4];
        for i in 0..2 {
            let n = &self.across[i];
            let q = dot_over_arc(n, &v0, &v1);
            // n · v⊥ = v × n.
            let n_perp = Vector2::new(n.y, -n.x);
            let q_slope = psi_slope.mul(dot_over_arc(&n_perp, &v0, &v1));
            let c = &self.contacts[i];
            let (b, b_slope, half) = if i == 0 {
                (b1, b1_slope, -0.5 * t.s)
            } else {
                (b2, b2_slope, 0.5 * t.s)
            };
            // T_+ = B κ(q) + half; T_− = −B κ(−q) + half.
            let (kl, dl) = c.edge(q.lo);
            let (kh, dh) = c.edge(q.hi);
            let (kappa, kappa_slope) = (Iv::new(kh, kl), Iv::new(dl, dh));
            terms[2 * i] = b.mul(kappa).shift(half);
            slopes[2 * i] = b_slope.mul(kappa).add(b.mul(kappa_slope).mul(q_slope));
            let (ml, el) = c.edge(-q.hi);
            let (mh, eh) = c.edge(-q.lo);
            let (kappa, kappa_slope) = (Iv::new(ml, mh), Iv::new(el, eh));
            terms[2 * i + 1] = b.mul(kappa).neg().shift(half);
            slopes[2 * i + 1] = b_slope
                .mul(kappa)
                .neg()
                .add(b.mul(kappa_slope).mul(q_slope));
        }
        Bounds {
            terms,
            slopes,
            b: [b1, b2],
            b_slopes: [b1_slope, b2_slope],
        }
    }
}

/// An upper bound of `quantity` over a piece of an edge from its value at the middle and the
/// enclosures: per term, the least of the interval bound and the mean-value bound
/// `F(m) + sup|F'| w/2` (module docs §4).
fn upper_bound(
    quantity: Quantity,
    t: Tilt,
    mid: &([f64; 4], [f64; 2]),
    bd: &Bounds,
    w: f64,
) -> f64 {
    let (terms, b) = mid;
    let mut best = 0.0f64;
    let base = 0.5 * t.s * t.s;
    for (j, &term) in terms.iter().enumerate() {
        let tj = bd.terms[j].max0();
        // max(T, 0) has the slope of T where T > 0, none where T < 0.
        let tj_slope = if bd.terms[j].hi <= 0.0 {
            Iv::point(0.0)
        } else if bd.terms[j].lo >= 0.0 {
            bd.slopes[j]
        } else {
            Iv::new(bd.slopes[j].lo.min(0.0), bd.slopes[j].hi.max(0.0))
        };
        let bound = match quantity {
            // max(T, 0) <= max(T(m) + sup|T'| w/2, 0): a term well below zero at the middle
            // bounds the piece below zero without splitting it down to `tolerance`.
            Quantity::Squeeze => tj
                .hi
                .min((term + bd.slopes[j].mag() * 0.5 * w).max(0.0))
                .min(term.max(0.0) + tj_slope.mag() * 0.5 * w),
            Quantity::Norm2 => {
                let sq = |x: f64| x * x;
                let at_mid = (2.0 * sq(term.max(0.0)) + base + sq(b[0]) + sq(b[1])).sqrt();
                let natural =
                    (2.0 * sq(tj.hi) + base + sq(bd.b[0].mag()) + sq(bd.b[1].mag())).sqrt();
                // F' = (2 T⁺ T⁺' + B1 B1' + B2 B2') / F, with F >= sqrt(1/2) (module docs §4).
                let least = (2.0 * sq(tj.lo) + base + sq(bd.b[0].mig()) + sq(bd.b[1].mig()))
                    .sqrt()
                    .max(0.5f64.sqrt());
                let top = tj
                    .scale(2.0)
                    .mul(tj_slope)
                    .add(bd.b[0].mul(bd.b_slopes[0]))
                    .add(bd.b[1].mul(bd.b_slopes[1]));
                natural.min(at_mid + top.mag() / least * 0.5 * w)
            }
        };
        best = best.max(bound);
    }
    best
}

/// How far a piece's bound may lie above the best value `best` found when the maximisation
/// stops, units of the weight: `CERTIFY |best| + CERTIFY_ABS` (module docs §4).
pub(super) fn tolerance(best: f64) -> f64 {
    CERTIFY * best.abs() + CERTIFY_ABS
}

/// A segment of the region (end points in axis coordinates), as the maximisation sees it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Segment {
    pub start: AxisPoint,
    pub end: AxisPoint,
}

/// Where the largest value was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Worst {
    /// The value, units of the weight.
    pub value: f64,
    /// Where: the segment's index and the parameter along it (`None`: the axis segment's end
    /// `t`).
    pub segment: Option<usize>,
    pub t: f64,
    /// The point.
    pub point: AxisPoint,
    /// An upper bound of the true maximum (module docs §4).
    pub bound: f64,
    /// How many pieces were split to certify it.
    pub splits: usize,
}

/// One piece of an edge waiting to be split.
#[derive(Debug, Clone, Copy)]
struct Piece {
    bound: f64,
    segment: usize,
    t0: f64,
    t1: f64,
}

// Ordered by bound alone, for the heap of `refine` (largest bound first).
impl PartialEq for Piece {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other).is_eq()
    }
}

impl Eq for Piece {}

impl PartialOrd for Piece {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Piece {
    fn cmp(&self, other: &Self) -> Ordering {
        self.bound.total_cmp(&other.bound)
    }
}

/// An object's squeeze and 2-norm from its four terms and `B1`, `B2` ([`AxisView::terms`]):
/// `h1 − s/2 = max(T_{1+}, T_{1−})` and `h2 + s/2 = max(T_{2+}, T_{2−})`, so this is
/// [`AxisView::held`] off the axis, to the last bit (subtracting `s/2` commutes with `max`).
fn held_from_terms(t: Tilt, (terms, [b1, b2]): &([f64; 4], [f64; 2])) -> Held {
    let squeeze = terms.iter().copied().fold(0.0, f64::max);
    let norm2 = (2.0 * squeeze * squeeze + 0.5 * t.s * t.s + b1 * b1 + b2 * b2).sqrt();
    Held { squeeze, norm2 }
}

impl Worst {
    /// Keeps `point` if its `value` is larger than the largest so far (the first of equals wins).
    fn consider(&mut self, value: f64, segment: Option<usize>, t: f64, point: AxisPoint) {
        if value > self.value {
            *self = Worst {
                value,
                segment,
                t,
                point,
                bound: 0.0,
                splits: 0,
            };
        }
    }
}

impl AxisView {
    /// The largest `quantity` over `segments` and the points `axis` (the region's points on the
    /// contact axis, every plane taken), certified to [`tolerance`] (module docs §4): every end
    /// point and the axis points are evaluated, then each edge is split where its upper bound
    /// is largest until no piece can beat the best value by more than the tolerance.
    pub fn worst(
        &self,
        quantity: Quantity,
        theta: f64,
        segments: &[Segment],
        axis: &[AxisPoint],
    ) -> Worst {
        let t = Tilt::new(theta);
        let mut best = Worst {
            value: f64::NEG_INFINITY,
            segment: None,
            t: 0.0,
            point: axis.first().copied().unwrap_or(segments[0].start),
            bound: 0.0,
            splits: 0,
        };
        for p in axis {
            best.consider(self.held(t, p).get(quantity), None, 0.0, *p);
        }
        let edges = self.edges(quantity, t, segments, &mut best);
        let pieces = self.first_pieces(quantity, t, &edges, &mut best);
        self.refine(quantity, t, &edges, pieces, best)
    }

    /// Each segment's ends evaluated, and the segment as an edge to split; `None` for one along
    /// or through the axis, which is affine on each side of it (module docs §3), after its point
    /// nearest the axis is evaluated.
    fn edges(
        &self,
        quantity: Quantity,
        t: Tilt,
        segments: &[Segment],
        best: &mut Worst,
    ) -> Vec<Option<Edge>> {
        let mut edges: Vec<Option<Edge>> = Vec::with_capacity(segments.len());
        for (i, s) in segments.iter().enumerate() {
            for (tt, p) in [(0.0, s.start), (1.0, s.end)] {
                best.consider(self.held(t, &p).get(quantity), Some(i), tt, p);
            }
            let edge = Edge {
                xi0: s.start.xi,
                dxi: s.end.xi - s.start.xi,
                u0: s.start.across,
                e: s.end.across - s.start.across,
                cross: s.start.across.perp(&(s.end.across - s.start.across)),
            };
            let e_norm = edge.e.norm();
            if e_norm <= THROUGH_AXIS * (1.0 + edge.u0.norm()) {
                edges.push(None);
                continue;
            }
            if edge.cross.abs() <= THROUGH_AXIS * e_norm {
                let foot = (-edge.u0.dot(&edge.e) / (e_norm * e_norm)).clamp(0.0, 1.0);
                let on_axis = AxisPoint {
                    xi: edge.xi0 + foot * edge.dxi,
                    across: Vector2::zeros(),
                };
                best.consider(self.held(t, &on_axis).get(quantity), Some(i), foot, on_axis);
                edges.push(None);
                continue;
            }
            edges.push(Some(edge));
        }
        edges
    }

    /// Each edge as one piece, its midpoint evaluated and its upper bound computed.
    fn first_pieces(
        &self,
        quantity: Quantity,
        t: Tilt,
        edges: &[Option<Edge>],
        best: &mut Worst,
    ) -> Vec<Piece> {
        let mut pieces: Vec<Piece> = Vec::with_capacity(4 * edges.len());
        for (i, edge) in edges.iter().enumerate() {
            if let Some(edge) = edge {
                let mid = edge.at(0.5);
                let m = self.terms(t, &mid);
                best.consider(self.held(t, &mid).get(quantity), Some(i), 0.5, mid);
                let bound = upper_bound(quantity, t, &m, &self.bounds(t, edge, 0.0, 1.0), 1.0);
                pieces.push(Piece {
                    bound,
                    segment: i,
                    t0: 0.0,
                    t1: 1.0,
                });
            }
        }
        pieces
    }

    /// Splits the piece of largest bound in two, evaluating each half's midpoint, until no bound
    /// exceeds the best value by more than [`tolerance`], or [`MAX_SPLITS`] splits were made
    /// (module docs §4: the bound reported is then the largest left, honest but looser).
    fn refine(
        &self,
        quantity: Quantity,
        t: Tilt,
        edges: &[Option<Edge>],
        pieces: Vec<Piece>,
        mut best: Worst,
    ) -> Worst {
        let mut pieces = BinaryHeap::from(pieces);
        let mut splits = 0;
        while let Some(top) = pieces.pop() {
            if top.bound <= best.value + tolerance(best.value) || splits >= MAX_SPLITS {
                best.bound = top.bound.max(best.value);
                best.splits = splits;
                return best;
            }
            splits += 1;
            let Some(edge) = edges[top.segment] else {
                continue;
            };
            let half = 0.5 * (top.t0 + top.t1);
            for (a, b) in [(top.t0, half), (half, top.t1)] {
                let tm = 0.5 * (a + b);
                let mid = edge.at(tm);
                let m = self.terms(t, &mid);
                best.consider(
                    held_from_terms(t, &m).get(quantity),
                    Some(top.segment),
                    tm,
                    mid,
                );
                let bound = upper_bound(quantity, t, &m, &self.bounds(t, &edge, a, b), b - a);
                pieces.push(Piece {
                    bound,
                    segment: top.segment,
                    t0: a,
                    t1: b,
                });
            }
        }
        best.bound = best.value;
        best.splits = splits;
        best
    }
}
