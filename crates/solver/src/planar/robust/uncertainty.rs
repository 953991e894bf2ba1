//! How well the object is known: the tolerances of its centre of mass and its mass, and their
//! checks (shared with the spatial tolerances).

use crate::limits::MAX_COORDINATE;
use crate::InvalidInput;
use nalgebra::Vector2;

/// How well the object is known. Zero everywhere means exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Uncertainty {
    /// Half-widths of a box around `center_of_mass` along the x and y axes of the candidate
    /// frame, m, each `>= 0`.
    pub center_of_mass_tolerance: Vector2<f64>,
    /// The mass lies in `mass ± mass_tolerance`, kg, in `[0, mass)`.
    pub mass_tolerance: f64,
}

impl Uncertainty {
    /// No uncertainty: the nominal problem.
    pub const EXACT: Uncertainty = Uncertainty {
        center_of_mass_tolerance: Vector2::new(0.0, 0.0),
        mass_tolerance: 0.0,
    };

    /// Whether every tolerance is zero.
    pub fn is_exact(&self) -> bool {
        self.center_of_mass_tolerance.x == 0.0
            && self.center_of_mass_tolerance.y == 0.0
            && self.mass_tolerance == 0.0
    }

    /// Checks the tolerances against the candidate's mass, naming the field at fault.
    pub(super) fn validate(&self, mass: f64) -> Result<(), InvalidInput> {
        let t = &self.center_of_mass_tolerance;
        check_tolerance("center_of_mass_tolerance.x", t.x, MAX_COORDINATE, " m")?;
        check_tolerance("center_of_mass_tolerance.y", t.y, MAX_COORDINATE, " m")?;
        check_tolerance("mass_tolerance", self.mass_tolerance, mass, " kg")
    }
}

/// One tolerance: finite and in `[0, limit)` (`unit` names the limit's unit in the message), or
/// the error naming `field`. The planar and the spatial tolerances are checked with it.
pub(crate) fn check_tolerance(
    field: &'static str,
    value: f64,
    limit: f64,
    unit: &'static str,
) -> Result<(), InvalidInput> {
    if !value.is_finite() {
        Err(InvalidInput::NotFinite { field })
    } else if !(0.0..limit).contains(&value) {
        Err(InvalidInput::Tolerance {
            field,
            value,
            limit,
            unit,
        })
    } else {
        Ok(())
    }
}
