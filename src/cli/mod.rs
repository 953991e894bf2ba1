//! The command line: one `run` per subcommand. It lives in the binary, not in the library's API.

pub mod node;
pub mod play;
pub mod plot;
pub mod rank;
pub mod recover;
pub mod replay;
pub mod solve;

use anyhow::{bail, Context};
use grasp_orient::config::{bounds, Config, RangeKind};
use grasp_orient::sets::{GripperDrive, Rules};
use grasp_orient::solver::{AllowedRange, Objective, Settings};
use std::path::PathBuf;

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
    /// The config file with these overrides applied, checked.
    pub fn settings(&self) -> anyhow::Result<Settings> {
        Ok(self.configured()?.1)
    }

    /// The config file with these overrides applied, checked: the config, the solver settings
    /// and the gripper rules.
    pub fn configured(&self) -> anyhow::Result<(Config, Settings, Rules)> {
        let mut config = Config::load(self.config.as_deref(), "grasp_orient")?;
        if let Some(o) = &self.objective {
            config.objective = o
                .parse::<Objective>()
                .map_err(|e| anyhow::anyhow!("--objective {e}"))?;
        }
        if let Some(s) = self.friction_safety_factor {
            config.friction_safety_factor = s;
        }
        if let Some(f) = self.max_grip_force {
            config.max_grip_force = f;
        }
        if let Some(d) = &self.gripper_drive {
            config.gripper_drive = d
                .parse::<GripperDrive>()
                .map_err(|e| anyhow::anyhow!("--gripper-drive {e}"))?;
        }
        let mut settings = config
            .solver_settings()
            .map_err(|e| anyhow::anyhow!("{e} (from --config or the options)"))?;
        if let Some(r) = &self.range {
            settings.range = parse_range(r)?;
        }
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
