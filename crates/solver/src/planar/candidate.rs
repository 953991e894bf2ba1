//! A planar grasp as it arrives: contacts, inward normals, friction, centre of mass, mass and
//! gravity in the candidate's own frame.

use nalgebra::Vector2;

/// A two-finger planar grasp in the candidate's own frame. SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Contact point 1, m.
    pub contact_1: Vector2<f64>,
    /// Contact point 2, m.
    pub contact_2: Vector2<f64>,
    /// Surface normal at contact 1, pointing into the object; any length > 0.
    pub normal_1: Vector2<f64>,
    /// Surface normal at contact 2, pointing into the object; any length > 0.
    pub normal_2: Vector2<f64>,
    /// Coulomb friction coefficient at contact 1, > 0.
    pub friction_1: f64,
    /// Coulomb friction coefficient at contact 2, > 0.
    pub friction_2: f64,
    /// Centre of mass, m.
    pub center_of_mass: Vector2<f64>,
    /// Mass, kg, > 0.
    pub mass: f64,
    /// Gravitational acceleration at the current pose, m/s².
    pub gravity: Vector2<f64>,
}
