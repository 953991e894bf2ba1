//! The command line: one `run` per subcommand.

pub mod plot;
pub mod recover;
pub mod replay;
pub mod solve;

use crate::config::Config;
use crate::solver::{AllowedRange, Objective, Settings};
use anyhow::{bail, Context};
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
}

impl SolveOptions {
    /// The config file with these overrides applied, validated.
    pub fn settings(&self) -> anyhow::Result<Settings> {
        let mut config = Config::load(self.config.as_deref(), "grasp_orient")?;
        if let Some(o) = &self.objective {
            if Objective::from_name(o).is_none() {
                bail!("--objective {o:?} is not one of norm2, norm1, internal_force");
            }
            config.objective = o.clone();
        }
        if let Some(s) = self.friction_safety_factor {
            config.friction_safety_factor = s;
        }
        let mut settings = config.validate()?;
        if let Some(r) = &self.range {
            settings.range = parse_range(r)?;
        }
        Ok(settings)
    }
}

fn parse_range(text: &str) -> anyhow::Result<AllowedRange> {
    Ok(match text {
        "from_above" => AllowedRange::FromAbove,
        "graspable" => AllowedRange::Graspable,
        bounds => {
            let (lo, hi) = bounds.split_once(':').with_context(|| {
                format!("--range {text:?}: expected from_above, graspable or LO:HI")
            })?;
            let lo: f64 = lo.trim().parse().context("--range lower bound")?;
            let hi: f64 = hi.trim().parse().context("--range upper bound")?;
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                bail!("--range {text:?}: bounds must be finite with LO < HI");
            }
            AllowedRange::Bounds { lo, hi }
        }
    })
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
    }
}
