//! `lookup(target, source, time)`: the walk up the tree from both frames to their common
//! ancestor, as tf2's `BufferCore::walkToTopParent` and `getLatestCommonTime`.
//!
//! Each frame's sample gives its pose in its parent, `T_parent_frame` (a point `p` in the frame
//! is `R p + t` in the parent). Walking up from the source composes
//! `T_a_source = T_a_b · T_b_c · … · T_x_source` for every ancestor `a` passed; walking up from
//! the target likewise gives `T_a_target`. At the first ancestor `a` of the target that the
//! source's walk passed, `T_target_source = T_a_target⁻¹ · T_a_source`: what turns a point given
//! in the source frame into the target frame (tf2's `lookupTransform(target, source)`).

use super::error::{Argument, TfError};
use super::TfBuffer;
use nalgebra::{Isometry3, Translation3};
use std::collections::HashMap;

/// tf2's `MAX_GRAPH_DEPTH`: a walk up longer than this is a loop of parents.
pub(crate) const MAX_GRAPH_DEPTH: usize = 1000;

impl TfBuffer {
    /// The index of `name` as a lookup argument, or tf2's error for it.
    fn argument(&self, name: &str, arg: Argument) -> Result<u32, TfError> {
        if name.is_empty() {
            return Err(TfError::Empty(arg));
        }
        if name.starts_with('/') {
            return Err(TfError::Slash(arg, name.to_string()));
        }
        self.ids
            .get(name)
            .copied()
            .ok_or_else(|| TfError::Unknown(arg, name.to_string()))
    }

    fn name(&self, id: u32) -> String {
        self.frames
            .get(id as usize)
            .map_or_else(String::new, |f| f.name.to_string())
    }

    /// The parent of `frame` at its latest sample and that sample's stamp (0 if static), or
    /// `None` at a root.
    fn latest_link(&self, frame: u32) -> Option<(i64, u32)> {
        let cache = self.frames.get(frame as usize)?.cache.as_ref()?;
        Some(cache.latest())
    }

    /// The latest time at which every transform between `source` and `target` is known: the
    /// least latest stamp on the way up from each to their common ancestor, statics left out;
    /// 0 when every one is static (tf2's `getLatestCommonTime`).
    fn latest_common_time(&self, target: u32, source: u32) -> Result<i64, TfError> {
        // The source's chain: each frame passed and the least stamp up to its link.
        let mut up: HashMap<u32, i64> = HashMap::new();
        let mut frame = source;
        let mut least = i64::MAX;
        up.insert(frame, least);
        for _ in 0..=MAX_GRAPH_DEPTH {
            let Some((stamp, parent)) = self.latest_link(frame) else {
                break;
            };
            if stamp != 0 {
                least = least.min(stamp);
            }
            frame = parent;
            if up.insert(frame, least).is_some() {
                return Err(TfError::Loop);
            }
            if up.len() > MAX_GRAPH_DEPTH + 1 {
                return Err(TfError::Loop);
            }
        }
        let mut frame = target;
        let mut least_target = i64::MAX;
        for _ in 0..=MAX_GRAPH_DEPTH + 1 {
            if let Some(&least_source) = up.get(&frame) {
                let t = least_source.min(least_target);
                return Ok(if t == i64::MAX { 0 } else { t });
            }
            let Some((stamp, parent)) = self.latest_link(frame) else {
                return Err(self.not_connected(target, source));
            };
            if stamp != 0 {
                least_target = least_target.min(stamp);
            }
            frame = parent;
        }
        Err(TfError::Loop)
    }

    fn not_connected(&self, target: u32, source: u32) -> TfError {
        TfError::NotConnected {
            source: self.name(source),
            target: self.name(target),
        }
    }

    /// The transform from `source` to `target` at `time` (ns since the epoch; 0: the latest
    /// time common to the chain): `T_target_source`, which maps a point given in `source` into
    /// `target`. Errors as tf2's.
    pub(crate) fn lookup(
        &self,
        target: &str,
        source: &str,
        time: i64,
    ) -> Result<Isometry3<f64>, TfError> {
        let target_id = self.argument(target, Argument::Target)?;
        let source_id = self.argument(source, Argument::Source)?;
        if target_id == source_id {
            return Ok(Isometry3::identity());
        }
        let time = if time == 0 {
            self.latest_common_time(target_id, source_id)?
        } else {
            time
        };
        // Up from the source: T_a_source for each ancestor a reached; the first failure to find
        // a sample is kept, since the target's walk may still meet the source's below it.
        let mut from_source: HashMap<u32, Isometry3<f64>> = HashMap::new();
        let mut frame = source_id;
        let mut pose = Isometry3::identity();
        from_source.insert(frame, pose);
        let mut source_gap = None;
        while let Some(cache) = self
            .frames
            .get(frame as usize)
            .and_then(|f| f.cache.as_ref())
        {
            match cache.at(time) {
                Ok(sample) => {
                    pose = isometry(&sample) * pose;
                    frame = sample.parent;
                    if from_source.insert(frame, pose).is_some()
                        || from_source.len() > MAX_GRAPH_DEPTH + 1
                    {
                        return Err(TfError::Loop);
                    }
                }
                Err(why) => {
                    source_gap = Some(why);
                    break;
                }
            }
        }
        // Up from the target until the source's walk is met.
        let mut frame = target_id;
        let mut pose = Isometry3::identity();
        for _ in 0..=MAX_GRAPH_DEPTH + 1 {
            if let Some(from) = from_source.get(&frame) {
                return Ok(pose.inverse() * from);
            }
            let Some(cache) = self
                .frames
                .get(frame as usize)
                .and_then(|f| f.cache.as_ref())
            else {
                return Err(match source_gap {
                    Some(why) => self.extrapolation(why, target_id, source_id),
                    None => self.not_connected(target_id, source_id),
                });
            };
            let sample = cache
                .at(time)
                .map_err(|why| self.extrapolation(why, target_id, source_id))?;
            pose = isometry(&sample) * pose;
            frame = sample.parent;
        }
        Err(TfError::Loop)
    }

    fn extrapolation(&self, why: super::error::Extrapolation, target: u32, source: u32) -> TfError {
        TfError::Extrapolation {
            why,
            source: self.name(source),
            target: self.name(target),
        }
    }
}

/// A sample as `T_parent_frame`.
fn isometry(sample: &super::cache::Sample) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(sample.translation), sample.rotation)
}
