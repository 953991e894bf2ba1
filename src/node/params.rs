//! The node's ROS parameters: the fields of [`Config`], declared with their values, validated as
//! a whole on every set, shared with the answering loop, and described from their declarations
//! ([`crate::config::PARAMETERS`]).

use crate::answer::{Answering, PoseAnswerer};
use crate::config::{Config, ConfigError, Domain, Parameter, RosType};
use crate::solver::Settings;
use ros2_client::parameters::{
    raw, NumericRange, ParameterDescriptor, ParameterType, SetParametersResult,
};
use ros2_client::{NodeOptions, ParameterValue};
use serde_yaml_ng::Value;
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

/// A parameter hook as ros2-client takes it: `Err(reason)` refuses the value, the reason being
/// a [`ParameterRefused`] in words (ros2-client's `SetParametersResult`).
pub(super) type ParameterHook =
    Box<dyn Fn(&str, &ParameterValue) -> SetParametersResult + Send + Sync>;

/// Why a parameter set is refused; its words are the reason ROS clients are given.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum ParameterRefused {
    /// A set to "not set": the node's parameters cannot be deleted.
    #[error("parameter {name} cannot be deleted")]
    Deleted {
        /// The parameter.
        name: String,
    },
    /// A value of a type no parameter has (a byte array, ...).
    #[error("parameter {name}: unsupported value {value}")]
    Unsupported {
        /// The parameter.
        name: String,
        /// The value, as ros2-client prints it.
        value: String,
    },
    /// A parameter that only a restart changes.
    #[error("{name} is fixed while the node runs; restart it with -p {name}:=VALUE")]
    Fixed {
        /// The parameter.
        name: String,
    },
    /// The value, or the settings with it, are refused.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A parameter the node does not declare.
    #[error("Setting undeclared parameter '{name}' is not allowed.")]
    Undeclared {
        /// The parameter.
        name: String,
    },
    /// A value of another type than the parameter's.
    #[error("Cannot change type of parameter '{name}' from {from} to {to}.")]
    TypeChange {
        /// The parameter.
        name: String,
        /// Its type, as ros2-client prints it.
        from: String,
        /// The value's type, likewise.
        to: String,
    },
    /// `use_sim_time` set to anything but a boolean.
    #[error("Parameter '{name}' must be Boolean.")]
    NotBoolean {
        /// The parameter.
        name: String,
    },
}

/// The parameters as they were from one time on.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Version {
    /// Counts the versions, from 0 for the start.
    pub(crate) seq: u64,
    /// From which receive time (ns since the epoch) on they apply; 0 for the start.
    pub(crate) since: u64,
    /// The parameter whose set made this version; `None` for the start.
    pub(crate) changed: Option<String>,
    /// Every parameter.
    pub(crate) config: Config,
    /// The solver settings they imply.
    pub(crate) settings: Settings,
}

impl Version {
    /// What answers with these parameters: their settings and gripper rules, pose candidates
    /// closing along their `closing_axis`, on the node's `meshes`.
    pub(crate) fn answering(&self, meshes: &Arc<grasp_orient_geometry::MeshCache>) -> Answering {
        let poses = PoseAnswerer::sharing(self.config.closing_axis, meshes.clone());
        Answering::new(self.settings, self.config.rules(), poses)
    }
}

/// How many versions are kept for candidates received before a change and answered after it.
const VERSIONS_KEPT: usize = 32;

/// The parameters that say what is recorded where: a set of one of them, even to its current
/// value, makes the recording follow them at once (setting `record` to true again retries).
pub(super) const RECORDING_PARAMETERS: [&str; 3] = ["record", "record_dir", "record_markers"];

/// The settings the answering loop reads, kept in step with the parameters.
#[derive(Debug)]
pub(crate) struct Live {
    /// Every parameter, as now.
    pub(crate) config: Config,
    /// The solver settings they imply.
    pub(crate) settings: Settings,
    /// The recent versions, oldest first; the last is `config` and `settings`.
    versions: std::collections::VecDeque<Version>,
    /// Sets of a [`RECORDING_PARAMETERS`] so far.
    recording_sets: u64,
}

impl Live {
    /// The version in force for a candidate received at `received` (ns since the epoch): the
    /// last one from before it (the oldest kept, for older candidates).
    pub(crate) fn version_at(&self, received: u64) -> &Version {
        let newer = self.versions.partition_point(|v| v.since <= received);
        let index = newer
            .saturating_sub(1)
            .min(self.versions.len().saturating_sub(1));
        &self.versions[index]
    }

    /// The versions after `seq`, oldest first.
    pub(crate) fn versions_after(&self, seq: u64) -> impl Iterator<Item = &Version> {
        self.versions.iter().filter(move |v| v.seq > seq)
    }

    /// Every version kept, oldest first.
    pub(crate) fn versions(&self) -> impl Iterator<Item = &Version> {
        self.versions.iter()
    }

    /// The newest version's number.
    pub(crate) fn last_seq(&self) -> u64 {
        self.versions.back().map_or(0, |v| v.seq)
    }

    /// How many times one of the [`RECORDING_PARAMETERS`] was set.
    pub(crate) fn recording_sets(&self) -> u64 {
        self.recording_sets
    }

    /// A new version from now on.
    fn push(&mut self, changed: &str, config: Config, settings: Settings) {
        let since = crate::record::now_ns().max(self.versions.back().map_or(0, |v| v.since));
        self.versions.push_back(Version {
            seq: self.last_seq() + 1,
            since,
            changed: Some(changed.to_string()),
            config: config.clone(),
            settings,
        });
        while self.versions.len() > VERSIONS_KEPT {
            self.versions.pop_front();
        }
        self.config = config;
        self.settings = settings;
    }
}

/// Called when a parameter was set.
type Wake = Box<dyn Fn() + Send + Sync>;

/// [`Live`] shared between parameter services and the answering loop, and what wakes the loop.
#[derive(Clone)]
pub(crate) struct Shared(Arc<(Mutex<Live>, OnceLock<Wake>)>);

impl std::fmt::Debug for Shared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Shared").field(&self.0 .0).finish()
    }
}

impl Shared {
    /// Shares a validated config, and logs its caveats ([`Config::caveats`]) as warnings.
    pub(crate) fn new(config: Config, settings: Settings) -> Self {
        for caveat in config.caveats() {
            log::warn!("{caveat}");
        }
        let start = Version {
            seq: 0,
            since: 0,
            changed: None,
            config: config.clone(),
            settings,
        };
        Self(Arc::new((
            Mutex::new(Live {
                config,
                settings,
                versions: [start].into(),
                recording_sets: 0,
            }),
            OnceLock::new(),
        )))
    }

    /// Calls `wake` after every accepted set (the first call sets it; later ones are ignored).
    pub(crate) fn wake_on_change(&self, wake: impl Fn() + Send + Sync + 'static) {
        self.0 .1.set(Box::new(wake)).ok();
    }

    /// The current settings (a poisoned lock still holds valid settings: sets are atomic).
    pub(crate) fn lock(&self) -> MutexGuard<'_, Live> {
        self.0 .0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether `name := value` would be accepted, and the config it would give.
    pub(crate) fn check(
        &self,
        name: &str,
        value: &ParameterValue,
    ) -> Result<(Config, Settings), ParameterRefused> {
        let live = self.lock();
        let value = to_yaml(value).ok_or_else(|| match value {
            ParameterValue::NotSet => ParameterRefused::Deleted {
                name: name.to_string(),
            },
            other => ParameterRefused::Unsupported {
                name: name.to_string(),
                value: format!("{other:?}"),
            },
        })?;
        let current = live
            .config
            .parameters()
            .into_iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v);
        let fixed = Parameter::find(name).is_some_and(|p| p.fixed);
        if fixed && current.as_ref() != Some(&value) {
            return Err(ParameterRefused::Fixed {
                name: name.to_string(),
            });
        }
        let mut config = live.config.clone();
        config.set_value(name, value)?;
        let settings = config.solver_settings()?;
        Ok((config, settings))
    }

    /// Node options that declare every parameter with its current value and validate every set
    /// through this.
    pub(crate) fn declare(&self, options: NodeOptions) -> NodeOptions {
        let mut options = options
            .parameter_validator(self.validator())
            .parameter_set_action(self.set_action());
        for (p, (name, value)) in crate::config::PARAMETERS
            .iter()
            .zip(self.lock().config.parameters())
        {
            if let Some(v) = from_yaml_as(&value, p.ros_type) {
                options = options.declare_parameter(name, v);
            }
        }
        options
    }

    /// The validator handed to ros2-client: refuses with a reason, keeping the old value.
    pub(crate) fn validator(&self) -> ParameterHook {
        let shared = self.clone();
        Box::new(move |name, value| {
            shared
                .check(name, value)
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
    }

    /// The set action handed to ros2-client: a change makes a new [`Version`], in force for
    /// candidates received from now on, and the answering loop is woken to act on it at once.
    pub(crate) fn set_action(&self) -> ParameterHook {
        let shared = self.clone();
        Box::new(move |name, value| {
            let (config, settings) = shared.check(name, value).map_err(|e| e.to_string())?;
            {
                let mut live = shared.lock();
                if live.config != config {
                    log::info!("parameter {name} set to {value:?}");
                    if config.caveats() != live.config.caveats() {
                        for caveat in config.caveats() {
                            log::warn!("{caveat}");
                        }
                    }
                    live.push(name, config, settings);
                }
                if RECORDING_PARAMETERS.contains(&name) {
                    live.recording_sets += 1;
                }
            }
            if let Some(wake) = shared.0 .1.get() {
                wake();
            }
            Ok(())
        })
    }
}

/// A parameter value as YAML; `None` for deletion and for types the config has none of.
pub(super) fn to_yaml(value: &ParameterValue) -> Option<Value> {
    Some(match value {
        ParameterValue::Boolean(b) => Value::Bool(*b),
        ParameterValue::Integer(i) => Value::Number((*i).into()),
        ParameterValue::Double(d) => Value::Number((*d).into()),
        ParameterValue::String(s) => Value::String(s.clone()),
        ParameterValue::DoubleArray(a) => {
            Value::Sequence(a.iter().map(|d| Value::Number((*d).into())).collect())
        }
        ParameterValue::StringArray(a) => {
            Value::Sequence(a.iter().cloned().map(Value::String).collect())
        }
        _ => return None,
    })
}

/// A YAML value as a parameter value.
pub(super) fn from_yaml(value: &Value) -> Option<ParameterValue> {
    Some(match value {
        Value::Bool(b) => ParameterValue::Boolean(*b),
        Value::Number(n) if n.is_i64() => ParameterValue::Integer(n.as_i64()?),
        Value::Number(n) => ParameterValue::Double(n.as_f64()?),
        Value::String(s) => ParameterValue::String(s.clone()),
        // A list of strings is a string array; any other list (an empty one too) a double array.
        Value::Sequence(items) if !items.is_empty() && items.iter().all(Value::is_string) => {
            ParameterValue::StringArray(
                items
                    .iter()
                    .map(|v| v.as_str().map(str::to_owned))
                    .collect::<Option<Vec<String>>>()?,
            )
        }
        Value::Sequence(items) => ParameterValue::DoubleArray(
            items
                .iter()
                .map(Value::as_f64)
                .collect::<Option<Vec<f64>>>()?,
        ),
        _ => return None,
    })
}

/// A YAML value as a parameter value of a declared type: as [`from_yaml`], but a list (an
/// empty one too) of a string array parameter is a string array.
pub(super) fn from_yaml_as(value: &Value, ros_type: RosType) -> Option<ParameterValue> {
    match (ros_type, value) {
        (RosType::StringArray, Value::Sequence(items)) => Some(ParameterValue::StringArray(
            items
                .iter()
                .map(|v| v.as_str().map(str::to_owned))
                .collect::<Option<Vec<String>>>()?,
        )),
        _ => from_yaml(value),
    }
}

/// The ROS descriptor of a declared parameter: its type, doc and unit, its range, its other
/// constraints in words, and whether it is read-only.
pub(super) fn descriptor(p: &Parameter) -> raw::ParameterDescriptor {
    let description = if p.unit.is_empty() {
        p.summary().to_string()
    } else {
        format!("{} [{}]", p.summary(), p.unit)
    };
    let mut constraints = Vec::new();
    if let Domain::Choices(_) = p.domain {
        constraints.push(p.domain.to_string());
    }
    if p.fixed {
        constraints.push("fixed while the node runs".to_string());
    }
    let range = match p.domain {
        Domain::Integer { min, max } => NumericRange::IntegerRange {
            from_value: min,
            to_value: max,
            step: 0,
        },
        Domain::Real { min, max } => NumericRange::FloatingPointRange {
            from_value: min,
            to_value: max,
            step: 0.0,
        },
        // ROS ranges include their ends: the largest double below the limit.
        Domain::Below { min, limit } => NumericRange::FloatingPointRange {
            from_value: min,
            to_value: limit.next_down(),
            step: 0.0,
        },
        Domain::Any | Domain::Choices(_) => NumericRange::NotSpecified,
    };
    ParameterDescriptor {
        name: p.name.to_string(),
        param_type: match p.ros_type {
            RosType::Bool => ParameterType::Bool,
            RosType::Integer => ParameterType::Integer,
            RosType::Double => ParameterType::Double,
            RosType::String => ParameterType::String,
            RosType::DoubleArray => ParameterType::DoubleArray,
            RosType::StringArray => ParameterType::StringArray,
        },
        description,
        additional_constraints: constraints.join("; "),
        read_only: p.fixed,
        dynamic_typing: false,
        range,
    }
    .into()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shared() -> Shared {
        let config = Config::default();
        let settings = config.solver_settings().expect("defaults are valid");
        Shared::new(config, settings)
    }

    #[test]
    fn valid_sets_apply_and_invalid_ones_keep_the_old_value() {
        let s = shared();
        let set = s.set_action();
        let check = s.validator();
        assert!(set("objective", &ParameterValue::String("norm1".into())).is_ok());
        assert_eq!(s.lock().settings.objective, crate::solver::Objective::Norm1);
        let why = check("objective", &ParameterValue::String("norm3".into()))
            .expect_err("unknown objective");
        assert!(why.contains("norm3"), "{why}");
        let why =
            check("friction_safety_factor", &ParameterValue::Double(0.5)).expect_err("below one");
        assert!(why.contains("friction_safety_factor"), "{why}");
        assert!(check("qos_depth", &ParameterValue::Integer(7)).is_err());
        assert!(check("qos_depth", &ParameterValue::Integer(100)).is_ok());
        assert!(check("objective", &ParameterValue::NotSet).is_err());
        // What every candidate would be refused for is refused when set.
        let why = check(
            "center_of_mass_tolerance",
            &ParameterValue::DoubleArray(vec![0.0, 1e6, 0.0]),
        )
        .expect_err("a box no candidate takes");
        assert_eq!(
            why,
            "parameter center_of_mass_tolerance: y: must be in [0, 1e6), got 1e6"
        );
        assert!(check("mass_tolerance", &ParameterValue::Double(1e9)).is_err());
        assert_eq!(s.lock().config.objective, crate::solver::Objective::Norm1);
    }

    /// A refusal names what is wrong in its type, and its words are those ROS clients have
    /// always been given.
    #[test]
    fn refusals_are_typed_and_keep_their_words() {
        let s = shared();
        let deleted = s
            .check("objective", &ParameterValue::NotSet)
            .expect_err("parameters are not deleted");
        assert!(matches!(&deleted, ParameterRefused::Deleted { name } if name == "objective"));
        assert_eq!(deleted.to_string(), "parameter objective cannot be deleted");
        let fixed = s
            .check("qos_depth", &ParameterValue::Integer(7))
            .expect_err("fixed while running");
        assert!(matches!(&fixed, ParameterRefused::Fixed { name } if name == "qos_depth"));
        assert_eq!(
            fixed.to_string(),
            "qos_depth is fixed while the node runs; restart it with -p qos_depth:=VALUE"
        );
        let below = s
            .check("friction_safety_factor", &ParameterValue::Double(0.5))
            .expect_err("below one");
        assert!(matches!(below, ParameterRefused::Config(_)));
    }

    #[test]
    fn every_parameter_has_a_ros_type() {
        for (declared, (name, value)) in crate::config::PARAMETERS
            .iter()
            .zip(Config::default().parameters())
        {
            let p = from_yaml_as(&value, declared.ros_type)
                .unwrap_or_else(|| panic!("{name} has no ROS type"));
            assert_eq!(to_yaml(&p).as_ref(), Some(&value), "{name}");
        }
    }

    #[test]
    fn descriptors_state_type_doc_range_and_fixedness() {
        for (p, (name, value)) in crate::config::PARAMETERS
            .iter()
            .zip(Config::default().parameters())
        {
            let d = descriptor(p);
            assert_eq!(d.name, name);
            let declared = from_yaml_as(&value, p.ros_type).expect("a ROS value");
            assert_eq!(
                d.r#type,
                ParameterValue::to_parameter_type_raw(&declared),
                "{name}"
            );
            assert!(d.description.starts_with(p.summary()), "{name}");
        }
        let find = |name| descriptor(Parameter::find(name).expect("declared"));
        let q = find("qos_depth");
        assert!(q.read_only && q.description.ends_with("[messages]"));
        assert_eq!(
            (q.integer_range[0].from_value, q.integer_range[0].to_value),
            (1, 100_000)
        );
        let t = find("center_of_mass_tolerance");
        assert_eq!(
            t.floating_point_range[0].to_value,
            crate::solver::MAX_COORDINATE.next_down()
        );
        let s = find("friction_safety_factor");
        assert_eq!(s.floating_point_range[0].from_value, 1.0);
        assert!(!s.read_only && s.integer_range.is_empty());
        let o = find("objective");
        assert_eq!(
            o.additional_constraints,
            "one of norm2, norm1, internal_force"
        );
    }
}
