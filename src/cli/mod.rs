//! The command line: one `run` per subcommand. It lives in the binary, not in the library's API.

pub(crate) mod node;
pub(crate) mod play;
pub(crate) mod plot;
pub(crate) mod rank;
pub(crate) mod recover;
pub(crate) mod replay;
pub(crate) mod solve;

use crate::answer::{Answering, GripperDrive, PoseAnswerer};
use crate::config::declare::{Real, Setting};
use crate::config::{
    bounds, params_in_file, Config, Domain, InvalidBounds, Parameter, RangeKind, ValueError,
};
use crate::geometry::ClosingAxis;
use crate::replay::Override;
use crate::solver::{AllowedRange, Objective, UnknownObjective};
use anyhow::bail;
use serde_yaml_ng::Value;
use std::path::PathBuf;

/// The answer is "no": `replay` found differences, `recover` lost messages. `main` exits 1 for
/// it, and 2 for every other error, as `diff` and `cmp` do.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub(crate) struct Negative(pub String);

/// The exit codes, for the `--help` of the commands that answer yes or no.
pub(crate) const EXIT_CODES: &str =
    "Exit codes (as diff and cmp): 0 same / nothing lost; 1 differences \
found (replay) or messages lost (recover); 2 trouble: bad arguments, an unreadable, damaged or \
cut-short input, an output that cannot be written.";

/// Options shared by the commands that solve: the config file and overrides of its settings.
/// Each value is checked by clap against its domain (exit code 2 with a one-line error).
#[derive(Debug, Clone, Default, clap::Args)]
pub(crate) struct SolveOptions {
    /// ROS 2 params file to read settings from (`grasp_orient: ros__parameters:`, or `/**:`);
    /// the built-in config/grasp_orient.yaml otherwise.
    #[arg(long, value_name = "FILE")]
    pub(crate) config: Option<PathBuf>,
    /// What to minimise: norm2, norm1 or internal_force.
    #[arg(long, value_parser = parse_objective)]
    pub(crate) objective: Option<Objective>,
    /// Where the recommendation may lie: from_above, graspable, or LO:HI (finite gravity-angle
    /// bounds in the paper's object frame, rad, LO < HI; a turn or more apart allows every angle).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_range)]
    pub(crate) range: Option<AllowedRange>,
    /// Divides both friction coefficients (in [1, 1000]; 1 reproduces the paper).
    #[arg(long, value_name = "S", allow_negative_numbers = true,
          value_parser = parameter::<f64>("friction_safety_factor"))]
    pub(crate) friction_safety_factor: Option<f64>,
    /// The most grip force the gripper gives, N (>= 0; 0: no limit). A grasp that needs more
    /// gets status 3.
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = parameter::<f64>("max_grip_force"))]
    pub(crate) max_grip_force: Option<f64>,
    /// How the fingers are driven, which picks the grip force: coupled (internal_force) or
    /// independent (finger_force).
    #[arg(long, value_name = "DRIVE", value_parser = parse_name::<GripperDrive>)]
    pub(crate) gripper_drive: Option<GripperDrive>,
    /// Half-widths of a box around the centre of mass along the candidate frame's axes, m
    /// (each >= 0), for candidates whose own center_of_mass_tolerance is zero: the answer is the
    /// worst case over the box.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true,
          value_parser = parse_center_of_mass_tolerance)]
    pub(crate) center_of_mass_tolerance: Option<[f64; 3]>,
    /// The mass lies in mass ± this, kg (>= 0), for candidates whose own mass_tolerance is zero:
    /// the answer is the worst case over it.
    #[arg(long, value_name = "KG", allow_negative_numbers = true,
          value_parser = parameter::<f64>("mass_tolerance"))]
    pub(crate) mass_tolerance: Option<f64>,
}

impl SolveOptions {
    /// The parameters these options set, in the order they apply: the `--config` file's, then
    /// each flag's. Each name is one of the parameter table's.
    pub(crate) fn overrides(&self) -> anyhow::Result<Vec<Override>> {
        let mut out: Vec<Override> = Vec::new();
        if let Some(path) = &self.config {
            for (name, value) in params_in_file(path, "grasp_orient")? {
                if Parameter::find(&name).is_none() {
                    bail!("{}: grasp_orient has no parameter {name}", path.display());
                }
                out.push((name, value));
            }
        }
        if let Some(o) = self.objective {
            out.push(("objective".into(), Value::String(o.to_string())));
        }
        if let Some(s) = self.friction_safety_factor {
            out.push(("friction_safety_factor".into(), Value::Number(s.into())));
        }
        if let Some(f) = self.max_grip_force {
            out.push(("max_grip_force".into(), Value::Number(f.into())));
        }
        if let Some(d) = self.gripper_drive {
            out.push(("gripper_drive".into(), Value::String(d.to_string())));
        }
        if let Some(t) = self.center_of_mass_tolerance {
            out.push(("center_of_mass_tolerance".into(), t.to_yaml()));
        }
        if let Some(t) = self.mass_tolerance {
            out.push(("mass_tolerance".into(), Value::Number(t.into())));
        }
        if let Some(r) = self.range {
            let kind = RangeKind::of(&r).to_string();
            out.push(("range".into(), Value::String(kind)));
            if let AllowedRange::Bounds { lo, hi } = r {
                out.push(("range_min".into(), Value::Number(lo.into())));
                out.push(("range_max".into(), Value::Number(hi.into())));
            }
        }
        Ok(out)
    }

    /// The built-in config with [`SolveOptions::overrides`] applied, checked.
    pub(crate) fn config(&self) -> anyhow::Result<Config> {
        let mut config = Config::load(None, "grasp_orient")?;
        for (name, value) in self.overrides()? {
            config.set_value(&name, value)?;
        }
        config.solver_settings()?;
        Ok(config)
    }

    /// [`SolveOptions::config`], and what answers with it: its solver settings, its gripper
    /// rules, and pose candidates closing along `closing_axis` (else the config's), meshes
    /// found through `AMENT_PREFIX_PATH`.
    pub(crate) fn answering(
        &self,
        closing_axis: Option<ClosingAxis>,
    ) -> anyhow::Result<(Config, Answering)> {
        let config = self.config()?;
        let poses = PoseAnswerer::from_env(closing_axis.unwrap_or(config.closing_axis));
        let with = config.answering(poses)?;
        Ok((config, with))
    }
}

/// Why a value on the command line is refused; clap prints its words after the option.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum BadValue {
    /// Not a number.
    #[error("{text:?} is not a number")]
    NotANumber {
        /// What was given.
        text: String,
    },
    /// Not an integer.
    #[error("{text:?} is not an integer")]
    NotAnInteger {
        /// What was given.
        text: String,
    },
    /// Not a value of the parameter's type.
    #[error("{text:?} is not a valid {type_name}")]
    NotOfType {
        /// What was given.
        text: String,
        /// The parameter's ROS type.
        type_name: &'static str,
    },
    /// Not three numbers separated by commas.
    #[error("expected X,Y,Z (three numbers), got {text:?}")]
    NotThree {
        /// What was given.
        text: String,
    },
    /// Not a range.
    #[error("expected from_above, graspable or LO:HI")]
    NotARange,
    /// Outside the parameter's domain.
    #[error(transparent)]
    Domain(#[from] ValueError),
    /// Range bounds that are no interval.
    #[error(transparent)]
    Bounds(#[from] InvalidBounds),
    /// A `--rate` between 0 and 0.001.
    #[error("must be 0 or in [0.001, 1000], got {}", Real(*.rate))]
    Rate {
        /// What was given.
        rate: f64,
    },
}

fn number(text: &str) -> Result<f64, BadValue> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| BadValue::NotANumber {
            text: text.to_string(),
        })
}

fn parse_objective(text: &str) -> Result<Objective, UnknownObjective> {
    parse_name(text)
}

/// A clap parser for a setting that is one of a few names.
pub(crate) fn parse_name<T>(text: &str) -> Result<T, T::Err>
where
    T: std::str::FromStr,
{
    text.parse::<T>()
}

/// `X,Y,Z` in m, each in the domain of the parameter `center_of_mass_tolerance`.
fn parse_center_of_mass_tolerance(text: &str) -> Result<[f64; 3], BadValue> {
    let parts: Vec<&str> = text.split(',').collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(BadValue::NotThree {
            text: text.to_string(),
        });
    };
    let value = [number(x)?, number(y)?, number(z)?];
    let domain = Parameter::find("center_of_mass_tolerance").map_or(Domain::Any, |p| p.domain);
    value.check(&domain)?;
    Ok(value)
}

/// `from_above`, `graspable`, or `LO:HI` bounds in rad.
fn parse_range(text: &str) -> Result<AllowedRange, BadValue> {
    let Some((lo, hi)) = text.split_once(':') else {
        return match text.parse::<RangeKind>() {
            Ok(kind @ (RangeKind::FromAbove | RangeKind::Graspable)) => Ok(kind.allowed(0.0, 0.0)?),
            _ => Err(BadValue::NotARange),
        };
    };
    Ok(bounds(number(lo)?, number(hi)?)?)
}

/// A clap parser for a value of parameter `name`, checked against the domain the parameter
/// table declares for it (so the option and the parameter agree).
pub(crate) fn parameter<T>(
    name: &'static str,
) -> impl Fn(&str) -> Result<T, BadValue> + Clone + Send + Sync
where
    T: std::str::FromStr + Setting,
{
    move |text| {
        let value: T = text.trim().parse().map_err(|_| BadValue::NotOfType {
            text: text.to_string(),
            type_name: T::ROS_TYPE.name(),
        })?;
        let domain = Parameter::find(name).map_or(Domain::Any, |p| p.domain);
        value.check(&domain)?;
        Ok(value)
    }
}

/// A clap parser for a real number in `[min, max]` (never NaN or infinite).
pub(crate) fn real_in(
    min: f64,
    max: f64,
) -> impl Fn(&str) -> Result<f64, BadValue> + Clone + Send + Sync {
    move |text| {
        let value = number(text)?;
        value.check(&Domain::Real { min, max })?;
        Ok(value)
    }
}

/// A clap parser for an integer in `min..=max`.
pub(crate) fn integer_in(
    min: i64,
    max: i64,
) -> impl Fn(&str) -> Result<i64, BadValue> + Clone + Send + Sync {
    move |text| {
        let value: i64 = text.trim().parse().map_err(|_| BadValue::NotAnInteger {
            text: text.to_string(),
        })?;
        value.check(&Domain::Integer { min, max })?;
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse() {
        assert_eq!(parse_range("graspable"), Ok(AllowedRange::Graspable));
        assert_eq!(
            parse_range("-1.5:0.5"),
            Ok(AllowedRange::Bounds { lo: -1.5, hi: 0.5 })
        );
        assert!(matches!(parse_range("1:0"), Err(BadValue::Bounds(_))));
        assert_eq!(parse_range("sideways"), Err(BadValue::NotARange));
        assert_eq!(
            parse_range("x:1").map_err(|e| e.to_string()),
            Err("\"x\" is not a number".to_string())
        );
        assert!(parse_range("sideways").is_err());
        assert!(parse_range("bounds").is_err());
        assert!(parse_range("nan:1").is_err());
        assert!(parse_range("-inf:1").is_err());
    }

    #[test]
    fn numbers_are_checked_against_their_domains() {
        let s = parameter::<f64>("friction_safety_factor");
        assert_eq!(s("1.5"), Ok(1.5));
        for bad in ["0.5", "nan", "inf", "1e300", "x"] {
            assert!(s(bad).is_err(), "{bad}");
        }
        let r = real_in(0.0, 10.0);
        assert!(r("-1").is_err() && r("NaN").is_err() && r("10").is_ok());
        let i = integer_in(1, 5);
        assert!(i("0").is_err() && i("-5").is_err() && i("1.5").is_err() && i("5").is_ok());
    }
}
