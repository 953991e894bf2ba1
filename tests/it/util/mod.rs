//! Test support: an independent numerical reference, a generator of random grasps, the paper's
//! Table 1 ([`table_1`]), and the binary under test with temporary folders ([`run`]).
//!
//! The reference shares no code with the solver's closed forms. It works in the candidate's own
//! frame: it builds the 3×4 grasp matrix from the normals and tangents, takes its pseudo-inverse
//! `Lᵀ (L Lᵀ)⁻¹` with one step of iterative refinement, finds the null vector by projection, bounds the null-space parameter exactly
//! from the six contact inequalities, and scans the object's rotation densely with the power and
//! its derivative (from the active constraint), bisecting every sign change of the derivative.

pub mod run;

/// The paper's Table 1, the same fixture the solver's unit tests use.
pub use grasp_orient::solver::table_1;
pub mod robust;
pub mod spatial;
pub mod torus;
pub mod zstd_bomb;

/// The channels of a recording of contact and pose candidates under the node's default names,
/// with no markers and no sets.
pub fn pose_bag_topics() -> grasp_orient::record::Topics {
    grasp_orient::record::Topics::new("/grasp_candidates", "/grip_recommendations")
        .with::<grasp_orient::kind::Poses>("/pose_candidates", "/pose_recommendations")
        .with::<grasp_orient::kind::PoseSets>("/pose_candidate_sets", "/pose_recommendation_sets")
}

/// Writes `payloads` to `w` in order, the k-th logged and published at `first + k * step` ns,
/// and finishes the recording.
pub fn write_in_order(
    mut w: grasp_orient::record::BagWriter,
    payloads: impl IntoIterator<Item = grasp_orient::record::Payload>,
    first: u64,
    step: u64,
) {
    for (k, payload) in payloads.into_iter().enumerate() {
        let t = first + k as u64 * step;
        w.write(&grasp_orient::record::Entry {
            payload,
            log_time: t,
            publish_time: t,
        })
        .expect("write");
    }
    w.finish().expect("finish");
}

/// A candidate's answer through the library's front door, with `settings` and the default
/// rules (no gripper limit, no default tolerances).
pub fn answer(
    m: &grasp_orient::msg::GraspCandidate,
    settings: &grasp_orient::solver::Settings,
) -> grasp_orient::msg::GripRecommendation {
    answering(settings, &grasp_orient::answer::Rules::default())
        .answer::<grasp_orient::kind::Candidates>(m)
}

/// The answering object of `settings` and `rules`; it reads no mesh.
pub fn answering(
    settings: &grasp_orient::solver::Settings,
    rules: &grasp_orient::answer::Rules,
) -> grasp_orient::answer::Answering {
    grasp_orient::answer::Answering::new(
        *settings,
        *rules,
        grasp_orient::answer::PoseAnswerer::new(
            grasp_orient::geometry::ClosingAxis::Y,
            grasp_orient::geometry::AmentIndex::default(),
        ),
    )
}

use grasp_orient::solver::planar::Candidate;
use nalgebra::{Matrix3x4, Matrix4x3, Vector2, Vector3, Vector4};
use rand::Rng;
use std::f64::consts::{PI, TAU};

/// Which objective the reference minimises (mirrors the solver's, by name only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefObjective {
    Norm2,
    Norm1,
    InternalForce,
}

/// Which rotations the reference may choose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefRange {
    /// The upward vertical through the centre of mass meets the contact segment.
    FromAbove,
    /// Gravity does not point strictly into the sector between the two contacts.
    Graspable,
}

fn rot(v: Vector2<f64>, angle: f64) -> Vector2<f64> {
    let (s, c) = angle.sin_cos();
    Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The reference's view of one candidate.
pub struct Reference {
    l: Matrix3x4<f64>,
    pinv: Matrix4x3<f64>,
    null: Vector4<f64>,
    /// Norm of the contact-1 block of `null`: the squeeze per unit of the parameter.
    squeeze_per_unit: f64,
    mu: [f64; 2],
    weight: Vector2<f64>,
    to_1: Vector2<f64>,
    to_2: Vector2<f64>,
    objective: RefObjective,
}

/// The reference's answer at one rotation.
#[derive(Debug, Clone, Copy)]
pub struct RefPoint {
    pub power: f64,
    pub internal_force: f64,
    /// `(N1, F1, N2, F2)`: friction along the inward normal turned +90°.
    pub forces: [f64; 4],
}

impl Reference {
    pub fn new(c: &Candidate, safety: f64, objective: RefObjective) -> Self {
        let n1 = c.normal_1.normalize();
        let n2 = c.normal_2.normalize();
        let t1 = rot(n1, PI / 2.0);
        let t2 = rot(n2, PI / 2.0);
        let r1 = c.contact_1 - c.center_of_mass;
        let r2 = c.contact_2 - c.center_of_mass;
        let col = |d: Vector2<f64>, r: Vector2<f64>| Vector3::new(d.x, d.y, cross(r, d));
        let l = Matrix3x4::from_columns(&[col(n1, r1), col(t1, r1), col(n2, r2), col(t2, r2)]);
        // Pseudo-inverse of a full-rank 3×4 matrix: Lᵀ (L Lᵀ)⁻¹.
        let gram = (l * l.transpose())
            .try_inverse()
            .expect("grasp matrix has full rank");
        let pinv = l.transpose() * gram;
        let proj = nalgebra::Matrix4::identity() - pinv * l;
        let mut null = (0..4)
            .map(|k| proj.column(k).into_owned())
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .expect("four columns");
        null /= null.norm();
        if null[0] + null[2] < 0.0 {
            null = -null;
        }
        let squeeze_per_unit = null[0].hypot(null[1]);
        Self {
            l,
            pinv,
            null,
            squeeze_per_unit,
            mu: [c.friction_1 / safety, c.friction_2 / safety],
            weight: c.gravity * c.mass,
            to_1: r1,
            to_2: r2,
            objective,
        }
    }

    /// The answer after rotating the object by `omega` about +z.
    pub fn at(&self, omega: f64) -> Option<RefPoint> {
        self.at_with_slope(omega).map(|(p, _)| p)
    }

    /// The answer at `omega` and the derivative of the power with respect to `omega`, from the
    /// active constraint (one-sided at a switch of constraints).
    ///
    /// Longer than a screen: the whole reference computation at one angle (the SOCP, its
    /// certificate, the slope from the active constraint) kept in one piece so that it can be read
    /// against the paper without jumping.
    pub fn at_with_slope(&self, omega: f64) -> Option<(RefPoint, f64)> {
        let w = rot(self.weight, -omega);
        // d/dω of rot(W, -ω) is -rot(W, -ω + π/2).
        let dw = -rot(self.weight, -omega + PI / 2.0);
        let b = Vector3::new(-w.x, -w.y, 0.0);
        let db = Vector3::new(-dw.x, -dw.y, 0.0);
        let solve = |rhs: Vector3<f64>| {
            let mut x = self.pinv * rhs;
            // One step of iterative refinement against the rounding of the inverse.
            x += self.pinv * (rhs - self.l * x);
            x
        };
        let fp = solve(b);
        let dfp = solve(db);
        let v = self.null;
        // Constraints a·F >= 0, i.e. a·fp + α a·v >= 0.
        let mu = self.mu;
        let rows = [
            Vector4::new(1.0, 0.0, 0.0, 0.0),
            Vector4::new(0.0, 0.0, 1.0, 0.0),
            Vector4::new(mu[0], -1.0, 0.0, 0.0),
            Vector4::new(mu[0], 1.0, 0.0, 0.0),
            Vector4::new(0.0, 0.0, mu[1], -1.0),
            Vector4::new(0.0, 0.0, mu[1], 1.0),
        ];
        // (bound, its derivative)
        let mut lo = (f64::NEG_INFINITY, 0.0);
        let mut hi = (f64::INFINITY, 0.0);
        for a in rows {
            let (c, d, dc) = (a.dot(&fp), a.dot(&v), a.dot(&dfp));
            if d > 0.0 {
                if -c / d > lo.0 {
                    lo = (-c / d, -dc / d);
                }
            } else if d < 0.0 {
                if -c / d < hi.0 {
                    hi = (-c / d, -dc / d);
                }
            } else if c < 0.0 {
                return None;
            }
        }
        if lo.0 > hi.0 {
            return None;
        }
        let clamp = |x: (f64, f64)| {
            if x.0 < lo.0 {
                lo
            } else if x.0 > hi.0 {
                hi
            } else {
                x
            }
        };
        let (alpha, dalpha) = match self.objective {
            RefObjective::Norm2 => clamp((-fp.dot(&v) / v.dot(&v), -dfp.dot(&v) / v.dot(&v))),
            RefObjective::InternalForce => clamp((0.0, 0.0)),
            RefObjective::Norm1 => {
                let g = |a: f64| (fp + v * a).abs().sum();
                let mut best = lo;
                for k in 0..4 {
                    if v[k] != 0.0 {
                        let a = -fp[k] / v[k];
                        if a > lo.0 && a <= hi.0 && g(a) < g(best.0) {
                            best = (a, -dfp[k] / v[k]);
                        }
                    }
                }
                best
            }
        };
        let f = fp + v * alpha;
        let df = dfp + v * dalpha;
        let (power, slope) = match self.objective {
            RefObjective::Norm2 => {
                let n = f.norm();
                (n, f.dot(&df) / n)
            }
            RefObjective::Norm1 => (f.abs().sum(), (0..4).map(|i| f[i].signum() * df[i]).sum()),
            RefObjective::InternalForce => (
                alpha * self.squeeze_per_unit,
                dalpha * self.squeeze_per_unit,
            ),
        };
        Some((
            RefPoint {
                power,
                internal_force: alpha * self.squeeze_per_unit,
                forces: [f[0], f[1], f[2], f[3]],
            },
            slope,
        ))
    }

    /// The rotations allowed, as one arc `[start, start + length]`.
    pub fn arc(&self, range: RefRange, gravity: Vector2<f64>) -> (f64, f64) {
        // Rotating the object by ω turns gravity, seen from the object, by -ω.
        let ga = gravity.y.atan2(gravity.x);
        let a1 = self.to_1.y.atan2(self.to_1.x);
        let a2 = self.to_2.y.atan2(self.to_2.x);
        // The sector from the centre of mass between the two contacts, counter-clockwise from
        // `from` over `width` (< π unless the centre of mass is on the contact line).
        let (from, width) = if cross(self.to_1, self.to_2) >= 0.0 {
            (a1, (a2 - a1).rem_euclid(TAU))
        } else {
            (a2, (a1 - a2).rem_euclid(TAU))
        };
        match range {
            // Upward direction -g after rotation, at angle ga + π - ω, lies in the sector:
            // ω ∈ [ga + π - from - width, ga + π - from].
            RefRange::FromAbove => (ga + PI - from - width, width),
            // Gravity direction ga - ω outside the open sector, in [from + width, from + 2π]:
            // ω ∈ [ga - from - 2π, ga - from - width].
            RefRange::Graspable => (ga - from - TAU, TAU - width),
        }
    }

    /// The best rotation over the arc: a dense scan with the power and its slope at every
    /// sample; every sign change of the slope between samples is bisected to rounding, and the
    /// arc's ends are kept as candidates.
    pub fn minimise(&self, range: RefRange, gravity: Vector2<f64>, samples: usize) -> (f64, f64) {
        let (start, len) = self.arc(range, gravity);
        let eval = |w: f64| {
            self.at_with_slope(w)
                .map_or((f64::INFINITY, 0.0), |(p, s)| (p.power, s))
        };
        let grid: Vec<(f64, f64, f64)> = (0..=samples)
            .map(|k| {
                let w = start + len * k as f64 / samples as f64;
                let (p, s) = eval(w);
                (w, p, s)
            })
            .collect();
        let mut best = (grid[0].0, grid[0].1);
        let mut keep = |w: f64, v: f64| {
            if v < best.1 {
                best = (w, v);
            }
        };
        for &(w, p, _) in &grid {
            keep(w, p);
        }
        for pair in grid.windows(2) {
            let ((mut a, _, sa), (mut b, _, sb)) = (pair[0], pair[1]);
            if sa < 0.0 && sb >= 0.0 {
                for _ in 0..100 {
                    let m = 0.5 * (a + b);
                    if m <= a || m >= b {
                        break;
                    }
                    if eval(m).1 < 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                for w in [a, b] {
                    keep(w, eval(w).0);
                }
            }
        }
        best
    }
}

impl Reference {
    /// Every local minimum over the arc: sign changes of the slope from - to + between samples,
    /// bisected, and the arc's ends where the power rises into the arc.
    pub fn local_minima(
        &self,
        range: RefRange,
        gravity: Vector2<f64>,
        samples: usize,
    ) -> Vec<(f64, f64)> {
        let (start, len) = self.arc(range, gravity);
        let eval = |w: f64| {
            self.at_with_slope(w)
                .map_or((f64::INFINITY, 0.0), |(p, s)| (p.power, s))
        };
        let grid: Vec<(f64, f64)> = (0..=samples)
            .map(|k| {
                let w = start + len * k as f64 / samples as f64;
                (w, eval(w).1)
            })
            .collect();
        let mut out = Vec::new();
        if grid[0].1 >= 0.0 {
            out.push((start, eval(start).0));
        }
        for pair in grid.windows(2) {
            let ((mut a, sa), (mut b, sb)) = (pair[0], pair[1]);
            if sa < 0.0 && sb >= 0.0 {
                for _ in 0..100 {
                    let m = 0.5 * (a + b);
                    if m <= a || m >= b {
                        break;
                    }
                    if eval(m).1 < 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let w = if eval(a).0 <= eval(b).0 { a } else { b };
                out.push((w, eval(w).0));
            }
        }
        if grid[samples].1 <= 0.0 {
            let end = start + len;
            if out.last().is_none_or(|(w, _)| (end - w).abs() > 1e-9) {
                out.push((end, eval(end).0));
            }
        }
        out
    }
}

/// Whether the friction cone at `p` (inward normal `n`, coefficient `mu`) contains point `q`.
fn cone_contains(p: Vector2<f64>, n: Vector2<f64>, mu: f64, q: Vector2<f64>) -> bool {
    let d = q - p;
    let n = n.normalize();
    let along = n.dot(&d);
    along > 0.0 && cross(n, d).abs() < mu * along
}

/// A random grasp with force closure, in a random frame, with a random labelling.
///
/// The object is implied: the centre of mass lies on the inner side of both tangent lines, so a
/// convex object through both contacts can contain it.
pub fn random_grasp(rng: &mut impl Rng) -> Candidate {
    random_grasp_behind(rng, [false, false])
}

/// [`random_grasp`] with the centre of mass behind the tangent line at contact `i` (by at least
/// 1e-3 of the scene's unit) where `behind[i]`, on its inner side (by as much) elsewhere: the
/// object is not convex there.
pub fn random_grasp_behind(rng: &mut impl Rng, behind: [bool; 2]) -> Candidate {
    let side_ok = |depth: f64, behind: bool| {
        if behind {
            depth < -1e-3
        } else {
            depth > 1e-3
        }
    };
    let reach = if behind.contains(&true) { 2.0 } else { 1.0 };
    loop {
        let p1 = Vector2::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        let p2 = Vector2::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
        if (p1 - p2).norm() < 0.05 {
            continue;
        }
        let along = (p2 - p1).normalize();
        let n1 = rot(along, rng.gen_range(-1.4..1.4));
        let n2 = rot(-along, rng.gen_range(-1.4..1.4));
        let mu1 = rng.gen_range(0.1..2.0);
        let mu2 = rng.gen_range(0.1..2.0);
        if !cone_contains(p1, n1, mu1, p2) || !cone_contains(p2, n2, mu2, p1) {
            continue;
        }
        // Centre of mass: somewhere inside both half-planes, near the contacts.
        let mid = (p1 + p2) / 2.0;
        let com = mid + Vector2::new(rng.gen_range(-reach..reach), rng.gen_range(-reach..reach));
        if !side_ok(n1.dot(&(com - p1)), behind[0]) || !side_ok(n2.dot(&(com - p2)), behind[1]) {
            continue;
        }
        // A random rigid motion and unit scale of the whole scene.
        let angle = rng.gen_range(-PI..PI);
        let shift = Vector2::new(rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0));
        let scale = 10f64.powf(rng.gen_range(-2.0..1.0));
        let place = |p: Vector2<f64>| rot(p, angle) * scale + shift;
        let g = 9.81 * rng.gen_range(0.5..1.5);
        return Candidate {
            contact_1: place(p1),
            contact_2: place(p2),
            normal_1: rot(n1, angle) * rng.gen_range(0.1..10.0),
            normal_2: rot(n2, angle) * rng.gen_range(0.1..10.0),
            friction_1: mu1,
            friction_2: mu2,
            center_of_mass: place(com),
            mass: 10f64.powf(rng.gen_range(-2.0..2.0)),
            gravity: rot(Vector2::new(0.0, -g), rng.gen_range(-PI..PI)),
        };
    }
}

/// `x` wrapped into `(-π, π]` (written here again so the reference owns its arithmetic).
pub fn wrap(x: f64) -> f64 {
    let w = (x + PI).rem_euclid(TAU) - PI;
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}
