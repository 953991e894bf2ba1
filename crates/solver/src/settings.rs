//! How to solve: the objective, the allowed gravity angles and the friction safety factor.

use std::fmt;

/// What the solver minimises over the feasible contact forces at each orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Objective {
    /// Euclidean norm of `(N1, F1, N2, F2)`, N (the paper's figures).
    #[default]
    Norm2,
    /// Sum of absolute values of `(N1, F1, N2, F2)`, N.
    Norm1,
    /// The squeeze force each finger adds along the contact line, N.
    InternalForce,
}

impl Objective {
    /// The name used in configuration files and messages.
    pub fn name(&self) -> &'static str {
        match self {
            Objective::Norm2 => "norm2",
            Objective::Norm1 => "norm1",
            Objective::InternalForce => "internal_force",
        }
    }

    /// Parses a name as written by [`Objective::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "norm2" => Some(Objective::Norm2),
            "norm1" => Some(Objective::Norm1),
            "internal_force" => Some(Objective::InternalForce),
            _ => None,
        }
    }

    /// Every name, in the order the documentation lists them.
    pub const NAMES: [&'static str; 3] = ["norm2", "norm1", "internal_force"];
}

impl fmt::Display for Objective {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not one of [`Objective::NAMES`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given:?} is not one of {}", Objective::NAMES.join(", "))]
#[non_exhaustive]
pub struct UnknownObjective {
    /// What was given.
    pub given: String,
}

impl std::str::FromStr for Objective {
    type Err = UnknownObjective;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Objective::from_name(s).ok_or_else(|| UnknownObjective {
            given: s.to_string(),
        })
    }
}

/// The gravity angles the recommendation may take.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AllowedRange {
    /// The object hangs below the fingers: the upward vertical through the centre of mass meets
    /// the segment between the contacts. `[-atan2(x1, y), atan2(x2, y)]`, closed.
    #[default]
    FromAbove,
    /// The paper's whole graspable range (8), closed.
    Graspable,
    /// Explicit gravity-angle bounds in the paper frame, rad; intersected with the graspable range.
    Bounds {
        /// Lower bound, rad.
        lo: f64,
        /// Upper bound, rad.
        hi: f64,
    },
}

/// How to solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// What to minimise.
    pub objective: Objective,
    /// Where the recommendation may lie.
    pub range: AllowedRange,
    /// Divides both friction coefficients, >= 1 (1 = the paper).
    pub friction_safety_factor: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            objective: Objective::default(),
            range: AllowedRange::default(),
            friction_safety_factor: 1.0,
        }
    }
}
