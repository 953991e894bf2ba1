//! What each recorded request is answered with in a replay ([`Plan`]): the settings records of
//! the bag, or the built-in config, with command-line overrides.

use crate::answer::{Answering, PoseAnswerer, Rules};
use crate::config::{Config, ConfigError};
use crate::msg::GripRecommendation;
use crate::record::bag::Bag;
use crate::record::settings::{SettingsError, SettingsRecord, METADATA_NAME};
use crate::solver::{Objective, Settings};
use grasp_orient_geometry::ClosingAxis;
use serde_yaml_ng::Value;

/// Why a recording cannot be replayed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    /// A settings record of the bag does not read.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The settings with the command line's overrides are refused.
    #[error("the recorded settings with the command line's overrides: {0}")]
    Overrides(ConfigError),
    /// A thread solving a share of the candidates failed.
    #[error("a replay worker failed: {0}")]
    Worker(String),
    /// A mesh a recorded pose was answered with cannot be read here.
    #[error(
        "mesh {resource} of a recorded pose cannot be read at replay time (package:// resolves \
         through AMENT_PREFIX_PATH): {why}"
    )]
    Mesh {
        /// The resource named in the recording.
        resource: String,
        /// Why it cannot be read.
        why: Box<grasp_orient_geometry::GeometryError>,
    },
}

/// A parameter set on the command line: its name and value.
pub(crate) type Override = (String, Value);

/// The settings each candidate of a recording is solved with.
///
/// A recording that carries settings records ([`crate::record::settings`]) is replayed with the
/// settings in force at each candidate's `log_time`; one without (made before they existed, or
/// by another writer) with the built-in config and the objective each recorded answer names.
/// Command-line overrides apply over both.
#[derive(Debug, Clone)]
pub struct Plan {
    /// From which `log_time` on each applies, in time order: settings, gripper rules, the
    /// closing axis of pose candidates and their inline meshes' bound, one mesh cache shared by
    /// all.
    timeline: Vec<(u64, Answering)>,
    /// For a recording without settings records.
    fallback: Answering,
    /// Whether each candidate is solved with the objective its recorded answer names.
    pub(crate) objective_from_answer: bool,
    /// The bag's settings records, overrides applied.
    pub recorded: Vec<SettingsRecord>,
    /// The parameters the command line set.
    pub overridden: Vec<String>,
}

impl Plan {
    /// The settings for the candidates of `bag`: its recorded settings, or else `base`; with
    /// `overrides` applied over either.
    pub(crate) fn for_bag(
        bag: &Bag,
        base: &Config,
        overrides: &[Override],
    ) -> Result<Self, ReplayError> {
        let apply = |config: &Config| -> Result<(Config, Settings), ReplayError> {
            let mut config = config.clone();
            for (name, value) in overrides {
                config
                    .set_value(name, value.clone())
                    .map_err(ReplayError::Overrides)?;
            }
            let settings = config.solver_settings().map_err(ReplayError::Overrides)?;
            Ok((config, settings))
        };
        let (base, base_settings) = apply(base)?;
        let meshes = pose_meshes();
        let mut recorded = Vec::new();
        for (name, entries) in &bag.metadata {
            if name == METADATA_NAME {
                recorded.push(SettingsRecord::from_metadata(entries)?);
            }
        }
        // In time order; records of one time keep their file order, the last one winning.
        recorded.sort_by_key(|r| r.since);
        // Inline meshes bounded as the node bounded them: a mesh it decoded only up to its
        // bound (`msg::limit_inline_mesh_decoding`) is refused here with the node's words.
        let answering = |config: &Config, settings| {
            let poses = PoseAnswerer::sharing(config.closing_axis, meshes.clone())
                .bounding_inline(config.max_inline_mesh_triangles);
            Answering::new(settings, config.rules(), poses)
        };
        let mut timeline = Vec::with_capacity(recorded.len());
        for record in &mut recorded {
            let (config, settings) = apply(&record.config)?;
            timeline.push((record.since, answering(&config, settings)));
            record.config = config;
        }
        let overridden: Vec<String> = overrides.iter().map(|(n, _)| n.clone()).collect();
        Ok(Self {
            objective_from_answer: timeline.is_empty()
                && !overridden.iter().any(|n| n == "objective"),
            fallback: answering(&base, base_settings),
            timeline,
            recorded,
            overridden,
        })
    }

    /// The same settings for every candidate, whatever the bag holds (for tests and benches).
    pub fn fixed(settings: Settings) -> Self {
        Self::fixed_with(settings, Rules::default())
    }

    /// [`Plan::fixed`] with gripper rules too.
    pub(crate) fn fixed_with(settings: Settings, rules: Rules) -> Self {
        let poses = PoseAnswerer::sharing(ClosingAxis::default(), pose_meshes());
        Self {
            timeline: Vec::new(),
            fallback: Answering::new(settings, rules, poses),
            objective_from_answer: true,
            recorded: Vec::new(),
            overridden: Vec::new(),
        }
    }

    /// Whether the bag carried its settings.
    pub(crate) fn settings_recorded(&self) -> bool {
        !self.timeline.is_empty()
    }

    /// What answers a candidate (or set, pose candidate, pose set) received at `log_time`: the
    /// settings of the last record from before it (the first record's for earlier ones).
    pub(crate) fn answering_at(&self, log_time: u64) -> &Answering {
        match self.index_at(log_time) {
            Some(i) => &self.timeline[i].1,
            None => &self.fallback,
        }
    }

    /// The meshes of the replay's pose candidates (one cache for every settings record).
    pub(crate) fn meshes(&self) -> &grasp_orient_geometry::MeshCache {
        self.fallback.poses().meshes()
    }

    /// The timeline entry in force at `log_time`: the last from before it, the first for earlier
    /// times; `None` without a timeline.
    fn index_at(&self, log_time: u64) -> Option<usize> {
        let after = self
            .timeline
            .partition_point(|(since, _)| *since <= log_time);
        after.checked_sub(1).or(self.timeline.first().map(|_| 0))
    }
}

/// The meshes of a replay's pose candidates: `package://` through this process's
/// `AMENT_PREFIX_PATH`.
pub(super) fn pose_meshes() -> std::sync::Arc<grasp_orient_geometry::MeshCache> {
    std::sync::Arc::new(grasp_orient_geometry::MeshCache::new(
        grasp_orient_geometry::AmentIndex::from_env(),
        crate::answer::MESH_CACHE_BYTES,
    ))
}

/// `settings` with the objective `recorded` names, if any.
pub(super) fn objective_like(
    settings: &Settings,
    recorded: Option<&GripRecommendation>,
) -> Settings {
    let objective = recorded
        .and_then(|r| Objective::from_name(&r.objective))
        .unwrap_or(settings.objective);
    Settings {
        objective,
        ..*settings
    }
}
