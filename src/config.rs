//! The settings, read from a ROS 2 params file (`grasp_orient: ros__parameters:`) and validated
//! once at load. `config/grasp_orient.yaml` is compiled in as the default.

use crate::solver::{AllowedRange, Objective, Settings};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The params file shipped with the package, compiled in.
pub const DEFAULT_YAML: &str = include_str!("../config/grasp_orient.yaml");

/// Every setting of grasp_orient. Names are the ROS parameter names.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// What is minimised: `norm2`, `norm1` or `internal_force`.
    pub objective: String,
    /// Where the recommendation may lie: `from_above`, `graspable` or `bounds`.
    pub range: String,
    /// Lower gravity-angle bound when `range` is `bounds`, rad (paper frame).
    pub range_min: f64,
    /// Upper gravity-angle bound when `range` is `bounds`, rad (paper frame).
    pub range_max: f64,
    /// Divides both friction coefficients, dimensionless, >= 1.
    pub friction_safety_factor: f64,
    /// QoS history depth of every topic, messages, 1..=100000.
    pub qos_depth: i64,
    /// Publish markers on `grip_markers`.
    pub publish_markers: bool,
    /// Record every run to MCAP.
    pub record: bool,
    /// Folder for recordings.
    pub record_dir: String,
    /// Record the markers as well.
    pub record_markers: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            objective: "norm2".into(),
            range: "from_above".into(),
            range_min: -std::f64::consts::PI,
            range_max: std::f64::consts::PI,
            friction_safety_factor: 1.0,
            qos_depth: 100,
            publish_markers: true,
            record: true,
            record_dir: "runs".into(),
            record_markers: false,
        }
    }
}

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
    /// The YAML is malformed or has unknown or mistyped keys.
    #[error("{origin}: {source}")]
    Yaml {
        /// Where the text came from.
        origin: String,
        /// The cause.
        source: serde_yaml_ng::Error,
    },
    /// A value is out of its allowed set or range.
    #[error("parameter {name}: {why}")]
    Value {
        /// The parameter.
        name: &'static str,
        /// What is wrong.
        why: String,
    },
}

impl Config {
    /// Reads a params file: the `ros__parameters` of `node` (or of `/**`) are applied over `self`.
    pub fn merge_yaml(&mut self, text: &str, origin: &str, node: &str) -> Result<(), ConfigError> {
        let yaml = |source| ConfigError::Yaml {
            origin: origin.to_string(),
            source,
        };
        let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(text).map_err(yaml)?;
        let Some(map) = doc.as_mapping() else {
            return Ok(());
        };
        let keys = ["/**", "**", node, &format!("/{node}")];
        for key in keys {
            if let Some(params) = map
                .get(key)
                .and_then(|v| v.get("ros__parameters"))
                .and_then(|v| v.as_mapping())
            {
                let mut merged = serde_yaml_ng::to_value(&*self).map_err(yaml)?;
                if let Some(target) = merged.as_mapping_mut() {
                    for (k, v) in params {
                        target.insert(k.clone(), v.clone());
                    }
                }
                *self = serde_yaml_ng::from_value(merged).map_err(yaml)?;
            }
        }
        Ok(())
    }

    /// Sets one parameter from its YAML text (as in `-p name:=value`), without validating.
    pub fn set_from_yaml(&mut self, name: &str, value: &str) -> Result<(), ConfigError> {
        let yaml = |source| ConfigError::Yaml {
            origin: format!("parameter {name}"),
            source,
        };
        let parsed: serde_yaml_ng::Value = serde_yaml_ng::from_str(value).map_err(yaml)?;
        self.set_value(name, parsed)
    }

    /// Sets one parameter from a YAML value, without validating.
    pub fn set_value(
        &mut self,
        name: &str,
        value: serde_yaml_ng::Value,
    ) -> Result<(), ConfigError> {
        let yaml = |source| ConfigError::Yaml {
            origin: format!("parameter {name}"),
            source,
        };
        let mut merged = serde_yaml_ng::to_value(&*self).map_err(yaml)?;
        if let Some(map) = merged.as_mapping_mut() {
            map.insert(serde_yaml_ng::Value::String(name.to_string()), value);
        }
        *self = serde_yaml_ng::from_value(merged).map_err(yaml)?;
        Ok(())
    }

    /// Every parameter as `(name, YAML value)`, in declaration order.
    pub fn parameters(&self) -> Vec<(String, serde_yaml_ng::Value)> {
        match serde_yaml_ng::to_value(self) {
            Ok(serde_yaml_ng::Value::Mapping(map)) => map
                .into_iter()
                .filter_map(|(k, v)| k.as_str().map(|k| (k.to_string(), v)))
                .collect(),
            _ => Vec::new(),
        }
    }

    /// The compiled-in defaults, then `file` if given, validated.
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
        config.validate()?;
        Ok(config)
    }

    /// Checks every value; the solver settings it implies.
    pub fn validate(&self) -> Result<Settings, ConfigError> {
        let objective =
            Objective::from_name(&self.objective).ok_or_else(|| ConfigError::Value {
                name: "objective",
                why: format!(
                    "{:?} is not one of norm2, norm1, internal_force",
                    self.objective
                ),
            })?;
        let range = match self.range.as_str() {
            "from_above" => AllowedRange::FromAbove,
            "graspable" => AllowedRange::Graspable,
            "bounds" => {
                if !(self.range_min.is_finite()
                    && self.range_max.is_finite()
                    && self.range_min < self.range_max)
                {
                    return Err(ConfigError::Value {
                        name: "range_min",
                        why: format!(
                            "bounds need finite range_min < range_max, got {} and {}",
                            self.range_min, self.range_max
                        ),
                    });
                }
                AllowedRange::Bounds {
                    lo: self.range_min,
                    hi: self.range_max,
                }
            }
            other => {
                return Err(ConfigError::Value {
                    name: "range",
                    why: format!("{other:?} is not one of from_above, graspable, bounds"),
                })
            }
        };
        if !(self.friction_safety_factor.is_finite() && self.friction_safety_factor >= 1.0) {
            return Err(ConfigError::Value {
                name: "friction_safety_factor",
                why: format!("must be >= 1, got {}", self.friction_safety_factor),
            });
        }
        if !(1..=100_000).contains(&self.qos_depth) {
            return Err(ConfigError::Value {
                name: "qos_depth",
                why: format!("must be in 1..=100000, got {}", self.qos_depth),
            });
        }
        Ok(Settings {
            objective,
            range,
            friction_safety_factor: self.friction_safety_factor,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_file_equals_the_defaults() {
        let c = Config::load(None, "grasp_orient").expect("valid");
        assert_eq!(c, Config::default());
        assert_eq!(c.validate().expect("valid"), Settings::default());
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
        assert_eq!(c.objective, "norm1");
        assert_eq!(c.validate().expect("valid").friction_safety_factor, 1.5);
        c.objective = "norm3".into();
        let e = c.validate().expect_err("unknown objective");
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
}
