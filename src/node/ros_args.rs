//! The `--ros-args` that `ros2 run` and launch files pass to a node, since ros2-client reads no
//! command line: `-r/--remap from:=to` (with `__node`, `__ns`), `-p/--param name:=value`,
//! `--params-file FILE`, and `--log-level LEVEL`; other rcl arguments are skipped with a warning.

use std::path::PathBuf;

/// Parsed ROS arguments.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RosArgs {
    /// `-r __node:=NAME`.
    pub node_name: Option<String>,
    /// `-r __ns:=/NS`.
    pub namespace: Option<String>,
    /// `-r from:=to` for topics, in order.
    pub remaps: Vec<(String, String)>,
    /// `-p name:=value`, the value as YAML text.
    pub params: Vec<(String, String)>,
    /// `--params-file FILE`, in order.
    pub params_files: Vec<PathBuf>,
    /// `--log-level LEVEL` (logger `None`: the default level) and `--log-level NAME:=LEVEL`
    /// (one logger), in order.
    pub log_levels: Vec<(Option<String>, LogLevel)>,
}

/// A ROS log level, as `--log-level` takes it (any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    /// `debug`.
    Debug,
    /// `info`.
    Info,
    /// `warn` (or `warning`).
    Warn,
    /// `error`.
    Error,
    /// `fatal`: only fatal messages, which grasp_orient never logs (errors that end a command
    /// are printed by the command itself).
    Fatal,
    /// `unset`: the logger follows the default level.
    Unset,
}

impl LogLevel {
    /// The level names rcl accepts (the tests parse each).
    #[cfg(test)]
    pub const NAMES: [&'static str; 6] = ["debug", "info", "warn", "error", "fatal", "unset"];

    /// The Rust log filter it stands for; `None` for `unset`.
    pub fn filter(self) -> Option<log::LevelFilter> {
        Some(match self {
            LogLevel::Debug => log::LevelFilter::Debug,
            LogLevel::Info => log::LevelFilter::Info,
            LogLevel::Warn => log::LevelFilter::Warn,
            LogLevel::Error => log::LevelFilter::Error,
            LogLevel::Fatal => log::LevelFilter::Off,
            LogLevel::Unset => return None,
        })
    }
}

impl std::str::FromStr for LogLevel {
    type Err = RosArgsError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "debug" => LogLevel::Debug,
            "info" => LogLevel::Info,
            "warn" | "warning" => LogLevel::Warn,
            "error" => LogLevel::Error,
            "fatal" => LogLevel::Fatal,
            "unset" => LogLevel::Unset,
            _ => return Err(RosArgsError::LogLevel(s.to_string())),
        })
    }
}

/// A malformed ROS argument.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RosArgsError {
    /// A flag without its value.
    #[error("--ros-args: {flag} needs a value")]
    MissingValue {
        /// The flag.
        flag: String,
    },
    /// A `from:=to` or `name:=value` without `:=`.
    #[error("--ros-args: {flag} {value:?} is not of the form a:=b")]
    NotAssignment {
        /// The flag.
        flag: String,
        /// What was given.
        value: String,
    },
    /// A log level rcl does not know.
    #[error("--ros-args: --log-level {0:?} is not one of debug, info, warn, error, fatal, unset (or NAME:=LEVEL)")]
    LogLevel(String),
    /// A namespace that is not absolute.
    #[error("--ros-args: namespace {0:?} must start with '/'")]
    RelativeNamespace(String),
}

impl RosArgs {
    /// Parses everything after `--ros-args` (up to a lone `--`).
    pub fn parse(args: &[String]) -> Result<Self, RosArgsError> {
        let mut out = RosArgs::default();
        let mut it = args.iter();
        let value = |it: &mut std::slice::Iter<'_, String>, flag: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| RosArgsError::MissingValue {
                    flag: flag.to_string(),
                })
        };
        let assignment = |flag: &str, v: &str| {
            v.split_once(":=")
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .ok_or_else(|| RosArgsError::NotAssignment {
                    flag: flag.to_string(),
                    value: v.to_string(),
                })
        };
        while let Some(arg) = it.next() {
            match arg.as_str() {
                "--ros-args" => {}
                "--" => break,
                "-r" | "--remap" => {
                    let v = value(&mut it, arg)?;
                    let (from, to) = assignment(arg, &v)?;
                    // A "node:from" prefix targets one node; this process has one.
                    let from = from.rsplit_once(':').map_or(from.as_str(), |(_, f)| f);
                    match from {
                        "__node" | "__name" => out.node_name = Some(to),
                        "__ns" => {
                            if !to.starts_with('/') {
                                return Err(RosArgsError::RelativeNamespace(to));
                            }
                            out.namespace = Some(to);
                        }
                        _ => out.remaps.push((from.to_string(), to)),
                    }
                }
                "-p" | "--param" => {
                    let v = value(&mut it, arg)?;
                    out.params.push(assignment(arg, &v)?);
                }
                "--params-file" => out.params_files.push(value(&mut it, arg)?.into()),
                "--log-level" => {
                    let v = value(&mut it, arg)?;
                    out.log_levels.push(match v.split_once(":=") {
                        // ROS logger names use dots where Rust's module paths use `::`.
                        Some((name, level)) => (Some(name.replace('.', "::")), level.parse()?),
                        None => (None, v.parse()?),
                    });
                }
                "--enclave" | "-e" | "--log-config-file" | "--log-file-name" => {
                    value(&mut it, arg)?;
                    log::warn!("--ros-args: {arg} is not supported and is ignored");
                }
                other => log::warn!("--ros-args: {other} is not supported and is ignored"),
            }
        }
        Ok(out)
    }

    /// The namespace, `/` by default, without a trailing slash.
    pub fn namespace(&self) -> String {
        match self.namespace.as_deref() {
            None | Some("/") => "/".to_string(),
            Some(ns) => ns.trim_end_matches('/').to_string(),
        }
    }

    /// The absolute topic name for `name` after remapping: relative names resolve in the
    /// namespace, `~/x` in the node's private namespace, and a remap applies when its left side
    /// is the name as written or its resolved form.
    pub fn topic(&self, name: &str, node: &str) -> String {
        let ns = self.namespace();
        let resolved = resolve(name, &ns, node);
        for (from, to) in &self.remaps {
            if from == name || resolve(from, &ns, node) == resolved {
                return resolve(to, &ns, node);
            }
        }
        resolved
    }
}

/// `name` made absolute in namespace `ns` for node `node`.
fn resolve(name: &str, ns: &str, node: &str) -> String {
    let base = if ns == "/" { "" } else { ns };
    if name.starts_with('/') {
        name.to_string()
    } else if let Some(private) = name.strip_prefix("~/") {
        format!("{base}/{node}/{private}")
    } else {
        format!("{base}/{name}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(text: &str) -> Vec<String> {
        text.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn launch_style_arguments() {
        let a = RosArgs::parse(&args(
            "--ros-args -r __node:=gripper -r __ns:=/robot1 --params-file /tmp/p.yaml \
             -p objective:=norm1 -r grasp_candidates:=/cands --log-level debug",
        ))
        .expect("valid");
        assert_eq!(a.node_name.as_deref(), Some("gripper"));
        assert_eq!(a.namespace(), "/robot1");
        assert_eq!(a.params, vec![("objective".into(), "norm1".into())]);
        assert_eq!(a.params_files, vec![PathBuf::from("/tmp/p.yaml")]);
        assert_eq!(a.log_levels, vec![(None, LogLevel::Debug)]);
        assert_eq!(a.topic("grasp_candidates", "gripper"), "/cands");
        assert_eq!(
            a.topic("grip_recommendations", "gripper"),
            "/robot1/grip_recommendations"
        );
        assert_eq!(a.topic("~/status", "gripper"), "/robot1/gripper/status");
    }

    #[test]
    fn every_ros_log_level_and_one_logger_at_a_time() {
        for name in LogLevel::NAMES {
            let a = RosArgs::parse(&args(&format!("--log-level {name}"))).expect("a level");
            assert_eq!(a.log_levels.len(), 1, "{name}");
        }
        let a = RosArgs::parse(&args(
            "--log-level FATAL --log-level grasp_orient.node:=debug --log-level rustdds:=warn",
        ))
        .expect("valid");
        assert_eq!(
            a.log_levels,
            vec![
                (None, LogLevel::Fatal),
                (Some("grasp_orient::node".into()), LogLevel::Debug),
                (Some("rustdds".into()), LogLevel::Warn),
            ]
        );
        assert_eq!(LogLevel::Fatal.filter(), Some(log::LevelFilter::Off));
        assert_eq!(LogLevel::Unset.filter(), None);
        assert!(matches!(
            RosArgs::parse(&args("--log-level loud")),
            Err(RosArgsError::LogLevel(_))
        ));
        assert!(RosArgs::parse(&args("--log-level grasp_orient:=loud")).is_err());
    }

    #[test]
    fn root_namespace_gives_single_slash_names() {
        let a = RosArgs::parse(&[]).expect("valid");
        assert_eq!(a.topic("grip_markers", "grasp_orient"), "/grip_markers");
        let a = RosArgs::parse(&args("-r /grip_markers:=viz")).expect("valid");
        assert_eq!(a.topic("grip_markers", "grasp_orient"), "/viz");
    }

    #[test]
    fn malformed_arguments_are_named() {
        assert!(matches!(
            RosArgs::parse(&args("-p objective")),
            Err(RosArgsError::NotAssignment { .. })
        ));
        assert!(matches!(
            RosArgs::parse(&args("--params-file")),
            Err(RosArgsError::MissingValue { .. })
        ));
        assert!(matches!(
            RosArgs::parse(&args("-r __ns:=robot")),
            Err(RosArgsError::RelativeNamespace(_))
        ));
    }
}
