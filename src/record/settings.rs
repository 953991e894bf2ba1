//! The settings a recording was made with, as MCAP metadata records: the node writes one when
//! a file starts (for every settings version a queued candidate may still be answered with)
//! and one at every parameter change, and `replay` solves each candidate with the settings in
//! force at its `log_time`.
//!
//! A record is named `METADATA_NAME` and holds:
//!
//! | key | value |
//! |---|---|
//! | `since_ns` | from which receive time (ns since the epoch) on the settings apply; `0` for "from the start" |
//! | `node` | the node's full name, e.g. `/arm/grasp_orient` |
//! | `reason` | why it was written, e.g. `start` or `parameter objective set` |
//! | `parameters` | every parameter of the table (`src/config/params.rs`) as a ROS 2 params file (`/**: ros__parameters: ...`) |
//! | `version` | the grasp_orient version that wrote it |
//!
//! Every parameter is recorded, so a parameter added to the table later is recorded with no
//! code here, and a recording's `parameters` text can be given to `--params-file` as it is.

use crate::config::{Config, ConfigError};
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;

/// The name of the metadata records that carry settings.
pub(crate) const METADATA_NAME: &str = "grasp_orient.settings";

/// The settings in force from one time on.
#[derive(Debug, Clone, PartialEq)]
pub struct SettingsRecord {
    /// Receive time (ns since the epoch) from which they apply; 0 for "from the start".
    pub since: u64,
    /// The node's full name.
    pub node: String,
    /// Why they were written.
    pub reason: String,
    /// Every parameter.
    pub config: Config,
}

/// Why a settings record cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SettingsError {
    /// A key is missing or malformed.
    #[error("settings metadata: {0}")]
    Malformed(String),
    /// The parameters do not read (a parameter this version does not know, a bad value).
    #[error("settings metadata of {node} (since {since} ns): {source}")]
    Parameters {
        /// The node.
        node: String,
        /// From when.
        since: u64,
        /// The cause.
        source: ConfigError,
    },
}

/// Every parameter of `config` as a ROS 2 params file for all nodes.
pub(crate) fn params_file(config: &Config) -> String {
    let parameters: Mapping = config
        .parameters()
        .into_iter()
        .map(|(name, value)| (Value::String(name.to_string()), value))
        .collect();
    let mut node = Mapping::new();
    node.insert("ros__parameters".into(), Value::Mapping(parameters));
    let mut doc = Mapping::new();
    doc.insert("/**".into(), Value::Mapping(node));
    // A mapping of strings, booleans and numbers always serialises.
    serde_yaml_ng::to_string(&Value::Mapping(doc)).unwrap_or_default()
}

impl SettingsRecord {
    /// The entries of its metadata record.
    pub(crate) fn to_metadata(&self) -> BTreeMap<String, String> {
        BTreeMap::from([
            ("since_ns".to_string(), self.since.to_string()),
            ("node".to_string(), self.node.clone()),
            ("reason".to_string(), self.reason.clone()),
            ("parameters".to_string(), params_file(&self.config)),
            ("version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ])
    }

    /// Reads the entries of a metadata record named [`METADATA_NAME`].
    pub(crate) fn from_metadata(entries: &BTreeMap<String, String>) -> Result<Self, SettingsError> {
        let get = |key: &str| {
            entries
                .get(key)
                .ok_or_else(|| SettingsError::Malformed(format!("no {key}")))
        };
        let since = get("since_ns")?
            .parse::<u64>()
            .map_err(|e| SettingsError::Malformed(format!("since_ns: {e}")))?;
        let node = get("node")?.clone();
        let mut config = Config::default();
        config
            .merge_yaml(get("parameters")?, "the recorded parameters", &node)
            .and_then(|_sections| config.solver_settings().map(|_| ()))
            .map_err(|source| SettingsError::Parameters {
                node: node.clone(),
                since,
                source,
            })?;
        Ok(Self {
            since,
            node,
            reason: entries.get("reason").cloned().unwrap_or_default(),
            config,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RangeKind;
    use crate::solver::Objective;

    #[test]
    fn every_parameter_survives_the_metadata_exactly() {
        let config = Config {
            objective: Objective::Norm1,
            range: RangeKind::Bounds,
            range_min: -0.1 - std::f64::consts::PI / 7.0,
            range_max: 1.0 / 3.0,
            friction_safety_factor: 1.5,
            record_dir: "runs: with 'quotes'".into(),
            center_of_mass_tolerance: [0.01, 1.0 / 3.0, 0.0],
            mass_tolerance: 0.1,
            ..Config::default()
        };
        let record = SettingsRecord {
            since: 1_795_326_000_123_456_789,
            node: "/arm/grasp_orient".into(),
            reason: "parameter objective set".into(),
            config,
        };
        let entries = record.to_metadata();
        assert!(entries["parameters"].starts_with("/**:\n  ros__parameters:\n"));
        for (name, _) in record.config.parameters() {
            assert!(
                // A list (center_of_mass_tolerance) follows on the next lines.
                entries["parameters"].contains(&format!("    {name}:")),
                "{name}"
            );
        }
        assert_eq!(
            SettingsRecord::from_metadata(&entries).expect("reads"),
            record
        );
    }

    #[test]
    fn unknown_and_invalid_parameters_are_refused_by_name() {
        let mut entries = SettingsRecord {
            since: 0,
            node: "/grasp_orient".into(),
            reason: "start".into(),
            config: Config::default(),
        }
        .to_metadata();
        let with = |text: &str| {
            let mut e = entries.clone();
            e.insert("parameters".into(), text.into());
            SettingsRecord::from_metadata(&e)
                .expect_err("refused")
                .to_string()
        };
        let e = with("/**:\n  ros__parameters:\n    gripper_drive: parallel\n");
        assert!(e.contains("gripper_drive"), "{e}");
        let e = with("/**:\n  ros__parameters:\n    friction_safety_factor: 0.5\n");
        assert!(e.contains("friction_safety_factor"), "{e}");
        entries.remove("since_ns");
        assert!(SettingsRecord::from_metadata(&entries).is_err());
    }
}
