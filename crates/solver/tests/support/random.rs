//! Random grasps for the batch tests and benchmark, from a small generator of their own
//! (SplitMix64), so that the solver crate needs no random-number crate.
//!
//! [`planar_grasp`] and [`spatial_grasp`] give grasps with force closure in a random frame, unit
//! scale and labelling (as `tests/it/util`'s generators of the root crate do); [`planar_mix`] and
//! [`spatial_mix`] mix in grasps without force closure and refused input.

use grasp_orient_solver::{planar, spatial};
use nalgebra::{Rotation3, Unit, Vector2, Vector3};
use std::f64::consts::PI;

/// SplitMix64 (Steele, Lea and Flood): 64 random bits a step from a counter.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// The generator started at `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

fn rot(v: Vector2<f64>, a: f64) -> Vector2<f64> {
    let (s, c) = a.sin_cos();
    Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

fn cross(a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Whether the friction cone at `p` (inward normal `n`, coefficient `mu`) contains `q`.
fn cone_contains(p: Vector2<f64>, n: Vector2<f64>, mu: f64, q: Vector2<f64>) -> bool {
    let d = q - p;
    let n = n.normalize();
    let along = n.dot(&d);
    along > 0.0 && cross(n, d).abs() < mu * along
}

/// The grasp in its own local frame before the random placement: contacts, unit inward
/// normals, friction and centre of mass.
struct Local {
    p: [Vector2<f64>; 2],
    n: [Vector2<f64>; 2],
    mu: [f64; 2],
    com: Vector2<f64>,
}

/// A grasp with force closure in a local frame; the centre of mass on the inner side of both
/// tangents, or behind one of them for about a tenth.
fn local_grasp(rng: &mut Rng) -> Local {
    loop {
        let p1 = Vector2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let p2 = Vector2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        if (p1 - p2).norm() < 0.05 {
            continue;
        }
        let along = (p2 - p1).normalize();
        let n1 = rot(along, rng.range(-1.4, 1.4));
        let n2 = rot(-along, rng.range(-1.4, 1.4));
        let mu = [rng.range(0.1, 2.0), rng.range(0.1, 2.0)];
        if !cone_contains(p1, n1, mu[0], p2) || !cone_contains(p2, n2, mu[1], p1) {
            continue;
        }
        let behind = rng.chance(0.1);
        let reach = if behind { 2.0 } else { 1.0 };
        let com =
            (p1 + p2) / 2.0 + Vector2::new(rng.range(-reach, reach), rng.range(-reach, reach));
        let depth = [n1.dot(&(com - p1)), n2.dot(&(com - p2))];
        if !behind && (depth[0] <= 1e-3 || depth[1] <= 1e-3) {
            continue;
        }
        return Local {
            p: [p1, p2],
            n: [n1, n2],
            mu,
            com,
        };
    }
}

/// A random planar grasp with force closure, in a random frame and unit scale.
pub fn planar_grasp(rng: &mut Rng) -> planar::Candidate {
    let l = local_grasp(rng);
    let angle = rng.range(-PI, PI);
    let shift = Vector2::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
    let scale = 10f64.powf(rng.range(-2.0, 1.0));
    let place = |p: Vector2<f64>| rot(p, angle) * scale + shift;
    let g = 9.81 * rng.range(0.5, 1.5);
    planar::Candidate {
        contact_1: place(l.p[0]),
        contact_2: place(l.p[1]),
        normal_1: rot(l.n[0], angle) * rng.range(0.1, 10.0),
        normal_2: rot(l.n[1], angle) * rng.range(0.1, 10.0),
        friction_1: l.mu[0],
        friction_2: l.mu[1],
        center_of_mass: place(l.com),
        mass: 10f64.powf(rng.range(-2.0, 2.0)),
        gravity: rot(Vector2::new(0.0, -g), rng.range(-PI, PI)),
    }
}

/// A planar grasp that the solver refuses: one field broken (the cause is random).
fn planar_broken(rng: &mut Rng, mut c: planar::Candidate) -> planar::Candidate {
    match rng.below(8) {
        0 => c.mass = f64::NAN,
        1 => c.mass = -1.0,
        2 => c.normal_1 = Vector2::zeros(),
        3 => c.normal_2 = -c.normal_2,
        4 => c.contact_2 = c.contact_1,
        5 => c.friction_1 = 0.0,
        6 => c.gravity = Vector2::zeros(),
        _ => c.center_of_mass.x = f64::INFINITY,
    }
    c
}

/// Mostly grasps with force closure; about a tenth with friction too low to hold
/// (no force closure), a tenth refused, and some with exact, symmetric coordinates (ties).
pub fn planar_mix(rng: &mut Rng) -> planar::Candidate {
    let c = planar_grasp(rng);
    match rng.below(10) {
        0 => planar::Candidate {
            friction_1: c.friction_1 * 1e-3,
            friction_2: c.friction_2 * 1e-3,
            ..c
        },
        1 => planar_broken(rng, c),
        2 => {
            // One of the paper's cases, turned and scaled: ties, plateaus and exact symmetry.
            let case = ['a', 'b', 'c', 'd'][rng.below(4) as usize];
            let t = grasp_orient_solver::table_1::table_1(case);
            let angle = rng.range(-PI, PI);
            planar::Candidate {
                gravity: rot(t.gravity, angle) * 9.81,
                ..t
            }
        }
        _ => c,
    }
}

fn unit_random(rng: &mut Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// A random spatial grasp with force closure: a planar one, its normals tilted out of its plane
/// by less than their friction angle, placed by a random rotation, shift and unit scale; gravity
/// random in 3D, or in the grasp plane for about a fifth (so that the current pose is held). A
/// twentieth have the centre of mass on the contact axis.
pub fn spatial_grasp(rng: &mut Rng) -> spatial::Candidate {
    let l = local_grasp(rng);
    let lift = |v: Vector2<f64>| Vector3::new(v.x, v.y, 0.0);
    let tilt = |rng: &mut Rng, n: Vector2<f64>, mu: f64| {
        let t = rng.range(-0.5, 0.5) * mu.atan();
        lift(n) * t.cos() + Vector3::z() * t.sin()
    };
    let n = [tilt(rng, l.n[0], l.mu[0]), tilt(rng, l.n[1], l.mu[1])];
    let com = if rng.chance(0.05) {
        let s = rng.range(0.2, 0.8);
        lift(l.p[0] * s + l.p[1] * (1.0 - s))
    } else {
        lift(l.com)
    };
    let axis = Unit::new_normalize(unit_random(rng));
    let rotation = Rotation3::from_axis_angle(&axis, rng.range(0.0, PI));
    let shift = Vector3::new(
        rng.range(-2.0, 2.0),
        rng.range(-2.0, 2.0),
        rng.range(-2.0, 2.0),
    );
    let scale = 10f64.powf(rng.range(-2.0, 1.0));
    let place = |p: Vector3<f64>| rotation * p * scale + shift;
    let g_local = if rng.chance(0.2) {
        let phi = rng.range(-PI, PI);
        Vector3::new(phi.cos(), phi.sin(), 0.0)
    } else {
        unit_random(rng)
    };
    spatial::Candidate {
        contact_1: place(lift(l.p[0])),
        contact_2: place(lift(l.p[1])),
        normal_1: rotation * n[0] * rng.range(0.1, 10.0),
        normal_2: rotation * n[1] * rng.range(0.1, 10.0),
        friction_1: l.mu[0],
        friction_2: l.mu[1],
        center_of_mass: place(com),
        mass: 10f64.powf(rng.range(-2.0, 2.0)),
        gravity: rotation * g_local * (9.81 * rng.range(0.5, 1.5)),
    }
}

/// Mostly spatial grasps with force closure; about a tenth with friction too low, a tenth
/// refused, and a tenth lying in the x-y plane (the planar model read in 3D).
pub fn spatial_mix(rng: &mut Rng) -> spatial::Candidate {
    let c = spatial_grasp(rng);
    match rng.below(10) {
        0 => spatial::Candidate {
            friction_1: c.friction_1 * 1e-3,
            friction_2: c.friction_2 * 1e-3,
            ..c
        },
        1 => {
            let mut c = c;
            match rng.below(6) {
                0 => c.mass = f64::NAN,
                1 => c.normal_1 = Vector3::zeros(),
                2 => c.normal_2 = -c.normal_2,
                3 => c.contact_2 = c.contact_1,
                4 => c.gravity = Vector3::zeros(),
                _ => c.center_of_mass = c.contact_1,
            }
            c
        }
        2 => {
            let p = planar_grasp(rng);
            let lift = |v: Vector2<f64>| Vector3::new(v.x, v.y, 0.0);
            spatial::Candidate {
                contact_1: lift(p.contact_1),
                contact_2: lift(p.contact_2),
                normal_1: lift(p.normal_1),
                normal_2: lift(p.normal_2),
                friction_1: p.friction_1,
                friction_2: p.friction_2,
                center_of_mass: lift(p.center_of_mass),
                mass: p.mass,
                gravity: lift(p.gravity),
            }
        }
        _ => c,
    }
}
