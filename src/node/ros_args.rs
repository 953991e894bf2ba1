//! The `--ros-args` that `ros2 run` and launch files pass to a node, since ros2-client reads no
//! command line: `-r/--remap from:=to` (with `__node`, `__ns`), `-p/--param name:=value`,
//! `--params-file FILE`, and `--log-level LEVEL`; other rcl arguments are skipped with a warning.

use std::path::PathBuf;

/// Parsed ROS arguments.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct RosArgs {
    /// `-r __node:=NAME`.
    pub(crate) node_name: Option<String>,
    /// `-r __ns:=/NS`.
    pub(crate) namespace: Option<String>,
    /// `-r from:=to` for topics, in order.
    pub(crate) remaps: Vec<(String, String)>,
    /// `-p name:=value`, the value as YAML text.
    pub(crate) params: Vec<(String, String)>,
    /// `--params-file FILE`, in order.
    pub(crate) params_files: Vec<PathBuf>,
    /// `--log-level LEVEL` (logger `None`: the default level) and `--log-level NAME:=LEVEL`
    /// (one logger), in order.
    pub(crate) log_levels: Vec<(Option<String>, LogLevel)>,
}

/// A ROS log level, as `--log-level` takes it (any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LogLevel {
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
    pub(crate) const NAMES: [&'static str; 6] =
        ["debug", "info", "warn", "error", "fatal", "unset"];

    /// The Rust log filter it stands for; `None` for `unset`.
    pub(crate) fn filter(self) -> Option<log::LevelFilter> {
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
pub(crate) enum RosArgsError {
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
    /// A remap rule that is not `from:=to` with one `:=` and two non-empty sides.
    #[error("--ros-args: remap {rule:?}: {why}")]
    Remap {
        /// The rule as given.
        rule: String,
        /// What is wrong with it.
        why: NameError,
    },
    /// Two of the node's topics remapped onto one name.
    #[error(
        "--ros-args: topics {first} and {second} are both remapped to {target}; each topic needs \
         a name of its own"
    )]
    SharedTarget {
        /// The first topic, as the node names it.
        first: String,
        /// The second.
        second: String,
        /// The name both resolve to.
        target: String,
    },
}

/// Why a name breaks the ROS 2 naming rules (those of `rmw_validate_full_topic_name`,
/// `rmw_validate_namespace` and `rmw_validate_node_name`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum NameError {
    /// A rule with a `:=` in either side (`a:=b:=c`).
    #[error("has more than one ':='")]
    TwoAssignments,
    /// A side that is empty (`:=x`, `x:=`).
    #[error("the {side} side is empty")]
    Empty {
        /// `left` or `right`.
        side: &'static str,
    },
    /// A character outside `[A-Za-z0-9_/~]`.
    #[error("{name:?} has {character:?} at {index}; names take letters, digits, '_' and '/'")]
    Character {
        /// The name.
        name: String,
        /// The character.
        character: char,
        /// Its byte index in the name.
        index: usize,
    },
    /// A token that starts with a digit.
    #[error("{name:?} has a token starting with a digit")]
    DigitFirst {
        /// The name.
        name: String,
    },
    /// `//`, or a name ending in `/` (other than the namespace `/`).
    #[error("{name:?} has an empty token ('//' or a trailing '/')")]
    EmptyToken {
        /// The name.
        name: String,
    },
    /// A `~` other than a leading `~` or `~/`.
    #[error("{name:?} has '~' other than at its start, followed by '/'")]
    Tilde {
        /// The name.
        name: String,
    },
    /// A namespace that does not start with `/`.
    #[error("namespace {name:?} must start with '/'")]
    RelativeNamespace {
        /// The namespace.
        name: String,
    },
    /// A node name with a `/` or `~`, or longer than 255 bytes.
    #[error("node name {name:?} must be one token of letters, digits and '_', at most 255 bytes")]
    NodeName {
        /// The name.
        name: String,
    },
}

impl RosArgs {
    /// Parses everything after `--ros-args` (up to a lone `--`).
    pub(crate) fn parse(args: &[String]) -> Result<Self, RosArgsError> {
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
                    out.remap(&v, &from, to)?;
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

    /// Applies the remap rule `rule` (`from:=to`, already split) after checking it against
    /// the ROS 2 rules: one `:=`, both sides non-empty, each a valid name; `__ns` an absolute
    /// namespace without a trailing `/`, `__node` a base name.
    fn remap(&mut self, rule: &str, from: &str, to: String) -> Result<(), RosArgsError> {
        let refuse = |why| RosArgsError::Remap {
            rule: rule.to_string(),
            why,
        };
        if to.contains(":=") {
            return Err(refuse(NameError::TwoAssignments));
        }
        // A "node:from" prefix targets one node; this process has one.
        let from = from.rsplit_once(':').map_or(from, |(_, f)| f);
        for (side, text) in [("left", from), ("right", to.as_str())] {
            if text.is_empty() {
                return Err(refuse(NameError::Empty { side }));
            }
        }
        match from {
            "__node" | "__name" => {
                check_node_name(&to).map_err(refuse)?;
                self.node_name = Some(to);
            }
            "__ns" => {
                check_namespace(&to).map_err(refuse)?;
                self.namespace = Some(to);
            }
            _ => {
                check_topic_name(from).map_err(refuse)?;
                check_topic_name(&to).map_err(refuse)?;
                self.remaps.push((from.to_string(), to));
            }
        }
        Ok(())
    }

    /// Checks that the node's topics `bases` (as it names them) resolve to distinct names once
    /// remapped: two of them on one name would leave one without its endpoint.
    pub(crate) fn check_distinct(&self, bases: &[&str], node: &str) -> Result<(), RosArgsError> {
        let resolved: Vec<String> = bases.iter().map(|b| self.topic(b, node)).collect();
        for (i, target) in resolved.iter().enumerate() {
            if let Some(j) = resolved[..i].iter().position(|t| t == target) {
                return Err(RosArgsError::SharedTarget {
                    first: bases[j].to_string(),
                    second: bases[i].to_string(),
                    target: target.clone(),
                });
            }
        }
        Ok(())
    }

    /// The namespace, `/` by default, without a trailing slash.
    pub(crate) fn namespace(&self) -> String {
        match self.namespace.as_deref() {
            None | Some("/") => "/".to_string(),
            Some(ns) => ns.trim_end_matches('/').to_string(),
        }
    }

    /// The absolute topic name for `name` after remapping: relative names resolve in the
    /// namespace, `~/x` in the node's private namespace, and a remap applies when its left side
    /// is the name as written or its resolved form.
    pub(crate) fn topic(&self, name: &str, node: &str) -> String {
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

/// Checks a topic or service name (absolute, relative, `~` or `~/...`) against the ROS 2 rules:
/// tokens of `[A-Za-z0-9_]` not starting with a digit, separated by single `/`, no trailing `/`.
fn check_topic_name(name: &str) -> Result<(), NameError> {
    let rest = match name.strip_prefix('~') {
        Some("") => return Ok(()),
        Some(private) => private.strip_prefix('/').ok_or_else(|| NameError::Tilde {
            name: name.to_string(),
        })?,
        None => name.strip_prefix('/').unwrap_or(name),
    };
    check_tokens(name, rest)
}

/// Checks `tokens`, the part of `name` after its leading `/` or `~/`: one or more tokens of
/// `[A-Za-z0-9_]`, none starting with a digit, separated by single `/`.
fn check_tokens(name: &str, tokens: &str) -> Result<(), NameError> {
    let offset = name.len() - tokens.len();
    for (index, character) in tokens.char_indices() {
        let allowed = character.is_ascii_alphanumeric() || character == '_' || character == '/';
        if character == '~' {
            return Err(NameError::Tilde {
                name: name.to_string(),
            });
        }
        if !allowed {
            return Err(NameError::Character {
                name: name.to_string(),
                character,
                index: offset + index,
            });
        }
    }
    for token in tokens.split('/') {
        match token.bytes().next() {
            None => {
                return Err(NameError::EmptyToken {
                    name: name.to_string(),
                })
            }
            Some(b) if b.is_ascii_digit() => {
                return Err(NameError::DigitFirst {
                    name: name.to_string(),
                })
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// Checks a namespace: `/`, or `/` followed by valid tokens, with no trailing `/`.
fn check_namespace(name: &str) -> Result<(), NameError> {
    match name.strip_prefix('/') {
        None => Err(NameError::RelativeNamespace {
            name: name.to_string(),
        }),
        Some("") => Ok(()),
        Some(tokens) => check_tokens(name, tokens),
    }
}

/// Checks a node's base name: one token of `[A-Za-z0-9_]`, not starting with a digit, at most
/// 255 bytes.
fn check_node_name(name: &str) -> Result<(), NameError> {
    if name.len() > 255 || name.contains(['/', '~']) {
        return Err(NameError::NodeName {
            name: name.to_string(),
        });
    }
    check_tokens(name, name)
}

/// `name` made absolute in namespace `ns` for node `node`.
fn resolve(name: &str, ns: &str, node: &str) -> String {
    let base = if ns == "/" { "" } else { ns };
    if name.starts_with('/') {
        name.to_string()
    } else if name == "~" {
        format!("{base}/{node}")
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
            Err(RosArgsError::Remap {
                why: NameError::RelativeNamespace { .. },
                ..
            })
        ));
    }

    /// The message of the error `text` gives, which must be refused.
    fn refusal(text: &str) -> String {
        RosArgs::parse(&args(text)).expect_err(text).to_string()
    }

    #[test]
    fn remaps_follow_the_ros_2_rules() {
        for (text, message) in [
            (
                "-r :=x",
                "--ros-args: remap \":=x\": the left side is empty",
            ),
            (
                "-r x:=",
                "--ros-args: remap \"x:=\": the right side is empty",
            ),
            (
                "-r a:=b:=c",
                "--ros-args: remap \"a:=b:=c\": has more than one ':='",
            ),
            (
                "-r __ns:=/arm/",
                "--ros-args: remap \"__ns:=/arm/\": \"/arm/\" has an empty token ('//' or a \
                 trailing '/')",
            ),
            (
                "-r __ns:=arm",
                "--ros-args: remap \"__ns:=arm\": namespace \"arm\" must start with '/'",
            ),
            (
                "-r grip_markers:=a//b",
                "--ros-args: remap \"grip_markers:=a//b\": \"a//b\" has an empty token ('//' \
                 or a trailing '/')",
            ),
            (
                "-r grip_markers:=viz/",
                "--ros-args: remap \"grip_markers:=viz/\": \"viz/\" has an empty token ('//' \
                 or a trailing '/')",
            ),
            (
                "-r grip_markers:=/2d",
                "--ros-args: remap \"grip_markers:=/2d\": \"/2d\" has a token starting with a \
                 digit",
            ),
            (
                "-r grip-markers:=x",
                "--ros-args: remap \"grip-markers:=x\": \"grip-markers\" has '-' at 4; names \
                 take letters, digits, '_' and '/'",
            ),
            (
                "-r x:=a~b",
                "--ros-args: remap \"x:=a~b\": \"a~b\" has '~' other than at its start, \
                 followed by '/'",
            ),
            (
                "-r __node:=arm/left",
                "--ros-args: remap \"__node:=arm/left\": node name \"arm/left\" must be one \
                 token of letters, digits and '_', at most 255 bytes",
            ),
            (
                "-r __node:=2arm",
                "--ros-args: remap \"__node:=2arm\": \"2arm\" has a token starting with a digit",
            ),
        ] {
            assert_eq!(refusal(text), message, "{text}");
        }
        let a = RosArgs::parse(&args(
            "-r __ns:=/ -r __node:=arm_2 -r ~/status:=/s -r grasp_orient:/x:=~ -r a/b:=c",
        ))
        .expect("valid");
        assert_eq!(a.namespace(), "/");
        assert_eq!(a.topic("/x", "arm_2"), "/arm_2");
        assert_eq!(a.topic("~/status", "arm_2"), "/s");
        assert_eq!(a.topic("a/b", "arm_2"), "/c");
        let a = RosArgs::parse(&args("-r __ns:=/arm/left")).expect("valid");
        assert_eq!(a.namespace(), "/arm/left");
    }

    #[test]
    fn two_topics_remapped_onto_one_are_refused() {
        let topics = ["grasp_candidates", "grip_recommendations", "grip_markers"];
        let a =
            RosArgs::parse(&args("-r grip_markers:=/arm/out -r __ns:=/arm")).expect("valid rules");
        a.check_distinct(&topics, "grasp_orient")
            .expect("distinct names");
        let a =
            RosArgs::parse(&args("-r grip_markers:=grip_recommendations")).expect("valid rules");
        assert_eq!(
            a.check_distinct(&topics, "grasp_orient")
                .expect_err("shared")
                .to_string(),
            "--ros-args: topics grip_recommendations and grip_markers are both remapped to \
             /grip_recommendations; each topic needs a name of its own"
        );
        let a = RosArgs::parse(&args("-r grasp_candidates:=/a -r grip_recommendations:=/a"))
            .expect("valid rules");
        assert!(a.check_distinct(&topics, "grasp_orient").is_err());
    }
}
