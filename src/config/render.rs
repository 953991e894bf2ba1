//! What is written from the parameter table ([`PARAMETERS`]): the params file
//! `config/grasp_orient.yaml`, the parameter list of `node --help`, and the parameter table of
//! `docs/node.md`. Tests keep the shipped file and that table equal to what is generated here;
//! `GRASP_ORIENT_REGENERATE=1 cargo test --lib config` rewrites both.

use super::{Config, Domain, Parameter, PARAMETERS};
use serde_yaml_ng::Value;

/// Width of generated comment and help text.
const WIDTH: usize = 100;

/// A value as it is written in YAML (and on the command line after `-p name:=`).
fn yaml(value: &Value) -> String {
    if let Value::Sequence(items) = value {
        // Flow style, on one line: `[0.0, 0.0, 0.0]`.
        let items: Vec<String> = items.iter().map(yaml).collect();
        return format!("[{}]", items.join(", "));
    }
    serde_yaml_ng::to_string(value)
        .map(|s| s.trim_end().to_string())
        .unwrap_or_default()
}

/// Every parameter with its default value as YAML text.
fn with_defaults() -> impl Iterator<Item = (&'static Parameter, String)> {
    PARAMETERS
        .iter()
        .zip(Config::default().parameters())
        .map(|(p, (_, value))| (p, yaml(&value)))
}

#[cfg(test)]
/// Unit, domain and fixedness as sentences ("Unit: rad. Domain: >= 1. Fixed while the node
/// runs."); empty when there is nothing to say.
pub(crate) fn facts(p: &Parameter) -> String {
    let mut facts = Vec::new();
    if !p.unit.is_empty() {
        facts.push(format!("Unit: {}.", p.unit));
    }
    if p.domain != Domain::Any {
        facts.push(format!("Domain: {}.", p.domain));
    }
    if p.fixed {
        facts.push("Fixed while the node runs.".to_string());
    }
    facts.join(" ")
}

/// `text` in lines of at most [`WIDTH`] characters, each starting with `prefix`.
fn wrap(text: &str, prefix: &str) -> String {
    let mut out = String::new();
    let mut line = String::from(prefix);
    for word in text.split_whitespace() {
        let empty = line.len() == prefix.len();
        if !empty && line.len() + 1 + word.len() > WIDTH {
            out.push_str(&line);
            out.push('\n');
            line = String::from(prefix);
        } else if !empty {
            line.push(' ');
        }
        line.push_str(word);
    }
    out.push_str(&line);
    out.push('\n');
    out
}

#[cfg(test)]
/// The params file: every parameter with its default, each under its doc line.
pub(crate) fn params_file() -> String {
    let mut out = String::from(
        "# grasp_orient parameters, in the ROS 2 params-file form (ros2 run ... --ros-args \
         --params-file).\n# This file is also compiled into the binary as its default. It is \
         generated from the table in\n# src/config/params.rs: GRASP_ORIENT_REGENERATE=1 cargo \
         test --lib config rewrites it.\ngrasp_orient:\n  ros__parameters:\n",
    );
    for (p, default) in with_defaults() {
        let doc = format!("{} {}", p.summary(), facts(p));
        out.push_str(&wrap(&doc, "    # "));
        out.push_str(&format!("    {}: {default}\n", p.name));
    }
    out
}

/// The parameter list for `node --help`.
pub(crate) fn help() -> String {
    let mut out = String::from(
        "Parameters (--ros-args -p NAME:=VALUE or --params-file FILE; ros2 param set while it \
         runs):\n",
    );
    for (p, default) in with_defaults() {
        let unit = if p.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", p.unit)
        };
        let mut kind = p.ros_type.name().to_string();
        if p.domain != Domain::Any {
            kind.push_str(&format!("; {}", p.domain));
        }
        if p.fixed {
            kind.push_str("; fixed while the node runs");
        }
        out.push_str(&format!("  {} = {default}{unit}  ({kind})\n", p.name));
        out.push_str(&wrap(p.summary(), "      "));
    }
    out
}

#[cfg(test)]
/// The parameter table of `docs/node.md`, in Markdown.
pub(crate) fn markdown_table() -> String {
    let mut out = String::from(
        "| parameter | type | default | unit | domain | what it does |\n|---|---|---|---|---|---|\n",
    );
    for (p, default) in with_defaults() {
        let mut domain = match p.domain {
            Domain::Choices(names) => format!(
                "one of {}",
                names
                    .iter()
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            other => other.to_string(),
        };
        if p.fixed {
            domain.push_str("; fixed while the node runs");
        }
        out.push_str(&format!(
            "| `{}` | {} | `{default}` | {} | {domain} | {} |\n",
            p.name,
            p.ros_type.name(),
            p.unit,
            p.summary()
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::DEFAULT_YAML;
    use super::*;
    use std::path::Path;

    /// The first line of the generated table in `docs/node.md`, and the line after it.
    const TABLE_START: &str =
        "<!-- parameters: generated from src/config/params.rs (GRASP_ORIENT_REGENERATE=1 cargo test --lib config) -->\n";
    const TABLE_END: &str = "<!-- end of parameters -->";

    fn regenerate() -> bool {
        std::env::var("GRASP_ORIENT_REGENERATE").is_ok_and(|v| v == "1")
    }

    fn repo(path: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
    }

    #[test]
    fn shipped_params_file_is_the_generated_one() {
        let generated = params_file();
        if regenerate() && DEFAULT_YAML != generated {
            // The compiled-in copy is the old one until the next build.
            std::fs::write(repo("config/grasp_orient.yaml"), &generated).expect("write");
            return;
        }
        assert!(
            DEFAULT_YAML == generated,
            "config/grasp_orient.yaml differs from src/config/params.rs; rewrite it with \
             GRASP_ORIENT_REGENERATE=1 cargo test --lib config. Generated:\n{generated}"
        );
    }

    #[test]
    fn node_doc_table_is_the_generated_one() {
        let path = repo("docs/node.md");
        let text = std::fs::read_to_string(&path).expect("docs/node.md");
        let start = text
            .find(TABLE_START)
            .expect("docs/node.md marks its table")
            + TABLE_START.len();
        let end = start
            + text[start..]
                .find(TABLE_END)
                .expect("docs/node.md ends its table");
        let generated = markdown_table();
        if regenerate() && text[start..end] != generated {
            let new = format!("{}{generated}{}", &text[..start], &text[end..]);
            std::fs::write(&path, new).expect("write");
            return;
        }
        assert_eq!(
            text[start..end],
            generated,
            "docs/node.md's parameter table differs from src/config/params.rs; rewrite it with \
             GRASP_ORIENT_REGENERATE=1 cargo test --lib config"
        );
    }

    #[test]
    fn help_names_every_parameter_with_default_and_domain() {
        let help = help();
        for p in PARAMETERS {
            assert!(help.contains(&format!("  {} = ", p.name)), "{}", p.name);
        }
        assert!(help.contains("qos_depth = 100 messages  (integer; in 1..=100000; fixed"));
        assert!(help.contains("objective = norm2  (string; one of norm2, norm1, internal_force)"));
    }

    #[test]
    fn every_default_lies_in_its_domain() {
        let c = Config::default();
        c.solver_settings().expect("the defaults are valid");
        for (p, (name, value)) in PARAMETERS.iter().zip(c.parameters()) {
            assert_eq!(p.name, name);
            let mut again = Config::default();
            again.set_value(name, value).expect("a default reads back");
            assert_eq!(again, c, "{name}");
        }
    }
}
