//! The paper's Table 1 (Ito et al.): its four case studies as candidates, in the paper frame.
//!
//! The unit tests here and the package's integration tests share these; `examples/paper_cases.jsonl`
//! in the ROS package holds the same four cases as messages, in SI units, and a test there holds
//! the two to each other.

use crate::planar::candidate::Candidate;

/// Case `'a'` .. `'d'` of Table 1: `p1`, `p2`, `φ1`, `φ2`, `μ1`, `μ2`, with `Mg = 1`, in the paper
/// frame (centre of mass at the origin, gravity along -y).
///
/// # Panics
/// For any other letter than `'a'` to `'d'`: the table has no other case.
pub fn table_1(case: char) -> Candidate {
    use std::f64::consts::PI;
    let r3 = 3f64.sqrt();
    match case {
        'a' => paper_grasp((5.0 * r3, 5.0), -5.0 * r3, (PI / 3.0, PI / 3.0), (1.5, 1.0)),
        'b' => paper_grasp((5.0, 4.0), -3.0, (PI / 4.0, PI / 4.0), (1.5, 2.5)),
        'c' => paper_grasp((1.0, 1.0), -1.0, (PI / 2.0, PI / 2.0), (r3, 1.0 / r3)),
        'd' => paper_grasp((1.0, 3.0), -1.0, (PI / 2.0, PI / 2.0), (r3, 1.0 / r3)),
        _ => panic!("Table 1 has the cases 'a' to 'd', not {case:?}"),
    }
}

/// A grasp in the paper's terms: contact 1 at `p1`, contact 2 at `(p2x, p1.y)`, inward normals
/// `(-sin φ1, -cos φ1)` and `(sin φ2, -cos φ2)`, friction `μ1`, `μ2`, `Mg = 1`, centre of mass at
/// the origin, gravity along -y.
pub fn paper_grasp(p1: (f64, f64), p2x: f64, phi: (f64, f64), mu: (f64, f64)) -> Candidate {
    use nalgebra::Vector2;
    Candidate {
        contact_1: Vector2::new(p1.0, p1.1),
        contact_2: Vector2::new(p2x, p1.1),
        normal_1: Vector2::new(-phi.0.sin(), -phi.0.cos()),
        normal_2: Vector2::new(phi.1.sin(), -phi.1.cos()),
        friction_1: mu.0,
        friction_2: mu.1,
        center_of_mass: Vector2::zeros(),
        mass: 1.0,
        gravity: Vector2::new(0.0, -1.0),
    }
}
