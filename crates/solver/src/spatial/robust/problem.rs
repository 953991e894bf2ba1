//! Everything the solve needs, in axis coordinates (module docs §1–§4): the region's edges and
//! axis points seen from the contact axis, each object's planar frame in its own plane, and the
//! certified worst case at one tilt, each maximisation made once.

use super::region::{Region, RegionPoint, RegionPointKind};
use super::uncertainty::Uncertainty;
use super::worst::{self, AxisPoint, AxisView, Quantity, Segment};
use crate::planar::analysis::Analysis;
use crate::planar::frame::GraspFrame;
use crate::spatial::on_axis::AxisGrasp;
use crate::spatial::plane::Geometry;
use crate::{Contact, Objective, Settings};
use nalgebra::{Vector2, Vector3};
use std::cell::{Cell, RefCell};

/// Everything the solve needs, in axis coordinates.
pub(super) struct Problem {
    pub(super) objective: Objective,
    quantity: Quantity,
    pub(super) view: AxisView,
    pub(super) region: Region,
    pub(super) segments: Vec<Segment>,
    /// The region's points on the axis (the ends of that segment).
    pub(super) axis_points: Vec<AxisPoint>,
    /// The nominal centre of mass.
    pub(super) center: AxisPoint,
    /// Whether the region is that point alone (only the mass is uncertain).
    pub(super) point_region: bool,
    /// The direction across the axis of the nominal object's plane (from the axis to `c`).
    pub(super) reference: Vector2<f64>,
    /// Unit inward normals, friction after the safety factor, the safety factor.
    mu: [f64; 2],
    safety: f64,
    /// Current gravity angle after the swing.
    pub(super) current: f64,
    /// Unit current gravity, candidate frame.
    pub(super) g0: Vector3<f64>,
    /// `m_max |g|` and `m |g|`, N.
    pub(super) weight: f64,
    pub(super) nominal_weight: f64,
    pub(super) mass_worst: f64,
    /// The splits of every maximisation so far (module docs §4).
    pub(super) splits: Cell<usize>,
    /// The maximisations made so far, by quantity and tilt (the bits of θ): the last exchange
    /// round's tilt is the answer's, and usually one of the local minima's too, and a
    /// maximisation depends on nothing else, so each is made once.
    done: RefCell<Vec<(bool, u64, worst::Worst)>>,
}

impl Problem {
    pub(super) fn new(
        candidate: &crate::spatial::Candidate,
        uncertainty: &Uncertainty,
        settings: &Settings,
        g: &Geometry,
        axis: &AxisGrasp,
        nominal: &crate::spatial::Recommendation,
    ) -> Self {
        let contacts = axis.contacts;
        let across = contacts.map(|c| Vector2::new(c.azimuth.cos(), c.azimuth.sin()) * c.sin_delta);
        let view = AxisView {
            p2: g.p[1],
            a: axis.a,
            b1: axis.b1,
            b2: axis.b2,
            d: g.d,
            contacts,
            across,
        };
        let region = Region::new(
            g.c,
            uncertainty.center_of_mass_tolerance,
            [
                (Contact::First, g.p[0], g.n[0]),
                (Contact::Second, g.p[1], g.n[1]),
            ],
            g.d,
        );
        let segments = region
            .segments
            .iter()
            .map(|(s, e)| Segment {
                start: view.coordinates(s),
                end: view.coordinates(e),
            })
            .collect();
        let axis_points = match region.clip(&g.p[1], &g.a, f64::NEG_INFINITY) {
            Some((t0, t1)) => [t0, t1]
                .iter()
                .map(|t| AxisPoint {
                    xi: t / g.d,
                    across: Vector2::zeros(),
                })
                .collect(),
            None => Vec::new(),
        };
        let c0 = view.coordinates(&g.c).across;
        let reference = if c0.norm() > 0.0 {
            c0 / c0.norm()
        } else {
            // On the axis: the nominal answer's plane, `v` along its gravity's part across.
            let y = nominal.plane_y;
            let v = -Vector2::new(y.dot(&axis.b1), y.dot(&axis.b2));
            if v.norm() > 0.0 {
                v / v.norm()
            } else {
                Vector2::x()
            }
        };
        let mass_worst = candidate.mass + uncertainty.mass_tolerance;
        // Scale-free: a gravity whose square underflows still has its length.
        let g_norm = crate::spatial::plane::length(&candidate.gravity);
        Self {
            center: view.coordinates(&g.c),
            point_region: uncertainty.center_of_mass_tolerance == Vector3::zeros(),
            objective: settings.objective,
            quantity: match settings.objective {
                Objective::InternalForce => Quantity::Squeeze,
                _ => Quantity::Norm2,
            },
            view,
            region,
            segments,
            axis_points,
            reference,
            mu: g.mu,
            safety: g.safety,
            current: g.g0.dot(&g.a).clamp(-1.0, 1.0).asin(),
            g0: g.g0,
            weight: mass_worst * g_norm,
            nominal_weight: candidate.mass * g_norm,
            mass_worst,
            splits: Cell::new(0),
            done: RefCell::new(Vec::new()),
        }
    }
}

impl Problem {
    /// The planar frame of the object at `p` in its own plane, in the shared convention of
    /// module docs §1–§2 (unit weight). On the axis, `across` picks the plane (`None`: the worst
    /// plane for each contact, which on the axis is `q_i = sin δ_i` for every tilt, `B_i <= 0`).
    pub(super) fn frame_at(&self, p: &AxisPoint, across: Option<Vector2<f64>>) -> GraspFrame {
        let rho = p.across.norm();
        let v = if rho > 0.0 {
            Some(p.across / rho)
        } else {
            across
        };
        let contacts = self.view.contacts;
        let q: [f64; 2] = std::array::from_fn(|i| match v {
            Some(v) => self.view.across[i].dot(&v),
            None => contacts[i].sin_delta,
        });
        let plane: [(f64, f64, f64); 2] = std::array::from_fn(|i| {
            let (p, sd) = (contacts[i].cos_delta, contacts[i].sin_delta);
            let len = p.hypot(q[i]);
            let tilt = (sd * sd - q[i] * q[i]).max(0.0).sqrt() / len;
            let mu = crate::spatial::sliced_friction(self.mu[i], tilt).unwrap_or(0.0);
            (p / len, q[i] / len, mu)
        });
        GraspFrame {
            x1: 1.0 - p.xi,
            x2: p.xi,
            y: rho,
            s1: plane[0].0,
            c1: plane[0].1,
            s2: plane[1].0,
            c2: plane[1].1,
            mu1: plane[0].2,
            mu2: plane[1].2,
            friction_safety_factor: self.safety,
            current_theta: self.current,
            weight: 1.0,
            contact_distance: self.view.d,
            swapped: false,
            e_x: Vector2::x(),
            e_y: Vector2::y(),
        }
    }

    /// The curve of the object at `p` over the gravity angles (module docs §5), if its frame
    /// has force closure (it has whenever the grasp has, §2).
    pub(super) fn analysis(&self, p: &AxisPoint) -> Option<Analysis> {
        let plane = self.point_region.then_some(self.reference);
        Analysis::new(&self.frame_at(p, plane), self.objective).ok()
    }

    /// The worst objective (or squeeze) at `theta` over the region, units of the weight (module
    /// docs §4); for a region of one point, that object's own value.
    pub(super) fn worst(&self, squeeze: bool, theta: f64) -> worst::Worst {
        if self.point_region {
            let value = self.analysis(&self.center).map_or(f64::NAN, |a| {
                let v = a.evaluate(theta);
                if squeeze {
                    v.internal_force
                } else {
                    v.power
                }
            });
            return worst::Worst {
                value,
                segment: None,
                t: 0.0,
                point: self.center,
                bound: value,
                splits: 0,
            };
        }
        let q = if squeeze {
            Quantity::Squeeze
        } else {
            self.quantity
        };
        let key = (squeeze, theta.to_bits());
        if let Some(&(_, _, w)) = self.done.borrow().iter().find(|d| (d.0, d.1) == key) {
            return w;
        }
        let worst = self.view.worst(q, theta, &self.segments, &self.axis_points);
        self.splits.set(self.splits.get() + worst.splits);
        self.done.borrow_mut().push((key.0, key.1, worst));
        worst
    }

    /// A point of the maximisation named as a point of the region.
    pub(super) fn region_point(&self, p: &AxisPoint) -> RegionPoint {
        let position = self.view.position(p);
        if p.across == Vector2::zeros() {
            return RegionPoint {
                position,
                kind: RegionPointKind::Axis,
            };
        }
        let eps = 1e-9 * self.view.d;
        match self
            .region
            .vertices
            .iter()
            .find(|v| (v.position - position).norm() <= eps)
        {
            Some(v) => *v,
            None => RegionPoint {
                position,
                kind: RegionPointKind::Edge,
            },
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// A deterministic sequence in [0, 1) (no rand in the library).
    pub(in crate::spatial::robust) fn uniform(k: u64) -> f64 {
        let x = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Contacts on the x axis at ±0.5, normals tilted off the axis within 0.9 of the friction
    /// angle, the centre of mass off the axis inside the object.
    pub(in crate::spatial::robust) fn grasp(k: u64) -> crate::spatial::Candidate {
        let r = |j: u64| uniform(97 * k + j);
        let mu = [0.3 + 1.2 * r(0), 0.3 + 1.2 * r(1)];
        let normal = |toward: f64, mu: f64, a: f64, b: f64| {
            let delta = 0.9 * mu.atan() * a;
            let eta = 2.0 * PI * b;
            Vector3::new(
                toward * delta.cos(),
                delta.sin() * eta.cos(),
                delta.sin() * eta.sin(),
            )
        };
        crate::spatial::Candidate {
            contact_1: Vector3::new(0.5, 0.0, 0.0),
            contact_2: Vector3::new(-0.5, 0.0, 0.0),
            normal_1: normal(-1.0, mu[0], r(2), r(3)),
            normal_2: normal(1.0, mu[1], r(4), r(5)),
            friction_1: mu[0],
            friction_2: mu[1],
            center_of_mass: Vector3::new(0.2 * (r(6) - 0.5), r(7) - 0.5, r(8) - 0.5),
            mass: 1.0,
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }

    fn problem(
        c: &crate::spatial::Candidate,
        t: Vector3<f64>,
        settings: &Settings,
    ) -> Option<Problem> {
        let g = Geometry::new(c, settings.friction_safety_factor).ok()?;
        let axis = AxisGrasp::new(&g).ok()?;
        let nominal = match crate::spatial::solve(c, settings).ok()? {
            crate::spatial::Verdict::Recommended(r) => *r,
            crate::spatial::Verdict::NoForceClosure(_) => return None,
        };
        let u = Uncertainty {
            center_of_mass_tolerance: t,
            mass_tolerance: 0.0,
        };
        Some(Problem::new(c, &u, settings, &g, &axis, &nominal))
    }

    /// Module docs §2: the closed form is the planar problem of each object's own plane with the
    /// sliced cones, at every tilt, for the 2-norm and the squeeze.
    #[test]
    fn closed_form_is_the_planar_problem_of_each_plane() {
        let settings = Settings::default();
        let mut checked = 0;
        for k in 0..200 {
            let c = grasp(k);
            let Some(p) = problem(&c, Vector3::new(0.1, 0.1, 0.1), &settings) else {
                continue;
            };
            for j in 0..20 {
                let q = AxisPoint {
                    xi: 0.5 + 0.6 * (uniform(1000 * k + j) - 0.5),
                    across: Vector2::new(uniform(2000 * k + j) - 0.5, uniform(3000 * k + j) - 0.5)
                        * if j == 0 { 0.0 } else { 1.0 },
                };
                let frame = p.frame_at(&q, None);
                let norm2 = Analysis::new(&frame, Objective::Norm2).expect("force closure");
                for i in 0..=12 {
                    let theta = -FRAC_PI_2 + PI * f64::from(i) / 12.0;
                    let held = p.view.held(worst::Tilt::new(theta), &q);
                    let v = norm2.evaluate(theta);
                    assert!(
                        (held.norm2 - v.power).abs() <= 1e-12 * v.power.max(1.0),
                        "grasp {k} point {j} θ {theta}: closed form {} planar {}",
                        held.norm2,
                        v.power
                    );
                    assert!((held.squeeze - v.internal_force).abs() <= 1e-12);
                }
                checked += 1;
            }
        }
        assert!(checked > 2000, "{checked}");
    }

    /// Module docs §4: the certified maximum is attained, is at least every sample of every
    /// segment, and its bound is within `worst::tolerance` of it.
    #[test]
    fn worst_is_at_least_every_sample_of_the_edges() {
        let settings = Settings::default();
        let mut inside = 0;
        for k in 0..60 {
            let c = grasp(k);
            let t = Vector3::new(0.05, 0.1 + 0.2 * uniform(k), 0.15);
            let Some(p) = problem(&c, t, &settings) else {
                continue;
            };
            for i in 0..=6 {
                let theta = -1.2 + 0.4 * f64::from(i);
                let tilt = worst::Tilt::new(theta);
                for q in [Quantity::Norm2, Quantity::Squeeze] {
                    let w = p.view.worst(q, theta, &p.segments, &p.axis_points);
                    assert!(
                        w.bound <= w.value + 2.0 * worst::tolerance(w.value),
                        "grasp {k} θ {theta} {q:?}: {} bound {}",
                        w.value,
                        w.bound
                    );
                    assert_eq!(p.view.held(tilt, &w.point).get(q), w.value);
                    let mut corners = f64::NEG_INFINITY;
                    for s in &p.segments {
                        for j in 0..=400 {
                            let u = f64::from(j) / 400.0;
                            let x = AxisPoint {
                                xi: s.start.xi + u * (s.end.xi - s.start.xi),
                                across: s.start.across + (s.end.across - s.start.across) * u,
                            };
                            let v = p.view.held(tilt, &x).get(q);
                            assert!(v <= w.value * (1.0 + 1e-12) + 1e-15, "{v} > {}", w.value);
                            if j == 0 || j == 400 {
                                corners = corners.max(v);
                            }
                        }
                    }
                    if w.value > corners * (1.0 + 1e-9) {
                        inside += 1;
                    }
                }
            }
        }
        assert!(inside > 0, "some worst case lies inside an edge");
    }
}
