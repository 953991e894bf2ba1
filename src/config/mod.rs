//! The settings: every parameter declared once (in `params.rs`, listed by [`PARAMETERS`]), read
//! from ROS 2 params files (`grasp_orient: ros__parameters:`) and `-p name:=value`, and checked
//! once ([`Config::solver_settings`]). `config/grasp_orient.yaml` is generated from the
//! declarations and compiled in as the default.

pub mod choices;
pub mod declare;
mod params;
pub mod render;

pub use choices::{bounds, Choice, InvalidBounds, RangeKind, UnknownName};
pub use declare::{Domain, Parameter, RosType};
pub use params::{Config, PARAMETERS};

use crate::sets::Rules;
use crate::solver::Settings;
use std::path::Path;

/// The params file shipped with the package, compiled in.
pub const DEFAULT_YAML: &str = include_str!("../../config/grasp_orient.yaml");

/// Why settings were refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The YAML is malformed.
    #[error("{origin}: {source}")]
    Yaml {
        /// Where the text came from.
        origin: String,
        /// The cause.
        source: serde_yaml_ng::Error,
    },
    /// No parameter has this name.
    #[error("grasp_orient has no parameter {name}")]
    Unknown {
        /// The name given.
        name: String,
    },
    /// A value is of the wrong type, or out of its domain.
    #[error("parameter {name}: {why}")]
    Value {
        /// The parameter.
        name: &'static str,
        /// What is wrong.
        why: String,
    },
    /// A params file holds a refused parameter.
    #[error("{origin}: {source}")]
    InFile {
        /// The file.
        origin: String,
        /// What is wrong with it.
        source: Box<ConfigError>,
    },
}

/// The parameters a params file sets for `node` (under `/**`, `**`, `node` or `/node`), in
/// file order, as names and YAML values (not checked against the table).
pub fn params_in_yaml(
    text: &str,
    origin: &str,
    node: &str,
) -> Result<Vec<(String, serde_yaml_ng::Value)>, ConfigError> {
    let doc: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(text).map_err(|source| ConfigError::Yaml {
            origin: origin.to_string(),
            source,
        })?;
    let Some(map) = doc.as_mapping() else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for key in ["/**", "**", node, &format!("/{node}")] {
        if let Some(params) = map
            .get(key)
            .and_then(|v| v.get("ros__parameters"))
            .and_then(|v| v.as_mapping())
        {
            for (name, value) in params {
                let name = name.as_str().unwrap_or_default().to_string();
                out.push((name, value.clone()));
            }
        }
    }
    Ok(out)
}

impl Parameter {
    /// The declaration of `name`.
    pub fn find(name: &str) -> Option<&'static Parameter> {
        PARAMETERS.iter().find(|p| p.name == name)
    }
}

impl Config {
    /// Reads a params file: the `ros__parameters` of `node` (or of `/**`) are applied over `self`.
    pub fn merge_yaml(&mut self, text: &str, origin: &str, node: &str) -> Result<(), ConfigError> {
        for (name, value) in params_in_yaml(text, origin, node)? {
            self.set_value(&name, value)
                .map_err(|e| ConfigError::InFile {
                    origin: origin.to_string(),
                    source: Box::new(e),
                })?;
        }
        Ok(())
    }

    /// Sets one parameter from its YAML text (as in `-p name:=value`), checking its type only.
    pub fn set_from_yaml(&mut self, name: &str, value: &str) -> Result<(), ConfigError> {
        let parsed: serde_yaml_ng::Value =
            serde_yaml_ng::from_str(value).map_err(|source| ConfigError::Yaml {
                origin: format!("parameter {name}"),
                source,
            })?;
        self.set_value(name, parsed)
    }

    /// The compiled-in defaults, then `file` if given, checked.
    pub fn load(file: Option<&Path>, node: &str) -> Result<Self, ConfigError> {
        let mut config = Config::default();
        config.merge_yaml(DEFAULT_YAML, "built-in config/grasp_orient.yaml", node)?;
        if let Some(path) = file {
            let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
                path: path.display().to_string(),
                source,
            })?;
            config.merge_yaml(&text, &path.display().to_string(), node)?;
        }
        config.solver_settings()?;
        Ok(config)
    }

    /// Checks every value against its declared domain, and the range bounds against each other;
    /// the solver settings they give.
    pub fn solver_settings(&self) -> Result<Settings, ConfigError> {
        self.check_domains()?;
        let range = self.range.allowed(self.range_min, self.range_max).map_err(
            |InvalidBounds { lo, hi }| ConfigError::Value {
                name: "range_min",
                why: format!("bounds need finite range_min < range_max, got {lo} and {hi}"),
            },
        )?;
        Ok(Settings {
            objective: self.objective,
            range,
            friction_safety_factor: self.friction_safety_factor,
        })
    }

    /// The gripper and set rules: `gripper_drive`, `max_grip_force`, `rank_by`, `max_set_size`
    /// (their domains are checked by [`Config::solver_settings`]).
    pub fn rules(&self) -> Rules {
        Rules {
            drive: self.gripper_drive,
            max_grip_force: self.max_grip_force,
            rank_by: self.rank_by,
            max_set_size: usize::try_from(self.max_set_size).unwrap_or(1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Objective;

    #[test]
    fn shipped_file_equals_the_defaults() {
        let c = Config::load(None, "grasp_orient").expect("valid");
        assert_eq!(c, Config::default());
        assert_eq!(c.solver_settings().expect("valid"), Settings::default());
    }

    #[test]
    fn params_file_overrides_and_validates() {
        let mut c = Config::default();
        c.merge_yaml(
            "/**:\n  ros__parameters:\n    objective: norm1\n    friction_safety_factor: 1.5\n",
            "test",
            "grasp_orient",
        )
        .expect("valid yaml");
        assert_eq!(c.objective, Objective::Norm1);
        assert_eq!(
            c.solver_settings().expect("valid").friction_safety_factor,
            1.5
        );
        let e = c
            .merge_yaml(
                "grasp_orient:\n  ros__parameters:\n    objective: norm3\n",
                "t",
                "grasp_orient",
            )
            .expect_err("unknown objective");
        assert!(e.to_string().contains("objective"), "{e}");
        let mut c = Config::default();
        let e = c
            .merge_yaml(
                "grasp_orient:\n  ros__parameters:\n    objectiv: norm1\n",
                "t",
                "grasp_orient",
            )
            .expect_err("typo");
        assert!(e.to_string().contains("objectiv"), "{e}");
    }

    #[test]
    fn domains_and_bounds_are_checked() {
        let mut c = Config {
            friction_safety_factor: 0.5,
            ..Config::default()
        };
        let e = c.solver_settings().expect_err("below one");
        assert_eq!(
            e.to_string(),
            "parameter friction_safety_factor: must be >= 1, got 0.5"
        );
        c.friction_safety_factor = f64::INFINITY;
        assert!(c.solver_settings().is_err());
        let c = Config {
            qos_depth: 0,
            ..Config::default()
        };
        assert!(c.solver_settings().is_err());
        let mut c = Config::default();
        c.set_from_yaml("range", "bounds").expect("a kind");
        c.set_from_yaml("range_min", "1.0").expect("a number");
        c.set_from_yaml("range_max", "0.5").expect("a number");
        let e = c.solver_settings().expect_err("inverted");
        assert!(e.to_string().contains("range_min"), "{e}");
        let e = c
            .set_from_yaml("qos_depth", "abc")
            .expect_err("not a number");
        assert!(e.to_string().contains("qos_depth"), "{e}");
    }

    #[test]
    fn gripper_and_set_parameters_are_checked_and_give_the_rules() {
        use crate::sets::{GripperDrive, RankBy, Rules};
        let c = Config::default();
        assert_eq!(c.rules(), Rules::default());
        let mut c = Config::default();
        c.set_from_yaml("gripper_drive", "independent")
            .expect("a drive");
        c.set_from_yaml("max_grip_force", "40.0").expect("a number");
        c.set_from_yaml("rank_by", "objective").expect("a name");
        c.set_from_yaml("max_set_size", "7").expect("an integer");
        c.solver_settings().expect("valid");
        assert_eq!(
            c.rules(),
            Rules {
                drive: GripperDrive::Independent,
                max_grip_force: 40.0,
                rank_by: RankBy::Objective,
                max_set_size: 7
            }
        );
        assert!(c.set_from_yaml("gripper_drive", "hydraulic").is_err());
        for (name, bad) in [
            ("max_grip_force", "-1.0"),
            ("max_grip_force", ".nan"),
            ("max_set_size", "0"),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, bad).expect("the type is right");
            let e = c.solver_settings().expect_err("out of the domain");
            assert!(e.to_string().contains(name), "{e}");
        }
    }
}
