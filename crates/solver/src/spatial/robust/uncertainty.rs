//! How well a spatial object is known: the tolerances of its centre of mass and its mass, and
//! their checks.

use crate::planar::robust::check_tolerance;
use crate::{InvalidInput, MAX_COORDINATE};
use nalgebra::Vector3;

/// How well a spatial object is known. Zero everywhere means exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[doc(alias = "SpatialUncertainty")]
pub struct Uncertainty {
    /// Half-widths of a box around `center_of_mass` along the x, y and z axes of the candidate
    /// frame, m, each `>= 0`.
    pub center_of_mass_tolerance: Vector3<f64>,
    /// The mass lies in `mass ± mass_tolerance`, kg, in `[0, mass)`.
    pub mass_tolerance: f64,
}

impl Uncertainty {
    /// No uncertainty: the nominal problem.
    pub const EXACT: Uncertainty = Uncertainty {
        center_of_mass_tolerance: Vector3::new(0.0, 0.0, 0.0),
        mass_tolerance: 0.0,
    };

    /// Whether every tolerance is zero.
    pub fn is_exact(&self) -> bool {
        self.center_of_mass_tolerance == Vector3::zeros() && self.mass_tolerance == 0.0
    }

    /// Checks the tolerances against the candidate's mass, naming the field at fault.
    pub(super) fn validate(&self, mass: f64) -> Result<(), InvalidInput> {
        let t = &self.center_of_mass_tolerance;
        check_tolerance("center_of_mass_tolerance.x", t.x, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.y", t.y, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.z", t.z, MAX_COORDINATE, " m")?;
        check_tolerance("mass_tolerance", self.mass_tolerance, mass, " kg")
    }
}
