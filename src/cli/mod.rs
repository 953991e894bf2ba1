//! The command line: one `run` per subcommand. It lives in the binary, not in the library's API.

pub mod node;
pub mod play;
pub mod plot;
pub mod rank;
pub mod recover;
pub mod replay;
pub mod solve;

use anyhow::{bail, Context};
use grasp_orient::config::{bounds, params_in_yaml, Config, Parameter, RangeKind};
use grasp_orient::replay::Override;
use grasp_orient::sets::{GripperDrive, Rules};
use grasp_orient::solver::{AllowedRange, Objective, Settings};
use serde_yaml_ng::Value;
use std::path::PathBuf;

/// The answer is "no": `replay` found differences, `recover` lost messages. `main` exits 1 for
/// it, and 2 for every other error, as `diff` and `cmp` do.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Negative(pub String);

/// The exit codes, for the `--help` of the commands that answer yes or no.
pub const EXIT_CODES: &str = "Exit codes (as diff and cmp): 0 same / nothing lost; 1 differences \
found (replay) or messages lost (recover); 2 trouble: bad arguments, an unreadable, damaged or \
cut-short input, an output that cannot be written.";

/// Options shared by the commands that solve: the config file and overrides of its settings.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SolveOptions {
    /// ROS 2 params file to read settings from (`grasp_orient: ros__parameters:`); the
    /// built-in config/grasp_orient.yaml otherwise.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// What to minimise: norm2, norm1 or internal_force.
    #[arg(long)]
    pub objective: Option<String>,
    /// Where the recommendation may lie: from_above, graspable, or LO:HI (gravity-angle bounds
    /// in the paper's object frame, rad).
    #[arg(long, allow_hyphen_values = true)]
    pub range: Option<String>,
    /// Divides both friction coefficients (>= 1; 1 reproduces the paper).
    #[arg(long, value_name = "S")]
    pub friction_safety_factor: Option<f64>,
    /// The most grip force the gripper gives, N (>= 0; 0: no limit). A grasp that needs more
    /// gets status 3.
    #[arg(long, value_name = "N")]
    pub max_grip_force: Option<f64>,
    /// How the fingers are driven, which picks the grip force: coupled (internal_force) or
    /// independent (finger_force).
    #[arg(long, value_name = "DRIVE")]
    pub gripper_drive: Option<String>,
}

impl SolveOptions {
    /// The parameters these options set, in the order they apply: the `--config` file's, then
    /// each flag's. Each name is one of the parameter table's.
    pub fn overrides(&self) -> anyhow::Result<Vec<Override>> {
        let mut out: Vec<Override> = Vec::new();
        if let Some(path) = &self.config {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read --config {}", path.display()))?;
            for (name, value) in params_in_yaml(&text, &path.display().to_string(), "grasp_orient")?
            {
                if Parameter::find(&name).is_none() {
                    bail!("{}: grasp_orient has no parameter {name}", path.display());
                }
                out.push((name, value));
            }
        }
        if let Some(o) = &self.objective {
            o.parse::<Objective>()
                .map_err(|e| anyhow::anyhow!("--objective {e}"))?;
            out.push(("objective".into(), Value::String(o.clone())));
        }
        if let Some(s) = self.friction_safety_factor {
            out.push(("friction_safety_factor".into(), Value::Number(s.into())));
        }
        if let Some(f) = self.max_grip_force {
            out.push(("max_grip_force".into(), Value::Number(f.into())));
        }
        if let Some(d) = &self.gripper_drive {
            d.parse::<GripperDrive>()
                .map_err(|e| anyhow::anyhow!("--gripper-drive {e}"))?;
            out.push(("gripper_drive".into(), Value::String(d.clone())));
        }
        if let Some(r) = &self.range {
            let text = |s: &str| Value::String(s.to_string());
            match parse_range(r)? {
                AllowedRange::FromAbove => out.push(("range".into(), text("from_above"))),
                AllowedRange::Graspable => out.push(("range".into(), text("graspable"))),
                AllowedRange::Bounds { lo, hi } => {
                    out.push(("range".into(), text("bounds")));
                    out.push(("range_min".into(), Value::Number(lo.into())));
                    out.push(("range_max".into(), Value::Number(hi.into())));
                }
            }
        }
        Ok(out)
    }

    /// The built-in config with [`SolveOptions::overrides`] applied, checked.
    pub fn config(&self) -> anyhow::Result<Config> {
        let mut config = Config::load(None, "grasp_orient")?;
        for (name, value) in self.overrides()? {
            config.set_value(&name, value)?;
        }
        config.solver_settings()?;
        Ok(config)
    }

    /// The solver settings of [`SolveOptions::config`].
    pub fn settings(&self) -> anyhow::Result<Settings> {
        Ok(self.config()?.solver_settings()?)
    }

    /// [`SolveOptions::config`], its solver settings and its gripper rules.
    pub fn configured(&self) -> anyhow::Result<(Config, Settings, Rules)> {
        let config = self.config()?;
        let settings = config.solver_settings()?;
        let rules = config.rules();
        Ok((config, settings, rules))
    }
}

/// `from_above`, `graspable`, or `LO:HI` bounds in rad.
fn parse_range(text: &str) -> anyhow::Result<AllowedRange> {
    let Some((lo, hi)) = text.split_once(':') else {
        return match text.parse::<RangeKind>() {
            Ok(kind @ (RangeKind::FromAbove | RangeKind::Graspable)) => Ok(kind.allowed(0.0, 0.0)?),
            _ => bail!("--range {text:?}: expected from_above, graspable or LO:HI"),
        };
    };
    let lo: f64 = lo.trim().parse().context("--range lower bound")?;
    let hi: f64 = hi.trim().parse().context("--range upper bound")?;
    bounds(lo, hi)
        .map_err(|_| anyhow::anyhow!("--range {text:?}: bounds must be finite with LO < HI"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse() {
        assert_eq!(parse_range("graspable").ok(), Some(AllowedRange::Graspable));
        assert_eq!(
            parse_range("-1.5:0.5").ok(),
            Some(AllowedRange::Bounds { lo: -1.5, hi: 0.5 })
        );
        assert!(parse_range("1:0").is_err());
        assert!(parse_range("sideways").is_err());
        assert!(parse_range("bounds").is_err());
    }
}
