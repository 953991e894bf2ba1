//! A TF buffer: the transforms of `/tf` and `/tf_static`, and lookups between any two frames at
//! a time, as tf2's `BufferCore` (geometry2, Jazzy) gives them.
//!
//! Frames form a tree: each frame has one parent at a time (the parent of its transform at
//! that time, as in tf2, so a frame can be moved under another parent). A static transform
//! (from `/tf_static`) holds at every time and is kept until another replaces it; dynamic ones
//! (from `/tf`) are kept per frame, sorted by time, for [`CACHE_TIME`] behind the frame's latest
//! (tf2's default, 10 s). A lookup at time 0 uses the latest time every transform on the way has
//! (tf2's `lookupTransform` with `TimePoint()`); between two samples, the translation is
//! interpolated linearly and the rotation by slerp, and no time outside a frame's samples is
//! extrapolated.
//!
//! The transforms come from any peer on the network, so the buffer bounds what it keeps:
//! [`MAX_FRAMES`] frames, [`MAX_FRAME_NAME_BYTES`] per name, [`MAX_SAMPLES_PER_FRAME`] samples
//! per frame (the oldest go first) and [`MAX_SAMPLES`] in all (about 20 MB); what does not fit is
//! dropped and counted in [`Dropped`]. A transform tf2 ignores (a frame its own parent, an empty
//! frame, a non-finite value, a quaternion whose squared norm is not within 0.01 of 1), or one
//! further than the solver's `MAX_COORDINATE` (1e6 m) from its parent, is dropped and counted
//! too; a loop of parents makes the lookups through it fail, not hang.

mod apply;
mod cache;
mod error;
mod lookup;
mod request;
#[cfg(test)]
mod tests;
mod tool;

pub(crate) use apply::{gravity_in, pose_in, TfFailure};
pub(crate) use error::TfError;
pub(crate) use request::{needs, resolve, Gravity};
pub(crate) use tool::{tool_frame, ToolFrame};

use crate::msg::{TfMessage, Time, TransformStamped};
use crate::solver::MAX_COORDINATE;
use cache::{Cache, Inserted, Sample};
use compact_str::CompactString;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::collections::{HashMap, VecDeque};

/// How long dynamic transforms are kept behind a frame's latest, ns (tf2's
/// `BUFFER_CORE_DEFAULT_CACHE_TIME`, 10 s).
pub(crate) const CACHE_TIME: i64 = 10_000_000_000;
/// The most frames the buffer knows (parents included); a transform naming one more is dropped.
pub(crate) const MAX_FRAMES: usize = 10_000;
/// The longest frame name kept, bytes; a transform naming a longer one is dropped.
pub(crate) const MAX_FRAME_NAME_BYTES: usize = 256;
/// The most dynamic samples one frame keeps (10 s at 1 kHz); past it, its oldest go.
pub(crate) const MAX_SAMPLES_PER_FRAME: usize = 10_000;
/// The most samples the buffer keeps in all, about 72 bytes each; past it, a frame makes room
/// from its own oldest (its only one for a newer), and a frame with none gets no new one.
pub(crate) const MAX_SAMPLES: usize = 1 << 18;
/// tf2's `QUATERNION_NORMALIZATION_TOLERANCE`: a rotation whose squared norm is further than
/// this from 1 is not a rotation, and the transform is dropped.
const QUATERNION_TOLERANCE: f64 = 10e-3;

/// Counts of the transforms the buffer did not keep, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Dropped {
    /// Empty frame or child frame, a frame its own parent, or a name over
    /// [`MAX_FRAME_NAME_BYTES`].
    pub(crate) bad_frame: u64,
    /// A NaN or infinite value, a translation beyond `MAX_COORDINATE`, or a quaternion not of
    /// unit length.
    pub(crate) bad_value: u64,
    /// Older than [`CACHE_TIME`] behind its frame's latest.
    pub(crate) too_old: u64,
    /// Over [`MAX_FRAMES`] or [`MAX_SAMPLES`].
    pub(crate) over_cap: u64,
}

impl Dropped {
    /// All of them.
    pub(crate) fn total(&self) -> u64 {
        self.bad_frame + self.bad_value + self.too_old + self.over_cap
    }
}

/// One frame: its name and, unless it is only ever a parent, its transforms to its parent.
#[derive(Debug, Clone)]
struct Frame {
    name: CompactString,
    cache: Option<Cache>,
}

/// The transforms received, and lookups between frames.
#[derive(Debug, Clone, Default)]
pub(crate) struct TfBuffer {
    frames: Vec<Frame>,
    ids: HashMap<CompactString, u32>,
    samples: usize,
    dropped: Dropped,
}

/// A wire time in ns since the epoch (tf2_ros's `fromMsg`: seconds plus nanoseconds).
pub(crate) fn nanoseconds(t: &Time) -> i64 {
    i64::from(t.sec) * 1_000_000_000 + i64::from(t.nanosec)
}

/// A frame name as tf2 stores it: without one leading `/` (tf2's `stripSlash`).
fn strip_slash(name: &str) -> &str {
    name.strip_prefix('/').unwrap_or(name)
}

impl TfBuffer {
    /// An empty buffer.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Keeps the transforms of one message of `/tf` (`is_static` false) or `/tf_static`.
    pub(crate) fn insert_message(&mut self, message: &TfMessage, is_static: bool) {
        for t in &message.transforms {
            self.insert(t, is_static);
        }
    }

    /// Keeps one transform, or counts why not.
    pub(crate) fn insert(&mut self, t: &TransformStamped, is_static: bool) {
        let parent = strip_slash(&t.header.frame_id);
        let child = strip_slash(&t.child_frame_id);
        if parent.is_empty()
            || child.is_empty()
            || parent == child
            || parent.len() > MAX_FRAME_NAME_BYTES
            || child.len() > MAX_FRAME_NAME_BYTES
        {
            self.dropped.bad_frame += 1;
            return;
        }
        let Some((translation, rotation)) = checked_transform(t) else {
            self.dropped.bad_value += 1;
            return;
        };
        let new_frames = usize::from(!self.ids.contains_key(parent))
            + usize::from(!self.ids.contains_key(child));
        // A frame new to the buffer needs a sample of room: without it, refused before its
        // name is kept.
        let room = self.samples < MAX_SAMPLES || self.ids.contains_key(child);
        if self.frames.len() + new_frames > MAX_FRAMES || !room {
            self.dropped.over_cap += 1;
            return;
        }
        let parent = self.id_or_insert(parent);
        let child = self.id_or_insert(child);
        let stamp = if is_static {
            0
        } else {
            nanoseconds(&t.header.stamp)
        };
        let sample = Sample {
            stamp,
            parent,
            translation,
            rotation,
        };
        self.keep(child, sample, is_static);
    }

    /// Puts `sample` into frame `child`'s cache, within the caps.
    fn keep(&mut self, child: u32, sample: Sample, is_static: bool) {
        let Some(frame) = self.frames.get_mut(child as usize) else {
            return;
        };
        let before = frame.cache.as_ref().map_or(0, Cache::len);
        match &mut frame.cache {
            // A static transform replaces whatever the frame had, as in tf2.
            slot if is_static => {
                if slot.is_none() && self.samples >= MAX_SAMPLES {
                    self.dropped.over_cap += 1;
                    return;
                }
                *slot = Some(Cache::Static(sample));
            }
            Some(cache @ Cache::Dynamic(_)) => match cache.plan(sample.stamp, CACHE_TIME) {
                Inserted::TooOld => {
                    self.dropped.too_old += 1;
                    return;
                }
                Inserted::Added
                    if (cache.len() >= MAX_SAMPLES_PER_FRAME || self.samples >= MAX_SAMPLES)
                        && !cache.make_room(sample.stamp) =>
                {
                    self.dropped.over_cap += 1;
                    return;
                }
                _ => {
                    cache.insert(sample, CACHE_TIME);
                }
            },
            // A dynamic transform replaces a static one, as in tf2: same count.
            Some(cache) => *cache = Cache::Dynamic(VecDeque::from([sample])),
            slot => {
                if self.samples >= MAX_SAMPLES {
                    self.dropped.over_cap += 1;
                    return;
                }
                *slot = Some(Cache::Dynamic(VecDeque::from([sample])));
            }
        }
        let after = frame.cache.as_ref().map_or(0, Cache::len);
        // Pruning can leave fewer than before.
        self.samples = (self.samples + after).saturating_sub(before);
    }

    fn id_or_insert(&mut self, name: &str) -> u32 {
        if let Some(&id) = self.ids.get(name) {
            return id;
        }
        // Below MAX_FRAMES, checked by the caller, so the index fits.
        let id = self.frames.len() as u32;
        let name = CompactString::from(name);
        self.frames.push(Frame {
            name: name.clone(),
            cache: None,
        });
        self.ids.insert(name, id);
        id
    }

    /// How many frames the buffer knows.
    pub(crate) fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// How many samples it keeps.
    pub(crate) fn sample_count(&self) -> usize {
        self.samples
    }

    /// What it did not keep.
    pub(crate) fn dropped(&self) -> Dropped {
        self.dropped
    }
}

/// The translation and rotation of a transform tf2 would keep: finite (and here within
/// [`MAX_COORDINATE`] m of the parent's origin), the quaternion of unit
/// squared norm within [`QUATERNION_TOLERANCE`] (normalised here, so that every composition
/// stays a rotation).
fn checked_transform(t: &TransformStamped) -> Option<(Vector3<f64>, UnitQuaternion<f64>)> {
    let v = &t.transform.translation;
    let q = &t.transform.rotation;
    let translation = Vector3::new(v.x, v.y, v.z);
    let quaternion = Quaternion::new(q.w, q.x, q.y, q.z);
    // Further than any candidate may lie (the solver's MAX_COORDINATE): no answer could use
    // it, and the bound keeps every composition of up to MAX_GRAPH_DEPTH of them finite.
    if !translation.iter().all(|c| c.abs() <= MAX_COORDINATE)
        || !quaternion.coords.iter().all(|c| c.is_finite())
    {
        return None;
    }
    if (quaternion.norm_squared() - 1.0).abs() >= QUATERNION_TOLERANCE {
        return None;
    }
    Some((translation, UnitQuaternion::from_quaternion(quaternion)))
}
