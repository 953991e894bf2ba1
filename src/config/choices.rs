//! The settings that take one of a few names, each as a type that parses ([`FromStr`]) and prints
//! ([`Display`]) itself. The solver's [`Objective`] has its text form in the solver crate
//! ([`Objective::name`], [`Objective::NAMES`]).

use crate::answer::{GripperDrive, RankBy};
use crate::solver::{AllowedRange, Objective};
use std::fmt::{self, Display};
use std::str::FromStr;

/// A setting whose value is one of a fixed list of names.
pub(crate) trait Choice: Copy + FromStr<Err: Display> + Display + 'static {
    /// Every name, in the order the documentation lists them.
    const NAMES: &'static [&'static str];
}

/// A name that is not among the choices.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given:?} is not one of {}", .names.join(", "))]
#[non_exhaustive]
pub struct UnknownName {
    /// What was given.
    pub given: String,
    /// The names accepted.
    pub names: &'static [&'static str],
}

impl UnknownName {
    fn new<T: Choice>(given: &str) -> Self {
        Self {
            given: given.to_string(),
            names: T::NAMES,
        }
    }
}

impl Choice for Objective {
    const NAMES: &'static [&'static str] = &Objective::NAMES;
}

/// Which gravity angles the recommendation may take (the `range` parameter); with `Bounds`, the
/// parameters `range_min` and `range_max` give them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RangeKind {
    /// [`AllowedRange::FromAbove`].
    #[default]
    FromAbove,
    /// [`AllowedRange::Graspable`].
    Graspable,
    /// [`AllowedRange::Bounds`].
    Bounds,
}

impl RangeKind {
    /// The kind of an allowed range (its bounds aside).
    pub(crate) fn of(range: &AllowedRange) -> Self {
        match range {
            AllowedRange::FromAbove => RangeKind::FromAbove,
            AllowedRange::Graspable => RangeKind::Graspable,
            AllowedRange::Bounds { .. } => RangeKind::Bounds,
        }
    }

    /// The name in params files and on the command line.
    pub(crate) fn name(&self) -> &'static str {
        match self {
            RangeKind::FromAbove => "from_above",
            RangeKind::Graspable => "graspable",
            RangeKind::Bounds => "bounds",
        }
    }

    /// The allowed range of this kind; `lo` and `hi` count for `Bounds` only.
    pub(crate) fn allowed(self, lo: f64, hi: f64) -> Result<AllowedRange, InvalidBounds> {
        match self {
            RangeKind::FromAbove => Ok(AllowedRange::FromAbove),
            RangeKind::Graspable => Ok(AllowedRange::Graspable),
            RangeKind::Bounds => bounds(lo, hi),
        }
    }
}

impl Choice for RangeKind {
    const NAMES: &'static [&'static str] = &["from_above", "graspable", "bounds"];
}

impl FromStr for RangeKind {
    type Err = UnknownName;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [
            RangeKind::FromAbove,
            RangeKind::Graspable,
            RangeKind::Bounds,
        ]
        .into_iter()
        .find(|k| k.name() == s)
        .ok_or_else(|| UnknownName::new::<Self>(s))
    }
}

impl Display for RangeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Implements [`Choice`], [`FromStr`] and [`Display`] for a type with `name()` and its variants.
macro_rules! named_choice {
    ($ty:ty, [$($variant:expr),+ $(,)?]) => {
        impl Choice for $ty {
            const NAMES: &'static [&'static str] = &[$($variant.name()),+];
        }

        impl FromStr for $ty {
            type Err = UnknownName;

            fn from_str(s: &str) -> Result<Self, Self::Err> {
                [$($variant),+]
                    .into_iter()
                    .find(|k| k.name() == s)
                    .ok_or_else(|| UnknownName::new::<Self>(s))
            }
        }

        impl Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

named_choice!(
    GripperDrive,
    [GripperDrive::Coupled, GripperDrive::Independent]
);
named_choice!(RankBy, [RankBy::GripForce, RankBy::Objective]);

/// Gravity-angle bounds that are not finite with `lo < hi`.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("bounds must be finite with lower < upper, got {lo} and {hi}")]
#[non_exhaustive]
pub(crate) struct InvalidBounds {
    /// Lower bound given, rad.
    pub(crate) lo: f64,
    /// Upper bound given, rad.
    pub(crate) hi: f64,
}

/// The one place where gravity-angle bounds (rad, paper frame) become an [`AllowedRange`].
pub(crate) fn bounds(lo: f64, hi: f64) -> Result<AllowedRange, InvalidBounds> {
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok(AllowedRange::Bounds { lo, hi })
    } else {
        Err(InvalidBounds { lo, hi })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every variant has its name listed, and every listed name parses back to its variant.
    fn round_trip<T: Choice + PartialEq + fmt::Debug>(variants: &[T]) {
        assert_eq!(variants.len(), T::NAMES.len());
        for v in variants {
            let name = v.to_string();
            assert!(T::NAMES.contains(&name.as_str()), "{name} not listed");
            assert_eq!(name.parse::<T>().ok(), Some(*v));
        }
    }

    #[test]
    fn names_round_trip() {
        // The matches fail to compile when a variant is added, so the lists stay complete.
        let objectives = [Objective::Norm2, Objective::Norm1, Objective::InternalForce];
        for o in objectives {
            match o {
                Objective::Norm2 | Objective::Norm1 | Objective::InternalForce => {}
            }
        }
        round_trip(&objectives);
        let kinds = [
            RangeKind::FromAbove,
            RangeKind::Graspable,
            RangeKind::Bounds,
        ];
        for k in kinds {
            match k {
                RangeKind::FromAbove | RangeKind::Graspable | RangeKind::Bounds => {}
            }
        }
        round_trip(&kinds);
        let drives = [GripperDrive::Coupled, GripperDrive::Independent];
        for d in drives {
            match d {
                GripperDrive::Coupled | GripperDrive::Independent => {}
            }
        }
        round_trip(&drives);
        let ranks = [RankBy::GripForce, RankBy::Objective];
        for r in ranks {
            match r {
                RankBy::GripForce | RankBy::Objective => {}
            }
        }
        round_trip(&ranks);
    }

    #[test]
    fn unknown_names_are_refused_with_the_choices() {
        let e = "norm3".parse::<Objective>().expect_err("unknown");
        assert_eq!(
            e.to_string(),
            "\"norm3\" is not one of norm2, norm1, internal_force"
        );
        assert!("sideways".parse::<RangeKind>().is_err());
    }

    #[test]
    fn bounds_are_finite_and_ordered() {
        assert_eq!(
            bounds(-1.5, 0.5),
            Ok(AllowedRange::Bounds { lo: -1.5, hi: 0.5 })
        );
        assert!(bounds(1.0, 0.0).is_err());
        assert!(bounds(0.0, 0.0).is_err());
        assert!(bounds(f64::NAN, 1.0).is_err());
        assert!(bounds(0.0, f64::INFINITY).is_err());
        assert_eq!(
            RangeKind::Graspable.allowed(1.0, 0.0),
            Ok(AllowedRange::Graspable)
        );
    }
}
