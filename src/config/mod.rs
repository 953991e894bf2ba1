//! The settings: every parameter declared once (in `params.rs`, listed by `PARAMETERS`), read
//! from ROS 2 params files (`grasp_orient: ros__parameters:`) and `-p name:=value`, and checked
//! once (`Config::solver_settings`). `config/grasp_orient.yaml` is generated from the
//! declarations and compiled in as the default.

pub(crate) mod choices;
pub(crate) mod declare;
pub(crate) mod error;
pub(crate) mod objects;
mod params;
pub(crate) mod render;

pub use choices::RangeKind;
pub(crate) use choices::{bounds, InvalidBounds};
pub(crate) use declare::{Domain, Parameter, RosType};
pub use error::ConfigError;
pub(crate) use error::ValueError;
pub use params::Config;
pub(crate) use params::PARAMETERS;

use crate::answer::{Answering, PoseAnswerer, Rules};
use crate::solver::Settings;
use std::path::Path;

/// Largest settings file read, bytes: far above any params file, far below a device that never
/// ends (`--config /dev/zero`).
pub(crate) const MAX_FILE_BYTES: u64 = 16 << 20;

/// The text of a file of at most `max` bytes (any kind of file: a pipe, `/dev/stdin`); longer is
/// an error, not a read that never ends.
pub(crate) fn read_text(path: &Path, max: u64) -> std::io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    std::fs::File::open(path)?
        .take(max + 1)
        .read_to_string(&mut text)?;
    if text.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("longer than {max} bytes"),
        ));
    }
    Ok(text)
}

/// The params file shipped with the package, compiled in.
pub(crate) const DEFAULT_YAML: &str = include_str!("../../config/grasp_orient.yaml");

/// The top-level sections of a params file: which there are, and which applied to the node.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Sections {
    /// Every top-level key, in file order.
    pub(crate) found: Vec<String>,
    /// The keys whose `ros__parameters` were applied (`/**`, `**`, the node's name, `/name`).
    pub(crate) applied: Vec<String>,
}

/// The parameters the params file `path` sets for `node` (under `/**`, `**`, `node` or `/node`), in
/// file order, as names and YAML values (not checked against the table), for a file
/// that is all settings (`--config`): it is read up to [`MAX_FILE_BYTES`], and a file with no
/// section for the node is an error ([`ConfigError::NoSection`]) rather than nothing to apply.
pub(crate) fn params_in_file(
    path: &Path,
    node: &str,
) -> Result<Vec<(String, serde_yaml_ng::Value)>, ConfigError> {
    let origin = path.display().to_string();
    let text = read_text(path, MAX_FILE_BYTES).map_err(|source| ConfigError::Read {
        path: origin.clone(),
        source,
    })?;
    let (sections, params) = read_sections(&text, &origin, node)?;
    if sections.applied.is_empty() {
        return Err(ConfigError::NoSection {
            origin,
            node: node.to_string(),
            found: sections.found,
        });
    }
    Ok(params)
}

/// The sections of a params file and the parameters it sets for `node`, as [`params_in_file`].
fn read_sections(
    text: &str,
    origin: &str,
    node: &str,
) -> Result<(Sections, Vec<(String, serde_yaml_ng::Value)>), ConfigError> {
    let doc: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(text).map_err(|source| ConfigError::Yaml {
            origin: origin.to_string(),
            source,
        })?;
    let mut sections = Sections::default();
    let mut out = Vec::new();
    let Some(map) = doc.as_mapping() else {
        return Ok((sections, out));
    };
    sections.found = map
        .keys()
        .map(|k| match k.as_str() {
            Some(s) => s.to_string(),
            None => serde_yaml_ng::to_string(k)
                .map_or_else(|_| "?".to_string(), |s| s.trim_end().to_string()),
        })
        .collect();
    for key in ["/**", "**", node, &format!("/{node}")] {
        if let Some(params) = map
            .get(key)
            .and_then(|v| v.get("ros__parameters"))
            .and_then(|v| v.as_mapping())
        {
            sections.applied.push(key.to_string());
            for (name, value) in params {
                let name = name.as_str().unwrap_or_default().to_string();
                out.push((name, value.clone()));
            }
        }
    }
    Ok((sections, out))
}

impl Parameter {
    /// The declaration of `name`.
    pub(crate) fn find(name: &str) -> Option<&'static Parameter> {
        PARAMETERS.iter().find(|p| p.name == name)
    }
}

impl Config {
    /// Reads a params file: the `ros__parameters` of `node` (or of `/**`) are applied over `self`.
    /// Like rcl, sections for other nodes are left alone; what applied is returned, for the
    /// callers that must not ignore a file with nothing for them ([`Config::load`]).
    pub(crate) fn merge_yaml(
        &mut self,
        text: &str,
        origin: &str,
        node: &str,
    ) -> Result<Sections, ConfigError> {
        let (sections, params) = read_sections(text, origin, node)?;
        for (name, value) in params {
            self.set_value(&name, value)
                .map_err(|e| ConfigError::InFile {
                    origin: origin.to_string(),
                    source: Box::new(e),
                })?;
        }
        Ok(sections)
    }

    /// Sets one parameter from its YAML text (as in `-p name:=value`), checking its type only.
    pub(crate) fn set_from_yaml(&mut self, name: &str, value: &str) -> Result<(), ConfigError> {
        let parsed: serde_yaml_ng::Value =
            serde_yaml_ng::from_str(value).map_err(|source| ConfigError::Yaml {
                origin: format!("parameter {name}"),
                source,
            })?;
        self.set_value(name, parsed)
    }

    /// The compiled-in defaults, then `file` if given (see [`params_in_file`]), checked.
    pub(crate) fn load(file: Option<&Path>, node: &str) -> Result<Self, ConfigError> {
        let mut config = Config::default();
        config.merge_yaml(DEFAULT_YAML, "built-in config/grasp_orient.yaml", node)?;
        if let Some(path) = file {
            for (name, value) in params_in_file(path, node)? {
                config
                    .set_value(&name, value)
                    .map_err(|e| ConfigError::InFile {
                        origin: path.display().to_string(),
                        source: Box::new(e),
                    })?;
            }
        }
        config.solver_settings()?;
        Ok(config)
    }

    /// Checks every value against its declared domain, and the range bounds against each other;
    /// the solver settings they give.
    pub(crate) fn solver_settings(&self) -> Result<Settings, ConfigError> {
        self.check_domains()?;
        let range = self.range.allowed(self.range_min, self.range_max).map_err(
            |InvalidBounds { lo, hi }| ConfigError::Value {
                name: "range_min",
                why: ValueError::Bounds { lo, hi },
            },
        )?;
        Ok(Settings {
            objective: self.objective,
            range,
            friction_safety_factor: self.friction_safety_factor,
        })
    }

    /// What these settings refuse though each of them is valid, one line each, to log when they
    /// are set: objective norm1 with a centre-of-mass box refuses every spatial candidate
    /// (`docs/uncertainty.md`), while planar candidates are answered.
    pub(crate) fn caveats(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.objective == crate::solver::Objective::Norm1
            && self.center_of_mass_tolerance != [0.0; 3]
        {
            out.push(
                "objective norm1 with center_of_mass_tolerance not zero: every spatial candidate \
                 will be refused (status 2), planar ones are answered \
                 (docs/uncertainty.md#spatial-candidates)"
                    .to_string(),
            );
        }
        out
    }

    /// The answering object of these parameters (their solver settings checked here), pose
    /// candidates by `poses`, their inline meshes bounded by `max_inline_mesh_triangles`.
    pub fn answering(&self, poses: PoseAnswerer) -> Result<Answering, ConfigError> {
        let poses = poses.bounding_inline(self.max_inline_mesh_triangles);
        Ok(Answering::new(self.solver_settings()?, self.rules(), poses))
    }

    /// The gripper and set rules: `gripper_drive`, `max_grip_force`, `rank_by`, `max_set_size`,
    /// and the default tolerances `center_of_mass_tolerance`, `mass_tolerance` (their domains are checked by [`Config::solver_settings`]).
    pub(crate) fn rules(&self) -> Rules {
        Rules {
            drive: self.gripper_drive,
            max_grip_force: self.max_grip_force,
            rank_by: self.rank_by,
            max_set_size: usize::try_from(self.max_set_size).unwrap_or(1),
            tolerances: crate::answer::DefaultTolerances {
                center_of_mass: self.center_of_mass_tolerance,
                mass: self.mass_tolerance,
            },
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
    fn a_config_file_without_a_section_for_us_is_an_error() {
        let dir = tempfile::Builder::new()
            .prefix("grasp_orient_cfg_")
            .tempdir()
            .expect("a temporary folder");
        let path = dir.path().join("other.yaml");
        std::fs::write(
            &path,
            "other_node:\n  ros__parameters:\n    objective: norm1\n",
        )
        .expect("write");
        let e = Config::load(Some(&path), "grasp_orient").expect_err("no section for us");
        let text = e.to_string();
        assert!(
            text.contains("no section for node grasp_orient") && text.contains("found: other_node"),
            "{text}"
        );
        std::fs::write(&path, "").expect("write");
        let e = Config::load(Some(&path), "grasp_orient").expect_err("empty");
        assert!(e.to_string().contains("found: none"), "{e}");
        std::fs::write(&path, "/**:\n  ros__parameters:\n    objective: norm1\n").expect("write");
        let c = Config::load(Some(&path), "grasp_orient").expect("a wildcard applies");
        assert_eq!(c.objective, Objective::Norm1);
        // rcl's rule for --params-file: other nodes' sections are left alone.
        let mut c = Config::default();
        let s = c
            .merge_yaml("a:\n  ros__parameters: {}\nb: 1\n", "t", "grasp_orient")
            .expect("valid");
        assert_eq!(s.found, ["a", "b"]);
        assert!(s.applied.is_empty());
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
            "parameter friction_safety_factor: must be in [1, 1000], got 0.5"
        );
        // Every double has a domain, checked whatever the other settings: NaN bounds are
        // refused while range is not bounds too.
        for name in ["range_min", "range_max", "friction_safety_factor"] {
            for bad in [".nan", ".inf", "-.inf"] {
                let mut c = Config::default();
                c.set_from_yaml(name, bad).expect("a double");
                let e = c.solver_settings().expect_err(bad);
                assert!(e.to_string().contains(name), "{e}");
            }
        }
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

    /// The TF parameters' domains: gravity's components within ±5000 m/s² (so that in any frame
    /// each is within the solver's 1e4), tf_timeout within [0, 10] s.
    #[test]
    fn tf_parameters_are_checked() {
        let c = Config::default();
        assert_eq!(
            (c.gravity_frame.as_str(), c.gravity, c.tf_timeout),
            ("", [0.0, 0.0, -9.80665], 0.1)
        );
        for (name, value, message) in [
            (
                "gravity",
                "[0.0, 5000.5, 0.0]",
                "parameter gravity: y: must be in [-5000, 5000], got 5000.5",
            ),
            (
                "tf_timeout",
                "-0.1",
                "parameter tf_timeout: must be in [0, 10], got -0.1",
            ),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, value).expect("the type is right");
            let e = c.solver_settings().expect_err(value);
            assert_eq!(e.to_string(), message);
        }
        let mut c = Config::default();
        c.set_from_yaml("gravity_frame", "world").expect("a string");
        c.set_from_yaml("gravity", "[-5000, 0, 9.8]")
            .expect("doubles");
        c.solver_settings().expect("in the domains");
        assert_eq!(
            (c.gravity_frame.as_str(), c.gravity),
            ("world", [-5000.0, 0.0, 9.8])
        );
    }

    /// A tolerance every candidate would be refused for is refused when set: the domains end
    /// where the solver's limits do (a box half-width below 1e6 m, a mass tolerance below the
    /// largest mass a candidate may have).
    #[test]
    fn tolerances_that_refuse_every_candidate_are_refused_when_set() {
        for (name, value, message) in [
            (
                "center_of_mass_tolerance",
                "[1e6, 0.0, 0.0]",
                "parameter center_of_mass_tolerance: x: must be in [0, 1e6), got 1e6",
            ),
            (
                "mass_tolerance",
                "1e9",
                "parameter mass_tolerance: must be in [0, 1e9), got 1e9",
            ),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, value).expect("the type is right");
            let e = c.solver_settings().expect_err(value);
            assert_eq!(e.to_string(), message);
        }
        // Just below the limits, a candidate is not refused for the tolerance the node gave it.
        use crate::answer::{answer_one, DefaultTolerances, Rules};
        use crate::msg::GripRecommendation;
        let largest = Config {
            center_of_mass_tolerance: [crate::solver::MAX_COORDINATE.next_down(), 0.0, 0.0],
            mass_tolerance: params::MAX_MASS.next_down(),
            ..Config::default()
        };
        let settings = largest.solver_settings().expect("in the domains");
        let mut heaviest = crate::msg::paper_cases().swap_remove(2);
        heaviest.mass = params::MAX_MASS;
        for rules in [
            Rules {
                tolerances: DefaultTolerances {
                    center_of_mass: [0.0; 3],
                    ..largest.rules().tolerances
                },
                ..largest.rules()
            },
            largest.rules(),
        ] {
            let a = answer_one(&heaviest, &settings, &rules);
            assert!(
                !a.message.contains("tolerance"),
                "refused for a tolerance in the domain: {}",
                a.message
            );
        }
        // params::MAX_MASS is the solver's: a candidate just heavier is refused for its mass.
        heaviest.mass = params::MAX_MASS.next_up();
        let a = answer_one(&heaviest, &settings, &Rules::default());
        assert_eq!(a.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert!(a.message.contains("mass"), "{}", a.message);
    }

    #[test]
    fn norm1_with_a_box_is_a_caveat() {
        let mut c = Config::default();
        c.set_from_yaml("objective", "norm1").expect("a name");
        assert!(c.caveats().is_empty());
        c.set_from_yaml("center_of_mass_tolerance", "[0.0, 0.01, 0.0]")
            .expect("three numbers");
        c.solver_settings()
            .expect("valid: planar candidates take it");
        let caveats = c.caveats();
        assert_eq!(caveats.len(), 1);
        assert!(caveats[0].contains("every spatial candidate will be refused"));
        c.set_from_yaml("objective", "norm2").expect("a name");
        assert!(c.caveats().is_empty());
    }

    #[test]
    fn gripper_and_set_parameters_are_checked_and_give_the_rules() {
        use crate::answer::{GripperDrive, RankBy, Rules};
        let c = Config::default();
        assert_eq!(c.rules(), Rules::default());
        let mut c = Config::default();
        c.set_from_yaml("gripper_drive", "independent")
            .expect("a drive");
        c.set_from_yaml("max_grip_force", "40.0").expect("a number");
        c.set_from_yaml("rank_by", "objective").expect("a name");
        c.set_from_yaml("max_set_size", "7").expect("an integer");
        c.set_from_yaml("center_of_mass_tolerance", "[0.01, 0.02, 0]")
            .expect("three numbers");
        c.set_from_yaml("mass_tolerance", "0.1").expect("a number");
        c.solver_settings().expect("valid");
        assert_eq!(
            c.rules(),
            Rules {
                drive: GripperDrive::Independent,
                max_grip_force: 40.0,
                rank_by: RankBy::Objective,
                max_set_size: 7,
                tolerances: crate::answer::DefaultTolerances {
                    center_of_mass: [0.01, 0.02, 0.0],
                    mass: 0.1,
                },
            }
        );
        assert!(c.set_from_yaml("gripper_drive", "hydraulic").is_err());
        for (name, bad) in [
            ("max_grip_force", "-1.0"),
            ("max_grip_force", ".nan"),
            ("max_set_size", "0"),
            ("max_set_time", "-1.0"),
            ("max_set_time", ".inf"),
            ("max_set_time", "1e6"),
            ("max_queued_sets", "-1"),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, bad).expect("the type is right");
            let e = c.solver_settings().expect_err("out of the domain");
            assert!(e.to_string().contains(name), "{e}");
        }
    }
}
