//! The keyword arguments that `grasp_orient solve`'s flags mirror (`--objective`, `--range`,
//! `--friction-safety-factor`, `--max-grip-force`, `--gripper-drive`,
//! `--center-of-mass-tolerance`, `--mass-tolerance`), applied to the built-in configuration and
//! checked by the root crate's own [`Config::solver_settings`], so that a value is accepted, and
//! means, exactly what the same flag does. A refusal is a `ValueError` naming the parameter.

use crate::arrays::value_error;
use grasp_orient::answer::{GripperDrive, PoseAnswerer, Rules};
use grasp_orient::config::{Config, RangeKind};
use grasp_orient::geometry::{AmentIndex, ClosingAxis};
use grasp_orient::solver::{Objective, Settings};
use pyo3::prelude::*;
use std::str::FromStr;

/// The keyword arguments, as given.
#[derive(Debug, Clone)]
pub(crate) struct Options {
    /// `norm2`, `norm1` or `internal_force`.
    pub objective: String,
    /// `from_above`, `graspable`, or `(lo, hi)` (rad).
    pub range: RangeArg,
    /// Divides both friction coefficients, in [1, 1000].
    pub friction_safety_factor: f64,
    /// N, >= 0; 0: no limit.
    pub max_grip_force: f64,
    /// `coupled` or `independent`.
    pub gripper_drive: String,
    /// m, each >= 0.
    pub center_of_mass_tolerance: [f64; 3],
    /// kg, >= 0.
    pub mass_tolerance: f64,
}

/// The `range` argument: a name or two bounds.
#[derive(Debug, Clone)]
pub(crate) enum RangeArg {
    /// `from_above` or `graspable`.
    Named(String),
    /// `(lo, hi)`, rad.
    Bounds(f64, f64),
}

impl RangeArg {
    /// A name (`"from_above"`, `"graspable"`) or a pair of numbers.
    pub(crate) fn extract(obj: &Bound<'_, PyAny>) -> PyResult<Self> {
        if let Ok(name) = obj.extract::<String>() {
            return Ok(RangeArg::Named(name));
        }
        obj.extract::<(f64, f64)>()
            .map(|(lo, hi)| RangeArg::Bounds(lo, hi))
            .map_err(|_| {
                value_error(
                    "range: expected \"from_above\", \"graspable\" or a pair (lo, hi) of gravity \
                     angles in rad",
                )
            })
    }
}

impl Options {
    /// The solver settings and the gripper rules these options give, checked as the parameters
    /// of the same names are. The rules answer a set of any size (`max_set_size` bounds what a
    /// node accepts, not what an answer is).
    pub(crate) fn settings(&self) -> PyResult<(Settings, Rules)> {
        let (range, range_min, range_max) = match &self.range {
            RangeArg::Named(name) => {
                let kind =
                    RangeKind::from_str(name).map_err(|e| value_error(format!("range: {e}")))?;
                if kind == RangeKind::Bounds {
                    return Err(value_error(
                        "range: give the bounds as a pair (lo, hi), rad, rather than \"bounds\"",
                    ));
                }
                let defaults = Config::default();
                (kind, defaults.range_min, defaults.range_max)
            }
            RangeArg::Bounds(lo, hi) => (RangeKind::Bounds, *lo, *hi),
        };
        let config = Config {
            objective: Objective::from_str(&self.objective)
                .map_err(|e| value_error(format!("objective: {e}")))?,
            range,
            range_min,
            range_max,
            friction_safety_factor: self.friction_safety_factor,
            max_grip_force: self.max_grip_force,
            gripper_drive: GripperDrive::from_str(&self.gripper_drive)
                .map_err(|e| value_error(format!("gripper_drive: {e}")))?,
            center_of_mass_tolerance: self.center_of_mass_tolerance,
            mass_tolerance: self.mass_tolerance,
            ..Config::default()
        };
        let with = config
            .answering(PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default()))
            .map_err(|e| value_error(e.to_string()))?;
        let rules = Rules {
            max_set_size: usize::MAX,
            ..*with.rules()
        };
        Ok((*with.settings(), rules))
    }
}
