//! An independent 3D reference for spatial grasps, and a generator of random spatial grasps.
//!
//! The reference shares no code and no idea with the solver's reduction to a plane: it knows
//! nothing of grasp planes, sliced cones or plane angles. For a gravity direction `ĝ` it solves,
//! with Clarabel, the second-order cone program
//!
//! ```text
//!   minimise t  over t ∈ ℝ, f1, f2 ∈ ℝ³
//!   f1 + f2 = −W ĝ                             (forces, 3 rows)
//!   r1 × f1 + r2 × f2 = 0,  r_i = p_i − c       (moments about the centre of mass, 3 rows)
//!   (μ_i n̂_i·f_i, t_i1·f_i, t_i2·f_i) ∈ SOC₃    (true circular Coulomb cones)
//!   (t, f1, f2) ∈ SOC₇                          (t ≥ ||(f1, f2)||₂, the gripping power)
//! ```
//!
//! The six balance rows have rank 5; when the right-hand side is not in their range (found from
//! the left null vector, by SVD) nothing holds the weight. Clarabel's answer is then polished
//! exactly along the one direction the balance leaves free (`SpatialReference::polish`): near the
//! friction angle a cone meets the plane of the forces in a thin wedge, where Clarabel's
//! feasibility tolerance alone moves the power by up to 1e-3 of itself. The tests report how far
//! Clarabel's own optimum lies from the polished one. Scans: over gravity directions in the plane
//! through the contacts and the centre of mass (found by the reference from the points alone), or
//! over the whole sphere, each refined by golden-section search.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, SecondOrderConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};
use grasp_orient::solver::spatial;
use nalgebra::{Matrix5x6, Matrix6, Rotation3, Unit, Vector3, Vector5, Vector6};
use rand::Rng;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// What the reference finds for one gravity direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Held {
    /// Least 2-norm of the two contact forces, N (polished), the forces, and Clarabel's own
    /// value before polishing (`None` when Clarabel gave no certain answer).
    Yes {
        power: f64,
        forces: [Vector3<f64>; 2],
        clarabel: Option<f64>,
        /// The mean push of the two forces along the contact line, into the object, N: the
        /// internal (squeeze) force of these forces.
        squeeze: f64,
    },
    /// No forces balance the weight: the balance equations are inconsistent.
    No,
}

impl Held {
    pub fn power(&self) -> Option<f64> {
        match self {
            Held::Yes { power, .. } => Some(*power),
            Held::No => None,
        }
    }

    pub fn squeeze(&self) -> Option<f64> {
        match self {
            Held::Yes { squeeze, .. } => Some(*squeeze),
            Held::No => None,
        }
    }
}

/// Which gravity directions the reference scans.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefRange {
    /// The upward vertical through the centre of mass meets the segment between the contacts.
    FromAbove,
    /// Gravity does not point strictly into the sector from the centre of mass between the
    /// contacts.
    Graspable,
}

/// The reference's view of one spatial candidate.
#[derive(Debug, Clone)]
pub struct SpatialReference {
    p: [Vector3<f64>; 2],
    c: Vector3<f64>,
    n: [Vector3<f64>; 2],
    mu: [f64; 2],
    weight: f64,
    /// Lengths are divided by this (the contact distance) inside the program.
    length: f64,
}

/// Two unit vectors completing `n` (unit) to an orthonormal basis.
fn across(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let least = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
        Vector3::x()
    } else if n.y.abs() <= n.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let t1 = least.cross(n).normalize();
    (t1, n.cross(&t1))
}

fn skew(r: &Vector3<f64>) -> [[f64; 3]; 3] {
    [[0.0, -r.z, r.y], [r.z, 0.0, -r.x], [-r.y, r.x, 0.0]]
}

impl SpatialReference {
    pub fn new(c: &spatial::Candidate, safety: f64) -> Self {
        Self {
            p: [c.contact_1, c.contact_2],
            c: c.center_of_mass,
            n: [c.normal_1.normalize(), c.normal_2.normalize()],
            mu: [c.friction_1 / safety, c.friction_2 / safety],
            weight: c.mass * c.gravity.norm(),
            length: (c.contact_1 - c.contact_2).norm(),
        }
    }

    /// The least 2-norm of the contact forces with gravity along `dir` (any length).
    ///
    /// The six balance rows (forces and moments on the six force components) have rank 5 (a
    /// squeeze along the contact line is free). The left null vector `y` of the 6×6 balance
    /// matrix `E`, found by SVD, must annihilate the right-hand side, or no forces at all balance
    /// the weight (`Held::No`). Otherwise the row with the largest weight in `y` follows from the
    /// others and is dropped, and Clarabel solves the SOCP on the five independent rows. Its
    /// answer is then polished (see [`SpatialReference::polish`]).
    pub fn at(&self, dir: &Vector3<f64>) -> Held {
        let g = dir.normalize();
        let r = [
            (self.p[0] - self.c) / self.length,
            (self.p[1] - self.c) / self.length,
        ];
        let (s1, s2) = (skew(&r[0]), skew(&r[1]));
        // Balance: E f = e with f = (f1, f2), forces in units of the weight.
        let mut e_mat = Matrix6::<f64>::zeros();
        let mut e_rhs = Vector6::<f64>::zeros();
        for k in 0..3 {
            e_mat[(k, k)] = 1.0;
            e_mat[(k, 3 + k)] = 1.0;
            e_rhs[k] = -g[k];
            for j in 0..3 {
                e_mat[(3 + k, j)] = s1[k][j];
                e_mat[(3 + k, 3 + j)] = s2[k][j];
            }
        }
        // The left null vector y (Eᵀ y = 0), from the SVD of Eᵀ: its right singular vectors are
        // accurate to rounding (E's own left ones are not, for small singular values).
        let left = e_mat.transpose().svd(false, true);
        let y = left
            .v_t
            .expect("requested")
            .row(left.singular_values.imin())
            .transpose();
        if y.dot(&e_rhs).abs() > 1e-12 {
            return Held::No;
        }
        let drop = y.iamax();
        let keep: Vec<usize> = (0..6).filter(|&i| i != drop).collect();
        let clarabel = self.socp(&e_mat, &e_rhs, &keep);
        let mut a5 = Matrix5x6::<f64>::zeros();
        let mut e5 = Vector5::<f64>::zeros();
        for (row, &i) in keep.iter().enumerate() {
            a5.set_row(row, &e_mat.row(i));
            e5[row] = e_rhs[i];
        }
        let f = self.polish(&e_mat, &a5, &e5);
        let forces = [
            Vector3::new(f[0], f[1], f[2]) * self.weight,
            Vector3::new(f[3], f[4], f[5]) * self.weight,
        ];
        let u = (self.p[1] - self.p[0]) / self.length;
        Held::Yes {
            power: (forces[0].norm_squared() + forces[1].norm_squared()).sqrt(),
            forces,
            clarabel: clarabel.map(|p| p * self.weight),
            squeeze: 0.5 * (forces[0].dot(&u) - forces[1].dot(&u)),
        }
    }

    /// Clarabel on the SOCP of the module docs with the balance rows `keep` (forces in units of
    /// the weight): the least `t`, or `None` when Clarabel reports no certain optimum.
    fn socp(&self, e_mat: &Matrix6<f64>, e_rhs: &Vector6<f64>, keep: &[usize]) -> Option<f64> {
        // Variables x = (t, f1, f2).
        let mut rows: Vec<Vec<f64>> = Vec::with_capacity(18);
        let mut b: Vec<f64> = Vec::with_capacity(18);
        for &i in keep {
            let mut row = vec![0.0; 7];
            for j in 0..6 {
                row[1 + j] = e_mat[(i, j)];
            }
            rows.push(row);
            b.push(e_rhs[i]);
        }
        for i in 0..2 {
            let (t1, t2) = across(&self.n[i]);
            for v in [self.n[i] * self.mu[i], t1, t2] {
                let mut row = vec![0.0; 7];
                for k in 0..3 {
                    row[1 + 3 * i + k] = -v[k];
                }
                rows.push(row);
                b.push(0.0);
            }
        }
        for k in 0..7 {
            let mut row = vec![0.0; 7];
            row[k] = -1.0;
            rows.push(row);
            b.push(0.0);
        }
        let a = CscMatrix::from(&rows);
        let p = CscMatrix::<f64>::zeros((7, 7));
        let q = vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let cones: [SupportedConeT<f64>; 4] = [
            ZeroConeT(keep.len()),
            SecondOrderConeT(3),
            SecondOrderConeT(3),
            SecondOrderConeT(7),
        ];
        // Tight gap first; Clarabel's defaults when it stalls. "Almost solved" is not trusted.
        for tol in [1e-10, 1e-8] {
            let settings = DefaultSettings {
                verbose: false,
                tol_gap_abs: tol,
                tol_gap_rel: tol,
                max_iter: 400,
                ..DefaultSettings::default()
            };
            let mut solver =
                DefaultSolver::new(&p, &q, &a, &b, &cones, settings).expect("well-formed program");
            solver.solve();
            if solver.solution.status == SolverStatus::Solved {
                let x = &solver.solution.x;
                return Some((x[1..7].iter().map(|v| v * v).sum::<f64>()).sqrt());
            }
        }
        None
    }

    /// The exact optimum along the free squeeze, which polishes Clarabel's answer.
    ///
    /// Near the friction angle the slice of a cone by the plane of the forces is thin, and a
    /// feasibility tolerance of 1e-9 in Clarabel moves the power by up to 1e-3 of itself. The
    /// balanced forces are `f(α) = f_p + α v` (`f_p` least-norm, `v` the unit null vector of `E`
    /// oriented to squeeze). Each cone `||f_i − (n̂_i·f_i) n̂_i|| ≤ μ_i n̂_i·f_i` is, along the line,
    /// the quadratic `Q_i(α) = (1 + μ_i²)(n̂_i·f_i)² − ||f_i||² ≥ 0` on the side where
    /// `n̂_i·f_i ≥ 0`; the squeeze points into both cones (force closure), so cone `i` holds from
    /// the larger root of `Q_i` on. With `α_u = −f_p·v` the unconstrained least norm, the optimum
    /// is `α* = max(α_u, root_1, root_2)`.
    fn polish(&self, e_mat: &Matrix6<f64>, a5: &Matrix5x6<f64>, e5: &Vector5<f64>) -> Vector6<f64> {
        let gram = (a5 * a5.transpose())
            .try_inverse()
            .expect("five independent balance rows");
        let mut f_p = a5.transpose() * (gram * e5);
        // One step of iterative refinement.
        f_p += a5.transpose() * (gram * (e5 - a5 * f_p));
        let right = e_mat.svd(false, true);
        let mut v = right
            .v_t
            .expect("requested")
            .row(right.singular_values.imin())
            .transpose();
        if v.fixed_rows::<3>(0).dot(&self.n[0]) < 0.0 {
            v = -v;
        }
        let mut alpha = -f_p.dot(&v);
        for i in 0..2 {
            let fp = f_p.fixed_rows::<3>(3 * i).into_owned();
            let vi = v.fixed_rows::<3>(3 * i).into_owned();
            let n = self.n[i];
            let m2 = 1.0 + self.mu[i] * self.mu[i];
            // Measured from the line's closest approach to the apex, h = f_i(α0) ⟂ v_i, so that
            // a line through the apex gives a small, accurate quadratic instead of a double root.
            let a0 = -fp.dot(&vi) / vi.norm_squared();
            let h = fp + vi * a0;
            // Q(α0 + s) = (1 + μ²)(n·f)² − |f|² = qa s² + qb s + qc, with |f|² = |h|² + s²|v_i|².
            let (c0, c1) = (n.dot(&h), n.dot(&vi));
            let qa = m2 * c1 * c1 - vi.norm_squared();
            let qb = 2.0 * m2 * c0 * c1;
            let qc = m2 * c0 * c0 - h.norm_squared();
            assert!(qa > 0.0 && c1 > 0.0, "the squeeze must point into cone {i}");
            let disc = (qb * qb - 4.0 * qa * qc).max(0.0).sqrt();
            // Larger root, without cancellation.
            let root = a0
                + if qb <= 0.0 {
                    (-qb + disc) / (2.0 * qa)
                } else if disc + qb > 0.0 {
                    2.0 * qc / (-qb - disc)
                } else {
                    0.0
                };
            alpha = alpha.max(root);
        }
        f_p + v * alpha
    }

    /// Power at `dir`, `+∞` where nothing holds.
    pub fn power(&self, dir: &Vector3<f64>) -> f64 {
        self.at(dir).power().unwrap_or(f64::INFINITY)
    }

    /// What a scan minimises at `dir`: the power, or the squeeze (the polished forces take the
    /// least squeeze not below zero, as the internal-force objective does), `+∞` where nothing
    /// holds.
    pub fn objective(&self, dir: &Vector3<f64>, squeeze: bool) -> f64 {
        let held = self.at(dir);
        if squeeze {
            held.squeeze()
        } else {
            held.power()
        }
        .unwrap_or(f64::INFINITY)
    }

    /// Whether the centre of mass is on the line through the contacts (relative 1e-9).
    pub fn on_axis(&self) -> bool {
        let a = (self.p[0] - self.p[1]) / self.length;
        let r = self.c - self.p[1];
        (r - a * r.dot(&a)).norm() <= 1e-9 * self.length
    }

    /// Orthonormal `(e1, e2)` of the plane through the contacts and the centre of mass (off the
    /// axis), and the allowed arc of gravity angles `φ` (direction `cos φ e1 + sin φ e2`) as
    /// `(start, length)`.
    pub fn plane_arc(&self, range: RefRange) -> (Vector3<f64>, Vector3<f64>, f64, f64) {
        let e1 = (self.p[0] - self.p[1]).normalize();
        let r = self.c - self.p[1];
        let e2 = (r - e1 * r.dot(&e1)).normalize();
        let angle = |v: Vector3<f64>| v.dot(&e2).atan2(v.dot(&e1));
        let (a1, a2) = (angle(self.p[0] - self.c), angle(self.p[1] - self.c));
        // The sector from the centre of mass between the contacts (less than π wide).
        let width = (a2 - a1).rem_euclid(TAU);
        let (from, width) = if width <= PI {
            (a1, width)
        } else {
            (a2, TAU - width)
        };
        match range {
            // Upward in the sector: gravity at φ ∈ [from + π, from + π + width].
            RefRange::FromAbove => (e1, e2, from + PI, width),
            // Gravity outside the open sector.
            RefRange::Graspable => (e1, e2, from + width, TAU - width),
        }
    }

    /// Golden-section search of `f` on `[lo, hi]` to `tol`; returns (argmin, min).
    fn golden(f: &dyn Fn(f64) -> f64, mut lo: f64, mut hi: f64, tol: f64) -> (f64, f64) {
        let k = 0.5 * (5f64.sqrt() - 1.0);
        let mut x1 = hi - k * (hi - lo);
        let mut x2 = lo + k * (hi - lo);
        let (mut f1, mut f2) = (f(x1), f(x2));
        while hi - lo > tol {
            if f1 <= f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - k * (hi - lo);
                f1 = f(x1);
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + k * (hi - lo);
                f2 = f(x2);
            }
        }
        if f1 <= f2 {
            (x1, f1)
        } else {
            (x2, f2)
        }
    }

    /// The least power (or squeeze) over gravity directions in the plane through the contacts
    /// and the centre of mass, within `range`: `samples` directions, then golden-section search in the
    /// bracket of each of the `refine` lowest sampled minima. Returns (direction, power).
    pub fn scan_plane(
        &self,
        range: RefRange,
        squeeze: bool,
        samples: usize,
        refine: usize,
    ) -> (Vector3<f64>, f64) {
        let (e1, e2, start, len) = self.plane_arc(range);
        let dir = |phi: f64| e1 * phi.cos() + e2 * phi.sin();
        let f = |phi: f64| self.objective(&dir(phi), squeeze);
        let step = len / samples as f64;
        let values: Vec<f64> = (0..=samples).map(|k| f(start + step * k as f64)).collect();
        let mut best = (start, values[0]);
        for (k, &v) in values.iter().enumerate() {
            if v < best.1 {
                best = (start + step * k as f64, v);
            }
        }
        let mut minima: Vec<usize> = (0..=samples)
            .filter(|&k| {
                (k == 0 || values[k] <= values[k - 1])
                    && (k == samples || values[k] <= values[k + 1])
            })
            .collect();
        minima.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
        for &k in minima.iter().take(refine) {
            let lo = start + step * (k.max(1) - 1) as f64;
            let hi = start + step * (k + 1).min(samples) as f64;
            let (phi, v) = Self::golden(&f, lo, hi, 1e-9 * len.max(1.0));
            if v < best.1 {
                best = (phi, v);
            }
        }
        (dir(best.0), best.1)
    }

    /// The least power (or squeeze) over the whole sphere of gravity directions (for a centre of mass on the
    /// axis): a latitude × longitude grid about the contact axis, then alternating golden-section
    /// searches in latitude and longitude from the `refine` lowest grid points.
    pub fn scan_sphere(
        &self,
        squeeze: bool,
        lat: usize,
        lon: usize,
        refine: usize,
    ) -> (Vector3<f64>, f64) {
        let a = (self.p[0] - self.p[1]).normalize();
        let (b1, b2) = across(&a);
        let dir = |la: f64, lo: f64| a * la.sin() + (b1 * lo.cos() + b2 * lo.sin()) * la.cos();
        let f = |la: f64, lo: f64| self.objective(&dir(la, lo), squeeze);
        let mut grid: Vec<(f64, f64, f64)> = Vec::with_capacity((lat + 1) * lon);
        for i in 0..=lat {
            let la = -FRAC_PI_2 + PI * i as f64 / lat as f64;
            for j in 0..lon {
                let lo = TAU * j as f64 / lon as f64;
                grid.push((la, lo, f(la, lo)));
            }
        }
        grid.sort_by(|x, y| x.2.total_cmp(&y.2));
        let mut best = grid[0];
        let (dla, dlo) = (PI / lat as f64, TAU / lon as f64);
        for &(mut la, mut lo, mut v) in grid.iter().take(refine) {
            let (mut wla, mut wlo) = (dla, dlo);
            // To 1e-7 rad: the power is flat to ~1e-14 of itself there.
            for _ in 0..4 {
                let (l, vl) = Self::golden(
                    &|x| f(x, lo),
                    (la - wla).max(-FRAC_PI_2),
                    (la + wla).min(FRAC_PI_2),
                    1e-7,
                );
                if vl <= v {
                    (la, v) = (l, vl);
                }
                let (m, vm) = Self::golden(&|x| f(la, x), lo - wlo, lo + wlo, 1e-7);
                if vm <= v {
                    (lo, v) = (m, vm);
                }
                wla *= 0.25;
                wlo *= 0.25;
            }
            if v < best.2 {
                best = (la, lo, v);
            }
        }
        (dir(best.0, best.1), best.2)
    }
}

/// The kinds of random spatial grasp the tests draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Centre of mass well off the axis, normals in the grasp plane.
    InPlane,
    /// Centre of mass well off the axis, normals tilted out of the plane (up to 0.95 ξ).
    Tilted,
    /// Tilts within 1e-3..1e-7 of the friction angle.
    NearLimitTilt,
    /// Centre of mass 1e-7..1e-2.5 of the contact distance off the axis.
    NearAxis,
    /// Centre of mass on the axis, normals tilted off the axis anyhow.
    OnAxis,
    /// On the axis with both normals along it (a ball or a can gripped through its centre).
    OnAxisSymmetric,
    /// On the axis with both normals' tilts in one plane through the axis.
    OnAxisCoplanar,
}

fn unit_random(rng: &mut impl Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

fn rot2(v: (f64, f64), a: f64) -> (f64, f64) {
    let (s, c) = a.sin_cos();
    (c * v.0 - s * v.1, s * v.0 + c * v.1)
}

/// A grasp in a local frame where the grasp plane (off the axis) is z = 0.
struct Local {
    p: [Vector3<f64>; 2],
    com: Vector3<f64>,
    n: [Vector3<f64>; 2],
}

fn on_axis(kind: Kind) -> bool {
    matches!(
        kind,
        Kind::OnAxis | Kind::OnAxisSymmetric | Kind::OnAxisCoplanar
    )
}

/// Contacts on the x axis either side of the centre of mass at the origin, each normal within
/// 0.95 of its friction angle of the axis (along it for `OnAxisSymmetric`, tilted in one plane
/// for `OnAxisCoplanar`).
fn on_axis_local(rng: &mut impl Rng, kind: Kind, mu: [f64; 2]) -> Local {
    let x1 = rng.gen_range(0.1..1.0);
    let x2 = rng.gen_range(0.1..1.0);
    let shared = rng.gen_range(-PI..PI);
    let mut normal = |toward: f64, xi: f64| {
        let delta = match kind {
            Kind::OnAxisSymmetric => 0.0,
            _ => rng.gen_range(0.0..0.95) * xi,
        };
        let eta = match kind {
            Kind::OnAxisCoplanar => shared + if rng.gen_bool(0.5) { 0.0 } else { PI },
            _ => rng.gen_range(-PI..PI),
        };
        Vector3::new(
            toward * delta.cos(),
            delta.sin() * eta.cos(),
            delta.sin() * eta.sin(),
        )
    };
    let n1 = normal(-1.0, mu[0].atan());
    let n2 = normal(1.0, mu[1].atan());
    Local {
        p: [Vector3::new(x1, 0.0, 0.0), Vector3::new(-x2, 0.0, 0.0)],
        com: Vector3::zeros(),
        n: [n1, n2],
    }
}

/// Contacts in the plane z = 0, normals tilted out of it by β (none for `InPlane`, within 1e-3 to
/// 1e-7 of the friction angle for `NearLimitTilt`, else up to 0.95 of it) and pointing within
/// 0.95 of the sliced half-angle ξ' (`cos ξ' = cos ξ / cos β`) of the other contact; the centre of
/// mass in the plane on the inner side of both normals, near the axis for `NearAxis`. `None`
/// when the draw does not make such a grasp.
fn off_axis_local(
    rng: &mut impl Rng,
    kind: Kind,
    mu: [f64; 2],
    behind: [bool; 2],
) -> Option<Local> {
    let q1: (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
    let q2: (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
    let dist = (q1.0 - q2.0).hypot(q1.1 - q2.1);
    if dist < 0.05 {
        return None;
    }
    let along = ((q2.0 - q1.0) / dist, (q2.1 - q1.1) / dist);
    let mut tilted = |mu: f64| {
        let xi = mu.atan();
        let beta = match kind {
            Kind::InPlane => 0.0,
            Kind::NearLimitTilt => xi * (1.0 - 10f64.powf(-rng.gen_range(3.0..7.0))),
            _ => rng.gen_range(0.0..0.95) * xi,
        } * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let xi_s = (xi.cos() / beta.cos()).min(1.0).acos();
        (beta, xi_s)
    };
    let (b1, xs1) = tilted(mu[0]);
    let (b2, xs2) = tilted(mu[1]);
    let u1 = rot2(along, rng.gen_range(-0.95..0.95) * xs1);
    let u2 = rot2((-along.0, -along.1), rng.gen_range(-0.95..0.95) * xs2);
    let n1 = Vector3::new(u1.0 * b1.cos(), u1.1 * b1.cos(), b1.sin());
    let n2 = Vector3::new(u2.0 * b2.cos(), u2.1 * b2.cos(), b2.sin());
    let p1 = Vector3::new(q1.0, q1.1, 0.0);
    let p2 = Vector3::new(q2.0, q2.1, 0.0);
    // A centre of mass behind a tangent plane is rare among the draws (behind both, a narrow
    // wedge beyond the contacts): up to 64 centres of mass are drawn for each pair of contacts
    // there, which takes about ten times fewer draws of the whole grasp (360 such grasps: 22 s
    // instead of 252 s on a loaded machine). Elsewhere one is drawn, as it always was, so the
    // other tests' grasps stay as they were.
    //
    // Behind a tangent, most pairs of contacts admit no such point in the square the centre of
    // mass is drawn from: the square is first cut by the two half-planes (`region_behind`), a
    // pair whose cut is empty is refused without a draw, and the centres of mass are drawn in
    // the cut's bounding box. A point is still uniform over the same region. Sixty-four draws in
    // the whole square would find a point with probability 1 − (1 − a)^64, `a` the cut's share of
    // the square, so a pair is kept with that probability: pairs whose cut is a sliver (contacts
    // almost touching, normals almost opposed) stay as rare as they were. The three tests on
    // these grasps went from 18 to 19 s each to about 4 s.
    let (tries, square) = if behind.contains(&true) {
        let mid = ((p1.x + p2.x) / 2.0, (p1.y + p2.y) / 2.0);
        let (square, area) = region_behind(mid, 2.0, [p1, p2], [n1, n2], behind, 1e-3 * dist)?;
        let share = (area / 16.0).min(1.0);
        if !rng.gen_bool(1.0 - (1.0 - share).powi(64)) {
            return None;
        }
        (256, Some(square))
    } else {
        (1, None)
    };
    let com = (0..tries).find_map(|_| {
        centre_of_mass(rng, kind, [p1, p2], [n1, n2], (dist, along), behind, square)
    })?;
    Some(Local {
        p: [p1, p2],
        com,
        n: [n1, n2],
    })
}

/// A centre of mass for the contacts `p` with normals `n`, `dist` apart along `along`
/// (`off_axis_local`): in the plane, on the inner side of both normals or behind the tangent
/// planes where `behind` says, near the axis for `NearAxis`; `None` when this draw is not such a
/// point.
fn centre_of_mass(
    rng: &mut impl Rng,
    kind: Kind,
    [p1, p2]: [Vector3<f64>; 2],
    [n1, n2]: [Vector3<f64>; 2],
    (dist, along): (f64, (f64, f64)),
    behind: [bool; 2],
    square: Option<[(f64, f64); 2]>,
) -> Option<Vector3<f64>> {
    let com = if kind == Kind::NearAxis {
        let t = rng.gen_range(0.2..0.8);
        let offset = dist * 10f64.powf(-rng.gen_range(2.5..7.0));
        let side = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        p1 + (p2 - p1) * t + Vector3::new(-along.1, along.0, 0.0) * (offset * side)
    } else if let Some([(x0, x1), (y0, y1)]) = square {
        Vector3::new(rng.gen_range(x0..=x1), rng.gen_range(y0..=y1), 0.0)
    } else {
        let mid = (p1 + p2) / 2.0;
        let reach = if behind.contains(&true) { 2.0 } else { 1.0 };
        mid + Vector3::new(
            rng.gen_range(-reach..reach),
            rng.gen_range(-reach..reach),
            0.0,
        )
    };
    let r = com - p1;
    let a = (p2 - p1) / dist;
    let offset = (r - a * r.dot(&a)).norm() / dist;
    if kind != Kind::NearAxis && offset < 0.02 {
        return None;
    }
    // Inside both half-spaces (with a margin, except near the axis where it cannot be had).
    let margin = if kind == Kind::NearAxis {
        0.0
    } else {
        1e-3 * dist
    };
    // Behind the tangent plane where asked (by as much): an object that is not convex there.
    let side_ok = |depth: f64, behind: bool| {
        if behind {
            depth < -margin.max(1e-3 * dist)
        } else {
            depth > margin
        }
    };
    if !side_ok(n1.dot(&(com - p1)), behind[0]) || !side_ok(n2.dot(&(com - p2)), behind[1]) {
        return None;
    }
    Some(com)
}

/// The bounding box `[(x_lo, x_hi), (y_lo, y_hi)]` of the part of the square of half-side `reach`
/// about `mid` (in the plane z = 0) that is behind the tangent plane at contact `i` by more than
/// `depth` where `behind[i]`, and on the inner side of its normal elsewhere, with that part's
/// area; `None` when it is empty (`centre_of_mass` would refuse every point of the square). The
/// square is cut as a polygon by each half-plane in turn (Sutherland–Hodgman).
fn region_behind(
    mid: (f64, f64),
    reach: f64,
    p: [Vector3<f64>; 2],
    n: [Vector3<f64>; 2],
    behind: [bool; 2],
    depth: f64,
) -> Option<([(f64, f64); 2], f64)> {
    let (cx, cy) = mid;
    let mut poly = vec![
        (cx - reach, cy - reach),
        (cx + reach, cy - reach),
        (cx + reach, cy + reach),
        (cx - reach, cy + reach),
    ];
    for i in 0..2 {
        // Kept: s · (n · (x − p)) ≥ 0 with s = −1 behind and +1 in front (the margins of
        // `centre_of_mass` are left to it: the box only has to hold every point it keeps).
        let s = if behind[i] { -1.0 } else { 1.0 };
        let side = |(x, y): (f64, f64)| {
            s * (n[i].x * (x - p[i].x) + n[i].y * (y - p[i].y))
                + if behind[i] { -depth } else { 0.0 }
        };
        let mut cut = Vec::with_capacity(poly.len() + 1);
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let (fa, fb) = (side(a), side(b));
            if fa >= 0.0 {
                cut.push(a);
            }
            if (fa >= 0.0) != (fb >= 0.0) {
                let t = fa / (fa - fb);
                cut.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
            }
        }
        poly = cut;
        if poly.is_empty() {
            return None;
        }
    }
    // The cut's area (shoelace), for the caller to keep the pair as often as drawing in the
    // whole square would have.
    let area = (0..poly.len())
        .map(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
        / 2.0;
    let fold = |f: fn(&(f64, f64)) -> f64| {
        poly.iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    Some(([fold(|q| q.0), fold(|q| q.1)], area))
}

/// A random spatial grasp with force closure of the given kind, in a random 3D frame, with
/// random units and normal lengths. Gravity is random in 3D, and in the grasp plane for about a
/// fifth of the off-axis grasps (so that the current pose can be held).
pub fn random_spatial_grasp(rng: &mut impl Rng, kind: Kind) -> spatial::Candidate {
    random_spatial_grasp_behind(rng, kind, [false, false])
}

/// [`random_spatial_grasp`] (off the axis) with the centre of mass behind the tangent plane at
/// contact `i` (by at least 1e-3 of the contact distance) where `behind[i]`.
pub fn random_spatial_grasp_behind(
    rng: &mut impl Rng,
    kind: Kind,
    behind: [bool; 2],
) -> spatial::Candidate {
    let (local, mu) = loop {
        let mu = [rng.gen_range(0.1..2.0), rng.gen_range(0.1..2.0)];
        if on_axis(kind) {
            break (on_axis_local(rng, kind, mu), mu);
        }
        if let Some(local) = off_axis_local(rng, kind, mu, behind) {
            break (local, mu);
        }
    };
    // A random rigid motion and unit scale of the whole scene.
    let axis = Unit::new_normalize(unit_random(rng));
    let rot = Rotation3::from_axis_angle(&axis, rng.gen_range(0.0..PI));
    let shift = Vector3::new(
        rng.gen_range(-2.0..2.0),
        rng.gen_range(-2.0..2.0),
        rng.gen_range(-2.0..2.0),
    );
    let scale = 10f64.powf(rng.gen_range(-2.0..1.0));
    let place = |p: Vector3<f64>| rot * p * scale + shift;
    let g_local = if !on_axis(kind) && rng.gen_bool(0.2) {
        let phi = rng.gen_range(-PI..PI);
        Vector3::new(phi.cos(), phi.sin(), 0.0)
    } else {
        unit_random(rng)
    };
    spatial::Candidate {
        contact_1: place(local.p[0]),
        contact_2: place(local.p[1]),
        normal_1: rot * local.n[0] * rng.gen_range(0.1..10.0),
        normal_2: rot * local.n[1] * rng.gen_range(0.1..10.0),
        friction_1: mu[0],
        friction_2: mu[1],
        center_of_mass: place(local.com),
        mass: 10f64.powf(rng.gen_range(-2.0..2.0)),
        gravity: rot * g_local * (9.81 * rng.gen_range(0.5..1.5)),
    }
}
